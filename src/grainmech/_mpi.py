"""Whether this process is one of several MPI ranks (private; imports nothing heavy).

The command line refuses to be started by ``mpiexec`` and the DEM model runs LAMMPS on the
ranks of ``MPI_COMM_WORLD`` when it is (:mod:`grainmech.lammps.engine`); both ask here.
"""

from __future__ import annotations

import os

__all__ = ["mpi_world_size"]

#: environment variables by which MPI launchers announce the size of the world
_WORLD_SIZE_VARS = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")


def mpi_world_size() -> int:
    """Ranks of the MPI world this process was started in by ``mpiexec`` (1 when it was not)."""
    for k in _WORLD_SIZE_VARS:
        v = os.environ.get(k, "")
        if v.isdigit() and int(v) > 1:
            return int(v)
    return 1

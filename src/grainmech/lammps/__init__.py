"""The one LAMMPS session: start LAMMPS, load a network, ramp, relax, measure.

The only package of grainmech that imports ``lammps`` (extra ``grainmech[dem]``; it is
imported on the first :class:`Lammps`, not with this package). Used by
:mod:`grainmech.packing` (making packings) and the DEM model :mod:`grainmech.driver.dem`.

Modules
-------
* :mod:`~grainmech.lammps.engine` - :class:`Lammps` (start, commands, errors, MPI ranks).
* :mod:`~grainmech.lammps.granular` - :class:`GrainMaterial`, the granular model
  (:func:`setup_lammps`, :func:`critical_time_step`).
* :mod:`~grainmech.lammps.network` - :func:`network_from_lammps`, :func:`unbalanced_ratio`.
* :mod:`~grainmech.lammps.rolling` - rolling and twisting resistance in LAMMPS.
* :mod:`~grainmech.lammps.session` - :func:`load_network`, :func:`ramp`, :func:`relax`.
* :mod:`~grainmech.lammps.probes` - :func:`strain_probes` (the measured tangent tensor).
"""

from __future__ import annotations

from grainmech.lammps.engine import Lammps, cores, lammps_available, mpi_comm, mpi_world_size, require_lammps
from grainmech.lammps.granular import GrainMaterial, critical_time_step, setup_lammps
from grainmech.lammps.network import network_from_lammps, unbalanced_ratio
from grainmech.lammps.probes import ProbeResult, strain_probes
from grainmech.lammps.session import RelaxationTimeout, Session, load_network, ramp, relax

__all__ = ["Lammps", "cores", "lammps_available", "mpi_comm", "mpi_world_size", "require_lammps",
           "GrainMaterial", "critical_time_step", "setup_lammps", "network_from_lammps", "unbalanced_ratio",
           "ProbeResult", "strain_probes", "RelaxationTimeout", "Session", "load_network", "ramp", "relax"]

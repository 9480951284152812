"""One rank of a DEM job started by :func:`grainmech.driver.dem.mpi.run_dem_ranks` (``python -m``).

Reads the inputs ``IN`` (pickle: network, law, path, settings, pressure, rolling, and the
path's saves: the steps after which it is saved and the saved state it goes on from),
runs :func:`grainmech.driver.dem.run.run_dem` (LAMMPS on ``MPI_COMM_WORLD``); rank 0
writes progress lines (JSON) on its standard output, each saved state to
``OUT.step<k>`` (announced by a ``{"saved": [k, file]}`` line), and ``("result",
DemResult)`` or ``("error", message)`` to ``OUT``. An unexpected error aborts every rank.
"""

from __future__ import annotations

import json
import pickle
import sys
import traceback
from pathlib import Path
from typing import Any

from grainmech.driver.dem.run import run_dem
from grainmech.driver.loop import PathCheckpoint
from grainmech.errors import GrainmechError
from grainmech.lammps.engine import mpi_comm


def _main(argv: list[str]) -> int:
    """One rank of a DEM job: run the path, rank 0 reports progress and writes the result."""
    src, out = argv
    net, law, path, settings, pressure, rolling, after, resume = pickle.loads(Path(src).read_bytes())
    comm = mpi_comm()
    rank = 0 if comm is None else int(comm.Get_rank())

    def emit(msg: dict) -> None:
        if rank == 0:
            sys.stdout.write(json.dumps(msg) + "\n")
            sys.stdout.flush()

    def on_step(k: int, n: int) -> None:
        emit({"step": [k, n]})

    def tick(steps: int, ub: float) -> None:
        emit({"tick": [steps, ub if ub == ub else None]})

    def save(k: int, state: dict) -> None:
        if rank == 0:
            f = Path(f"{out}.step{k}")
            f.with_suffix(".part").write_bytes(pickle.dumps(state))
            f.with_suffix(".part").replace(f)
            emit({"saved": [k, str(f)]})

    cp = PathCheckpoint(tuple(after), save, resume) if after or resume is not None else None
    try:
        result: tuple[str, Any] = ("result", run_dem(net, law, path, settings, pressure=pressure,
                                                     on_step=on_step, tick=tick, rolling=rolling, checkpoint=cp))
    except GrainmechError as exc:
        result = ("error", str(exc))
    except BaseException:
        traceback.print_exc()
        if comm is not None:
            comm.Abort(1)
        return 1
    if rank == 0:
        tmp = Path(out).with_suffix(".part")
        tmp.write_bytes(pickle.dumps(result))
        tmp.replace(out)
    return 0


if __name__ == "__main__":  # pragma: no cover - run by mpiexec
    sys.exit(_main(sys.argv[1:]))

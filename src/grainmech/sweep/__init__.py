"""SweepParameter sweeps: many runs of one config kind with some keys varied, on dask.

>>> from grainmech.sweep import load_sweep, run_sweep          # doctest: +SKIP
>>> summary = run_sweep(load_sweep("sweep.toml"), "out")        # doctest: +SKIP

* :mod:`grainmech.sweep.design` -- parameters, grid / Latin-hypercube / Monte-Carlo designs
* :mod:`grainmech.sweep.spec` -- sweep files -> points (resolved configs, stable ids)
* :mod:`grainmech.sweep.kinds` -- run kinds: config -> scalar outputs
* :mod:`grainmech.sweep.runner` -- execution on dask.distributed, persistence, resume, table

See ``docs/sweep.md``. Dask is needed only to run points (extra ``parallel``).
"""

from __future__ import annotations

from grainmech.sweep.design import SweepParameter, grid, latin_hypercube, make_design, monte_carlo
from grainmech.sweep.kinds import SWEEP_KINDS, run_point
from grainmech.sweep.runner import run_sweep
from grainmech.sweep.spec import Point, Sweep, load_sweep, point_id, sweep_from_dict

__all__ = ["SweepParameter", "grid", "latin_hypercube", "monte_carlo", "make_design", "SWEEP_KINDS", "run_point",
           "run_sweep", "Point", "Sweep", "load_sweep", "point_id", "sweep_from_dict"]

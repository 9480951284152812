"""Benchmark of the main job: the built-in default ``grainmech run`` (never asserted in tests).

Runs the built-in default config (``grainmech/data/default_run.toml``) through
:func:`grainmech.jobs.compute_run` twice: the first run loads or compiles the numba
kernels (what a first ``grainmech run`` after installing pays), the second is what every
later run costs. Reports the wall time of each run and, per kinematic model, the time of
its cyclic runs, the number of steps and the law evaluations. Target (issue on the
packing driver): <= 60 s for the later runs on 2 cores.

Run: ``python benchmarks/bench_default_run.py``
"""

from __future__ import annotations

import os
import time
import tomllib
from importlib import resources

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def main() -> None:
    from grainmech.jobs import RunComparison, compute_run

    cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
    for label in ("first run (compiles or loads the kernels)", "later run"):
        t0 = time.perf_counter()
        out = compute_run(cfg)
        wall = time.perf_counter() - t0
        outs = out.outcomes if isinstance(out, RunComparison) else [out]
        print(f"{label}: {wall:.1f} s wall, success {out.success}")
        for o in outs:
            steps = sum(len(r.stress) - 1 for r in o.results)
            prep = o.details.get("prepare_seconds")
            print(f"  {o.method:8s} {o.seconds:6.1f} s cyclic runs ({steps} steps"
                  + (f"; preparation {prep:.1f} s" if prep is not None else "") + f"), Gmax {o.G_max:.4g} Pa")


if __name__ == "__main__":
    main()

"""Benchmark of ``grainmech pack``: 2000 quartz grains to 100 kPa (target: <= 2 min on 2 cores).

Usage: ``python benchmarks/bench_pack.py [dense|medium|loose ...]`` (needs LAMMPS). Runs the
shipped packings' configs (``grainmech/data/packings/NAME.toml``) and prints, per config,
the wall time, time steps, steps per second, void ratio and unbalanced force ratio.
Nothing is written.
"""

from __future__ import annotations

import sys
import time
import tomllib
from importlib import resources


def main(names: list[str]) -> None:
    from grainmech.jobs import pack_job
    from grainmech.lammps.engine import cores

    print(f"cores available: {cores()}")
    for name in names or ["dense", "medium", "loose"]:
        cfg = tomllib.loads(resources.files("grainmech.data").joinpath("packings").joinpath(f"{name}.toml")
                            .read_text())
        t0 = time.perf_counter()
        res = pack_job(cfg)
        dt = time.perf_counter() - t0
        s = res.summary
        print(f"{name:7s} {dt:7.1f} s  {s['time_steps']:8d} steps  {s['time_steps'] / dt:7.0f} steps/s  "
              f"e = {s['void_ratio']:.4f}  UFR = {s['unbalanced_force_ratio']:.2e}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])

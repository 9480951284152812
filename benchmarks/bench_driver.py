"""Benchmark of the material-point driver (never asserted in tests).

10 cycles of strain-controlled simple shear gamma_xz, 100 steps per cycle, a
5810-direction Lebedev set (SciPy order 131) of an isotropic fabric, the
Mindlin-Deresiewicz law, in two variants:

* ``volume``: constant-volume simple shear, every strain component prescribed (the
  driver integrates it in one compiled pass, one law evaluation per direction and step);
* ``stress``: constant normal stress sigma_zz (mixed control: Newton iterations per step).

Reports the wall time, steps per second and direction-updates per second (one
direction-update = one evaluation of the law at one direction, Newton iterations and
substeps included). The first run of each variant is a warm-up (numba compilation or
cache loading) and is not timed.

Run: ``python benchmarks/bench_driver.py [--constant volume stress] [--backend auto|numpy]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from grainmech.assembly import ContactSet
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint, cyclic_simple_shear, run
from grainmech.fabric import sphere_rule


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backend", default="auto", choices=["auto", "numpy"],
                    help="contact-law evaluation: compiled kernel when available, or the NumPy reference")
    ap.add_argument("--cycles", type=int, default=10)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--amplitude", type=float, default=1e-4)
    ap.add_argument("--constant", nargs="+", default=["volume", "stress"], choices=["volume", "stress"])
    ap.add_argument("--repeat", type=int, default=3, help="timed runs (the best is reported)")
    a = ap.parse_args()

    normals, w = sphere_rule(131)  # degree 131 Lebedev rule: 5810 points
    radius = 1e-3
    nv = 8 / (2 * (4 / 3 * np.pi * radius ** 3) * 1.6)  # m/2 contacts per grain, e = 0.6
    cs = ContactSet(normals, 2 * radius * normals, nv * w, 0.0, 0.0)
    law = MindlinDeresiewicz(29e9, 0.15, radius, friction=0.5)
    pt = MaterialPoint.isotropic(cs, law, 1e5, backend=a.backend)
    print(f"directions: {len(cs)}  cycles: {a.cycles} x {a.steps} steps  law: Mindlin-Deresiewicz  "
          f"backend: {a.backend}")
    for constant in a.constant:
        path = cyclic_simple_shear(a.amplitude, a.cycles, a.steps, constant=constant)
        run(pt, cyclic_simple_shear(a.amplitude, 1, 4, constant=constant))  # warm-up
        times = []
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            r = run(pt, path)
            times.append(time.perf_counter() - t0)
        dt = min(times)
        evals = int(r.iterations.sum())
        print(f"\nconstant {constant}: success {r.success} ({r.message})")
        print(f"  law evaluations per direction: {evals} ({evals / len(path):.2f} per step, "
              f"max {r.iterations.max()} iterations, max {r.substeps.max()} substeps)")
        print(f"  wall time: {dt:.3f} s (best of {a.repeat}; all: {', '.join(f'{t:.3f}' for t in times)})   "
              f"steps/s: {len(path) / dt:.0f}   direction-updates/s: {evals * len(cs) / dt:.3g}")

if __name__ == "__main__":
    main()

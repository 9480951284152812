"""Benchmark of the material-point driver (never asserted in tests).

10 cycles of strain-controlled simple shear (gamma_xz, constant sigma_zz), 100 steps per
cycle, a 5810-direction Lebedev set (SciPy order 131) of an isotropic fabric, the
Mindlin-Deresiewicz law. Reports the wall time and direction-updates per second (one
direction-update = one evaluation of the law at one direction, Newton iterations and
substeps included).

Run: ``/work/venv/bin/python benchmarks/bench_driver.py [--backend contact|iwan] [--cycles N]``
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
    ap.add_argument("--backend", default="contact", choices=["contact", "iwan"])
    ap.add_argument("--cycles", type=int, default=10)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--amplitude", type=float, default=1e-4)
    a = ap.parse_args()

    normals, w = sphere_rule(131)  # degree 131 Lebedev rule: 5810 points
    radius = 1e-3
    nv = 8 / (2 * (4 / 3 * np.pi * radius ** 3) * 1.6)  # m/2 contacts per grain, e = 0.6
    cs = ContactSet(normals, 2 * radius * normals, nv * w, 0.0, 0.0)
    law = MindlinDeresiewicz(29e9, 0.15, radius, friction=0.5)
    pt = MaterialPoint.isotropic(cs, law, 1e5, backend=a.backend)
    path = cyclic_simple_shear(a.amplitude, a.cycles, a.steps)
    t0 = time.perf_counter()
    r = run(pt, path)
    dt = time.perf_counter() - t0
    evals = int(r.iterations.sum())
    print(f"directions: {len(cs)}  steps: {len(path)}  backend: {a.backend}")
    print(f"success: {r.success}  ({r.message})")
    print(f"law evaluations (Newton iterations incl. substeps): {evals}  "
          f"max iterations/step: {r.iterations.max()}  max substeps: {r.substeps.max()}")
    print(f"wall time: {dt:.2f} s   step rate: {len(path) / dt:.1f} steps/s   "
          f"direction-updates/s: {evals * len(cs) / dt:.3g}")


if __name__ == "__main__":
    main()

"""Benchmark of the packing driver: G/Gmax and damping on a ~2000-grain packing.

7 amplitudes x 2 cycles x 40 steps of constant-stress cyclic simple shear
(:func:`grainmech.driver.packing.packing_modulus_reduction`) on a disordered fcc packing of
Hertz / Mindlin-Deresiewicz spheres (8^3 cells, 5 % vacancies: 1946 grains), equilibrated
first (not timed with the curves). Prints wall times, Newton and GMRES iterations per
step and the throughput. Target: <= 30 s for the curves on 2 cores.

Shipped packings: ``python benchmarks/bench_packing_driver.py shipped [dense,medium,loose]``
runs 2 cycles x 40 steps at 1e-4 (constant stress, Mindlin-Deresiewicz with quartz, the
compiled law) on each shipped packing from its own 100 kPa and prints one row each: wall
time, its ratio to the dgemm yardstick, whether it completed and the issue-29 targets
(1e-4 on 'dense' <= 20 s, on 'loose' <= 60 s, 2 cores).

Run: ``python benchmarks/bench_packing_driver.py [n_cells] [law_backend] [fast]``
(``law_backend``: ``numpy``, the reference law, or ``auto``, the compiled kernel when
numba is present; ``fast``: ``PackingOptions(reproducible=False)``, PARDISO on every
core instead of one). OpenBLAS is limited to one thread unless ``OPENBLAS_NUM_THREADS`` is
set: SciPy's GMRES makes many small BLAS calls whose thread start-up costs more than the
work (3x slower on a loaded 2-core machine).
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from _yardstick import dgemm_seconds

from grainmech.contact import MindlinDeresiewicz
from grainmech.driver.packing import (PackingOptions, PackingPoint, equilibrate_network, packing_modulus_reduction,
                                      perturbed_fcc_network)


#: issue 29's wall-time targets [s] for 2 cycles x 40 steps at 1e-4 on 2 cores
TARGETS = {"dense": 20.0, "loose": 60.0}


def shipped(names: list[str]) -> None:
    """One row per shipped packing: 1e-4, 2 cycles x 40 steps, wall time and dgemm ratio."""
    from grainmech.driver import cyclic_simple_shear
    from grainmech.driver.packing import run_packing
    from grainmech.packing import QUARTZ, load_packing

    dg = dgemm_seconds()
    print(f"dgemm yardstick (n = 2048): {dg:.3f} s")
    print("| packing | grains | result | max residual | s | dgemm | target |")
    print("|---|---|---|---|---|---|---|", flush=True)
    for name in names:
        net = load_packing(name)
        law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()),
                                 friction=QUARTZ.friction)
        opts = PackingOptions(law_backend="auto", tangent="none")
        pt = PackingPoint.from_network(net, law, options=opts)
        _ = pt.preconditioner()
        t0 = time.perf_counter()
        res = run_packing(pt, cyclic_simple_shear(1e-4, 2, 40), opts)
        sec = time.perf_counter() - t0
        tgt = TARGETS.get(name)
        met = "" if tgt is None else f"<= {tgt:g} s: {'met' if sec <= tgt and res.success else 'NOT met'}"
        print(f"| {name} | {pt.n_grains} | {'completed' if res.success else res.message} | "
              f"{res.residual.max():.3g} | {sec:.1f} | {sec / dg:.0f} | {met} |", flush=True)


def main() -> None:
    """The fcc benchmark, or the shipped packings' rows (``shipped``)."""
    if len(sys.argv) > 1 and sys.argv[1] == "shipped":
        shipped((sys.argv[2] if len(sys.argv) > 2 else "dense,medium,loose").split(","))
        return
    n_cells = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    backend = sys.argv[2] if len(sys.argv) > 2 else "numpy"
    law = MindlinDeresiewicz(29e9, 0.15, 1.0, friction=0.5)
    t0 = time.perf_counter()
    net = equilibrate_network(perturbed_fcc_network(n_cells, seed=1, vacancies=0.05, overlap=0.004,
                                                    disorder=0.0008), law)
    t1 = time.perf_counter()
    fast = len(sys.argv) > 3 and sys.argv[3] == "fast"
    opts = PackingOptions(law_backend=None if backend == "auto" else backend, reproducible=not fast)
    pt = PackingPoint.from_network(net, law, options=opts)
    _ = pt.tangent
    t2 = time.perf_counter()
    print(f"equilibration {t1 - t0:.2f} s, point (factorisation, relaxed tangent) {t2 - t1:.2f} s", flush=True)
    amps = np.logspace(-6, -3, 7)
    mr = packing_modulus_reduction(pt, amps, n_cycles=2, steps_per_cycle=40, options=opts)
    t3 = time.perf_counter()
    steps = sum(len(r.strain) - 1 for r in mr.results)
    newton = sum(int(r.iterations.sum()) for r in mr.results)
    krylov = sum(int(r.krylov.sum()) for r in mr.results)
    fact = sum(r.factorizations for r in mr.results)
    print(f"packing: {pt.n_grains} grains, {pt.n_contacts} tracked contacts "
          f"({int(pt.initially_closed.sum())} closed), {6 * pt.n_grains - 3} grain unknowns, "
          f"p = {pt.stress[:3].mean():.4g} Pa; law backend {backend}")
    print(f"curves: {t3 - t2:.2f} s wall for {steps} steps = {steps / (t3 - t2):.1f} steps/s; "
          f"Newton iterations/step {newton / steps:.2f}, GMRES iterations/step {krylov / steps:.2f}, "
          f"extra factorisations {fact}")
    print("amplitude   G/Gmax   damping   max residual")
    for a, g, d, r in zip(mr.amplitude, mr.G_ratio, mr.damping, mr.results):
        print(f"{a:9.2e}  {g:7.4f}  {d:8.5f}  {r.residual.max():.2e}")
    dg = dgemm_seconds()
    print(f"Gmax = {mr.G_max:.4g} Pa; curves {t3 - t2:.2f} s = {(t3 - t2) / dg:.0f} dgemm (n = 2048: {dg:.3f} s); "
          f"factorisation {pt.preconditioner().factor.name} ({'all cores' if fast else 'one thread, reproducible'}); target <= 30 s: {'met' if t3 - t2 <= 30 else 'NOT met'}")


if __name__ == "__main__":
    main()

"""Benchmark of the relaxed stiffness tensor, solver against solver (never asserted in tests).

For the shipped 2000-grain frictional packing (``load_packing("dense")``, Hertz-Mindlin
contacts), copies of it (``--tiles``, default 5x5x2 = 1e5 grains: ``tile_network``, each
contact's stiffnesses scaled by one random factor in [0.5, 1.5] so that the solve is not
periodic, i.e. a packing-like network of that size) and random periodic networks
(``--particles``, default 10000,100000; far worse conditioned than packings) it times
:func:`grainmech.network.relaxed_stiffness` with every installed solver (best of
``--repeat``; a solver is skipped at sizes where one run exceeds ``--budget`` seconds),
split into the assembly and the solve, and prints the residual, the solver ``auto``
picks, the time as a multiple of an OpenBLAS dgemm (n = 2048) timed in the same process,
and the peak traced memory (tracemalloc: NumPy/SciPy arrays; the factorisation inside
cholespy is not traced, the process max RSS is printed as well).

    python benchmarks/bench_relaxed.py [--tiles 5x5x2] [--particles 10000,100000] [--repeat 3] [--tol 1e-10]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
import tracemalloc

import numpy as np
from _yardstick import dgemm_seconds


def _case(label: str, net, kn, ks, solvers: list[str], repeat: int, budget: float, dg: float,
          tol: float | None) -> dict:
    from grainmech.network import _solvers, relaxed_stiffness

    rows = {}
    ref = None
    for s in solvers:
        best, res, peak = np.inf, None, 0
        for _ in range(repeat):
            tracemalloc.start()
            t0 = time.perf_counter()
            try:
                kw = {} if tol is None else {"tol": tol}
                res = relaxed_stiffness(net, kn, ks, solver=s, maxiter=50000, **kw)
            except Exception as exc:  # noqa: BLE001 (reported, the others go on)
                tracemalloc.stop()
                print(f"  {label:28s} {s:9s} failed: {exc}")
                break
            dt = time.perf_counter() - t0
            peak = max(peak, tracemalloc.get_traced_memory()[1])
            tracemalloc.stop()
            best = min(best, dt)
            if dt > budget:
                break
        if res is None or not np.isfinite(best):
            continue
        ref = res.C_relaxed if ref is None else ref
        dev = float(np.abs(res.C_relaxed - ref).max() / np.abs(ref).max())
        rows[s] = best
        print(f"  {label:28s} {s:9s} {best:8.3f} s = {best / dg:6.2f} dgemm  ran {res.solver:8s} "
              f"iterations {res.iterations:5d} residual {res.residual:.1e}  |C - C_first|/|C| {dev:.1e}  "
              f"peak traced {peak / 1e6:6.0f} MB")
    ndof = 6 * res.n_particles if res is not None else 0
    print(f"  {label:28s} auto: block CG, else {_solvers.choose('auto', ndof)} for {ndof} unknowns; process max RSS "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    return rows


def main(argv: list[str] | None = None) -> int:
    """Time every installed solver on the shipped packing and the random networks."""
    from grainmech.network import _solvers, contact_stiffnesses, random_network, tile_network
    from grainmech.packing import load_packing

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tiles", default="5x5x2", help="copies of the dense packing, e.g. 5x5x2 (empty: none)")
    ap.add_argument("--particles", default="10000,100000")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--budget", type=float, default=60.0, help="skip repeats of a solver slower than this [s]")
    ap.add_argument("--solvers", default="auto,pardiso,cholesky,superlu,amg,cg")
    ap.add_argument("--tol", type=float, default=None, help="CG tolerance (default: the library's)")
    a = ap.parse_args(argv)
    dg = dgemm_seconds()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, cpus {os.cpu_count()}, "
          f"dgemm n=2048 {dg:.3f} s")
    solvers = [s for s in a.solvers.split(",") if s == "auto" or _solvers.available(s)]
    net = load_packing("dense")
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
    _case(f"dense packing {net.n_particles} grains", net, kn, ks, solvers, a.repeat, a.budget, dg, a.tol)
    if a.tiles:
        big = tile_network(net, [int(x) for x in a.tiles.split("x")])
        kn, ks, _ = contact_stiffnesses(big, shear_modulus=29e9, poisson=0.15)
        f = np.random.default_rng(0).uniform(0.5, 1.5, big.n_contacts)
        use = [s for s in solvers if s in ("auto", "cg", "pardiso")]  # the others: minutes at 1e5 grains
        _case(f"dense x {a.tiles} {big.n_particles} grains", big, kn * f, ks * f, use, a.repeat, a.budget, dg,
              a.tol)
    for n in [int(float(x)) for x in a.particles.split(",") if x]:
        rnet = random_network(n, coordination=7.0, seed=1)
        kn, ks, _ = contact_stiffnesses(rnet, shear_modulus=29e9, poisson=0.15)
        use = [s for s in solvers if s != "superlu"]  # SuperLU: minutes and GBs of fill-in beyond ~20k unknowns
        _case(f"random network {n} grains", rnet, kn, ks, use, a.repeat if n <= 20000 else 1, a.budget, dg,
              a.tol)
    return 0


if __name__ == "__main__":
    sys.exit(main())

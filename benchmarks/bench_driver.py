"""Benchmark of the material-point driver (never asserted in tests).

10 cycles of strain-controlled simple shear gamma_xz, 100 steps per cycle, a
5810-direction Lebedev set (SciPy order 131) of an isotropic fabric, the
Mindlin-Deresiewicz law, in two variants:

* ``volume``: constant-volume simple shear, every strain component prescribed (the
  driver integrates it in one compiled pass, one law evaluation per direction and step);
* ``stress``: constant normal stress sigma_zz (mixed control: Newton iterations per step,
  the whole step/Newton loop in one compiled call, ``driver/_mixed.py``).

The Lebedev set is invariant under the antipodal map and the mirrors through the
coordinate planes, and simple shear in xz (eps_xy = eps_yz = 0) under the mirror
y -> -y, so the compiled driver evaluates one row per orbit of the four sign maps with
the orbit's weight (``driver/_fold.py``: 1475 of the 5810 rows; ``SolverOptions(fold=False)``
evaluates all). ``--antipodal-only`` folds by the antipodal map alone (2905 rows), as
before the mirrors were used, for a before/after in the same run.

Reports the wall time (best of ``--repeat``, serial and with numba's threads), law
evaluations per step, steps and direction-updates per second (one direction-update = one
evaluation of the law at one direction, Newton iterations and substeps included), the
ratio to an OpenBLAS dgemm (n = 2048, float64) timed in the same process (the ratio
holds across machines, the seconds do not), and the ratio of the NumPy reference
(``backend="numpy"``: NumPy law, Python step loop) to the compiled driver per step,
the reference timed on ``--numpy-cycles`` cycles. The first run of each variant is a
warm-up (numba compilation or cache loading) and is not timed.

``--sizes 1e3,1e4,1e5,1e6`` adds the cost of one mixed-control cycle against the number
of directions (random sets: nothing to fold).

Run: ``python benchmarks/bench_driver.py [--constant volume stress] [--backend auto|numpy] [--sizes ...]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import get_num_threads, set_num_threads

import grainmech
from grainmech.assembly import ContactSet
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint, cyclic_simple_shear, run
from grainmech.fabric import sphere_rule


def main() -> None:
    """Time both variants, serial and threaded, against the dgemm yardstick."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backend", default="auto", choices=["auto", "numpy"],
                    help="contact-law evaluation: compiled kernel when available, or the NumPy reference")
    ap.add_argument("--cycles", type=int, default=10)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--amplitude", type=float, default=1e-4)
    ap.add_argument("--constant", nargs="+", default=["volume", "stress"], choices=["volume", "stress"])
    ap.add_argument("--repeat", type=int, default=3, help="timed runs (the best is reported)")
    ap.add_argument("--numpy-cycles", type=int, default=1,
                    help="cycles of the NumPy reference run (0: skip it)")
    ap.add_argument("--sizes", default="",
                    help="cost against size: comma list of direction counts (e.g. 1e3,1e4,1e5,1e6), each "
                         "a random isotropic set without antipodal pairs, one cycle of --steps steps "
                         "with sigma_zz held, numba's threads")
    ap.add_argument("--antipodal-only", action="store_true",
                    help="fold by the antipodal map alone (no mirrors): the driver before the mirrors")
    a = ap.parse_args()
    if a.antipodal_only:
        from grainmech.driver.affine import _fused, _mixed

        for mod in (_fused, _mixed):
            mod.path_mirrors = lambda *args: ()  # type: ignore[assignment]

    rng = np.random.default_rng(0)
    A, B = rng.random((2048, 2048)), rng.random((2048, 2048))
    np.dot(A, B)
    t_dgemm = min(_timed(lambda: np.dot(A, B)) for _ in range(3))
    print(f"grainmech: {grainmech.__file__}")
    print(f"yardstick: OpenBLAS dgemm n=2048 {t_dgemm:.3f} s (best of 3)")

    normals, w = sphere_rule(131)  # degree 131 Lebedev rule: 5810 points
    radius = 1e-3
    nv = 8 / (2 * (4 / 3 * np.pi * radius ** 3) * 1.6)  # m/2 contacts per grain, e = 0.6
    cs = ContactSet(normals, 2 * radius * normals, nv * w, 0.0, 0.0)
    law = MindlinDeresiewicz(29e9, 0.15, radius, friction=0.5)
    pt = MaterialPoint.isotropic(cs, law, 1e5, backend=a.backend)
    print(f"directions: {len(cs)}  cycles: {a.cycles} x {a.steps} steps  law: Mindlin-Deresiewicz  "
          f"backend: {a.backend}")
    from grainmech.driver.affine._fold import fold, path_mirrors

    for constant in a.constant:
        p = cyclic_simple_shear(a.amplitude, 1, 4, constant=constant)
        mirrors = () if a.antipodal_only else path_mirrors(p.stress_control[0], p.increment, pt.stress)
        f = fold(cs, pt.state, pt.response, True, mirrors)[0] if a.backend != "numpy" else None
        print(f"rows evaluated by the compiled driver ({constant}): {len(cs) if f is None else len(f.rows)} "
              f"({'all' if f is None else f'one per orbit of {len(f.group)} sign maps, the orbit weight'}; "
              "direction-updates/s below count every direction)")
    for constant in a.constant:
        path = cyclic_simple_shear(a.amplitude, a.cycles, a.steps, constant=constant)
        threads = get_num_threads()
        timings = {}
        for label, nt in (("threads", threads), ("serial", 1)):
            set_num_threads(nt)
            run(pt, cyclic_simple_shear(a.amplitude, 1, 4, constant=constant))  # warm-up
            times = []
            for _ in range(a.repeat):
                t0 = time.perf_counter()
                r = run(pt, path)
                times.append(time.perf_counter() - t0)
            timings[label] = times
            if threads == 1:
                break
        set_num_threads(threads)
        evals = int(r.iterations.sum())
        print(f"\nconstant {constant}: success {r.success} ({r.message})")
        print(f"  law evaluations per direction: {evals} ({evals / len(path):.2f} per step, "
              f"max {r.iterations.max()} iterations, max {r.substeps.max()} substeps)")
        for label, times in timings.items():
            dt = min(times)
            print(f"  wall time ({label}, {threads if label == 'threads' else 1} thread(s)): {dt:.3f} s = "
                  f"{dt / t_dgemm:.1f} dgemm (best of {a.repeat}; all: {', '.join(f'{t:.3f}' for t in times)})   "
                  f"steps/s: {len(path) / dt:.0f}   direction-updates/s: {evals * len(cs) / dt:.3g}")
        best = min(min(t) for t in timings.values())
        if a.numpy_cycles > 0 and a.backend != "numpy":
            ref_pt = MaterialPoint.isotropic(cs, law, 1e5, backend="numpy")
            ref_path = cyclic_simple_shear(a.amplitude, a.numpy_cycles, a.steps, constant=constant)
            t0 = time.perf_counter()
            rr = run(ref_pt, ref_path)
            t_ref = time.perf_counter() - t0
            per_ref = t_ref / len(ref_path)
            print(f"  NumPy reference (backend numpy, {a.numpy_cycles} cycle(s)): {t_ref:.2f} s, "
                  f"{rr.iterations.sum() / len(ref_path):.2f} evaluations/step; per step "
                  f"{per_ref * 1e3:.2f} ms vs compiled {best / len(path) * 1e3:.3f} ms: "
                  f"compiled {per_ref / (best / len(path)):.0f}x faster")
    if a.sizes:
        _sizes([int(float(x)) for x in a.sizes.split(",")], a.amplitude, a.steps, t_dgemm)


def _sizes(sizes: list[int], amplitude: float, steps: int, t_dgemm: float) -> None:
    """Cost of one mixed-control cycle against the number of directions (random sets, nothing folded)."""
    radius = 1e-3
    nv = 8 / (2 * (4 / 3 * np.pi * radius ** 3) * 1.6)
    law = MindlinDeresiewicz(29e9, 0.15, radius, friction=0.5)
    print(f"\ncost against size: one cycle of {steps} steps, sigma_zz held, gamma {amplitude:g}, "
          f"{get_num_threads()} thread(s); random directions (no antipodal pairs: every row evaluated)")
    for n in sizes:
        v = np.random.default_rng(n).standard_normal((n, 3))
        normals = v / np.linalg.norm(v, axis=1)[:, None]
        cs = ContactSet(normals, 2 * radius * normals, np.full(n, nv / n), 0.0, 0.0)
        pt = MaterialPoint.isotropic(cs, law, 1e5)
        run(pt, cyclic_simple_shear(amplitude, 1, 4, constant="stress"))  # warm-up (compilation, cache)
        path = cyclic_simple_shear(amplitude, 1, steps, constant="stress")
        t0 = time.perf_counter()
        r = run(pt, path)
        dt = time.perf_counter() - t0
        ev = r.iterations.sum() / len(path)
        print(f"  {n:8d} directions: {dt:8.3f} s = {dt / t_dgemm:7.1f} dgemm  {ev:.2f} evaluations/step  "
              f"{dt / (n * len(path)) * 1e9:6.0f} ns per direction and step  success {r.success}")


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()

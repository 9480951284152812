"""Benchmark of parameter sweeps on dask (never asserted in tests).

Two sweeps, both Latin-hypercube designs with inline base configs:

* ``stiffness``: 1000 points of the stiffness kind (Hertz-Mindlin quartz sand, a
  transversely isotropic fabric) over void ratio, mean stress and the fabric parameter a20;
* ``driver``: 100 points of the run kind, cyclic simple shear at 5 strain amplitudes
  (2 cycles of 40 steps each, Mindlin-Deresiewicz contacts, 50 quadrature directions)
  over mean stress and friction angle.

For each sweep it reports points per second for

* ``loop``: the same points in a plain Python loop (``grainmech.sweep.run_point``), no
  dask, no files;
* ``1 worker``: :func:`grainmech.sweep.run_sweep` on the default in-process cluster
  (one worker thread);
* ``2 workers``: two local worker processes;

and the per-point overhead of the sweep machinery, ``(t_sweep - t_loop) / n`` for one
worker (scheduling, transfer, writing the point file; the final table and summary
included), plus the bare scheduler round trip of a no-op task. Cluster start-up time is
reported separately and not included; the workers are warmed up (numba compilation or
cache loading) before timing. With ``--repeat R`` the three variants are run R times,
interleaved, and the best time of each is reported (useful on a shared machine).

Run: ``python benchmarks/bench_sweep.py [--stiffness-points 1000] [--driver-points 100] [--repeat 1]``
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time

STIFFNESS_BASE = {
    "microstructure": {"void_ratio": 0.62, "coordination": "yanagisawa", "radius": "0.2 mm"},
    "fabric": {"dim": 3, "a20": 0.2},
    "contacts": {"law": "hertz-mindlin", "shear_modulus": "44 GPa", "poisson": 0.08},
    "stress": {"pressure": "200 kPa"},
}
STIFFNESS_PARAMS = {
    "microstructure.void_ratio": {"min": 0.55, "max": 0.85},
    "stress.pressure": {"min": "25 kPa", "max": "1.6 MPa", "scale": "log"},
    "fabric.a20": {"min": 0.0, "max": 0.5},
}
DRIVER_BASE = {
    "microstructure": {"void_ratio": 0.65, "coordination": "chang", "radius": "0.25 mm"},
    "contacts": {"law": "mindlin-deresiewicz", "shear_modulus": "44 GPa", "poisson": 0.08,
                 "friction_angle": "27 deg"},
    "initial": {"pressure": "100 kPa"},
    "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-6, 1e-5, 1e-4, 3e-4, 1e-3],
             "n_cycles": 2, "steps_per_cycle": 40},
    "quadrature": {"degree": 11},
}
DRIVER_PARAMS = {
    "initial.pressure": {"min": "25 kPa", "max": "800 kPa", "scale": "log"},
    "contacts.friction_angle": {"min": "20 deg", "max": "35 deg"},
}


def _noop(x: int) -> int:
    return x


def _warm(kind: str, cfg: dict) -> bool:
    from grainmech.sweep import run_point

    run_point((kind, cfg, None))
    return True


def sweep_of(kind: str, base: dict, params: dict, n: int):
    from grainmech.sweep import sweep_from_dict

    return sweep_from_dict({"sweep": {"kind": kind, "design": "latin-hypercube", "samples": n, "seed": 1},
                            "base": copy.deepcopy(base), "parameters": copy.deepcopy(params)})


def bench(name: str, kind: str, base: dict, params: dict, n: int, repeat: int) -> None:
    from grainmech.parallel import map_completed, open_client
    from grainmech.sweep import run_point, run_sweep

    sw = sweep_of(kind, base, params, n)
    _warm(kind, sw.points[0].config)
    t_run: dict = {"loop": [], 1: [], 2: []}
    t_noop: dict = {1: [], 2: []}
    t_start: dict = {1: [], 2: []}
    for _ in range(repeat):  # interleaved, best of `repeat`: the machine may be shared
        t0 = time.perf_counter()
        for pt in sw.points:
            run_point((kind, pt.config, None))
        t_run["loop"].append(time.perf_counter() - t0)
        for workers in (1, 2):
            t0 = time.perf_counter()
            with open_client(workers=workers) as client:
                t_start[workers].append(time.perf_counter() - t0)
                client.run(_warm, kind, sw.points[0].config)
                t0 = time.perf_counter()
                list(map_completed(_noop, range(n), client=client))
                t_noop[workers].append(time.perf_counter() - t0)
                with tempfile.TemporaryDirectory() as d:
                    t0 = time.perf_counter()
                    s = run_sweep(sw, d, client=client, plots=False)
                    t_run[workers].append(time.perf_counter() - t0)
            assert s["succeeded"] == n, s
    t_loop = min(t_run["loop"])
    print(f"\n{name}: {n} points ({kind}, Latin hypercube), best of {repeat}")
    print(f"  loop       {t_loop:8.2f} s  {n / t_loop:8.1f} points/s  ({1e3 * t_loop / n:.1f} ms/point)")
    for workers in (1, 2):
        t = min(t_run[workers])
        label = f"{workers} worker" + ("s" if workers > 1 else " ")
        extra = f", overhead {1e3 * (t - t_loop) / n:+.2f} ms/point vs loop" if workers == 1 else \
            f", speed-up {t_loop / t:.2f}x vs loop"
        print(f"  {label}  {t:8.2f} s  {n / t:8.1f} points/s{extra}; no-op task round trip "
              f"{1e3 * min(t_noop[workers]) / n:.2f} ms/task; cluster start {min(t_start[workers]):.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stiffness-points", type=int, default=1000)
    ap.add_argument("--driver-points", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=1, help="interleaved repetitions (the best is reported)")
    a = ap.parse_args()
    if a.stiffness_points:
        bench("stiffness sweep", "stiffness", STIFFNESS_BASE, STIFFNESS_PARAMS, a.stiffness_points, a.repeat)
    if a.driver_points:
        bench("cyclic-driver sweep", "run", DRIVER_BASE, DRIVER_PARAMS, a.driver_points, a.repeat)


if __name__ == "__main__":
    main()

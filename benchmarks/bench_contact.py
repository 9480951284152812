"""Benchmark of the vectorised Mindlin–Deresiewicz update (not a test; never asserts timings).

Usage::

    python benchmarks/bench_contact.py            # 1e5 and 1e6 contacts, both backends
    python benchmarks/bench_contact.py --n 200000 --steps 20 --backend numba

For each size it times ``grainmech.contact.update`` on three kinds of increments, each
applied to every contact at once (contact axis first, 3D tangential vectors):

* ``tangential cycles``  constant normal force, random per-contact tangential cycles
  (reversals, Masing pops and some gross sliding in every step);
* ``oblique, rising N``  normal and tangential increments together (no-slip and slip
  cases of seed Eq. 3.10 mixed);
* ``random 3D``          random normal and tangential increments in 3D, including
  falling normal force and opening/closing contacts.

and prints contact updates per second (contacts x steps / wall time) for each backend of
``update`` (``numpy``: the vectorised reference; ``numba``: the compiled kernel of
``grainmech.contact.kernel``, compiled or loaded from its cache in the untimed warm-up
step; it runs on ``numba.get_num_threads()`` threads above ``PARALLEL_THRESHOLD`` contacts).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from grainmech.contact import MindlinDeresiewicz, hertz_approach_from_force, state_from_normal_force, update


def _run(p, n: int, steps: int, kind: str, backend: str, seed: int = 0) -> float:
    rng = np.random.default_rng(seed)
    N0 = rng.uniform(5.0, 15.0, n)
    st = state_from_normal_force(p, N0, dim=3)
    aref = float(hertz_approach_from_force(10.0, p))
    amp = rng.uniform(0.05, 0.6, n) * aref                    # tangential amplitude per contact
    direction = np.zeros((n, 3))
    direction[:, 0] = 1.0
    # warm-up step (memory axes, first reversal)
    st, _ = update(p, st, np.zeros(n), 0.5 * amp[:, None] * direction, backend=backend)
    t0 = time.perf_counter()
    for k in range(steps):
        if kind == "tangential cycles":
            sgn = 1.0 if (k // 2) % 2 == 0 else -1.0
            dn = np.zeros(n)
            dt = (sgn * amp * rng.uniform(0.5, 1.0, n))[:, None] * direction
        elif kind == "oblique, rising N":
            dn = np.full(n, 0.01 * aref)
            dt = (amp * rng.uniform(-0.1, 0.1, n))[:, None] * direction
        else:
            dn = rng.normal(0.0, 0.15, n) * aref
            dt = rng.normal(0.0, 0.3, (n, 3)) * aref
        st, resp = update(p, st, dn, dt, backend=backend)
    dt_wall = time.perf_counter() - t0
    return n * steps / dt_wall


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[100_000, 1_000_000])
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--max-reversals", type=int, default=16)
    ap.add_argument("--backend", nargs="*", default=["numpy", "numba"], choices=["numpy", "numba"])
    args = ap.parse_args(argv)
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5, max_reversals=args.max_reversals)
    print(f"grainmech.contact.update, Mindlin–Deresiewicz, dim = 3, max_reversals = {args.max_reversals}")
    print(f"{'contacts':>10}  {'increments':<20} {'backend':<8} {'updates/s':>12}")
    for n in args.n:
        for kind in ("tangential cycles", "oblique, rising N", "random 3D"):
            for backend in args.backend:
                rate = _run(p, n, args.steps, kind, backend)
                print(f"{n:>10d}  {kind:<20} {backend:<8} {rate:12.3e}")


if __name__ == "__main__":
    main()

"""Benchmark: discrete stiffness assembly (seed Eq. 2.26) over 1e6 and 1e7 random contacts.

Reports contacts per second for the NumPy and (if installed) numba kernels, 3D and 2D,
and the fraction of this machine's memory bandwidth reached. The bandwidth bound is
measured in the same run by a streaming read of an array of the same size as the
kernel's inputs (numba parallel sum if available, else NumPy sum): the kernel must read
``9 * 8`` bytes per contact in 3D (n, l: 6 doubles; w, kn, ks: 3) and ``7 * 8`` in 2D.

Run:  python benchmarks/bench_assembly.py [--sizes 1e6 1e7] [--repeat 3]
Never asserted in the test suite.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from grainmech.assembly import ContactSet, numba_available, stiffness


def _stream_read_bandwidth(nbytes: int, repeat: int) -> float:
    """Bytes per second of a parallel streaming read of ``nbytes`` (best of ``repeat``)."""
    a = np.ones(nbytes // 8)
    if numba_available():
        import numba

        @numba.njit(parallel=True, cache=True)
        def _sum(x):
            s = 0.0
            for i in numba.prange(x.shape[0]):
                s += x[i]
            return s
        _sum(a[:1000])
        f = _sum
    else:
        f = np.sum
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        f(a)
        best = min(best, time.perf_counter() - t)
    return a.nbytes / best


def _contacts(m: int, d: int, rng) -> ContactSet:
    n = rng.normal(size=(m, d))
    n /= np.linalg.norm(n, axis=1)[:, None]
    return ContactSet(n, n * rng.uniform(1e-3, 2e-3, m)[:, None], rng.uniform(0.5, 1.5, m) * 1e9,
                      rng.uniform(1e5, 1e6, m), rng.uniform(1e5, 5e5, m))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", type=float, default=[1e6, 1e7])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    rows = []
    for d in (3, 2):
        for size in args.sizes:
            m = int(size)
            cs = _contacts(m, d, rng)
            bytes_per = (2 * d + 3) * 8
            bw = _stream_read_bandwidth(m * bytes_per, args.repeat)
            backends = ["numpy"] + (["numba"] if numba_available() else [])
            for be in backends:
                stiffness(cs, backend=be)  # warm-up / JIT
                best = np.inf
                for _ in range(args.repeat):
                    t = time.perf_counter()
                    stiffness(cs, backend=be)
                    best = min(best, time.perf_counter() - t)
                rate = m / best
                rows.append(dict(dim=d, contacts=m, backend=be, seconds=best, contacts_per_s=rate,
                                 bandwidth_GBps=bw / 1e9, fraction_of_bandwidth=rate * bytes_per / bw))
            del cs
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print(f"{'dim':>3} {'contacts':>10} {'backend':>7} {'seconds':>9} {'Mcontacts/s':>12} {'stream GB/s':>11} {'of bw':>6}")
    for r in rows:
        print(f"{r['dim']:>3} {r['contacts']:>10} {r['backend']:>7} {r['seconds']:>9.4f} "
              f"{r['contacts_per_s'] / 1e6:>12.1f} {r['bandwidth_GBps']:>11.2f} {r['fraction_of_bandwidth']:>6.0%}")


if __name__ == "__main__":
    main()

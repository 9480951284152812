"""Per-contact cost of the mixed-control driver's evaluation pass (never asserted in tests).

The state of ``bench_driver.py --constant stress`` after one cycle (5810 directions,
Mindlin-Deresiewicz, sigma_zz held); then, serially and from that state, the compiled
pieces that ``driver/_mixed.py`` runs per step:

* the evaluation pass (kinematics, the law, Love-Weber stress, Newton Jacobian) for one
  strain increment, run ``--passes`` times (2.18 passes per step in the benchmark);
* the law alone (``kernel.law_function``, chunks of 128 contacts) on the same input;
* the commit of the accepted iterate (the pass with ``commit``: state copy, deferred
  falling-N dissipation, reported tangent, stored energy; once per step).

Prints ns per contact (best of ``--repeat``) and a hash of the pass's outputs (forces,
state, tangents, per-chunk sums; dissipation excluded), to check that a change of the
law leaves its results unchanged bit for bit. ``--shear`` sets the shear increment
(the sign selects which half of the directions has a falling normal force).

Run: ``python benchmarks/bench_mixed_pass.py [--shear 4e-6] [--passes 30] [--repeat 25]``
"""

from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np
from numba import njit, set_num_threads, typeof, types

import grainmech
from grainmech.assembly import ContactSet
from grainmech.contact import MindlinDeresiewicz, kernel
from grainmech.contact.kernel import KernelIncrement, KernelScratch, KernelState
from grainmech.driver import MaterialPoint, cyclic_simple_shear, run
from grainmech.driver.affine import _mixed, _mixed_pass, _mixed_rows
from grainmech.fabric import sphere_rule


@njit
def _passes(k, f, law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp):
    _mixed_rows.start_radii(kc.linear, kc.E, kc.R, st.approach, st.normal_force, inc.rad0)
    for _ in range(k):
        f(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, False)


@njit
def _laws(k, law_fn, kc, st, inc, out, scratch):
    n = st.approach.shape[0]
    for _ in range(k):
        for lo in range(0, n, 128):
            law_fn(lo, min(n, lo + 128), kc, st, inc, out, scratch)


@njit
def _commits(k, f, law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, cflat, nfall):
    for _ in range(k):
        for i in range(nfall.shape[0]):  # the falls recorded by the pass (the commit consumes them)
            scratch.fall[i, 0] = nfall[i]
        f(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, True)
        _mixed_pass.commit_sums(part, cflat)


def main() -> None:
    """Time the pass, the law and the commit; print the pass outputs' hash."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shear", type=float, default=4e-6, help="engineering shear increment gamma_xz of the pass")
    ap.add_argument("--passes", type=int, default=30, help="passes (law calls, commits) per timing")
    ap.add_argument("--repeat", type=int, default=25)
    a = ap.parse_args()
    set_num_threads(1)
    print(f"grainmech: {grainmech.__file__}")

    normals, w = sphere_rule(131)
    radius = 1e-3
    nv = 8 / (2 * (4 / 3 * np.pi * radius ** 3) * 1.6)
    cs = ContactSet(normals, 2 * radius * normals, nv * w, 0.0, 0.0)
    law = MindlinDeresiewicz(29e9, 0.15, radius, friction=0.5)
    pt = run(MaterialPoint.isotropic(cs, law, 1e5), cyclic_simple_shear(1e-4, 1, 100, constant="stress")).final
    kc = kernel.constants(law)
    n = len(cs)

    def c(x, dtype=float):
        return np.array(x, dtype=dtype, order="C")

    s0 = pt.state
    st = KernelState(c(s0.approach), c(s0.normal_force), c(s0.tangential_force), c(s0.axis),
                     c(s0.direction, np.int8), c(s0.depth, np.int32), c(s0.reversals), c(s0.dissipated_energy))
    nrev = st.reversals.shape[1]
    out = kernel.new_output(n, 3, nrev)
    scratch = KernelScratch(np.empty((n, 3)), np.empty((n, 3)), np.zeros(n, dtype=np.int8),
                            np.zeros((n, kernel.FALL_COLUMNS)))
    inc = KernelIncrement(np.empty(n), np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n))
    part = np.zeros((_mixed.chunk_count(n), _mixed_rows.PARTIAL_SUMS))
    sc = np.array([False, False, True, False, False, False])
    nrm, br, wt = c(cs.normals), c(cs.branch), c(cs.weights)
    law_fn = kernel.law_function(kc, st, inc, out, scratch, defer=True)
    law_sig = kernel.law_signature(kc, st, inc, out, scratch)
    resp = tuple(np.zeros(n) for _ in range(7))
    pass_sig = (types.FunctionType(types.none(*law_sig)), typeof(kc), typeof(nrm), typeof(br), typeof(wt),
                typeof(np.zeros(6)), typeof(sc), typeof(st), typeof(out), typeof(scratch), typeof(inc), typeof(part),
                typeof(resp), types.boolean)
    eval_fn = _mixed.pass_function(False, pass_sig)
    de = np.array([0.0, 0.0, -1e-7, 0.0, a.shear, 0.0])  # a shear step, sigma_zz roughly held
    args = (kc, nrm, br, wt, de, sc, st, out, scratch, inc, part, resp)
    cflat = np.empty(36)
    _passes(1, eval_fn, law_fn, *args)
    h = hashlib.sha1()
    for name, x in zip(out._fields, out):
        if name != "dissipation":
            h.update(np.ascontiguousarray(x).tobytes())
    h.update(part.tobytes())
    falling = float(np.mean(inc.N1 < st.normal_force))
    _laws(1, law_fn, kc, st, inc, out, scratch)
    cargs = (eval_fn, law_fn, *args, cflat, scratch.fall[:, 0].copy())
    k = a.passes
    best = {"pass": np.inf, "law": np.inf, "commit": np.inf}
    for _ in range(a.repeat):
        for label, fn in (("pass", lambda: _passes(k, eval_fn, law_fn, *args)),
                          ("law", lambda: _laws(k, law_fn, kc, st, inc, out, scratch))):
            t0 = time.perf_counter()
            fn()
            best[label] = min(best[label], (time.perf_counter() - t0) / k / n)
    _commits(1, *cargs)
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        _commits(k, *cargs)
        best["commit"] = min(best["commit"], (time.perf_counter() - t0) / k / n)
    print(f"directions {n}, shear increment {a.shear:g}, falling N at {100 * falling:.0f} % of them")
    print(f"ns per contact (best of {a.repeat} x {k}): pass {best['pass'] * 1e9:.1f}, law alone "
          f"{best['law'] * 1e9:.1f}, commit {best['commit'] * 1e9:.1f}")
    print(f"pass outputs hash (dissipation excluded): {h.hexdigest()[:12]}")


if __name__ == "__main__":
    main()

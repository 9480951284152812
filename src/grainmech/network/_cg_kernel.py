r"""Compiled, matrix-free block-Jacobi CG for the relaxed stiffness of a 3D network.

The same iteration as :func:`grainmech.network._solvers.block_cg` (the NumPy reference,
``tests/network/test_network.py`` holds the two to the same tensor), for grains with three
translations and three rotations, but

* the Hessian is never assembled: ``H p = sum_c G_c^T K_c G_c p`` is applied contact by
  contact (Lemaitre & Maloney 2006, Eq. 12; Kruyt & Rothenburg 1998): with
  ``q = (u, theta)`` per grain the contact displacement of A relative to B is

      ``Delta = u_A - u_B + theta_A x r_A - theta_B x r_B``,

  the force ``f = K Delta = ks Delta + (kn - ks) (n . Delta) n`` (seed Eq. 2.20 with the
  full tangential projector), and ``G^T f`` adds ``(f, r_A x f)`` to A and
  ``(-f, -r_B x f)`` to B -- about 50 flops per contact and column instead of a sparse
  product with the assembled ``H`` (six times as many stored numbers, read every
  iteration);
* every right-hand side column is carried through one loop over contacts and one loop
  over grains per iteration (no temporaries), inside one compiled call;
* on large networks (:func:`grainmech.network.relaxed._block_cg`) the grains are numbered
  by reverse Cuthill-McKee and split into as many ranges ("parts") as there are threads;
  the contacts inside a part are applied by that part's thread (no two threads write to
  the same grain), the few contacts between parts afterwards on one thread, and the grain
  passes run in fixed chunks of :data:`_GCH` grains (per-chunk partial sums added in
  order, so they do not depend on the number of threads; ``p . H p`` does, one partial
  sum per part: results differ in round-off between thread counts).

Imported only when numba is installed (the optional extra ``fast``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["hessian_product", "block_inverses", "block_cg3", "block_cg3_parts"]

#: grains per work item of the grain passes (the partial sums are per chunk)
_GCH = 1024


@njit(cache=True, error_model="numpy", fastmath=True)
def _apply_contacts(lo, hi, ci, cj, n, kn, ks, rA, rB, x, out, xHx):  # pragma: no cover - compiled
    """Add ``G_c^T K_c G_c x`` of contacts ``lo <= c < hi`` to ``out`` and ``Delta . f`` to ``xHx``."""
    m = x.shape[2]
    for c in range(lo, hi):
        a = ci[c]
        b = cj[c]
        nx, ny, nz = n[c, 0], n[c, 1], n[c, 2]
        ax, ay, az = rA[c, 0], rA[c, 1], rA[c, 2]
        bx, by, bz = rB[c, 0], rB[c, 1], rB[c, 2]
        s = ks[c]
        t = kn[c] - s
        for k in range(m):
            ta0, ta1, ta2 = x[a, 3, k], x[a, 4, k], x[a, 5, k]
            tb0, tb1, tb2 = x[b, 3, k], x[b, 4, k], x[b, 5, k]
            # Delta = u_A - u_B + theta_A x r_A - theta_B x r_B
            d0 = x[a, 0, k] - x[b, 0, k] + (ta1 * az - ta2 * ay) - (tb1 * bz - tb2 * by)
            d1 = x[a, 1, k] - x[b, 1, k] + (ta2 * ax - ta0 * az) - (tb2 * bx - tb0 * bz)
            d2 = x[a, 2, k] - x[b, 2, k] + (ta0 * ay - ta1 * ax) - (tb0 * by - tb1 * bx)
            dn = t * (nx * d0 + ny * d1 + nz * d2)
            f0 = s * d0 + dn * nx
            f1 = s * d1 + dn * ny
            f2 = s * d2 + dn * nz
            xHx[k] += d0 * f0 + d1 * f1 + d2 * f2
            out[a, 0, k] += f0
            out[a, 1, k] += f1
            out[a, 2, k] += f2
            out[a, 3, k] += ay * f2 - az * f1
            out[a, 4, k] += az * f0 - ax * f2
            out[a, 5, k] += ax * f1 - ay * f0
            out[b, 0, k] -= f0
            out[b, 1, k] -= f1
            out[b, 2, k] -= f2
            out[b, 3, k] -= by * f2 - bz * f1
            out[b, 4, k] -= bz * f0 - bx * f2
            out[b, 5, k] -= bx * f1 - by * f0


@njit(cache=True, error_model="numpy", fastmath=True)
def hessian_product(ci, cj, n, kn, ks, rA, rB, x, out, xHx):  # pragma: no cover - compiled
    """``out = H x`` for ``x`` (P, 6, m): translations ``x[:, :3]``, rotations ``x[:, 3:]``.

    ``ci, cj`` (C,) grains of each contact; ``n`` (C, 3) unit normals; ``kn, ks`` (C,)
    [force/length]; ``rA, rB`` (C, 3) centre-to-contact vectors of A and B [length].
    ``xHx`` (m,) receives ``x_k . (H x)_k = sum_c Delta_c . f_c`` per column.
    """
    out[:] = 0.0
    xHx[:] = 0.0
    _apply_contacts(0, ci.shape[0], ci, cj, n, kn, ks, rA, rB, x, out, xHx)


@njit(cache=True, error_model="numpy")
def block_inverses(D, rel):  # pragma: no cover - compiled
    """Inverses of the symmetric blocks ``D`` (P, b, b) by Cholesky factorisation.

    Returns the inverses and a mask of the blocks whose Cholesky pivot falls to ``rel``
    times their largest diagonal entry or below (singular or nearly so: the caller takes
    their pseudo-inverse instead; their rows of the result are left undefined).
    """
    P, b, _ = D.shape
    out = np.empty_like(D)
    bad = np.zeros(P, dtype=np.bool_)
    L = np.empty((b, b))
    y = np.empty(b)
    for g in range(P):
        dmax = 0.0
        for i in range(b):
            dmax = max(dmax, abs(D[g, i, i]))
        ok = dmax > 0.0
        for j in range(b):
            if not ok:
                break
            acc = D[g, j, j]
            for k in range(j):
                acc -= L[j, k] * L[j, k]
            if acc <= rel * dmax:
                ok = False
                break
            L[j, j] = np.sqrt(acc)
            for i in range(j + 1, b):
                acc = D[g, i, j]
                for k in range(j):
                    acc -= L[i, k] * L[j, k]
                L[i, j] = acc / L[j, j]
        if not ok:
            bad[g] = True
            continue
        for c in range(b):  # column c of D^-1: L y = e_c, L^T x = y
            for i in range(b):
                acc = 1.0 if i == c else 0.0
                for k in range(i):
                    acc -= L[i, k] * y[k]
                y[i] = acc / L[i, i]
            for i in range(b - 1, -1, -1):
                acc = y[i]
                for k in range(i + 1, b):
                    acc -= L[k, i] * out[g, k, c]
                out[g, i, c] = acc / L[i, i]
    return out, bad


def _make(parallel: bool):
    """Block CG compiled serial or parallel (``prange`` over parts and grain chunks).

    A closure over ``rng`` only (as in :mod:`grainmech.driver.affine._fused`): two dispatchers of
    one plain function would share numba's on-disk cache entry, and a closure over other
    dispatchers gets a new cache key in every process. Both give the same bits for the
    same ``gsplit``/``csplit``.
    """
    rng = prange if parallel else range

    def block_cg(ci, cj, n, kn, ks, rA, rB, Minv, rhs, nb, tol, maxiter, predict_after,
                 gsplit, csplit):  # pragma: no cover - compiled
        """Block-Jacobi CG on ``H x = rhs``, all columns at once (columns independent).

        ``Minv`` (P, 6, 6) pseudo-inverses of the diagonal blocks, ``rhs`` (P, 6, m), ``nb``
        (m,) the residual scale per column, ``predict_after`` as in
        :func:`grainmech.network._solvers.block_cg` (0: never stop early). ``H p`` is
        applied part by part: contacts ``csplit[t] <= c < csplit[t + 1]`` join grains
        ``gsplit[t] <= g < gsplit[t + 1]`` only (``t < T``, one thread each); contacts
        from ``csplit[T]`` on join two parts and are applied afterwards, in order, on one
        thread (one part: the whole network). The grain passes (``x += alpha p``, ``r -=
        alpha H p``, ``z_g = Minv_g r_g``, ``r . z``, ``|r|^2``; ``p = z + beta p``) run in
        chunks of :data:`_GCH` grains, their partial sums added in chunk order. Returns
        ``x`` (P, 6, m), the iterations and the largest relative residual.
        """
        P, b, m = rhs.shape
        T = gsplit.shape[0] - 1
        nch = (P + _GCH - 1) // _GCH
        x = np.zeros_like(rhs)
        r = rhs.copy()
        z = np.empty_like(rhs)
        p = np.empty_like(rhs)
        Hp = np.zeros_like(rhs)
        part = np.zeros((T, m))
        prz = np.zeros((nch, m))
        prr = np.zeros((nch, m))
        rz = np.zeros(m)
        rr = np.zeros(m)
        pHp = np.zeros(m)
        alpha = np.zeros(m)
        beta = np.zeros(m)
        it = -1
        res = np.zeros(m)
        while True:
            if it >= 0:
                # Hp = H p
                for t in rng(T):
                    Hp[gsplit[t]:gsplit[t + 1]] = 0.0
                    acc = np.zeros(m)
                    _apply_contacts(csplit[t], csplit[t + 1], ci, cj, n, kn, ks, rA, rB, p, Hp, acc)
                    part[t] = acc
                pHp[:] = 0.0
                for t in range(T):
                    for k in range(m):
                        pHp[k] += part[t, k]
                _apply_contacts(csplit[T], ci.shape[0], ci, cj, n, kn, ks, rA, rB, p, Hp, pHp)
                for k in range(m):
                    alpha[k] = rz[k] / pHp[k] if pHp[k] > 0 else 0.0
            # x += alpha p, r -= alpha Hp, z = Minv r (alpha = 0 at the start)
            for ch in rng(nch):
                for k in range(m):
                    prz[ch, k] = 0.0
                    prr[ch, k] = 0.0
                for g in range(ch * _GCH, min(P, (ch + 1) * _GCH)):
                    for k in range(m):
                        a = alpha[k]
                        if a != 0.0:
                            for i in range(6):
                                x[g, i, k] += a * p[g, i, k]
                                r[g, i, k] -= a * Hp[g, i, k]
                        r0, r1, r2 = r[g, 0, k], r[g, 1, k], r[g, 2, k]
                        r3, r4, r5 = r[g, 3, k], r[g, 4, k], r[g, 5, k]
                        acc_rz = 0.0
                        for i in range(6):
                            zi = (Minv[g, i, 0] * r0 + Minv[g, i, 1] * r1 + Minv[g, i, 2] * r2
                                  + Minv[g, i, 3] * r3 + Minv[g, i, 4] * r4 + Minv[g, i, 5] * r5)
                            z[g, i, k] = zi
                            acc_rz += r[g, i, k] * zi
                        prz[ch, k] += acc_rz
                        prr[ch, k] += r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3 + r4 * r4 + r5 * r5
            rr[:] = 0.0
            for k in range(m):
                acc_rz = 0.0
                for ch in range(nch):
                    acc_rz += prz[ch, k]
                    rr[k] += prr[ch, k]
                beta[k] = acc_rz / rz[k] if (it >= 0 and rz[k] > 0) else 0.0
                rz[k] = acc_rz
            # p = z + beta p (beta = 0 at the start: p = z)
            for ch in rng(nch):
                for q in range(ch * _GCH, min(P, (ch + 1) * _GCH)):
                    for i in range(b):
                        for k in range(m):
                            p[q, i, k] = z[q, i, k] + (beta[k] * p[q, i, k] if it >= 0 else 0.0)
            it += 1
            for k in range(m):
                res[k] = np.sqrt(rr[k]) / nb[k]
            if it >= maxiter or res.max() <= tol:
                break
            if predict_after > 0 and it == predict_after:
                rate = res.max() ** (1.0 / it)
                if rate >= 1.0 or np.log(tol) / np.log(rate) > maxiter:
                    break
        return x, it, res.max()

    return njit(cache=True, error_model="numpy", fastmath=True, parallel=parallel)(block_cg)


#: block CG on one thread (one part) and with a ``prange`` over parts and grain chunks
block_cg3 = _make(False)
block_cg3_parts = _make(True)

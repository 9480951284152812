"""The evaluation pass of the compiled mixed-control loop (:mod:`grainmech.driver.affine._mixed`).

One pass over the contacts in chunks (serial, or a ``prange`` over chunks): the law
update from the last converged state, the Love-Weber stress, the weighted sliding and
open fractions, the dissipation and the Newton Jacobian of the stress-controlled
components; with ``commit``, the committed state, the reported tangent (seed Eq. 2.26)
and the stored energy (``_commit_rows``, ``commit_sums``). ``evaluate_serial`` and
``evaluate_parallel`` are the two compiled passes.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from grainmech.contact.kernel import (
    KernelConstants,
    KernelIncrement,
    KernelOutput,
    KernelScratch,
    KernelState,
)
from grainmech.driver.affine._mixed_rows import (
    FIRST_CLASS,
    INNER,
    PARTIAL_SUMS,
    add_jacobian_sub,
    bcol,
    increment_end,
    love_weber_terms,
    pick,
    stored_energy_term,
)


def _make(parallel: bool):
    """Evaluation pass and segment driver, serial or with a ``prange`` over chunks."""
    rng = prange if parallel else range

    def _evaluate(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, commit):
        # trial update of every contact from the converged state ``st`` by the strain
        # increment ``de``; per-chunk sums into ``part``; returns the first contact the
        # law could not advance (-1: none). With ``commit``: accept the last trial
        # instead (_commit_rows, per chunk; commit_sums adds the chunks' sums)
        n = normals.shape[0]
        nch = part.shape[0]          # chunk_count(n)
        size = (n + nch - 1) // nch  # rows per chunk (the last ones may be shorter or empty)
        (law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp, maxrev, hcoef, gcoef,
         glx, glw, sph, k8) = kc
        # arrays as plain values into the (parallel) loop: writes through a named tuple's
        # fields inside a prange are lost; the tuples are rebuilt inside
        i_dn, i_dt, i_N1, i_rad0, i_rad1 = inc
        s_a, s_N, s_T, s_e, s_d, s_k, s_P, s_en = st
        (o_a, o_N, o_T, o_e, o_s, o_k, o_P, o_sl, o_di, o_ks, o_ksp, o_ktn, o_kn, o_op, o_td,
         o_ta) = out
        c_tp, c_dp, c_fl, c_fa = scratch
        r_kn, r_ks, r_ksp, r_ktn, r_di, r_sl, r_op = resp
        exx = de[0]
        eyy = de[1]
        ezz = de[2]
        eyz = 0.5 * de[3]
        exz = 0.5 * de[4]
        exy = 0.5 * de[5]
        bad_c = np.full(nch, -1, dtype=np.int64)
        sidx = np.zeros(6, dtype=np.int64)  # the stress-controlled components
        ns = 0
        for q in range(6):
            if sc[q]:
                sidx[ns] = q
                ns += 1
        for ch in rng(nch):
            lo = ch * size
            hi = min(n, lo + size)
            kcc = KernelConstants(law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp,
                                  maxrev, hcoef, gcoef, glx, glw, sph, k8)
            st_c = KernelState(s_a, s_N, s_T, s_e, s_d, s_k, s_P, s_en)
            inc_c = KernelIncrement(i_dn, i_dt, i_N1, i_rad0, i_rad1)
            out_c = KernelOutput(o_a, o_N, o_T, o_e, o_s, o_k, o_P, o_sl, o_di, o_ks, o_ksp, o_ktn, o_kn, o_op,
                                 o_td, o_ta)
            scr_c = KernelScratch(c_tp, c_dp, c_fl, c_fa)
            if commit:
                prow = part[ch]
                for q in range(38):
                    prow[q] = 0.0
                _commit_rows(lo, hi, law_fn, kcc, normals, branch, weights, st_c, out_c,
                             (r_kn, r_ks, r_ksp, r_ktn, r_di, r_sl, r_op), inc_c, scr_c, prow)
                continue
            # (i_rad0, the start radius, is that of the converged state: start_radii, _commit_rows)
            for i in range(lo, hi):
                (i_dn[i], i_dt[i, 0], i_dt[i, 1], i_dt[i, 2], i_N1[i],
                 i_rad1[i]) = increment_end(exx, eyy, ezz, eyz, exz, exy, normals[i, 0], normals[i, 1],
                                             normals[i, 2], branch[i, 0], branch[i, 1], branch[i, 2],
                                             s_a[i], linear, kn_lin, E, R)
                c_fl[i] = 0
            law_fn(lo, hi, kcc, st_c, inc_c, out_c, scr_c)  # kernel.rows (kernel.law_function)
            for i in range(lo, hi):
                if c_fl[i] != 0 and bad_c[ch] < 0:
                    bad_c[ch] = i
            for q in range(PARTIAL_SUMS):
                part[ch, q] = 0.0
            if bad_c[ch] < 0:
                prow = part[ch]
                for i in range(lo, hi):
                    w = weights[i]
                    nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
                    lx, ly, lz = branch[i, 0], branch[i, 1], branch[i, 2]
                    # Love-Weber, symmetric part (seed Eq. 2.6)
                    tt = love_weber_terms(o_N[i], o_T[i, 0], o_T[i, 1], o_T[i, 2], w, nx, ny, nz, lx, ly, lz)
                    for q in range(6):
                        prow[q] += tt[q]
                    if o_sl[i]:
                        prow[42] += w
                    if o_op[i]:
                        prow[43] += w
                    prow[44] += w * o_di[i]
                    # Jacobian rows/columns sc: B^T K B with the law's step tangent
                    add_jacobian_sub(prow, 6, sidx, ns, w, o_kn[i], o_ta, o_td, i, nx, ny, nz, lx, ly, lz)
        for ch in range(nch):
            if bad_c[ch] >= 0:
                return bad_c[ch]
        return -1  # (a commit never sets bad_c)

    # called by the segment loop through its C-callable wrapper (a first-class function)
    return njit(parallel=parallel, **FIRST_CLASS)(_evaluate)


@njit(**INNER)
def _commit_rows(lo, hi, law_fn, kc, normals, branch, weights, st, out, resp, inc, scratch, prow):
    # accept the trial state of rows lo <= i < hi: out -> st (dissipated energy
    # accumulated, with the falling-N dissipation the law deferred to here added first:
    # law_fn(-lo - 1, hi, ...), kernel.rows), the response kept in ``resp``; adds to
    # ``prow`` the reported tangent's upper triangle (prow[6 q + q2], q <= q2; seed
    # Eq. 2.26, kn n n + ks (I - n n), the laws' kn, ks clipped at 0), the stored energy
    # (prow[36]) and the weighted dissipation of the step (prow[37]).
    # inc.rad0 becomes the start radius of the new state: start_radius(a1, N1) is
    # hertz_radius(N1) = rad1 of the accepted evaluation when a1 > 0 and N1 > 0, else
    # hertz_radius(0) = 0 (the same bits as computing it again)
    linear, R, Gs, ks_lin = kc.linear, kc.R, kc.Gs, kc.ks_lin
    nrev = st.reversals.shape[1]
    law_fn(-lo - 1, hi, kc, st, inc, out, scratch)
    for i in range(lo, hi):
        st.approach[i] = out.approach[i]
        st.normal_force[i] = out.normal_force[i]
        for c in range(3):
            st.tangential_force[i, c] = out.tangential_force[i, c]
            st.axis[i, c] = out.axis[i, c]
        st.direction[i] = out.direction[i]
        st.depth[i] = out.depth[i]
        for c in range(nrev):
            st.reversals[i, c] = out.reversals[i, c]
        prow[37] += weights[i] * out.dissipation[i]
        st.dissipated_energy[i] += out.dissipation[i]
        if not linear:
            inc.rad0[i] = inc.rad1[i] if (out.approach[i] > 0.0 and out.normal_force[i] > 0.0) else 0.0
        resp[0][i] = out.kn[i]
        resp[1][i] = out.ks[i]
        resp[2][i] = out.ks_perp[i]
        resp[3][i] = out.ktn[i]
        resp[4][i] = out.dissipation[i]
        resp[5][i] = 1.0 if out.sliding[i] else 0.0
        resp[6][i] = 1.0 if out.open[i] else 0.0
        w = weights[i]
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        lx, ly, lz = branch[i, 0], branch[i, 1], branch[i, 2]
        kn = out.kn[i] if out.kn[i] > 0.0 else 0.0
        ks = out.ks[i] if out.ks[i] > 0.0 else 0.0
        # u = B^T n, the tangent w B^T (ks I + (kn - ks) n n) B
        u0 = nx * lx
        u1 = ny * ly
        u2 = nz * lz
        u3 = 0.5 * (ny * lz + nz * ly)
        u4 = 0.5 * (nx * lz + nz * lx)
        u5 = 0.5 * (nx * ly + ny * lx)
        cn = w * (kn - ks)
        cs = w * ks
        for q in range(6):
            uq = pick(q, u0, u1, u2, u3, u4, u5)
            bq0, bq1, bq2 = bcol(q, lx, ly, lz)
            for q2 in range(q, 6):
                uq2 = pick(q2, u0, u1, u2, u3, u4, u5)
                c0, c1, c2 = bcol(q2, lx, ly, lz)
                btb = bq0 * c0 + bq1 * c1 + bq2 * c2
                prow[6 * q + q2] += cs * btb + cn * uq * uq2
        prow[36] += w * stored_energy_term(out.normal_force[i], out.approach[i], out.tangential_force[i, 0],
                                           out.tangential_force[i, 1], out.tangential_force[i, 2], linear,
                                           ks_lin, R, Gs)


@njit(**INNER)
def commit_sums(part, Cout):
    """Sum the commit's per-chunk sums, in chunk order.

    The reported tangent into ``Cout`` (36,), its lower triangle mirrored; returns
    (stored energy, weighted dissipation).
    """
    for q in range(36):
        Cout[q] = 0.0
    wst = 0.0
    wdi = 0.0
    for ch in range(part.shape[0]):
        for q in range(6):
            for q2 in range(q, 6):
                Cout[6 * q + q2] += part[ch, 6 * q + q2]
        wst += part[ch, 36]
        wdi += part[ch, 37]
    for q in range(6):
        for q2 in range(q):
            Cout[6 * q + q2] = Cout[6 * q2 + q]
    return wst, wdi


evaluate_serial = _make(False)
evaluate_parallel = _make(True)

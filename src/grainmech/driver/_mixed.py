r"""Compiled step/Newton loop of a mixed-control path segment (one compiled call).

:func:`grainmech.driver.solver.run` solves each step of a path with stress-controlled
components by Newton iterations on those components (``solver._solve``), halving a step
that does not converge (``solver._subdivided``). This module runs *the same* loop --
same predictor, same acceptance rules (``rtol``; ``rtol_accept`` on a two-cycle or
after ``max_iter``), same subdivision, same failure causes -- for every step of a
segment of constant control mask inside one compiled function, so that no Python runs
between law evaluations. Per evaluation, one pass over the contacts (chunks of
``_CH``, a ``prange`` from :data:`PARALLEL_ROWS` rows):

* kinematics, seed Eq. 2.13 (``delta = d eps . l``) and the normal law at the step's
  end (seed Eq. 3.6, 3.2), exactly as :mod:`grainmech.driver._fused`;
* the compiled law update :func:`grainmech.contact.kernel.rows` from the last converged
  state (trial increment, no drift), passed in as a first-class function
  (:func:`grainmech.contact.kernel.law_function`: compiled once for the law at hand, not
  linked into the pass and the loop);
* the Love-Weber stress (seed Eq. 2.6, symmetric part), the weighted sliding and open
  fractions and the dissipation;
* the Newton Jacobian rows and columns of the stress-controlled components,
  ``sum_c w_c B_c^T K_c B_c`` with the law's step tangent
  ``K = (kn n + t_alpha) n^T + t_delta (I - n n)`` (consistent with the update,
  normal-tangential coupling ``mu dN (1 - theta)`` of seed Eq. 3.11 included;
  :func:`grainmech.driver.point.consistent_tangent` is the NumPy form).

After a converged (sub)step one more pass (the same function with ``commit``, chunk by
chunk, threaded like the evaluations) commits the state and assembles the reported
tangent (seed Eq. 2.26 with the laws' ``kn``, ``ks``, full tangential projector) and the
stored energy. The loop takes the pass (serial or parallel) and the law as first-class functions, so
the three compile separately, and on an empty cache in two processes at once
(:func:`_compile`). The NumPy step loop stays the reference (``SolverOptions(compiled=False)``);
``tests/test_driver_mixed.py`` holds the two to the same success, stresses and Newton
iterations.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange

from grainmech.contact.geometry import (
    hertz_energy,
    hertz_force,
    hertz_radius,
    hertz_radius_from_approach,
    mindlin_kt0,
    spring_energy,
)
from grainmech.contact.kernel import (
    KernelConstants,
    KernelIncrement,
    KernelOutput,
    KernelScratch,
    KernelState,
)
from grainmech.driver._fold import fold, path_mirrors, unfold

__all__ = ["mixed_segment", "add_step_jacobian", "contact_increment", "love_weber_terms", "stored_energy_term",
           "FAIL_SINGULAR", "FAIL_NOT_FINITE", "FAIL_NO_CONVERGENCE", "FAIL_LAW"]

_CH = 128  # at most this many contacts per chunk (work item of the prange)
_CH_GROUP = 8  # the number of chunks is a multiple of this (see chunk_count)
#: rows from which the evaluation pass runs on numba's threads (with more than one): on
#: 2 cores the threaded run took the serial one's time at 128 rows and was 1.35-1.84x
#: faster from 256 to 1475 rows (random sets, 2 cycles of simple shear with sigma_zz
#: held; ``docs/performance.md``, "Mixed-control driver")
PARALLEL_ROWS = 256
# functions that allocate nothing: compiled without numba's reference counting (atomic
# increments of the arrays they are passed, per contact)
_NO_NRT: dict[str, Any] = {"cache": True, "error_model": "numpy", "_nrt": False, "no_cpython_wrapper": True,
                           "no_cfunc_wrapper": True}
# functions called only from compiled code: no Python or C wrapper
_INNER: dict[str, Any] = {"cache": True, "error_model": "numpy", "no_cpython_wrapper": True, "no_cfunc_wrapper": True}
# functions passed to compiled code as first-class functions: only the C wrapper
_FIRST_CLASS: dict[str, Any] = {"cache": True, "error_model": "numpy", "no_cpython_wrapper": True}
# functions called from Python only: no C wrapper
_PY_ONLY: dict[str, Any] = {"cache": True, "error_model": "numpy", "no_cfunc_wrapper": True}
_NP = 6 + 36 + 3  # per-chunk partial sums: stress, Jacobian, (sliding, open, dissipation) weights

#: failure causes reported by the compiled loop (``info[1]``)
FAIL_SINGULAR = 1        # Newton Jacobian singular (condition number in finfo[0])
FAIL_NOT_FINITE = 2      # Newton update not finite
FAIL_NO_CONVERGENCE = 3  # max_iter iterations, no iterate within rtol_accept
FAIL_LAW = 4             # the law could not advance a contact (index in info[3], flag in info[4])


@njit(**_INNER)
def _pick(q, u0, u1, u2, u3, u4, u5):
    """The ``q``-th of six scalars (a register-held 6-vector)."""
    if q == 0:
        return u0
    if q == 1:
        return u1
    if q == 2:
        return u2
    if q == 3:
        return u3
    if q == 4:
        return u4
    return u5


@njit(**_INNER)
def _bcol(q, lx, ly, lz):
    """Column ``q`` of ``B``, ``(B[0, q], B[1, q], B[2, q])``: relative displacement per unit engineering strain ``q``.

    Seed Eq. 2.13, ``delta_i = eps_ij l_j``, library order xx, yy, zz, yz, xz, xy. (One
    function returning the column, not one per entry: numba compiled an entry function
    once per literal row index.)
    """
    if q == 0:
        return lx, 0.0, 0.0
    if q == 1:
        return 0.0, ly, 0.0
    if q == 2:
        return 0.0, 0.0, lz
    if q == 3:
        return 0.0, 0.5 * lz, 0.5 * ly
    if q == 4:
        return 0.5 * lz, 0.0, 0.5 * lx
    return 0.5 * ly, 0.5 * lx, 0.0


@njit(**_NO_NRT)
def _step_tangent3(kn, t_alpha, t_delta, i, nx, ny, nz):
    """Entries (row by row) of ``K = (kn n + t_alpha) n^T + t_delta (I - n n)`` of contact ``i``.

    The law's step (consistent) tangent of ``f = N n + T`` with respect to the relative
    displacement (seed Eq. 2.13, 2.26); an open contact (``kn <= 0``) has no normal part.
    """
    knc = kn if kn > 0.0 else 0.0
    K00 = K01 = K02 = K10 = K11 = K12 = K20 = K21 = K22 = 0.0
    for a in range(3):
        ha = knc * (nx if a == 0 else (ny if a == 1 else nz)) + t_alpha[i, a]
        tn = t_delta[i, a, 0] * nx + t_delta[i, a, 1] * ny + t_delta[i, a, 2] * nz
        k0 = (ha - tn) * nx + t_delta[i, a, 0]
        k1 = (ha - tn) * ny + t_delta[i, a, 1]
        k2 = (ha - tn) * nz + t_delta[i, a, 2]
        if a == 0:
            K00, K01, K02 = k0, k1, k2
        elif a == 1:
            K10, K11, K12 = k0, k1, k2
        else:
            K20, K21, K22 = k0, k1, k2
    return K00, K01, K02, K10, K11, K12, K20, K21, K22


@njit(**_NO_NRT)
def add_step_jacobian(acc, off, rowmask, colmask, w, kn, t_alpha, t_delta, i, nx, ny, nz, lx, ly, lz):
    """Add ``w B^T K B`` (rows ``rowmask``, columns ``colmask``) to ``acc[off + 6 q + r]``.

    ``K = (kn n + t_alpha) n^T + t_delta (I - n n)``: the law's step (consistent) tangent
    of ``f = N n + T`` with respect to the relative displacement ``delta = B d eps``
    (seed Eq. 2.13, 2.26; :func:`grainmech.driver.point.consistent_tangent`).
    """
    K00, K01, K02, K10, K11, K12, K20, K21, K22 = _step_tangent3(kn, t_alpha, t_delta, i, nx, ny, nz)
    for r in range(6):
        if colmask[r]:
            b0, b1, b2 = _bcol(r, lx, ly, lz)
            g0 = w * (K00 * b0 + K01 * b1 + K02 * b2)   # w K B[:, r]
            g1 = w * (K10 * b0 + K11 * b1 + K12 * b2)
            g2 = w * (K20 * b0 + K21 * b1 + K22 * b2)
            for q in range(6):
                if rowmask[q]:
                    c0, c1, c2 = _bcol(q, lx, ly, lz)
                    acc[off + 6 * q + r] += c0 * g0 + c1 * g1 + c2 * g2


@njit(**_NO_NRT)
def _add_jacobian_sub(acc, off, idx, ns, w, kn, t_alpha, t_delta, i, nx, ny, nz, lx, ly, lz):
    """:func:`add_step_jacobian` with rows = columns = ``idx[:ns]`` (the same values).

    The stress-controlled components listed once per pass instead of six mask tests
    of the rows and of the columns per contact.
    """
    K00, K01, K02, K10, K11, K12, K20, K21, K22 = _step_tangent3(kn, t_alpha, t_delta, i, nx, ny, nz)
    for rr in range(ns):
        r = idx[rr]
        b0, b1, b2 = _bcol(r, lx, ly, lz)
        g0 = w * (K00 * b0 + K01 * b1 + K02 * b2)   # w K B[:, r]
        g1 = w * (K10 * b0 + K11 * b1 + K12 * b2)
        g2 = w * (K20 * b0 + K21 * b1 + K22 * b2)
        for qq in range(ns):
            q = idx[qq]
            c0, c1, c2 = _bcol(q, lx, ly, lz)
            acc[off + 6 * q + r] += c0 * g0 + c1 * g1 + c2 * g2


@njit(**_INNER)
def _copy_state(src, src_resp, dst, dst_resp):
    """Copy the state arrays ``src`` -> ``dst`` (KernelState layout) and the response rows.

    Element loops over C-contiguous arrays (a slice assignment compiles numba's
    shape-checking machinery, seconds of the first run's compilation).
    """
    n = src.approach.shape[0]
    dim = src.tangential_force.shape[1]
    nrev = src.reversals.shape[1]
    for i in range(n):
        dst.approach[i] = src.approach[i]
        dst.normal_force[i] = src.normal_force[i]
        dst.direction[i] = src.direction[i]
        dst.depth[i] = src.depth[i]
        dst.dissipated_energy[i] = src.dissipated_energy[i]
        for c in range(dim):
            dst.tangential_force[i, c] = src.tangential_force[i, c]
            dst.axis[i, c] = src.axis[i, c]
        for c in range(nrev):
            dst.reversals[i, c] = src.reversals[i, c]
        for f in range(len(src_resp)):
            dst_resp[f][i] = src_resp[f][i]


@njit(**_INNER)
def contact_increment(exx, eyy, ezz, eyz, exz, exy, nx, ny, nz, lx, ly, lz, a0, N0, linear, kn_lin, E, R):
    """One contact's step input from a strain increment.

    Tensor components, compression positive: ``delta = d eps . l`` split into ``d_n`` and ``d_t`` (seed Eq. 2.13), the
    normal force at the step end (seed Eq. 3.6, or ``kn alpha``) and the Hertz contact
    radii at its start and end (seed Eq. 3.2). Returns ``(d_n, dtx, dty, dtz, N1, rad0, rad1)``.
    """
    d_n, dtx, dty, dtz, N1, rad1 = _increment_end(exx, eyy, ezz, eyz, exz, exy, nx, ny, nz, lx, ly, lz, a0,
                                                  linear, kn_lin, E, R)
    if linear:
        return d_n, dtx, dty, dtz, N1, N1, N1
    return d_n, dtx, dty, dtz, N1, start_radius(a0, N0, E, R), rad1


@njit(**_INNER)
def start_radius(a0, N0, E, R):
    """Hertz contact radius at the start of a step (seed Eq. 3.2; 0 for an open contact)."""
    Nc = N0 if (a0 > 0.0 and N0 > 0.0) else 0.0
    return hertz_radius(Nc, E, R)


@njit(**_INNER)
def _increment_end(exx, eyy, ezz, eyz, exz, exy, nx, ny, nz, lx, ly, lz, a0, linear, kn_lin, E, R):
    """:func:`contact_increment` without the radius at the step's start: ``(d_n, dtx, dty, dtz, N1, rad1)``.

    The mixed-control pass keeps the start radius of the converged state (it changes only
    when a step is committed) instead of taking its cube root at every evaluation.
    """
    dx = exx * lx + exy * ly + exz * lz
    dy = exy * lx + eyy * ly + eyz * lz
    dz = exz * lx + eyz * ly + ezz * lz
    d_n = dx * nx + dy * ny + dz * nz
    a1 = a0 + d_n
    ap = a1 if a1 > 0.0 else 0.0
    if linear:
        N1 = kn_lin * ap
        return d_n, dx - d_n * nx, dy - d_n * ny, dz - d_n * nz, N1, N1
    N1 = hertz_force(ap, E, R)
    return d_n, dx - d_n * nx, dy - d_n * ny, dz - d_n * nz, N1, hertz_radius(N1, E, R)


@njit(**_NO_NRT)
def _start_radii(linear, E, R, approach, normal_force, rad0):
    """``rad0`` of the converged state (:func:`start_radius`; unused for linear springs)."""
    for i in range(approach.shape[0]):
        rad0[i] = 0.0 if linear else start_radius(approach[i], normal_force[i], E, R)


@njit(**_INNER)
def love_weber_terms(N, tx, ty, tz, w, nx, ny, nz, lx, ly, lz):
    """One contact's Love-Weber stress terms ``w sym(f (x) l)``, ``f = N n + T``.

    Seed Eq. 2.6, as (xx, yy, zz, yz, xz, xy).
    """
    fx = (N * nx + tx) * w
    fy = (N * ny + ty) * w
    fz = (N * nz + tz) * w
    return (fx * lx, fy * ly, fz * lz, 0.5 * (fy * lz + fz * ly), 0.5 * (fx * lz + fz * lx),
            0.5 * (fx * ly + fy * lx))


@njit(**_PY_ONLY)
def _solve_small(A, b):
    """Solve ``A x = b`` for a small dense (n, n) ``A`` (n <= 6); ``A`` and ``b`` are overwritten.

    Gaussian elimination with partial pivoting (the algorithm of LAPACK's ``dgesv``),
    written out because ``np.linalg.solve`` costs seconds of numba compilation on the
    first run. Returns ``(x, ok)``; ``ok`` is False for an exactly zero pivot (LAPACK's
    ``info > 0``, ``np.linalg.solve`` raises then).
    """
    n = A.shape[0]
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        if A[p, k] == 0.0:
            return b, False
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, n):
            f = A[i, k] / A[k, k]
            for j in range(k + 1, n):
                A[i, j] -= f * A[k, j]
            b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for j in range(k + 1, n):
            acc -= A[k, j] * b[j]
        b[k] = acc / A[k, k]
    return b, True


@njit(**_PY_ONLY)
def _cond2(J):
    """2-norm condition number ``s_max / s_min`` of a small finite (n, n) matrix (n <= 6).

    As ``np.linalg.cond(J)`` (``inf`` for a singular ``J``), with the singular values by
    one-sided Jacobi rotations (Hestenes 1958; Demmel & Veselic 1992: high relative
    accuracy, also for the smallest one), written out because numba's SVD costs a second
    of compilation on the first run.
    """
    n = J.shape[0]
    U = J.copy()
    for _sweep in range(60):
        rotated = False
        for p in range(n - 1):
            for q in range(p + 1, n):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for i in range(n):
                    alpha += U[i, p] * U[i, p]
                    beta += U[i, q] * U[i, q]
                    gamma += U[i, p] * U[i, q]
                if gamma == 0.0 or abs(gamma) <= 1e-16 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for i in range(n):
                    up = U[i, p]
                    uq = U[i, q]
                    U[i, p] = c * up - s * uq
                    U[i, q] = s * up + c * uq
        if not rotated:
            break
    smax = 0.0
    smin = math.inf
    for j in range(n):
        sj = 0.0
        for i in range(n):
            sj += U[i, j] * U[i, j]
        sj = math.sqrt(sj)
        smax = max(smax, sj)
        smin = min(smin, sj)
    return smax / smin if smin > 0.0 else math.inf


@njit(**_INNER)
def _reduce(part, sig, jac, sym):
    """Sum the per-chunk partial sums.

    Stress into ``sig`` (6,), Jacobian into ``jac`` (6, 6), each component times its
    factor in ``sym`` (42,: 1, or 0 for a component a folding's group does not leave
    invariant, :attr:`grainmech.driver._fold.Folding.sym`); returns the (sliding, open,
    dissipation) weighted sums.
    """
    sig[:] = 0.0
    jac[:, :] = 0.0
    s_sl = 0.0
    s_op = 0.0
    s_di = 0.0
    for ch in range(part.shape[0]):
        for q in range(6):
            sig[q] += part[ch, q]
        for q in range(36):
            jac[q // 6, q % 6] += part[ch, 6 + q]
        s_sl += part[ch, 42]
        s_op += part[ch, 43]
        s_di += part[ch, 44]
    for q in range(6):
        sig[q] *= sym[q]
    for q in range(36):
        jac[q // 6, q % 6] *= sym[6 + q]
    return s_sl, s_op, s_di


@njit(**_INNER)
def stored_energy_term(N, alpha, tx, ty, tz, linear, ks_lin, R, Gs):
    """Elastic energy held by one contact, as :meth:`ContactLaw.stored_energy`.

    The normal law's ``int N d alpha`` (seed Eq. 3.6, or ``N alpha/2``) plus ``|T|^2 / (2 kt0)``.
    """
    ap = alpha if alpha > 0.0 else 0.0
    T2 = tx * tx + ty * ty + tz * tz
    if linear:
        en_n = spring_energy(N, ap)
        kt0 = ks_lin if N > 0.0 else 0.0
    else:
        en_n = hertz_energy(N, ap)
        kt0 = mindlin_kt0(hertz_radius_from_approach(ap, R), Gs)
    return en_n + (T2 / (2.0 * kt0) if kt0 > 0.0 else 0.0)


def _make(parallel: bool):
    """Evaluation pass and segment driver, serial or with a ``prange`` over chunks."""
    rng = prange if parallel else range

    def _evaluate(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, commit):
        # trial update of every contact from the converged state ``st`` by the strain
        # increment ``de``; per-chunk sums into ``part``; returns the first contact the
        # law could not advance (-1: none). With ``commit``: accept the last trial
        # instead (_commit_rows, per chunk; _commit_sums adds the chunks' sums)
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
            # (i_rad0, the start radius, is that of the converged state: _start_radii, _commit_rows)
            for i in range(lo, hi):
                (i_dn[i], i_dt[i, 0], i_dt[i, 1], i_dt[i, 2], i_N1[i],
                 i_rad1[i]) = _increment_end(exx, eyy, ezz, eyz, exz, exy, normals[i, 0], normals[i, 1],
                                             normals[i, 2], branch[i, 0], branch[i, 1], branch[i, 2],
                                             s_a[i], linear, kn_lin, E, R)
                c_fl[i] = 0
            law_fn(lo, hi, kcc, st_c, inc_c, out_c, scr_c)  # kernel.rows (kernel.law_function)
            for i in range(lo, hi):
                if c_fl[i] != 0 and bad_c[ch] < 0:
                    bad_c[ch] = i
            for q in range(_NP):
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
                    _add_jacobian_sub(prow, 6, sidx, ns, w, o_kn[i], o_ta, o_td, i, nx, ny, nz, lx, ly, lz)
        for ch in range(nch):
            if bad_c[ch] >= 0:
                return bad_c[ch]
        return -1  # (a commit never sets bad_c)

    # called by the segment loop through its C-callable wrapper (a first-class function)
    return njit(parallel=parallel, **_FIRST_CLASS)(_evaluate)


@njit(**_INNER)
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
            uq = _pick(q, u0, u1, u2, u3, u4, u5)
            bq0, bq1, bq2 = _bcol(q, lx, ly, lz)
            for q2 in range(q, 6):
                uq2 = _pick(q2, u0, u1, u2, u3, u4, u5)
                c0, c1, c2 = _bcol(q2, lx, ly, lz)
                btb = bq0 * c0 + bq1 * c1 + bq2 * c2
                prow[6 * q + q2] += cs * btb + cn * uq * uq2
        prow[36] += w * stored_energy_term(out.normal_force[i], out.approach[i], out.tangential_force[i, 0],
                                           out.tangential_force[i, 1], out.tangential_force[i, 2], linear,
                                           ks_lin, R, Gs)


@njit(**_INNER)
def _commit_sums(part, Cout):
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


def _segment(eval_fn, law_fn, kc, normals, branch, weights, sc, incs, stress0, strain0, C0, t_stress0, t_strain0,
             rtol, rtol_accept, max_iter, max_depth, st, out, scratch, inc, part, resp, bk_st, bk_resp,
             rec_strain, rec_stress, rec_tan, rec_scal, rec_int, info, finfo, sym):
    # the step/Newton loop of a segment; eval_fn is the serial or the parallel evaluation
    # pass and law_fn the law (first-class functions: pass_function, kernel.law_function)
    # rec_scal[k] = (sliding, open, dissipation, work, stored); rec_int[k] = (substeps,
    # iterations); info = (steps done, cause, depth reached, contact, flag, loose count);
    # finfo = (condition or residual, tolerance, sliding, open); sym: Folding.sym (42,)
    m = incs.shape[0]
    ns = 0
    for q in range(6):
        if sc[q]:
            ns += 1
    idx = np.empty(ns, dtype=np.int64)
    jdx = np.empty(6 - ns, dtype=np.int64)
    a = 0
    b = 0
    for q in range(6):
        if sc[q]:
            idx[a] = q
            a += 1
        else:
            jdx[b] = q
            b += 1
    stress = stress0.copy()
    strain = strain0.copy()
    C = C0.copy()
    t_stress = t_stress0  # advanced in place (the caller continues from them)
    t_strain = t_strain0
    Cflat = np.empty(36)
    jac = np.zeros((6, 6))
    sig = np.zeros(6)
    hist = np.zeros(max_iter + 1)
    best_de = np.zeros(6)
    de = np.zeros(6)
    # substep stack (depth first): strain increment, stress targets at start/end, depth
    sk_d = np.zeros((max_depth + 2, 6))
    sk_t0 = np.zeros((max_depth + 2, 6))
    sk_t1 = np.zeros((max_depth + 2, 6))
    sk_dep = np.zeros(max_depth + 2, dtype=np.int64)
    n_loose = 0
    _start_radii(kc.linear, kc.E, kc.R, st.approach, st.normal_force, inc.rad0)
    for k in range(m):
        new_ts = np.empty(6)
        new_te = np.empty(6)
        for q in range(6):
            new_ts[q] = t_stress[q] + incs[k, q] if sc[q] else stress[q]
            new_te[q] = strain[q] if sc[q] else t_strain[q] + incs[k, q]
        nsk = 1
        for q in range(6):
            sk_d[0, q] = 0.0 if sc[q] else new_te[q] - strain[q]
            sk_t0[0, q] = stress[q] if sc[q] else 0.0
            sk_t1[0, q] = new_ts[q] if sc[q] else 0.0
        sk_dep[0] = 0
        n_sub = 0
        n_it = 0
        diss = 0.0
        work = 0.0
        wsl = 0.0
        wop = 0.0
        wst = 0.0
        backed = False
        while nsk > 0:
            nsk -= 1
            dep = sk_dep[nsk]
            d_strain = sk_d[nsk].copy()
            t0 = sk_t0[nsk].copy()
            target = sk_t1[nsk].copy()
            # ---- solver._solve: one (sub)step of Newton iterations
            cause = 0
            for q in range(6):
                de[q] = 0.0 if sc[q] else d_strain[q]
            scale = 0.0
            for q in range(6):
                scale = max(scale, abs(stress[q]))
            ts = 0.0
            for a in range(ns):
                ts = max(ts, abs(target[idx[a]]))
            scale = max(scale, ts)
            if scale == 0.0:
                cm = 0.0
                dm = 0.0
                for q in range(36):
                    cm = max(cm, abs(C[q // 6, q % 6]))
                for q in range(6):
                    dm = max(dm, abs(de[q]))
                scale = cm * dm
                if scale == 0.0:
                    scale = 1.0
            tol = rtol * scale
            loose = rtol_accept * scale
            if ns > 0:
                A = np.empty((ns, ns))
                rhs = np.empty(ns)
                for a in range(ns):
                    acc = target[idx[a]] - stress[idx[a]]
                    for b in range(6 - ns):
                        acc -= C[idx[a], jdx[b]] * de[jdx[b]]
                    rhs[a] = acc
                    for b in range(ns):
                        A[a, b] = C[idx[a], idx[b]]
                x, ok = _solve_small(A, rhs)  # singular predictor: start from zero
                for a in range(ns):
                    de[idx[a]] = x[a] if ok else 0.0
                fin = True
                for q in range(6):
                    if not math.isfinite(de[q]):
                        fin = False
                if not fin:
                    for a in range(ns):
                        de[idx[a]] = 0.0
            have_best = False
            best_r = 0.0
            nh = 0
            it_done = 0
            loose_acc = False
            rmax = 0.0
            for it in range(1, max_iter + 1):
                bad = eval_fn(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, False)
                if bad >= 0:
                    cause = FAIL_LAW
                    info[3] = bad
                    info[4] = scratch.flags[bad]
                    break
                s_sl, s_op, s_di = _reduce(part, sig, jac, sym)
                rmax = 0.0
                for a in range(ns):
                    rmax = max(rmax, abs(sig[idx[a]] - target[idx[a]]))
                if rmax <= loose:
                    if rmax <= tol:
                        it_done = it
                        break
                    if (not have_best) or rmax < best_r:
                        have_best = True
                        best_r = rmax
                        for q in range(6):
                            best_de[q] = de[q]
                    if nh >= 2 and abs(rmax - hist[nh - 2]) <= 1e-6 * rmax:  # two-cycle at a tie
                        it_done = it
                        loose_acc = True
                        break
                hist[nh] = rmax
                nh += 1
                J = np.empty((ns, ns))
                r = np.empty(ns)
                for a in range(ns):
                    r[a] = sig[idx[a]] - target[idx[a]]
                    for b in range(ns):
                        J[a, b] = jac[idx[a], idx[b]]
                jfin = True
                for a in range(ns):
                    for b in range(ns):
                        if not math.isfinite(J[a, b]):
                            jfin = False
                cond = _cond2(J) if jfin else np.nan
                if not math.isfinite(cond) or cond > 1e13:
                    cause = FAIL_SINGULAR
                    finfo[0] = cond
                    break
                x, _ = _solve_small(J, r)  # not singular (condition checked)
                fin = True
                for a in range(ns):
                    de[idx[a]] = de[idx[a]] - x[a]
                for q in range(6):
                    if not math.isfinite(de[q]):
                        fin = False
                if not fin:
                    cause = FAIL_NOT_FINITE
                    break
            if cause == 0 and it_done == 0:  # max_iter iterations
                if have_best:
                    it_done = max_iter
                    loose_acc = True
                else:
                    cause = FAIL_NO_CONVERGENCE
                    finfo[0] = rmax
                    finfo[1] = tol
            if cause == 0 and loose_acc and best_r < rmax:
                # the best iterate is not the last one: evaluate it again (same state)
                for q in range(6):
                    de[q] = best_de[q]
                eval_fn(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, False)
                s_sl, s_op, s_di = _reduce(part, sig, jac, sym)
            if cause != 0:
                wtot = 0.0
                for i in range(weights.shape[0]):
                    wtot += weights[i]
                finfo[2] = s_sl / wtot if (wtot > 0.0 and cause != FAIL_LAW) else 0.0
                finfo[3] = s_op / wtot if (wtot > 0.0 and cause != FAIL_LAW) else 0.0
                if dep >= max_depth:
                    if backed:  # substeps of this step were committed: back to its start
                        _copy_state(bk_st, bk_resp, st, resp)
                    info[0] = k
                    info[1] = cause
                    info[2] = dep
                    info[5] = n_loose
                    return k
                if not backed and n_sub == 0:  # nothing committed in this step yet
                    _copy_state(st, resp, bk_st, bk_resp)
                    backed = True
                # ---- solver._subdivided: two halves, the first on top of the stack
                for q in range(6):
                    tm = 0.5 * (t0[q] + target[q])
                    hd = 0.5 * d_strain[q]
                    sk_d[nsk, q] = hd
                    sk_t0[nsk, q] = tm
                    sk_t1[nsk, q] = target[q]
                    sk_d[nsk + 1, q] = hd
                    sk_t0[nsk + 1, q] = t0[q]
                    sk_t1[nsk + 1, q] = tm
                sk_dep[nsk] = dep + 1
                sk_dep[nsk + 1] = dep + 1
                nsk += 2
                continue
            # ---- accepted: commit the state, counters as solver._subdivided
            new_strain = np.empty(6)  # strain + de (an element loop: no array expression to compile)
            for q in range(6):
                new_strain[q] = strain[q] + de[q]
            eval_fn(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, True)
            wst, wdi = _commit_sums(part, Cflat)
            for q in range(36):
                Cflat[q] *= sym[6 + q]
            n_sub += 1
            n_it += it_done
            if loose_acc:
                n_loose += 1
            diss += wdi  # (s_di of the pass without the deferred falling-N part)
            dw = 0.0
            for q in range(6):
                dw += 0.5 * (stress[q] + sig[q]) * (new_strain[q] - strain[q])
            work += dw
            strain = new_strain
            stress = sig.copy()
            for q in range(36):
                C[q // 6, q % 6] = Cflat[q]
            wsl = s_sl
            wop = s_op
        # ---- record the step
        for q in range(6):
            t_stress[q] = new_ts[q] if sc[q] else stress[q]
            t_strain[q] = strain[q] if sc[q] else new_te[q]
            rec_strain[k, q] = strain[q]
            rec_stress[k, q] = stress[q]
        for q in range(36):
            rec_tan[k, q // 6, q % 6] = C[q // 6, q % 6]
        rec_scal[k, 0] = wsl
        rec_scal[k, 1] = wop
        rec_scal[k, 2] = diss
        rec_scal[k, 3] = work
        rec_scal[k, 4] = wst
        rec_int[k, 0] = n_sub
        rec_int[k, 1] = n_it
    info[0] = m
    info[1] = 0
    info[5] = n_loose
    return m


_evaluate_serial = _make(False)
_evaluate_parallel = _make(True)
# the pass and the law are arguments (first-class functions), not linked into the loop:
# one compiled loop serves the serial and the parallel pass
_segment_compiled = njit(**_PY_ONLY)(_segment)


def chunk_count(n: int) -> int:
    """Chunks of the evaluation pass over ``n`` rows: a multiple of 8, each of at most 128 rows.

    A multiple of the thread count keeps the threads' shares equal: on 2 cores an odd
    number of chunks made the threaded pass up to 1.5x *slower* than the serial one (the
    thread done first falls asleep after its short spin and is woken again for the next
    evaluation, ~0.1 ms), an even number 1.5-1.6x faster (``docs/performance.md``). The
    chunking does not depend on the thread count, so the serial and the threaded pass
    sum in the same order (the same bits).
    """
    return _CH_GROUP * max(1, -(-int(n) // (_CH_GROUP * _CH)))


def pass_signature(law_sig: tuple, args: tuple) -> tuple:
    """The numba argument types of the evaluation pass called by the loop with ``args`` (those after the law)."""
    from numba import typeof, types

    # positions in the argument tuple built by mixed_segment
    kc, normals, branch, weights, sc = args[0], args[1], args[2], args[3], args[4]
    st, out, scratch, inc, part, resp = args[15], args[16], args[17], args[18], args[19], args[20]
    return (types.FunctionType(types.none(*law_sig)), typeof(kc), typeof(normals), typeof(branch), typeof(weights),
            typeof(np.zeros(6)), typeof(sc), typeof(st), typeof(out), typeof(scratch), typeof(inc), typeof(part),
            typeof(resp), types.boolean)


def compile_pass(parallel: bool, sig: tuple) -> None:
    """Compile (or load from numba's cache) the serial or parallel evaluation pass for ``sig``."""
    (_evaluate_parallel if parallel else _evaluate_serial).compile(sig)


def pass_function(parallel: bool, sig: tuple) -> Any:
    """The evaluation pass as a first-class function value (compiled or loaded first)."""
    from numba.core.types.function_type import CompileResultWAP

    fn = _evaluate_parallel if parallel else _evaluate_serial
    fn.compile(sig)
    return CompileResultWAP(fn.overloads[sig])


#: the worker process that compiles the law while this one compiles the segment loop
#: (``GRAINMECH_COMPILE_WORKER=0`` switches it off: :mod:`grainmech._workers`)
_WORKER = ("import pickle, sys\n"
           "path, (key, law_sig, parallel, pass_sig) = pickle.load(sys.stdin.buffer)\n"
           "sys.path[:] = path  # import the same grainmech as the parent\n"
           "from grainmech.contact import kernel\n"
           "from grainmech.driver import _mixed\n"
           "kernel.compile_law(key, law_sig)\n"
           "_mixed.compile_pass(parallel, pass_sig)\n")


def _start_worker(job: tuple) -> Any:
    """A Python process that compiles the law and the evaluation pass of ``job`` into numba's cache (or None)."""
    from grainmech._workers import start_worker

    return start_worker(_WORKER, job)


def _compile(args: tuple, key: tuple, law_sig: tuple, parallel: bool, pass_sig: tuple) -> None:
    """Compile (or load) the segment loop for ``args``; the law and the pass at the same time elsewhere.

    The loop takes the pass and the law as first-class functions, so compiling it needs
    only their types, not their code. When the loop has to be compiled (numba starts a
    compilation: an empty or stale cache), the law and the pass are compiled in a second
    Python process meanwhile, into numba's on-disk cache, from which
    :func:`kernel.law_function` and :func:`pass_function` then load them: with a free
    second core the first run waits for the longer of the two compilations instead of
    their sum (``docs/performance.md``, "First run"). If the worker fails, they are
    compiled here as before.
    """
    from numba import typeof, types

    from grainmech._workers import on_first_compile
    from grainmech.contact import kernel

    sig = ((types.FunctionType(types.intp(*pass_sig)), types.FunctionType(types.none(*law_sig)))
           + tuple(typeof(a) for a in args))
    if sig in _segment_compiled.overloads:
        return

    def start() -> Any:
        done = kernel.law_compiled(key, law_sig) and pass_sig in (
            _evaluate_parallel if parallel else _evaluate_serial).overloads
        return None if done else _start_worker((key, law_sig, parallel, pass_sig))

    with on_first_compile(start):
        _segment_compiled.compile(sig)


def mixed_segment(point, sc: np.ndarray, increments: np.ndarray, t_stress: np.ndarray, t_strain: np.ndarray,
                  options) -> dict:
    """Run the steps ``increments`` (m, 6) of constant control mask ``sc`` (6,) from ``point``.

    Parameters
    ----------
    point : MaterialPoint
        Converged start, with a :class:`~grainmech.contact.interface.ContactLaw` whose
        parameters the compiled kernel supports (the caller checks), no finite-deformation
        correction.
    sc : (6,) bool, stress-controlled components
    increments : (m, 6) increments of the controlled components (stress or strain)
    t_stress, t_strain : (6,) running targets at the segment's start (``solver.run``)
    options : SolverOptions

    Returns
    -------
    dict
        ``done`` (steps completed), ``cause`` (0 or a ``FAIL_*`` code), ``depth``,
        ``contact``, ``flag`` (law failure), ``n_loose``, ``finfo`` (condition or residual,
        tolerance, sliding and open fractions of the failing evaluation), per-step records
        ``strain``, ``stress``, ``tangent`` (m, ...), ``sliding``, ``open`` (fractions),
        ``dissipation``, ``work`` (per step), ``stored``, ``substeps``, ``iterations``; the
        final ``state``, ``response``, ``stress``, ``strain``, ``tangent``,
        ``t_stress``, ``t_strain``.
    """
    from numba import get_num_threads

    from grainmech.contact import kernel
    from grainmech.contact.law import ContactResponse, ContactState

    cs = point.contacts
    params = point.law.params
    kc = kernel.constants(params)
    m = increments.shape[0]
    # one row per orbit of the symmetries of the rows, the state and the segment's path
    # (the antipodal map, mirrors), its weight times the orbit's size (driver/_fold.py)
    folding, normals, branch, weights, st0, r0 = fold(cs, point.state, point.response, options.fold,
                                                      path_mirrors(sc, increments, t_stress))
    sym = folding.sym if folding is not None else np.ones(42)
    n = normals.shape[0]
    nch = chunk_count(n)

    def c(x, dtype=float):
        return np.array(x, dtype=dtype, order="C")

    dtypes = (float, float, float, float, np.int8, np.int32, float, float)
    fields = (st0.approach, st0.normal_force, st0.tangential_force, st0.axis, st0.direction, st0.depth,
              st0.reversals, st0.dissipated_energy)
    st = KernelState(*(c(x, dt) for x, dt in zip(fields, dtypes)))
    bk = KernelState(*(np.empty_like(x) for x in st))
    nrev = st.reversals.shape[1]
    out = KernelOutput(np.empty(n), np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, dtype=np.int8),
                       np.empty(n, dtype=np.int32), np.empty((n, nrev)), np.empty(n, dtype=np.bool_), np.empty(n),
                       np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_),
                       np.empty((n, 3, 3)), np.empty((n, 3)))
    scratch = KernelScratch(np.empty((n, 3)), np.empty((n, 3)), np.zeros(n, dtype=np.int8),
                            np.zeros((n, kernel.FALL_COLUMNS)))
    inc = KernelIncrement(np.empty(n), np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n))
    resp = tuple(c(x) for x in (r0.kn, r0.ks, r0.ks_perp, r0.ktn, r0.dissipation, r0.sliding, r0.open))
    bk_resp = tuple(np.empty(n) for _ in resp)
    part = np.zeros((nch, _NP))
    rec_strain = np.zeros((m, 6))
    rec_stress = np.zeros((m, 6))
    rec_tan = np.zeros((m, 6, 6))
    rec_scal = np.zeros((m, 5))
    rec_int = np.zeros((m, 2), dtype=np.int64)
    info = np.zeros(6, dtype=np.int64)
    finfo = np.zeros(4)
    parallel = n >= PARALLEL_ROWS and get_num_threads() > 1
    # the start's stress and tangent as the folded sums give them: the components the
    # group does not leave invariant (zero to rounding for the symmetric state) set to 0,
    # so that a stress-controlled one stays at its zero target with a zero increment
    C0 = np.ascontiguousarray(point.tangent * sym[6:].reshape(6, 6), dtype=float)
    t_stress = c(t_stress * sym[:6])  # a held component the group maps to minus itself: zero target
    t_strain = c(t_strain)
    args = (kc, c(normals), c(branch), c(weights), c(sc, np.bool_), c(increments),
            c(point.stress * sym[:6]), c(point.strain), C0, t_stress, t_strain,
            float(options.rtol), float(options.rtol_accept), int(options.max_iter), int(options.max_depth),
            st, out, scratch, inc, part, resp, bk, bk_resp,
            rec_strain, rec_stress, rec_tan, rec_scal, rec_int, info, finfo, sym)
    law_sig = kernel.law_signature(kc, st, inc, out, scratch)
    pass_sig = pass_signature(law_sig, args)
    _compile(args, kernel.law_key(kc, True, 3), law_sig, parallel, pass_sig)
    law_fn = kernel.law_function(kc, st, inc, out, scratch, defer=True)  # falling-N dissipation at the commit
    eval_fn = pass_function(parallel, pass_sig)
    done = int(_segment_compiled(eval_fn, law_fn, *args))
    wtot = float(weights.sum())
    if folding is not None:
        st = KernelState(*(unfold(folding, x, name) for name, x in zip(st._fields, st)))
        resp = tuple(unfold(folding, x) for x in resp)
        if info[1] == FAIL_LAW:
            info[3] = folding.rows[info[3]]
    sliding = resp[5] > 0.5
    state = ContactState(st.approach, st.normal_force, st.tangential_force, st.axis, st.direction, st.depth,
                         st.reversals, sliding, st.dissipated_energy)
    response = ContactResponse(st.normal_force, st.tangential_force, resp[0], resp[1], resp[2], resp[3],
                               st.axis, sliding, resp[6] > 0.5, resp[4])
    frac = rec_scal[:, :2] / wtot if wtot > 0 else np.zeros((m, 2))
    last = done - 1
    return {
        "done": done, "cause": int(info[1]), "depth": int(info[2]), "contact": int(info[3]), "flag": int(info[4]),
        "n_loose": int(info[5]), "finfo": finfo,
        "strain": rec_strain[:done], "stress": rec_stress[:done], "tangent": rec_tan[:done],
        "sliding": frac[:done, 0], "open": frac[:done, 1], "dissipation": rec_scal[:done, 2],
        "work": rec_scal[:done, 3], "stored": rec_scal[:done, 4],
        "substeps": rec_int[:done, 0], "iterations": rec_int[:done, 1],
        "state": state, "response": response,
        "stress_end": rec_stress[last].copy() if done else point.stress.copy(),
        "strain_end": rec_strain[last].copy() if done else point.strain.copy(),
        "tangent_end": rec_tan[last].copy() if done else C0.copy(),
        "t_stress": t_stress, "t_strain": t_strain,
    }

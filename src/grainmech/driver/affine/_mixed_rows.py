"""Per-contact pieces and small dense algebra of the compiled mixed-control loop (``affine._mixed``).

Compile options and failure codes of the loop; the contact increment of a strain
increment (seed Eq. 2.13) and the normal law at the step's end (seed Eq. 3.6, 3.2), the
Love-Weber stress terms (seed Eq. 2.6), the Newton Jacobian rows of the
stress-controlled components with the law's step tangent, the stored energy of a
contact, the state copies, and the small linear solves and condition number of the
Newton update. :mod:`grainmech.driver.affine._fused` uses the same pieces.
"""

from __future__ import annotations

import math
from typing import Any

from numba import njit

from grainmech.contact.geometry import (
    hertz_energy,
    hertz_force,
    hertz_radius,
    hertz_radius_from_approach,
    mindlin_kt0,
    spring_energy,
)

CHUNK = 128  # at most this many contacts per chunk (work item of the prange)
CHUNK_GROUP = 8  # the number of chunks is a multiple of this (see chunk_count)
#: rows from which the evaluation pass runs on numba's threads (with more than one): on
#: 2 cores the threaded run took the serial one's time at 128 rows and was 1.35-1.84x
#: faster from 256 to 1475 rows (random sets, 2 cycles of simple shear with sigma_zz
#: held; ``docs/performance.md``, "Mixed-control driver")
PARALLEL_ROWS = 256
# functions that allocate nothing: compiled without numba's reference counting (atomic
# increments of the arrays they are passed, per contact)
NO_NRT: dict[str, Any] = {"cache": True, "error_model": "numpy", "_nrt": False, "no_cpython_wrapper": True,
                           "no_cfunc_wrapper": True}
# functions called only from compiled code: no Python or C wrapper
INNER: dict[str, Any] = {"cache": True, "error_model": "numpy", "no_cpython_wrapper": True, "no_cfunc_wrapper": True}
# functions passed to compiled code as first-class functions: only the C wrapper
FIRST_CLASS: dict[str, Any] = {"cache": True, "error_model": "numpy", "no_cpython_wrapper": True}
# functions called from Python only: no C wrapper
PY_ONLY: dict[str, Any] = {"cache": True, "error_model": "numpy", "no_cfunc_wrapper": True}
PARTIAL_SUMS = 6 + 36 + 3  # per-chunk partial sums: stress, Jacobian, (sliding, open, dissipation) weights

#: failure causes reported by the compiled loop (``info[1]``)
FAIL_SINGULAR = 1        # Newton Jacobian singular (condition number in finfo[0])
FAIL_NOT_FINITE = 2      # Newton update not finite
FAIL_NO_CONVERGENCE = 3  # max_iter iterations, no iterate within rtol_accept
FAIL_LAW = 4             # the law could not advance a contact (index in info[3], flag in info[4])


@njit(**INNER)
def pick(q, u0, u1, u2, u3, u4, u5):
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


@njit(**INNER)
def bcol(q, lx, ly, lz):
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


@njit(**NO_NRT)
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


@njit(**NO_NRT)
def add_step_jacobian(acc, off, rowmask, colmask, w, kn, t_alpha, t_delta, i, nx, ny, nz, lx, ly, lz):
    """Add ``w B^T K B`` (rows ``rowmask``, columns ``colmask``) to ``acc[off + 6 q + r]``.

    ``K = (kn n + t_alpha) n^T + t_delta (I - n n)``: the law's step (consistent) tangent
    of ``f = N n + T`` with respect to the relative displacement ``delta = B d eps``
    (seed Eq. 2.13, 2.26; :func:`grainmech.driver.affine.point.consistent_tangent`).
    """
    K00, K01, K02, K10, K11, K12, K20, K21, K22 = _step_tangent3(kn, t_alpha, t_delta, i, nx, ny, nz)
    for r in range(6):
        if colmask[r]:
            b0, b1, b2 = bcol(r, lx, ly, lz)
            g0 = w * (K00 * b0 + K01 * b1 + K02 * b2)   # w K B[:, r]
            g1 = w * (K10 * b0 + K11 * b1 + K12 * b2)
            g2 = w * (K20 * b0 + K21 * b1 + K22 * b2)
            for q in range(6):
                if rowmask[q]:
                    c0, c1, c2 = bcol(q, lx, ly, lz)
                    acc[off + 6 * q + r] += c0 * g0 + c1 * g1 + c2 * g2


@njit(**NO_NRT)
def add_jacobian_sub(acc, off, idx, ns, w, kn, t_alpha, t_delta, i, nx, ny, nz, lx, ly, lz):
    """:func:`add_step_jacobian` with rows = columns = ``idx[:ns]`` (the same values).

    The stress-controlled components listed once per pass instead of six mask tests
    of the rows and of the columns per contact.
    """
    K00, K01, K02, K10, K11, K12, K20, K21, K22 = _step_tangent3(kn, t_alpha, t_delta, i, nx, ny, nz)
    for rr in range(ns):
        r = idx[rr]
        b0, b1, b2 = bcol(r, lx, ly, lz)
        g0 = w * (K00 * b0 + K01 * b1 + K02 * b2)   # w K B[:, r]
        g1 = w * (K10 * b0 + K11 * b1 + K12 * b2)
        g2 = w * (K20 * b0 + K21 * b1 + K22 * b2)
        for qq in range(ns):
            q = idx[qq]
            c0, c1, c2 = bcol(q, lx, ly, lz)
            acc[off + 6 * q + r] += c0 * g0 + c1 * g1 + c2 * g2


@njit(**INNER)
def copy_state(src, src_resp, dst, dst_resp):
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


@njit(**INNER)
def contact_increment(exx, eyy, ezz, eyz, exz, exy, nx, ny, nz, lx, ly, lz, a0, N0, linear, kn_lin, E, R):
    """One contact's step input from a strain increment.

    Tensor components, compression positive: ``delta = d eps . l`` split into ``d_n`` and ``d_t`` (seed Eq. 2.13), the
    normal force at the step end (seed Eq. 3.6, or ``kn alpha``) and the Hertz contact
    radii at its start and end (seed Eq. 3.2). Returns ``(d_n, dtx, dty, dtz, N1, rad0, rad1)``.
    """
    d_n, dtx, dty, dtz, N1, rad1 = increment_end(exx, eyy, ezz, eyz, exz, exy, nx, ny, nz, lx, ly, lz, a0,
                                                  linear, kn_lin, E, R)
    if linear:
        return d_n, dtx, dty, dtz, N1, N1, N1
    return d_n, dtx, dty, dtz, N1, start_radius(a0, N0, E, R), rad1


@njit(**INNER)
def start_radius(a0, N0, E, R):
    """Hertz contact radius at the start of a step (seed Eq. 3.2; 0 for an open contact)."""
    Nc = N0 if (a0 > 0.0 and N0 > 0.0) else 0.0
    return hertz_radius(Nc, E, R)


@njit(**INNER)
def increment_end(exx, eyy, ezz, eyz, exz, exy, nx, ny, nz, lx, ly, lz, a0, linear, kn_lin, E, R):
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


@njit(**NO_NRT)
def start_radii(linear, E, R, approach, normal_force, rad0):
    """``rad0`` of the converged state (:func:`start_radius`; unused for linear springs)."""
    for i in range(approach.shape[0]):
        rad0[i] = 0.0 if linear else start_radius(approach[i], normal_force[i], E, R)


@njit(**INNER)
def love_weber_terms(N, tx, ty, tz, w, nx, ny, nz, lx, ly, lz):
    """One contact's Love-Weber stress terms ``w sym(f (x) l)``, ``f = N n + T``.

    Seed Eq. 2.6, as (xx, yy, zz, yz, xz, xy).
    """
    fx = (N * nx + tx) * w
    fy = (N * ny + ty) * w
    fz = (N * nz + tz) * w
    return (fx * lx, fy * ly, fz * lz, 0.5 * (fy * lz + fz * ly), 0.5 * (fx * lz + fz * lx),
            0.5 * (fx * ly + fy * lx))


@njit(**PY_ONLY)
def solve_small(A, b):
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


@njit(**PY_ONLY)
def cond2(J):
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


@njit(**INNER)
def reduce_chunks(part, sig, jac, sym):
    """Sum the per-chunk partial sums.

    Stress into ``sig`` (6,), Jacobian into ``jac`` (6, 6), each component times its
    factor in ``sym`` (42,: 1, or 0 for a component a folding's group does not leave
    invariant, :attr:`grainmech.driver.affine._fold.Folding.sym`); returns the (sliding, open,
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


@njit(**INNER)
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

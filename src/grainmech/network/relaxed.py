"""Relaxed (non-affine) small-strain stiffness of a contact network."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.network import _solvers
from grainmech.network.data import ContactNetwork
from grainmech.network.measures import rattler_threshold, rattlers
from grainmech.network.stiffness import affine_stiffness, contact_matrix, effective_ks, strain_map

__all__ = ["relaxed_stiffness", "RelaxedResult"]


@dataclass(frozen=True)
class RelaxedResult:
    """Result of :func:`relaxed_stiffness`.

    Attributes
    ----------
    C_relaxed, C_affine : arrays (6, 6)
        Voigt, library order, of the network the solve used (rattlers removed).
    correction : array (6, 6)
        ``C_affine - C_relaxed = (1/V) B^T H^+ B`` (positive semi-definite).
    displacements : array (P, 6, 6) or None
        Non-affine fluctuation per particle (translation 3, rotation 3) for each unit
        strain column; zero rows for rattlers.
    n_particles, n_contacts, n_rattlers : int
    solver : str
        ``"direct"`` (SuperLU) or ``"cg"`` (block-Jacobi preconditioned CG).
    iterations : int
    residual : float
        ``max_k |H q_k + B_k| / max(|B_k|, 1e-6 |B_k|_gross)`` where the gross norm is
        taken before cancellation between contacts.
    """

    C_relaxed: np.ndarray
    C_affine: np.ndarray
    correction: np.ndarray
    displacements: np.ndarray | None
    n_particles: int
    n_contacts: int
    n_rattlers: int
    solver: str
    iterations: int
    residual: float


def _cross_matrix(r: np.ndarray) -> np.ndarray:
    """[r]_x with [r]_x v = r x v, shape (C, 3, 3)."""
    X = np.zeros(r.shape[:-1] + (3, 3))
    X[..., 0, 1] = -r[..., 2]
    X[..., 0, 2] = r[..., 1]
    X[..., 1, 0] = r[..., 2]
    X[..., 1, 2] = -r[..., 0]
    X[..., 2, 0] = -r[..., 1]
    X[..., 2, 1] = r[..., 0]
    return X


def _assemble(P: int, ci: np.ndarray, cj: np.ndarray, n: np.ndarray, l_: np.ndarray, kn: np.ndarray,
              ks: np.ndarray, rA: np.ndarray, rB: np.ndarray, rotations: bool):
    """Hessian and coupling of the relaxed stiffness.

    ``H = G^T K G`` (CSR, ``P b`` square), ``B = G^T K E`` (``P b``, m), the gross size of
    ``B`` per column and ``b`` (unknowns per particle).

    ``G`` (``C d`` x ``P b``) maps the particle unknowns to the contact displacements
    ``Delta_c = G_A q_A + G_B q_B`` with ``G_A = [I, -[r_A]x]``, ``G_B = [-I, [r_B]x]``; it is
    built as one vectorised COO matrix, ``K`` is block diagonal (``d x d`` per contact) and
    both products run in SciPy's sparse kernels.
    """
    import scipy.sparse as sp

    d = n.shape[1]
    b = 2 * d if (rotations and d == 3) else (d + 1 if rotations else d)
    C = ci.size
    K = contact_matrix(n, kn, ks)  # (C, d, d)
    GA = np.zeros((C, d, b))
    GB = np.zeros((C, d, b))
    GA[:, :, :d] = np.eye(d)
    GB[:, :, :d] = -np.eye(d)
    if rotations:
        if d == 3:
            GA[:, :, 3:] = -_cross_matrix(rA)
            GB[:, :, 3:] = _cross_matrix(rB)
        else:  # theta e_z x r = theta (-r_y, r_x)
            GA[:, 0, 2], GA[:, 1, 2] = -rA[:, 1], rA[:, 0]
            GB[:, 0, 2], GB[:, 1, 2] = rB[:, 1], -rB[:, 0]
    row = np.broadcast_to((np.arange(C)[:, None] * d + np.arange(d))[:, :, None], (C, d, b))
    k = np.arange(b)
    colA = np.broadcast_to((ci[:, None] * b + k)[:, None, :], (C, d, b))
    colB = np.broadcast_to((cj[:, None] * b + k)[:, None, :], (C, d, b))
    vals = np.concatenate([GA.ravel(), GB.ravel()])
    keep = vals != 0
    G = sp.csr_matrix((vals[keep], (np.concatenate([row.ravel(), row.ravel()])[keep],
                                    np.concatenate([colA.ravel(), colB.ravel()])[keep])),
                      shape=(C * d, P * b))
    Kb = sp.bsr_matrix((K, np.arange(C), np.arange(C + 1)), shape=(C * d, C * d)).tocsr()
    GT = G.T.tocsr()
    H = (GT @ (Kb @ G)).tocsr()
    H = (0.5 * (H + H.T)).tocsr()  # exactly symmetric for the Cholesky factorisation
    KE = np.matmul(K, strain_map(l_))  # (C, d, m)
    m = KE.shape[2]
    B = np.asarray(GT @ KE.reshape(C * d, m))
    # size of B before cancellation between contacts (scale for residuals)
    bref2 = np.zeros(m)
    for Gx in (GA, GB):
        for s in range(0, C, 65536):
            X = np.einsum("cik,cia->cka", Gx[s:s + 65536], KE[s:s + 65536])
            bref2 += np.einsum("cka,cka->a", X, X)
    return H, B, np.sqrt(bref2), b


def _diagonal_blocks(H, P: int, b: int) -> np.ndarray:
    """The ``b x b`` diagonal blocks of ``H`` (P, b, b)."""
    Hb = H.tobsr(blocksize=(b, b))
    rows = np.repeat(np.arange(P), np.diff(Hb.indptr))
    on = Hb.indices == rows
    out = np.zeros((P, b, b))
    out[rows[on]] = Hb.data[on]
    return out


#: ``solver="auto"``: iterations after which block CG predicts its total, and the most
#: it may need before the factorisation is used instead (``docs/performance.md``)
AUTO_CG_PREDICT = 40
AUTO_CG_MAXITER = 600


def relaxed_stiffness(net: ContactNetwork, kn: np.ndarray, ks: np.ndarray, *,
                      remove_rattlers: bool = True, min_contacts: int | None = None,
                      rotations: bool = True, geometric: bool = False, solver: str = "auto",
                      tol: float = 1e-10, maxiter: int = 20000,
                      return_displacements: bool = False) -> RelaxedResult:
    """Relaxed (non-affine) small-strain stiffness of a contact network.

    Each particle ``p`` has a fluctuation ``q_p = (u_p, theta_p)`` on top of the affine
    field ``-eps x`` (compression-positive strain); periodic images share ``q``. The
    displacement of contact point ``A`` relative to ``B`` is

        ``Delta_c = eps . l_c + u_A - u_B + theta_A x r_A - theta_B x r_B``,

    with lever arms ``r_A = R_A n``, ``r_B = -R_B n`` (centre to contact point), and the
    force by A on B is ``f_c = K_c Delta_c``, ``K = kn n n + ks (I - n n)``. Writing
    ``Delta = G q + E e`` the energy density is ``(1/2V) sum_c Delta^T K Delta``;
    minimising over ``q`` (equilibrium of forces and moments on every particle) gives
    ``H q = -B e`` with ``H = sum G^T K G``, ``B = sum G^T K E`` and

        ``C_relaxed = C_affine - (1/V) B^T H^+ B``

    (Lemaitre & Maloney 2006, Eq. 12; Agnolin & Roux 2007; Kruyt & Rothenburg 1998).
    ``B`` lies in the range of ``H`` (a zero mode ``z`` has ``K G z = 0``), so the
    product does not depend on the zero modes: the global translation is pinned (one
    particle's translation fixed) and the remaining floppy modes (e.g. free rotations of
    frictionless grains) are removed by a relative regularisation ``1e-12 diag(H)``.

    Parameters
    ----------
    net : ContactNetwork
        3D (rotations 3 per particle) or 2D (1 per particle).
    kn, ks : arrays (C,)
        Contact stiffnesses [force/length].
    remove_rattlers : bool
        Drop rattlers (:func:`rattlers`; contacts counted as carrying when ``kn > 0``
        and ``N > 0`` if forces are present) and their contacts before solving.
    min_contacts : int, optional
        Rattler threshold; default :func:`rattler_threshold` (2 when any contact has a
        tangential stiffness and rotations are on, else ``d + 1``). If nothing is left
        after removal the function raises :class:`~grainmech.errors.GrainmechError`
        instead of returning zeros.
    rotations : bool
        Include particle rotations (needs radii; without radii the lever arms are
        ``|l|/2``).
    geometric : bool
        Add the geometric term ``-(N/|l|) (I - n n)`` to ``K`` (default off).
    solver : {"auto", "direct", "pardiso", "cholesky", "superlu", "amg", "cg"}
        ``direct``: the best installed sparse factorisation (PARDISO from pypardiso,
        CHOLMOD from cholespy, else SciPy's SuperLU), factored once for the six
        right-hand sides; ``amg``: CG preconditioned by algebraic multigrid (pyamg);
        ``cg``: block-Jacobi preconditioned CG on all six right-hand sides at once;
        ``auto``: block CG when its first :data:`AUTO_CG_PREDICT` iterations predict
        convergence within :data:`AUTO_CG_MAXITER`, else the method chosen by size and
        installed packages (:func:`grainmech.network._solvers.choose`; measurements in
        ``docs/performance.md``).  The result names the solver that ran
        and its relative residual.
    tol, maxiter : CG tolerance (relative residual) and iteration cap.

    Returns
    -------
    RelaxedResult
        Voigt matrices in library order [stress]; ``C_affine`` is that of the solved
        (rattler-free) network.
    """
    _solvers.choose(solver, 0)  # validates the name and the optional package
    d = net.dim
    kn = np.asarray(kn, float)
    ks_e = effective_ks(net, ks, geometric)
    if kn.shape != (net.n_contacts,) or ks_e.shape != (net.n_contacts,):
        raise GrainmechError(f"kn and ks must have shape ({net.n_contacts},)")
    if not (np.all(np.isfinite(kn)) and np.all(np.isfinite(ks_e))):
        raise GrainmechError("kn and ks must be finite")
    stiff = kn > 0
    if min_contacts is None:
        frictional = bool(np.any(ks_e[stiff] > 0))
        min_contacts = rattler_threshold(d, frictional, rotations)
        rule = (f"the {'frictional' if frictional and rotations else 'frictionless'} rule: "
                + ("some contact has ks > 0 and grains rotate" if frictional and rotations else
                   "no contact has ks > 0" if not frictional else "rotations are off"))
    else:
        rule = "min_contacts as given"
    if remove_rattlers:
        carrying = stiff & (net.normal_force > 0) if np.any(net.force) else stiff
        ratt = rattlers(net, min_contacts, carrying)
    else:
        carrying = stiff
        ratt = np.zeros(net.n_particles, dtype=bool)
    alive = ~ratt
    csel = (kn != 0) | (ks_e != 0)
    csel &= alive[net.i] & alive[net.j]
    alive_idx = np.flatnonzero(alive)
    m = 6 if d == 3 else 3
    if alive_idx.size == 0 or not csel.any():
        raise GrainmechError(
            f"relaxed stiffness: nothing is left to solve - {int(ratt.sum())} of {net.n_particles} "
            f"particles are rattlers (fewer than {min_contacts} force-carrying contacts, {rule}; "
            f"removed iteratively; {int(carrying.sum())} of {net.n_contacts} contacts carry force "
            "and have kn > 0). The network is too loose for this rule: check the contact "
            "forces/stiffnesses, or lower min_contacts")
    newidx = -np.ones(net.n_particles, dtype=np.int64)
    newidx[alive_idx] = np.arange(alive_idx.size)
    ci, cj = newidx[net.i[csel]], newidx[net.j[csel]]
    n = net.normals[csel]
    l_ = net.branch[csel]
    if net.radii is not None:
        RA, RB = net.radii[net.i[csel]], net.radii[net.j[csel]]
    else:
        RA = RB = 0.5 * net.branch_length[csel]
    rA = RA[:, None] * n
    rB = -RB[:, None] * n
    P = alive_idx.size
    H, B, bref, b = _assemble(P, ci, cj, n, l_, kn[csel], ks_e[csel], rA, rB, rotations)
    V = net.volume
    ndof = P * b
    rhs = -B
    name = _solvers.choose(solver, ndof)
    q = None
    if solver == "auto":
        # block CG first: on packings it converges in a few hundred iterations and beats
        # every factorisation; when its first iterations predict more than AUTO_CG_MAXITER
        # (ill-conditioned networks) it stops and the factorisation runs instead
        q, iters, res_cg = _solvers.block_cg(H, rhs, _diagonal_blocks(H, P, b), tol, AUTO_CG_MAXITER,
                                             1e-6 * bref, predict_after=AUTO_CG_PREDICT)
        if res_cg <= tol:
            name = "cg"
        else:
            q = None
    if name == "cg" and q is None:
        q, iters, _ = _solvers.block_cg(H, rhs, _diagonal_blocks(H, P, b), tol, maxiter, 1e-6 * bref)
    elif name != "cg":
        # pin the translation of particle 0 (global translation mode); the other zero modes
        # (e.g. free rotations of frictionless grains) are lifted for the factorisation by
        # 1e-10 times the largest diagonal entry of the same kind of unknown (at least 1e-6
        # of the translational one, times the squared mean lever arm for rotations), then
        # removed again by iterative refinement against H itself
        free = np.ones(ndof, dtype=bool)
        free[:d] = False
        Hf = H[free][:, free].tocsr()
        kind = np.flatnonzero(free) % b
        typemax = np.zeros(b)
        np.maximum.at(typemax, kind, np.abs(Hf.diagonal()))
        ref = np.full(b, float(typemax[:d].max()) or 1.0)
        ref[d:] *= float(np.mean(np.r_[RA, RB]) ** 2)
        typemax = np.maximum(typemax, 1e-6 * ref)
        q = np.zeros((ndof, m))
        q[free], iters = _solvers.solve_spd(Hf, rhs[free], name, dof_type=kind, shift=1e-10 * typemax[kind],
                                            tol=tol, maxiter=maxiter)
    R = H @ q - rhs
    nb = np.maximum(np.linalg.norm(rhs, axis=0), 1e-6 * bref)
    scale_r = np.where(nb > 0, nb, 1.0)
    residual = float(np.max(np.linalg.norm(R, axis=0) / scale_r))
    corr = B.T @ q  # = -B^T H^+ B  (q solves H q = -B)
    Ca = affine_stiffness(net.subset(csel), kn[csel], ks_e[csel])
    Cr = Ca + corr / V
    Cr = 0.5 * (Cr + Cr.T)
    correction = Ca - Cr
    disp = None
    if return_displacements:
        disp = np.zeros((net.n_particles, b, m))
        disp[alive_idx] = np.asarray(q).reshape(P, b, m)
    if residual > max(tol * 100, 1e-6):
        what = (f"CG did not converge in {iters} iterations" if name in ("cg", "amg") else
                "the factorisation is not accurate (ill-conditioned network)")
        raise GrainmechError(f"relaxed stiffness: solver {name!r}: {what} (relative residual "
                             f"{residual:.3g}); raise maxiter or try another solver")
    return RelaxedResult(Cr, Ca, correction, disp, int(P), int(csel.sum()), int(ratt.sum()), name,
                         int(iters), residual)

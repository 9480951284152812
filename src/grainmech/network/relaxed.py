"""Relaxed (non-affine) small-strain stiffness of a contact network."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainmech.errors import GrainmechError
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


def _assemble(net: ContactNetwork, alive_idx: np.ndarray, ci: np.ndarray, cj: np.ndarray,
              n: np.ndarray, l_: np.ndarray, kn: np.ndarray, ks: np.ndarray,
              rA: np.ndarray, rB: np.ndarray, rotations: bool):
    """Block Hessian H (BSR, b x b blocks) and B (ndof, m) of the relaxed problem."""
    import scipy.sparse as sp

    d = n.shape[1]
    b = 2 * d if (rotations and d == 3) else (d + 1 if rotations else d)
    P = alive_idx.size
    C = ci.size
    K = contact_matrix(n, kn, ks)  # (C, d, d)
    # Delta = G_A q_A + G_B q_B + E e;  G_A = [I, -[rA]x], G_B = [-I, +[rB]x]
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
    KGA = K @ GA
    KGB = K @ GB
    GAt = np.swapaxes(GA, 1, 2)
    GBt = np.swapaxes(GB, 1, 2)
    HAA = GAt @ KGA
    HBB = GBt @ KGB
    HAB = GAt @ KGB
    E = strain_map(l_)
    m = E.shape[2]
    KE = K @ E
    BA = GAt @ KE  # (C, b, m)
    BB = GBt @ KE
    # diagonal blocks
    diag = np.zeros((P, b, b))
    np.add.at(diag, ci, HAA)
    np.add.at(diag, cj, HBB)
    rows = np.concatenate([np.arange(P), ci, cj])
    cols = np.concatenate([np.arange(P), cj, ci])
    blocks = np.concatenate([diag, HAB, np.swapaxes(HAB, 1, 2)])
    order = np.lexsort((cols, rows))
    rows, cols, blocks = rows[order], cols[order], blocks[order]
    key = rows * P + cols
    first = np.concatenate([[True], key[1:] != key[:-1]])
    starts = np.flatnonzero(first)
    blocks = np.add.reduceat(blocks, starts, axis=0)
    rows, cols = rows[starts], cols[starts]
    indptr = np.searchsorted(rows, np.arange(P + 1))
    H = sp.bsr_matrix((blocks, cols, indptr), shape=(P * b, P * b))
    Bm = np.zeros((P, b, m))
    np.add.at(Bm, ci, BA)
    np.add.at(Bm, cj, BB)
    # size of B before cancellation between contacts (scale for residuals)
    bref = np.sqrt(np.einsum("cia,cia->a", BA, BA) + np.einsum("cia,cia->a", BB, BB))
    return H, Bm.reshape(P * b, m), diag, b, bref


def _block_cg(H, rhs: np.ndarray, diag_blocks: np.ndarray, tol: float, maxiter: int,
              ref: np.ndarray) -> tuple[np.ndarray, int, float]:
    """Block-Jacobi preconditioned CG, all right-hand sides at once (columns independent)."""
    P, b, _ = diag_blocks.shape
    # pseudo-inverse of each diagonal block (handles zero rotation blocks)
    Minv = np.linalg.pinv(diag_blocks, hermitian=True)

    def prec(r):
        return np.matmul(Minv, r.reshape(P, b, -1)).reshape(r.shape)

    x = np.zeros_like(rhs)
    r = rhs.copy()
    z = prec(r)
    p = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    nb = np.maximum(np.linalg.norm(rhs, axis=0), ref)
    nb[nb == 0] = 1.0
    it = 0
    res = np.linalg.norm(r, axis=0) / nb
    while it < maxiter and res.max() > tol:
        Hp = H @ p
        pHp = np.einsum("ij,ij->j", p, Hp)
        active = pHp > 0
        alpha = np.where(active, rz / np.where(active, pHp, 1.0), 0.0)
        x += p * alpha
        r -= Hp * alpha
        z = prec(r)
        rz_new = np.einsum("ij,ij->j", r, z)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        p = z + p * beta
        rz = rz_new
        it += 1
        res = np.linalg.norm(r, axis=0) / nb
    return x, it, float(res.max())


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
    solver : {"auto", "direct", "cg"}
        ``direct`` uses SuperLU; ``cg`` block-Jacobi preconditioned conjugate gradients
        on all 6 right-hand sides at once; ``auto`` is direct up to 15000 unknowns
        (about 2500 particles; SuperLU fill-in grows fast for 3D networks beyond).
    tol, maxiter : CG tolerance (relative residual) and iteration cap.

    Returns
    -------
    RelaxedResult
        Voigt matrices in library order [stress]; ``C_affine`` is that of the solved
        (rattler-free) network.
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    if solver not in ("auto", "direct", "cg"):
        raise GrainmechError(f"solver must be 'auto', 'direct' or 'cg', got {solver!r}")
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
    H, B, diag, b, bref = _assemble(net, alive_idx, ci, cj, n, l_, kn[csel], ks_e[csel], rA, rB, rotations)
    V = net.volume
    P = alive_idx.size
    ndof = P * b
    rhs = -B
    # pin the translation of particle 0 (global translation mode)
    free = np.ones(ndof, dtype=bool)
    free[:d] = False
    use_direct = solver == "direct" or (solver == "auto" and ndof <= 15000)
    Hc = H.tocsr()
    if use_direct:
        Hf = Hc[free][:, free].tocsc()
        dg = Hf.diagonal()
        scale = float(np.max(np.abs(dg))) if dg.size else 1.0
        reg = 1e-12 * np.where(dg > 0, dg, scale)
        Hf = (Hf + sp.diags(reg)).tocsc()
        try:
            lu = spla.splu(Hf)
        except RuntimeError as exc:  # exactly singular even after regularisation
            raise GrainmechError(f"relaxed stiffness: factorisation failed ({exc})") from None
        q = np.zeros((ndof, m))
        q[free] = lu.solve(rhs[free])
        iters = 1
        name = "direct"
    else:
        q, iters, _ = _block_cg(Hc, rhs, diag, tol, maxiter, 1e-6 * bref)
        name = "cg"
    R = Hc @ q - rhs
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
        disp[alive_idx] = q.reshape(P, b, m)
    if name == "cg" and residual > max(tol * 100, 1e-6):
        raise GrainmechError(f"relaxed stiffness: CG did not converge in {iters} iterations "
                             f"(relative residual {residual:.3g}); raise maxiter or use solver='direct'")
    return RelaxedResult(Cr, Ca, correction, disp, int(P), int(csel.sum()), int(ratt.sum()), name,
                         int(iters), residual)

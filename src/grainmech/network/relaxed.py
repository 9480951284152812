"""Relaxed (non-affine) small-strain stiffness of a contact network."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from grainmech.contact.rolling import RollingConstants, rolling_elastic_stiffness
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
        The method that produced the tensor (``"pardiso"``, ``"cholesky"``, ``"superlu"``,
        ``"amg"`` or ``"cg"``); with ``solver="auto"`` ``"cg"`` also when a factorisation
        did not reach its residual target and block CG was run instead.
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


def cross_matrix(r: np.ndarray) -> np.ndarray:
    """[r]_x with [r]_x v = r x v, shape (C, 3, 3)."""
    X = np.zeros(r.shape[:-1] + (3, 3))
    X[..., 0, 1] = -r[..., 2]
    X[..., 0, 2] = r[..., 1]
    X[..., 1, 0] = r[..., 2]
    X[..., 1, 2] = -r[..., 0]
    X[..., 2, 0] = -r[..., 1]
    X[..., 2, 1] = r[..., 0]
    return X


@dataclass
class _System:
    """The relaxed-stiffness system of one network, per contact and per grain.

    ``Delta_c = G_A q_A + G_B q_B + E_c e`` with ``G_A = [I, -[r_A]x]``, ``G_B = [-I,
    [r_B]x]`` (``GA, GB`` (C, d, b)), contact stiffness ``K`` (C, d, d); the coupling
    ``B = G^T K E`` (``P b``, m), its size per column before cancellation between
    contacts ``bref`` (m,), and the ``b x b`` diagonal blocks of ``H = G^T K G`` (P, b,
    b) are formed from the per-contact blocks; the sparse ``H`` itself only when a
    solver asks for it (:meth:`hessian`).
    """

    P: int
    b: int
    ci: np.ndarray
    cj: np.ndarray
    GA: np.ndarray
    GB: np.ndarray
    K: np.ndarray
    B: np.ndarray
    bref: np.ndarray
    diag_blocks: np.ndarray
    _H: object = None

    def hessian(self):
        """``H = G^T K G`` (CSR, ``P b`` square, exactly symmetric), built once.

        ``G`` (``C d`` x ``P b``) is one vectorised COO matrix, ``K`` block diagonal; both
        products run in SciPy's sparse kernels.
        """
        if self._H is not None:
            return self._H
        C, d, b = self.GA.shape
        row = np.broadcast_to((np.arange(C)[:, None] * d + np.arange(d))[:, :, None], (C, d, b))
        k = np.arange(b)
        colA = np.broadcast_to((self.ci[:, None] * b + k)[:, None, :], (C, d, b))
        colB = np.broadcast_to((self.cj[:, None] * b + k)[:, None, :], (C, d, b))
        vals = np.concatenate([self.GA.ravel(), self.GB.ravel()])
        keep = vals != 0
        G = sp.csr_matrix((vals[keep], (np.concatenate([row.ravel(), row.ravel()])[keep],
                                        np.concatenate([colA.ravel(), colB.ravel()])[keep])),
                          shape=(C * d, self.P * b))
        Kb = sp.bsr_matrix((self.K, np.arange(C), np.arange(C + 1)), shape=(C * d, C * d)).tocsr()
        H = (G.T.tocsr() @ (Kb @ G)).tocsr()
        self._H = (0.5 * (H + H.T)).tocsr()  # exactly symmetric for the Cholesky factorisation
        return self._H


def _assemble(P: int, ci: np.ndarray, cj: np.ndarray, n: np.ndarray, l_: np.ndarray, kn: np.ndarray,
              ks: np.ndarray, rA: np.ndarray, rB: np.ndarray, rotations: bool,
              Km: np.ndarray | None = None) -> _System:
    """Per-contact blocks, coupling ``B`` and diagonal blocks of the relaxed stiffness.

    ``b`` unknowns per particle: ``2 d`` in 3D with rotations, ``d + 1`` in 2D with
    rotations, ``d`` without. Per-grain sums of per-contact blocks are sparse incidence
    products (grain x contact), which scale linearly.

    ``Km`` (C, 3, 3), 3D with rotations only: the contacts' moment stiffness (rolling and
    twisting resistance). Each contact's deformation then has six components, the
    relative displacement and the relative rotation ``omega = theta_A - theta_B``
    (``G_A = [[I, -[r_A]x], [0, I]]``, ``G_B = [[-I, [r_B]x], [0, -I]]``), with the
    block-diagonal stiffness ``diag(K, Km)``; the strain moves no rotation (the affine
    field ``-eps x`` has none), so ``E`` has zero rows there.
    """
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
            GA[:, :, 3:] = -cross_matrix(rA)
            GB[:, :, 3:] = cross_matrix(rB)
        else:  # theta e_z x r = theta (-r_y, r_x)
            GA[:, 0, 2], GA[:, 1, 2] = -rA[:, 1], rA[:, 0]
            GB[:, 0, 2], GB[:, 1, 2] = rB[:, 1], -rB[:, 0]
    E = strain_map(l_)  # (C, d, m)
    if Km is not None:
        if not (rotations and d == 3):
            raise GrainmechError("rolling resistance needs 3D grains with rotations")
        GA = np.concatenate([GA, np.zeros((C, 3, b))], axis=1)
        GB = np.concatenate([GB, np.zeros((C, 3, b))], axis=1)
        GA[:, 3:, 3:] = np.eye(3)
        GB[:, 3:, 3:] = -np.eye(3)
        Kx = np.zeros((C, 6, 6))
        Kx[:, :3, :3] = K
        Kx[:, 3:, 3:] = Km
        K = Kx
        E = np.concatenate([E, np.zeros((C, 3, E.shape[2]))], axis=1)
    KE = np.matmul(K, E)  # (C, d, m)
    m = KE.shape[2]
    one, cols = np.ones(C), np.arange(C)
    SA = sp.csr_matrix((one, (ci, cols)), shape=(P, C))
    SB = sp.csr_matrix((one, (cj, cols)), shape=(P, C))
    XA = np.matmul(GA.transpose(0, 2, 1), KE)  # (C, b, m): G_A^T K E
    XB = np.matmul(GB.transpose(0, 2, 1), KE)
    B = np.asarray(SA @ XA.reshape(C, b * m) + SB @ XB.reshape(C, b * m)).reshape(P * b, m)
    # size of B before cancellation between contacts (scale for residuals)
    bref = np.sqrt(np.einsum("cka,cka->a", XA, XA) + np.einsum("cka,cka->a", XB, XB))
    DA = np.matmul(GA.transpose(0, 2, 1), np.matmul(K, GA)).reshape(C, b * b)
    DB = np.matmul(GB.transpose(0, 2, 1), np.matmul(K, GB)).reshape(C, b * b)
    diag = np.asarray(SA @ DA + SB @ DB).reshape(P, b, b)
    diag = 0.5 * (diag + diag.transpose(0, 2, 1))
    return _System(P, b, ci, cj, GA, GB, K, B, bref, diag)


_KERNEL = None  # grainmech.network._cg_kernel once imported, False without numba


def _cg_kernel():
    """The compiled CG module, or ``None`` when numba is not installed."""
    global _KERNEL
    if _KERNEL is None:
        try:
            from grainmech.network import _cg_kernel as kernel
        except ImportError:
            _KERNEL = False
        else:
            _KERNEL = kernel
    return _KERNEL or None


def _block_cg(sys_: _System, rhs: np.ndarray, n: np.ndarray, kn: np.ndarray, ks: np.ndarray,
              rA: np.ndarray, rB: np.ndarray, tol: float, maxiter: int, predict_after: int | None
              ) -> tuple[np.ndarray, int, float]:
    """Block-Jacobi CG on ``H q = rhs``; returns ``q``, the iterations and the residual.

    The compiled matrix-free kernel for 3D grains with rotations
    (:mod:`grainmech.network._cg_kernel`, when numba is installed), else the NumPy
    reference :func:`grainmech.network._solvers.block_cg` on the assembled ``H``.
    """
    kernel = _cg_kernel()
    ref = 1e-6 * sys_.bref
    if kernel is None or sys_.b != 6 or sys_.K.shape[1] != 3:  # the kernel has no moment springs
        return _solvers.block_cg(sys_.hessian(), rhs, sys_.diag_blocks, tol, maxiter, ref,
                                 predict_after=predict_after)
    m = rhs.shape[1]
    nb = np.maximum(np.linalg.norm(rhs, axis=0), ref)
    nb[nb == 0] = 1.0
    # block inverses by Cholesky; the (nearly) singular blocks, e.g. a grain free to spin
    # about the line through its two contacts, by pseudo-inverse as the NumPy reference.
    # A singular block's last pivot is a rounding residue that may reach 1e-11 of the
    # diagonal: blocks with a pivot below 1e-8 of it count as singular (above, the
    # Cholesky inverse is accurate to ~1e-8, which a preconditioner does not notice)
    Minv, bad = kernel.block_inverses(sys_.diag_blocks, 1e-8)
    if bad.any():
        Minv[bad] = np.linalg.pinv(sys_.diag_blocks[bad], hermitian=True)
    P = sys_.P
    order = _grain_order(P, sys_.ci, sys_.cj)
    parts = _thread_parts(P)
    if order is None:
        ci, cj = sys_.ci, sys_.cj
        rhs3 = np.ascontiguousarray(rhs.reshape(P, 6, m))
    else:
        rank = np.empty(P, dtype=np.int64)
        rank[order] = np.arange(P)
        ci, cj = rank[sys_.ci], rank[sys_.cj]
        Minv = np.ascontiguousarray(Minv[order])
        rhs3 = np.ascontiguousarray(rhs.reshape(P, 6, m)[order])
    gsplit = np.linspace(0, P, parts + 1).round().astype(np.int64)
    # contacts of each part, then those between parts; by their first grain within each
    pa, pb = np.searchsorted(gsplit, ci, "right") - 1, np.searchsorted(gsplit, cj, "right") - 1
    key = np.where(pa == pb, pa, parts)
    perm = np.lexsort((np.minimum(ci, cj), key))
    csplit = np.searchsorted(key[perm], np.arange(parts + 1)).astype(np.int64)
    ci, cj = np.ascontiguousarray(ci[perm]), np.ascontiguousarray(cj[perm])
    cargs = tuple(np.ascontiguousarray(a[perm]) for a in (n, kn, ks, rA, rB))
    run = kernel.block_cg3_parts if parts > 1 else kernel.block_cg3
    x, it, res = run(ci, cj, *cargs, Minv, rhs3, nb, float(tol), int(maxiter), int(predict_after or 0),
                     gsplit, csplit)
    if order is not None:
        x = x[rank]
    return x.reshape(P * 6, m), int(it), float(res)


#: grains from which the compiled CG numbers them by reverse Cuthill-McKee (contacts then
#: join nearby rows: the Hessian product on the 1e5-grain tiled packing of
#: ``docs/performance.md`` took 20.7 ms instead of 39.7 ms) and splits them between threads
CG_REORDER_GRAINS = 20000


def _grain_order(P: int, ci: np.ndarray, cj: np.ndarray) -> np.ndarray | None:
    """Reverse Cuthill-McKee order of the grains of a large network, else None.

    ``order[k]`` is the grain numbered ``k`` (SciPy's ``reverse_cuthill_mckee`` on the
    contact graph; George & Liu 1981, Sec. 4.3).
    """
    if P < CG_REORDER_GRAINS:
        return None
    A = sp.csr_matrix((np.ones(ci.size), (ci, cj)), shape=(P, P))
    return np.asarray(reverse_cuthill_mckee((A + A.T).tocsr(), symmetric_mode=True), dtype=np.int64)


def _thread_parts(P: int) -> int:
    """Parts (threads) of the compiled CG: numba's thread count on large networks, else 1."""
    if P < CG_REORDER_GRAINS:
        return 1
    from numba import get_num_threads

    return max(1, int(get_num_threads()))


def _apply_hessian(sys_: _System, q: np.ndarray, n: np.ndarray, kn: np.ndarray, ks: np.ndarray,
                   rA: np.ndarray, rB: np.ndarray) -> np.ndarray:
    """``H q`` for ``q`` (P b, m): matrix-free when compiled and ``H`` was not built."""
    kernel = _cg_kernel()
    if sys_._H is not None or kernel is None or sys_.b != 6 or sys_.K.shape[1] != 3:
        return sys_.hessian() @ q
    m = q.shape[1]
    out = np.empty((sys_.P, 6, m))
    kernel.hessian_product(sys_.ci, sys_.cj, n, kn, ks, rA, rB, np.ascontiguousarray(q.reshape(sys_.P, 6, m)), out,
                           np.empty(m))
    return out.reshape(q.shape)


#: ``solver="auto"``: iterations after which block CG predicts its total, and the most
#: it may need before the factorisation is used instead (``docs/performance.md``)
AUTO_CG_PREDICT = 40
AUTO_CG_MAXITER = 600

#: Relative residual to which a factorisation (of the shifted Hessian) is refined at
#: least: its residual lies in the softest modes, where it weighs most in the tensor (a
#: CG residual lies in the stiff ones), so ``tol`` alone does not bound the tensor's error
DIRECT_REFINE_TOL = 1e-10

#: Most CG steps preconditioned by the factorisation that refine a direct solve: each
#: removes about one near-floppy mode left by the regularising shift (four on the
#: 1e4-grain random network of ``docs/performance.md``); more means the factor is a poor
#: preconditioner and ``auto`` goes to block CG instead
DIRECT_REFINE_STEPS = 50


def _solved_part(net: ContactNetwork, kn: np.ndarray, ks_e: np.ndarray, remove_rattlers: bool,
                 min_contacts: int | None, rotations: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The part of the network :func:`relaxed_stiffness` solves: ``(ratt, csel, alive_idx, m)``.

    Rattlers (removed iteratively by the rule of ``min_contacts``), the contacts kept and
    the particles kept; ``m`` the number of strain components. Raises
    :class:`~grainmech.errors.GrainmechError` when nothing is left.
    """
    d = net.dim
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
    return ratt, csel, alive_idx, m


def _fluctuations(sys_: _System, rhs: np.ndarray, ndof: int, n: np.ndarray, knc: np.ndarray, ksc: np.ndarray,
                  rA: np.ndarray, rB: np.ndarray, RA: np.ndarray, RB: np.ndarray, d: int, m: int, solver: str,
                  tol: float, maxiter: int) -> tuple[np.ndarray, int, str, tuple[str, int, float, float] | None]:
    """The grains' fluctuations ``q`` solving ``H q = rhs`` for :func:`relaxed_stiffness`.

    Returns ``(q, iterations, solver name, direct_left)``; ``direct_left`` names a
    factorisation (or AMG-CG) that stopped short of its target residual, else None.
    """
    b = sys_.b
    name = _solvers.choose(solver, ndof)
    q: np.ndarray | None = None
    if solver == "auto":
        # block CG first: on packings it converges in a few hundred iterations and beats
        # every factorisation; when its first iterations predict more than AUTO_CG_MAXITER
        # (ill-conditioned networks) it stops and the factorisation runs instead
        q, iters, res_cg = _block_cg(sys_, rhs, n, knc, ksc, rA, rB, tol, AUTO_CG_MAXITER, AUTO_CG_PREDICT)
        if res_cg <= tol:
            name = "cg"
        else:
            q = None
    direct_left: tuple[str, int, float, float] | None = None  # a factorisation short of its target
    if name != "cg" and q is None:
        # pin the translation of particle 0 (global translation mode); the other zero modes
        # (e.g. free rotations of frictionless grains) are lifted for the factorisation by
        # 1e-10 times the largest diagonal entry of the same kind of unknown (at least 1e-6
        # of the translational one, times the squared mean lever arm for rotations), then
        # removed again by CG on H itself preconditioned by the factor (solve_spd)
        H = sys_.hessian()
        free = np.ones(ndof, dtype=bool)
        free[:d] = False
        Hf = H[free][:, free].tocsr()
        kind = np.flatnonzero(free) % b
        typemax = np.zeros(b)
        np.maximum.at(typemax, kind, np.abs(Hf.diagonal()))
        ref = np.full(b, float(typemax[:d].max()) or 1.0)
        ref[d:] *= float(np.mean(np.r_[RA, RB]) ** 2)
        typemax = np.maximum(typemax, 1e-6 * ref)
        target = min(tol, DIRECT_REFINE_TOL)
        q = np.zeros((ndof, m))
        q[free], iters, res_d = _solvers.solve_spd(Hf, rhs[free], name, dof_type=kind,
                                                   shift=1e-10 * typemax[kind], tol=target, maxiter=maxiter,
                                                   refine=DIRECT_REFINE_STEPS)
        if float(res_d.max()) > target:
            # the residual of a shifted factorisation (or of AMG-CG short of its target)
            # lies in the softest modes, where it weighs most in the tensor (7.8e-4 of it at
            # a residual of 1.7e-8 on a 1e4-grain network, docs/performance.md): never keep
            # it silently
            direct_left = (name, iters, float(res_d.max()), target)
            if solver == "auto":
                q, name = None, "cg"  # block CG resolves these modes (in more iterations)
    if name == "cg" and q is None:
        q, iters, _ = _block_cg(sys_, rhs, n, knc, ksc, rA, rB, tol, maxiter, None)
    assert q is not None
    return q, iters, name, direct_left


def _relative_residual(Hq: np.ndarray, rhs: np.ndarray, bref: np.ndarray) -> float:
    """Largest relative residual ``|H q - rhs| / max(|rhs|, 1e-6 bref)`` over the columns."""
    R = Hq - rhs
    nb = np.maximum(np.linalg.norm(rhs, axis=0), 1e-6 * bref)
    scale_r = np.where(nb > 0, nb, 1.0)
    return float(np.max(np.linalg.norm(R, axis=0) / scale_r))


def _check_solve(direct_left: tuple[str, int, float, float] | None, solver: str, name: str, iters: int, residual: float,
                 tol: float) -> None:
    """Raise :class:`GrainmechError` when the fluctuation solve of :func:`relaxed_stiffness` failed.

    ``direct_left``: ``(solver, iterations, residual, target)`` of a factorisation (or
    AMG-CG) that stopped above its target (an error unless ``solver="auto"``, which
    fell back to CG); ``residual``: the relative residual ``|H q + B| / |B|`` of the
    returned fluctuations, an error above ``max(100 tol, 1e-6)``.
    """
    if direct_left is not None and solver != "auto":
        dname, dits, dres, dtarget = direct_left
        how = (f"CG preconditioned by algebraic multigrid stopped after {dits} iterations" if dname == "amg"
               else f"the factorisation, refined by {dits - 1} steps of CG preconditioned by it,")
        raise GrainmechError(
            f"relaxed stiffness: solver {dname!r}: {how} left a relative residual {dres:.3g} above "
            f"{dtarget:.3g} (ill-conditioned network with near-floppy modes, where the residual weighs "
            "most in the tensor); try solver='cg' or 'auto'")
    if residual > max(tol * 100, 1e-6):
        what = (f"CG did not converge in {iters} iterations" if name in ("cg", "amg") else
                "the factorisation is not accurate (ill-conditioned network)")
        raise GrainmechError(f"relaxed stiffness: solver {name!r}: {what} (relative residual "
                             f"{residual:.3g}); raise maxiter or try another solver")


def relaxed_stiffness(net: ContactNetwork, kn: np.ndarray, ks: np.ndarray, *,
                      remove_rattlers: bool = True, min_contacts: int | None = None,
                      rotations: bool = True, geometric: bool = False, solver: str = "auto",
                      tol: float = 1e-7, maxiter: int = 20000,
                      return_displacements: bool = False,
                      rolling: RollingConstants | None = None) -> RelaxedResult:
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
    With rolling and twisting resistance (``rolling``) each contact also resists the
    relative rotation ``omega_c = theta_A - theta_B`` of its grains with the elastic moment
    stiffness ``K_m = k_roll R*^2 (I - n n) + k_twist n n``
    (:func:`~grainmech.contact.rolling.rolling_elastic_stiffness`; Iwashita & Oda 1998;
    LAMMPS ``rolling sds`` / ``twisting sds``): the energy gains
    ``(1/2V) sum_c omega_c^T K_m omega_c`` and the grains' rotational block of ``H`` gains
    ``H_r^T K_m H_r``, ``H_r`` mapping the grains' rotations to ``omega``. The strain
    does not enter ``omega``, so ``B`` and ``C_affine`` are unchanged and the rolling
    springs can only stiffen ``C_relaxed``. The caps (``mu_r R* N``, ``c_twist N``) do
    not act at zero strain: every ``mu_r > 0`` gives the same tensor.
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
    tol : float
        Relative residual at which CG stops (a factorisation is refined to
        ``min(tol, DIRECT_REFINE_TOL)``). The tensor is evaluated in its energy form
        ``C_affine + (B^T q + q^T B + q^T H q)/V``, which is stationary at the solution:
        its error is quadratic in the residual (measured on the shipped packings and on
        random networks: ``tol = 1e-7`` gives the tensor to better than 1e-12 relative,
        ``1e-6`` to 1e-10, ``docs/performance.md``).
    maxiter : int
        CG iteration cap.
    rolling : RollingConstants, optional
        Rolling and twisting resistance of the contacts
        (:func:`~grainmech.contact.rolling.rolling_constants`), 3D with rotations; contacts
        carrying no compressive force (``N <= 0`` when the network has forces) get no
        moment stiffness. ``None`` or a resistance that resists nothing (``mu_r = 0`` and no
        twisting cap) gives the tensor without it, identically. Solved by the NumPy block
        CG or a factorisation (the compiled matrix-free CG has no moment springs).

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
    ratt, csel, alive_idx, m = _solved_part(net, kn, ks_e, remove_rattlers, min_contacts, rotations)
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
    knc, ksc = kn[csel], ks_e[csel]
    Km = None
    if rolling is not None and (rolling.mu_roll > 0 or rolling.twist_cap > 0):
        closed = net.normal_force[csel] > 0 if np.any(net.force) else np.ones(n.shape[0], bool)
        Km = rolling_elastic_stiffness(rolling, n, RA * RB / (RA + RB), closed)
    sys_ = _assemble(P, ci, cj, n, l_, knc, ksc, rA, rB, rotations, Km)
    b, B = sys_.b, sys_.B
    V = net.volume
    ndof = P * b
    rhs = -B
    q, iters, name, direct_left = _fluctuations(sys_, rhs, ndof, n, knc, ksc, rA, rB, RA, RB, d, m, solver, tol,
                                                maxiter)
    Hq = _apply_hessian(sys_, q, n, knc, ksc, rA, rB)
    residual = _relative_residual(Hq, rhs, sys_.bref)
    # the energy of the strain e with the grains at q e minimised over q: e^T (C_affine +
    # (B^T q + q^T B + q^T H q)/V) e. At the solution the bracket is -B^T H^+ B; an error
    # dq of the solve changes it by dq^T H dq only (the energy is stationary), where B^T q
    # alone would change by B^T dq: the tensor's error is quadratic in the residual
    corr = B.T @ q
    corr = corr + corr.T + q.T @ Hq
    Ca = affine_stiffness(net.subset(csel), kn[csel], ks_e[csel])
    Cr = Ca + corr / V
    Cr = 0.5 * (Cr + Cr.T)
    correction = Ca - Cr
    disp = None
    if return_displacements:
        disp = np.zeros((net.n_particles, b, m))
        disp[alive_idx] = np.asarray(q).reshape(P, b, m)
    _check_solve(direct_left, solver, name, iters, residual, tol)
    return RelaxedResult(Cr, Ca, correction, disp, int(P), int(csel.sum()), int(ratt.sum()), name,
                         int(iters), residual)

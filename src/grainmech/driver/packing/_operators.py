"""Kinematics, residuals and linear algebra of the packing driver (private).

Conventions (as :func:`grainmech.network.relaxed_stiffness`, ``docs/models/packing.md``):
every tracked contact ``c`` joins grains ``A = a[c]`` and ``B = b[c]`` (rows of the
non-rattler grains), branch ``l = x_B - x_A`` (periodic image), unit normal ``n = l/|l|``,
lever arms ``r_A = R_A n`` and ``r_B = -R_B n``. Each grain has six fluctuation
unknowns ``q_p = (u_p, theta_p)``; with the engineering Voigt strain ``e``
(compression positive) the relative displacement of the contact is

``Delta_c = eps . l_c + u_A - u_B + theta_A x r_A - theta_B x r_B = G_c q + E_c e``

(seed Eq. 2.13 for the affine part). The force ``f_c`` (by A on B, compression positive)
is work-conjugate to ``Delta_c``, so the out-of-balance force and moment of every grain
is ``G^T f`` and ``V sigma = E^T f`` (Love-Weber, seed Eq. 2.6).
"""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from grainmech.errors import GrainmechError
from grainmech.network._solvers import refine_pcg, shared_pardiso
from grainmech.network.relaxed import cross_matrix as cross_rows  # [r]_x, one home with the relaxed tensor

__all__: list[str] = []


def strain_tensor(e: np.ndarray) -> np.ndarray:
    """(3, 3) strain tensor of an engineering Voigt vector (xx, yy, zz, yz, xz, xy)."""
    return np.array([[e[0], 0.5 * e[5], 0.5 * e[4]],
                     [0.5 * e[5], e[1], 0.5 * e[3]],
                     [0.5 * e[4], 0.5 * e[3], e[2]]])


def voigt_of(f: np.ndarray, l_: np.ndarray) -> np.ndarray:
    """``E^T f``: Voigt vector (6,) of ``sym(sum_c f_c (x) l_c)`` (seed Eq. 2.6 times V)."""
    S = np.einsum("ci,cj->ij", f, l_)  # no BLAS call: small products pay thread start-up costs
    return np.array([S[0, 0], S[1, 1], S[2, 2], 0.5 * (S[1, 2] + S[2, 1]),
                     0.5 * (S[0, 2] + S[2, 0]), 0.5 * (S[0, 1] + S[1, 0])])


@dataclass(frozen=True, eq=False)
class Kinematics:
    """Fixed reference geometry of the tracked contacts and its linear maps.

    Attributes
    ----------
    a, b : int arrays (C,)
        Grain rows (non-rattlers) of A and B.
    n, l : arrays (C, 3)
        Unit normal and branch vector [length].
    free : bool array (6 P,)
        Unknowns solved for (the translation of grain 0 is pinned: global translation).
    G : sparse (3C, n_free)
        ``Delta = G q_free + E e``.
    Gt : sparse (n_free, 3C)
        Its transpose (CSR): out-of-balance forces and moments ``G^T f``.
    E : array (3C, 6)
        Affine map of the engineering strain.
    Hr, Hrt : sparse (3C, n_free), (n_free, 3C) or None
        Relative rotations of the contacts and their transpose (rolling resistance only).
    Rs : array (C,)
        Effective radius ``R_A R_B / (R_A + R_B)`` of each contact [length].
    twisting : bool
        The contacts resist the relative rotation along their normal too.
    """

    a: np.ndarray
    b: np.ndarray
    n: np.ndarray
    l: np.ndarray
    n_grains: int
    free: np.ndarray
    G: sp.csr_matrix
    Gt: sp.csr_matrix
    E: np.ndarray
    Hr: sp.csr_matrix | None = None
    Hrt: sp.csr_matrix | None = None
    Rs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    twisting: bool = False

    @classmethod
    def build(cls, a: np.ndarray, b: np.ndarray, n: np.ndarray, l_: np.ndarray, RA: np.ndarray,
              RB: np.ndarray, n_grains: int, rolling: bool = False, twisting: bool = False) -> Kinematics:
        """The kinematics of contacts ``a``-``b``; ``rolling``: also the relative rotations ``Hr``.

        ``Hr`` (3C, n_free) maps the grain unknowns to each contact's relative rotation
        ``omega_c = theta_A - theta_B`` (:mod:`grainmech.contact.rolling`); its transpose
        ``Hrt`` turns contact moments into the grains' out-of-balance moments. ``twisting``:
        the twisting part along ``n`` is resisted too.
        """
        C = a.size
        rA = RA[:, None] * n
        rB = -RB[:, None] * n
        blk = np.zeros((C, 3, 12))
        blk[:, :, 0:3] = np.eye(3)
        blk[:, :, 3:6] = -cross_rows(rA)
        blk[:, :, 6:9] = -np.eye(3)
        blk[:, :, 9:12] = cross_rows(rB)
        cols = np.concatenate([6 * a[:, None] + np.arange(6), 6 * b[:, None] + np.arange(6)], axis=1)
        rows = 3 * np.arange(C)[:, None, None] + np.arange(3)[None, :, None]
        G = sp.csr_matrix((blk.ravel(), (np.broadcast_to(rows, blk.shape).ravel(),
                                         np.broadcast_to(cols[:, None, :], blk.shape).ravel())),
                          shape=(3 * C, 6 * n_grains))
        free = np.ones(6 * n_grains, dtype=bool)
        free[:3] = False
        Gf = G[:, free].tocsr()
        Gf.eliminate_zeros()
        E = np.zeros((C, 3, 6))
        for k in range(6):
            unit = np.zeros(6)
            unit[k] = 1.0
            E[:, :, k] = l_ @ strain_tensor(unit)
        Hr = Hrt = None
        Rs = RA * RB / (RA + RB)
        if rolling:
            rows_r = (3 * np.arange(C)[:, None] + np.arange(3)).ravel()
            H = sp.csr_matrix((np.concatenate([np.ones(3 * C), -np.ones(3 * C)]),
                               (np.concatenate([rows_r, rows_r]),
                                np.concatenate([(6 * a[:, None] + 3 + np.arange(3)).ravel(),
                                                (6 * b[:, None] + 3 + np.arange(3)).ravel()]))),
                              shape=(3 * C, 6 * n_grains))
            Hr = H[:, free].tocsr()
            Hrt = Hr.T.tocsr()
        return cls(a, b, n, l_, int(n_grains), free, Gf, Gf.T.tocsr(), E.reshape(3 * C, 6), Hr, Hrt, Rs,
                   bool(rolling and twisting))

    @property
    def rolling(self) -> bool:
        """Whether the contacts resist relative rotation (:mod:`grainmech.contact.rolling`)."""
        return self.Hr is not None

    def omega(self, dq: np.ndarray) -> np.ndarray:
        """Relative rotations ``theta_A - theta_B`` (C, 3) of ``dq`` (n_free,)."""
        assert self.Hr is not None
        return (self.Hr @ dq).reshape(-1, 3)

    def moment_balance(self, m: np.ndarray) -> np.ndarray:
        """Out-of-balance moments ``Hr^T m`` (n_free,) of contact moments ``m`` (C, 3)."""
        assert self.Hrt is not None
        return self.Hrt @ m.reshape(-1)

    @property
    def n_contacts(self) -> int:
        return int(self.a.size)

    @property
    def n_free(self) -> int:
        return int(self.free.sum())

    def delta(self, dq: np.ndarray, de: np.ndarray) -> np.ndarray:
        """Relative displacement (C, 3) of ``dq`` (n_free,) and strain ``de`` (6,)."""
        return (self.G @ dq).reshape(-1, 3) + self.affine(de)

    def affine(self, de: np.ndarray) -> np.ndarray:
        """Relative displacement (C, 3) of the strain ``de`` (6,) alone: ``l_c . eps``.

        Written out term by term in a fixed order (eps symmetric: ``(eps l_c)_i = (l_c
        eps)_i``), so that the compiled kinematics (:mod:`grainmech.driver.packing._kernels`)
        give the same bits; a matrix product may fuse or reorder the terms.
        """
        e = np.asarray(de, dtype=float)
        e01, e02, e12 = 0.5 * e[5], 0.5 * e[4], 0.5 * e[3]
        lx, ly, lz = self.l[:, 0], self.l[:, 1], self.l[:, 2]
        return np.stack([lx * e[0] + ly * e01 + lz * e02,
                         lx * e01 + ly * e[1] + lz * e12,
                         lx * e02 + ly * e12 + lz * e[2]], axis=1)

    def normal_part(self, d: np.ndarray) -> np.ndarray:
        """``d_c . n_c`` (C,) of vectors ``d`` (C, 3), term by term in a fixed order (as the compiled kinematics)."""
        return d[:, 0] * self.n[:, 0] + d[:, 1] * self.n[:, 1] + d[:, 2] * self.n[:, 2]

    def balance(self, f: np.ndarray) -> np.ndarray:
        """Out-of-balance forces and moments ``G^T f`` (n_free,) of forces ``f`` (C, 3)."""
        return self.Gt @ f.reshape(-1)

    def full(self, x: np.ndarray) -> np.ndarray:
        """(P, 6) array of a free-dof vector (pinned entries zero)."""
        out = np.zeros(6 * self.n_grains)
        out[self.free] = x
        return out.reshape(self.n_grains, 6)


def contact_tangent(n: np.ndarray, kn: np.ndarray, ks: np.ndarray, ks_perp: np.ndarray,
                    ktn: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Consistent contact tangent ``dF/dDelta`` (C, 3, 3).

    ``K = kn n n + ks_perp (I - n n) + (ks - ks_perp) e e + ktn e n`` with ``e`` the slip
    axis and ``ktn = d tau / d alpha`` (seed Eq. 3.11; Thornton & Randall 1988), as the
    material-point driver assembles it (``docs/models/affine.md``).
    """
    nn = n[:, :, None] * n[:, None, :]
    ee = axis[:, :, None] * axis[:, None, :]
    en = axis[:, :, None] * n[:, None, :]
    K = (kn - ks_perp)[:, None, None] * nn + ks_perp[:, None, None] * np.eye(3)
    K += (ks - ks_perp)[:, None, None] * ee + ktn[:, None, None] * en
    return K


def block_diagonal(K: np.ndarray) -> sp.bsr_matrix:
    """Block-diagonal sparse matrix of (C, 3, 3) blocks."""
    C = K.shape[0]
    return sp.bsr_matrix((K, np.arange(C), np.arange(C + 1)), shape=(3 * C, 3 * C))


class RollingTangent:
    """The contact moments' part of the consistent tangent (:mod:`grainmech.contact.rolling`).

    ``d(Hr^T m) = Hr^T (KR Hr dq + dm/dN kn (n . Delta))``: the moment springs (``KR``,
    (C, 3, 3)) and, on a cap, the cap's dependence on the normal force (``dmdN`` (C, 3)
    times the physical normal stiffness ``kn`` (C,) of the contact).
    """

    def __init__(self, kin: Kinematics, KR: np.ndarray, dmdN: np.ndarray, kn: np.ndarray) -> None:
        self.kin = kin
        self.KRb = block_diagonal(KR)
        self.c = dmdN * kn[:, None]
        self.coupled = bool(np.any(self.c))

    def apply(self, vq: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Out-of-balance moments (n_free,) of the update ``vq`` whose contact displacements are ``d`` (C, 3)."""
        kin = self.kin
        dm = (self.KRb @ (kin.Hr @ vq)).reshape(-1, 3)
        if self.coupled:
            dm = dm + self.c * kin.normal_part(d)[:, None]
        return kin.moment_balance(dm)

    def strain_columns(self) -> np.ndarray:
        """``d(Hr^T m)/de`` (n_free, 6): the cap coupling through the affine normal displacements."""
        kin = self.kin
        out = np.zeros((kin.n_free, 6))
        if self.coupled:
            En = kin.E.reshape(-1, 3, 6)
            dn = np.einsum("ci,cik->ck", kin.n, En)
            for k in range(6):
                out[:, k] = kin.moment_balance(self.c * dn[:, k:k + 1])
        return out


#: PARDISO's perm argument (unused: iparm(5) = 0)
_NO_PERM = np.zeros(0, dtype=np.int32)


def openblas_one_thread() -> Any:
    """Context manager: OpenBLAS on one thread (threadpoolctl; a no-op without it).

    The packing driver's dense products are small (GMRES' Gram-Schmidt, Anderson's least
    squares on ~11k x 10, the grains' 6 x 6 blocks) and run beside the law's compiled
    threads; OpenBLAS' own threads, spinning between them, cost more than they gain: the
    built-in default run took 56.3 s with them, 52.1 s with ``OPENBLAS_NUM_THREADS=1``
    set by hand and 48.0 s with this limit (2 cores); on a loaded machine
    Gram-Schmidt took 24 ms per product instead of under 1 ms (``docs/models/packing.md``).
    MKL (PARDISO) keeps its own setting.
    """
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:
        return contextlib.nullcontext()
    return ThreadpoolController().select(internal_api="openblas").limit(limits=1)


class _Factor:
    """Sparse symmetric positive definite factorisation of the elastic operator.

    ``backend``: ``"pardiso"`` (Intel MKL PARDISO through ``pypardiso``: nested-dissection
    ordering, parallel supernodal factorisation), ``"cholespy"`` (CHOLMOD), ``"superlu"``
    (SciPy), or ``"auto"``: the first of these that is installed and succeeds. A
    factorisation that fails (e.g. a zero pivot) falls back to the next one under
    ``auto`` and raises under a named backend.
    """

    def __init__(self, A: sp.spmatrix, backend: str, reproducible: bool = True) -> None:
        if backend in ("auto", "pardiso"):
            try:
                self._init_pardiso(A, reproducible)
                return
            except ImportError:
                if backend == "pardiso":
                    raise GrainmechError("factorization = 'pardiso' needs pypardiso, which is not installed: "
                                         "pip install \"grainmech[sparse]\" (or factorization = 'auto')") from None
            except Exception as exc:  # noqa: BLE001 (pypardiso raises its own PyPardisoError)
                if backend == "pardiso":
                    raise GrainmechError(f"PARDISO factorisation of the elastic operator failed ({exc})") from None
        if backend in ("auto", "cholespy"):
            try:
                import cholespy
            except ImportError:
                if backend == "cholespy":
                    raise GrainmechError("factorization = 'cholespy' needs cholespy, which is not installed: "
                                         "pip install \"grainmech[sparse]\" (or factorization = 'auto')") from None
            else:
                c = A.tocoo()
                self._s = cholespy.CholeskySolverD(A.shape[0], c.row.astype(np.int32),
                                                   c.col.astype(np.int32), np.ascontiguousarray(c.data),
                                                   cholespy.MatrixType.COO)
                self.name = "cholespy"
                return
        self.name = "superlu"
        self._lu = spla.splu(A.tocsc())

    def _init_pardiso(self, A: sp.spmatrix, reproducible: bool) -> None:
        import pypardiso  # noqa: F401 (not installed: ImportError here, before the shared handle is asked for)

        Au = sp.triu(A, format="csr")  # PARDISO reads the upper triangle of a symmetric matrix
        Au.sort_indices()
        ps = shared_pardiso()  # for its MKL library; the factor has its own handle (_pt)
        # ``reproducible``: PARDISO factors on one MKL thread (thread-local, restored after
        # the call; the factor keeps that thread count for its solves). Its multithreaded
        # factorisation and solves sum in a schedule-dependent order, and the packing
        # driver's path through the kinks of the contact laws amplified those round-off
        # differences into runs of 51 s and 126 s for the same input. One thread costs
        # ~50 % per solve on the 11 673-unknown benchmark operator (10.3 vs 6.6 ms);
        # PARDISO's own reproducible mode (iparm(34) with MKL_CBWR) was slower still (12 ms)
        self._threads = getattr(ps.libmkl, "MKL_Set_Num_Threads_Local", None) if reproducible else None
        # PARDISO is called directly (pypardiso's solve() converts the index arrays and
        # compares the matrix with the factorised one at every call), with its factor in
        # single precision (iparm(28) = 1: the matrix, right-hand sides and solutions are
        # float32). The factor is only ever a preconditioner here (Anderson and GMRES
        # iterations on the true residual) or refined by CG to 1e-10 (exact_Y), and a
        # solve is accurate to ~3e-5 relative on the benchmark operator; it reads half
        # the memory: 3.2 ms per solve instead of 6.0 ms (one thread, 11 673 unknowns,
        # 8.3 million factor entries). iparm (1-based): (1) = 1 our own settings, (2) = 2
        # nested dissection (METIS), (8) = 0 no iterative refinement (it tripled a solve),
        # (10) = 8 pivot perturbation 1e-8, (28) = 1 single precision, (35) = 0 one-based indices.
        self._call = ps._mkl_pardiso
        self._pt = np.zeros(64, dtype=np.int64)
        self._iparm = np.zeros(64, dtype=np.int32)
        for k, v in ((1, 1), (2, 2), (8, 0), (10, 8), (28, 1), (35, 0)):
            self._iparm[k - 1] = v
        self._ia = (Au.indptr + 1).astype(np.int32)
        self._ja = (Au.indices + 1).astype(np.int32)
        self._a = Au.data.astype(np.float32)
        self._n = Au.shape[0]
        self.name = "pardiso-factoring"  # not "pardiso" (solves, and freed at __del__) until it succeeded
        with self._one_thread():
            z = np.zeros(self._n, dtype=np.float32)
            err = self._pardiso(12, z, z.copy())
        if err != 0:
            self._pardiso(-1, z, z.copy())
            raise GrainmechError(f"PARDISO error {err} in the factorisation of the elastic operator")
        self.name = "pardiso"

    def _pardiso(self, phase: int, b: np.ndarray, x: np.ndarray) -> int:
        """One call of MKL's ``pardiso`` (phase 12: analysis and factorisation, 33: solve, -1: free)."""
        i32 = ctypes.POINTER(ctypes.c_int32)
        err = ctypes.c_int32(0)
        one = ctypes.c_int32(1)
        self._call(self._pt.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)), ctypes.byref(one), ctypes.byref(one),
                   ctypes.byref(ctypes.c_int32(2)), ctypes.byref(ctypes.c_int32(phase)),
                   ctypes.byref(ctypes.c_int32(self._n)), self._a.ctypes.data_as(ctypes.c_void_p),
                   self._ia.ctypes.data_as(i32), self._ja.ctypes.data_as(i32), _NO_PERM.ctypes.data_as(i32),
                   ctypes.byref(ctypes.c_int32(1 if b.ndim == 1 else b.shape[1])), self._iparm.ctypes.data_as(i32),
                   ctypes.byref(ctypes.c_int32(0)), b.ctypes.data_as(ctypes.c_void_p),
                   x.ctypes.data_as(ctypes.c_void_p), ctypes.byref(err))
        return int(err.value)

    @contextmanager
    def _one_thread(self) -> Iterator[None]:
        """MKL on one thread in this thread while the block runs (PARDISO's factorisation: reproducible).

        Nothing when ``_threads`` is None (not reproducible, or no such MKL function).
        """
        if self._threads is None:
            yield
            return
        prev = self._threads(1)
        try:
            yield
        finally:
            self._threads(prev)  # 0: back to the global setting

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self.name == "pardiso":
            bf = np.asfortranarray(b, dtype=np.float32)  # the factor solves on the threads it was made with
            x = np.zeros_like(bf)
            err = self._pardiso(33, bf, x)
            if err != 0:
                raise GrainmechError(f"PARDISO error {err} in a solve with the elastic operator")
            return np.ascontiguousarray(x, dtype=float)
        if self.name == "cholespy":
            b = np.ascontiguousarray(b, dtype=float)
            x = np.zeros_like(b)
            self._s.solve(b, x)
            return x
        return self._lu.solve(b)

    def __del__(self) -> None:
        if getattr(self, "name", None) == "pardiso":  # MKL keeps the factor until told
            try:
                z = np.zeros(1, dtype=np.float32)
                self._pardiso(-1, z, z.copy())
            except Exception:  # noqa: BLE001,S110 (interpreter shutdown: nothing left to free)
                pass


class Preconditioner:
    """Exact inverse of the bordered elastic operator ``[[H0 + S, B0_S], [B0_S^T, A0_SS]]``.

    ``H0 = G^T K0 G`` with the symmetric elastic contact stiffness ``K0 = kn n n +
    ks_perp (I - n n)`` (no slip) of the state it was built from, shifted by
    ``S = reg diag(H0)`` (``PackingOptions.regularization``: floppy and near-floppy
    modes, i.e. free rotations of frictionless grains, a grain held by two or three weak
    contacts, get a bounded update; a floor of ``1e-6`` of the median diagonal where the
    diagonal itself vanishes); ``B0 = G^T K0 E``, ``A0 = E^T K0 E``. The
    stress-controlled strains are eliminated by the Schur complement. Also provides the
    Jacobi scaling ``D`` and :meth:`exact_Y`, ``H0^-1 B0`` without the shift.
    """

    def __init__(self, kin: Kinematics, K0: np.ndarray, backend: str = "auto", reg: float = 1e-4,
                 reproducible: bool = True, KR0: np.ndarray | None = None) -> None:
        Kb = block_diagonal(K0)
        KG = (Kb @ kin.G).tocsr()
        H = (kin.Gt @ KG).tocsr()
        if KR0 is not None and kin.Hr is not None:  # the elastic rolling and twisting springs
            H = (H + kin.Hrt @ (block_diagonal(KR0) @ kin.Hr)).tocsr()
        dg = H.diagonal().copy()
        rot = np.tile(np.arange(6) >= 3, kin.n_grains)[kin.free]
        # floors of the translational [force/length] and rotational [force length] diagonals
        dt = dg[~rot]
        ft = float(np.median(dt[dt > 0])) if np.any(dt > 0) else 1.0
        r2 = float(np.mean(np.einsum("ij,ij->i", kin.l, kin.l))) / 4.0
        dr = dg[rot]
        okr = dr > 1e-8 * ft * r2
        fr = float(np.median(dr[okr])) if okr.any() else ft * r2
        floor = np.where(rot, fr, ft)
        self.H0 = H = 0.5 * (H + H.T)
        self.shift = np.where(dg > 1e-6 * floor, reg * dg, 1e-6 * floor)
        self.factor = _Factor((H + sp.diags(self.shift)).tocsr(), backend, reproducible)
        KE = Kb @ kin.E
        self.B0 = kin.Gt @ KE                     # (n_free, 6)
        self.A0 = kin.E.T @ KE                     # (6, 6)
        self.Y = self.factor.solve(self.B0)        # (H0 + S)^-1 B0 (exact_Y: H0^-1 B0)
        self.dq = 1.0 / np.sqrt(dg + self.shift)
        self.de = 1.0 / np.sqrt(np.maximum(np.diag(self.A0), 1e-300))
        self.solves = 0
        self._exact: tuple | None = None
        self._schur: dict = {}  # per stress-control mask: (B0_S, Y_S, Schur complement)

    def exact_Y(self, tol: float = 1e-10, maxiter: int = 200) -> tuple[np.ndarray, np.ndarray]:
        """``H0^-1 B0`` of the unshifted operator and its relative residual per column.

        Conjugate gradients on ``H0 Y = B0`` preconditioned by the shifted factor and
        warm-started from ``Y`` (:func:`grainmech.network._solvers.refine_pcg`: each
        near-floppy mode the shift holds costs about one iteration). ``B0`` lies in the
        range of ``H0`` (``G^T`` of contact forces), so the floppy modes themselves do not
        enter. Cached.
        """
        if self._exact is None:

            Y, _it, res = refine_pcg(self.H0, self.B0, self.Y, self.factor.solve, tol, maxiter)
            self._exact = (Y, res)
        return self._exact

    def apply(self, rq: np.ndarray, re: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``M^-1 (rq, re)`` for the stress-controlled components ``S`` (bool (6,))."""
        self.solves += 1
        z = self.factor.solve(rq)
        if not S.any():
            return z, re[:0]
        key = tuple(bool(v) for v in S)
        if key not in self._schur:  # the same for every solve of a run's segment
            Bs, Ys = self.B0[:, S], self.Y[:, S]
            self._schur[key] = (Bs, Ys, self.A0[np.ix_(S, S)] - np.einsum("ik,il->kl", Bs, Ys))
        Bs, Ys, Sc = self._schur[key]
        ye = np.linalg.solve(Sc, re - np.einsum("ik,i->k", Bs, z))
        return z - np.einsum("ik,k->i", Ys, ye), ye

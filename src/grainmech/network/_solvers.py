"""Sparse symmetric positive-definite solvers for the relaxed stiffness.

Several right-hand sides at once.

* ``pardiso`` - Intel MKL PARDISO (parallel supernodal Cholesky, nested-dissection
  ordering) from the optional package ``pypardiso``; factor once, solve all columns.
* ``cholesky`` - sparse Cholesky factorisation (CHOLMOD through the optional package
  ``cholespy``, minimum-degree ordering); factor once, solve all columns.
* ``superlu`` - SciPy's SuperLU with the symmetric ordering ``MMD_AT_PLUS_A`` and
  diagonal pivoting (the SciPy-only direct fallback).
* ``amg`` - conjugate gradients preconditioned by one V-cycle of smoothed-aggregation
  algebraic multigrid (optional package ``pyamg``; Vanek, Mandel & Brezina 1996), the
  rigid modes of one particle (unit translations and rotations of every particle) as the
  near-null space.
* ``cg`` - block-Jacobi preconditioned conjugate gradients (NumPy/SciPy only).

``docs/performance.md`` has the measurements behind :func:`choose`.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, files
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from grainmech.errors import GrainmechError

__all__ = ["METHODS", "PACKAGES", "available", "choose", "solve_spd", "refine_pcg", "block_cg"]

#: Names accepted by :func:`solve_spd` (``direct``: the best direct method installed).
METHODS = ("auto", "direct", "pardiso", "cholesky", "superlu", "amg", "cg")

#: Unknowns up to which ``auto`` uses a direct factorisation (above: AMG-CG if pyamg is
#: installed); see ``docs/performance.md``.
DIRECT_LIMIT_PARDISO = 1_000_000
DIRECT_LIMIT_CHOLESKY = 150_000
DIRECT_LIMIT_SUPERLU = 20_000

#: Optional package behind each method that needs one.
PACKAGES = {"pardiso": "pypardiso", "cholesky": "cholespy", "amg": "pyamg"}


def available(method: str) -> bool:
    """True if the optional package behind ``method`` is installed."""
    pkg = PACKAGES.get(method)
    return pkg is None or importlib.util.find_spec(pkg) is not None


def choose(method: str, n: int) -> str:
    """The method :func:`solve_spd` runs for ``method`` and ``n`` unknowns.

    ``auto`` (measured in ``docs/performance.md``): PARDISO up to
    :data:`DIRECT_LIMIT_PARDISO` unknowns when pypardiso is installed (the fastest method
    at every size measured); else cholespy up to :data:`DIRECT_LIMIT_CHOLESKY` unknowns
    (SuperLU up to :data:`DIRECT_LIMIT_SUPERLU`, whose fill-in and time grow faster),
    AMG-preconditioned CG above when pyamg is installed, else block-Jacobi CG.
    ``direct``: the first installed of pardiso, cholesky, superlu.
    """
    if method not in METHODS:
        raise GrainmechError(f"solver must be one of {', '.join(METHODS)}; got {method!r}")
    have_pardiso, have_chol, have_amg = available("pardiso"), available("cholesky"), available("amg")
    if method == "direct":
        return "pardiso" if have_pardiso else "cholesky" if have_chol else "superlu"
    if method == "auto":
        if have_pardiso and (n <= DIRECT_LIMIT_PARDISO or not have_amg):
            return "pardiso"
        if have_chol and (n <= DIRECT_LIMIT_CHOLESKY or not have_amg):
            return "cholesky"
        if n <= DIRECT_LIMIT_SUPERLU:
            return "superlu"
        return "amg" if have_amg else "cg"
    if not available(method):
        pkg = PACKAGES[method]
        raise GrainmechError(f"solver {method!r} needs the optional package {pkg} "
                             f"(pip install {pkg})")
    return method


#: serialises the use of the shared PARDISO handle (:func:`shared_pardiso`) for factors
_PARDISO_LOCK = threading.Lock()


def pardiso_solver(mtype: int = 2) -> Any:
    """A ``pypardiso.PyPardisoSolver``, its MKL runtime found from the ``mkl`` package's file list.

    pypardiso looks for ``mkl_rt`` with ``ctypes.util.find_library`` (``ldconfig``/``gcc``
    in subprocesses) and then a recursive glob of ``sys.prefix`` unless the environment
    variable ``PYPARDISO_MKL_RT`` names it (0.16-0.4 s per process here). The ``mkl``
    distribution that pypardiso depends on lists the library among its files, so its path
    is set there first (a value the user set is kept; without such a file pypardiso
    searches as before).
    """
    import pypardiso

    if "PYPARDISO_MKL_RT" not in os.environ:
        try:

            found = [f for f in (files("mkl") or []) if "mkl_rt" in f.name]
        except (ImportError, PackageNotFoundError):
            found = []
        for f in sorted(found, key=lambda x: len(str(x))):
            path = os.path.realpath(str(f.locate()))
            if os.path.isfile(path):
                os.environ["PYPARDISO_MKL_RT"] = path
                break
    return pypardiso.PyPardisoSolver(mtype=mtype)


@contextmanager
def one_mkl_thread(ps: Any) -> Iterator[None]:
    """MKL on one thread in the calling thread while the block runs (``ps``: a pypardiso handle).

    PARDISO's multithreaded reordering, after other MKL and OpenMP work in the same
    process (the packing driver, numba's threads), failed with error -3 or spun forever
    in METIS; on one thread it does not, the factor is reproducible, and the operators
    here factor in milliseconds to seconds. The setting is MKL's thread-local one
    (``MKL_Set_Num_Threads_Local``), restored after the block; nothing happens with an
    MKL that lacks it.
    """
    local = getattr(ps.libmkl, "MKL_Set_Num_Threads_Local", None)
    prev = local(1) if local is not None else None
    try:
        yield
    finally:
        if local is not None:
            local(prev)


@functools.cache
def shared_pardiso() -> Any:
    """The one PARDISO handle of this process (real symmetric positive definite).

    It holds the MKL library and its ``pardiso`` entry point: the relaxed tensor factors
    through it (under ``_PARDISO_LOCK``), the packing driver calls ``pardiso`` directly
    with its own factor handles (``driver.packing._operators._Factor``). Made once: even with
    :func:`pardiso_solver`'s look-up, pypardiso's constructor is not free.
    """
    return pardiso_solver(2)


@contextmanager
def _factorised(A: Any, method: str) -> Iterator[Callable[[np.ndarray], np.ndarray]]:
    """Factor ``A`` (CSR, SPD) and yield ``solve(b)`` for (n, k) right-hand sides.

    The factor is released on exit (PARDISO keeps it in MKL's memory until told).
    """
    if method == "pardiso":
        Au = sp.triu(A, format="csr")  # PARDISO reads the upper triangle of a symmetric matrix
        Au.sort_indices()
        with _PARDISO_LOCK:
            ps = shared_pardiso()
            ps.set_matrix_type(2)
            with one_mkl_thread(ps):
                try:
                    ps.factorize(Au)
                except Exception as exc:  # noqa: BLE001 (pypardiso raises its own PyPardisoError)
                    ps.free_memory(everything=True)
                    raise GrainmechError(f"relaxed stiffness: PARDISO factorisation failed ({exc})") from None

                def solve_p(b: np.ndarray) -> np.ndarray:
                    return np.asarray(ps.solve(Au, np.ascontiguousarray(b, dtype=float))).reshape(b.shape)
                try:
                    yield solve_p
                finally:
                    ps.free_memory(everything=True)
        return
    if method == "cholesky":
        from cholespy import CholeskySolverD, MatrixType

        Ac = sp.csr_matrix(A)
        try:
            f = CholeskySolverD(Ac.shape[0], Ac.indptr.astype(np.int32), Ac.indices.astype(np.int32),
                                np.ascontiguousarray(Ac.data, dtype=float), MatrixType.CSR)
        except (ValueError, RuntimeError) as exc:
            raise GrainmechError(f"relaxed stiffness: Cholesky factorisation failed ({exc})") from None

        def solve_c(b: np.ndarray) -> np.ndarray:
            b = np.ascontiguousarray(b, dtype=float)
            x = np.zeros_like(b)
            f.solve(b, x)
            return x
        yield solve_c
        return

    try:
        lu = spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
    except RuntimeError as exc:  # exactly singular even after regularisation
        raise GrainmechError(f"relaxed stiffness: factorisation failed ({exc})") from None
    yield lu.solve


def _amg_cg(As: Any, rhs: np.ndarray, dof_type: np.ndarray, tol: float, maxiter: int
            ) -> tuple[np.ndarray, int, Callable[[np.ndarray], np.ndarray]]:
    """CG with a smoothed-aggregation AMG V-cycle as preconditioner, column by column.

    Solves the shifted system ``As`` (the hierarchy needs a definite matrix); returns the
    solution, the most iterations of any column and the V-cycle as a block preconditioner
    (for :func:`refine_pcg` on the unshifted matrix, :func:`solve_spd`).
    """
    import pyamg

    n = As.shape[0]
    # near-null space: the same unit translation / rotation of every particle
    Bn = np.zeros((n, int(dof_type.max()) + 1))
    Bn[np.arange(n), dof_type] = 1.0
    ml = pyamg.smoothed_aggregation_solver(sp.csr_matrix(As), B=Bn, symmetry="symmetric",
                                           strength=("symmetric", {"theta": 0.0}),
                                           smooth=("jacobi", {"omega": 4.0 / 3.0}),
                                           max_coarse=2000)
    M = ml.aspreconditioner(cycle="V")
    X = np.zeros_like(rhs)
    iters = 0
    for k in range(rhs.shape[1]):
        count = [0]

        def cb(_: Any, c: list[int] = count) -> None:
            c[0] += 1
        x, info = spla.cg(As, rhs[:, k], rtol=tol, atol=0.0, maxiter=maxiter, M=M, callback=cb)
        X[:, k] = x
        iters = max(iters, count[0])

    def apply(R: np.ndarray) -> np.ndarray:
        return np.column_stack([M @ R[:, k] for k in range(R.shape[1])])

    return X, iters, apply


def block_cg(H: Any, rhs: np.ndarray, diag_blocks: np.ndarray, tol: float, maxiter: int,
             ref: np.ndarray, predict_after: int | None = None) -> tuple[np.ndarray, int, float]:
    """Block-Jacobi preconditioned CG, all right-hand sides at once (columns independent).

    Works on the singular ``H`` (zero modes are not excited: the right-hand sides lie in
    its range). Returns the solution, the iterations and the largest relative residual.
    With ``predict_after = k`` the run stops early (unconverged) when, after ``k``
    iterations, the mean reduction rate of the residual so far predicts more than
    ``maxiter`` iterations to reach ``tol``.
    """
    P, b, _ = diag_blocks.shape
    # pseudo-inverse of each diagonal block (handles zero rotation blocks)
    Minv = np.linalg.pinv(diag_blocks, hermitian=True)

    def prec(r: np.ndarray) -> np.ndarray:
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
        if predict_after is not None and it == predict_after and res.max() > tol:
            rate = float(res.max()) ** (1.0 / it)
            if rate >= 1.0 or np.log(tol) / np.log(rate) > maxiter:
                break
    return x, it, float(res.max())


def refine_pcg(A: Any, rhs: np.ndarray, X: np.ndarray, solve: Callable[[np.ndarray], np.ndarray], tol: float,
               maxiter: int) -> tuple[np.ndarray, int, np.ndarray]:
    """Conjugate gradients on ``A X = rhs`` warm-started from ``X``, preconditioned by ``solve``.

    ``solve`` applies an SPD approximate inverse, here the factor of the shifted matrix
    ``(A + S)^-1``. Iterative refinement with it (``X += solve(rhs - A X)``) reduces the
    error in an eigenvector of ``A`` with eigenvalue ``lam`` by ``s / (lam + s)`` per step
    and so stalls on the near-floppy modes (``lam <~ s``) that hold the residual of a
    shifted factorisation; CG on the preconditioned operator ``(A + S)^-1 A``, whose
    spectrum is ``lam / (lam + s)`` (1 except for those few modes), removes each such
    outlying eigenvalue in about one iteration (preconditioned CG: Golub & Van Loan 2013,
    *Matrix Computations*, 4th ed., sec. 11.5; outlying eigenvalues: Greenbaum 1997,
    *Iterative Methods for Solving Linear Systems*, ch. 3). Columns are independent; converged columns stop moving.

    Returns the solution, the iterations (solves with ``solve``) and the true relative
    residual ``|rhs_k - A X_k| / |rhs_k|`` per column.
    """
    nb = np.linalg.norm(rhs, axis=0)
    nb[nb == 0] = 1.0
    R = rhs - A @ X
    res = np.linalg.norm(R, axis=0) / nb
    it = 0
    if res.max() <= tol or maxiter <= 0:
        return X, it, res
    X = X.copy()
    Z = solve(R)
    Pd = Z.copy()
    rz = np.einsum("ij,ij->j", R, Z)
    while it < maxiter:
        active = res > tol
        AP = A @ Pd
        pAp = np.einsum("ij,ij->j", Pd, AP)
        ok = active & (pAp > 0) & (rz > 0)
        alpha = np.where(ok, rz / np.where(ok, pAp, 1.0), 0.0)
        X += Pd * alpha
        R -= AP * alpha
        it += 1
        res = np.linalg.norm(R, axis=0) / nb
        if res.max() <= tol:
            # the recurred residual drifts from the true one: confirm, else go on from it
            R = rhs - A @ X
            res = np.linalg.norm(R, axis=0) / nb
            if res.max() <= tol:
                break
        Z = solve(R)
        rz_new = np.einsum("ij,ij->j", R, Z)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        Pd = Z + Pd * beta
        rz = rz_new
    res = np.linalg.norm(rhs - A @ X, axis=0) / nb
    return X, it, res


def solve_spd(A: Any, rhs: np.ndarray, method: str, *, dof_type: np.ndarray, shift: np.ndarray | None = None,
              tol: float = 1e-10, maxiter: int = 20000, refine: int = 50) -> tuple[np.ndarray, int, np.ndarray]:
    """Solve ``A X = rhs`` with ``method`` (see :func:`choose`).

    ``A`` sparse symmetric positive semi-definite, ``rhs`` (n, k) in its range.

    Parameters
    ----------
    dof_type : int array (n,)
        Kind of each unknown (translation x, y, z, rotation x, y, z) for the AMG near-null
        space.
    shift : array (n,), optional
        Diagonal added to ``A`` before it is factored (lifts the zero modes; ``amg``
        builds its hierarchy on it and runs CG on it). Every method then checks the true
        residual of every column against ``A`` itself and, while it is above ``tol``,
        runs at most ``refine`` steps of CG on ``A`` preconditioned by the factor (the
        V-cycle) and warm-started from its solution (:func:`refine_pcg`), so the shift
        does not change the answer in the range of ``A``. On a well-conditioned system
        this costs one residual check.

    Returns
    -------
    X : array (n, k)
    iterations : int
        Solves with the factor (1 + refinement steps) for direct methods; for ``amg`` the
        most CG iterations of any column plus the refinement steps.
    residual : array (k,)
        True relative residual ``|rhs_k - A X_k| / |rhs_k|`` of each column; the caller
        decides whether it is good enough (a direct method returns it even above ``tol``).
    """
    As = A if shift is None else (A + sp.diags(shift)).tocsr()
    if method in ("pardiso", "cholesky", "superlu"):
        with _factorised(As, method) as solve:
            X, steps, res = refine_pcg(A, rhs, solve(rhs), solve, tol, refine)
        return X, 1 + steps, res
    if method == "amg":
        # CG on the shifted system leaves its error in the near-floppy modes (where the
        # shift acts), as a shifted factorisation does: refined the same way, by CG on A
        # preconditioned by the V-cycle, checked against the true residual
        X, iters, apply = _amg_cg(As, rhs, dof_type, tol, maxiter)
        X, steps, res = refine_pcg(A, rhs, X, apply, tol, refine)
        return X, iters + steps, res
    raise GrainmechError(f"solve_spd: unknown method {method!r}")

"""Stiffness input handling, checks, compliance, Kelvin moduli and rotations.

Stiffness input handling, checks, compliance, Kelvin moduli and rotations
(library Voigt order; Mandel form internally, see :mod:`grainmech.elasticity`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from grainmech.conventions import (
    ORDER_2D,
    ORDER_3D,
    mandel_to_voigt,
    matrix_to_tensor4,
    tensor4_to_matrix,
    voigt_to_mandel,
)
from grainmech.errors import GrainmechError

_SQ2 = float(np.sqrt(2.0))


def _as_voigt(C: np.ndarray, name: str = "C") -> tuple[np.ndarray, bool]:
    """Return ``(voigt_matrix, was_tensor4)``; shape errors name the argument."""
    arr = np.asarray(C, dtype=float)
    if arr.shape in ((3, 3, 3, 3), (2, 2, 2, 2)):
        return tensor4_to_matrix(arr), True
    if arr.shape in ((6, 6), (3, 3)):
        return arr.copy(), False
    raise GrainmechError(
        f"{name} must be a 6x6 (3D) or 3x3 (2D) Voigt matrix or a (3,3,3,3)/(2,2,2,2) "
        f"tensor; got shape {arr.shape}")


def _dim(M: np.ndarray) -> int:
    return 3 if M.shape[0] == 6 else 2


def _output(M: np.ndarray, tensor4: bool) -> np.ndarray:
    return matrix_to_tensor4(M) if tensor4 else M


def _check_finite_symmetric(M: np.ndarray, tol: float, name: str = "C") -> None:
    if not np.all(np.isfinite(M)):
        bad = np.argwhere(~np.isfinite(M))[0]
        raise GrainmechError(
            f"{name} has a non-finite entry {name}[{bad[0]}, {bad[1]}] = {M[tuple(bad)]!r}")
    scale = float(np.max(np.abs(M)))
    if scale == 0.0:
        raise GrainmechError(f"{name} is identically zero")
    asym = np.abs(M - M.T)
    i, j = np.unravel_index(np.argmax(asym), asym.shape)
    if asym[i, j] > tol * scale:
        raise GrainmechError(
            f"{name} is not symmetric: {name}[{i}, {j}] = {M[i, j]:.6g} but "
            f"{name}[{j}, {i}] = {M[j, i]:.6g} (relative difference "
            f"{asym[i, j] / scale:.3g} > tol = {tol:g})")


def kelvin_moduli(C: np.ndarray) -> np.ndarray:
    """Eigenvalues of the Mandel (Kelvin) stiffness matrix, ascending.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Stiffness (library Voigt order, or tensor).

    Returns
    -------
    array, shape (6,) or (3,)
        The Kelvin moduli (Mehrabadi & Cowin 1990), units of ``C``.  They are the
        eigenvalues of ``C`` as a map on symmetric tensors and do not depend on the frame.
        Their multiplicities are a necessary (not sufficient) symmetry fingerprint:
        isotropic (1, 5), cubic (1, 2, 3), transversely isotropic at least two double
        eigenvalues.
    """
    M, _ = _as_voigt(C)
    Mm = voigt_to_mandel(M)
    return np.linalg.eigvalsh(0.5 * (Mm + Mm.T))


def check_stiffness(C: np.ndarray, tol: float = 1e-10, name: str = "C") -> np.ndarray:
    """Check that a stiffness is finite, symmetric and positive definite.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Stiffness (library Voigt order, or tensor).
    tol : float
        Relative tolerance.  Symmetry: ``|C_ij - C_ji| <= tol * max|C|``.  Positive
        definiteness: the smallest Kelvin modulus must exceed ``tol * largest``.
    name : str
        Name of the argument used in error messages.

    Returns
    -------
    array
        The Kelvin moduli (eigenvalues of the Mandel matrix), ascending.

    Raises
    ------
    GrainmechError
        Wrong shape, non-finite entries, asymmetry, or not positive definite (the message
        gives the smallest and largest Kelvin moduli).
    """
    M, _ = _as_voigt(C, name)
    _check_finite_symmetric(M, tol, name)
    lam = kelvin_moduli(0.5 * (M + M.T))
    if not lam[0] > tol * abs(lam[-1]):
        raise GrainmechError(
            f"{name} is not positive definite: smallest Kelvin (Mandel) eigenvalue = "
            f"{lam[0]:.6g}, largest = {lam[-1]:.6g} (all eigenvalues: "
            f"{np.array2string(lam, precision=4)})")
    return lam


def compliance(C: np.ndarray, tol: float = 1e-10) -> np.ndarray:
    """Compliance (inverse stiffness).

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Positive-definite stiffness.  A Voigt matrix (acting on engineering strain) gives
        a Voigt compliance ``S = C^-1`` that maps the stress vector to the engineering
        strain vector (so ``S_44 = 1/G_yz``).  A tensor gives the compliance tensor
        ``S_ijkl`` with ``e_ij = S_ijkl s_kl`` (inverted through the Mandel form, so the
        factors of 2 and 4 on shear entries are right).
    tol : float
        Passed to :func:`check_stiffness`.

    Returns
    -------
    array, same shape as ``C``, units 1/[C].

    Raises
    ------
    GrainmechError
        If ``C`` is singular or not positive definite (naming the smallest eigenvalue).
    """
    M, t4 = _as_voigt(C)
    check_stiffness(M, tol)
    M = 0.5 * (M + M.T)
    if t4:
        Sm = np.linalg.inv(voigt_to_mandel(M))
        return matrix_to_tensor4(0.5 * (Sm + Sm.T), mandel=True)
    S = np.linalg.inv(M)
    return 0.5 * (S + S.T)


def contracted_tensors(C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two contracted second-order tensors of Cowin & Mehrabadi (1987).

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)

    Returns
    -------
    d, v : arrays, shape (dim, dim)
        Dilatational ``d_ij = C_ijkk`` and Voigt ``v_ij = C_ikjk`` tensors.  The normal of
        every symmetry plane of ``C`` is an eigenvector of both.
    """
    M, _ = _as_voigt(C)
    T = matrix_to_tensor4(M)
    return np.einsum("ijkk->ij", T), np.einsum("ikjk->ij", T)


def _unit(vec: ArrayLike, dim: int, name: str) -> np.ndarray:
    v = np.asarray(vec, dtype=float)
    if v.shape[-1:] != (dim,):
        raise GrainmechError(f"{name} must have trailing dimension {dim}; got shape {v.shape}")
    nrm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(~np.isfinite(nrm)) or np.any(nrm == 0):
        raise GrainmechError(f"{name} contains a zero or non-finite vector")
    return v / nrm


def _frame_from_axis(a: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """Right-handed frame whose third axis is ``a``.

    Right-handed frame (rows x', y', a) with x' the projection of ``ref`` (default e_x,
    else e_y) onto the plane normal to ``a``.
    """
    a = a / np.linalg.norm(a)
    cands = [ref] if ref is not None else []
    cands += [np.array([1.0, 0, 0]), np.array([0, 1.0, 0])]
    for r in cands:
        t = r - np.dot(r, a) * a
        if np.linalg.norm(t) > 1e-3:
            break
    t = t / np.linalg.norm(t)
    return np.array([t, np.cross(a, t), a])


def rotation_about(axis: ArrayLike, angle: float) -> np.ndarray:
    """Proper rotation matrix by ``angle`` (radians, right-handed) about ``axis``."""
    a = _unit(axis, 3, "axis")
    return Rotation.from_rotvec(a * float(angle)).as_matrix()


@lru_cache(maxsize=2)
def _mandel_index(dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index pairs (i, j) of the Mandel components and their weights (1 or sqrt 2)."""
    order = ORDER_3D if dim == 3 else ORDER_2D
    i = np.array(["xyz".index(lab[0]) for lab in order])
    j = np.array(["xyz".index(lab[1]) for lab in order])
    w = np.where(i == j, 1.0, _SQ2)
    return i, j, w


def _mandel_rot(R: np.ndarray) -> np.ndarray:
    """Orthogonal Mandel map ``K`` with ``M' = K M K^T`` for ``C'_ijkl = R_ia R_jb R_kc R_ld C_abcd``.

    ``R`` has shape (..., d, d); returns (..., m, m).  With ``(i, j)`` the index pair of
    Mandel component ``a`` and ``(k, l)`` that of ``b``,
    ``K_ab = w_a w_b (R_ik R_jl + R_il R_jk) / 2`` (``w = 1`` normal, ``sqrt 2`` shear),
    i.e. ``K_ab = B_a : (R B_b R^T)`` for the orthonormal Mandel basis ``B``.
    """
    R = np.asarray(R, dtype=float)
    i, j, w = _mandel_index(R.shape[-1])
    I, J = i[:, None], j[:, None]
    Kk, L = i[None, :], j[None, :]
    return (w[:, None] * w[None, :] / 2.0) * (R[..., I, Kk] * R[..., J, L] + R[..., I, L] * R[..., J, Kk])


def _check_orthogonal(R: np.ndarray, dim: int, atol: float = 1e-8) -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (dim, dim):
        raise GrainmechError(f"R must have shape (..., {dim}, {dim}) for this stiffness; "
                             f"got {R.shape}")
    err = np.max(np.abs(np.einsum("...ki,...kj->...ij", R, R) - np.eye(dim)))
    if not err <= atol:
        raise GrainmechError(f"R is not orthogonal: max |R^T R - I| = {err:.3g}")
    return R


def rotate_stiffness(C: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Transform a stiffness by an orthogonal matrix: ``C'_ijkl = R_ia R_jb R_kc R_ld C_abcd``.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
    R : array, shape (..., 3, 3) or (..., 2, 2)
        Orthogonal matrix (improper allowed).  If the rows of ``R`` are new basis vectors
        expressed in the old frame, ``C'`` holds the components in the new frame; if ``R``
        rotates the material, ``C'`` is the rotated material in the old frame.

    Returns
    -------
    array, shape (..., 6, 6) etc., in the same form (Voigt or tensor) as ``C``.
    """
    M, t4 = _as_voigt(C)
    dim = _dim(M)
    R = _check_orthogonal(R, dim)
    K = _mandel_rot(R)
    Mm = voigt_to_mandel(M)
    out = K @ Mm @ np.swapaxes(K, -1, -2)
    if out.ndim == 2:
        return _output(mandel_to_voigt(out), t4)
    flat = out.reshape(-1, *out.shape[-2:])
    res = np.stack([_output(mandel_to_voigt(x), t4) for x in flat])
    return res.reshape(out.shape[:-2] + res.shape[1:])

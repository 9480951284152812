"""Matrix forms of stiffness shared by the elasticity modules.

Input handling (a Voigt matrix or a fourth-order tensor in, the same form out, shape and
symmetry checks whose errors name the argument), unit vectors and frames, the Mandel map
of a rotation, and the orthogonal projection onto isotropic tensors (spherical and
deviatoric projectors). Library Voigt order (``docs/conventions.md``); Mandel form for the
algebra (orthonormal basis, shear components times ``sqrt 2``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike

from grainmech.conventions import ORDER_2D, ORDER_3D, matrix_to_tensor4, tensor4_to_matrix
from grainmech.errors import GrainmechError

_SQ2 = float(np.sqrt(2.0))


def as_voigt(C: np.ndarray, name: str = "C") -> tuple[np.ndarray, bool]:
    """Return ``(voigt_matrix, was_tensor4)``; shape errors name the argument."""
    arr = np.asarray(C, dtype=float)
    if arr.shape in ((3, 3, 3, 3), (2, 2, 2, 2)):
        return tensor4_to_matrix(arr), True
    if arr.shape in ((6, 6), (3, 3)):
        return arr.copy(), False
    raise GrainmechError(
        f"{name} must be a 6x6 (3D) or 3x3 (2D) Voigt matrix or a (3,3,3,3)/(2,2,2,2) "
        f"tensor; got shape {arr.shape}")


def dimension(M: np.ndarray) -> int:
    """Dimension (3 or 2) of a Voigt or Mandel matrix (6 x 6 or 3 x 3)."""
    return 3 if M.shape[0] == 6 else 2


def as_given(M: np.ndarray, tensor4: bool) -> np.ndarray:
    """``M`` in the form the caller gave its input: the fourth-order tensor if ``tensor4``, else the matrix."""
    return matrix_to_tensor4(M) if tensor4 else M


def check_finite_symmetric(M: np.ndarray, tol: float, name: str = "C") -> None:
    """Raise a :class:`~grainmech.errors.GrainmechError` naming the entry: ``M`` not finite, zero or asymmetric."""
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


def unit_vectors(vec: ArrayLike, dim: int, name: str) -> np.ndarray:
    """``vec`` (..., dim) normalised; a wrong shape, zero or non-finite vector raises naming ``name``."""
    v = np.asarray(vec, dtype=float)
    if v.shape[-1:] != (dim,):
        raise GrainmechError(f"{name} must have trailing dimension {dim}; got shape {v.shape}")
    nrm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(~np.isfinite(nrm)) or np.any(nrm == 0):
        raise GrainmechError(f"{name} contains a zero or non-finite vector")
    return v / nrm


def frame_from_axis(a: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
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


@lru_cache(maxsize=2)
def _mandel_index(dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index pairs (i, j) of the Mandel components and their weights (1 or sqrt 2)."""
    order = ORDER_3D if dim == 3 else ORDER_2D
    i = np.array(["xyz".index(lab[0]) for lab in order])
    j = np.array(["xyz".index(lab[1]) for lab in order])
    w = np.where(i == j, 1.0, _SQ2)
    return i, j, w


def mandel_rotation(R: np.ndarray) -> np.ndarray:
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


def check_orthogonal(R: np.ndarray, dim: int, atol: float = 1e-8) -> np.ndarray:
    """``R`` (..., dim, dim) as floats; raises if its shape does not fit or ``R^T R`` is not ``I`` to ``atol``."""
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (dim, dim):
        raise GrainmechError(f"R must have shape (..., {dim}, {dim}) for this stiffness; "
                             f"got {R.shape}")
    err = np.max(np.abs(np.einsum("...ki,...kj->...ij", R, R) - np.eye(dim)))
    if not err <= atol:
        raise GrainmechError(f"R is not orthogonal: max |R^T R - I| = {err:.3g}")
    return R


def isotropic_projectors(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Mandel matrices of the spherical (J) and deviatoric (Kd) projectors."""
    m = np.zeros(6 if dim == 3 else 3)
    m[:dim] = 1.0
    J = np.outer(m, m) / dim
    return J, np.eye(m.size) - J


def isotropic_moduli(Mm: np.ndarray, dim: int) -> tuple[float, float]:
    """Bulk and shear moduli of the isotropic projection of a Mandel matrix."""
    J, Kd = isotropic_projectors(dim)
    ndev = Kd.shape[0] - 1
    # P(C) = dim*K J + 2 G Kd  (3D: 3K J + 2G Kd; 2D: 2K J + 2G Kd)
    return float(np.sum(J * Mm)) / dim, float(np.sum(Kd * Mm)) / (2.0 * ndev)


def isotropic_projection(Mm: np.ndarray, dim: int) -> np.ndarray:
    """Orthogonal projection of a Mandel matrix onto the isotropic tensors: ``dim K J + 2 G Kd``."""
    J, Kd = isotropic_projectors(dim)
    K, G = isotropic_moduli(Mm, dim)
    return dim * K * J + 2 * G * Kd

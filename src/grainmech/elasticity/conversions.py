"""Stiffness input handling, checks, compliance, Kelvin moduli and rotations.

Stiffness input handling, checks, compliance, Kelvin moduli and rotations
(library Voigt order; Mandel form internally, see :mod:`grainmech.elasticity`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from grainmech.conventions import (
    mandel_to_voigt,
    matrix_to_tensor4,
    voigt_to_mandel,
)
from grainmech.elasticity._mandel import (
    as_given,
    as_voigt,
    check_finite_symmetric,
    check_orthogonal,
    dimension,
    mandel_rotation,
    unit_vectors,
)
from grainmech.errors import GrainmechError


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
    M, _ = as_voigt(C)
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
    M, _ = as_voigt(C, name)
    check_finite_symmetric(M, tol, name)
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
    M, t4 = as_voigt(C)
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
    M, _ = as_voigt(C)
    T = matrix_to_tensor4(M)
    return np.einsum("ijkk->ij", T), np.einsum("ikjk->ij", T)


def rotation_about(axis: ArrayLike, angle: float) -> np.ndarray:
    """Proper rotation matrix by ``angle`` (radians, right-handed) about ``axis``."""
    a = unit_vectors(axis, 3, "axis")
    return Rotation.from_rotvec(a * float(angle)).as_matrix()


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
    M, t4 = as_voigt(C)
    dim = dimension(M)
    R = check_orthogonal(R, dim)
    K = mandel_rotation(R)
    Mm = voigt_to_mandel(M)
    out = K @ Mm @ np.swapaxes(K, -1, -2)
    if out.ndim == 2:
        return as_given(mandel_to_voigt(out), t4)
    flat = out.reshape(-1, *out.shape[-2:])
    res = np.stack([as_given(mandel_to_voigt(x), t4) for x in flat])
    return res.reshape(out.shape[:-2] + res.shape[1:])

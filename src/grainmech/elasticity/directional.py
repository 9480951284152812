"""Directional Young's modulus, Poisson's ratio and shear modulus of a stiffness."""

from __future__ import annotations

import numpy as np

from grainmech.conventions import stress_to_vector, voigt_to_mandel
from grainmech.elasticity._mandel import as_voigt, dimension, unit_vectors
from grainmech.elasticity.conversions import check_stiffness
from grainmech.errors import GrainmechError


def _mandel_compliance(C: np.ndarray) -> tuple[np.ndarray, int]:
    M, _ = as_voigt(C)
    check_stiffness(M)
    Sm = np.linalg.inv(voigt_to_mandel(0.5 * (M + M.T)))
    return 0.5 * (Sm + Sm.T), dimension(M)


def directional_young(C: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Young's modulus along direction(s) ``d``: ``E(d) = 1 / (d d : S : d d)``.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3) or tensor
        Positive-definite stiffness.
    d : array, shape (..., 3) or (..., 2)
        Direction(s); normalised internally.

    Returns
    -------
    array, shape (...)
        Units of ``C``.  Equals ``E_xx`` for ``d = (1, 0, 0)`` etc.
    """
    Sm, dim = _mandel_compliance(C)
    n = unit_vectors(d, dim, "d")
    a = stress_to_vector(n[..., :, None] * n[..., None, :], mandel=True)
    return 1.0 / np.einsum("...a,ab,...b->...", a, Sm, a)


def directional_poisson(C: np.ndarray, d: np.ndarray, m: np.ndarray,
                        atol: float = 1e-8) -> np.ndarray:
    """Poisson's ratio for loading along ``d`` and lateral direction ``m``.

    ``nu(d, m) = -e_mm / e_dd = -E(d) (m m : S : d d)`` under uniaxial stress along ``d``.

    Parameters
    ----------
    C : array
        Positive-definite stiffness.
    d, m : arrays, shape (..., 3) or (..., 2), broadcastable
        Loading and lateral directions (normalised internally); must be orthogonal.
    atol : float
        Tolerance on ``|d . m|`` after normalisation.

    Returns
    -------
    array, shape (...)
        Dimensionless.  ``directional_poisson(C, ex, ey) == engineering_constants(C).nu_xy``.
    """
    Sm, dim = _mandel_compliance(C)
    n = unit_vectors(d, dim, "d")
    t = unit_vectors(m, dim, "m")
    dot = np.abs(np.sum(n * t, axis=-1))
    if np.any(dot > atol):
        raise GrainmechError(f"m must be orthogonal to d; max |d . m| = {np.max(dot):.3g}")
    a = stress_to_vector(n[..., :, None] * n[..., None, :], mandel=True)
    b = stress_to_vector(t[..., :, None] * t[..., None, :], mandel=True)
    return -np.einsum("...a,ab,...b->...", b, Sm, a) / np.einsum("...a,ab,...b->...", a, Sm, a)


def directional_shear(C: np.ndarray, d: np.ndarray, m: np.ndarray,
                      atol: float = 1e-8) -> np.ndarray:
    """Shear modulus in the plane of orthogonal directions ``d`` and ``m``.

    ``G(d, m) = 1 / (4 sym(d m) : S : sym(d m))`` -- the ratio of the shear stress
    ``s_dm`` to the engineering shear strain ``2 e_dm`` when only ``s_dm`` acts.

    Parameters
    ----------
    C : array
        Positive-definite stiffness.
    d, m : arrays, shape (..., 3) or (..., 2), broadcastable, orthogonal.

    Returns
    -------
    array, shape (...), units of ``C``.  ``G(ey, ez) = G_yz``.
    """
    Sm, dim = _mandel_compliance(C)
    n = unit_vectors(d, dim, "d")
    t = unit_vectors(m, dim, "m")
    dot = np.abs(np.sum(n * t, axis=-1))
    if np.any(dot > atol):
        raise GrainmechError(f"m must be orthogonal to d; max |d . m| = {np.max(dot):.3g}")
    P = 0.5 * (n[..., :, None] * t[..., None, :] + t[..., :, None] * n[..., None, :])
    a = stress_to_vector(P, mandel=True)
    return 1.0 / (4.0 * np.einsum("...a,ab,...b->...", a, Sm, a))

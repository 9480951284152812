"""Closed-form contact geometry and stiffness: pure, vectorised functions.

These are the formulas the assembly calls directly for a given (e.g. isotropic) state,
and the building blocks of the incremental laws in :mod:`grainmech.contact.law`.
All functions broadcast over array arguments and never return NaN for admissible
input: a non-positive approach or force gives a zero force, radius and stiffness.

Compression positive: ``approach > 0`` means overlap, ``N >= 0`` compressive.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from grainmech.contact._errors import ContactDomainError

if TYPE_CHECKING:  # annotations only: params imports this module (its stiffness methods)
    from grainmech.contact.params import Cylinder, Hertz, LinearSpring

__all__ = [
    "hertz_force",
    "hertz_radius",
    "hertz_radius_from_approach",
    "hertz_kn",
    "mindlin_kt0",
    "hertz_energy",
    "spring_energy",
    "hertz_normal_force",
    "hertz_contact_radius",
    "hertz_contact_radius_from_force",
    "hertz_approach_from_force",
    "hertz_normal_stiffness",
    "hertz_normal_stiffness_from_approach",
    "mindlin_tangential_stiffness",
    "mindlin_tangential_stiffness_from_force",
    "cylinder_contact_halfwidth",
    "cylinder_normal_stiffness",
    "cylinder_approach_from_force",
    "cylinder_normal_force",
    "cylinder_tangential_stiffness",
]


try:  # one definition of the Hertz/Mindlin closed forms for NumPy and compiled code
    from numba.extending import register_jitable as _jitable
except ImportError:  # pragma: no cover - numba is optional
    def _jitable(fn):  # type: ignore[no-redef]  # the NumPy stand-in for numba's decorator
        return fn


# ---------------------------------------------------------------------------------------
# Hertz/Mindlin closed forms in the effective constants (E*, R*, G*). Each is written once
# and serves scalars and arrays in NumPy and, through ``register_jitable``, compiled code
# (the per-contact kernel of :mod:`grainmech.contact.kernel`, the driver's compiled pass).
# ---------------------------------------------------------------------------------------
@_jitable
def hertz_force(alpha, E, R):
    """``N = (4/3) E* R*^(1/2) alpha^(3/2)``, 0 for ``alpha <= 0`` (seed Eq. 3.6) [N]."""
    a = np.maximum(alpha, 0.0)
    return (4.0 / 3.0) * E * np.sqrt(R) * a * np.sqrt(a)


@_jitable
def hertz_radius(N, E, R):
    """Contact radius ``a = (3 N R* / (4 E*))^(1/3)``, 0 for ``N <= 0`` (seed Eq. 3.2) [m]."""
    return np.cbrt(0.75 * np.maximum(N, 0.0) * R / E)


@_jitable
def hertz_radius_from_approach(alpha, R):
    """Contact radius ``a = (R* alpha)^(1/2)``, 0 for ``alpha <= 0`` (seed Eq. 3.5) [m]."""
    return np.sqrt(R * np.maximum(alpha, 0.0))


@_jitable
def hertz_kn(a, E):
    """Normal stiffness ``kn = dN/dalpha = 2 E* a`` from the contact radius (seed Eq. 3.7) [N/m]."""
    return 2.0 * E * a


@_jitable
def mindlin_kt0(a, G):
    """No-slip tangential stiffness ``kt0 = 8 G* a`` [N/m] (Mindlin 1949; seed Eq. 3.11-3.12).

    No-slip tangential stiffness ``kt0 = 8 G* a`` (Mindlin 1949; seed Eq. 3.11 with theta = 1,
    ``G*`` of Eq. 3.12), 0 for ``a <= 0`` [N/m].
    """
    return 8.0 * G * np.maximum(a, 0.0)


@_jitable
def hertz_energy(N, alpha):
    """Elastic energy of the Hertz normal law, ``int N dalpha = (2/5) N alpha`` (seed Eq. 3.6) [J]."""
    return 0.4 * N * np.maximum(alpha, 0.0)


@_jitable
def spring_energy(N, alpha):
    """Elastic energy of a linear normal spring, ``N alpha / 2`` [J]."""
    return 0.5 * N * np.maximum(alpha, 0.0)


def _pos(x: ArrayLike) -> np.ndarray:
    """``max(x, 0)`` as a float array (NaN-free for finite input)."""
    return np.maximum(np.asarray(x, dtype=float), 0.0)


# ---------------------------------------------------------------------------------------
# Hertz: spheres (seed Eq. 3.1-3.7)
# ---------------------------------------------------------------------------------------
def hertz_normal_force(approach: ArrayLike, params: Hertz) -> np.ndarray:
    """Normal force of a Hertz contact from the approach (seed Eq. 3.6).

    ``N = (4/3) E* R*^(1/2) alpha^(3/2)`` for ``alpha > 0``, else 0.

    Parameters
    ----------
    approach : array_like, shape (n,)
        Approach (overlap) of the sphere centres ``alpha`` [m].
    params : Hertz
        Any :class:`Hertz`-derived parameter object.

    Returns
    -------
    ndarray, shape (n,)
        Normal force ``N`` [N].
    """
    return hertz_force(_pos(approach), params.effective_modulus, params.effective_radius)


def hertz_contact_radius(approach: ArrayLike, params: Hertz) -> np.ndarray:
    """Contact radius from the approach, ``a = (R* alpha)^(1/2)`` (seed Eq. 3.5) [m]."""
    return hertz_radius_from_approach(_pos(approach), params.effective_radius)


def hertz_contact_radius_from_force(normal_force: ArrayLike, params: Hertz) -> np.ndarray:
    """Contact radius from the normal force, ``a^3 = 3 N R* / (4 E*)`` (seed Eq. 3.2) [m].

    Parameters
    ----------
    normal_force : array_like, shape (n,)
        ``N`` [N]; non-positive values give ``a = 0``.
    params : Hertz
    """
    return hertz_radius(_pos(normal_force), params.effective_modulus, params.effective_radius)


def hertz_approach_from_force(normal_force: ArrayLike, params: Hertz) -> np.ndarray:
    """Approach from the normal force, ``alpha^3 = 9 N^2 / (16 R* E*^2)`` (seed Eq. 3.1) [m]."""
    a = hertz_contact_radius_from_force(normal_force, params)
    return a * a / params.effective_radius


def hertz_normal_stiffness(normal_force: ArrayLike, params: Hertz) -> np.ndarray:
    """Incremental normal stiffness ``kn = dN/dalpha = 2 E* a`` (seed Eq. 3.7) [N/m].

    Parameters
    ----------
    normal_force : array_like, shape (n,)
        Current normal force ``N`` [N]; ``a`` from seed Eq. 3.2.
    params : Hertz
    """
    return hertz_kn(hertz_contact_radius_from_force(normal_force, params), params.effective_modulus)


def hertz_normal_stiffness_from_approach(approach: ArrayLike, params: Hertz) -> np.ndarray:
    """``kn = 2 E* a`` with ``a = (R* alpha)^(1/2)`` (seed Eq. 3.5, 3.7) [N/m]."""
    return hertz_kn(hertz_contact_radius(approach, params), params.effective_modulus)


def mindlin_tangential_stiffness(contact_radius: ArrayLike, params: Hertz) -> np.ndarray:
    """No-slip tangential stiffness ``kt = 8 G* a`` (Mindlin 1949; seed Eq. 3.11, theta=1).

    Parameters
    ----------
    contact_radius : array_like, shape (n,)
        Contact radius ``a`` [m].
    params : Hertz
        ``G*`` from seed Eq. 3.12, ``1/G* = (2-nu1)/G1 + (2-nu2)/G2``.

    Returns
    -------
    ndarray, shape (n,)
        [N/m]. For equal spheres ``8 G* a = 4 G a / (2 - nu)``.
    """
    return mindlin_kt0(_pos(contact_radius), params.effective_shear_modulus)


def mindlin_tangential_stiffness_from_force(normal_force: ArrayLike, params: Hertz) -> np.ndarray:
    """``8 G* a(N)`` with ``a`` from seed Eq. 3.2 [N/m]."""
    return mindlin_tangential_stiffness(hertz_contact_radius_from_force(normal_force, params), params)


# ---------------------------------------------------------------------------------------
# Cylinders: line contact per unit length (seed Eq. 3.8, 3.17)
# ---------------------------------------------------------------------------------------
def _cyl_c(params: Cylinder) -> float:
    """``a^2 = c N`` with ``c = 2 (1-nu) R / (pi G)``."""
    return 2.0 * (1.0 - params.poisson) * params.equivalent_radius / (math.pi * params.shear_modulus_equiv)


def cylinder_contact_halfwidth(normal_force: ArrayLike, params: Cylinder) -> np.ndarray:
    """Half-width of the contact strip, ``a = (2 (1-nu) N R / (pi G))^(1/2)`` (seed Eq. 3.8) [m].

    Parameters
    ----------
    normal_force : array_like, shape (n,)
        Force per unit length ``N`` [N/m].
    params : Cylinder
    """
    return np.sqrt(_cyl_c(params) * _pos(normal_force))


def _cyl_log(normal_force: np.ndarray, params: Cylinder) -> np.ndarray:
    """``ln(2R/a)`` (finite: a zero force gives a large but finite value)."""
    N = np.maximum(normal_force, 1e-300)
    # ln(2R/a) = ln(2R) - 0.5 ln(c N)
    return math.log(2.0 * params.equivalent_radius) - 0.5 * (math.log(_cyl_c(params)) + np.log(N))


def _check_cyl_domain(normal_force: np.ndarray, params: Cylinder) -> None:
    bad = normal_force >= params.max_normal_force
    if np.any(bad):
        raise ContactDomainError(
            f"cylinder normal force {float(np.max(normal_force[bad])):.6g} N/m reaches the limit "
            f"{params.max_normal_force:.6g} N/m of seed Eq. 3.8 (2 ln(2R/a) <= 1: the printed "
            f"stiffness would be infinite or negative)")


def cylinder_normal_stiffness(normal_force: ArrayLike, params: Cylinder) -> np.ndarray:
    """Normal stiffness per unit length of a rod contact (seed Eq. 3.8) [Pa].

    ``1/Kn = (1-nu)/(pi G) [2 ln(2R/a) - 1]`` with ``a`` from
    :func:`cylinder_contact_halfwidth`. ``Kn -> 0`` as ``N -> 0`` (logarithmically).

    Raises
    ------
    ContactDomainError
        If ``N`` reaches :attr:`Cylinder.max_normal_force` (``2 ln(2R/a) <= 1``).
    """
    N = _pos(normal_force)
    _check_cyl_domain(N, params)
    L = _cyl_log(N, params)
    out = math.pi * params.shear_modulus_equiv / ((1.0 - params.poisson) * (2.0 * L - 1.0))
    return np.where(N > 0.0, out, 0.0)


def cylinder_approach_from_force(normal_force: ArrayLike, params: Cylinder) -> np.ndarray:
    """Approach of a rod contact, the integral of seed Eq. 3.8 [m].

    ``alpha(N) = 2 (1-nu) N / (pi G) ln(2R/a(N))``; its derivative
    ``dalpha/dN = (1-nu)/(pi G) [2 ln(2R/a) - 1]`` is exactly the seed's ``1/Kn``
    (``a`` grows as ``N^(1/2)``).
    """
    N = _pos(normal_force)
    _check_cyl_domain(N, params)
    out = 2.0 * (1.0 - params.poisson) * N / (math.pi * params.shear_modulus_equiv) * _cyl_log(N, params)
    return np.where(N > 0.0, out, 0.0)


def cylinder_normal_force(approach: ArrayLike, params: Cylinder) -> np.ndarray:
    """Inverse of :func:`cylinder_approach_from_force` (safeguarded Newton) [N/m].

    Raises
    ------
    ContactDomainError
        If the approach exceeds ``2R/e``, the largest approach of the law.
    """
    alpha = _pos(approach)
    nmax = params.max_normal_force
    amax = 2.0 * params.equivalent_radius / math.e  # alpha(N_max), where 2 ln(2R/a) = 1
    if np.any(alpha >= amax):
        raise ContactDomainError(
            f"cylinder approach {float(np.max(alpha)):.6g} m exceeds 2R/e = {amax:.6g} m, "
            f"the largest approach for which seed Eq. 3.8 holds")
    k = 2.0 * (1.0 - params.poisson) / (math.pi * params.shear_modulus_equiv)
    lo = np.zeros_like(alpha)
    hi = np.full_like(alpha, nmax)
    # initial guess: N ~ alpha / (k ln(2R/a)) iterated once from a rough log value
    N = np.minimum(alpha / (k * 5.0), 0.5 * nmax)
    pos = alpha > 0.0
    active = pos.copy()  # each contact iterates until *it* has converged (results independent of n)
    for _ in range(200):
        if not np.any(active):
            break
        Nc = np.maximum(N, 1e-300)
        f = k * Nc * _cyl_log(Nc, params) - alpha
        df = 0.5 * k * (2.0 * _cyl_log(Nc, params) - 1.0)
        lo = np.where(active & (f < 0.0), N, lo)
        hi = np.where(active & (f >= 0.0), N, hi)
        Nn = N - f / df
        bad = ~((Nn > lo) & (Nn < hi))
        Nn = np.where(bad, 0.5 * (lo + hi), Nn)
        conv = np.abs(Nn - N) <= 1e-15 * np.maximum(Nn, 1e-300)
        N = np.where(active, Nn, N)
        active = active & ~conv
    return np.where(pos, N, 0.0)


def cylinder_tangential_stiffness(normal_force: ArrayLike, tangential_force: ArrayLike,
                                  params: Cylinder) -> np.ndarray:
    """Shear stiffness per unit length of a rod contact on first loading (seed Eq. 3.17) [Pa].

    ``1/Ks = (Psi/Kn) [1 - |T| / (tan(phi_mu) N)]^(-1/2)``, i.e.
    ``Ks = (Kn/Psi) (1 - |T|/(mu N))^(1/2)``; zero at and beyond sliding and for ``N <= 0``.

    Parameters
    ----------
    normal_force, tangential_force : array_like, shape (n,)
        ``N`` and ``T`` per unit length [N/m].
    params : Cylinder
    """
    N = _pos(normal_force)
    T = np.abs(np.asarray(tangential_force, dtype=float))
    mu = params.friction
    kn = cylinder_normal_stiffness(N, params)
    cap = mu * N
    ratio = np.where(cap > 0.0, T / np.where(cap > 0.0, cap, 1.0), 1.0)
    return kn / params.psi * np.sqrt(np.clip(1.0 - ratio, 0.0, 1.0))


def linear_normal_force(approach: ArrayLike, params: LinearSpring) -> np.ndarray:
    """``N = kn max(alpha, 0)`` [N]."""
    return params.kn * _pos(approach)

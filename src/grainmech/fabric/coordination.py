r"""Packing density and coordination-number / void-ratio correlations (seed Sec. 4.1.1).

Counting convention
-------------------
The seed's ``N`` in ``N/V`` (Eq. 4.1, used in Eq. 2.41 and 4.19) counts each contact
**from both particles**: the stiffness sum of Eq. 2.26 runs over particles ``n`` and their
contacts ``m``, so a contact between two particles appears twice (once with each
particle's centre-to-contact vector).  Hence::

    N/V (seed, Eq. 4.1) = m_bar * (particles per volume)          ("contact ends")
    physical contacts per volume          = m_bar / 2 * (particles per volume)

with particles per volume ``3 / (4 pi rho^3 (1 + e))`` for equal spheres of radius
``rho`` and ``1 / (pi rho^2 (1 + e))`` per unit area for equal discs.  The two functions
are :func:`contact_ends_per_volume` (the seed's N/V) and :func:`contacts_per_volume`.

Correlations
------------
``m_bar(e)`` for random packings of (nearly) equal spheres, as printed in the seed
(Eq. 4.2-4.5, 6.4).  The seed gives no ranges of validity; the functions accept any
``e > 0`` for which the formula gives ``m_bar > 0`` and emit a
:class:`CorrelationRangeWarning` outside the *nominal* range
``0.35 <= e <= 0.91`` (between the densest, face-centred cubic ``e = 0.3505``, and the
loosest stable regular packing, simple cubic ``e = 0.9099``, of equal spheres) or when the
result exceeds 12 (the kissing number of equal spheres).  Porosity ``n = e / (1 + e)``.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np

from grainmech.errors import ParameterError
from grainmech.fabric import _checks

__all__ = [
    "CorrelationRangeWarning",
    "NOMINAL_VOID_RATIO_RANGE",
    "porosity",
    "void_ratio_from_porosity",
    "particles_per_volume",
    "contact_ends_per_volume",
    "contacts_per_volume",
    "coordination_yanagisawa",
    "coordination_smith",
    "coordination_filep",
    "coordination_field",
    "coordination_chang",
    "void_ratio_chang",
    "coordination_number",
    "CORRELATIONS",
]

#: Nominal void-ratio range of the correlations (FCC to simple cubic packing of spheres).
NOMINAL_VOID_RATIO_RANGE: tuple[float, float] = (0.35, 0.91)
#: Kissing number of equal spheres: no coordination number can exceed it.
MAX_COORDINATION_SPHERES = 12.0


class CorrelationRangeWarning(UserWarning):
    """An empirical correlation is used outside its nominal range."""


def _as_positive(x: object, name: str, strict_upper: float | None = None) -> np.ndarray:
    a = _checks.as_finite_array(x, name)
    bad = a <= 0 if strict_upper is None else (a <= 0) | (a >= strict_upper)
    if np.any(bad):
        v = a[bad].flat[0] if a.ndim else a.item()
        rng = "> 0" if strict_upper is None else f"in (0, {strict_upper:g})"
        raise ParameterError(name, float(v), f"must be {rng}")
    return a


def _out(a: np.ndarray) -> np.ndarray | float:
    return float(a) if a.ndim == 0 else a


def porosity(void_ratio: object) -> np.ndarray | float:
    """Porosity ``n = e / (1 + e)`` (volume of voids over total volume)."""
    e = _as_positive(void_ratio, "void_ratio")
    return _out(e / (1.0 + e))


def void_ratio_from_porosity(n: object) -> np.ndarray | float:
    """Void ratio ``e = n / (1 - n)`` for porosity ``0 < n < 1``."""
    p = _as_positive(n, "porosity", 1.0)
    return _out(p / (1.0 - p))


def particles_per_volume(void_ratio: object, radius: object, dim: int = 3) -> np.ndarray | float:
    """Number of equal particles per unit volume (3D) or per unit area (2D).

    ``3 / (4 pi rho^3 (1 + e))`` for spheres, ``1 / (pi rho^2 (1 + e))`` for discs
    (solid volume ``V/(1+e)`` divided by the particle volume/area).

    Parameters
    ----------
    void_ratio : float or array
        ``e > 0``.
    radius : float or array
        Particle radius ``rho > 0`` (length unit L); result in L^-3 (3D) or L^-2 (2D).
    dim : {3, 2}
    """
    e = _as_positive(void_ratio, "void_ratio")
    r = _as_positive(radius, "radius")
    dim = _checks.as_dim(dim)
    with np.errstate(over="ignore", divide="ignore", under="ignore"):
        if dim == 3:
            nv = 3.0 / (4.0 * np.pi * r ** 3 * (1.0 + e))
        else:
            nv = 1.0 / (np.pi * r ** 2 * (1.0 + e))
    bad = ~np.isfinite(nv) | (nv <= 0)
    if np.any(bad):
        v = r[bad].flat[0] if r.ndim else r.item()
        raise ParameterError("radius", float(v), "gives a particle count per volume outside the "
                          "floating-point range (check the length unit)")
    return _out(nv)


def contact_ends_per_volume(void_ratio: object, coordination: object, radius: object,
                            dim: int = 3) -> np.ndarray | float:
    """The seed's ``N/V`` (Eq. 4.1): contacts counted from both particles.

    ``N/V = 3 m_bar / (4 pi rho^3 (1 + e))`` (spheres), ``m_bar / (pi rho^2 (1 + e))``
    (discs, per unit area) = ``m_bar`` x particles per volume.  Use this with the seed's
    Eq. 2.41 / 4.19 (sum over particles and their contacts, centre-to-contact vectors).

    Parameters
    ----------
    void_ratio : float or array
        ``e > 0``.
    coordination : float or array
        Mean coordination number ``m_bar > 0`` (contacts per particle).
    radius : float or array
        Particle radius ``rho > 0``.
    dim : {3, 2}
    """
    m = _as_positive(coordination, "coordination")
    return _out(m * np.asarray(particles_per_volume(void_ratio, radius, dim)))


def contacts_per_volume(void_ratio: object, coordination: object, radius: object,
                        dim: int = 3) -> np.ndarray | float:
    """Physical contacts per unit volume: ``m_bar / 2`` x particles per volume.

    Half of :func:`contact_ends_per_volume` (each contact is shared by two particles).
    Use this with a sum over contacts counted once (DEM convention, branch vectors).
    """
    return _out(0.5 * np.asarray(contact_ends_per_volume(void_ratio, coordination, radius, dim)))


def _check_range(e: np.ndarray, m: np.ndarray, name: str) -> np.ndarray | float:
    lo, hi = NOMINAL_VOID_RATIO_RANGE
    if np.any(m <= 0):
        v = e[m <= 0].flat[0] if e.ndim else e.item()
        raise ParameterError("void_ratio", float(v),
                          f"{name} gives a non-positive coordination number there")
    if np.any((e < lo) | (e > hi)):
        warnings.warn(f"{name}: void ratio outside the nominal range {lo}..{hi}",
                      CorrelationRangeWarning, stacklevel=3)
    if np.any(m > MAX_COORDINATION_SPHERES + 0.01):   # 0.01: rounding of printed constants
        warnings.warn(f"{name}: coordination number above 12 (impossible for equal spheres)",
                      CorrelationRangeWarning, stacklevel=3)
    return _out(m)


def coordination_yanagisawa(void_ratio: object) -> np.ndarray | float:
    """Yanagisawa (1983), seed Eq. 4.2: ``m_bar = 3.183 ** (2.469 - e)``.

    Source: E. Yanagisawa (1983), glass balls and gravels; as printed in the seed
    (used there for the resonant-column comparison, Sec. 6.2).  Gives 9.0 at e = 0.57.
    """
    e = _as_positive(void_ratio, "void_ratio")
    return _check_range(e, 3.183 ** (2.469 - e), "Yanagisawa (1983), Eq. 4.2")


def coordination_smith(void_ratio: object) -> np.ndarray | float:
    """Smith, Foote and Busang (1929), seed Eq. 4.3: ``m_bar = 26.486 - 10.726 / (1 - n)``.

    ``n = e/(1+e)`` is the porosity, so ``1/(1-n) = 1+e``.  Lead shot.  The formula
    interpolates the regular packings: 12.0 at face-centred cubic (n = 0.2595) and 6.0 at
    simple cubic (n = 0.4764).  Non-positive beyond ``e = 1.469``.
    """
    e = _as_positive(void_ratio, "void_ratio")
    n = e / (1.0 + e)
    return _check_range(e, 26.486 - 10.726 / (1.0 - n), "Smith, Foote and Busang (1929), Eq. 4.3")


def coordination_filep(void_ratio: object) -> np.ndarray | float:
    """Filep (1936), seed Eq. 4.4: ``m_bar = 3.1 / n`` with porosity ``n = e/(1+e)``."""
    e = _as_positive(void_ratio, "void_ratio")
    return _check_range(e, 3.1 * (1.0 + e) / e, "Filep (1936), Eq. 4.4")


def coordination_field(void_ratio: object) -> np.ndarray | float:
    """Field (1963), seed Eq. 4.5: ``m_bar = 12 / (1 + e)``."""
    e = _as_positive(void_ratio, "void_ratio")
    return _check_range(e, 12.0 / (1.0 + e), "Field (1963), Eq. 4.5")


def coordination_chang(void_ratio: object) -> np.ndarray | float:
    """Seed Eq. 6.4 inverted: ``e = (23 - m_bar)/25``  ->  ``m_bar = 23 - 25 e``.

    A straight line fitted to coordination / void-ratio data for the comparison with
    Hardin and Black's sand moduli (seed Sec. 6.3.1, Fig. 6.8).  Positive for e < 0.92;
    above 12 for e < 0.44.
    """
    e = _as_positive(void_ratio, "void_ratio")
    return _check_range(e, 23.0 - 25.0 * e, "Chang (1988), Eq. 6.4")


def void_ratio_chang(coordination: object) -> np.ndarray | float:
    """Seed Eq. 6.4 as printed: ``e = (23 - m_bar) / 25``; needs ``0 < m_bar < 23``."""
    m = _as_positive(coordination, "coordination", 23.0)
    return _out((23.0 - m) / 25.0)


#: Named correlations for :func:`coordination_number`.
CORRELATIONS: dict[str, Callable[[object], np.ndarray | float]] = {
    "yanagisawa": coordination_yanagisawa,
    "smith": coordination_smith,
    "filep": coordination_filep,
    "field": coordination_field,
    "chang": coordination_chang,
}


def coordination_number(void_ratio: object, correlation: str = "yanagisawa") -> np.ndarray | float:
    """Mean coordination number from the void ratio with a named correlation.

    Parameters
    ----------
    void_ratio : float or array
    correlation : {'yanagisawa', 'smith', 'filep', 'field', 'chang'}
        Seed Eq. 4.2, 4.3, 4.4, 4.5 or 6.4.
    """
    if correlation not in CORRELATIONS:
        raise ParameterError("correlation", correlation, f"must be one of {sorted(CORRELATIONS)}")
    return CORRELATIONS[correlation](void_ratio)

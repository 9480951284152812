"""Quadrature rules on the unit sphere and the unit circle.

Both rules are normalised so that the weights sum to one, i.e. they compute the *mean*
of a function over the sphere (circle): ``sum_k w_k f(n_k) = (1/|S|) * integral f dS``
with ``|S| = 4 pi`` (sphere) or ``2 pi`` (circle).

Sphere
    SciPy's Lebedev rules (:func:`scipy.integrate.lebedev_rule`; Lebedev and Laikov
    1999).  A rule of *order* ``p`` integrates every polynomial in ``(x, y, z)`` of total
    degree ``<= p`` exactly (checked for every available order in
    ``tests/fabric/test_quadrature.py``).  The available orders and point counts are
    listed in :data:`LEBEDEV_ORDERS` / :data:`LEBEDEV_POINTS`.  Orders 13, 25 and 27
    contain negative weights; they are skipped unless ``positive=False`` is requested,
    because a negative weight would become a "negative contact" in a stiffness sum.
Circle
    ``K`` uniformly spaced nodes ``theta_j = 2 pi j / K`` (seed angle, measured from the
    y axis, so ``n = (sin theta, cos theta)`` in library ``(x, y)`` components).  This is
    exact for trigonometric polynomials of degree ``< K``, hence for polynomials in
    ``(x, y)`` of total degree ``<= K - 1``; :func:`circle_rule` uses ``K = degree + 1``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.integrate import lebedev_rule

from grainmech.errors import ParameterError

__all__ = [
    "LEBEDEV_ORDERS",
    "LEBEDEV_POINTS",
    "LEBEDEV_NEGATIVE_WEIGHT_ORDERS",
    "lebedev_order",
    "sphere_rule",
    "circle_rule",
    "unit_rule",
]

#: Orders (exactly integrated polynomial degree) of SciPy's Lebedev rules.
LEBEDEV_ORDERS: tuple[int, ...] = (
    3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31, 35,
    41, 47, 53, 59, 65, 71, 77, 83, 89, 95, 101, 107, 113, 119, 125, 131,
)
#: Number of points of the rule of each order in :data:`LEBEDEV_ORDERS`.
LEBEDEV_POINTS: tuple[int, ...] = (
    6, 14, 26, 38, 50, 74, 86, 110, 146, 170, 194, 230, 266, 302, 350, 434,
    590, 770, 974, 1202, 1454, 1730, 2030, 2354, 2702, 3074, 3470, 3890, 4334, 4802,
    5294, 5810,
)
#: Orders whose rule has some negative weights (skipped when ``positive=True``).
LEBEDEV_NEGATIVE_WEIGHT_ORDERS: tuple[int, ...] = (13, 25, 27)

MAX_SPHERE_DEGREE = LEBEDEV_ORDERS[-1]


def _check_degree(degree: object, name: str = "degree") -> int:
    if isinstance(degree, (bool, np.bool_)) or not isinstance(degree, (int, np.integer)):
        raise ParameterError(name, degree, "must be a non-negative integer")
    if degree < 0:
        raise ParameterError(name, degree, "must be a non-negative integer")
    return int(degree)


def lebedev_order(degree: int, positive: bool = True) -> int:
    """Smallest available Lebedev order that integrates polynomials of ``degree`` exactly.

    Parameters
    ----------
    degree : int
        Total polynomial degree of the integrand in the Cartesian components of ``n``.
    positive : bool, default True
        Skip the orders whose rule has negative weights (13, 25, 27).

    Returns
    -------
    int
        An element of :data:`LEBEDEV_ORDERS`, ``>= degree``.

    Raises
    ------
    ParameterError
        If ``degree`` is negative or exceeds 131 (the highest order SciPy provides).
    """
    degree = _check_degree(degree)
    for order in LEBEDEV_ORDERS:
        if order >= degree and not (positive and order in LEBEDEV_NEGATIVE_WEIGHT_ORDERS):
            return order
    raise ParameterError("degree", degree,
                      f"no Lebedev rule is exact beyond degree {MAX_SPHERE_DEGREE}")


@lru_cache(maxsize=64)
def _lebedev(order: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = lebedev_rule(order)
    pts = np.ascontiguousarray(np.asarray(x, dtype=float).T)
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    w = np.asarray(w, dtype=float)
    w = w / w.sum()
    pts.setflags(write=False)
    w.setflags(write=False)
    return pts, w


def sphere_rule(degree: int, positive: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Lebedev rule on the unit sphere, exact for polynomials of total degree ``degree``.

    Parameters
    ----------
    degree : int
        Highest total degree (in ``n_x, n_y, n_z``) to be integrated exactly, 0..131.
    positive : bool, default True
        Use only rules with positive weights (see module notes).

    Returns
    -------
    points : ndarray, shape (k, 3)
        Unit vectors in library ``(x, y, z)`` components.
    weights : ndarray, shape (k,)
        Sum to 1: ``weights @ f(points) = (1 / 4 pi) * integral f dOmega``.

    Notes
    -----
    The returned arrays are read-only views of a cached rule; copy before modifying.
    """
    return _lebedev(lebedev_order(degree, positive))


@lru_cache(maxsize=64)
def _circle(k: int) -> tuple[np.ndarray, np.ndarray]:
    theta = 2.0 * np.pi * np.arange(k) / k
    pts = np.stack([np.sin(theta), np.cos(theta)], axis=-1)
    w = np.full(k, 1.0 / k)
    pts.setflags(write=False)
    w.setflags(write=False)
    return pts, w


def circle_rule(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Uniform rule on the unit circle, exact for polynomials of total degree ``degree``.

    Parameters
    ----------
    degree : int
        Highest total degree (in ``n_x, n_y``) to be integrated exactly.

    Returns
    -------
    points : ndarray, shape (degree + 1, 2)
        ``(sin theta_j, cos theta_j)`` with ``theta_j = 2 pi j / (degree + 1)`` (seed angle
        from the y axis).
    weights : ndarray, shape (degree + 1,)
        All equal to ``1 / (degree + 1)``; ``weights @ f(points) = (1/2 pi) integral f dtheta``.
    """
    degree = _check_degree(degree)
    return _circle(degree + 1)


def unit_rule(dim: int, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sphere_rule` for ``dim == 3``, :func:`circle_rule` for ``dim == 2``."""
    if dim == 3:
        return sphere_rule(degree)
    if dim == 2:
        return circle_rule(degree)
    raise ParameterError("dim", dim, "must be 2 or 3")

r"""Analytic Mindlin–Deresiewicz curves at constant normal force (reference solutions).

Two spheres pressed together by a constant normal force ``N`` (contact radius ``a``
from Hertz, seed Eq. 3.2) and loaded by a tangential force ``T`` of fixed direction
(Cattaneo 1938; Mindlin 1949; Mindlin & Deresiewicz 1953; Johnson 1985, §7.2–7.3).
With ``1/G* = (2-nu1)/G1 + (2-nu2)/G2`` (seed Eq. 3.12) and ``x = T/(mu N)``:

* initial loading (stick radius ``c = a (1 - x)^(1/3)``)::

      delta_L(T) = 3 mu N / (16 G* a) [1 - (1 - x)^(2/3)]

  whose slope ``dT/d delta = 8 G* a (1 - x)^(1/3)`` is seed Eq. 3.11 with Eq. 3.13;

* unloading from ``(T*, delta*)`` and reloading from ``(-T*, -delta*)`` by Masing's rule
  (Mindlin & Deresiewicz 1953; Johnson 1985, §7.3)::

      delta_U(T) =  delta* - 2 delta_L((T* - T)/2)
      delta_R(T) = -delta* + 2 delta_L((T* + T)/2)

* energy dissipated per cycle of amplitude ``T*`` (the loop area; Mindlin et al. 1952,
  Johnson 1985, §7.3), with ``x* = T*/(mu N)``::

      W = 9 mu^2 N^2 / (10 G* a) [1 - (1 - x*)^(5/3) - (5 x*/6) (1 + (1 - x*)^(2/3))]

  which behaves as ``T*^3 / (36 mu N G* a)`` for small amplitudes and reaches
  ``3 mu^2 N^2 / (20 G* a)`` at ``T* = mu N``. (The inner term is ``1 + (1-x*)^(2/3)``;
  a form with ``1 - (1-x*)^(2/3)`` has a non-zero slope at ``x* = 0`` and is wrong.)
  Derivation: integrate ``delta_U - delta_R`` over ``T`` in ``[-T*, T*]``; checked
  symbolically in ``tests/contact/test_md_analytic.py``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from grainmech.contact.geometry import hertz_contact_radius_from_force
from grainmech.contact.params import Hertz

__all__ = [
    "md_loading_displacement",
    "md_loading_force",
    "md_unloading_displacement",
    "md_unloading_force",
    "md_reloading_displacement",
    "md_dissipation_per_cycle",
]


def _consts(normal_force: ArrayLike, params: Hertz, friction: float | None):
    mu = params.friction if friction is None else float(friction)
    if not mu > 0 or not np.isfinite(mu):
        raise ValueError(f"friction = {mu!r}: the Mindlin–Deresiewicz curves need 0 < mu < inf")
    N = np.asarray(normal_force, dtype=float)
    if np.any(N <= 0):
        raise ValueError("normal_force must be positive")
    a = hertz_contact_radius_from_force(N, params)
    return mu, N, a, params.effective_shear_modulus


def md_loading_displacement(tangential_force: ArrayLike, normal_force: ArrayLike, params: Hertz,
                            friction: float | None = None) -> np.ndarray:
    """Tangential displacement on initial loading (Mindlin 1949; Johnson 1985, §7.2).

    ``delta = 3 mu N / (16 G* a) [1 - (1 - |T|/(mu N))^(2/3)] sign(T)``.

    Parameters
    ----------
    tangential_force : array_like
        ``T`` with ``|T| <= mu N`` [N].
    normal_force : array_like
        Constant ``N > 0`` [N].
    params : Hertz
        Geometry and materials (and ``friction`` unless given).
    friction : float, optional
        Overrides ``params.friction``.

    Returns
    -------
    ndarray
        ``delta`` [m], same shape as the broadcast inputs.
    """
    mu, N, a, Gs = _consts(normal_force, params, friction)
    T = np.asarray(tangential_force, dtype=float)
    x = np.clip(np.abs(T) / (mu * N), 0.0, 1.0)
    return np.sign(T) * 3.0 * mu * N / (16.0 * Gs * a) * (1.0 - (1.0 - x) ** (2.0 / 3.0))


def md_loading_force(displacement: ArrayLike, normal_force: ArrayLike, params: Hertz,
                     friction: float | None = None) -> np.ndarray:
    """Inverse of :func:`md_loading_displacement`: ``T = mu N [1 - (1 - delta/delta_s)^(3/2)]``.

    ``delta_s = 3 mu N / (16 G* a)`` is the displacement at which gross sliding starts;
    beyond it ``T = mu N``.
    """
    mu, N, a, Gs = _consts(normal_force, params, friction)
    d = np.asarray(displacement, dtype=float)
    ds = 3.0 * mu * N / (16.0 * Gs * a)
    x = np.clip(np.abs(d) / ds, 0.0, 1.0)
    return np.sign(d) * mu * N * (1.0 - (1.0 - x) ** 1.5)


def md_unloading_displacement(tangential_force: ArrayLike, t_star: ArrayLike, normal_force: ArrayLike,
                              params: Hertz, friction: float | None = None) -> np.ndarray:
    """Unloading branch from ``(T*, delta_L(T*))`` by Masing's rule (Mindlin & Deresiewicz 1953).

    ``delta = delta_L(T*) - 2 delta_L((T* - T)/2)`` for ``-T* <= T <= T*``.
    """
    dstar = md_loading_displacement(t_star, normal_force, params, friction)
    half = 0.5 * (np.asarray(t_star, dtype=float) - np.asarray(tangential_force, dtype=float))
    return dstar - 2.0 * md_loading_displacement(half, normal_force, params, friction)


def md_reloading_displacement(tangential_force: ArrayLike, t_star: ArrayLike, normal_force: ArrayLike,
                              params: Hertz, friction: float | None = None) -> np.ndarray:
    """Reloading branch from ``(-T*, -delta_L(T*))``: ``-delta_U(-T)``."""
    return -md_unloading_displacement(-np.asarray(tangential_force, dtype=float), t_star,
                                      normal_force, params, friction)


def md_unloading_force(displacement: ArrayLike, t_star: ArrayLike, normal_force: ArrayLike,
                       params: Hertz, friction: float | None = None) -> np.ndarray:
    """Tangential force on the unloading branch from ``T*`` at displacement ``delta``.

    ``T = T* - 2 T_L((delta* - delta)/2)`` with ``T_L`` from :func:`md_loading_force`.
    """
    ts = np.asarray(t_star, dtype=float)
    dstar = md_loading_displacement(ts, normal_force, params, friction)
    half = 0.5 * (dstar - np.asarray(displacement, dtype=float))
    return ts - 2.0 * md_loading_force(half, normal_force, params, friction)


def md_dissipation_per_cycle(t_star: ArrayLike, normal_force: ArrayLike, params: Hertz,
                             friction: float | None = None) -> np.ndarray:
    """Energy dissipated in one symmetric cycle ``+-T*`` at constant ``N`` [J].

    ``W = 9 mu^2 N^2/(10 G* a) [1 - (1-x)^(5/3) - (5x/6)(1 + (1-x)^(2/3))]``,
    ``x = T*/(mu N)`` (Mindlin, Mason, Osmer & Deresiewicz 1952; Johnson 1985, §7.3,
    written with the seed's ``G*`` of Eq. 3.12). Small amplitudes:
    ``W ~ T*^3 / (36 mu N G* a)``.
    """
    mu, N, a, Gs = _consts(normal_force, params, friction)
    x = np.clip(np.abs(np.asarray(t_star, dtype=float)) / (mu * N), 0.0, 1.0)
    w = 1.0 - x
    bracket = 1.0 - w ** (5.0 / 3.0) - (5.0 * x / 6.0) * (1.0 + w ** (2.0 / 3.0))
    return 9.0 * mu * mu * N * N / (10.0 * Gs * a) * np.maximum(bracket, 0.0)

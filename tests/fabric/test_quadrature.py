"""Quadrature rules: exactness against closed-form monomial integrals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import gamma as G

from grainmech.errors import ParameterError
from grainmech.fabric import (
    LEBEDEV_NEGATIVE_WEIGHT_ORDERS,
    LEBEDEV_ORDERS,
    LEBEDEV_POINTS,
    circle_rule,
    lebedev_order,
    sphere_rule,
)
from grainmech.fabric.quadrature import _lebedev


def sphere_monomial_mean(a: int, b: int, c: int) -> float:
    """(1/4 pi) integral x^a y^b z^c dOmega (Folland 2001, closed form)."""
    if a % 2 or b % 2 or c % 2:
        return 0.0
    return 2 * G((a + 1) / 2) * G((b + 1) / 2) * G((c + 1) / 2) / G((a + b + c + 3) / 2) / (4 * np.pi)


def circle_monomial_mean(a: int, b: int) -> float:
    """(1/2 pi) integral x^a y^b dtheta."""
    if a % 2 or b % 2:
        return 0.0
    return G((a + 1) / 2) * G((b + 1) / 2) / G((a + b + 2) / 2) / np.pi


def _max_error_sphere(pts, w, deg):
    """Largest error over all monomials x^a y^b z^c of total degree ``deg``."""
    X = pts[:, 0][None, :] ** np.arange(deg + 1)[:, None]
    Y = pts[:, 1][None, :] ** np.arange(deg + 1)[:, None]
    Z = pts[:, 2][None, :] ** np.arange(deg + 1)[:, None]
    err = 0.0
    for a in range(deg + 1):
        b = np.arange(deg - a + 1)
        num = (w * X[a]) @ (Y[b] * Z[deg - a - b]).T
        ref = np.array([sphere_monomial_mean(a, int(bb), deg - a - int(bb)) for bb in b])
        err = max(err, float(np.abs(num - ref).max()))
    return err


@pytest.mark.parametrize("degree", [0, 1, 2, 4, 6, 8, 9, 12, 13, 16, 20, 25])
def test_sphere_rule_exact_for_all_monomials(degree):
    pts, w = sphere_rule(degree)
    assert pts.shape[1] == 3 and w.shape == (pts.shape[0],)
    assert abs(w.sum() - 1) < 1e-14
    assert np.allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-14)
    assert np.all(w > 0)
    for d in range(0, degree + 1):
        assert _max_error_sphere(pts, w, d) < 1e-14, d


def test_every_lebedev_order_integrates_its_degree():
    for order, npts in zip(LEBEDEV_ORDERS, LEBEDEV_POINTS):
        pts, w = _lebedev(order)
        assert len(w) == npts
        # every order is odd: odd monomials vanish because the point set is centrosymmetric
        # (each point's antipode carries the same weight) ...
        key = np.round(pts, 12)
        idx = {tuple(p): i for i, p in enumerate(key)}
        anti = np.array([idx[tuple(-p + 0.0)] for p in key])
        assert np.allclose(w[anti], w, rtol=0, atol=1e-15)
        # ... and degree order-1 monomials are exact, which implies every lower even degree
        # (multiply by x^2 + y^2 + z^2 = 1)
        assert _max_error_sphere(pts, w, order - 1) < 1e-13
        assert (w.min() < 0) == (order in LEBEDEV_NEGATIVE_WEIGHT_ORDERS)


def test_smallest_order_is_chosen_and_never_too_low():
    assert lebedev_order(4) == 5
    assert lebedev_order(5) == 5
    assert lebedev_order(6) == 7
    assert lebedev_order(13) == 15          # 13 has negative weights
    assert lebedev_order(13, positive=False) == 13
    assert lebedev_order(24) == 29          # 25, 27 skipped
    assert lebedev_order(131) == 131
    # a degree-(p+1) even monomial is not integrated by the order-p rule: the choice matters
    pts, w = _lebedev(5)
    assert _max_error_sphere(pts, w, 6) > 1e-3


@pytest.mark.parametrize("bad", [-1, 132, 2.5, "4", None, True])
def test_sphere_rule_bad_degree(bad):
    with pytest.raises(ParameterError) as exc:
        sphere_rule(bad)
    assert "degree" in str(exc.value)


@pytest.mark.parametrize("degree", [0, 1, 2, 3, 4, 7, 8, 15])
def test_circle_rule_exact(degree):
    pts, w = circle_rule(degree)
    assert len(w) == degree + 1 and abs(w.sum() - 1) < 1e-15
    # first node on the y axis (seed theta = 0)
    assert np.allclose(pts[0], [0.0, 1.0])
    for d in range(degree + 1):
        for a in range(d + 1):
            v = w @ (pts[:, 0] ** a * pts[:, 1] ** (d - a))
            assert abs(v - circle_monomial_mean(a, d - a)) < 1e-14
    # and not beyond: cos((degree+1) theta) is not integrated
    th = np.arctan2(pts[:, 0], pts[:, 1])
    assert abs(w @ np.cos((degree + 1) * th)) > 0.5

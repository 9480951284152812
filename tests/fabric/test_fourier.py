"""2D Fourier density (seed Eq. 4.9, 4.34, 4.35)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from _hyp import given, settings, st
from grainmech.conventions import seed_normal_2d
from grainmech.errors import NegativeDensityError, ParameterError
from grainmech.fabric import FourierDensity, isotropic, rotate_tensor


def test_from_seed_is_eq_4_34_and_normalised():
    a2, b2, a4, b4 = 0.3, 0.1, 0.1, -0.05
    d = FourierDensity.from_seed(a2, b2, a4, b4)
    assert d.order == 4
    th = np.linspace(0, 2 * np.pi, 37)
    eq434 = (1 + a2 * np.cos(2 * th) + b2 * np.sin(2 * th) + a4 * np.cos(4 * th)
             + b4 * np.sin(4 * th)) / (2 * np.pi)
    assert np.allclose(d(seed_normal_2d(th)), eq434, atol=1e-15)
    total, _ = quad(lambda t: float(d(seed_normal_2d(t))), 0, 2 * np.pi, epsabs=1e-13)
    assert abs(total - 1) < 1e-12        # 1/(2 pi) is the right factor ...


def test_eq_4_35_prefactor_erratum():
    # ... and the tensor form with the 1/(4 pi) printed in Eq. 4.35 integrates to 1/2
    d = FourierDensity.from_seed(a2=0.3, b2=0.1, a4=0.1, b4=-0.05)
    phis = d.coefficient_tensors()

    def tensor_form(t, pref):
        n = seed_normal_2d(t)
        return pref * (1 + np.einsum("ij,i,j", phis[2], n, n)
                       + np.einsum("ijkl,i,j,k,l", phis[4], n, n, n, n))
    I4pi, _ = quad(tensor_form, 0, 2 * np.pi, args=(1 / (4 * np.pi),))
    I2pi, _ = quad(tensor_form, 0, 2 * np.pi, args=(1 / (2 * np.pi),))
    assert abs(I4pi - 0.5) < 1e-12 and abs(I2pi - 1) < 1e-12
    th = np.linspace(0, 6, 13)
    assert np.allclose([tensor_form(t, 1 / (2 * np.pi)) for t in th], d(seed_normal_2d(th)))


def test_tensor_components_in_library_frame():
    a2, b2, a4, b4 = 0.3, 0.1, 0.1, -0.05
    phis = FourierDensity.from_seed(a2, b2, a4, b4).coefficient_tensors()
    x, y = 0, 1
    assert np.allclose([phis[2][y, y], phis[2][x, x], phis[2][x, y]], [a2, -a2, b2])
    p4 = phis[4]
    assert np.allclose([p4[y, y, y, y], p4[x, x, x, x], p4[x, x, y, y], p4[x, y, x, y]], [a4, a4, -a4, -a4])
    assert np.allclose([p4[x, y, y, y], p4[y, x, y, y], p4[x, x, x, y], p4[y, x, x, x]], [b4, b4, -b4, -b4])


def test_order_2_when_no_fourth_order_terms_and_round_trip():
    assert FourierDensity.from_seed(a2=0.2).order == 2
    c = {2: (0.2, -0.1), 4: (0.05, 0.02), 6: (0.01, 0.0), 8: (0.0, 0.003)}
    d = FourierDensity.from_seed_coefficients(c)
    assert d.order == 8
    for k, v in d.seed_coefficients().items():
        assert np.allclose(v, c[k])


def test_directions_exact():
    d = FourierDensity.from_seed_coefficients({2: (0.3, 0.1), 4: (0.1, -0.1), 6: (0.02, 0.01)})
    for extra in (0, 2, 4, 5):
        n, w = d.directions(extra)
        assert len(w) == d.order + extra + 1 and abs(w.sum() - 1) < 1e-14
        for a in range(extra + 1):
            f = lambda t, a=a: np.sin(t) ** a * np.cos(t) ** (extra - a)   # n_x^a n_y^(e-a)
            ref, _ = quad(lambda t: f(t) * float(d(seed_normal_2d(t))), 0, 2 * np.pi,
                          epsabs=1e-14, limit=200)
            assert abs(w @ (n[:, 0] ** a * n[:, 1] ** (extra - a)) - ref) < 1e-12


def test_negative_rejected_with_theta():
    with pytest.raises(NegativeDensityError) as exc:
        FourierDensity.from_seed(a2=1.2)
    msg = str(exc.value)
    assert "theta = 90 deg" in msg and "-0.2" in msg      # min of 1 + 1.2 cos 2t at t = 90 deg
    m = FourierDensity.from_seed(a2=1.2, allow_negative=True).minimum()
    assert np.isclose(m.normalised, -0.2) and np.isclose(m.seed_angles[0], np.pi / 2)


quat = st.floats(0, 2 * np.pi)
small = st.floats(-0.2, 0.2)


@settings(max_examples=25, deadline=None)
@given(quat, st.booleans(), small, small, small, small)
def test_rotation_and_reflection_commute_with_fabric(alpha, reflect, a2, b2, a4, b4):
    R = np.array([[np.cos(alpha), -np.sin(alpha)], [np.sin(alpha), np.cos(alpha)]])
    if reflect:
        R = R @ np.diag([1.0, -1.0])
    d = FourierDensity.from_seed(a2, b2, a4, b4, allow_negative=True)
    r = d.rotated(R)
    n = seed_normal_2d(np.linspace(0, 6, 17))
    assert np.allclose(r(n), d(n @ R), atol=1e-14)
    for rank in (2, 4):
        assert np.allclose(r.fabric_tensor(rank), rotate_tensor(d.fabric_tensor(rank), R), atol=1e-14)


def test_rotation_shifts_seed_angle():
    # library rotation by +alpha (x towards y) decreases the seed angle (from y towards x)
    d = FourierDensity.from_seed(a2=0.5)
    alpha = 0.3
    R = np.array([[np.cos(alpha), -np.sin(alpha)], [np.sin(alpha), np.cos(alpha)]])
    r = d.rotated(R)
    th = np.linspace(0, 6, 11)
    assert np.allclose(r(seed_normal_2d(th)), d(seed_normal_2d(th + alpha)))


def test_isotropic_and_errors():
    iso = isotropic(2)
    assert np.isclose(iso([1.0, 0.0]), 1 / (2 * np.pi))
    assert np.allclose(iso.fabric_tensor(2), np.eye(2) / 2)
    with pytest.raises(ParameterError, match="dim"):
        isotropic(4)
    with pytest.raises(ParameterError, match="a"):
        FourierDensity(order=4, a=[0.1], b=[0.0, 0.0])
    with pytest.raises(ParameterError, match="k"):
        FourierDensity.from_seed_coefficients({3: (0.1, 0.0)})
    d = FourierDensity.from_seed(0.1)
    with pytest.raises(ParameterError, match="normals"):
        d([0.0, 0.0, 1.0])
    with pytest.raises(ParameterError, match="unit"):
        d([0.5, 0.5])


@pytest.mark.parametrize(("a", "b"), [([2.5], [0.0]), ([1e308], [1e308]), ([0.0], [-1.7e308]), ([1.5], [1.5])])
def test_impossible_coefficients_are_refused_before_any_evaluation(a, b):
    """A coefficient pair of a density xi >= 0 with unit mean has sqrt(a_k^2 + b_k^2) <= 2
    (twice the mean of a cosine over it): beyond, the error says so without evaluating the
    series (no overflow warning for 1e308)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NegativeDensityError, match="exceeds 2"):
            FourierDensity(2, a, b)
    # a point mass of unit mean reaches the bound: it is not refused by it
    th = 0.3
    assert FourierDensity(2, [2 * np.cos(2 * th)], [2 * np.sin(2 * th)], allow_negative=True)._impossible_coefficient() \
        is None

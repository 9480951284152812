"""phi <-> N conversions (seed Eq. 4.6, 4.10, 4.11; Kanatani 1984) checked by quadrature."""

from __future__ import annotations

import numpy as np
import pytest

from _hyp import given, settings, st
from grainmech.errors import ParameterError
from grainmech.fabric import (
    FourierDensity,
    SphericalDensity,
    anisotropy,
    density_from_fabric_tensor,
    deviatoric,
    fabric_from_phi,
    isotropic_moment,
    kanatani_factor,
    phi_from_fabric,
    symmetrize,
    trace,
)
from test_harmonics import product_rule


def circle_points(k=400):
    t = 2 * np.pi * np.arange(k) / k
    return np.stack([np.sin(t), np.cos(t)], -1), np.full(k, 1.0 / k)


def moment(pts, w, vals, rank):
    """integral n^(x)rank xi dOmega with an independent rule (w sums to 1, vals = |S| xi)."""
    M = (w * vals)[:, None]
    for _ in range(rank):
        M = (M[:, :, None] * pts[:, None, :]).reshape(len(w), -1)
    return M.sum(axis=0).reshape((pts.shape[1],) * rank)


def S6(delta, A):
    return 6 * symmetrize(np.multiply.outer(delta, A))


def S3(delta):
    return 3 * symmetrize(np.multiply.outer(delta, delta))


def test_kanatani_factors():
    assert kanatani_factor(2, 3) == 7.5 and kanatani_factor(4, 3) == 315 / 8
    assert kanatani_factor(6, 3) == 3003 / 16
    assert kanatani_factor(2, 2) == 4 and kanatani_factor(4, 2) == 16


def test_eq_4_11_spheres_by_quadrature():
    a20, a22, b22 = 0.4, -0.1, 0.07
    pts, w = product_rule(12)
    d = SphericalDensity.from_seed(a20, a22, b22)
    N = moment(pts, w, 4 * np.pi * d(pts), 2)
    phi = np.diag([-a20 / 2 - 3 * a22, -a20 / 2 + 3 * a22, a20])
    phi[0, 1] = phi[1, 0] = 3 * b22
    assert np.allclose(7.5 * (N - np.eye(3) / 3), phi, atol=1e-14)      # Eq. 4.11, spheres
    assert np.allclose(phi_from_fabric(N)[2], phi, atol=1e-13)


def test_eq_4_11_discs_by_quadrature():
    a2, b2 = 0.5, -0.2
    pts, w = circle_points()
    d = FourierDensity.from_seed(a2, b2)
    N = moment(pts, w, 2 * np.pi * d(pts), 2)
    phi = np.array([[-a2, b2], [b2, a2]])
    assert np.allclose(4 * (N - np.eye(2) / 2), phi, atol=1e-14)        # Eq. 4.11, discs


@pytest.mark.parametrize("dim", [2, 3])
def test_fourth_order_closed_forms(dim):
    rng = np.random.default_rng(dim)
    phi2 = deviatoric(rng.normal(0, 0.1, (dim, dim)))
    phi4 = deviatoric(rng.normal(0, 0.05, (dim,) * 4))
    if dim == 3:
        pts, w = product_rule(10)
    else:
        pts, w = circle_points(64)
    vals = 1 + np.einsum("ij,qi,qj->q", phi2, pts, pts) + np.einsum("ijkl,qi,qj,qk,ql->q", phi4, pts, pts, pts, pts)
    N4 = moment(pts, w, vals, 4)
    delta = np.eye(dim)
    if dim == 3:
        ref = S3(delta) / 15 + 2 / 105 * S6(delta, phi2) + 8 / 315 * phi4
    else:
        ref = S3(delta) / 8 + S6(delta, phi2) / 24 + phi4 / 16
    assert np.allclose(N4, ref, atol=1e-14)
    assert np.allclose(fabric_from_phi({2: phi2, 4: phi4}, 4), ref, atol=1e-14)
    back = phi_from_fabric(N4)
    assert np.allclose(back[4], phi4, atol=1e-13) and np.allclose(back[2], phi2, atol=1e-13)
    # 315/8 and 16: phi_ijkl = F_4 dev N_ijkl
    assert np.allclose(kanatani_factor(4, dim) * deviatoric(N4), phi4, atol=1e-13)


@pytest.mark.parametrize("dim", [2, 3])
def test_deviatoric_rank4_closed_form(dim):
    rng = np.random.default_rng(7)
    T = symmetrize(rng.normal(size=(dim,) * 4))
    T2, t = trace(T), trace(T, 2)
    delta = np.eye(dim)
    ref = T - S6(delta, T2) / (dim + 4) + t * S3(delta) / ((dim + 4) * (dim + 2))
    D = deviatoric(T)
    assert np.allclose(D, ref, atol=1e-13)
    assert np.allclose(trace(D), 0, atol=1e-13)
    assert np.allclose(deviatoric(np.eye(dim) * 3.0 + np.array([[0, 1], [1, 0]] if dim == 2 else
                                                                np.diag([1.0, -1.0, 0.0]))),
                       np.array([[0, 1], [1, 0]]) if dim == 2 else np.diag([1.0, -1.0, 0.0]))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("rank", [0, 2, 4, 6])
def test_isotropic_moment(dim, rank):
    pts, w = (product_rule(12) if dim == 3 else circle_points(32))
    assert np.allclose(isotropic_moment(rank, dim), moment(pts, w, np.ones(len(w)), rank), atol=1e-14)


small = st.floats(-0.1, 0.1)


@settings(max_examples=20, deadline=None)
@given(st.lists(small, min_size=14, max_size=14))
def test_round_trip_density_fabric_density_3d(c):
    d = SphericalDensity(order=4, coefficients=np.array(c) / 4, allow_negative=True)
    N4 = d.fabric_tensor(4)
    assert np.isclose(trace(N4, 2), 1.0)
    assert np.allclose(trace(N4), d.fabric_tensor(2), atol=1e-14)
    d2 = SphericalDensity.from_fabric_tensor(N4, allow_negative=True)
    assert np.allclose(d2.coefficients, d.coefficients, atol=1e-13)
    phis = d.coefficient_tensors()
    assert np.allclose(fabric_from_phi(phis, 4), N4, atol=1e-14)
    d3 = SphericalDensity.from_coefficient_tensors(phis, allow_negative=True)
    assert np.allclose(d3.coefficients, d.coefficients, atol=1e-13)


@settings(max_examples=20, deadline=None)
@given(st.lists(small, min_size=6, max_size=6))
def test_round_trip_density_fabric_density_2d(c):
    d = FourierDensity(order=6, a=np.array(c[:3]), b=np.array(c[3:]), allow_negative=True)
    N6 = d.fabric_tensor(6)
    d2 = density_from_fabric_tensor(N6, allow_negative=True)
    assert isinstance(d2, FourierDensity)
    assert np.allclose(d2.a, d.a, atol=1e-13) and np.allclose(d2.b, d.b, atol=1e-13)


def test_anisotropy_measures():
    an = SphericalDensity.from_seed(a20=0.6).anisotropy()
    assert np.isclose(an.amplitude, 0.6)
    assert np.allclose(an.principal_axes[:, 0], [0, 0, 1])
    assert np.isclose(an.major_axis_seed_angles[0], 0.0)
    assert np.isclose(an.deviator_norm, np.linalg.norm(np.diag([-0.3, -0.3, 0.6])) * 2 / 15)
    # 2D: xi = (1/2 pi)[1 + a cos 2(theta - theta_a)], a = 0.4, theta_a = 30 deg
    ta = np.radians(30)
    d = FourierDensity.from_seed(a2=0.4 * np.cos(2 * ta), b2=0.4 * np.sin(2 * ta))
    an2 = d.anisotropy()
    assert np.isclose(an2.amplitude, 0.4)
    assert np.isclose(an2.major_axis_seed_angles[0], ta)
    assert np.isclose(an2.amplitude, 2 * (an2.principal_values[0] - an2.principal_values[1]))
    # orthotropic 3D: principal axes of N are those of phi (Eq. 4.17)
    an3 = SphericalDensity.from_seed(0.2, 0.25, 0.0).anisotropy()
    assert np.allclose(np.abs(an3.principal_axes[:, 0]), [0, 1, 0])     # phi_yy = 0.65 largest


def test_conversion_errors():
    with pytest.raises(ParameterError, match="trace"):
        phi_from_fabric(np.eye(3))                         # trace 3, not 1
    with pytest.raises(ParameterError, match="symmetric"):
        phi_from_fabric(np.array([[0.5, 0.1], [0.0, 0.5]]))
    with pytest.raises(ParameterError, match="even"):
        phi_from_fabric(np.zeros((3, 3, 3)))
    with pytest.raises(ParameterError, match="traceless"):
        SphericalDensity.from_coefficient_tensors({2: np.eye(3) * 0.1})
    with pytest.raises(ParameterError, match="rank"):
        SphericalDensity.from_coefficient_tensors({2: np.zeros((3, 3, 3, 3))})
    with pytest.raises(ParameterError, match="shape"):
        anisotropy(np.eye(4) / 4)
    with pytest.raises(ParameterError, match="non-finite"):
        deviatoric(np.full((3, 3), np.nan))

"""3D spherical-harmonic density: seed convention, normalisation, quadrature, rotation."""

from __future__ import annotations

from math import factorial

import numpy as np
import pytest
import sympy as sp
from scipy.spatial.transform import Rotation

from _hyp import given, settings, st
from grainmech.conventions import seed_angles, seed_normal
from grainmech.errors import NegativeDensityError, ParameterError
from grainmech.fabric import SphericalDensity, isotropic, rotate_tensor, sh_degrees_orders
from grainmech.fabric._basis import real_sh


def product_rule(degree: int):
    """Independent rule: Gauss-Legendre in cos(gamma) x uniform in beta (weights sum 1)."""
    q = degree // 2 + 2
    x, gw = np.polynomial.legendre.leggauss(q)
    K = degree + 2
    beta = 2 * np.pi * np.arange(K) / K
    Z, B = np.meshgrid(x, beta, indexing="ij")
    S = np.sqrt(1 - Z ** 2)
    pts = np.stack([S * np.sin(B), S * np.cos(B), Z], axis=-1).reshape(-1, 3)
    w = (gw[:, None] / 2 * np.full(K, 1.0 / K)).reshape(-1)
    return pts, w


def rodrigues(k: int, m: int):
    """Seed Eq. 4.13 with sympy: P_k^m(x) = (1-x^2)^(m/2)/(2^k k!) d^(k+m)/dx^(k+m) (x^2-1)^k."""
    x = sp.symbols("x")
    expr = (1 - x ** 2) ** sp.Rational(m, 2) / (2 ** k * sp.factorial(k)) * sp.diff((x ** 2 - 1) ** k, x, k + m)
    return sp.lambdify(x, sp.simplify(expr), "numpy")


def test_seed_legendre_convention_eq_4_14():
    g = np.linspace(0.1, 3.0, 7)
    assert np.allclose(rodrigues(2, 2)(np.cos(g)), 3 * np.sin(g) ** 2)          # Eq. 4.14
    assert np.allclose(rodrigues(2, 0)(np.cos(g)), 0.5 * (3 * np.cos(g) ** 2 - 1))  # Eq. 4.12


def test_real_basis_matches_rodrigues_without_condon_shortley():
    rng = np.random.default_rng(3)
    gam = rng.uniform(0, np.pi, 11)
    bet = rng.uniform(0, 2 * np.pi, 11)
    n = seed_normal(gam, bet)
    for k in (2, 4, 6):
        ks, ms = sh_degrees_orders(k)
        sel = ks == k
        Y = real_sh(n, ks[sel], ms[sel])
        for j, m in enumerate(ms[sel]):
            am = abs(int(m))
            N = np.sqrt((2 * k + 1) / (4 * np.pi) * factorial(k - am) / factorial(k + am))
            P = rodrigues(k, am)(np.cos(gam))
            trig = 1.0 if m == 0 else np.sqrt(2) * (np.cos(am * bet) if m > 0 else np.sin(am * bet))
            assert np.allclose(Y[:, j], N * P * trig, atol=1e-12), (k, m)


def test_basis_is_orthonormal():
    ks, ms = sh_degrees_orders(8)
    pts, w = product_rule(16)
    Y = real_sh(pts, ks, ms)
    gram = 4 * np.pi * (Y * w[:, None]).T @ Y
    assert np.allclose(gram, np.eye(len(ks)), atol=1e-12)


def test_from_seed_is_eq_4_15_and_4_17():
    a20, a22, b22 = 0.2, 0.25, 0.1
    d = SphericalDensity.from_seed(a20, a22, b22)
    rng = np.random.default_rng(0)
    g = rng.uniform(0, np.pi, 50)
    b = rng.uniform(0, 2 * np.pi, 50)
    eq415 = (1 + 0.25 * a20 * (3 * np.cos(2 * g) + 1)
             + 3 * np.sin(g) ** 2 * (a22 * np.cos(2 * b) + b22 * np.sin(2 * b))) / (4 * np.pi)
    assert np.allclose(d(seed_normal(g, b)), eq415, atol=1e-14)
    phi = d.coefficient_tensors()[2]
    expected = np.zeros((3, 3))            # Eq. 4.17 in library (x, y, z) components
    expected[2, 2] = a20
    expected[1, 1] = -a20 / 2 + 3 * a22
    expected[0, 0] = -a20 / 2 - 3 * a22
    expected[0, 1] = expected[1, 0] = 3 * b22
    assert np.allclose(phi, expected, atol=1e-13)
    sp_ = d.seed_parameters
    assert np.allclose([sp_["a20"], sp_["a22"], sp_["b22"], sp_["a21"], sp_["b21"]], [a20, a22, b22, 0, 0])


def test_p21_terms_give_off_diagonal_z_components():
    a21, b21 = 0.1, -0.05
    d = SphericalDensity.from_seed_coefficients({(2, 1): (a21, b21)})
    phi = d.coefficient_tensors()[2]
    assert np.isclose(phi[1, 2], 1.5 * a21) and np.isclose(phi[0, 2], 1.5 * b21)


def test_seed_coefficients_round_trip_order_6():
    rng = np.random.default_rng(5)
    scale = {(k, m): 0.02 / np.abs(rodrigues(k, m)(np.linspace(-1, 1, 201))).max() for k in (2, 4, 6) for m in range(k + 1)}
    coeffs = {(k, m): (float(rng.normal(0, scale[k, m])), 0.0 if m == 0 else float(rng.normal(0, scale[k, m])))
              for k in (2, 4, 6) for m in range(k + 1)}
    d = SphericalDensity.from_seed_coefficients(coeffs)
    assert d.order == 6
    back = d.seed_coefficients()
    for key, (a, b) in coeffs.items():
        assert np.allclose(back[key], (a, b), atol=1e-14)
    # Eq. 4.7 evaluated directly with sympy Rodrigues functions
    g = rng.uniform(0, np.pi, 20)
    be = rng.uniform(0, 2 * np.pi, 20)
    s = np.ones_like(g)
    for (k, m), (a, b) in coeffs.items():
        P = rodrigues(k, m)(np.cos(g))
        s = s + P * (a * np.cos(m * be) + b * np.sin(m * be))
    assert np.allclose(d(seed_normal(g, be)), s / (4 * np.pi), atol=1e-13)


def test_normalisation_eq_4_8():
    d = SphericalDensity.from_seed_coefficients({(2, 0): (0.3, 0), (4, 3): (0.01, 0.004), (6, 6): (1e-5, 0)})
    pts, w = product_rule(12)
    assert abs(4 * np.pi * w @ d(pts) - 1) < 1e-13


def test_directions_exact_against_independent_rule():
    d = SphericalDensity.from_seed_coefficients({(2, 0): (0.3, 0), (2, 2): (0.05, 0.02),
                                                 (4, 0): (0.1, 0), (4, 2): (0.01, -0.01)})
    rng = np.random.default_rng(1)
    for extra in (0, 2, 4, 6):
        n, wts = d.directions(extra)
        assert abs(wts.sum() - 1) < 1e-13 and np.all(wts > 0)
        pts, w = product_rule(d.order + extra)
        for _ in range(5):      # random polynomial of degree `extra`
            c = rng.normal(size=(extra + 1, extra + 1, extra + 1))

            def f(p, c=c):
                out = np.zeros(len(p))
                for a in range(extra + 1):
                    for b in range(extra + 1 - a):
                        cc = extra - a - b
                        out += c[a, b, cc] * p[:, 0] ** a * p[:, 1] ** b * p[:, 2] ** cc
                return out
            ref = 4 * np.pi * w @ (f(pts) * d(pts))
            assert abs(wts @ f(n) - ref) < 1e-12 * max(1, abs(ref))


def test_negative_density_rejected_with_location():
    # phi_xx = -a20/2 - 3 a22 = -0.1 - 1.2 = -1.3 -> 4 pi xi = -0.3 along x
    with pytest.raises(NegativeDensityError) as exc:
        SphericalDensity.from_seed(a20=0.2, a22=0.4)
    msg = str(exc.value)
    assert "-0.3" in msg and "gamma = 90 deg" in msg and "beta = 90 deg" in msg
    d = SphericalDensity.from_seed(a20=0.2, a22=0.4, allow_negative=True)
    m = d.minimum()
    assert np.isclose(m.normalised, -0.3, atol=1e-9)
    assert np.allclose(np.abs(m.normal), [1, 0, 0], atol=1e-5)
    # a boundary case with minimum exactly zero is accepted
    z = SphericalDensity.from_seed(a20=-1.0)
    assert abs(z.minimum().normalised) < 1e-9


def test_minimum_search_finds_narrow_dip():
    # order-8 density with a narrow dip: compare with a brute-force fine grid
    rng = np.random.default_rng(11)
    ks, ms = sh_degrees_orders(8)
    c = rng.normal(0, 0.03, len(ks))
    d = SphericalDensity(order=8, coefficients=c, allow_negative=True)
    g, b = np.meshgrid(np.linspace(0, np.pi, 181), np.linspace(0, 2 * np.pi, 361), indexing="ij")
    brute = d(seed_normal(g, b)).min()
    assert d.minimum().value <= brute + 1e-12
    assert d.maximum().value >= d(seed_normal(g, b)).max() - 1e-12


def test_isotropic_and_errors():
    iso = isotropic(3)
    assert iso.order == 0 and np.isclose(iso([0, 0, 1]), 1 / (4 * np.pi))
    assert np.allclose(iso.fabric_tensor(2), np.eye(3) / 3)
    with pytest.raises(ParameterError, match="order"):
        SphericalDensity(order=3, coefficients=np.zeros(9))
    with pytest.raises(ParameterError, match="coefficients"):
        SphericalDensity(order=2, coefficients=np.zeros(4))
    with pytest.raises(ParameterError, match="coefficients"):
        SphericalDensity(order=2, coefficients=[np.nan, 0, 0, 0, 0])
    d = SphericalDensity.from_seed(0.3)
    with pytest.raises(ParameterError, match="unit vectors"):
        d([1.0, 1.0, 0.0])
    with pytest.raises(ParameterError, match="shape"):
        d([1.0, 0.0])
    with pytest.raises(ParameterError, match="non-finite"):
        d([np.nan, 0.0, 1.0])
    with pytest.raises(ParameterError, match="a20"):
        SphericalDensity.from_seed(a20=float("nan"))
    with pytest.raises(ParameterError, match="b_k0"):
        SphericalDensity.from_seed_coefficients({(2, 0): (0.1, 0.2)})
    with pytest.raises(ParameterError, match="even"):
        SphericalDensity.from_seed_coefficients({(3, 0): (0.1, 0.0)})
    with pytest.raises(ParameterError, match="R"):
        d.rotated(np.ones((3, 3)))


def test_eval_shape_and_antipodal_symmetry():
    d = SphericalDensity.from_seed(0.3, 0.1, -0.05)
    n = seed_normal(np.full((4, 5), 0.7), np.linspace(0, 6, 20).reshape(4, 5))
    v = d(n)
    assert v.shape == (4, 5)
    assert np.allclose(v, d(-n))                   # centrosymmetric (Eq. 4.7 remark)
    g, b = seed_angles(n)
    assert np.allclose(seed_normal(np.pi - g, b + np.pi), -n)    # correct antipode (erratum)


def _rot(q):
    q = np.asarray(q, float)
    return Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()


quat = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1)
small = st.floats(-0.15, 0.15)


@settings(max_examples=25, deadline=None)
@given(quat, small, small, small, small, small)
def test_rotation_commutes_with_fabric_tensors(q, a20, a22, b22, a40, a43):
    R = _rot(q)
    d = SphericalDensity.from_seed_coefficients({(2, 0): (a20, 0), (2, 2): (a22, b22),
                                                 (4, 0): (a40, 0), (4, 3): (a43 / 30, a20 / 30)},
                                                allow_negative=True)
    r = d.rotated(R)
    rng = np.random.default_rng(0)
    n = rng.normal(size=(20, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert np.allclose(r(n), d(n @ R), atol=1e-13)          # xi'(n) = xi(R^T n)
    for rank in (2, 4):
        assert np.allclose(r.fabric_tensor(rank), rotate_tensor(d.fabric_tensor(rank), R), atol=1e-13)
    phis = d.coefficient_tensors()
    rphis = r.coefficient_tensors()
    for k in phis:
        assert np.allclose(rphis[k], rotate_tensor(phis[k], R), atol=1e-12)


def test_tetragonal_fabric_of_table_1_is_transversely_isotropic_about_x():
    # seed Sec. 4.3: a20 = 2 a22, b22 = 0 gives F = diag(1+a20, 1+a20, 1-2 a20) in (z, y, x):
    # invariant under every rotation about x, i.e. transversely isotropic, not tetragonal.
    d = SphericalDensity.from_seed(a20=0.3, a22=0.15)
    phi = d.coefficient_tensors()[2]
    assert np.allclose(np.diag(phi), [-0.6, 0.3, 0.3])
    for ang in (0.3, 1.0, np.pi / 4, 2.2):
        R = Rotation.from_rotvec([ang, 0, 0]).as_matrix()
        assert np.allclose(d.rotated(R).coefficients, d.coefficients, atol=1e-13)


def test_seed_fig_4_2_fabrics_are_valid_densities():
    # transversely isotropic, orthotropic, monoclinic parameter sets of the seed's Fig. 4.2
    for (a20, a22, b22), expected_min in [((0.8, 0, 0), 0.6), ((0.2, 0.25, 0), 0.15),
                                          ((0.2, 0.25, 0.1), None)]:
        d = SphericalDensity.from_seed(a20, a22, b22)
        phi = d.coefficient_tensors()[2]
        lam = np.linalg.eigvalsh(phi)
        # a second-order density's minimum is 1 + smallest eigenvalue of phi (over |n| = 1)
        assert np.isclose(d.minimum().normalised, 1 + lam[0], atol=1e-10)
        assert np.isclose(d.maximum().normalised, 1 + lam[-1], atol=1e-10)
        if expected_min is not None:
            assert np.isclose(1 + lam[0], expected_min)


def test_from_function_shrunk_truncated():
    d = SphericalDensity.from_seed_coefficients({(2, 0): (0.3, 0), (4, 1): (0.01, 0.02)})
    e = SphericalDensity.from_function(d, order=4)
    assert np.allclose(e.coefficients, d.coefficients, atol=1e-14)
    with pytest.raises(ParameterError, match="integrate to 1"):
        SphericalDensity.from_function(lambda p: 2 * d(p), order=4)
    f = SphericalDensity.from_function(lambda p: 2 * d(p), order=4, normalise=True)
    assert np.allclose(f.coefficients, d.coefficients, atol=1e-14)
    assert np.allclose(d.shrunk(0.5).coefficients, 0.5 * d.coefficients)
    t = d.truncated(2)
    assert t.order == 2 and np.allclose(t.coefficients, d.coefficients[:5])
    assert np.allclose(t.truncated(4).coefficients[5:], 0)
    # projecting a non-polynomial function: exp(k z^2), normalised, order 8
    g = SphericalDensity.from_function(lambda p: np.exp(p[:, 2] ** 2), order=8, degree=30,
                                       normalise=True)
    assert g.order == 8 and g.is_nonnegative


def test_positivity_shortcut_is_sound():
    """The check that skips the refined minimum search (coefficient bound from the
    addition theorem, or grid values with Bernstein's inequality) must never pass a
    density whose refined minimum is negative, and the coefficient bound must hold."""
    from grainmech.fabric import FourierDensity
    from grainmech.fabric.harmonics import n_coefficients_3d

    rng = np.random.default_rng(2)
    g = rng.normal(size=(50000, 3))
    g /= np.linalg.norm(g, axis=1)[:, None]
    certified = 0
    for L in (2, 4, 6):
        for _ in range(12):
            c = rng.normal(size=n_coefficients_3d(L)) * rng.uniform(0.005, 0.06)
            d = SphericalDensity(L, c, allow_negative=True)
            assert np.abs(d._normalised(g) - 1).max() <= d._anisotropy_bound() + 1e-12
            ok = d._certainly_positive()
            certified += ok
            assert not (ok and d.minimum().normalised <= 0)
        for _ in range(12):
            a, b = rng.normal(size=(2, L // 2)) * 0.5
            d2 = FourierDensity(L, a, b, allow_negative=True)
            assert not (d2._certainly_positive() and d2.minimum().normalised <= 0)
    assert certified > 5  # the shortcut does fire


@pytest.mark.parametrize("kw", [{"a22": 3.07e154}, {"b22": 5.05e153}, {"a20": -1e200}, {"a22": 1.7e308},
                                {"a20": 1.7e308}])
def test_huge_coefficients_are_refused_without_overflow(kw):
    """A config value such as a22 = 3e154 (found by tests/io/test_config_fuzz.py) is refused
    with the one NegativeDensityError before anything is evaluated: a coefficient of a
    density xi >= 0 with unit integral is the mean of Y_km over xi, so |c_km| <=
    max|Y_km| <= sqrt((2k+1)/(4 pi)) (addition theorem); no overflow warning on the way."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(NegativeDensityError, match=r"exceeds sqrt\(\(2k\+1\)/\(4 pi\)\) = 0\.6308"):
            SphericalDensity.from_seed(**kw)


def test_coefficient_bound_is_attained_by_no_valid_density_and_spares_the_valid_ones():
    """The bound |c_km| <= sqrt((2k+1)/(4 pi)) never refuses a non-negative density: the
    seed's extreme valid second-order densities (1 + a20 P2 >= 0 for a20 = 2 and -1) pass
    it, and so do the coefficients of non-negative measures of unit mass concentrated on a
    few directions (weighted means of Y_km: the largest coefficients such a measure has),
    which come within a few per cent of the bound but not over it."""
    for kw in ({"a20": 2.0}, {"a20": -1.0}, {"a22": 1.0 / 6.0}, {"b22": -1.0 / 6.0}):
        d = SphericalDensity.from_seed(**kw)
        assert d._impossible_coefficient() is None
    ref = SphericalDensity(order=6, coefficients=np.zeros(27))
    bound = np.sqrt((2 * ref._ks + 1) / (4 * np.pi))
    rng = np.random.default_rng(4)
    worst = 0.0
    for size in (1, 2, 3, 50):
        for _ in range(200):
            pts = rng.standard_normal((size, 3))
            pts /= np.linalg.norm(pts, axis=1)[:, None]
            w = rng.random(size)
            c = (w / w.sum()) @ real_sh(pts, ref._ks, ref._ms)
            worst = max(worst, float(np.max(np.abs(c) / bound)))
    assert 0.9 < worst <= 1.0 + 1e-12

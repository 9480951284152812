"""Fitting densities to measured normals; empirical fabric tensors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.stats import chi2

from grainmech.errors import NegativeDensityError, ParameterError
from grainmech.fabric import (
    FourierDensity,
    NegativeDensityWarning,
    SphericalDensity,
    fabric_tensor,
    fit_density,
)

TRUE_3D = SphericalDensity.from_seed_coefficients(
    {(2, 0): (0.35, 0.0), (2, 1): (0.05, -0.04), (2, 2): (0.08, 0.03),
     (4, 0): (0.15, 0.0), (4, 2): (0.004, -0.002), (4, 4): (0.0005, 0.0003)})
TRUE_2D = FourierDensity.from_seed(a2=0.4, b2=-0.15, a4=0.2, b4=0.05)


def test_fabric_tensor_from_normals():
    n = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 0, 1.0], [0, 1.0, 0]])
    N = fabric_tensor(n, 2)
    assert np.allclose(N, np.diag([0.25, 0.25, 0.5]))
    Nw = fabric_tensor(n, 2, weights=[2, 0, 0, 2])
    assert np.allclose(Nw, np.diag([0.5, 0.5, 0.0]))
    assert np.isclose(fabric_tensor(n, 0), 1.0)
    N4 = fabric_tensor(n, 4)
    assert np.isclose(N4[2, 2, 2, 2], 0.5) and np.isclose(N4[0, 0, 1, 1], 0.0)


@pytest.mark.parametrize("true, n_samples", [(TRUE_3D, 30000), (TRUE_2D, 20000)])
def test_fit_recovers_known_density_within_standard_errors(true, n_samples):
    normals = true.sample(n_samples, rng=2024)
    # random signs: the fit must not care about the sign of a normal
    normals *= np.where(np.random.default_rng(1).random(n_samples) < 0.5, -1.0, 1.0)[:, None]
    res = fit_density(normals, true.order)
    c_true = true.coefficients       # orthonormal-basis coefficients in both dimensions
    z = (res.coefficients - c_true) / res.standard_errors
    assert np.all(np.abs(z) < 4.0), z
    # sum of squared z-scores ~ chi2(p) (approximately, the coefficients are correlated)
    assert 1e-3 < chi2.cdf(np.sum(z ** 2), len(z)) < 1 - 1e-3
    # seed-convention estimates and errors are consistent
    for key, (a, b) in true.seed_coefficients().items():
        ea, eb = res.seed_coefficients[key]
        sa, sb = res.seed_standard_errors[key]
        assert abs(ea - a) < 4 * sa + 1e-15 and abs(eb - b) < 4 * sb + 1e-15
    # the standard errors are the sampling spread: compare with the theoretical value
    # Var(f_j) under the true density, from quadrature
    pts, w = true.directions(2 * true.order)
    from grainmech.fabric.fit import _basis
    B = _basis(pts, true.order)
    var = w @ (B - c_true) ** 2
    assert np.allclose(res.standard_errors, np.sqrt(var / n_samples), rtol=0.1)
    # goodness of fit: correct model not rejected
    assert res.p_value is not None and res.p_value > 1e-3, res
    assert res.min_expected >= 5
    # the fitted density reproduces the empirical fabric tensors exactly (moment property)
    for rank in range(2, true.order + 1, 2):
        assert np.allclose(res.density.fabric_tensor(rank), fabric_tensor(normals, rank), atol=1e-12)


def test_underfitting_is_detected_by_chi_square():
    normals = TRUE_2D.sample(20000, rng=7)
    assert fit_density(normals, 2).p_value < 1e-6
    normals3 = TRUE_3D.sample(30000, rng=7)
    assert fit_density(normals3, 2).p_value < 1e-6


def test_weighted_fit_equals_replicated_fit():
    rng = np.random.default_rng(3)
    n = TRUE_3D.sample(500, rng=rng)
    reps = rng.integers(1, 4, len(n))
    a = fit_density(n, 2, weights=reps.astype(float), on_negative="allow")
    b = fit_density(np.repeat(n, reps, axis=0), 2, on_negative="allow")
    assert np.allclose(a.coefficients, b.coefficients, atol=1e-14)
    assert a.n_effective < b.n_effective


def test_on_negative_modes():
    # a sharply clustered sample: its order-2 projection is negative somewhere
    rng = np.random.default_rng(0)
    v = np.array([0, 0, 1.0]) + rng.normal(0, 0.05, (2000, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    with pytest.warns(NegativeDensityWarning, match="negative"):
        r = fit_density(v, 2)
    assert r.density.allow_negative and r.minimum.normalised < 0
    assert "seed angles gamma" in r.message and "(|S| xi = -1.48" in r.message
    assert abs(r.minimum.seed_angles[0] - np.pi / 2) < 0.05       # minimum on the equator
    with pytest.raises(NegativeDensityError, match="minimum"):
        fit_density(v, 2, on_negative="raise")
    s = fit_density(v, 2, on_negative="shrink")
    assert 0 < s.shrink_factor < 1
    assert s.density.minimum().normalised >= -1e-10 and not s.density.allow_negative
    # principal direction preserved, estimates reported unshrunk
    assert np.allclose(s.coefficients, r.coefficients)
    from grainmech.fabric import anisotropy
    axis_emp = anisotropy(fabric_tensor(v, 2)).principal_axes[:, 0]
    assert np.allclose(s.density.anisotropy().principal_axes[:, 0], axis_emp, atol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit_density(v, 2, on_negative="allow")


def test_fit_input_errors():
    n = TRUE_3D.sample(100, rng=1)
    with pytest.raises(ParameterError, match="order"):
        fit_density(n, 3)
    with pytest.raises(ParameterError, match="unit"):
        fit_density(n * 1.1, 2)
    bad = n.copy()
    bad[5, 1] = np.nan
    with pytest.raises(ParameterError, match=r"non-finite.*\(5, 1\)"):
        fit_density(bad, 2)
    with pytest.raises(ParameterError, match="shape"):
        fit_density(n[:, :1], 2)
    with pytest.raises(ParameterError, match="weights"):
        fit_density(n, 2, weights=np.ones(99))
    with pytest.raises(ParameterError, match="weights"):
        fit_density(n, 2, weights=-np.ones(100))
    with pytest.raises(ParameterError, match="on_negative"):
        fit_density(n, 2, on_negative="clip")
    with pytest.raises(ParameterError, match="n_bins"):
        fit_density(n, 2, n_bins=10)
    with pytest.raises(ParameterError, match="rank"):
        fabric_tensor(n, -1)


def test_small_sample_skips_chi_square_with_message():
    n = TRUE_3D.sample(10, rng=1)
    r = fit_density(n, 4, on_negative="allow")
    assert r.p_value is None and "skipped" in r.message

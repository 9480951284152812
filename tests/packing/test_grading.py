"""Grain-size distributions of ``grainmech pack`` (grainmech.packing.grading).

The sample is a *number* sample of a *mass* curve: its mass-weighted distribution must
reproduce the curve (ASTM D6913 percent passing by mass); D50-Cu is checked against the
definition Cu = D60 / D10 of the mass curve.
"""

import numpy as np
import pytest

from grainmech.errors import ParameterError
from grainmech.packing import D50Cu, SieveCurve, UniformRadius


def mass_passing(radii, d):
    """Percent passing by mass of diameter d for a number sample of radii."""
    D = 2 * np.asarray(radii)
    m = D ** 3
    return np.array([m[D <= x].sum() / m.sum() for x in np.atleast_1d(d)])


def mass_quantile(radii, q):
    D = np.sort(2 * np.asarray(radii))
    cm = np.cumsum(D ** 3)
    cm /= cm[-1]
    return np.interp(q, cm, D)


def test_sieve_curve_sample_reproduces_mass_curve():
    sizes = [0.2e-3, 0.3e-3, 0.45e-3, 0.6e-3]
    passing = [0, 20, 70, 100]
    g = SieveCurve(sizes, passing)
    s = g.sample(40000, np.random.default_rng(3), max_ratio=10.0)
    assert s.cut_fines == 0 and s.cut_coarse == 0
    got = mass_passing(s.radii, sizes[1:3])
    assert got == pytest.approx([0.20, 0.70], abs=0.02)
    assert 2 * s.radii.min() >= 0.2e-3 and 2 * s.radii.max() <= 0.6e-3


def test_sieve_curve_truncation_reports_cut_mass():
    g = SieveCurve([0.01e-3, 0.1e-3, 1e-3], [0, 10, 100])
    s = g.sample(2000, np.random.default_rng(1), max_ratio=4.0)
    # D_min = 1 mm / 4 = 0.25 mm: cut mass = passing at 0.25 mm on the log-linear curve
    expect = 0.10 + 0.90 * np.log(0.25e-3 / 0.1e-3) / np.log(10)
    assert s.cut_fines == pytest.approx(expect, rel=1e-9)
    assert 2 * s.radii.min() >= 0.25e-3 * (1 - 1e-12)


def test_d50_cu_matches_definition():
    g = D50Cu(0.3e-3, 2.0)
    s = g.sample(60000, np.random.default_rng(5), max_ratio=1e3)
    d10, d50, d60 = mass_quantile(s.radii, [0.1, 0.5, 0.6])
    assert d50 == pytest.approx(0.3e-3, rel=0.03)
    assert d60 / d10 == pytest.approx(2.0, rel=0.05)


def test_uniform_radius_bounds_and_mean():
    s = UniformRadius(1e-4, 0.2).sample(20000, np.random.default_rng(0))
    assert s.radii.min() >= 0.8e-4 and s.radii.max() <= 1.2e-4
    assert s.radii.mean() == pytest.approx(1e-4, rel=0.01)
    assert np.all(UniformRadius(1e-4).sample(5, np.random.default_rng(0)).radii == 1e-4)


@pytest.mark.parametrize("sizes, passing, key", [
    ([0.3e-3, 0.2e-3], [0, 100], "grading.sizes"),
    ([0.2e-3, 0.3e-3, 0.4e-3], [0, 60, 50], "grading.passing"),
    ([0.2e-3, 0.3e-3], [10, 100], "grading.passing"),
    ([-1.0, 0.3e-3], [0, 100], "grading.sizes"),
])
def test_bad_sieve_curves_name_the_key(sizes, passing, key):
    with pytest.raises(ParameterError) as e:
        SieveCurve(sizes, passing)
    assert e.value.name == key


def test_bad_d50_cu_and_uniform():
    with pytest.raises(ParameterError, match="cu"):
        D50Cu(0.3e-3, 0.9)
    with pytest.raises(ParameterError, match="spread"):
        UniformRadius(1e-4, 1.0)


def test_measured_grading_by_mass():
    """D10, D50, D60 by mass (D^3) and Cu = D60/D10: one size gives Cu = 1; a sample of a
    D50-Cu curve gives its D50 and Cu back (within the sampling and the cut sizes); the
    shipped packings (drawn from D50 = 0.3 mm, Cu = 1.3, cut to a size ratio of 2.5)
    measure D50 = 0.298 mm, Cu = 1.28."""
    from grainmech.packing import load_packing, measured_grading

    one = measured_grading(np.full(7, 1e-4))
    assert one.cu == 1.0 and one.d50 == pytest.approx(2e-4, rel=1e-12) and one.n_grains == 7
    # mass, not number: 1000 grains of 0.1 mm and one of 1 mm carry equal mass
    two = measured_grading(np.r_[np.full(1000, 0.5e-4), 0.5e-3])
    assert 1e-4 < two.d50 < 1e-3 and two.d10 == pytest.approx(1e-4, rel=1e-12)
    s = D50Cu(3e-4, 1.5).sample(20000, np.random.default_rng(3), max_ratio=20)
    m = measured_grading(s.radii)
    assert m.d50 == pytest.approx(3e-4, rel=0.02) and m.cu == pytest.approx(1.5, rel=0.03)
    dense = measured_grading(load_packing("dense").radii)
    assert dense.d50 == pytest.approx(0.298e-3, rel=2e-3) and dense.cu == pytest.approx(1.278, rel=1e-3)
    with pytest.raises(ParameterError, match="radii"):
        measured_grading([1e-4, -1e-4])

"""Packing density (seed Eq. 4.1) and coordination-number correlations (Eq. 4.2-4.5, 6.4)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from grainmech.errors import ParameterError
from grainmech.fabric import (
    CorrelationRangeWarning,
    contact_ends_per_volume,
    contacts_per_volume,
    coordination_chang,
    coordination_field,
    coordination_filep,
    coordination_number,
    coordination_smith,
    coordination_yanagisawa,
    particles_per_volume,
    porosity,
    void_ratio_chang,
    void_ratio_from_porosity,
)

FCC_E = 1 / (np.pi / (3 * np.sqrt(2))) - 1        # 0.3505
SC_E = 1 / (np.pi / 6) - 1                        # 0.9099


def test_eq_4_1_spheres_and_discs():
    e, m, r = 0.57, 9.0, 0.01
    assert np.isclose(contact_ends_per_volume(e, m, r), 3 * m / (4 * np.pi * r ** 3 * (1 + e)))
    assert np.isclose(contact_ends_per_volume(e, m, r, dim=2), m / (np.pi * r ** 2 * (1 + e)))
    assert np.isclose(contacts_per_volume(e, m, r), 0.5 * contact_ends_per_volume(e, m, r))


def test_counting_on_a_simple_cubic_lattice():
    # simple cubic packing of spheres, radius r: one particle per (2r)^3, 6 contacts each,
    # 3 physical contacts per cell
    r = 0.5
    assert np.isclose(particles_per_volume(SC_E, r), 1.0)
    assert np.isclose(contacts_per_volume(SC_E, 6, r), 3.0)
    assert np.isclose(contact_ends_per_volume(SC_E, 6, r), 6.0)
    # square packing of discs: one disc per (2r)^2, 2 physical contacts per cell
    e_sq = 4 / np.pi - 1
    assert np.isclose(contacts_per_volume(e_sq, 4, r, dim=2), 2.0)


def test_correlations_values():
    e = 0.57
    n = e / (1 + e)
    assert np.isclose(coordination_yanagisawa(e), 3.183 ** (2.469 - e))
    assert abs(coordination_yanagisawa(e) - 9.0) < 0.02       # the seed's (m=9, e=0.57) pair
    assert np.isclose(coordination_smith(e), 26.486 - 10.726 / (1 - n))
    assert np.isclose(coordination_filep(e), 3.1 / n)
    assert np.isclose(coordination_field(e), 12 / (1 + e))
    assert np.isclose(coordination_chang(e), 23 - 25 * e)
    assert np.isclose(void_ratio_chang(coordination_chang(e)), e)      # Eq. 6.4 inverted
    assert np.isclose(coordination_number(e, "field"), 12 / 1.57)
    # Smith et al. interpolate the regular packings: 12 at FCC, 6 at simple cubic
    assert abs(coordination_smith(FCC_E + 1e-9) - 12) < 0.01
    assert abs(coordination_smith(SC_E) - 6) < 0.01
    arr = coordination_field(np.array([0.4, 0.6, 0.8]))
    assert arr.shape == (3,) and np.allclose(arr, 12 / np.array([1.4, 1.6, 1.8]))


def test_porosity_round_trip():
    assert np.isclose(porosity(1.0), 0.5)
    assert np.isclose(void_ratio_from_porosity(porosity(0.7)), 0.7)


@pytest.mark.parametrize("f", [coordination_yanagisawa, coordination_smith, coordination_filep,
                               coordination_field, coordination_chang, porosity])
@pytest.mark.parametrize("bad", [0.0, -0.2, float("nan"), float("inf")])
def test_bad_void_ratio(f, bad):
    with pytest.raises(ParameterError, match="void_ratio"):
        f(bad)


def test_errors_and_warnings():
    with pytest.raises(ParameterError, match="radius"):
        contact_ends_per_volume(0.6, 9, 0.0)
    with pytest.raises(ParameterError, match="coordination"):
        contacts_per_volume(0.6, -1, 0.1)
    with pytest.raises(ParameterError, match="dim"):
        particles_per_volume(0.6, 0.1, dim=1)
    with pytest.raises(ParameterError, match="void_ratio"):
        coordination_smith(1.6)                  # gives m <= 0
    with pytest.raises(ParameterError, match="void_ratio"):
        coordination_chang(0.95)                 # 23 - 25 e < 0
    with pytest.raises(ParameterError, match="porosity"):
        void_ratio_from_porosity(1.0)
    with pytest.raises(ParameterError, match="coordination"):
        void_ratio_chang(24.0)
    with pytest.raises(ParameterError, match="correlation"):
        coordination_number(0.6, "oda")
    with pytest.warns(CorrelationRangeWarning, match="nominal"):
        coordination_field(1.2)
    with pytest.warns(CorrelationRangeWarning, match="above 12"):
        coordination_chang(0.36)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        coordination_yanagisawa(0.6)


def test_particles_per_volume_out_of_float_range_is_a_clear_error():
    """A radius so small that 1/r^3 overflows (wrong length unit) names the radius."""
    from grainmech.errors import ParameterError
    from grainmech.fabric.coordination import particles_per_volume

    with pytest.raises(ParameterError, match="radius = 1e-120"):
        particles_per_volume(0.6, 1e-120)
    # 3 / (4 pi r^3 (1 + e)) for r = 1 mm, e = 0.6
    assert particles_per_volume(0.6, 1e-3) == pytest.approx(3 / (4 * np.pi * 1e-9 * 1.6), rel=1e-14)

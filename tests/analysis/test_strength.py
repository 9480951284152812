"""Peak and critical-state friction angles (grainmech.analysis.strength).

Reference: Mohr-Coulomb for zero cohesion, sin(phi) = (s1 - s3)/(s1 + s3), and on a
triaxial compression path q/p = 6 sin(phi) / (3 - sin(phi)) (Wood 1990, Sec. 4.2):
sigma_1 = 3, sigma_3 = 1 gives phi = 30 deg and q/p = 1.2 exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.analysis.strength import mobilised_friction_angle, path_strength
from grainmech.errors import ParameterError


def test_mobilised_angle_of_a_triaxial_state_and_its_rotation() -> None:
    s = np.array([[1.0, 1.0, 3.0, 0.0, 0.0, 0.0]])
    assert mobilised_friction_angle(s)[0] == pytest.approx(30.0, abs=1e-12)
    # the same state rotated by 45 deg about y (xz plane): principal values unchanged
    c = 0.5 * (1 + 3)
    r = np.array([[c, 1.0, c, 0.0, 0.5 * (3 - 1), 0.0]])
    assert mobilised_friction_angle(r)[0] == pytest.approx(30.0, abs=1e-9)
    assert np.isnan(mobilised_friction_angle(np.array([[-1.0, -1, -1, 0, 0, 0]]))[0])


def test_peak_and_critical_state_of_a_dense_like_path() -> None:
    ea = np.linspace(0.0, 0.2, 201)
    # stress ratio rises to a peak of 40 deg at 3 % and settles to 30 deg; volume dilates
    # then stops changing
    phi = 30.0 + 10.0 * np.exp(-((ea - 0.03) / 0.02) ** 2) * (ea > 0.005)
    phi[ea > 0.1] = 30.0
    sin = np.sin(np.radians(phi))
    s3 = np.full_like(ea, 100e3)
    s1 = s3 * (1 + sin) / (1 - sin)
    stress = np.column_stack([s3, s3, s1, 0 * s3, 0 * s3, 0 * s3])
    ev = -0.02 * np.minimum(ea / 0.1, 1.0)
    out = path_strength(stress, ea, ev)
    assert out.peak_friction_angle_deg == pytest.approx(40.0, abs=0.05)
    assert out.peak_axial_strain == pytest.approx(0.03, abs=1e-3)
    assert out.critical_friction_angle_deg == pytest.approx(30.0, abs=1e-9)
    assert out.critical_q_over_p == pytest.approx(1.2, rel=1e-9)
    assert out.critical and abs(out.dilatancy_rate) < 1e-9


def test_a_path_still_dilating_is_not_called_critical() -> None:
    ea = np.linspace(0.0, 0.05, 51)
    stress = np.column_stack([np.full(51, 1e5), np.full(51, 1e5), 2e5 + 1e6 * ea, 0 * ea, 0 * ea, 0 * ea])
    out = path_strength(stress, ea, -0.5 * ea)
    assert not out.critical and out.dilatancy_rate == pytest.approx(-0.5)
    assert "not a critical state" in out.note
    with pytest.raises(ParameterError, match="tail"):
        path_strength(stress, ea, -0.5 * ea, tail=1.5)

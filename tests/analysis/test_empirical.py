"""Darendeli (2001) and Hardin-Drnevich (1972) curves, against their published definitions.

Darendeli: all-soils coefficients (Table 8.12): gamma_r = 0.0352 % at 1 atm, PI = 0,
OCR = 1; G/Gmax(gamma_r) = 1/2; D_min = 0.8005 % at 1 atm and 1 Hz; gamma_r scales as
sigma^0.3483. Mean stress is taken in Pa and converted with 1 atm = 101325 Pa.
"""

import math

import numpy as np
import pytest

from grainmech.analysis import P_ATM, darendeli, hardin_drnevich
from grainmech.errors import ParameterError


def test_darendeli_reference_values_at_one_atmosphere():
    c = darendeli([3.52e-4], P_ATM)
    assert c.gamma_r == pytest.approx(3.52e-4, rel=1e-12)
    assert c.G_ratio[0] == pytest.approx(0.5, rel=1e-12)
    assert c.d_min == pytest.approx(0.008005, rel=1e-12)
    assert c.curvature == 0.919


def test_darendeli_mean_stress_in_pa_converted_to_atm():
    c1 = darendeli([1e-4], 100e3)  # 100 kPa = 0.987 atm (not 100 atm)
    assert c1.gamma_r == pytest.approx(3.52e-4 * (100e3 / 101325) ** 0.3483, rel=1e-12)
    c4 = darendeli([1e-4], 4 * P_ATM, pi=15, ocr=2)
    assert c4.gamma_r == pytest.approx((0.0352 + 0.0010 * 15 * 2 ** 0.3246) * 4 ** 0.3483 / 100)


def test_darendeli_damping_limits_and_trends():
    g = np.logspace(-7, -2, 30)
    c = darendeli(g, P_ATM, n_cycles=10, frequency=1)
    assert c.damping[0] == pytest.approx(c.d_min, rel=1e-2)  # tiny strain -> D_min
    assert np.all(np.diff(c.damping) > 0) and np.all(np.diff(c.G_ratio) < 0)
    # more cycles lower the Masing part: b = 0.6329 - 0.0057 ln N
    c100 = darendeli(g, P_ATM, n_cycles=100)
    b10, b100 = 0.6329 - 0.0057 * math.log(10), 0.6329 - 0.0057 * math.log(100)
    ratio = (c100.damping[-1] - c100.d_min) / (c.damping[-1] - c.d_min)
    assert ratio == pytest.approx(b100 / b10, rel=1e-12)


def test_hardin_drnevich():
    r, d = hardin_drnevich([1e-4, 3e-4], 1e-4, 0.2)
    assert r[0] == pytest.approx(0.5) and d[0] == pytest.approx(0.1)
    assert r[1] == pytest.approx(0.25) and d[1] == pytest.approx(0.15)
    with pytest.raises(ParameterError, match="gamma_r"):
        hardin_drnevich([1e-4], -1.0)
    with pytest.raises(ParameterError, match="mean_stress"):
        darendeli([1e-4], 0.0)


def test_bolton_1986_relative_dilatancy_and_peak_angle():
    """Bolton (1986): I_R = D_r (10 - ln p'/kPa) - 1 clipped to [0, 4]; phi_peak = phi_cs + 3 I_R (triaxial)."""
    from grainmech.analysis.empirical import bolton

    b = bolton(0.85, 100e3)
    ir = 0.85 * (10 - math.log(100.0)) - 1  # 3.5357
    assert b.relative_dilatancy == pytest.approx(ir, rel=1e-12)
    assert b.phi_peak == pytest.approx(33.0 + 3 * ir, rel=1e-12)  # 43.6 deg: dense quartz sand
    assert b.dilatancy_rate == pytest.approx(0.3 * ir)
    assert bolton(0.85, 100e3, test="plane strain").phi_peak == pytest.approx(33.0 + 5 * ir)
    assert bolton(0.1, 100e3).relative_dilatancy == 0.0  # clipped below
    assert bolton(1.0, 1e3).relative_dilatancy == 4.0  # clipped above (10 - ln 1 - 1 = 9)
    with pytest.raises(ParameterError, match="relative_density"):
        bolton(85.0, 100e3)


def test_relative_density():
    from grainmech.analysis.empirical import relative_density

    assert relative_density(0.6, 0.5, 0.9) == pytest.approx(0.75)
    with pytest.raises(ParameterError, match="e_max"):
        relative_density(0.6, 0.9, 0.5)

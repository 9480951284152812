"""The modified hyperbola fitted to published curves gives back their own parameters.

Darendeli (2001), Ch. 9 and Table 8.12 (all soils): gamma_r [%] = (0.0352 + 0.0010 PI
OCR^0.3246) (p'/p_a)^0.3483, a = 0.9190, b = 0.6329 - 0.0057 ln N,
D_min [%] = (0.8005 + 0.0129 PI OCR^-0.1069) (p'/p_a)^-0.2889 (1 + 0.2919 ln f).
Menq (2003): gamma_r [%] = 0.12 Cu^-0.6 (p'/p_a)^(0.5 Cu^-0.15), a = 0.86 + 0.1 log10(p'/p_a),
D_min [%] = 0.55 Cu^0.1 D50[mm]^-0.3 (p'/p_a)^-0.08, b = 0.6329 - 0.00566 ln N.
The expected values below are these formulas evaluated here by hand, not the code's curves.
"""

import math

import numpy as np
import pytest

from grainmech.analysis import darendeli, menq_curve
from grainmech.analysis.hyperbola import fit_hyperbola, hyperbola_damping, modified_hyperbola
from grainmech.errors import GrainmechError

P_A = 101325.0
STRAINS = np.logspace(-6, -2, 13)


@pytest.mark.parametrize("kpa", [50.0, 100.0, 400.0])
def test_recovers_darendeli(kpa):
    s = kpa * 1e3 / P_A
    c = darendeli(STRAINS, kpa * 1e3, pi=0.0, ocr=1.0, n_cycles=10.0, frequency=1.0)
    fit = fit_hyperbola(STRAINS, c.G_ratio, c.damping)
    assert fit.gamma_r == pytest.approx(0.0352e-2 * s ** 0.3483, rel=1e-6)
    assert fit.curvature == pytest.approx(0.9190, rel=1e-6)
    assert fit.masing_scaling == pytest.approx(0.6329 - 0.0057 * math.log(10.0), rel=1e-5)
    assert fit.d_min == pytest.approx(0.8005e-2 * s ** -0.2889, rel=1e-5)
    assert fit.g_residual < 1e-8 and fit.damping_residual < 1e-8
    assert fit.at_bound == []


@pytest.mark.parametrize("kpa,cu", [(61.0, 1.7), (100.0, 1.5), (176.0, 3.0)])
def test_recovers_menq(kpa, cu):
    s = kpa * 1e3 / P_A
    c = menq_curve(STRAINS, kpa * 1e3, cu, 0.15e-3, 10.0)
    fit = fit_hyperbola(STRAINS, c.G_ratio, c.damping)
    assert fit.gamma_r == pytest.approx(0.12e-2 * cu ** -0.6 * s ** (0.5 * cu ** -0.15), rel=1e-6)
    assert fit.curvature == pytest.approx(0.86 + 0.1 * math.log10(s), rel=1e-6)
    assert fit.masing_scaling == pytest.approx(0.6329 - 0.00566 * math.log(10.0), rel=1e-5)
    assert fit.d_min == pytest.approx(0.55e-2 * cu ** 0.1 * 0.15 ** -0.3 * s ** -0.08, rel=1e-5)


def test_menq_100_kpa_published_numbers():
    """Menq at 100 kPa, Cu = 1.5: gamma_r = 0.0935 %, a = 0.859 (analysis.empirical's worked example)."""
    c = menq_curve(STRAINS, 100e3, 1.5, 0.2e-3)
    fit = fit_hyperbola(STRAINS, c.G_ratio)
    assert round(100 * fit.gamma_r, 4) == 0.0935
    assert round(fit.curvature, 3) == 0.859
    assert math.isnan(fit.masing_scaling)


def test_hyperbola_half_at_reference_strain_and_held_damping():
    assert modified_hyperbola([2e-4], 2e-4, 0.7)[0] == pytest.approx(0.5)
    # damping held at its peak far beyond gamma_r (Menq's rule): equal at 1e3 and 1e5 gamma_r
    d = hyperbola_damping([0.3, 30.0], 3e-4, 0.86, 0.62, 0.01)
    assert d[0] == pytest.approx(d[1], rel=1e-12)


def test_noisy_points_report_a_residual():
    g = np.array([1e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2])
    r = modified_hyperbola(g, 3e-4, 1.0) + np.array([0.01, -0.01, 0.01, -0.01, 0.01, -0.01, 0.01, -0.01])
    fit = fit_hyperbola(g, r)
    assert 0.005 < fit.g_residual < 0.011
    assert fit.gamma_r == pytest.approx(3e-4, rel=0.1)


def test_bad_input():
    with pytest.raises(GrainmechError, match="at least two"):
        fit_hyperbola([1e-4], [0.9])
    with pytest.raises(GrainmechError, match="> 0"):
        fit_hyperbola([0.0, 1e-4], [1.0, 0.9])

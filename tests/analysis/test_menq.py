"""Menq (2003) curves of clean sands and gravels, against the published form and pystrata.

Menq, F.-Y. (2003), "Dynamic properties of sandy and gravelly soils", PhD thesis, Univ. of
Texas at Austin, in the form of pystrata's ``MenqSoilType`` (pystrata/site.py):
gamma_r [%] = 0.12 Cu^-0.6 (p'/p_a)^(0.5 Cu^-0.15), a = 0.86 + 0.1 log10(p'/p_a),
D_min [%] = 0.55 Cu^0.1 D50[mm]^-0.3 (p'/p_a)^-0.08, b = 0.6329 - 0.00566 ln N,
D = b (G/Gmax)^0.1 D_Masing + D_min (Darendeli's 2001 Masing damping of the modified
hyperbola), p_a = 101.325 kPa.
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from grainmech.analysis import P_ATM, masing_damping_hyperbolic, menq_curve
from grainmech.analysis.empirical import _masing_modified_pct
from grainmech.errors import ParameterError


def test_reference_values_at_100_kpa():
    """/work/shared/REFERENCES.md: at 100 kPa and Cu = 1.5, G/Gmax = 0.872 / 0.727 / 0.486 /
    0.115 at 1e-4 / 3e-4 / 1e-3 / 1e-2 (pystrata's MenqSoilType gives 0.87227, 0.72652,
    0.48558, 0.11541); D50 does not enter G/Gmax."""
    g = [1e-4, 3e-4, 1e-3, 1e-2]
    for d50 in (2e-4, 5e-3):
        c = menq_curve(g, 100e3, 1.5, d50)
        assert np.round(c.G_ratio, 3) == pytest.approx([0.872, 0.727, 0.486, 0.115], abs=1e-12)
    s = 100e3 / 101325.0
    assert c.gamma_r == pytest.approx(0.12e-2 * 1.5 ** -0.6 * s ** (0.5 * 1.5 ** -0.15), rel=1e-12)
    assert c.curvature == pytest.approx(0.86 + 0.1 * math.log10(s), rel=1e-12)
    assert c.d_min == pytest.approx(0.55e-2 * 1.5 ** 0.1 * 5.0 ** -0.3 * s ** -0.08, rel=1e-12)
    assert c.masing_scaling == pytest.approx(0.6329 - 0.00566 * math.log(10), rel=1e-12)


def test_at_one_atmosphere_and_the_reference_strain():
    c = menq_curve([1e-3], P_ATM, 1.0, 1e-3)
    assert c.gamma_r == pytest.approx(0.12e-2, rel=1e-12)  # Cu = 1, p = p_a: 0.12 %
    assert c.curvature == pytest.approx(0.86, rel=1e-12)
    assert c.d_min == pytest.approx(0.55e-2, rel=1e-12)  # D50 = 1 mm
    assert menq_curve([c.gamma_r], P_ATM, 1.0, 1e-3).G_ratio[0] == pytest.approx(0.5, rel=1e-12)


def test_damping_rises_from_d_min_and_is_held_beyond_its_peak():
    g = np.logspace(-7, 0, 400)
    c = menq_curve(g, 50e3, 2.0, 4e-4)
    assert c.damping[0] == pytest.approx(c.d_min, abs=1e-4)
    assert np.all(np.diff(c.damping) >= 0)
    held = g >= c.peak_strain
    assert held.any() and np.ptp(c.damping[held]) == 0.0
    assert 30 < c.peak_strain / c.gamma_r < 150  # about 65 gamma_r at a = 0.83


def test_masing_closed_form_against_a_numerical_loop():
    """The Masing damping of the hyperbola (a = 1) in closed form equals the area of the
    Masing loop integrated numerically, D = A / (4 pi W), W = tau_a gamma_a / 2; Darendeli's
    polynomial for the modified hyperbola at Menq's curvature (a = 0.80-0.96 for 30 kPa
    to 1.2 MPa) is within 1 percentage point of the numerical loop up to 30 gamma_r."""
    def numerical(x_a, a):
        """Masing loop of tau = x / (1 + |x|^a) (per unit Gmax and gamma_r) at amplitude x_a, in %."""
        backbone = lambda x: x / (1.0 + abs(x) ** a)  # noqa: E731
        t_a = backbone(x_a)
        load = lambda x: -t_a + 2.0 * backbone((x + x_a) / 2.0)  # noqa: E731  from -x_a
        unload = lambda x: t_a - 2.0 * backbone((x_a - x) / 2.0)  # noqa: E731  from +x_a
        area, _ = quad(lambda x: load(x) - unload(x), -x_a, x_a, epsabs=0, epsrel=1e-12, limit=200)
        return 100.0 * area / (4.0 * math.pi * 0.5 * t_a * x_a)

    for x in (0.01, 0.1, 1.0, 3.0, 10.0, 30.0, 100.0):
        assert 100.0 * masing_damping_hyperbolic(x, 1.0) == pytest.approx(numerical(x, 1.0), rel=1e-9)
    for kpa in (30.0, 100.0, 1200.0):
        a = menq_curve([1e-4], kpa * 1e3, 1.5, 2e-4).curvature
        for x in (0.3, 1.0, 3.0, 10.0, 30.0):
            assert abs(float(_masing_modified_pct(np.array([x]), 1.0, a)[0]) - numerical(x, a)) < 1.0, (kpa, x)


def test_agrees_with_pystratas_menq_soil_type():
    """pystrata's MenqSoilType (pystrata/site.py: MenqSoilType, ModifiedHyperbolicSoilType):
    G/Gmax and damping to 1e-6 relative on its strain grid below the peak of the Masing
    term; above it pystrata holds its last grid value before the peak and this function
    the peak value itself, at most 0.1 % larger (pystrata's default grid has 4.2 points
    per decade)."""
    pystrata = pytest.importorskip("pystrata")
    for cu, d50_mm, kpa, strains in ((1.5, 0.2, 100.0, None), (10.0, 5.0, 101.3, None), (1.2, 0.7, 400.0, None),
                                     (3.0, 2.0, 10.0, np.logspace(-6, 0.5, 300)),
                                     (1.5, 0.2, 24.0, np.logspace(-6, 0.5, 300))):
        theirs = pystrata.site.MenqSoilType(18.0, uniformity_coeff=cu, diam_mean=d50_mm, stress_mean=kpa,
                                            strains=strains)
        g = theirs.mod_reduc.strains
        ours = menq_curve(g, kpa * 1e3, cu, d50_mm * 1e-3)
        assert ours.G_ratio == pytest.approx(theirs.mod_reduc.values, rel=1e-6)
        below = g < ours.peak_strain
        assert ours.damping[below] == pytest.approx(theirs.damping.values[below], rel=1e-6)
        above = ~below
        assert np.all(ours.damping[above] >= theirs.damping.values[above] * (1 - 1e-12))
        assert np.all(ours.damping[above] <= theirs.damping.values[above] * (1 + 1e-3))


@pytest.mark.parametrize("kw, field", [
    (dict(mean_stress=0.0), "mean_stress"),
    (dict(mean_stress=float("nan")), "mean_stress"),
    (dict(uniformity_coefficient=0.9), "uniformity_coefficient"),
    (dict(d50=0.0), "d50"),
    (dict(d50=0.2), "d50"),  # 0.2 "mm" given as metres
    (dict(n_cycles=0.0), "n_cycles"),
])
def test_bad_inputs_name_the_field(kw, field):
    args = dict(mean_stress=100e3, uniformity_coefficient=1.5, d50=2e-4) | kw
    with pytest.raises(ParameterError, match=field):
        menq_curve([1e-4], **args)
    with pytest.raises(ParameterError, match="gamma"):
        menq_curve([0.0], 100e3, 1.5, 2e-4)

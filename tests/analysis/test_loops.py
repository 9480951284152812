"""Loop analysis against closed forms.

* Linear viscoelastic ellipse tau = G gamma_a (sin wt + eta cos wt): secant G, D = eta/2.
* Masing loop of the hyperbola tau = G g/(1 + g/g_r): damping equals the closed form of
  Darendeli (2001, Eq. 9.4a with a = 1) -- an independent check of both.
"""

import numpy as np
import pytest

from grainmech.analysis import condensed_modulus, loop_properties, masing_damping_hyperbolic
from grainmech.elasticity import isotropic_stiffness
from grainmech.errors import ParameterError


def test_ellipse_loop():
    G, ga, eta = 5e7, 1e-4, 0.1
    t = np.linspace(0, 2 * np.pi, 20001)
    lp = loop_properties(ga * np.sin(t), G * ga * (np.sin(t) + eta * np.cos(t)))
    assert lp.secant_modulus == pytest.approx(G, rel=1e-6)
    assert lp.damping == pytest.approx(eta / 2, rel=1e-6)
    assert lp.dissipated == pytest.approx(np.pi * G * eta * ga ** 2, rel=1e-6)


@pytest.mark.parametrize("ratio", [0.1, 1.0, 10.0])
def test_masing_hyperbolic_loop(ratio):
    G, gr = 1e8, 1e-4
    ga = ratio * gr
    f = lambda g: G * g / (1 + np.abs(g) / gr)  # noqa: E731
    s = np.linspace(0, 1, 20001)
    down = ga - 2 * ga * s  # +ga -> -ga on the Masing branch tau_a - 2 f((ga - g)/2)
    up = -ga + 2 * ga * s
    g = np.concatenate([down, up[1:]])
    tau = np.concatenate([f(ga) - 2 * f((ga - down) / 2), -f(ga) + 2 * f((up[1:] + ga) / 2)])
    lp = loop_properties(g, tau)
    assert lp.secant_modulus == pytest.approx(G / (1 + ratio), rel=1e-9)
    assert lp.damping == pytest.approx(float(masing_damping_hyperbolic(ga, gr)), rel=1e-6)


def test_condensed_modulus_isotropic():
    C = isotropic_stiffness(E=1e8, nu=0.25)
    mask = np.array([False, False, True, False, False, False])
    assert condensed_modulus(C, 4, mask) == pytest.approx(1e8 / 2.5)
    # axial strain with lateral stress free: Young's modulus
    assert condensed_modulus(C, 2, ~np.eye(6, dtype=bool)[2]) == pytest.approx(1e8)


def test_loop_errors():
    with pytest.raises(ParameterError, match="gamma"):
        loop_properties([0, 0, 0, 0], [1, 2, 3, 4])


# ---------------------------------------------------------------- loop quality (closure, symmetry)
def _masing_cycles(ga, n_cycles=2, n=200, G=1e8, gr=1e-4, tau_0=0.0):
    """Strain-controlled cycles 0 -> +ga -> 0 -> -ga -> 0 of a hyperbolic Masing material
    (backbone f(g) = G g / (1 + |g|/gr), branches tau_rev +- 2 f((g - g_rev)/2)), starting
    on the backbone; returns gamma, tau of every cycle (lists of arrays, each cycle from its
    first state to its last)."""
    f = lambda g: G * g / (1 + np.abs(g) / gr)  # noqa: E731
    q = n // 4
    up1 = np.linspace(0, ga, q + 1)
    cycles = []
    # first cycle: backbone to +ga, unloading branch to -ga, reloading branch back to 0
    down = np.linspace(ga, -ga, 2 * q + 1)[1:]
    back = np.linspace(-ga, 0, q + 1)[1:]
    g1 = np.concatenate([up1, down, back])
    t1 = np.concatenate([f(up1), f(ga) - 2 * f((ga - down) / 2), -f(ga) + 2 * f((back + ga) / 2)])
    cycles.append((g1, t1 + tau_0))
    for _ in range(n_cycles - 1):  # stationary: the reloading branch from -ga up to +ga, then as before
        up = np.linspace(0, ga, q + 1)
        g = np.concatenate([up, down, back])
        t = np.concatenate([-f(ga) + 2 * f((up + ga) / 2), f(ga) - 2 * f((ga - down) / 2),
                            -f(ga) + 2 * f((back + ga) / 2)])
        cycles.append((g, t + tau_0))
    return cycles


@pytest.mark.parametrize("ratio", [0.1, 1.0, 10.0])
def test_closed_masing_loop_passes(ratio):
    """The second cycle of a Masing material is closed and symmetric: closures and
    asymmetry vanish (to round-off) and the loop passes the default tolerances."""
    from grainmech.analysis import loop_quality

    ga = ratio * 1e-4
    (_, _), (g, t) = _masing_cycles(ga)
    q = loop_quality(g, t)
    assert q.stress_closure < 1e-12 and q.strain_closure == 0.0 and q.asymmetry < 1e-12
    assert q.gamma_a == pytest.approx(ga) and q.tau_a == pytest.approx(1e8 * ga / (1 + ratio), rel=1e-12)
    assert q.ok and q.closed and q.symmetric and q.problems == []


def test_first_cycle_from_virgin_loading_is_not_closed():
    """The first cycle starts on the backbone (tau = 0) and ends on the reloading branch:
    at gamma_a = gamma_r it ends -f(ga) + 2 f(ga/2) = G ga / 6 above its start, a third of
    tau_a = f(ga) = G ga / 2."""
    from grainmech.analysis import loop_quality

    (g, t), _ = _masing_cycles(1e-4)
    q = loop_quality(g, t)
    assert q.stress_closure == pytest.approx(1 / 3, rel=1e-9)
    assert not q.closed and not q.ok
    assert q.problems[0].startswith("loop not closed: the analysed cycle ends 33.3 % of tau_a")


def test_drifting_loop_fails():
    """A loop whose stress drifts by 20 % of tau_a over the cycle (ratcheting) and whose
    strain does not come back by 8 % of gamma_a: both closures measured, loop not closed."""
    from grainmech.analysis import loop_quality

    _, (g, t) = _masing_cycles(1e-4)
    s = np.linspace(0, 1, len(t))
    ta = 1e8 * 1e-4 / 2
    t_drift = t + 0.2 * ta * s
    g_drift = g + 0.08 * 1e-4 * s
    q = loop_quality(g_drift, t_drift)
    # the peaks sit a quarter and three quarters into the cycle: tau_a = (1 - 0.2/4) ta,
    # gamma_a = (1 - 0.08/4) ga
    assert q.stress_closure == pytest.approx(0.2 / 0.95, rel=1e-9)
    assert q.strain_closure == pytest.approx(0.08 / 0.98, rel=1e-9)
    assert not q.closed and not q.ok
    # just inside the tolerance: 4 % drift passes, 6 % does not
    assert loop_quality(g, t + 0.04 * ta * s).closed
    assert not loop_quality(g, t + 0.06 * ta * s).closed


def test_asymmetric_peaks():
    """Peaks measured from the test's initial shear stress tau_0: a loop shifted by 15 % of
    tau_a is asymmetric about 0, symmetric about its own tau_0; a loop stiffer one way
    (positive half scaled by 1.3) is asymmetric by 0.3 / 1.15."""
    from grainmech.analysis import loop_quality

    _, (g, t) = _masing_cycles(1e-4)
    ta = 1e8 * 1e-4 / 2
    shifted = t + 0.15 * ta
    q = loop_quality(g, shifted)
    assert q.asymmetry == pytest.approx(0.30, rel=1e-9) and not q.symmetric and q.closed
    assert "loop not symmetric" in q.problems[0]
    assert loop_quality(g, shifted, tau_0=0.15 * ta).asymmetry < 1e-12
    stiff = np.where(t > 0, 1.3 * t, t)
    q = loop_quality(g, stiff)
    assert q.asymmetry == pytest.approx(0.3 / 1.15, rel=1e-9) and not q.symmetric
    # custom tolerance
    assert loop_quality(g, stiff, asymmetry_tolerance=0.3).symmetric


def test_loop_quality_errors_and_degenerate():
    from grainmech.analysis import loop_quality

    with pytest.raises(ParameterError, match="gamma"):
        loop_quality([0, 0, 0, 0], [1, 2, 3, 4])
    with pytest.raises(ParameterError, match="gamma/tau"):
        loop_quality([0, 1, 0], [0, 1, 0])
    with pytest.raises(ParameterError, match="closure_tolerance"):
        loop_quality([0, 1, 0, -1, 0], [0, 1, 0, -1, 0], closure_tolerance=0)
    q = loop_quality([0, 1, 0, -1, 0], [0, -1, 0, 1, 0])  # stress against the strain
    assert q.tau_a < 0 and not q.ok and q.problems[0].startswith("no positive stress amplitude")
    d = loop_quality([0, 1, 0, -1, 0], [0, 2, 0.5, -2, 0]).as_dict()
    assert d["ok"] and d["stress_closure"] == 0.0 and d["tau_a_Pa"] == 2.0

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

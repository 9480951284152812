"""The driver's law adapter: both backends against Mindlin et al. (1952) at constant N.

Reference: energy dissipated per symmetric cycle of amplitude T* at constant N
(Mindlin, Mason, Osmer & Deresiewicz 1952; Johnson 1985, Sec. 7.3):
W = 9 mu^2 N^2 / (10 G* a) [1 - (1-x)^(5/3) - (5x/6)(1 + (1-x)^(2/3))], x = T*/(mu N).
"""

import numpy as np
import pytest

from grainmech.contact import MindlinDeresiewicz
from grainmech.driver._laws import ContactLaw, IwanLaw, make_law, md_fractions

P = MindlinDeresiewicz(29e9, 0.15, 1e-3, friction=0.5)
N = 1.0


def _mindlin_w(t_star):
    a = np.cbrt(0.75 * N * P.effective_radius / P.effective_modulus)
    x = t_star / (P.friction * N)
    return 9 * P.friction ** 2 * N ** 2 / (10 * P.effective_shear_modulus * a) * (
        1 - (1 - x) ** (5 / 3) - (5 * x / 6) * (1 + (1 - x) ** (2 / 3)))


@pytest.mark.parametrize("law,rtol", [(ContactLaw(P), 1e-3), (IwanLaw(P, 64), 2e-2)])
@pytest.mark.parametrize("frac", [0.3, 0.8])
def test_cycle_dissipation_matches_mindlin(law, rtol, frac):
    a = np.cbrt(0.75 * N * P.effective_radius / P.effective_modulus)
    kt0 = 8 * P.effective_shear_modulus * a
    u_star = 1.5 * P.friction * N / kt0
    n = 400
    u = frac * u_star * np.sin(2 * np.pi * np.arange(1, 2 * n + 1) / n)
    st = law.initial_state(np.array([N]))
    D, T = 0.0, []
    for i, du in enumerate(np.diff(np.concatenate([[0.0], u]))):
        st, r = law.update(st, np.zeros(1), np.array([[du, 0.0, 0.0]]))
        if i >= n:
            D += r.dissipation[0]
            T.append(r.tangential_force[0, 0])
    t_star = 0.5 * (max(T) - min(T))
    assert D == pytest.approx(_mindlin_w(t_star), rel=rtol)


def test_iwan_fractions_sum_to_one_and_backbone_tangent():
    """Strength fractions sum to 1; tangent kt0 (1 - T/muN)^(1/3) at the element breakpoints."""
    kf, sf = md_fractions(16)
    assert kf.sum() == pytest.approx(1.0) and sf.sum() == pytest.approx(1.0)
    uy = sf / kf  # yield displacements in units of mu N / kt0, increasing
    assert np.all(np.diff(uy) > 0)
    for j in range(1, 16):
        T = np.sum(np.minimum(kf * uy[j - 1], sf))  # force (/muN) when element j just yields
        exact = (1 - T) ** (1 / 3)  # seed Eq. 3.11 tangent / kt0 at that force
        assert kf[j:].sum() - 1e-12 <= exact <= kf[j - 1:].sum() + 1e-12


def test_make_law_backends():
    assert isinstance(make_law(P), ContactLaw)
    assert isinstance(make_law(P, backend="iwan"), IwanLaw)
    with pytest.raises(ValueError, match="backend"):
        make_law(P, backend="nope")

"""The contact-law interface the driver uses, both evaluation backends, against Mindlin et
al. (1952) at constant N.

Reference: energy dissipated per symmetric cycle of amplitude T* at constant N
(Mindlin, Mason, Osmer & Deresiewicz 1952; Johnson 1985, Sec. 7.3):
W = 9 mu^2 N^2 / (10 G* a) [1 - (1-x)^(5/3) - (5x/6)(1 + (1-x)^(2/3))], x = T*/(mu N).
"""

import numpy as np
import pytest

from grainmech.contact import ContactLaw, ContactLawProtocol, MindlinDeresiewicz, make_law

P = MindlinDeresiewicz(29e9, 0.15, 1e-3, friction=0.5)
N = 1.0


def _mindlin_w(t_star):
    a = np.cbrt(0.75 * N * P.effective_radius / P.effective_modulus)
    x = t_star / (P.friction * N)
    return 9 * P.friction ** 2 * N ** 2 / (10 * P.effective_shear_modulus * a) * (
        1 - (1 - x) ** (5 / 3) - (5 * x / 6) * (1 + (1 - x) ** (2 / 3)))


@pytest.mark.parametrize("law,rtol", [(ContactLaw(P, "numpy"), 1e-3), (ContactLaw(P, "auto"), 1e-3)])
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


def test_make_law_and_protocol():
    law = make_law(P)
    assert isinstance(law, ContactLaw) and isinstance(law, ContactLawProtocol)
    assert make_law(law) is law
    assert not isinstance(P, ContactLawProtocol)
    with pytest.raises(ValueError, match="backend"):
        make_law(P, backend="nope")
    with pytest.raises(ValueError, match="law"):
        make_law(object())

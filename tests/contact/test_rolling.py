"""Rolling and twisting resistance (grainmech.contact.rolling): the law against its definition.

References: Iwashita & Oda (1998), J. Eng. Mech. 124(3) (rolling spring k_r and limit
moment); Ai et al. (2011), Powder Technol. 206(3) (the elastic-plastic "type C" model); LAMMPS ``pair_style granular`` ``rolling sds`` (moment stiffness
k_roll R*^2, cap mu_roll R* N) and ``twisting sds``.
"""

import math

import numpy as np
import pytest

from grainmech.contact import HertzMindlin, LinearSpring, MindlinDeresiewicz
from grainmech.contact.rolling import (
    RollingConstants,
    RollingResistance,
    rolling_constants,
    rolling_elastic_stiffness,
    rolling_update,
)
from grainmech.errors import GrainmechError, ParameterError

CONSTS = RollingConstants(mu_roll=0.2, k_roll=2.0e5, k_twist=1.5e-3, twist_cap=8e-6, mean_radius=7e-5)


def _frame(C, rng):
    n = rng.normal(size=(C, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    return n


@pytest.mark.parametrize("field,kw", [("rolling_friction", {"friction": -0.1}),
                                      ("rolling_friction", {"friction": math.nan}),
                                      ("rolling_friction", {"friction": "0.1"}),
                                      ("rolling_stiffness", {"friction": 0.1, "stiffness": 0.0}),
                                      ("rolling_stiffness", {"friction": 0.1, "stiffness": math.inf}),
                                      ("twisting_friction", {"friction": 0.1, "twisting_friction": -1.0})])
def test_bad_parameters_name_the_field(field, kw):
    with pytest.raises(ParameterError, match=field):
        RollingResistance(**kw)


def test_zero_coefficients_are_inactive():
    assert not RollingResistance(0.0).active
    assert RollingResistance(0.0, twisting_friction=0.1).active
    assert RollingResistance(0.1).mu_twist == 0.1


def test_default_stiffness_is_mindlin_kt_at_the_mean_contact():
    """k_roll = 8 G* a at the mean force and mean R* (seed Eq. 3.2, 3.11; Iwashita & Oda 1998)."""
    law = MindlinDeresiewicz(29e9, 0.15, 1e-4, friction=0.5)
    N = np.array([0.5, 1.5, 0.0])  # the open contact is left out of the means
    Rs = np.array([4e-5, 6e-5, 1e-3])
    c = rolling_constants(RollingResistance(0.1), law, N, Rs)
    Rbar, Nbar = 5e-5, 1.0
    E_star = 1.0 / ((1 - 0.15) / 29e9)  # two bodies of one material: 1/E* = 2 (1 - nu) / (2 G)
    a = (3 * Nbar * Rbar / (4 * E_star)) ** (1 / 3)  # seed Eq. 3.2
    G_star = 1.0 / (2 * (2 - 0.15) / 29e9)  # seed Eq. 3.12
    assert c.k_roll == pytest.approx(8 * G_star * a, rel=1e-12)
    assert c.k_twist == pytest.approx(c.k_roll * Rbar ** 2, rel=1e-12)
    assert c.twist_cap == pytest.approx(0.1 * Rbar, rel=1e-12)
    given = rolling_constants(RollingResistance(0.1, stiffness=3e5, twisting_friction=0.05), law, N, Rs)
    assert given.k_roll == 3e5 and given.twist_cap == pytest.approx(0.05 * Rbar)
    lin = rolling_constants(RollingResistance(0.1), LinearSpring(1e6, 4e5), N, Rs)
    assert lin.k_roll == 4e5


def test_no_force_carrying_contact_is_an_error():
    law = HertzMindlin(29e9, 0.15, 1e-4, friction=0.5)
    with pytest.raises(GrainmechError, match="rolling_stiffness"):
        rolling_constants(RollingResistance(0.1), law, np.zeros(3), np.full(3, 5e-5))


def test_elastic_moments_and_lammps_coefficients():
    """Below the caps M = k_roll R*^2 omega_perp + k_twist (n . omega) n (LAMMPS rolling/twisting sds)."""
    rng = np.random.default_rng(1)
    C = 50
    n = _frame(C, rng)
    Rs = rng.uniform(4e-5, 9e-5, C)
    N = rng.uniform(0.5, 2.0, C)
    w = 1e-9 * rng.normal(size=(C, 3))
    r = rolling_update(CONSTS, n, Rs, N, np.zeros((C, 3)), w)
    wn = np.einsum("ci,ci->c", w, n)
    expect = CONSTS.k_roll * Rs[:, None] ** 2 * (w - wn[:, None] * n) + CONSTS.k_twist * wn[:, None] * n
    np.testing.assert_allclose(r.moment, expect, rtol=1e-12, atol=0)
    assert not r.rolling.any() and not r.twisting.any()
    np.testing.assert_allclose(np.einsum("cij,cj->ci", rolling_elastic_stiffness(CONSTS, n, Rs), w), expect,
                               rtol=1e-12)
    assert CONSTS.lammps(1e-3, 1e-9) == " rolling sds 200000 0.001 0.2 twisting sds 0.0015 1e-09 8e-06"


def test_caps_hold_and_dissipation_is_non_negative_on_a_closed_cycle():
    """|M_r| <= mu_r R* N and |M_t| <= c_twist N at every increment; a closed rotation cycle dissipates >= 0."""
    rng = np.random.default_rng(2)
    C = 40
    n = _frame(C, rng)
    Rs = rng.uniform(4e-5, 9e-5, C)
    N = rng.uniform(0.5, 2.0, C)
    amp = 0.1 * rng.normal(size=(C, 3))
    m = np.zeros((C, 3))
    diss = np.zeros(C)
    path = np.concatenate([np.linspace(0, 1, 20), np.linspace(1, -1, 40)[1:], np.linspace(-1, 0, 20)[1:]])
    for k in range(1, path.size):
        r = rolling_update(CONSTS, n, Rs, N, m, (path[k] - path[k - 1]) * amp)
        m = r.moment
        diss += r.dissipated
        mt = np.einsum("ci,ci->c", m, n)
        mr = np.linalg.norm(m - mt[:, None] * n, axis=1)
        assert np.all(mr <= CONSTS.mu_roll * Rs * N * (1 + 1e-12))
        assert np.all(np.abs(mt) <= CONSTS.twist_cap * N * (1 + 1e-12))
    assert np.all(diss >= 0.0) and np.any(diss > 0.0)


def test_consistent_tangent_matches_finite_differences():
    """dM/d omega and dM/dN of the radial return, elastic and on the caps, against central differences."""
    rng = np.random.default_rng(3)
    C = 30
    n = _frame(C, rng)
    Rs = rng.uniform(4e-5, 9e-5, C)
    N = rng.uniform(0.5, 2.0, C)
    m0 = np.zeros((C, 3))
    w = np.where(np.arange(C)[:, None] % 2 == 0, 1e-5, 0.1) * rng.normal(size=(C, 3))  # half elastic, half capped
    r = rolling_update(CONSTS, n, Rs, N, m0, w)
    assert r.rolling.any() and (~r.rolling).any()
    h = 1e-7 * np.abs(w).max(axis=1)[:, None]
    for j in range(3):
        e = np.zeros((C, 3))
        e[:, j] = 1.0
        fd = (rolling_update(CONSTS, n, Rs, N, m0, w + h * e).moment
              - rolling_update(CONSTS, n, Rs, N, m0, w - h * e).moment) / (2 * h)
        np.testing.assert_allclose(r.tangent[:, :, j], fd, rtol=1e-5, atol=1e-6 * np.abs(r.tangent).max())
    dN = 1e-6 * N
    fdN = (rolling_update(CONSTS, n, Rs, N + dN, m0, w).moment
           - rolling_update(CONSTS, n, Rs, N - dN, m0, w).moment) / (2 * dN[:, None])
    np.testing.assert_allclose(r.dmoment_dnormal, fdN, rtol=1e-5, atol=1e-9 * np.abs(fdN).max())


def test_open_contacts_carry_no_moment_and_vectorised_equals_one_by_one():
    rng = np.random.default_rng(4)
    C = 12
    n = _frame(C, rng)
    Rs = rng.uniform(4e-5, 9e-5, C)
    N = np.where(np.arange(C) < 3, 0.0, rng.uniform(0.5, 2.0, C))
    m0 = 1e-7 * rng.normal(size=(C, 3))
    w = 1e-5 * rng.normal(size=(C, 3))
    r = rolling_update(CONSTS, n, Rs, N, m0, w)
    assert np.all(r.moment[:3] == 0.0) and np.all(r.tangent[:3] == 0.0)
    for c in range(C):
        one = rolling_update(CONSTS, n[c:c + 1], Rs[c:c + 1], N[c:c + 1], m0[c:c + 1], w[c:c + 1])
        np.testing.assert_array_equal(one.moment[0], r.moment[c])
        np.testing.assert_array_equal(one.tangent[0], r.tangent[c])


def test_moment_energy_is_the_springs_energy():
    """|M_r|^2 / (2 k_roll R*^2) + M_t^2 / (2 k_twist): the work of loading the springs elastically from zero."""
    from grainmech.contact.rolling import moment_energy

    rng = np.random.default_rng(5)
    C = 20
    n = _frame(C, rng)
    Rs = rng.uniform(4e-5, 9e-5, C)
    N = np.full(C, 2.0)
    w = 1e-6 * rng.normal(size=(C, 3))  # well below the caps
    steps = 200
    m = np.zeros((C, 3))
    work = np.zeros(C)
    for _ in range(steps):
        r = rolling_update(CONSTS, n, Rs, N, m, w / steps)
        work += np.einsum("ci,ci->c", 0.5 * (m + r.moment), w / steps)
        m = r.moment
    np.testing.assert_allclose(moment_energy(CONSTS, m, n, Rs), work, rtol=1e-10)

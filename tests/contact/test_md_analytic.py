"""Mindlin–Deresiewicz law at constant normal force against the analytic solution.

References: Mindlin (1949), Mindlin & Deresiewicz (1953), Johnson (1985, Sec. 7.2-7.3).
With 1/G* = (2-nu1)/G1 + (2-nu2)/G2 (seed Eq. 3.12) and a from Hertz (seed Eq. 3.2):

* loading   delta_L(T) = 3 mu N/(16 G* a) [1 - (1 - T/(mu N))^(2/3)]
* unloading delta_U(T) = delta_L(T*) - 2 delta_L((T* - T)/2)        (Masing)
* reloading delta_R(T) = -delta_U(-T)
* per cycle W = 9 mu^2 N^2/(10 G* a) [1 - (1-x)^(5/3) - (5x/6)(1 + (1-x)^(2/3))], x = T*/(mu N)
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from grainmech.contact import (
    MindlinDeresiewicz,
    hertz_contact_radius_from_force,
    md_dissipation_per_cycle,
    md_loading_displacement,
    md_loading_force,
    md_unloading_displacement,
    md_unloading_force,
    reversal_forces,
    solve_step,
    state_from_normal_force,
    update,
)
from grainmech.contact.analytic import md_reloading_displacement

P = MindlinDeresiewicz(30e9, 0.25, 1e-3, 2e-3, 70e9, 0.2, friction=0.45)
N = 12.0
MU = 0.45


def test_energy_per_cycle_formula_from_the_masing_loop_symbolically():
    """Integrate delta_U - delta_R over [-T*, T*] with sympy and compare with the closed form."""
    T, Ts, mu, n, G, a, x = sp.symbols("T T_s mu N G a x", positive=True)
    C = 3 * mu * n / (16 * G * a)

    def dL(t):
        return C * (1 - (1 - t / (mu * n)) ** sp.Rational(2, 3))

    dU = dL(Ts) - 2 * dL((Ts - T) / 2)
    dR = -dL(Ts) + 2 * dL((Ts + T) / 2)
    W = sp.integrate(sp.simplify(dU - dR), (T, -Ts, Ts))
    Wx = sp.simplify((W * G * a / (mu**2 * n**2)).subs(Ts, x * mu * n))
    closed = sp.Rational(9, 10) * (1 - (1 - x) ** sp.Rational(5, 3)
                                   - sp.Rational(5, 6) * x * (1 + (1 - x) ** sp.Rational(2, 3)))
    for xv in (0.05, 0.3, 0.7, 0.95, 1.0):
        assert float(Wx.subs(x, xv)) == pytest.approx(float(closed.subs(x, xv)), rel=1e-12)
    # small amplitudes: W ~ T*^3/(36 mu N G* a)  (Mindlin et al. 1952)
    assert sp.limit(Wx / x**3, x, 0) == sp.Rational(1, 36)
    # and the library function agrees
    a_val = float(hertz_contact_radius_from_force(N, P))
    Gs = P.effective_shear_modulus
    for xv in (0.05, 0.5, 0.99):
        ref = float(closed.subs(x, xv)) * MU**2 * N**2 / (Gs * a_val)
        assert float(md_dissipation_per_cycle(xv * MU * N, N, P)) == pytest.approx(ref, rel=1e-12)


def test_analytic_helpers_are_inverse_of_each_other():
    T = np.linspace(-0.99, 0.99, 9) * MU * N
    d = md_loading_displacement(T, N, P)
    np.testing.assert_allclose(md_loading_force(d, N, P), T, rtol=1e-12, atol=1e-12)
    Ts = 0.8 * MU * N
    du = md_unloading_displacement(T * 0.8, Ts, N, P)
    np.testing.assert_allclose(md_unloading_force(du, Ts, N, P), T * 0.8, rtol=1e-11, atol=1e-12)


def _force_cycle(x_amp: float, nq: int):
    """Force-controlled loading 0 -> T*, unloading T* -> -T*, reloading -T* -> T*; nq steps per quarter."""
    Ts = x_amp * MU * N
    st = state_from_normal_force(P, [N], dim=1)
    targets = np.concatenate([np.linspace(0, Ts, nq + 1)[1:], np.linspace(Ts, -Ts, 2 * nq + 1)[1:],
                              np.linspace(-Ts, Ts, 2 * nq + 1)[1:]])
    d, T, W = [0.0], [0.0], [0.0]
    for tt in targets:
        st, r, _, dt = solve_step(P, st, normal_force=[N], tangential_force=[tt])
        d.append(d[-1] + dt[0, 0])
        T.append(r.tangential_force[0, 0])
        W.append(st.dissipated_energy[0])
    return Ts, np.array(d), np.array(T), np.array(W), st


@pytest.mark.parametrize("x_amp", [0.1, 0.5, 0.8, 0.99])
def test_force_cycle_matches_mindlin_deresiewicz_curves(x_amp):
    nq = 8
    Ts, d, T, W, st = _force_cycle(x_amp, nq)
    scale = d.max()
    np.testing.assert_allclose(d[: nq + 1], md_loading_displacement(T[: nq + 1], N, P), rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(d[nq: 3 * nq + 1], md_unloading_displacement(T[nq: 3 * nq + 1], Ts, N, P),
                               rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(d[3 * nq:], md_reloading_displacement(T[3 * nq:], Ts, N, P), rtol=0,
                               atol=1e-9 * scale)
    # the loop closes: back at (delta*, T*) with the memory wiped (Masing)
    assert d[-1] == pytest.approx(d[nq], rel=1e-9)
    # loading on past T* wipes the loop from memory and follows the virgin curve again
    if x_amp < 0.9:
        T_more = 1.1 * Ts
        st_more, _, _, dt = solve_step(P, st, normal_force=[N], tangential_force=[T_more])
        assert st_more.depth[0] == 0
        assert d[-1] + dt[0, 0] == pytest.approx(float(md_loading_displacement(T_more, N, P)), rel=1e-9)
    # dissipation booked by the law over the closed cycle = analytic loop area
    Wa = float(md_dissipation_per_cycle(Ts, N, P))
    assert W[-1] - W[nq] == pytest.approx(Wa, rel=1e-8)


def test_loop_area_within_half_percent_and_converges_with_steps():
    """Loop area of the sampled loop (trapezoid) -> analytic W, second order in the step."""
    x_amp = 0.8
    errs = []
    for nq in (10, 20, 40):
        Ts, d, T, W, _ = _force_cycle(x_amp, nq)
        dl, Tl = d[nq:], T[nq:]
        area = np.sum(0.5 * (Tl[1:] + Tl[:-1]) * np.diff(dl))
        Wa = float(md_dissipation_per_cycle(Ts, N, P))
        errs.append(abs(area - Wa) / Wa)
    assert errs[0] < 5e-3                     # 0.5 % at 10 steps per quarter cycle
    assert errs[1] < errs[0] / 3 and errs[2] < errs[1] / 3   # O(h^2)


def test_displacement_controlled_unloading_matches_analytic_force():
    Ts = 0.7 * MU * N
    dstar = float(md_loading_displacement(Ts, N, P))
    st = state_from_normal_force(P, [N], dim=1)
    st, _ = update(P, st, [0.0], [[dstar]])           # one step: exact at constant N
    assert st.tangential_force[0, 0] == pytest.approx(Ts, rel=1e-12)
    ds = np.linspace(dstar, -dstar, 7)
    for dprev, dnext in zip(ds[:-1], ds[1:]):
        st, r = update(P, st, [0.0], [[dnext - dprev]])
        assert r.tangential_force[0, 0] == pytest.approx(float(md_unloading_force(dnext, Ts, N, P)),
                                                         rel=1e-10, abs=1e-12 * Ts)
    # remembered reversal T* (the seed's Fig. 3.1) after reloading a little
    st, _ = update(P, st, [0.0], [[0.1 * dstar]])
    rf = reversal_forces(P, st)[0]
    assert st.depth[0] == 1
    assert rf[0] == pytest.approx(-Ts, rel=1e-10)   # T** = -T*: the start of the reloading branch


def test_tangent_stiffness_is_eq_3_11_with_eq_3_13_to_3_15():
    Ts = 0.6 * MU * N
    a = float(hertz_contact_radius_from_force(N, P))
    k0 = 8 * P.effective_shear_modulus * a
    st = state_from_normal_force(P, [N], dim=1)
    st, r = solve_step(P, st, normal_force=[N], tangential_force=[Ts])[:2]
    assert r.ks[0] == pytest.approx(k0 * (1 - Ts / (MU * N)) ** (1 / 3), rel=1e-9)      # Eq. 3.13
    st, r = solve_step(P, st, normal_force=[N], tangential_force=[0.1 * Ts])[:2]
    assert r.ks[0] == pytest.approx(k0 * (1 - (Ts - 0.1 * Ts) / (2 * MU * N)) ** (1 / 3), rel=1e-9)  # 3.14
    st, r = solve_step(P, st, normal_force=[N], tangential_force=[0.5 * Ts])[:2]
    assert r.ks[0] == pytest.approx(k0 * (1 - (0.5 * Ts - 0.1 * Ts) / (2 * MU * N)) ** (1 / 3), rel=1e-9)


def test_nested_inner_loop_closes_and_rejoins_outer_branch():
    """Masing's memory rule: an inner loop closes on its start and the outer branch resumes."""
    st = state_from_normal_force(P, [N], dim=1)
    T1, T2, T3 = 0.7 * MU * N, -0.2 * MU * N, 0.3 * MU * N
    for target in (T1, T2, T3):
        st = solve_step(P, st, normal_force=[N], tangential_force=[target])[0]
    assert st.depth[0] == 2
    # unload to 0.0 (inside the inner loop), then back to T3: returns to the same displacement
    st_a = st
    st_b, _, _, dt1 = solve_step(P, st_a, normal_force=[N], tangential_force=[0.0])
    st_c, _, _, dt2 = solve_step(P, st_b, normal_force=[N], tangential_force=[T3])
    assert dt1[0, 0] + dt2[0, 0] == pytest.approx(0.0, abs=1e-9 * abs(dt1[0, 0]))
    # reload past T1: the virgin curve continues exactly as if the excursion had not happened
    st_d, r, _, dt3 = solve_step(P, st_c, normal_force=[N], tangential_force=[0.9 * MU * N])
    assert st_d.depth[0] == 0
    ref = state_from_normal_force(P, [N], dim=1)
    ref, _, _, dref = solve_step(P, ref, normal_force=[N], tangential_force=[0.9 * MU * N])
    delta_total = float(md_loading_displacement(0.9 * MU * N, N, P))
    assert dref[0, 0] == pytest.approx(delta_total, rel=1e-9)
    # total displacement of the detour path equals the direct one
    assert r.tangential_force[0, 0] == pytest.approx(0.9 * MU * N, rel=1e-10)


def test_gross_sliding_dissipates_mu_n_per_unit_slip_and_partition_matches_mdr():
    """Energy at the onset of sliding: work = stored + dissipated.

    In the method of dimensionality reduction (Popov & Hess 2015) every spring is at its
    limit L(x) = mu E* (d - x^2/R) at the onset of sliding, so the stored energy is
    sum L^2/(2 k) = 0.6 mu^2 N^2 / kt0 (kt0 = 8 G* a), computed here by quadrature; the
    work is 0.9 mu^2 N^2 / kt0, so 0.3 mu^2 N^2 / kt0 has been dissipated.
    """
    st = state_from_normal_force(P, [N], dim=1)
    a = float(hertz_contact_radius_from_force(N, P))
    Gs, E, R = P.effective_shear_modulus, P.effective_modulus, P.effective_radius
    k0 = 8 * Gs * a
    ds = 3 * MU * N / (16 * Gs * a)      # displacement at which sliding starts
    st, r = update(P, st, [0.0], [[ds]])
    assert r.tangential_force[0, 0] == pytest.approx(MU * N, rel=1e-12)
    assert bool(r.sliding[0]) and r.ks[0] == 0.0
    dd = np.linspace(0, ds, 200001)
    Tq = md_loading_force(dd, N, P)
    work = np.sum(0.5 * (Tq[1:] + Tq[:-1]) * np.diff(dd))
    assert work == pytest.approx(0.9 * MU**2 * N**2 / k0, rel=1e-6)
    x = np.linspace(0, a, 200001)
    L = MU * E * (a * a / R - x * x / R)          # MDR spring limits per unit length, d = a^2/R
    stored = 2 * np.sum(0.5 * (L[1:] ** 2 + L[:-1] ** 2) * np.diff(x)) / (2 * 4 * Gs)
    assert stored == pytest.approx(0.6 * MU**2 * N**2 / k0, rel=1e-6)
    assert st.dissipated_energy[0] == pytest.approx(work - stored, rel=1e-5)
    # further sliding dissipates mu N per unit slip
    W0 = st.dissipated_energy[0]
    st2, r2 = update(P, st, [0.0], [[5 * ds]])
    assert st2.dissipated_energy[0] - W0 == pytest.approx(MU * N * 5 * ds, rel=1e-12)
    assert r2.tangential_force[0, 0] == pytest.approx(MU * N, rel=1e-12)

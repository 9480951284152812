"""Linear, Hertz–Mindlin (no slip + Coulomb), rod (seed Eq. 3.8/3.17) and frictionless laws;
opening/closing; the force-controlled solver; memory bookkeeping."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from grainmech.contact import (
    Cylinder,
    Hertz,
    HertzMindlin,
    LinearSpring,
    MindlinDeresiewicz,
    cylinder_normal_stiffness,
    cylinder_tangential_stiffness,
    hertz_approach_from_force,
    hertz_contact_radius,
    reversal_forces,
    solve_step,
    state_from_approach,
    state_from_normal_force,
    update,
)
from grainmech.contact.forms import frictional, normal_law
from grainmech.errors import GrainmechError


def test_linear_spring_elastic_then_coulomb_sliding():
    p = LinearSpring(kn=2e6, ks=1e6, friction=0.5)
    st = state_from_approach(p, [1e-5], dim=3)          # N = 20, mu N = 10
    d = np.array([[3e-6, 4e-6, 0.0]])                    # |d| = 5e-6 -> trial |T| = 5
    st, r = update(p, st, [0.0], d)
    np.testing.assert_allclose(r.tangential_force, 1e6 * d)
    assert r.dissipation[0] == 0.0 and not r.sliding[0]
    st, r = update(p, st, [0.0], 2 * d)                  # trial |T| = 15 > 10: slip 5e-6
    np.testing.assert_allclose(r.tangential_force, 10.0 * d / 5e-6, rtol=1e-14)
    assert r.dissipation[0] == pytest.approx(10.0 * 5e-6, rel=1e-12)
    assert r.sliding[0] and r.ks[0] == 0.0 and r.ks_perp[0] == 1e6


def test_linear_spring_without_friction_never_slides():
    p = LinearSpring(kn=2e6, ks=1e6)
    st = state_from_approach(p, [1e-5], dim=2)
    st, r = update(p, st, [0.0], np.array([[1.0, 0.0]]))
    assert r.tangential_force[0, 0] == pytest.approx(1e6)
    assert not r.sliding[0]


def test_closing_step_uses_only_the_part_in_contact():
    p = LinearSpring(kn=2e6, ks=1e6)
    st = state_from_approach(p, [-1e-6], dim=1)          # a gap of 1 um
    st, r = update(p, st, [3e-6], [[3e-6]])              # in contact for 2/3 of the step
    assert r.normal_force[0] == pytest.approx(2e6 * 2e-6)
    assert r.tangential_force[0, 0] == pytest.approx(1e6 * 2e-6)


def _cycle_work(p, a0, path):
    st = state_from_approach(p, [a0], dim=1)
    work = 0.0
    for da, dd in path:
        T_old = st.tangential_force[0, 0]
        st, r = update(p, st, [da], [[dd]])
        work += 0.5 * (T_old + r.tangential_force[0, 0]) * dd
    return st, work


def test_hertz_mindlin_closed_cycles_create_no_energy():
    """Walton (1987)'s rough spheres, dT = 8 G* a d delta, on closed rectangles in
    (alpha, delta). The plain incremental law creates energy (work (k0 - k1) d^2/2 < 0) on
    the cycle alpha up -> delta up -> alpha down -> delta down (the path dependence
    discussed by Elata & Berryman 1996); with the rescaling of T by a_new/a_old when the
    area shrinks (Thornton, Cummins & Cleary 2013, Eq. 18b) that cycle ends with T = 0 and
    its work, (k1 - k0) d^2/2 >= 0, is exactly the dissipation booked. The opposite
    orientation also has non-negative work."""
    p = HertzMindlin(29e9, 0.2, 1e-3)                     # mu = inf: never slides
    a0, a1, dmax, n = 1e-6, 4e-6, 2e-6, 200
    k0 = 8 * p.effective_shear_modulus * float(hertz_contact_radius(a0, p))
    k1 = 8 * p.effective_shear_modulus * float(hertz_contact_radius(a1, p))
    up, down = ((a1 - a0) / n, 0.0), (-(a1 - a0) / n, 0.0)
    right, left = (0.0, dmax / n), (0.0, -dmax / n)
    st, work = _cycle_work(p, a0, [up] * n + [right] * n + [down] * n + [left] * n)
    assert work == pytest.approx((k1 - k0) * dmax**2 / 2, rel=1e-9)
    assert st.tangential_force[0, 0] == pytest.approx(0.0, abs=1e-12 * k1 * dmax)
    assert st.dissipated_energy[0] == pytest.approx(work, rel=1e-9)
    # the other orientation: T = k0 d -> kept while alpha rises -> (k0 - k1) d -> rescaled
    st, work = _cycle_work(p, a0, [right] * n + [up] * n + [left] * n + [down] * n)
    assert work == pytest.approx((k1 - k0) * dmax**2 / 2, rel=1e-9)
    assert st.tangential_force[0, 0] == pytest.approx((k0 - k1) * dmax * k0 / k1, rel=1e-9)


def test_bare_hertz_is_frictionless():
    p = Hertz(29e9, 0.2, 1e-3)
    st = state_from_normal_force(p, [5.0], dim=3)
    st, r = update(p, st, [1e-7], np.array([[1e-6, 0.0, 0.0]]))
    assert np.all(r.tangential_force == 0.0) and r.ks[0] == 0.0
    assert r.normal_force[0] > 5.0


ROD = Cylinder(shear_modulus_equiv=1.034e8, poisson=0.1, radius=3.175e-3, psi=2.5,
               friction_angle=math.radians(15))


def test_rod_first_loading_follows_eq_3_17_exactly():
    """dT/d delta = (Kn/Psi)(1 - T/(mu N))^(1/2) integrates to
    T = mu N [1 - (1 - Kn delta/(2 Psi mu N))^2]."""
    N = 3500.0
    st = state_from_normal_force(ROD, [N], dim=1)
    kn = float(cylinder_normal_stiffness(N, ROD))
    mu = ROD.friction
    dslide = 2 * ROD.psi * mu * N / kn
    for frac in (0.1, 0.3, 0.6, 0.9):
        s1, r = update(ROD, st, [0.0], [[frac * dslide]])
        T_exact = mu * N * (1 - (1 - frac) ** 2)
        assert r.tangential_force[0, 0] == pytest.approx(T_exact, rel=1e-12)
        assert r.ks[0] == pytest.approx(float(cylinder_tangential_stiffness(N, T_exact, ROD)), rel=1e-9)


def test_rod_cycle_energy_matches_masing_loop_with_exponent_one_half():
    """Loop area of the Masing cycle built on the rod loading curve (sympy), vs the law."""
    N = 3500.0
    kn = float(cylinder_normal_stiffness(N, ROD))
    mu = ROD.friction
    Ts = 0.7 * mu * N
    Tsym, Tss = sp.symbols("T Ts", real=True)
    C = 2 * ROD.psi * mu * N / kn

    def dL(t):
        return C * (1 - sp.sqrt(1 - t / (mu * N)))

    dU = dL(Tss) - 2 * dL((Tss - Tsym) / 2)
    dR = -dL(Tss) + 2 * dL((Tss + Tsym) / 2)
    W = float(sp.Integral((dU - dR).subs(Tss, Ts), (Tsym, -Ts, Ts)).evalf(30))
    st = state_from_normal_force(ROD, [N], dim=1)
    for target in (Ts, -Ts):
        st = solve_step(ROD, st, normal_force=[N], tangential_force=[target])[0]
    W0 = st.dissipated_energy[0]
    st = solve_step(ROD, st, normal_force=[N], tangential_force=[Ts])[0]
    st = solve_step(ROD, st, normal_force=[N], tangential_force=[-Ts])[0]
    assert st.dissipated_energy[0] - W0 == pytest.approx(W, rel=1e-9)


def test_rod_normal_law_integrates_eq_3_8():
    st = state_from_normal_force(ROD, [100.0], dim=2)
    h = 1e-5 * st.approach[0]
    _, rp = update(ROD, st, [h], np.zeros((1, 2)))
    _, rm = update(ROD, st, [-h], np.zeros((1, 2)))
    # central difference of the normal law = the seed's Eq. 3.8 (used as the tangent)
    assert (rp.normal_force[0] - rm.normal_force[0]) / (2 * h) == pytest.approx(
        float(cylinder_normal_stiffness(100.0, ROD)), rel=1e-8)
    assert rp.kn[0] == pytest.approx(float(cylinder_normal_stiffness(rp.normal_force[0], ROD)), rel=1e-14)


def test_opening_mid_cycle_releases_force_and_memory_and_dissipates_the_rest():
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5)
    N0 = 10.0
    st = state_from_normal_force(p, [N0], dim=3)
    for d in (1e-6, -0.6e-6, 0.3e-6):
        st, _ = update(p, st, [0.0], np.array([[d, 0.0, 0.0]]))
    assert st.depth[0] == 2
    W = st.dissipated_energy[0]
    st2, r = update(p, st, [-2 * st.approach[0]], np.array([[0.2e-6, 0.0, 0.0]]))
    assert r.open[0] and st2.depth[0] == 0 and np.all(st2.tangential_force == 0.0)
    assert st2.dissipated_energy[0] > W
    # closing again starts a virgin contact
    st3, r3 = update(p, st2, [3 * st.approach[0]], np.zeros((1, 3)))
    assert not r3.open[0] and np.all(r3.tangential_force == 0.0)
    assert r3.ks[0] == pytest.approx(r3.ks_perp[0])


def test_opening_from_sliding_dissipates_the_sliding_work_exactly():
    """At sliding T = mu N; unloading N to zero at fixed delta slides the whole way:
    D = int mu^2 N / kt0 dN = (3/5) mu^2 N0^2 / kt0(N0) for Hertz (kt0 ~ N^(1/3))."""
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5)
    N0 = 10.0
    st = state_from_normal_force(p, [N0], dim=1)
    st, _ = update(p, st, [0.0], [[1e-5]])
    W = st.dissipated_energy[0]
    k0 = p.stiffness(np.array([N0]))[1][0]
    st2, r = update(p, st, [-2 * st.approach[0]], [[0.0]])
    assert st2.dissipated_energy[0] - W == pytest.approx(0.6 * 0.25 * N0**2 / k0, rel=1e-12)


def test_normal_rotation_keeps_force_magnitude_in_the_new_tangent_plane():
    p = HertzMindlin(29e9, 0.2, 1e-3, friction=0.5)
    st = state_from_normal_force(p, [10.0], dim=3)
    st, r = update(p, st, [0.0], np.array([[1e-7, 0.0, 0.0]]))
    T0 = np.linalg.norm(r.tangential_force)
    n_new = np.array([[0.1, 0.0, 1.0]])
    st2, r2 = update(p, st, [0.0], np.zeros((1, 3)), normals=n_new)
    assert np.linalg.norm(r2.tangential_force) == pytest.approx(T0, rel=1e-14)
    assert abs(r2.tangential_force[0] @ n_new[0]) < 1e-14 * T0


def test_solve_step_hits_targets_and_rejects_impossible_ones():
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5)
    st = state_from_normal_force(p, [10.0, 4.0], dim=3)
    st2, r, dn, dt = solve_step(p, st, normal_force=[12.0, 4.0], tangential_force=[3.0, -1.5],
                                direction=[0.0, 1.0, 0.0])
    np.testing.assert_allclose(r.normal_force, [12.0, 4.0], rtol=1e-12)
    np.testing.assert_allclose(r.tangential_force[:, 1], [3.0, -1.5], rtol=1e-9)
    assert np.all(dt[:, [0, 2]] == 0.0)
    np.testing.assert_allclose(dn, hertz_approach_from_force(np.array([12.0, 4.0]), p) - st.approach)
    with pytest.raises(GrainmechError, match="friction limit"):
        solve_step(p, st, normal_force=[10.0, 4.0], tangential_force=[5.1, 0.0])
    # exactly at the limit is reachable (onset of sliding)
    st3, r3, _, _ = solve_step(p, st, normal_force=[10.0, 4.0], tangential_force=[5.0, 2.0])
    assert r3.sliding[0] and r3.tangential_force[0, 0] == pytest.approx(5.0, rel=1e-9)


def test_reversal_forces_are_the_seeds_t_star_and_t_double_star():
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5)
    st = state_from_normal_force(p, [10.0], dim=1)
    st = solve_step(p, st, normal_force=[10.0], tangential_force=[3.0])[0]     # load to T*
    st = solve_step(p, st, normal_force=[10.0], tangential_force=[-1.0])[0]    # unload to T**
    st = solve_step(p, st, normal_force=[10.0], tangential_force=[0.5])[0]     # reload
    rf = reversal_forces(p, st)[0]
    np.testing.assert_allclose(rf[:2], [3.0, -1.0], rtol=1e-9)
    assert np.all(np.isnan(rf[2:]))
    # a change of N moves them by -+ mu dN (Thornton & Randall 1988): T* up, T** down
    st2 = solve_step(p, st, normal_force=[11.0], d_tangential=np.zeros((1, 1)))[0]
    np.testing.assert_allclose(reversal_forces(p, st2)[0, :2], [3.0 + 0.5, -1.0 - 0.5], rtol=1e-9)


def test_state_must_match_params():
    p8 = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5, max_reversals=8)
    p16 = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5, max_reversals=16)
    st = state_from_normal_force(p8, [1.0])
    with pytest.raises(ValueError, match="max_reversals"):
        update(p16, st, [0.0], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="d_tangential"):
        update(p8, st, [0.0], np.zeros((1, 2)))
    with pytest.raises(ValueError, match="d_normal"):
        update(p8, st, [np.nan], np.zeros((1, 3)))


def test_state_from_forces_places_contacts_on_the_virgin_curve():
    """From T on the virgin curve, further loading continues the Mindlin curve."""
    from grainmech.contact import md_loading_displacement, state_from_forces

    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5)
    st = state_from_forces(p, [10.0], np.array([[0.0, 2.0, 0.0]]))
    assert st.axis[0, 1] == 1.0 and st.depth[0] == 0
    st2, r, _, dt = solve_step(p, st, normal_force=[10.0], tangential_force=[4.0], direction=[0, 1, 0])
    expected = float(md_loading_displacement(4.0, 10.0, p) - md_loading_displacement(2.0, 10.0, p))
    assert dt[0, 1] == pytest.approx(expected, rel=1e-9)
    with pytest.raises(ValueError, match="tangential_force"):
        state_from_forces(p, [10.0], np.array([[0.0, 5.5, 0.0]]))


def test_frictional_and_normal_law_predicates_of_forms():
    """contact.forms.frictional / normal_law: the only dispatch the packing driver uses."""
    G, nu, R = 29e9, 0.15, 1e-3
    assert frictional(MindlinDeresiewicz(G, nu, R, friction=0.5))
    assert not frictional(MindlinDeresiewicz(G, nu, R, friction=0.0))
    assert frictional(HertzMindlin(G, nu, R))  # default friction inf: infinitely rough
    assert not frictional(HertzMindlin(G, nu, R, friction=0.0))
    assert not frictional(Hertz(G, nu, R))
    assert frictional(LinearSpring(1e6, 5e5, 0.3))
    assert not frictional(LinearSpring(1e6, 0.0, 0.3))  # no tangential spring
    assert not frictional(LinearSpring(1e6, 5e5, 0.0))
    assert not frictional(object())
    assert [normal_law(p) for p in (Hertz(G, nu, R), LinearSpring(1e6, 0.0), object())] == ["hertz", "linear", None]


def test_law_dispatch_lives_in_contact_forms_only():
    """Issue 30: no ``isinstance`` test on a law parameter class outside ``contact/forms.py``."""
    src = Path(__file__).resolve().parents[2] / "src" / "grainmech"
    law = re.compile(r"isinstance\([^)]*\b(Hertz|HertzMindlin|MindlinDeresiewicz|LinearSpring|Cylinder)\b")
    hits = [f"{p.relative_to(src)}:{i}" for p in sorted(src.rglob("*.py")) if p.name != "forms.py"
            for i, line in enumerate(p.read_text().splitlines(), 1) if law.search(line)]
    assert hits == []

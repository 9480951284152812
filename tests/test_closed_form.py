"""Closed forms (seed Eq. 4.21-4.33, 4.37-4.42, 4.43-4.45) against quadrature of Eq. 2.41, and Walton/Digby."""

import numpy as np
import pytest
from scipy.integrate import lebedev_rule

from _hyp import given, settings, st
from grainmech import closed_form as cf
from grainmech.assembly import ContactSet, stiffness
from grainmech.conventions import seed_angles, seed_normal_2d
from grainmech.errors import GrainmechError


def _seed_density_3d(n, a20, a22, b22):
    """Seed Eq. 4.15 evaluated from the seed's angles (independent of grainmech.fabric)."""
    g, b = seed_angles(n)
    return (1 + 0.25 * a20 * (3 * np.cos(2 * g) + 1)
            + 3 * np.sin(g) ** 2 * (a22 * np.cos(2 * b) + b22 * np.sin(2 * b))) / (4 * np.pi)


def _quadrature_3d(a20, a22, b22, kn, ks, scale):
    x, w = lebedev_rule(11)  # exact to degree 11 >= 2 (density) + 4 (integrand)
    n = x.T
    wt = w * _seed_density_3d(n, a20, a22, b22)
    return stiffness(ContactSet(n, n, scale * wt, kn, ks), backend="numpy")


def _quadrature_2d(a2, b2, a4, b4, kn, ks, scale, k=64):
    t = 2 * np.pi * np.arange(k) / k
    xi = (1 + a2 * np.cos(2 * t) + b2 * np.sin(2 * t) + a4 * np.cos(4 * t) + b4 * np.sin(4 * t)) / (2 * np.pi)
    n = seed_normal_2d(t)
    return stiffness(ContactSet(n, n, scale * xi * 2 * np.pi / k, kn, ks), backend="numpy")


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.5, 0.5), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1),
       st.floats(0.1, 10), st.floats(0, 10), st.floats(0.1, 100))
def test_spheres_second_order_matches_quadrature(a20, a22, b22, kn, ks, scale):
    """Seed Eq. 4.21-4.33 vs Lebedev quadrature of Eq. 2.41/4.19 (to 1e-10 relative)."""
    ref = _quadrature_3d(a20, a22, b22, kn, ks, scale)
    got = cf.spheres_second_order(a20, a22, b22, kn, ks, scale)
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


def test_spheres_second_order_seed_order_entries():
    """Spot values in the seed's order (zz, yy, xx, zy, zx, xy), Eq. 4.21, 4.26, 4.31, 4.33."""
    a20, a22, b22, kn, ks = 0.2, 0.25, 0.1, 3.0, 1.0
    C = cf.spheres_second_order(a20, a22, b22, kn, ks, 15.0, order="seed")
    assert C[0, 0] == pytest.approx((3 * kn + 2 * ks) + 2 * a20 / 7 * (6 * kn + ks))
    assert C[1, 2] == pytest.approx((kn - ks) * (1 - 2 * a20 / 7))
    assert C[1, 5] == pytest.approx(0.5 * 12 * b22 / 7 * (3 * kn + 0.5 * ks))
    assert C[3, 4] == pytest.approx(0.5 * 12 * b22 / 7 * (kn + 0.75 * ks))
    assert C[0, 3] == 0 and C[4, 5] == 0


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.4, 0.4), st.floats(-0.4, 0.4), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1),
       st.floats(0.1, 10), st.floats(0, 10), st.floats(0.1, 100))
def test_discs_fourth_order_matches_quadrature(a2, b2, a4, b4, kn, ks, scale):
    """Corrected seed Eq. 4.37-4.42 vs uniform-node quadrature on the circle."""
    ref = _quadrature_2d(a2, b2, a4, b4, kn, ks, scale)
    got = cf.discs_fourth_order(a2, b2, a4, b4, kn, ks, scale)
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


def test_discs_printed_eq_4_37_to_4_40_are_the_physical_convention_and_4_41_4_42_are_wrong():
    """Seed Eq. 4.37-4.42 with prefactor m/(8 pi (1+e)) vs our corrected forms (errata E-4.41, E-4.42)."""
    m, e, kn, ks = 4.0, 0.2, 3.0, 1.0
    a2, b2, a4, b4 = 0.3, 0.2, 0.1, 0.05
    nv, ell = cf.packing_scale(e, m, 0.01, dim=2, convention="physical")
    C = cf.discs_fourth_order(a2, b2, a4, b4, kn, ks, nv * ell**2, order="seed")
    p8, p16 = m / (8 * np.pi * (1 + e)), m / (16 * np.pi * (1 + e))
    assert C[0, 0] == pytest.approx(p8 * ((6 * kn + 2 * ks) + 4 * a2 * kn + a4 * (kn - ks)))  # 4.37
    assert C[1, 1] == pytest.approx(p8 * ((6 * kn + 2 * ks) - 4 * a2 * kn + a4 * (kn - ks)))  # 4.38
    assert C[0, 1] == pytest.approx(p8 * (2 * (kn - ks) - a4 * (kn - ks)))  # 4.39
    assert C[2, 2] == pytest.approx(p16 * (4 * (kn + ks) - 2 * a4 * (kn - ks)))  # 4.40
    printed_41 = p16 * (2 * b2 * kn + b4 * (kn - ks))
    printed_42 = p16 * (2 * b2 * (kn + ks) - b4 * kn)
    assert C[0, 2] == pytest.approx(2 * printed_41)  # prefactor 8 pi, not 16 pi
    assert C[1, 2] == pytest.approx(p8 * (2 * b2 * kn - b4 * (kn - ks)))
    assert C[1, 2] != pytest.approx(printed_42)
    # with the literal seed convention (Eq. 4.1 + Eq. 2.41) everything is half of the printed 4.37
    nv_s, r = cf.packing_scale(e, m, 0.01, dim=2, convention="seed")
    C_s = cf.discs_fourth_order(a2, b2, a4, b4, kn, ks, nv_s * r**2, order="seed")
    np.testing.assert_allclose(C_s, 0.5 * C, rtol=1e-14)


def test_isotropic_poisson_ratio_fig_4_3():
    """Seed Fig. 4.3 / Sec. 4.4: nu = 0.25 at Ks/Kn = 0 and decreasing with Ks/Kn."""
    ratios = np.linspace(0, 1, 21)
    nus = []
    for r in ratios:
        C = cf.spheres_second_order(0, 0, 0, 3800.0, 3800.0 * r, 1.0)
        S = np.linalg.inv(C)
        nus.append(-S[0, 1] / S[0, 0])
    assert nus[0] == pytest.approx(0.25, abs=1e-14)
    assert np.all(np.diff(nus) < 0)
    assert nus[-1] == pytest.approx(0.0, abs=1e-14)  # Ks = Kn: nu = (Kn-Ks)/(4Kn+Ks) = 0


@pytest.mark.parametrize("convention", ["physical", "seed"])
def test_isotropic_hertz_mindlin_matches_quadrature(convention):
    """Eq. 4.43-4.44 and corrected 4.45 vs the general assembly with Hertz-Mindlin stiffnesses."""
    G, nu, P, e, m, rho = 29e9, 0.15, 2e5, 0.65, 7.5, 2e-4
    r = cf.isotropic_hertz_mindlin(G, nu, P, void_ratio=e, coordination=m, radius=rho, convention=convention)
    nv, ell = cf.packing_scale(e, m, rho, convention=convention)
    x, w = lebedev_rule(7)
    n = x.T
    cs = ContactSet(n, ell * n, nv * w / (4 * np.pi), r.kn, r.ks)
    C = stiffness(cs)
    S = np.linalg.inv(C)
    assert 1 / S[0, 0] == pytest.approx(r.E, rel=1e-12)
    assert -S[0, 1] / S[0, 0] == pytest.approx(r.nu, rel=1e-12)
    assert C[3, 3] == pytest.approx(r.G, rel=1e-12)
    # Eq. 4.44 as printed
    assert r.nu == pytest.approx(nu / (2 * (5 - 3 * nu)), rel=1e-12)
    # isotropic stress from the contact force reproduces P (Eq. 4.43)
    from grainmech.assembly import love_weber_stress
    s = love_weber_stress(r.contact_force * n, ell * n, nv * w / (4 * np.pi))
    np.testing.assert_allclose(s.stress, P * np.eye(3), rtol=1e-12, atol=1e-12 * P)


def test_eq_4_45_corrected_and_printed():
    """Corrected Eq. 4.45 (seed convention) is 10/30 r^2...; the printed 4/30 is 0.4 of it (E-4.45)."""
    G, nu, P, e, m, rho = 5.75e6, 0.13, 10.0, 0.6, 8.0, 0.05
    r = cf.isotropic_hertz_mindlin(G, nu, P, void_ratio=e, coordination=m, radius=rho, convention="seed")
    NV = 3 * m / (4 * np.pi * rho**3 * (1 + e))
    core = (5 - 4 * nu) / (5 - 3 * nu) * (9 * P) ** (1 / 3) * (G * NV / (1 - nu)) ** (2 / 3)
    assert r.E == pytest.approx(rho**2 / 3 * core, rel=1e-12)
    printed = 4 * rho**2 / 30 * core
    assert printed / r.E == pytest.approx(0.4, rel=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.floats(1e6, 1e11), st.floats(0.0, 0.45), st.floats(1e2, 1e7), st.floats(0.3, 1.2), st.floats(4, 12))
def test_physical_convention_reproduces_walton_and_digby(G, nu, P, e, m):
    """Walton (1987) rough spheres == our physical convention == Digby (1981) with b = a; seed gives half."""
    phys = cf.isotropic_hertz_mindlin(G, nu, P, void_ratio=e, coordination=m, radius=1e-3)
    seed = cf.isotropic_hertz_mindlin(G, nu, P, void_ratio=e, coordination=m, radius=1e-3, convention="seed")
    K_w, G_w = cf.walton(G, nu, P, porosity=e / (1 + e), coordination=m)
    K_d, G_d = cf.digby(G, nu, P, porosity=e / (1 + e), coordination=m)
    assert phys.K == pytest.approx(K_w, rel=1e-10) and phys.G == pytest.approx(G_w, rel=1e-10)
    assert K_d == pytest.approx(K_w, rel=1e-10) and G_d == pytest.approx(G_w, rel=1e-10)
    assert seed.G == pytest.approx(0.5 * G_w, rel=1e-10)


def test_walton_smooth_and_digby_unbonded():
    """Smooth limit: G = 3K/5 (Walton 1987); Digby with b = 0 gives the same."""
    K, G = cf.walton(30e9, 0.2, 1e5, porosity=0.36, coordination=9, rough=False)
    assert G == pytest.approx(0.6 * K)
    Kd, Gd = cf.digby(30e9, 0.2, 1e5, porosity=0.36, coordination=9, bonded_fraction=0.0)
    assert Kd == pytest.approx(K) and Gd == pytest.approx(G)


def test_packing_scale_eq_4_1():
    nv, ell = cf.packing_scale(0.57, 9.0, 0.01, convention="seed")
    assert nv == pytest.approx(3 * 9 / (4 * np.pi * 0.01**3 * 1.57)) and ell == 0.01
    nv2, ell2 = cf.packing_scale(0.57, 9.0, 0.01, dim=2, convention="seed")
    assert nv2 == pytest.approx(9 / (np.pi * 0.01**2 * 1.57))
    nvp, lp = cf.packing_scale(0.57, 9.0, 0.01)
    assert nvp * lp**2 == pytest.approx(2 * nv * ell**2)


@pytest.mark.parametrize("kwargs, match", [
    (dict(void_ratio=-0.1, coordination=6, radius=1), "void_ratio = -0.1: must be > 0"),
    (dict(void_ratio=0.5, coordination=0, radius=1), "coordination = 0.0: must be > 0"),
    (dict(void_ratio=0.5, coordination=6, radius=float("nan")), "radius must be > 0"),
])
def test_bad_packing_inputs(kwargs, match):
    with pytest.raises(GrainmechError, match=match):
        cf.packing_scale(**kwargs)


def test_bad_material_inputs():
    with pytest.raises(GrainmechError, match="poisson must lie in"):
        cf.isotropic_hertz_mindlin(1e9, 0.5, 1e5, void_ratio=0.6, coordination=8, radius=1e-3)
    with pytest.raises(GrainmechError, match="pressure.*must be > 0"):
        cf.isotropic_hertz_mindlin(1e9, 0.2, -1, void_ratio=0.6, coordination=8, radius=1e-3)
    with pytest.raises(GrainmechError, match="porosity"):
        cf.walton(1e9, 0.2, 1e5, porosity=1.2, coordination=8)

"""Closed-form contact geometry: Hertz (seed Eq. 3.1-3.7), rods (Eq. 3.8, 3.17)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from grainmech.contact import (
    ContactDomainError,
    Cylinder,
    Hertz,
    HertzMindlin,
    cylinder_approach_from_force,
    cylinder_contact_halfwidth,
    cylinder_normal_force,
    cylinder_normal_stiffness,
    cylinder_tangential_stiffness,
    hertz_approach_from_force,
    hertz_contact_radius,
    hertz_contact_radius_from_force,
    hertz_normal_force,
    hertz_normal_stiffness,
    hertz_normal_stiffness_from_approach,
    mindlin_tangential_stiffness,
)

P = Hertz(30e9, 0.25, 1e-3, 3e-3, 80e9, 0.3)
ROD = Cylinder(shear_modulus_equiv=1.034e8, poisson=0.1, radius=3.175e-3, psi=2.5,
               friction_angle=math.radians(15))


def test_hertz_equations_are_mutually_consistent():
    """Eq. 3.1 (alpha^3 = 9N^2/(16 R E^2)), 3.2, 3.5 and 3.6 describe one relation."""
    N = np.array([1e-6, 0.3, 1.0, 47.0])
    R, E = P.effective_radius, P.effective_modulus
    alpha = hertz_approach_from_force(N, P)
    np.testing.assert_allclose(alpha**3, 9 * N**2 / (16 * R * E**2), rtol=1e-13)      # Eq. 3.1
    np.testing.assert_allclose(hertz_normal_force(alpha, P), N, rtol=1e-13)           # Eq. 3.6
    a = hertz_contact_radius_from_force(N, P)
    np.testing.assert_allclose(a**3, 3 * N * R / (4 * E), rtol=1e-13)                 # Eq. 3.2
    np.testing.assert_allclose(alpha, a**2 / R, rtol=1e-13)                           # Eq. 3.5
    np.testing.assert_allclose(hertz_contact_radius(alpha, P), a, rtol=1e-13)


def test_hertz_incremental_stiffness_is_derivative_of_eq_3_6():
    """Eq. 3.7: dN/dalpha = 2 E a (sympy derivative of Eq. 3.6)."""
    al, E, R = sp.symbols("alpha E R", positive=True)
    Nsym = sp.Rational(4, 3) * E * sp.sqrt(R * al**3)
    dN = sp.diff(Nsym, al)
    assert sp.simplify(dN - 2 * E * sp.sqrt(R * al)) == 0
    alpha = np.array([1e-9, 1e-7, 3e-6])
    expected = np.array([float(dN.subs({al: x, E: P.effective_modulus, R: P.effective_radius}))
                         for x in alpha])
    np.testing.assert_allclose(hertz_normal_stiffness_from_approach(alpha, P), expected, rtol=1e-13)
    N = hertz_normal_force(alpha, P)
    np.testing.assert_allclose(hertz_normal_stiffness(N, P), expected, rtol=1e-12)


def test_mindlin_no_slip_stiffness_equal_spheres():
    """8 G* a = 4 G a / (2 - nu) for equal spheres (Mindlin 1949)."""
    G, nu = 29e9, 0.2
    p = HertzMindlin(G, nu, 1e-3)
    a = np.array([0.0, 1e-5, 4e-5])
    np.testing.assert_allclose(mindlin_tangential_stiffness(a, p), 4 * G * a / (2 - nu), rtol=1e-14)


def test_non_positive_input_gives_zero_not_nan():
    z = np.array([-1.0, 0.0])
    for f in (hertz_normal_force, hertz_contact_radius, hertz_normal_stiffness_from_approach):
        out = f(z, P)
        assert np.all(out == 0.0)
    for f in (hertz_contact_radius_from_force, hertz_approach_from_force, hertz_normal_stiffness):
        assert np.all(f(z, P) == 0.0)
    assert np.all(cylinder_normal_stiffness(z, ROD) == 0.0)
    assert np.all(cylinder_approach_from_force(z, ROD) == 0.0)
    assert np.all(cylinder_normal_force(z, ROD) == 0.0)
    assert np.all(np.isfinite(cylinder_tangential_stiffness(z, z, ROD)))


def test_cylinder_approach_integrates_eq_3_8():
    """d alpha/dN of alpha(N) = 2(1-nu)N/(pi G) ln(2R/a) is exactly 1/Kn of Eq. 3.8."""
    Ns, G, nu, R = sp.symbols("N G nu R", positive=True)
    a = sp.sqrt(2 * (1 - nu) * Ns * R / (sp.pi * G))
    alpha = 2 * (1 - nu) * Ns / (sp.pi * G) * sp.log(2 * R / a)
    inv_kn = (1 - nu) / (sp.pi * G) * (2 * sp.log(2 * R / a) - 1)
    assert sp.simplify(sp.expand_log(sp.diff(alpha, Ns) - inv_kn, force=True)) == 0
    N = np.array([1.0, 50.0, 3000.0])
    subs = {G: ROD.shear_modulus_equiv, nu: ROD.poisson, R: ROD.equivalent_radius}
    expected_kn = np.array([1.0 / float(inv_kn.subs(subs).subs(Ns, x)) for x in N])
    np.testing.assert_allclose(cylinder_normal_stiffness(N, ROD), expected_kn, rtol=1e-12)
    expected_alpha = np.array([float(alpha.subs(subs).subs(Ns, x)) for x in N])
    np.testing.assert_allclose(cylinder_approach_from_force(N, ROD), expected_alpha, rtol=1e-12)
    # the Newton inverse
    np.testing.assert_allclose(cylinder_normal_force(expected_alpha, ROD), N, rtol=1e-12)


def test_cylinder_halfwidth_is_hertz_line_contact_for_equal_rods():
    """Johnson (1985, Sec. 4.3): b^2 = 4 P R_eq/(pi E*), R_eq = R/2 and E* = G/(1-nu) for equal rods."""
    N = np.array([10.0, 500.0])
    G, nu, R = ROD.shear_modulus_equiv, ROD.poisson, ROD.equivalent_radius
    b = np.sqrt(4 * N * (R / 2) * (1 - nu) / (math.pi * G))
    np.testing.assert_allclose(cylinder_contact_halfwidth(N, ROD), b, rtol=1e-14)


def test_cylinder_shear_stiffness_eq_3_17():
    N = np.array([100.0, 100.0, 100.0, 100.0])
    mu = math.tan(ROD.friction_angle)
    T = np.array([0.0, 0.75 * mu * 100, -0.75 * mu * 100, mu * 100])
    kn = cylinder_normal_stiffness(N, ROD)
    ks = cylinder_tangential_stiffness(N, T, ROD)
    np.testing.assert_allclose(ks, kn / ROD.psi * np.array([1.0, 0.5, 0.5, 0.0]), rtol=1e-13, atol=0)
    # 1/Ks = (Psi/Kn)(1 - T/(mu N))^(-1/2), printed form
    np.testing.assert_allclose(1 / ks[:3], ROD.psi / kn[:3] * (1 - np.abs(T[:3]) / (mu * N[:3])) ** -0.5)


def test_cylinder_domain_limit_is_enforced():
    with pytest.raises(ContactDomainError, match="Eq. 3.8"):
        cylinder_normal_stiffness(np.array([ROD.max_normal_force * 1.01]), ROD)
    with pytest.raises(ContactDomainError, match="2R/e"):
        cylinder_normal_force(np.array([ROD.equivalent_radius]), ROD)

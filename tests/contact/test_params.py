"""Contact-law parameters: validation (errors name the field) and derived constants."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from grainmech.contact import Cylinder, Hertz, HertzMindlin, LinearSpring, MindlinDeresiewicz
from grainmech.errors import ParameterError

GOOD = dict(shear_modulus=29e9, poisson=0.2, radius1=1e-3)


@pytest.mark.parametrize("cls, kwargs, field, value", [
    (Hertz, dict(GOOD), "shear_modulus", -1.0),
    (Hertz, dict(GOOD), "shear_modulus", 0.0),
    (Hertz, dict(GOOD), "shear_modulus", math.nan),
    (Hertz, dict(GOOD), "shear_modulus", math.inf),
    (Hertz, dict(GOOD), "poisson", 0.5),
    (Hertz, dict(GOOD), "poisson", -1.0),
    (Hertz, dict(GOOD), "poisson", 0.7),
    (Hertz, dict(GOOD), "radius1", 0.0),
    (Hertz, dict(GOOD), "radius2", -2e-3),
    (Hertz, dict(GOOD), "shear_modulus2", -5.0),
    (Hertz, dict(GOOD), "poisson2", 0.6),
    (Hertz, dict(GOOD), "radius1", "1 mm"),
    (HertzMindlin, dict(GOOD), "friction", -0.1),
    (MindlinDeresiewicz, dict(GOOD, friction=0.5), "friction", -1.0),
    (MindlinDeresiewicz, dict(GOOD, friction=0.5), "friction", math.inf),
    (MindlinDeresiewicz, dict(GOOD, friction=0.5), "max_reversals", 0),
    (MindlinDeresiewicz, dict(GOOD, friction=0.5), "max_reversals", 2.5),
    (LinearSpring, dict(kn=1e6, ks=1e5), "kn", 0.0),
    (LinearSpring, dict(kn=1e6, ks=1e5), "ks", -1.0),
    (LinearSpring, dict(kn=1e6, ks=1e5), "friction", -0.3),
    (Cylinder, dict(shear_modulus_equiv=1e8, poisson=0.1, radius=3e-3, psi=2.5, friction_angle=0.26),
     "shear_modulus_equiv", -1e8),
    (Cylinder, dict(shear_modulus_equiv=1e8, poisson=0.1, radius=3e-3, psi=2.5, friction_angle=0.26),
     "poisson", 0.5),
    (Cylinder, dict(shear_modulus_equiv=1e8, poisson=0.1, radius=3e-3, psi=2.5, friction_angle=0.26),
     "psi", 0.0),
    (Cylinder, dict(shear_modulus_equiv=1e8, poisson=0.1, radius=3e-3, psi=2.5, friction_angle=0.26),
     "friction_angle", -0.1),
    (Cylinder, dict(shear_modulus_equiv=1e8, poisson=0.1, radius=3e-3, psi=2.5, friction_angle=0.26),
     "friction_angle", math.pi / 2),
    (Cylinder, dict(shear_modulus_equiv=1e8, poisson=0.1, radius=3e-3, psi=2.5, friction_angle=0.26),
     "radius", 0.0),
])
def test_bad_parameters_are_rejected_naming_the_field(cls, kwargs, field, value):
    kwargs = dict(kwargs)
    kwargs[field] = value
    with pytest.raises(ParameterError) as info:
        cls(**kwargs)
    assert info.value.name == field
    assert field in str(info.value)
    assert isinstance(info.value, ValueError)


def test_mindlin_deresiewicz_requires_friction():
    with pytest.raises(ParameterError, match="friction"):
        MindlinDeresiewicz(**GOOD)


def test_parameters_are_frozen():
    p = MindlinDeresiewicz(**GOOD, friction=0.4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.friction = 0.3  # type: ignore[misc]


def test_derived_constants_for_two_different_spheres():
    """Seed Eq. 3.3, 3.4 (with E = 2G(1+nu)) and 3.12, computed by hand."""
    G1, n1, R1 = 30e9, 0.25, 1e-3
    G2, n2, R2 = 80e9, 0.3, 3e-3
    p = Hertz(G1, n1, R1, R2, G2, n2)
    E1, E2 = 2 * G1 * (1 + n1), 2 * G2 * (1 + n2)
    assert p.effective_radius == pytest.approx(1 / (1 / R1 + 1 / R2), rel=1e-15)
    assert p.effective_modulus == pytest.approx(1 / ((1 - n1**2) / E1 + (1 - n2**2) / E2), rel=1e-14)
    assert p.effective_shear_modulus == pytest.approx(1 / ((2 - n1) / G1 + (2 - n2) / G2), rel=1e-14)


def test_equal_spheres_constants_and_stiffness_ratio():
    G, nu = 29e9, 0.2
    p = HertzMindlin(G, nu, 1e-3)
    assert p.effective_radius == pytest.approx(0.5e-3)
    assert p.effective_modulus == pytest.approx(G / (1 - nu))
    assert p.effective_shear_modulus == pytest.approx(G / (2 * (2 - nu)))
    # Mindlin (1949): kt/kn = 2(1-nu)/(2-nu) at the same contact radius
    assert 1 / p.stiffness_ratio == pytest.approx(2 * (1 - nu) / (2 - nu))
    assert HertzMindlin.for_equal_spheres(G, nu, 1e-3) == p


def test_sphere_on_flat():
    p = Hertz(29e9, 0.2, 1e-3, math.inf)
    assert p.effective_radius == pytest.approx(1e-3)


def test_stiffness_method_matches_closed_forms():
    p = HertzMindlin(29e9, 0.2, 1e-3, friction=0.5)
    N = np.array([0.0, 1.0, 10.0])
    kn, ks = p.stiffness(N)
    a = np.cbrt(0.75 * N * p.effective_radius / p.effective_modulus)
    np.testing.assert_allclose(kn, 2 * p.effective_modulus * a, rtol=1e-14)
    np.testing.assert_allclose(ks, 8 * p.effective_shear_modulus * a, rtol=1e-14)
    kn0, ks0 = Hertz(29e9, 0.2, 1e-3).stiffness(N)
    np.testing.assert_allclose(ks0, 0.0)


def test_cylinder_radius_and_friction():
    c = Cylinder(1e8, 0.1, 2e-3, 2.5, math.radians(15))
    assert c.friction == pytest.approx(math.tan(math.radians(15)))
    assert c.equivalent_radius == 2e-3
    c2 = Cylinder(1e8, 0.1, 2e-3, 2.5, 0.2, radius2=2e-3)
    assert c2.equivalent_radius == pytest.approx(2e-3)
    c3 = Cylinder(1e8, 0.1, 1e-3, 2.5, 0.2, radius2=3e-3)
    assert c3.equivalent_radius == pytest.approx(2 * 1e-3 * 3e-3 / 4e-3)

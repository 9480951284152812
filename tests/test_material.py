"""Packing stiffness under stress (seed Sec. 4.2.2, Eq. 4.43) and normal force estimates."""

import numpy as np
import pytest

from grainmech import closed_form as cf
from grainmech import fabric, material
from grainmech.assembly import love_weber_stress
from grainmech.errors import GrainmechError


def test_normal_forces_carry_the_stress_and_reduce_to_eq_4_43():
    pk = material.Packing.from_grains(fabric.SphericalDensity.from_seed(0.3, 0.1, 0.05),
                                      void_ratio=0.6, coordination=8, radius=1e-3)
    cs = pk.contact_set(extra_degree=8)
    sigma = np.array([[1.5, 0.1, 0.0], [0.1, 1.3, 0.2], [0.0, 0.2, 2.0]]) * 1e5
    N = material.normal_forces_for_stress(cs, sigma)
    s = love_weber_stress(N[:, None] * cs.normals, cs.branch, cs.weights).stress
    np.testing.assert_allclose(s, sigma, rtol=1e-11, atol=1e-9 * 1e5)
    iso = material.Packing.from_grains(fabric.isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)
    cs0 = iso.contact_set()
    N0 = material.normal_forces_for_stress(cs0, 1e5 * np.eye(3))
    # Eq. 4.43 (physical count): f = 3 V P / (N_c l)
    np.testing.assert_allclose(N0, 3 * 1e5 / (iso.contacts_per_volume * iso.branch_length), rtol=1e-12)


def test_tensile_normal_force_is_reported():
    iso = material.Packing.from_grains(fabric.isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)
    with pytest.raises(GrainmechError, match="tension"):
        material.normal_forces_for_stress(iso.contact_set(), np.diag([1.0, 1.0, -3.0]))


def test_isotropic_hertz_mindlin_packing_equals_closed_form():
    iso = material.Packing.from_grains(fabric.isotropic(3), void_ratio=0.7, coordination=7, radius=2e-4)
    hm = material.HertzMindlinStiffness.for_equal_spheres(30e9, 0.2, 2e-4)
    res = material.packing_stiffness(iso, hm, 3e5)
    ref = cf.isotropic_hertz_mindlin(30e9, 0.2, 3e5, void_ratio=0.7, coordination=7, radius=2e-4)
    assert res.C[3, 3] == pytest.approx(ref.G, rel=1e-12)
    assert res.C[0, 1] == pytest.approx(ref.lam, rel=1e-12)


def test_anisotropic_hertz_mindlin_quadrature_is_converged():
    """Direction-dependent kn ~ N^(1/3) is not polynomial: the default degree must be converged."""
    pk = material.Packing.from_grains(fabric.SphericalDensity.from_seed(0.5, 0.1, 0.0),
                                      void_ratio=0.6, coordination=8, radius=1e-3)
    hm = material.HertzMindlinStiffness.for_equal_spheres(30e9, 0.2, 1e-3)
    res = material.packing_stiffness(pk, hm, np.diag([1e5, 1e5, 2e5]))
    cs = pk.contact_set(extra_degree=2 * material.DEGREE_VARYING_STIFFNESS)
    N = material.normal_forces_for_stress(cs, np.diag([1e5, 1e5, 2e5]))
    from grainmech.assembly import stiffness
    fine = stiffness(cs.with_stiffness(*hm.stiffness(N)))
    np.testing.assert_allclose(res.C, fine, rtol=1e-9, atol=1e-9 * np.abs(fine).max())


def test_pressure_needed_for_force_dependent_stiffness():
    iso = material.Packing.from_grains(fabric.isotropic(3), void_ratio=0.7, coordination=7, radius=2e-4)
    hm = material.HertzMindlinStiffness.for_equal_spheres(30e9, 0.2, 2e-4)
    with pytest.raises(GrainmechError, match="stress"):
        material.packing_stiffness(iso, hm)
    with pytest.raises(GrainmechError, match="pressure.*must be > 0"):
        material.packing_stiffness(iso, hm, -1.0)

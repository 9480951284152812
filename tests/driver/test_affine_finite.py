"""First-order finite-deformation correction (seed Eq. 2.36-2.38, errata E-2.34).

References: for sigma = p I, G(sigma) : d eps = -p d eps + p tr(d eps) I (closed form);
isotropic compression with linear springs: Eq. 2.38 with the contact stiffness of the
reference geometry is the ODE d sigma/de = k + 2 sigma (k = d sigma_c/de constant), whose
solution is sigma = -k/2 + (p0 + k/2) exp(2 e).

Note: the driver keeps the reference geometry in C (no update of l and V), so this option
is first order in the strain: the deformed-geometry Love-Weber stress sigma_c/(1-e)^2
differs by ~ 2 e (sigma_c - p0), which is not small for stiff packings (documented).
"""

import numpy as np
import pytest

from grainmech.contact import LinearSpring
from grainmech.driver import MaterialPoint, geometric_stiffness, run, segment
from grainmech.fabric import isotropic
from grainmech.material import Packing

PK = Packing.from_grains(isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)


def test_geometric_stiffness_isotropic_closed_form():
    p = 3.0
    G = geometric_stiffness(np.array([p, p, p, 0, 0, 0]))
    expect = np.zeros((6, 6))
    expect[:3, :3] = p * np.ones((3, 3)) - p * np.eye(3)
    expect[3:, 3:] = -0.5 * p * np.eye(3)  # engineering shear: d sigma_xz = -p d gamma_xz / 2
    assert np.allclose(G, expect)


def test_isotropic_compression_correction_integrates_eq_2_38():
    pt = MaterialPoint.isotropic(PK, LinearSpring(1e6, 4e5), 1e5)
    e = 1e-3
    small = run(pt, segment("EEEEEE", [e, e, e, 0, 0, 0], 50))
    big = run(pt, segment("EEEEEE", [e, e, e, 0, 0, 0], 50), finite_deformation=True)
    assert small.success and big.success
    sc = small.stress[-1, 0]  # contact stress, same in both runs
    corr = big.stress[-1, 0] - sc
    assert big.final.correction[0] == pytest.approx(corr, rel=1e-12)
    p0 = 1e5
    k = (sc - p0) / e
    exact = -k / 2 + (p0 + k / 2) * np.exp(2 * e)
    assert big.stress[-1, 0] == pytest.approx(exact, rel=1e-6)
    assert corr == pytest.approx(exact - sc, rel=1e-3)  # mid-step sigma in G: 2nd order


def test_stress_control_with_correction():
    """sigma_zz held under simple shear with the correction switched on (Newton on C + G)."""
    pt = MaterialPoint.isotropic(PK, LinearSpring(1e6, 4e5), 1e5)
    r = run(pt, segment("EESEEE", [0, 0, 0, 0, 1e-3, 0], 10), finite_deformation=True)
    assert r.success, r.message
    assert np.allclose(r.stress[:, 2], 1e5, rtol=1e-9)

"""The packing model with rolling and twisting resistance (grainmech.contact.rolling).

References: the moment springs of Iwashita & Oda (1998) and Ai et al. (2011) in every
grain's moment balance; the relaxed tensor C = C_affine - (1/V) B^T H^+ B (Lemaitre &
Maloney 2006, Eq. 12) with H gaining Hr^T K_m Hr, checked here against a dense
assembly of the same operator written out in the test (an independent derivation of
the rotational block: relative rotation theta_A - theta_B, K_m = k_roll R*^2 (I - n n) +
k_twist n n); the Love-Weber stress (seed Eq. 2.6), which contact moments do not enter.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.analysis import loop_properties
from grainmech.contact import MindlinDeresiewicz
from grainmech.contact.rolling import RollingConstants, RollingResistance
from grainmech.driver import cyclic_simple_shear, segment
from grainmech.driver.packing import (
    PackingPoint,
    equilibrate_network,
    perturbed_fcc_network,
    run_packing,
    unbalanced_force_ratio,
)
from grainmech.errors import ParameterError

G_GRAIN, NU = 29e9, 0.15
MD = MindlinDeresiewicz(G_GRAIN, NU, 1.0, friction=0.5)


@pytest.fixture(scope="module")
def packing():
    """~100 grains, disordered fcc (5 % vacancies), equilibrated with frictionless Hertz contacts."""
    return equilibrate_network(perturbed_fcc_network(3, seed=1, vacancies=0.05), MD)


@pytest.fixture(scope="module")
def rolled(packing):
    return PackingPoint.from_network(packing, MD, rolling=RollingResistance(0.1))


def test_zero_rolling_friction_is_todays_model(packing):
    """mu_r = 0 (or None) builds no moment springs: the same point, the same loop, bit for bit."""
    plain = PackingPoint.from_network(packing, MD)
    zero = PackingPoint.from_network(packing, MD, rolling=RollingResistance(0.0))
    assert zero.rolling is None and zero.kinematics.Hr is None
    np.testing.assert_array_equal(plain.elastic_tangent, zero.elastic_tangent)
    path = cyclic_simple_shear(1e-5, 1, 16, constant="volume")
    a, b = run_packing(plain, path), run_packing(zero, path)
    np.testing.assert_array_equal(a.stress, b.stress)


def test_elastic_tangent_equals_an_independent_dense_assembly(packing, rolled):
    """The relaxed tensor with moment springs against the condensation of a dense matrix built here."""
    pt = rolled
    kin, c = pt.kinematics, pt.rolling
    assert c is not None and c.mu_roll == 0.1
    K, K0 = pt.contact_stiffness()
    closed = ~np.asarray(pt.response.open, bool)
    C = kin.n_contacts
    P = kin.n_grains
    # relative displacement and rotation of each contact in the grains' (u, theta), written out
    Gd = np.zeros((3 * C, 6 * P))
    Hd = np.zeros((3 * C, 6 * P))
    Rg = pt.radii
    for k in range(C):
        a, b, n = kin.a[k], kin.b[k], kin.n[k]

        def cross(r):
            return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])

        Gd[3 * k:3 * k + 3, 6 * a:6 * a + 3] = np.eye(3)
        Gd[3 * k:3 * k + 3, 6 * b:6 * b + 3] = -np.eye(3)
        # theta x r = -[r]x theta with r_A = R_A n, r_B = -R_B n
        Gd[3 * k:3 * k + 3, 6 * a + 3:6 * a + 6] = -cross(Rg[a] * n)
        Gd[3 * k:3 * k + 3, 6 * b + 3:6 * b + 6] = cross(-Rg[b] * n)
        Hd[3 * k:3 * k + 3, 6 * a + 3:6 * a + 6] = np.eye(3)
        Hd[3 * k:3 * k + 3, 6 * b + 3:6 * b + 6] = -np.eye(3)
    Rs = Rg[kin.a] * Rg[kin.b] / (Rg[kin.a] + Rg[kin.b])
    nn = np.einsum("ci,cj->cij", kin.n, kin.n)
    Km = (c.k_roll * Rs ** 2)[:, None, None] * (np.eye(3) - nn) + c.k_twist * nn
    Km[~closed] = 0.0
    from scipy.linalg import block_diag

    K0d, Kmd = block_diag(*K0), block_diag(*Km)
    free = kin.free
    H = (Gd.T @ K0d @ Gd + Hd.T @ Kmd @ Hd)[np.ix_(free, free)]
    B = (Gd.T @ K0d @ kin.E)[free]
    A = kin.E.T @ K0d @ kin.E
    Crel = (A - B.T @ np.linalg.lstsq(H, B, rcond=None)[0]) / pt.volume
    np.testing.assert_allclose(pt.elastic_tangent, Crel, rtol=1e-6, atol=1e-6 * np.abs(Crel).max())
    plain = PackingPoint.from_network(packing, MD)
    # the springs stiffen the packing (1.06 % on this 12-contact packing; 21 % on the shipped "dense")
    assert pt.elastic_tangent[4, 4] > 1.005 * plain.elastic_tangent[4, 4]
    # the moment springs' own energy: consistent with their stiffness (zero moments at the start)
    assert pt.stored_energy() == pytest.approx(plain.stored_energy(), rel=1e-12)


def test_small_cycle_secant_equals_the_rolling_relaxed_c55(rolled):
    """gamma -> 0: the secant G of a constant-volume cycle is the point's relaxed C55 (to 1e-3)."""
    r = run_packing(rolled, cyclic_simple_shear(1e-6, 1, 24, constant="volume"))
    assert r.success, r.message
    lp = loop_properties(r.strain[:, 4], r.stress[:, 4])
    assert lp.secant_modulus == pytest.approx(rolled.tangent[4, 4], rel=1e-3)
    fin = r.final
    assert fin.moments is not None and np.abs(fin.moments).max() > 0
    assert unbalanced_force_ratio(fin) < 1e-4  # forces and moments, contact moments included


def test_caps_bound_the_moments_and_dissipate(packing):
    """A weak rolling friction is reached by 2e-4 of shear: |M_r| <= mu_r R* N; the loop still closes."""
    pt = PackingPoint.from_network(packing, MD, rolling=RollingResistance(0.002))
    e = np.zeros(6)
    e[4] = 2e-4
    r = run_packing(pt, segment("EEEEEE", e, 12))
    assert r.success, r.message
    fin = r.final
    kin = fin.kinematics
    N = np.where(np.asarray(fin.response.open, bool), 0.0, fin.response.normal_force)
    mt = np.einsum("ci,ci->c", fin.moments, kin.n)
    mr = np.linalg.norm(fin.moments - mt[:, None] * kin.n, axis=1)
    assert np.all(mr <= 0.002 * kin.Rs * N * (1 + 1e-9))
    assert fin.rolling_response.rolling.sum() >= 5  # 7 of 588 contacts at the rolling cap
    cyc = run_packing(pt, cyclic_simple_shear(2e-4, 1, 24, constant="volume"))
    assert cyc.success, cyc.message
    assert cyc.dissipation[-1] > 0 and np.isfinite(cyc.dissipation[-1])


def test_consistent_tangent_matches_a_small_strain_step(rolled):
    """The consistent tangent (moment springs and their cap coupling included) predicts a 1e-8 step."""
    e = np.zeros(6)
    e[4] = 1e-8
    r = run_packing(rolled, segment("EEEEEE", e, 1))
    assert r.success, r.message
    ds = (r.stress[-1] - r.stress[0]) / 1e-8
    np.testing.assert_allclose(ds[4], rolled.tangent[4, 4], rtol=2e-3)


def test_resolved_constants_are_taken_as_given(packing):
    c = RollingConstants(0.1, 1e5, 1e-3, 1e-5, 0.5)
    pt = PackingPoint.from_network(packing, MD, rolling=c)
    assert pt.rolling is c
    with pytest.raises(ParameterError, match="rolling"):
        PackingPoint.from_network(packing, MD, rolling=0.1)

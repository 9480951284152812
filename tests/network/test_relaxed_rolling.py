"""The relaxed small-strain tensor with rolling and twisting resistance
(``relaxed_stiffness(..., rolling=)``).

The grains' rotational block gains ``H_r^T K_m H_r`` with ``omega = theta_A - theta_B`` and
``K_m = k_roll R*^2 (I - n n) + k_twist n n`` (Iwashita & Oda 1998; LAMMPS ``rolling sds`` /
``twisting sds``, :mod:`grainmech.contact.rolling`). Checked here: without it (None, or
``mu_r = 0``) the tensor is the one without rolling to round-off; the assembly against a
dense energy minimisation written contact by contact; the tensor against LAMMPS strain
probes with ``rolling sds`` / ``twisting sds`` on (shipped 'dense', within 1 %); and that
rolling stiffness raises G and never exceeds the affine bound.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.contact import HertzMindlin
from grainmech.contact.rolling import RollingConstants, RollingResistance, rolling_constants
from grainmech.elasticity import shear_modulus
from grainmech.errors import GrainmechError
from grainmech.network import contact_stiffnesses, random_network, relaxed_stiffness
from grainmech.network.stiffness import strain_map
from grainmech.packing import QUARTZ, load_packing

G, NU = QUARTZ.shear_modulus, QUARTZ.poisson


def _rstar(net):
    R = net.radii
    return R[net.i] * R[net.j] / (R[net.i] + R[net.j])


def _law(net):
    return HertzMindlin(G, NU, float(np.median(net.radii)), friction=0.5)


@pytest.fixture(scope="module")
def dense():
    net = load_packing("dense")
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU, source="overlap")
    return net, kn, ks, relaxed_stiffness(net, kn, ks)


def test_no_rolling_gives_the_tensor_without_it(dense):
    net, kn, ks, r0 = dense
    off = rolling_constants(RollingResistance(0.0), _law(net), net.normal_force, _rstar(net))
    for rolling in (None, off):
        r = relaxed_stiffness(net, kn, ks, rolling=rolling)
        np.testing.assert_allclose(r.C_relaxed, r0.C_relaxed, rtol=0, atol=1e-12 * np.abs(r0.C_relaxed).max())
        np.testing.assert_array_equal(r.C_affine, r0.C_affine)


def _dense_reference(net, kn, ks, consts):
    """``C_affine - (1/V) B^T H^+ B`` with H and B summed contact by contact (dense)."""
    P, C = net.n_particles, net.n_contacts
    n, l_ = net.normals, net.branch
    R = net.radii
    Rs = _rstar(net)
    E = strain_map(l_)  # (C, 3, 6): Delta = E e
    H = np.zeros((6 * P, 6 * P))
    B = np.zeros((6 * P, 6))
    Ca = np.zeros((6, 6))
    eye = np.eye(3)
    for c in range(C):
        a, b = net.i[c], net.j[c]
        K = kn[c] * np.outer(n[c], n[c]) + ks[c] * (eye - np.outer(n[c], n[c]))
        Km = consts.k_roll * Rs[c] ** 2 * (eye - np.outer(n[c], n[c])) + consts.k_twist * np.outer(n[c], n[c])
        rA, rB = R[a] * n[c], -R[b] * n[c]
        # Delta = u_A - u_B + theta_A x r_A - theta_B x r_B + E e;  omega = theta_A - theta_B
        GA = np.hstack([eye, np.array([np.cross(eye[k], rA) for k in range(3)]).T])
        GB = np.hstack([-eye, -np.array([np.cross(eye[k], rB) for k in range(3)]).T])
        OA = np.hstack([np.zeros((3, 3)), eye])
        OB = -OA
        Gc = np.zeros((3, 6 * P))
        Oc = np.zeros((3, 6 * P))
        Gc[:, 6 * a:6 * a + 6] += GA
        Gc[:, 6 * b:6 * b + 6] += GB
        Oc[:, 6 * a:6 * a + 6] += OA
        Oc[:, 6 * b:6 * b + 6] += OB
        H += Gc.T @ K @ Gc + Oc.T @ Km @ Oc
        B += Gc.T @ K @ E[c]
        Ca += E[c].T @ K @ E[c]
    V = net.volume
    return Ca / V - B.T @ np.linalg.pinv(H, rcond=1e-12, hermitian=True) @ B / V


def test_assembly_against_a_dense_minimisation():
    net = random_network(40, seed=3)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    consts = RollingConstants(0.1, 0.7 * float(np.mean(ks)), 0.7 * float(np.mean(ks)) * 0.3 ** 2, 0.03, 0.3)
    ref = _dense_reference(net, kn, ks, consts)
    for solver in ("cg", "superlu"):
        r = relaxed_stiffness(net, kn, ks, rolling=consts, remove_rattlers=False, solver=solver, tol=1e-10)
        np.testing.assert_allclose(r.C_relaxed, ref, rtol=0, atol=1e-7 * np.abs(ref).max())


def test_rolling_stiffens_but_stays_below_the_affine_bound(dense):
    net, kn, ks, r0 = dense
    consts = rolling_constants(RollingResistance(0.1), _law(net), net.normal_force, _rstar(net))
    r = relaxed_stiffness(net, kn, ks, rolling=consts)
    g0, g1, ga = shear_modulus(r0.C_relaxed), shear_modulus(r.C_relaxed), shear_modulus(r.C_affine)
    # measured on 'dense' (k_roll = k_t at the mean contact force): +21.4 %
    assert 1.15 < g1 / g0 < 1.30
    assert g1 < ga
    # the correction stays positive semi-definite (the rolling springs only restrain the grains)
    assert np.linalg.eigvalsh(r.correction).min() > -1e-9 * np.abs(r.C_affine).max()
    # any mu_r > 0 gives the same tensor (caps do not act at zero strain); stiffer springs stiffen more
    other = rolling_constants(RollingResistance(0.5), _law(net), net.normal_force, _rstar(net))
    np.testing.assert_allclose(relaxed_stiffness(net, kn, ks, rolling=other).C_relaxed, r.C_relaxed,
                               rtol=0, atol=1e-9 * np.abs(r.C_relaxed).max())
    stiff = rolling_constants(RollingResistance(0.1, 10 * consts.k_roll), _law(net), net.normal_force, _rstar(net))
    assert shear_modulus(relaxed_stiffness(net, kn, ks, rolling=stiff).C_relaxed) > g1
    # twisting alone stiffens a little
    twist = rolling_constants(RollingResistance(0.0, None, 0.1), _law(net), net.normal_force, _rstar(net))
    g_t = shear_modulus(relaxed_stiffness(net, kn, ks, rolling=twist).C_relaxed)
    assert g0 < g_t < g1


def test_rolling_needs_rotations(dense):
    net, kn, ks, _ = dense
    consts = rolling_constants(RollingResistance(0.1), _law(net), net.normal_force, _rstar(net))
    with pytest.raises(GrainmechError, match="rolling resistance needs 3D grains with rotations"):
        relaxed_stiffness(net, kn, ks, rolling=consts, rotations=False)


# ----------------------------------------------------------------------------- LAMMPS
def _lammps() -> bool:
    try:
        from grainmech.lammps.engine import require_lammps

        require_lammps()
    except GrainmechError:
        return False
    return True


@pytest.mark.skipif(not _lammps(), reason="LAMMPS (grainmech[dem]) is not installed")
def test_relaxed_tensor_with_rolling_matches_lammps_strain_probe():
    """One shear probe (gamma_xy = 1e-6, quasi-static, ~10 s on one core) of 'dense' with
    LAMMPS ``rolling sds`` / ``twisting sds`` (mu_r = 0.1, k_roll = k_t at the mean contact
    force) against the relaxed tensor of the re-settled reference state with the same
    constants: measured 0.04 % on C66 (2.378e8 Pa with rolling, 1.963e8 Pa without)."""
    from grainmech.lammps.probes import strain_probes
    from grainmech.lammps.rolling import rolling_of_network

    net = load_packing("dense")
    consts = rolling_of_network(RollingResistance(0.1), QUARTZ, net)
    pr = strain_probes(net, QUARTZ, components=[5], rolling=consts, threads=1)
    ref = pr.network
    assert ref.moment is not None and np.abs(ref.moment).max() > 0
    kn, ks, _ = contact_stiffnesses(ref, shear_modulus=G, poisson=NU, source="overlap")
    C = relaxed_stiffness(ref, kn, ks, rolling=consts).C_relaxed
    C0 = relaxed_stiffness(ref, kn, ks).C_relaxed
    assert pr.C[5, 5] == pytest.approx(C[5, 5], rel=0.01)
    assert pr.C[5, 5] > 1.15 * C0[5, 5]  # LAMMPS sees the rolling springs too
    # the whole column, to 1 % of its diagonal
    assert np.abs(pr.C[:, 5] - C[:, 5]).max() < 0.01 * C[5, 5]

"""Measures, affine and relaxed stiffness of contact networks (grainmech.network)."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from _hyp import HealthCheck, assume, given, settings, st
from grainmech.errors import GrainmechError
from grainmech.network import (
    Box,
    ContactNetwork,
    affine_stiffness,
    contact_stiffnesses,
    coordination,
    lattice_network,
    network_fabric,
    network_stress,
    random_network,
    rattler_threshold,
    rattlers,
    relaxed_stiffness,
    tile_network,
)

G, NU = 29e9, 0.15


def hertz_kn_ks(R1, R2, overlap, G=G, nu=NU):
    """Independent Hertz-Mindlin tangent stiffnesses (Johnson 1985 Eq. 4.22, 7.42)."""
    E = 2 * G * (1 + nu)
    Es = 1.0 / (2 * (1 - nu ** 2) / E)
    Gs = 1.0 / (2 * (2 - nu) / G)
    Rs = R1 * R2 / (R1 + R2)
    a = np.sqrt(Rs * overlap)
    return 2 * Es * a, 8 * Gs * a


# ---------------------------------------------------------------- lattices: analytic values

@pytest.mark.parametrize("kind", ["sc", "fcc"])
def test_lattice_relaxed_equals_affine_equals_analytic(kind):
    R, dl = 1.0, 2e-3
    net = lattice_network(kind, 3, R, dl, shear_modulus=G, poisson=NU)
    kn, ks, used = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    assert used == "overlap"
    kn0, ks0 = hertz_kn_ks(R, R, dl)
    np.testing.assert_allclose(kn, kn0, rtol=1e-12)
    np.testing.assert_allclose(ks, ks0, rtol=1e-12)
    d = 2 * R - dl  # nearest-neighbour distance
    ref = np.zeros((6, 6))
    if kind == "sc":
        # C11 = kn/a, C12 = 0, C44 = ks/(2a), a = d
        ref[:3, :3] = np.eye(3) * kn0 / d
        ref[3:, 3:] = np.eye(3) * ks0 / (2 * d)
    else:
        # cube edge a = sqrt(2) d, 4 particles and 24 contacts per cube:
        # C11 = 2(kn+ks)/a, C12 = (kn-ks)/a, C44 = (kn+ks)/a
        a = np.sqrt(2) * d
        ref[:3, :3] = (kn0 - ks0) / a
        ref[[0, 1, 2], [0, 1, 2]] = 2 * (kn0 + ks0) / a
        ref[3:, 3:] = np.eye(3) * (kn0 + ks0) / a
    Ca = affine_stiffness(net, kn, ks)
    res = relaxed_stiffness(net, kn, ks, solver="direct")
    res_cg = relaxed_stiffness(net, kn, ks, solver="cg")
    scale = np.abs(ref).max()
    np.testing.assert_allclose(Ca, ref, atol=1e-10 * scale)
    np.testing.assert_allclose(res.C_affine, ref, atol=1e-10 * scale)
    np.testing.assert_allclose(res.C_relaxed, ref, atol=1e-9 * scale)
    np.testing.assert_allclose(res_cg.C_relaxed, ref, atol=1e-9 * scale)
    assert res.n_rattlers == 0


def test_affine_matches_direct_tensor_sum():
    net = random_network(150, seed=3)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    n, l_ = net.normals, net.branch
    C4 = np.zeros((3, 3, 3, 3))
    for c in range(net.n_contacts):
        K = kn[c] * np.outer(n[c], n[c]) + ks[c] * (np.eye(3) - np.outer(n[c], n[c]))
        C4 += np.einsum("ik,j,l->ijkl", K, l_[c], l_[c])
    C4 /= net.volume
    C4 = 0.25 * (C4 + C4.transpose(1, 0, 2, 3) + C4.transpose(0, 1, 3, 2) + C4.transpose(1, 0, 3, 2))
    pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    ref = np.array([[C4[i, j, k, l] for k, l in pairs] for i, j in pairs])
    np.testing.assert_allclose(affine_stiffness(net, kn, ks), ref, rtol=1e-10, atol=1e-12 * ref.max())
    res = relaxed_stiffness(net, kn, ks, remove_rattlers=False)
    np.testing.assert_allclose(res.C_affine, ref, rtol=1e-10, atol=1e-12 * ref.max())


def test_geometric_term_sc_shear():
    """With the geometric term, ks -> ks - N/|l|: C44 of the sc lattice = (ks - N/d)/(2d)."""
    net = lattice_network("sc", 3, 1.0, 1e-3)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    d = 2.0 - 1e-3
    N = net.normal_force[0]
    C = affine_stiffness(net, kn, ks, geometric=True)
    np.testing.assert_allclose(C[3, 3], (ks[0] - N / d) / (2 * d), rtol=1e-10)
    np.testing.assert_allclose(C[0, 0], kn[0] / d, rtol=1e-10)


# ---------------------------------------------------------------- relaxed: independent reference

def _energy_hessian_reference(net, kn, ks):
    """Relaxed stiffness by brute force: quadratic energy evaluated with np.cross, Hessian by
    polarisation, dense pseudo-inverse. Independent of the sparse assembly."""
    P, C = net.n_particles, net.n_contacts
    n = net.normals
    rA = net.radii[net.i][:, None] * n
    rB = -net.radii[net.j][:, None] * n
    V = net.volume

    def delta(q, eps):
        u = q[: 3 * P].reshape(P, 3)
        th = q[3 * P:].reshape(P, 3)
        return (net.branch @ eps.T + u[net.i] - u[net.j]
                + np.cross(th[net.i], rA) - np.cross(th[net.j], rB))

    def energy(q, eps):
        D = delta(q, eps)
        Dn = np.einsum("ij,ij->i", D, n)
        Dt = D - Dn[:, None] * n
        return 0.5 * np.sum(kn * Dn ** 2 + ks * np.einsum("ij,ij->i", Dt, Dt)) / V

    nd = 6 * P
    units = []
    for a, (i, j) in enumerate([(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]):
        e = np.zeros((3, 3))
        e[i, j] = e[j, i] = 1.0 if i == j else 0.5
        units.append(e)
    # quadratic form in z = (q, e): energy(z) = 1/2 z^T M z; M by polarisation
    nz = nd + 6

    def en(z):
        eps = sum(z[nd + a] * units[a] for a in range(6))
        return energy(z[:nd], eps)

    I = np.eye(nz)
    diag = np.array([en(I[k]) for k in range(nz)])
    M = np.zeros((nz, nz))
    for a in range(nz):
        for b in range(a + 1, nz):
            M[a, b] = M[b, a] = en(I[a] + I[b]) - diag[a] - diag[b]
    M[np.arange(nz), np.arange(nz)] = 2 * diag
    H, B, A = M[:nd, :nd], M[:nd, nd:], M[nd:, nd:]
    return A, A - B.T @ np.linalg.pinv(H, rcond=1e-10) @ B


def test_relaxed_matches_bruteforce_energy_minimisation():
    net = random_network(14, coordination=8.0, seed=11)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    A_ref, C_ref = _energy_hessian_reference(net, kn, ks)
    res = relaxed_stiffness(net, kn, ks, remove_rattlers=False, solver="direct")
    s = np.abs(A_ref).max()
    np.testing.assert_allclose(res.C_affine, A_ref, atol=1e-8 * s)
    np.testing.assert_allclose(res.C_relaxed, C_ref, atol=1e-7 * s)
    assert np.abs(res.correction).max() > 1e-3 * s  # the disorder does relax


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10 ** 6), z=st.floats(4.5, 9.0), ratio=st.floats(0.0, 1.5),
       rot=st.booleans())
def test_relaxed_no_stiffer_than_affine(seed, z, ratio, rot):
    net = random_network(60, coordination=z, seed=seed)
    rng = np.random.default_rng(seed)
    kn = rng.uniform(0.5, 2.0, net.n_contacts) * 1e6
    ks = ratio * kn * rng.uniform(0.5, 1.0, net.n_contacts)
    try:
        res = relaxed_stiffness(net, kn, ks, rotations=rot)
    except GrainmechError as exc:  # a small frictionless network can be all rattlers
        assert "nothing is left to solve" in str(exc)
        assume(False)
    # affine of the full network >= affine of the rattler-free network >= relaxed
    Cfull = affine_stiffness(net, kn, ks)
    for D in (res.correction, Cfull - res.C_relaxed):
        ev = np.linalg.eigvalsh(0.5 * (D + D.T))
        assert ev.min() >= -1e-9 * np.abs(Cfull).max()
    assert res.residual < 1e-6


def test_cg_matches_direct_and_displacements_equilibrate():
    net = random_network(200, seed=5)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    a = relaxed_stiffness(net, kn, ks, solver="direct", return_displacements=True)
    b = relaxed_stiffness(net, kn, ks, solver="cg", tol=1e-11)
    np.testing.assert_allclose(b.C_relaxed, a.C_relaxed, atol=1e-7 * np.abs(a.C_affine).max())
    # net force and moment on every particle vanish for the relaxed field (unit e_xx)
    q = a.displacements[:, :, 0]
    n = net.normals
    rA, rB = net.radii[net.i][:, None] * n, -net.radii[net.j][:, None] * n
    e = np.diag([1.0, 0, 0])
    D = net.branch @ e.T + q[net.i, :3] - q[net.j, :3] + np.cross(q[net.i, 3:], rA) - np.cross(q[net.j, 3:], rB)
    Dn = np.einsum("ij,ij->i", D, n)
    f = kn[:, None] * Dn[:, None] * n + ks[:, None] * (D - Dn[:, None] * n)
    ratt = rattlers(net, rattler_threshold(3, frictional=True), (kn > 0) & (net.normal_force > 0))
    keep = ~ratt[net.i] & ~ratt[net.j]
    F = np.zeros((net.n_particles, 3))
    M = np.zeros((net.n_particles, 3))
    np.add.at(F, net.j[keep], f[keep])
    np.add.at(F, net.i[keep], -f[keep])
    np.add.at(M, net.j[keep], np.cross(rB[keep], f[keep]))
    np.add.at(M, net.i[keep], np.cross(rA[keep], -f[keep]))
    fscale = np.abs(f).max()
    assert np.abs(F).max() < 1e-7 * fscale
    assert np.abs(M).max() < 1e-7 * fscale * net.radii.max()


def test_frictionless_rotations_are_floppy_but_harmless():
    net = random_network(80, seed=7)
    kn, _, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    ks = np.zeros_like(kn)
    a = relaxed_stiffness(net, kn, ks, rotations=True)
    b = relaxed_stiffness(net, kn, ks, rotations=False)
    np.testing.assert_allclose(a.C_relaxed, b.C_relaxed, atol=1e-7 * np.abs(a.C_affine).max())


# ---------------------------------------------------------------- stress, fabric, coordination

def test_stress_direct_sum_and_skew():
    net = random_network(120, seed=2)
    st_ = network_stress(net)
    full = sum(np.outer(f, l_) for f, l_ in zip(net.force, net.branch)) / net.volume
    np.testing.assert_allclose(st_.stress, 0.5 * (full + full.T), rtol=1e-12)
    np.testing.assert_allclose(st_.skew, 0.5 * (full - full.T), rtol=1e-12, atol=1e-12 * np.abs(full).max())
    assert st_.skew_ratio > 1e-4  # random tangential forces: not in moment equilibrium
    lat = lattice_network("fcc", 3, 1.0, 1e-3)
    s2 = network_stress(lat)
    assert s2.skew_ratio < 1e-14
    # isotropic pressure of the fcc lattice: p = (C/V) N d / 3, compression positive
    N = lat.normal_force[0]
    p_ref = lat.n_contacts / lat.volume * N * (2 - 1e-3) / 3
    np.testing.assert_allclose(s2.stress, np.eye(3) * p_ref, rtol=1e-12, atol=1e-12 * p_ref)
    assert s2.mean > 0


def test_fabric_tensors():
    net = random_network(200, seed=4)
    fab = network_fabric(net)
    n = net.normals
    np.testing.assert_allclose(fab.normal2, n.T @ n / len(n), rtol=1e-12)
    np.testing.assert_allclose(fab.normal4, np.einsum("ci,cj,ck,cl->ijkl", n, n, n, n) / len(n), rtol=1e-12)
    l_ = net.branch
    np.testing.assert_allclose(fab.branch2, l_.T @ l_ / np.sum(l_ * l_), rtol=1e-12)
    lat = network_fabric(lattice_network("sc", 3, 1.0, 1e-3))
    np.testing.assert_allclose(lat.normal2, np.eye(3) / 3, atol=1e-15)
    assert lat.normal_anisotropy.deviator_norm < 1e-12


def _chain_network():
    """Cube corner cluster: 5 particles mutually touching (each has 4 contacts) plus a
    2-particle tail (a - b) attached to particle 0; the tail are rattlers."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [-1, 0, 0], [-2, 0, 0.]]) * 2.0
    pairs = [(a, b) for a, b in itertools.combinations(range(5), 2)] + [(0, 5), (5, 6)]
    I = np.array([p[0] for p in pairs])
    J = np.array([p[1] for p in pairs])
    box = Box.orthogonal([-10] * 3, [10] * 3, False)
    br = pos[J] - pos[I]
    f = br / np.linalg.norm(br, axis=1)[:, None]
    f[-1] *= 0.0  # the last contact carries no force
    return ContactNetwork(np.arange(7) + 10, pos, np.ones(7), box, I, J, f, br)


def test_coordination_and_rattlers():
    net = _chain_network()
    co = coordination(net)
    assert co.n_contacts == 12 and co.n_force_carrying == 11
    np.testing.assert_allclose(co.z, 24 / 7)
    np.testing.assert_allclose(co.z_force, 22 / 7)
    # particles 5 and 6 are rattlers (1 and 0 force-carrying contacts), the 5-clique keeps z = 4
    np.testing.assert_array_equal(rattlers(net), [False] * 5 + [True] * 2)
    np.testing.assert_allclose(co.z_mechanical, 4.0)
    assert co.n_rattlers == 2
    # with a threshold of 5 the removal cascades to everything
    assert coordination(net, min_contacts=5).z_mechanical == 0.0


def test_contact_stiffness_sources():
    net = random_network(50, seed=8)
    kn_o, ks_o, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU, source="overlap")
    kn_f, ks_f, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU, source="force")
    # forces were made from the same overlaps by Hertz (tangential part does not change N)
    np.testing.assert_allclose(kn_f, kn_o, rtol=1e-10)
    ref = hertz_kn_ks(net.radii[net.i], net.radii[net.j], net.overlap)
    np.testing.assert_allclose(kn_o, ref[0], rtol=1e-12)
    np.testing.assert_allclose(ks_o, ref[1], rtol=1e-12)
    kn_c, ks_c, used = contact_stiffnesses(net, kn=3.0, ks=2.0)
    assert used == "constant" and np.all(kn_c == 3.0) and np.all(ks_c == 2.0)
    with pytest.raises(GrainmechError, match="shear_modulus"):
        contact_stiffnesses(net, source="overlap")


def test_2d_square_lattice_and_perturbed():
    """Square lattice of discs (spacing a): C11 = C22 = kn, C12 = 0, C66 = ks/2 (per unit
    thickness); a perturbed copy relaxes (affine - relaxed PSD, non-zero)."""
    n, a = 4, 1.3
    pos = np.array([[i * a, j * a] for i in range(n) for j in range(n)], float)
    idx = lambda i, j: (i % n) * n + (j % n)  # noqa: E731
    I = np.array([idx(i, j) for i in range(n) for j in range(n) for _ in (0, 1)])
    J = np.array([idx(i + 1, j) if k == 0 else idx(i, j + 1) for i in range(n) for j in range(n) for k in (0, 1)])
    box = Box.orthogonal([0, 0], [n * a, n * a], True)
    kn, ks = np.full(I.size, 3.0), np.full(I.size, 1.0)
    for noise in (0.0, 0.1):
        p = pos + np.random.default_rng(0).normal(scale=noise, size=pos.shape)
        br = box.minimum_image(p[J] - p[I])
        net = ContactNetwork(np.arange(n * n), p, np.full(n * n, 0.5 * a), box, I, J, br.copy(), br)
        res = relaxed_stiffness(net, kn, ks)
        if noise == 0.0:
            np.testing.assert_allclose(affine_stiffness(net, kn, ks), np.diag([3.0, 3.0, 0.5]), atol=1e-12)
            np.testing.assert_allclose(res.C_relaxed, np.diag([3.0, 3.0, 0.5]), atol=1e-10)
        else:
            ev = np.linalg.eigvalsh(res.correction)
            assert ev.min() >= -1e-12 and ev.max() > 1e-3


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 10 ** 6))
def test_relaxed_stiffness_is_objective(seed):
    """Rotating the whole network (centres, cell, forces) rotates both tensors (seed Eq. 2.28-2.29)."""
    from scipy.spatial.transform import Rotation

    from grainmech.elasticity import rotate_stiffness

    net = random_network(50, seed=seed)
    R = Rotation.random(random_state=seed).as_matrix()
    box = Box(net.box.origin @ R.T, net.box.cell @ R.T, net.box.periodic)
    rot = ContactNetwork(net.ids, net.positions @ R.T, net.radii, box, net.i, net.j, net.force @ R.T,
                         net.branch @ R.T, net.overlap)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    a = relaxed_stiffness(net, kn, ks)
    b = relaxed_stiffness(rot, kn, ks)
    s = np.abs(a.C_affine).max()
    np.testing.assert_allclose(b.C_affine, rotate_stiffness(a.C_affine, R), atol=1e-10 * s)
    np.testing.assert_allclose(b.C_relaxed, rotate_stiffness(a.C_relaxed, R), atol=1e-8 * s)


def test_report_closed_form_isotropic_for_cubic_lattice():
    """FCC contacts have an isotropic 2nd-order fabric: the seed closed form reduces to
    C11 = s(3kn+2ks)/15, C12 = s(kn-ks)/15, C44 = s(2kn+3ks)/30 with s = (C/V) d^2."""
    from grainmech.network import network_report

    dl = 1e-3
    net = lattice_network("fcc", 3, 1.0, dl)
    rep = network_report(net, shear_modulus=G, poisson=NU, relaxed=False)
    kn, ks = hertz_kn_ks(1.0, 1.0, dl)
    s = net.n_contacts / net.volume * (2 - dl) ** 2
    C = rep.stiffness_closed_form
    np.testing.assert_allclose(np.diag(C), [s * (3 * kn + 2 * ks) / 15] * 3 + [s * (2 * kn + 3 * ks) / 30] * 3,
                               rtol=1e-9)
    np.testing.assert_allclose(C[0, 1], s * (kn - ks) / 15, rtol=1e-9)
    assert rep.relaxed is None
    js = rep.to_json()
    for key in ("stress", "fabric", "coordination", "stiffness_affine", "order"):
        assert key in js
    assert js["stiffness_relaxed"] is None
    np.testing.assert_array_equal(np.array(js["stiffness_closed_form"]), C)
    json.dumps(js, allow_nan=False)  # plain JSON: lists, floats, None


def test_equal_area_density_plot_is_normalised():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from grainmech.plots import plot_normal_density, plot_rose

    rng = np.random.default_rng(0)
    n = rng.normal(size=(40000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    P = 2 * len(n)
    pos = rng.random((P, 3)) * 100
    I, J = np.arange(0, P, 2), np.arange(1, P, 2)
    pos[J] = pos[I] + 2 * n
    box = Box.orthogonal([-10] * 3, [110] * 3, False)
    net = ContactNetwork(np.arange(P), pos, np.ones(P), box, I, J, n, 2 * n)
    fig = plot_normal_density(net)
    mesh = fig.axes[0].collections[0]
    vals = mesh.get_array()
    assert abs(float(vals.mean()) - 1.0) < 0.03  # uniform on the sphere -> density 1 everywhere
    # no bias at the rim (cells cut by the projection circle are normalised by their inside area)
    c = mesh.get_coordinates()  # (bins+1, bins+1, 2) corners
    mid = 0.25 * (c[:-1, :-1] + c[1:, :-1] + c[:-1, 1:] + c[1:, 1:])
    r = np.hypot(mid[..., 0], mid[..., 1]).ravel()
    v = np.ma.asarray(vals).ravel()
    rim = (r > 1.2) & ~np.ma.getmaskarray(v)
    assert rim.sum() > 50 and abs(float(v[rim].mean()) - 1.0) < 0.06
    plt.close(fig)
    plt.close(plot_rose(net))


def test_rattler_rule_follows_the_contact_law_on_a_loose_frictional_network():
    """A loose frictional network (z = 4.2): the frictionless rule (fewer than d + 1 = 4
    contacts, removed iteratively) strips most grains, the frictional rule (2 contacts with
    rotations; Thornton 2000) keeps them, and the relaxed tensor is not zero."""
    from grainmech.network import contact_stiffnesses, random_network, rattler_threshold, rattlers, relaxed_stiffness

    net = random_network(400, coordination=4.2, seed=3)
    assert rattler_threshold(3, frictional=True) == 2
    assert rattler_threshold(3, frictional=False) == 4
    assert rattler_threshold(3, frictional=True, rotations=False) == 4
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
    frictionless_rule = rattlers(net, 4).mean()
    frictional_rule = rattlers(net, 2).mean()
    assert frictionless_rule > 0.5 and frictional_rule < 0.2, (frictionless_rule, frictional_rule)
    rr = relaxed_stiffness(net, kn, ks)
    assert rr.n_rattlers == int(rattlers(net, 2).sum())
    assert rr.C_relaxed[3, 3] > 0 and rr.C_relaxed[0, 0] > 0


def test_relaxed_stiffness_with_nothing_left_is_an_error_not_zeros():
    from grainmech.errors import GrainmechError
    from grainmech.network import contact_stiffnesses, random_network, relaxed_stiffness

    net = random_network(200, coordination=3.0, seed=1)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
    with pytest.raises(GrainmechError, match=r"nothing is left to solve - 200 of 200 particles are "
                                             r"rattlers \(fewer than 20 force-carrying"):
        relaxed_stiffness(net, kn, ks, min_contacts=20)


def test_frictionless_loose_network_names_the_rule_that_removed_everything():
    """Frictionless contacts (ks = 0) need d + 1 = 4 contacts (rattler_threshold); in this
    network with z = 2 iterated removal leaves no grain with 4 contacts, so the error names
    the rule and its cause instead of returning zeros; the frictional rule (2) keeps about
    half of the grains."""
    from grainmech.errors import GrainmechError
    from grainmech.network import contact_stiffnesses, random_network, rattlers, relaxed_stiffness

    net = random_network(300, coordination=2.0, seed=3)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
    assert rattlers(net, 4).all() and rattlers(net, 2).mean() < 0.6
    with pytest.raises(GrainmechError, match=r"300 of 300 particles are rattlers \(fewer than 4 force-"
                                             r"carrying contacts, the frictionless rule: no contact has "
                                             r"ks > 0"):
        relaxed_stiffness(net, kn, np.zeros_like(ks))
    # the same network with its tangential stiffness keeps grains (frictional rule: 2)
    rr = relaxed_stiffness(net, kn, ks)
    assert rr.n_particles > 0 and rr.C_affine[0, 0] > 0
    # what is kept is a mechanism at z = 2: its relaxed stiffness is zero, to rounding
    # (its sign is that of the rounding errors, about 1e-13 of the affine one)
    assert np.abs(rr.C_relaxed).max() < 1e-9 * np.abs(rr.C_affine).max()


def test_every_installed_solver_gives_the_same_relaxed_tensor():
    """PARDISO, CHOLMOD, SuperLU, AMG-CG and block CG solve the same system H q = -B
    (Lemaitre & Maloney 2006, Eq. 12): same C_relaxed, each reporting the solver that ran
    and a residual below the tolerance; ``auto`` runs a direct method when one is installed."""
    from grainmech.network import _solvers

    net = random_network(100, seed=5)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    ref = relaxed_stiffness(net, kn, ks, solver="superlu")
    for s in ("pardiso", "cholesky", "amg", "cg"):
        if not _solvers.available(s):
            continue
        r = relaxed_stiffness(net, kn, ks, solver=s, maxiter=50000)
        # AMG-CG solves the shifted system without refinement: its residual against H is
        # what relaxed_stiffness accepts (<= 1e-6), the others reach the default tol 1e-7
        assert r.solver == s and r.residual <= (1e-6 if s == "amg" else 1e-7)
        np.testing.assert_allclose(r.C_relaxed, ref.C_relaxed, rtol=0,
                                   atol=(1e-6 if s == "amg" else 1e-9) * np.abs(ref.C_relaxed).max())
    auto = relaxed_stiffness(net, kn, ks)
    assert auto.solver in ("cg", _solvers.choose("auto", 6 * auto.n_particles))
    np.testing.assert_allclose(auto.C_relaxed, ref.C_relaxed, rtol=0, atol=1e-9 * np.abs(ref.C_relaxed).max())


def test_auto_uses_cg_on_a_packing_and_a_factorisation_when_cg_would_be_slow(monkeypatch):
    """auto: block CG when its early convergence rate predicts few iterations (the
    fcc lattice converges at once), a factorisation when it predicts many."""
    from grainmech.network import _solvers
    from grainmech.network import relaxed as rel

    net = lattice_network("fcc", 3, 1.0, 1e-3)
    kn = np.full(net.n_contacts, 1.0e6)
    ks = np.full(net.n_contacts, 0.4e6)
    assert relaxed_stiffness(net, kn, ks).solver == "cg"
    rnet = random_network(100, seed=5)
    kn, ks, _ = contact_stiffnesses(rnet, shear_modulus=G, poisson=NU)
    monkeypatch.setattr(rel, "AUTO_CG_MAXITER", 5)
    r = relaxed_stiffness(rnet, kn, ks)
    assert r.solver == _solvers.choose("auto", 6 * r.n_particles) and r.residual <= 1e-7


@pytest.mark.parametrize("cell", [None, np.array([[9.0, 0, 0], [2.0, 8.5, 0], [1.0, -1.5, 10.0]])],
                         ids=["cube", "triclinic"])
def test_a_tiled_packing_is_the_same_material(cell):
    """tile_network: 2 x 1 x 2 copies of a periodic random network (a cube, a triclinic cell)
    have 4x the grains and contacts, the same Love-Weber stress (Eq. 2.6), fabric and affine
    tensor (the same contacts per volume), and the same relaxed tensor: the fluctuation
    that solves the small cell solves the large one. The contact ends are checked against
    an independent minimum-image search in the large box."""
    net = random_network(300 if cell is None else 150, seed=3, cell=cell)
    big = tile_network(net, (2, 1, 2))
    assert big.n_particles == 4 * net.n_particles and big.n_contacts == 4 * net.n_contacts
    np.testing.assert_allclose(big.box.volume, 4 * net.box.volume, rtol=1e-14)
    # every contact's branch vector joins the grains it names (nearest image in the big box)
    d = big.positions[big.j] - big.positions[big.i]
    f = d @ np.linalg.inv(big.box.cell)
    d = (f - np.round(f)) @ big.box.cell
    np.testing.assert_allclose(d, big.branch, atol=1e-9)
    assert len(np.unique(big.ids)) == big.n_particles
    np.testing.assert_allclose(network_stress(big).stress, network_stress(net).stress, rtol=1e-12)
    np.testing.assert_allclose(network_fabric(big).normal4, network_fabric(net).normal4, rtol=1e-12, atol=1e-15)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G, poisson=NU)
    kb, sb, _ = contact_stiffnesses(big, shear_modulus=G, poisson=NU)
    np.testing.assert_allclose(affine_stiffness(big, kb, sb), affine_stiffness(net, kn, ks), rtol=1e-12)
    small = relaxed_stiffness(net, kn, ks, solver="superlu")
    large = relaxed_stiffness(big, kb, sb, solver="superlu")
    np.testing.assert_allclose(large.C_relaxed, small.C_relaxed, rtol=0, atol=1e-9 * np.abs(small.C_relaxed).max())
    with pytest.raises(GrainmechError, match=r"reps must be 3 positive integers, got \(2, 0, 1\)"):
        tile_network(net, (2, 0, 1))


def test_reordered_cg_in_parts_gives_the_same_tensor(monkeypatch):
    """The compiled CG on a large network: grains renumbered by reverse Cuthill-McKee, the
    contacts split between three parts (threads) and the contacts between parts. On 2 x 2
    x 1 copies of the 'dense' packing (jittered contact stiffnesses, so that the solve is
    not periodic) it takes the iterations of the plain one-part CG and gives its tensor;
    unjittered it gives the single packing's tensor (tiling invariance)."""
    kernel = pytest.importorskip("grainmech.network._cg_kernel")
    from grainmech.network import relaxed as rel
    from grainmech.packing import load_packing

    base = load_packing("dense")
    big = tile_network(base, (2, 2, 1))
    kn, ks, _ = contact_stiffnesses(big, shear_modulus=G, poisson=NU)
    f = np.random.default_rng(0).uniform(0.5, 1.5, big.n_contacts)
    plain = relaxed_stiffness(big, kn * f, ks * f, solver="cg", tol=1e-10, return_displacements=True)
    monkeypatch.setattr(rel, "CG_REORDER_GRAINS", 1000)
    monkeypatch.setattr(rel, "_thread_parts", lambda P: 3)
    calls = []
    real = kernel.block_cg3_parts
    monkeypatch.setattr(kernel, "block_cg3_parts", lambda *a: calls.append(a[-2]) or real(*a))
    parts = relaxed_stiffness(big, kn * f, ks * f, solver="cg", tol=1e-10, return_displacements=True)
    assert calls and len(calls[0]) == 4 and calls[0][-1] == big.n_particles - parts.n_rattlers
    assert abs(parts.iterations - plain.iterations) <= 2 and parts.residual <= 1e-10
    np.testing.assert_allclose(parts.C_relaxed, plain.C_relaxed, rtol=0, atol=1e-11 * np.abs(plain.C_relaxed).max())
    # the grains' displacements come back in the network's own numbering
    d0 = plain.displacements
    np.testing.assert_allclose(parts.displacements, d0, rtol=0, atol=1e-6 * np.abs(d0).max())
    kb, sb, _ = contact_stiffnesses(base, shear_modulus=G, poisson=NU)
    one = relaxed_stiffness(base, kb, sb, solver="cg")
    tiled = relaxed_stiffness(big, kn, ks, solver="cg")
    np.testing.assert_allclose(tiled.C_relaxed, one.C_relaxed, rtol=0, atol=1e-11 * np.abs(one.C_relaxed).max())


def test_network_checks_name_the_row_across_blocks(monkeypatch):
    """ContactNetwork checks its arrays in blocks of rows: a bad value in a later block is
    still reported with its own row (blocks of 7 rows here)."""
    from grainmech.network import data as netdata

    monkeypatch.setattr(netdata, "_CHECK_BLOCK", 7)
    net = lattice_network("sc", 3, 1.0, 1e-3)
    assert net.n_contacts > 30

    def with_(**kw):
        a = {k: getattr(net, k) for k in ("ids", "positions", "radii", "box", "i", "j", "force", "branch",
                                          "overlap", "contact_point", "kn", "ks", "source")}
        a.update(kw)
        return ContactNetwork(**a)

    f = net.force.copy()
    f[23, 2] = np.nan
    with pytest.raises(GrainmechError, match="force has a non-finite value at row 23"):
        with_(force=f)
    b = net.branch.copy()
    b[17] = 0.0
    with pytest.raises(GrainmechError, match=rf"contact 17 \({net.ids[net.i[17]]}-{net.ids[net.j[17]]}\) has a "
                                             "zero branch vector"):
        with_(branch=b)
    with_()  # the unchanged arrays pass

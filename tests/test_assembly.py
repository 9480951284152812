"""Assembly: stiffness (seed Eq. 2.26, 2.41) and Love-Weber stress (Eq. 2.6-2.7)."""

import numpy as np
import pytest

from _hyp import given, settings, st
from grainmech import assembly
from grainmech.assembly import ContactSet, love_weber_stress, stiffness, stiffness_tensor
from grainmech.conventions import tensor4_to_matrix
from grainmech.errors import GrainmechError


def _unit(rng, n, d):
    v = rng.normal(size=(n, d))
    return v / np.linalg.norm(v, axis=1)[:, None]


def _brute_force(n, l_, w, kn, ks):
    """Seed Eq. 2.26 written literally: C_lqkp = sum w r_q T_li K_ij T_jk r_p, symmetrised."""
    d = n.shape[1]
    C = np.zeros((d, d, d, d))
    for c in range(n.shape[0]):
        # local basis (n, s, t): rows of T (Eq. 2.18)
        basis = np.linalg.svd(n[c][None, :])[2]  # first row is +-n, rest span the tangent plane
        basis[0] = n[c]
        Kloc = np.diag([kn[c]] + [ks[c]] * (d - 1))
        K = basis.T @ Kloc @ basis
        C += w[c] * np.einsum("lk,q,p->lqkp", K, l_[c], l_[c])
    C = 0.5 * (C + C.transpose(1, 0, 2, 3))
    return 0.5 * (C + C.transpose(0, 1, 3, 2))


@pytest.mark.parametrize("d", [2, 3])
def test_kernel_equals_literal_eq_2_26(d):
    rng = np.random.default_rng(11)
    n = _unit(rng, 200, d)
    l_ = rng.normal(size=(200, d))  # general (non-parallel) vectors
    w, kn, ks = rng.random(200), rng.random(200), rng.random(200)
    ref = tensor4_to_matrix(_brute_force(n, l_, w, kn, ks))
    for backend in ["numpy"] + (["numba"] if assembly.numba_available() else []):
        got = stiffness(ContactSet(n, l_, w, kn, ks), backend=backend)
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())


@pytest.mark.skipif(not assembly.numba_available(), reason="numba not installed")
@pytest.mark.parametrize("d", [2, 3])
def test_numba_kernel_agrees_with_numpy_on_large_sets(d):
    rng = np.random.default_rng(5)
    m = 300_001  # not a multiple of the chunk sizes
    n = _unit(rng, m, d)
    cs = ContactSet(n, n * (1 + rng.random(m))[:, None], rng.random(m), rng.random(m), rng.random(m))
    a = stiffness(cs, backend="numpy")
    b = stiffness(cs, backend="numba")
    np.testing.assert_allclose(b, a, rtol=1e-11)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 60), st.integers(0, 2**31 - 1), st.sampled_from([2, 3]))
def test_symmetric_and_positive_semidefinite(m, seed, d):
    rng = np.random.default_rng(seed)
    n = _unit(rng, m, d)
    C = stiffness(ContactSet(n, n * rng.uniform(0.5, 2, m)[:, None], rng.random(m), rng.random(m), rng.random(m)))
    np.testing.assert_allclose(C, C.T, atol=1e-14 * max(1, np.abs(C).max()))
    Cm = stiffness(ContactSet(n, n * 1.0, rng.random(m), rng.random(m), rng.random(m)), mandel=True)
    assert np.linalg.eigvalsh(Cm).min() >= -1e-12 * np.abs(Cm).max()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_objectivity_rotating_the_contacts_rotates_the_tensor(seed):
    """Seed Eq. 2.28-2.29: C(Q n, Q l) = Q Q C Q Q."""
    rng = np.random.default_rng(seed)
    m = 40
    n = _unit(rng, m, 3)
    l_ = n * rng.uniform(0.5, 2, m)[:, None]
    w, kn, ks = rng.random(m), rng.random(m), rng.random(m)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    C = stiffness_tensor(ContactSet(n, l_, w, kn, ks))
    Cr = stiffness_tensor(ContactSet(n @ Q.T, l_ @ Q.T, w, kn, ks))
    expect = np.einsum("ia,jb,kc,ld,abcd->ijkl", Q, Q, Q, Q, C)
    np.testing.assert_allclose(Cr, expect, atol=1e-12 * np.abs(C).max())


def test_counting_convention_seed_is_half_of_physical_for_equal_spheres():
    """Each contact twice with r = +-rho n (seed Eq. 2.6, 2.26) vs once with l = 2 rho n.

    Same forces -> same stress; same contact law -> the seed's sum gives exactly half the
    stiffness (docs/seed-errata.md, E-2.26).
    """
    rng = np.random.default_rng(3)
    m, rho, V = 500, 0.7, 123.0
    n = _unit(rng, m, 3)
    kn, ks = rng.random(m), rng.random(m)
    force = (rng.random(m) + 0.5)[:, None] * n + 0.1 * rng.normal(size=(m, 3))
    phys = ContactSet(n, 2 * rho * n, 1 / V, kn, ks)
    # particle A sees r = +rho n and exerts +f on B; particle B sees r = -rho n and exerts -f on A
    seed = ContactSet(np.vstack([n, -n]), np.vstack([rho * n, -rho * n]), 1 / V,
                      np.concatenate([kn, kn]), np.concatenate([ks, ks]), convention="seed")
    s_phys = love_weber_stress(force, phys.branch, phys.weights)
    s_seed = love_weber_stress(np.vstack([force, -force]), seed.branch, seed.weights)
    np.testing.assert_allclose(s_seed.stress, s_phys.stress, rtol=1e-13)
    np.testing.assert_allclose(stiffness(seed), 0.5 * stiffness(phys), rtol=1e-13)


def test_love_weber_isotropic_and_skew_part():
    rng = np.random.default_rng(9)
    m, ell, V, N = 4000, 2.0, 10.0, 3.0
    n = _unit(rng, m, 3)
    n = np.vstack([n, -n])  # centro-symmetric set
    res = love_weber_stress(N * n, ell * n, 1 / V)
    # sum_c N l n n / V: trace = N l (2m) / V
    assert np.trace(res.stress) == pytest.approx(N * ell * 2 * m / V)
    assert res.skew_ratio < 1e-14
    # a pure tangential force at one contact gives a skew part (Eq. 2.7)
    t = np.cross(n[0], [0, 0, 1.0])
    r1 = love_weber_stress(t[None, :], n[:1], 1.0)
    np.testing.assert_allclose(r1.skew, 0.5 * (np.outer(t, n[0]) - np.outer(n[0], t)), atol=1e-15)


def test_contact_set_validation_names_the_field():
    n = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    with pytest.raises(GrainmechError, match="normals must be unit vectors; row 1"):
        ContactSet(np.array([[1.0, 0, 0], [0, 2.0, 0]]), n, 1.0, 1.0, 1.0)
    with pytest.raises(GrainmechError, match="ks must be >= 0; row 0"):
        ContactSet(n, n, 1.0, 1.0, [-1.0, 1.0])
    with pytest.raises(GrainmechError, match="weights has a non-finite value at contact 1"):
        ContactSet(n, n, [1.0, np.nan], 1.0, 1.0)
    with pytest.raises(GrainmechError, match="branch must have the shape"):
        ContactSet(n, n[:, :2], 1.0, 1.0, 1.0)
    with pytest.raises(GrainmechError, match="shape"):
        ContactSet(np.ones(3), n, 1.0, 1.0, 1.0)
    with pytest.raises(GrainmechError, match="backend"):
        stiffness(ContactSet(n, n, 1.0, 1.0, 1.0), backend="gpu")

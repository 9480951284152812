"""Fabric -> stiffness invariants (property tests; seed Eq. 2.28-2.29, 2.41, 4.19)."""

import numpy as np

from _hyp import given, settings, st
from grainmech import fabric
from grainmech.assembly import ContactSet, stiffness
from grainmech.closed_form import spheres_second_order
from grainmech.conventions import matrix_to_tensor4, tensor4_to_matrix


def _rotation(seed):
    rng = np.random.default_rng(seed)
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


@settings(max_examples=25, deadline=None)
@given(st.floats(-0.6, 0.6), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1), st.integers(0, 2**31 - 1),
       st.floats(0.0, 1.0))
def test_rotating_the_fabric_rotates_the_tensor(a20, a22, b22, seed, ratio):
    """Objectivity (seed Eq. 2.28-2.29): C[R-rotated density] = R R C R R."""
    d = fabric.SphericalDensity.from_seed(a20, a22, b22, allow_negative=True)
    R = _rotation(seed)
    C = stiffness(ContactSet.from_density(d, contacts_per_volume=1e4, branch_length=1e-2, kn=1.0, ks=ratio))
    Cr = stiffness(ContactSet.from_density(d.rotated(R), contacts_per_volume=1e4, branch_length=1e-2,
                                           kn=1.0, ks=ratio))
    expect = tensor4_to_matrix(np.einsum("ia,jb,kc,ld,abcd->ijkl", R, R, R, R, matrix_to_tensor4(C)))
    np.testing.assert_allclose(Cr, expect, atol=1e-12 * np.abs(C).max())


@settings(max_examples=25, deadline=None)
@given(st.floats(1e-3, 1e3), st.floats(0.0, 1e3), st.sampled_from([0, 2, 4, 6]))
def test_isotropic_fabric_gives_isotropic_tensor(kn, ks, order):
    d = fabric.isotropic(3, order)
    C = stiffness(ContactSet.from_density(d, contacts_per_volume=1.0, branch_length=1.0, kn=kn, ks=ks))
    lam, mu = C[0, 1], C[3, 3]
    iso = lam * np.outer([1, 1, 1, 0, 0, 0], [1, 1, 1, 0, 0, 0]) + mu * np.diag([2, 2, 2, 1, 1, 1])
    np.testing.assert_allclose(C, iso, atol=1e-12 * np.abs(C).max())
    # and the seed's isotropic closed forms (Eq. 4.21-4.29 with a = 0), physical scale (N/V) l^2 = 1
    np.testing.assert_allclose(C, spheres_second_order(0, 0, 0, kn, ks, 1.0), rtol=1e-12,
                               atol=1e-12 * np.abs(C).max())


def test_discrete_sample_converges_to_the_quadrature_result():
    """A random sample of n normals from a density (weights 1/n) -> Eq. 2.41 as n grows, error ~ n^-1/2."""
    d = fabric.SphericalDensity.from_seed(0.5, 0.15, 0.05)
    ref = stiffness(ContactSet.from_density(d, contacts_per_volume=1.0, branch_length=1.0, kn=2.0, ks=1.0))
    errs = []
    for n in (1_000, 16_000, 256_000):
        rel = []
        for rep in range(4):
            nrm = d.sample(n, rng=1000 * rep + n)
            C = stiffness(ContactSet(nrm, nrm, 1.0 / n, 2.0, 1.0))
            rel.append(np.linalg.norm(C - ref) / np.linalg.norm(ref))
        errs.append(np.sqrt(np.mean(np.square(rel))))
    assert errs[2] < 5e-3
    # 16x more samples: error down by ~4 (allow 2..8)
    assert 2.0 < errs[0] / errs[1] < 8.0 and 2.0 < errs[1] / errs[2] < 8.0


def test_2d_fourier_density_quadrature_matches_closed_form():
    d = fabric.FourierDensity.from_seed(0.3, -0.2, 0.1, 0.05)
    from grainmech.closed_form import discs_fourth_order
    C = stiffness(ContactSet.from_density(d, contacts_per_volume=3.0, branch_length=0.5, kn=2.0, ks=0.7))
    np.testing.assert_allclose(C, discs_fourth_order(0.3, -0.2, 0.1, 0.05, 2.0, 0.7, 3.0 * 0.25),
                               rtol=1e-12)

"""Conventions: component orders, Voigt/Mandel maps, the seed's axis labelling (seed Eq. 2.19, 4.20, 4.36)."""

import numpy as np
import pytest

from _hyp import arrays, given, settings, st
from grainmech import conventions as cv


def _random_tensor4(rng, d):
    A = rng.normal(size=(d, d, d, d))
    A = A + A.transpose(1, 0, 2, 3)
    A = A + A.transpose(0, 1, 3, 2)
    return A + A.transpose(2, 3, 0, 1)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("mandel", [False, True])
def test_tensor_matrix_round_trip(d, mandel):
    C = _random_tensor4(np.random.default_rng(d), d)
    M = cv.tensor4_to_matrix(C, mandel=mandel)
    assert M.shape == ((6, 6) if d == 3 else (3, 3))
    np.testing.assert_allclose(cv.matrix_to_tensor4(M, mandel=mandel), C, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("d", [2, 3])
def test_voigt_acts_on_engineering_strain_and_mandel_on_sqrt2(d):
    rng = np.random.default_rng(7)
    C = _random_tensor4(rng, d)
    eps = rng.normal(size=(d, d))
    eps = eps + eps.T
    sigma = np.einsum("ijkl,kl->ij", C, eps)
    s_v = cv.tensor4_to_matrix(C) @ cv.strain_to_vector(eps)
    np.testing.assert_allclose(s_v, cv.stress_to_vector(sigma), rtol=1e-12)
    s_m = cv.tensor4_to_matrix(C, mandel=True) @ cv.strain_to_vector(eps, mandel=True)
    np.testing.assert_allclose(s_m, cv.stress_to_vector(sigma, mandel=True), rtol=1e-12)
    np.testing.assert_allclose(cv.vector_to_strain(cv.strain_to_vector(eps)), eps)
    # Mandel form is norm-preserving: sigma:eps == s_m . e_m
    np.testing.assert_allclose(np.sum(sigma * eps), s_m @ cv.strain_to_vector(eps, mandel=True), rtol=1e-12)


def test_voigt_mandel_converters_inverse():
    C = cv.tensor4_to_matrix(_random_tensor4(np.random.default_rng(3), 3))
    np.testing.assert_allclose(cv.mandel_to_voigt(cv.voigt_to_mandel(C)), C, rtol=1e-14)
    assert cv.voigt_to_mandel(C)[3, 3] == pytest.approx(2 * C[3, 3])
    assert cv.voigt_to_mandel(C)[0, 3] == pytest.approx(np.sqrt(2) * C[0, 3])


def test_seed_order_mapping_is_a_relabelling():
    C = _random_tensor4(np.random.default_rng(1), 3)
    lib = cv.tensor4_to_matrix(C)
    seed = cv.reorder(lib, to=cv.SEED_ORDER_3D)
    # seed C11 is zz-zz, C26 is yy-xy, C45 is zy-zx (Eq. 4.20)
    assert seed[0, 0] == C[2, 2, 2, 2]
    assert seed[1, 5] == C[1, 1, 0, 1]
    assert seed[3, 4] == C[2, 1, 2, 0]
    np.testing.assert_array_equal(cv.reorder(seed, to=cv.ORDER_3D, frm=cv.SEED_ORDER_3D), lib)
    np.testing.assert_array_equal(seed, cv.tensor4_to_matrix(C, order=cv.SEED_ORDER_3D))
    C2 = _random_tensor4(np.random.default_rng(2), 2)
    seed2 = cv.tensor4_to_matrix(C2, order=cv.SEED_ORDER_2D)
    assert seed2[0, 0] == C2[1, 1, 1, 1] and seed2[1, 2] == C2[0, 0, 0, 1]


def test_seed_normal_labelling():
    # gamma = 0 is the z axis; beta = 0 lies in the y-z plane; beta = pi/2 towards x (Eq. 2.19)
    np.testing.assert_allclose(cv.seed_normal(0.0, 0.3), [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(cv.seed_normal(np.pi / 2, 0.0), [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(cv.seed_normal(np.pi / 2, np.pi / 2), [1, 0, 0], atol=1e-15)
    # 2D: theta from the y axis, n = (n_y, n_x) = (cos, sin)
    np.testing.assert_allclose(cv.seed_normal_2d(0.0), [0, 1], atol=1e-15)
    np.testing.assert_allclose(cv.seed_normal_2d(np.pi / 2), [1, 0], atol=1e-15)


@settings(max_examples=50, deadline=None)
@given(arrays(float, (5, 3), elements=st.floats(-1, 1)).filter(lambda a: np.all(np.linalg.norm(a, axis=1) > 0.1)))
def test_seed_angles_inverse(v):
    n = v / np.linalg.norm(v, axis=1)[:, None]
    g, b = cv.seed_angles(n)
    np.testing.assert_allclose(cv.seed_normal(g, b), n, atol=1e-12)
    assert np.all((g >= 0) & (g <= np.pi)) and np.all((b >= 0) & (b < 2 * np.pi))


@settings(max_examples=50, deadline=None)
@given(st.floats(0, 2 * np.pi, exclude_max=True))
def test_seed_theta_inverse(t):
    n = cv.seed_normal_2d(t)
    t2 = cv.seed_theta(n)
    assert 0 <= t2 < 2 * np.pi
    np.testing.assert_allclose(cv.seed_normal_2d(t2), n, atol=1e-12)


def test_bad_inputs_name_the_problem():
    with pytest.raises(ValueError, match="two of the letters"):
        cv.index_pairs(["xq"])
    with pytest.raises(ValueError, match="6x6"):
        cv.matrix_to_tensor4(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="order must be"):
        cv.order_for(3, "abaqus")
    with pytest.raises(ValueError, match="same components"):
        cv.reorder(np.eye(6), to=("xx", "yy", "zz", "yz", "xz", "xx"))


def test_von_mises_is_the_deviator_stress_of_soil_mechanics():
    """q = sigma_1 - sigma_3 on a triaxial state, sqrt(3) tau in pure shear (J2 = tau^2),
    independent of the frame (an invariant) and of a mean stress added."""
    from scipy.spatial.transform import Rotation

    from grainmech.conventions import stress_to_vector, vector_to_stress, von_mises

    assert von_mises(np.array([300e3, 100e3, 100e3, 0, 0, 0])) == pytest.approx(200e3, rel=1e-15)
    assert von_mises(np.array([0, 0, 0, 0, 5e3, 0])) == pytest.approx(np.sqrt(3.0) * 5e3, rel=1e-15)
    R = Rotation.from_rotvec([0.3, -0.7, 0.4]).as_matrix()
    sig = np.diag([300e3, 100e3, 100e3])
    rotated = stress_to_vector(R @ sig @ R.T)
    both = np.stack([rotated, rotated + np.array([1e5, 1e5, 1e5, 0, 0, 0])])
    np.testing.assert_allclose(von_mises(both), [200e3, 200e3], rtol=1e-12)
    assert von_mises(both).shape == (2,)
    np.testing.assert_allclose(vector_to_stress(rotated), R @ sig @ R.T, atol=1e-9)
    with pytest.raises(ValueError, match="6 components"):
        von_mises(np.zeros(3))

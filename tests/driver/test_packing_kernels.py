"""Compiled iteration glue of the packing driver against its NumPy reference.

``driver/packing/_kernels.py`` (relative displacements ``Delta = G q + l . eps``, seed
Eq. 2.13; forces, out-of-balance ``G^T f`` and ``V sigma``, Love-Weber seed Eq. 2.6; the
per-grain trust limit and the closing cap) and ``contact.law.CompiledUpdate`` (the
compiled law from one start state, its inputs converted once) must give the same bits
as the NumPy functions they replace, so that a run takes the same path either way.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from grainmech.contact import HertzMindlin, LinearSpring, MindlinDeresiewicz, update  # noqa: E402
from grainmech.contact.law import CompiledUpdate, compiled_kernel, state_from_normal_force  # noqa: E402
from grainmech.driver import cyclic_simple_shear  # noqa: E402
from grainmech.driver.packing import (  # noqa: E402
    PackingOptions,
    PackingPoint,
    equilibrate_network,
    perturbed_fcc_network,
    run_packing,
)
from grainmech.driver.packing import _kernels as K  # noqa: E402
from grainmech.driver.packing import _iterations as IT  # noqa: E402
from grainmech.driver.packing import _trial as TR  # noqa: E402
from grainmech.driver.packing import step as PS  # noqa: E402
from grainmech.driver.packing._operators import voigt_of  # noqa: E402

MD = MindlinDeresiewicz(29e9, 0.15, 1.0, friction=0.5)


@pytest.fixture(scope="module")
def point():
    net = equilibrate_network(perturbed_fcc_network(3, seed=1, vacancies=0.05), MD)
    return PackingPoint.from_network(net, MD, options=PackingOptions(law_backend="auto"))


def _loaded_state(params, n, rng):
    """A state with tangential forces and (for Mindlin-Deresiewicz) reversal memory."""
    st = state_from_normal_force(params, rng.uniform(0.5, 2.0, n) * 1e-3 * params.shear_modulus
                                 if hasattr(params, "shear_modulus") else rng.uniform(0.5, 2.0, n))
    for k in range(3):
        dt = rng.standard_normal((n, 3)) * 1e-7
        dt[:, 2] = 0.0  # tangent plane of normal z (the state's normals are implicit)
        st, _ = update(params, st, rng.standard_normal(n) * 1e-8, (-1) ** k * dt, backend="numpy")
    return st


@pytest.mark.parametrize("params", [MD, HertzMindlin(29e9, 0.15, 1.0, friction=0.5),
                                    LinearSpring(1e6, 5e5, friction=0.4)], ids=["md", "hm", "linear"])
def test_compiled_update_from_one_state_equals_update(params):
    """One CompiledUpdate serves several trials from the same state, each bit for bit update()'s."""
    rng = np.random.default_rng(3)
    n = 300
    st = _loaded_state(params, n, rng)
    call = CompiledUpdate(compiled_kernel(params, "numba"), params, st)
    for trial in range(3):
        dn = rng.standard_normal(n) * 1e-8 * (trial + 1)
        dt = rng.standard_normal((n, 3)) * 1e-8
        dt[:, 2] = 0.0
        ref_st, ref_resp = update(params, st, dn, dt, backend="numba")
        got_st, got_resp = call(dn, dt)
        for a, b in zip(ref_st, got_st):
            np.testing.assert_array_equal(a, b)
        for a, b in zip(ref_resp, got_resp):
            np.testing.assert_array_equal(a, b)
    # the start state is read, not written
    again = _loaded_state(params, n, np.random.default_rng(3))
    for a, b in zip(st, again):
        np.testing.assert_array_equal(a, b)


def test_compiled_update_raises_as_update():
    st = _loaded_state(MD, 10, np.random.default_rng(0))
    call = CompiledUpdate(compiled_kernel(MD, "numba"), MD, st)
    with pytest.raises(ValueError, match="d_normal must be finite"):
        call(np.full(10, np.nan), np.zeros((10, 3)))
    with pytest.raises(ValueError, match="increments of shape"):
        call(np.zeros(9), np.zeros((9, 3)))


def test_kinematics_and_balance_equal_the_numpy_reference(point):
    """Delta = G q + l . eps split into normal and tangential parts (times the law scale),
    forces N n + T, G^T f and V sigma: the same bits as Kinematics.delta/normal_part/balance
    and voigt_of."""
    kin = point.kinematics
    glue = TR.compiled_glue(point)
    assert glue is not None
    rng = np.random.default_rng(5)
    dq = rng.standard_normal(kin.n_free) * 1e-6
    de = rng.standard_normal(6) * 1e-5
    D = kin.delta(dq, de)
    dn_ref = kin.normal_part(D)
    dt_ref = D - dn_ref[:, None] * kin.n
    dn, dt = np.empty(kin.n_contacts), np.empty((kin.n_contacts, 3))
    assert K.contact_increments(*glue.g, dq, glue.l, glue.n, de, point.scale, dn, dt)
    np.testing.assert_array_equal(dn, dn_ref * point.scale)
    np.testing.assert_array_equal(dt, dt_ref * point.scale[:, None])
    # the affine part, written out, is l . eps
    np.testing.assert_allclose(kin.affine(de), kin.l @ np.array(
        [[de[0], de[5] / 2, de[4] / 2], [de[5] / 2, de[1], de[3] / 2], [de[4] / 2, de[3] / 2, de[2]]]),
        rtol=1e-14, atol=1e-14 * np.abs(kin.l).max() * np.abs(de).max())
    bad = dq.copy()
    bad[7] = np.inf
    assert not K.contact_increments(*glue.g, bad, glue.l, glue.n, de, point.scale, dn, dt)

    N = rng.uniform(0.0, 2.0, kin.n_contacts)
    T = rng.standard_normal((kin.n_contacts, 3)) * 0.1
    f, rq, vs = np.empty((kin.n_contacts, 3)), np.empty(kin.n_free), np.empty(6)
    K.forces_balance(N, T, glue.n, glue.l, *glue.gt, f.reshape(-1), rq, vs)
    f_ref = N[:, None] * kin.n + T
    np.testing.assert_array_equal(f, f_ref)
    np.testing.assert_array_equal(rq, kin.balance(f_ref))
    np.testing.assert_array_equal(vs, voigt_of(f_ref, kin.l))


def test_trust_limit_equals_the_numpy_reference(point):
    """clip_moves / affine_move / closing_cap give clip_grain_moves / trust_ratio / stop_closing's bits,
    also when the update closes open contacts beyond the cap (both grains scaled)."""
    kin = point.kinematics
    glue = TR.compiled_glue(point)
    rng = np.random.default_rng(7)
    R = point.radii
    S = np.array([False, False, True, False, False, False])
    approach = point.state.approach / point.scale
    opened = approach.copy()
    opened[::5] = -np.abs(opened[::5]) - 1e-4  # every fifth contact open, just apart
    cap = 0.05 * float(np.mean(approach[approach > 0]))
    for scale in (1e-7, 1e-4, 1e-2):
        dxq = rng.standard_normal(kin.n_free) * scale
        dxe = rng.standard_normal(1) * scale
        for app in (approach, opened):
            ref_q = IT.clip_grain_moves(kin, dxq, R, 0.01)
            ref_e = dxe / IT.trust_ratio(kin, None, dxe, S, 0.01)
            ref_q = IT.stop_closing(kin, ref_q, ref_e, S, app, cap)
            got_q, got_e = glue.limit(dxq, dxe, S, R, 0.01, app, cap)
            np.testing.assert_array_equal(got_q, ref_q)
            np.testing.assert_array_equal(got_e, ref_e)
    # the cap acted somewhere in these cases (else the test would not test it)
    d6 = np.zeros(6)
    big = rng.standard_normal(kin.n_free) * 1e-2
    out = big.copy()
    changed = K.closing_cap(*glue.g, big, glue.l, glue.n, d6, opened, cap, kin.a, kin.b, glue.pos,
                            np.ones(kin.n_grains), out)
    assert changed and not np.array_equal(out, big)


def test_a_run_takes_the_same_path_with_either_glue(point, monkeypatch):
    """Cyclic simple shear at constant stress: the same iterations and the same stresses,
    bit for bit, with the compiled glue and with the NumPy functions."""
    path = cyclic_simple_shear(1e-4, 1, 8, constant="stress")
    opts = PackingOptions(law_backend="auto", tangent="none")
    fast = run_packing(point, path, opts)
    monkeypatch.setattr(PS, "compiled_glue", lambda pt: None)
    ref = run_packing(point, path, opts)
    assert fast.success and ref.success
    np.testing.assert_array_equal(fast.iterations, ref.iterations)
    np.testing.assert_array_equal(fast.stress, ref.stress)
    np.testing.assert_array_equal(fast.strain, ref.strain)


def test_numpy_law_backend_keeps_the_numpy_glue(point):
    from dataclasses import replace

    assert TR.compiled_glue(replace(point, law_backend="numpy")) is None

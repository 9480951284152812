"""The compiled (numba) contact kernel equals the NumPy reference path.

``update(..., backend="numba")`` (module :mod:`grainmech.contact.kernel`) must give the
state and response of ``update(..., backend="numpy")`` to rounding:

* forces to 1e-12 of the friction force ``mu N``, stiffnesses to 1e-12 of their natural
  scale (``kt0 = 8 G* a``, ``mu kn``), dissipation to 1e-12 of the work scale of the step;
* identical flags (``sliding``, ``open``), directions, memory depths, and reversal stacks
  equal to 1e-12 of ``mu N``;
* the same errors (``ReversalMemoryError`` naming the same contacts, non-finite input).

Steps are compared from the same (reference) state, so that one branch decision taken
differently at the rounding level cannot hide or amplify a difference; a separate test
follows both backends along their own trajectories.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import pytest

import grainmech.contact.law as law_module
from _hyp import HealthCheck, given, settings, st
from grainmech.contact import (
    Cylinder,
    Hertz,
    HertzMindlin,
    LinearSpring,
    MindlinDeresiewicz,
    ReversalMemoryError,
    hertz_approach_from_force,
    state_from_forces,
    state_from_normal_force,
    update,
)

pytest.importorskip("numba")

MD = MindlinDeresiewicz(29e9, 0.2, 1e-3, 1.5e-3, friction=0.4, max_reversals=64)
LAWS = {
    "md": MD,
    "md-shallow": MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.5, max_reversals=3),
    "md-frictionless": MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.0),
    "hm": HertzMindlin(29e9, 0.2, 1e-3, friction=0.3),
    "hm-rough": HertzMindlin(29e9, 0.2, 1e-3),
    "lin": LinearSpring(1e6, 4e5, friction=0.5),
    "hertz": Hertz(29e9, 0.2, 1e-3),
}
ALPHA_REF = {name: (1e-5 if name == "lin" else float(hertz_approach_from_force(10.0, p)))
             for name, p in LAWS.items()}
RTOL = 1e-12

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _mu(p) -> float:
    mu = p.friction
    return mu if math.isfinite(mu) else 1.0


def _kt0_scale(p, N):
    """No-slip tangential stiffness at ``N`` (0 for a frictionless law)."""
    return np.broadcast_to(np.asarray(p.stiffness(N)[1], dtype=float), N.shape)


def assert_same_step(p, state, dn, dt, normals=None):
    """One step from ``state`` with both backends; returns the reference result."""
    a, ra = update(p, state, dn, dt, normals=normals, backend="numpy")
    b, rb = update(p, state, dn, dt, normals=normals, backend="numba")
    assert type(a) is type(b) and type(ra) is type(rb)
    for x, y in zip((*a, *ra), (*b, *rb)):
        assert x.shape == y.shape and x.dtype == y.dtype
    # exact: flags, branch directions, memory depths
    for name in ("direction", "depth", "sliding"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(ra.sliding, rb.sliding)
    np.testing.assert_array_equal(ra.open, rb.open)
    # normal law: closed forms
    np.testing.assert_array_equal(a.approach, b.approach)
    np.testing.assert_allclose(b.normal_force, a.normal_force, rtol=RTOL, atol=0)
    np.testing.assert_allclose(rb.kn, ra.kn, rtol=RTOL, atol=0)
    # forces on the scale of the friction force (their natural resolution)
    N = np.maximum(a.normal_force, state.normal_force)
    f_scale = _mu(p) * N + np.linalg.norm(a.tangential_force, axis=1) + 1e-300
    dT = np.linalg.norm(a.tangential_force - b.tangential_force, axis=1)
    assert np.all(dT <= RTOL * f_scale), np.max(dT / f_scale)
    assert np.array_equal(ra.tangential_force, a.tangential_force)
    assert np.array_equal(rb.tangential_force, b.tangential_force)
    # memory axis: a unit vector, ill-conditioned only where |T| itself is tiny
    tn = np.linalg.norm(a.tangential_force, axis=1)
    de = np.linalg.norm(a.axis - b.axis, axis=1)
    assert np.all(de <= RTOL * (1.0 + f_scale / np.maximum(tn, 1e-300))), np.max(de)
    # reversal invariants P_j (0 <= P_j <= 2 mu N), the whole stack (same cells written)
    if a.reversals.size:
        dP = np.abs(a.reversals - b.reversals)
        assert np.all(dP <= RTOL * (f_scale[:, None] + np.abs(a.reversals))), np.max(dP)
    # stiffnesses on their natural scales
    kt0 = ra.ks_perp
    np.testing.assert_allclose(rb.ks_perp, kt0, rtol=RTOL, atol=0)
    assert np.all(np.abs(ra.ks - rb.ks) <= RTOL * (kt0 + 1e-300))
    assert np.all(np.abs(ra.ktn - rb.ktn) <= RTOL * (_mu(p) * ra.kn + 1e-300))
    # dissipation on the energy scale of the contact and step: force x (displacement
    # increment + elastic tangential displacement mu N / kt0). The rescaling of T when the
    # contact area shrinks dissipates (1 - kt0(N1)/kt0(N0)) |T|^2 / (2 kt0): for a tiny
    # change of N this is a difference of nearly equal stiffnesses, resolved only to
    # ulp(kt0) |T|^2 / kt0.
    dd = np.atleast_1d(np.asarray(dn, dtype=float))
    kt = np.maximum(ra.ks_perp, _kt0_scale(p, N))
    elastic = np.where(kt > 0, f_scale / np.where(kt > 0, kt, 1.0), 0.0)
    w_scale = f_scale * (np.linalg.norm(np.reshape(dt, (len(N), -1)), axis=1) + np.abs(dd) + elastic)
    ratio = np.abs(ra.dissipation - rb.dissipation) / np.maximum(w_scale + np.abs(ra.dissipation), 1e-300)
    assert np.all(ratio <= RTOL), (np.max(ratio), int(np.argmax(ratio)))
    e_scale = np.abs(a.dissipated_energy) + w_scale
    ratio = np.abs(a.dissipated_energy - b.dissipated_energy) / np.maximum(e_scale, 1e-300)
    assert np.all(ratio <= RTOL), np.max(ratio)
    assert np.all(rb.dissipation >= 0.0)
    for x in (*b, *rb):
        assert np.all(np.isfinite(np.asarray(x, dtype=float)))
    return a, ra


def _random_increments(rng, n, dim, aref, *, falling_bias=0.0):
    """Random normal/tangential increments: zero, tiny, moderate and large steps mixed."""
    dn = rng.normal(falling_bias, 0.3, n) * aref * rng.choice([0.0, 1e-3, 0.1, 1.0], n)
    dt = rng.normal(0.0, 0.3, (n, dim)) * aref * rng.choice([0.0, 1e-4, 0.1, 1.0], (n, 1))
    # some purely collinear increments (reversals along the memory axis)
    col = rng.random(n) < 0.3
    if dim > 1 and np.any(col):
        dt[col, 1:] = 0.0
    return dn, dt


@pytest.mark.parametrize("name", sorted(LAWS))
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_kernel_equals_numpy_on_random_paths(name, dim):
    p = LAWS[name]
    aref = ALPHA_REF[name]
    rng = np.random.default_rng(zlib.crc32(f"{name}-{dim}".encode()))
    n = 64
    N0 = rng.uniform(0.0, 20.0, n) * (rng.random(n) > 0.15)      # some open contacts
    N0[:4] = [0.0, 1e-12, 1e-9, 1e-3]                             # vanishing forces
    state = state_from_normal_force(p, N0, dim=dim)
    for step in range(60):
        bias = -0.2 if (step // 10) % 2 else 0.15                 # alternate unloading
        dn, dt = _random_increments(rng, n, dim, aref, falling_bias=bias)
        try:
            state, _ = assert_same_step(p, state, dn, dt)
        except ReversalMemoryError:
            assert name == "md-shallow"
            with pytest.raises(ReversalMemoryError):
                update(p, state, dn, dt, backend="numba")
            break


def test_kernel_equals_numpy_constant_n_cycles_with_reversal_memory():
    """Decaying tangential cycles at constant and oscillating N fill the reversal stack."""
    p = MD
    aref = ALPHA_REF["md"]
    n = 40
    rng = np.random.default_rng(7)
    state = state_from_normal_force(p, rng.uniform(2.0, 15.0, n), dim=3)
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    amp = rng.uniform(0.05, 0.8, n) * aref
    depth_seen = 0
    for cyc in range(14):
        for leg in (1.0, -1.0):
            dn = (0.02 * aref * np.sin(cyc + leg) * rng.random(n)) if cyc % 3 == 2 else np.zeros(n)
            # amplitudes drawn per leg: a branch never ends exactly (to rounding) on the
            # reversal point it started from, where closing the loop or not are the same
            # state and either backend may take either decision
            dx = leg * amp * rng.uniform(0.9, 1.0, n) / 3
            for _ in range(3):
                state, _ = assert_same_step(p, state, dn / 3, dx[:, None] * direction)
        amp = amp * 0.8
        depth_seen = max(depth_seen, int(state.depth.max()))
    assert depth_seen >= 6


def test_a_cycle_back_to_a_remembered_level_closes_its_loop(monkeypatch):
    """Load to +a, back to -a, up to +a again in sub-steps (300 contacts, random 3D
    directions and amplitudes, constant N): the branch ends on the reversal point it heads
    for up to rounding, and Masing's rule closes the loop there for every contact, with both
    backends alike (hysteresis.TIE_TOL). Decided by rounding alone, 143 of the 300 kept
    the loop open (NumPy law), and the backends could differ."""
    import grainmech.contact.hysteresis as hyst

    p = MD
    n = 300
    rng = np.random.default_rng(11)
    start = state_from_normal_force(p, rng.uniform(2.0, 15.0, n), dim=3)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    amp = rng.uniform(0.05, 0.6, n) * ALPHA_REF["md"]

    def cycle(check):
        state = start
        for f, m in ((1.0, 1), (-2.0, 7), (2.0, 7)):
            for _ in range(m):
                dt = (f * amp / m)[:, None] * d
                state = (assert_same_step(p, state, np.zeros(n), dt)[0] if check
                         else update(p, state, np.zeros(n), dt, backend="numpy")[0])
        return state

    assert np.all(cycle(True).depth == 0)
    monkeypatch.setattr(hyst, "TIE_TOL", 0.0)
    assert np.count_nonzero(cycle(False).depth) > 50  # without the rule: rounding decides


def test_a_rounding_size_component_along_the_slip_axis_is_no_motion_along_it(monkeypatch):
    """A contact with a memory axis along x (loaded along x, then partly back: one
    reversal remembered) is moved along y; the increment's component along x is of
    rounding size, +-1e-20 of it, or exactly 0. All three give the same state and force,
    with both backends (hysteresis.PAR_TOL): no reversal is decided by the sign of a
    rounding error. Without the rule the +sign continues the branch and the -sign reverses
    it (the NumPy law: another depth and branch direction)."""
    import grainmech.contact.hysteresis as hyst

    p = MD
    n = 20
    a = np.linspace(0.05, 0.6, n) * ALPHA_REF["md"]
    state = state_from_normal_force(p, np.full(n, 8.0), dim=3)
    ex = np.zeros((n, 3))
    ex[:, 0] = 1.0
    state, _ = assert_same_step(p, state, np.zeros(n), a[:, None] * ex)
    state, _ = assert_same_step(p, state, np.zeros(n), -0.4 * a[:, None] * ex)
    assert np.all(state.depth == 1) and np.all(state.direction == -1)

    def move(eps, backend=None):
        dt = np.zeros((n, 3))
        dt[:, 1] = 0.3 * a
        dt[:, 0] = eps * 0.3 * a
        if backend is None:
            return assert_same_step(p, state, np.zeros(n), dt)
        return update(p, state, np.zeros(n), dt, backend=backend)

    ref, rref = move(0.0)
    for eps in (1e-20, -1e-20):
        st, r = move(eps)
        np.testing.assert_array_equal(st.depth, ref.depth)
        np.testing.assert_array_equal(st.direction, ref.direction)
        np.testing.assert_allclose(st.tangential_force, ref.tangential_force, rtol=0,
                                   atol=1e-15 * np.abs(ref.tangential_force).max())
        np.testing.assert_allclose(r.ks, rref.ks, rtol=1e-15)
    monkeypatch.setattr(hyst, "PAR_TOL", 0.0)
    plus, _ = move(1e-20, "numpy")
    minus, _ = move(-1e-20, "numpy")
    assert not np.array_equal(plus.depth, minus.depth) or not np.array_equal(plus.direction, minus.direction)


def test_kernel_equals_numpy_falling_normal_force_events():
    """N falls at fixed displacement through erasure, Masing closure and sliding events."""
    p = MD
    aref = ALPHA_REF["md"]
    n = 30
    rng = np.random.default_rng(3)
    state = state_from_normal_force(p, np.full(n, 10.0), dim=1)
    amp = rng.uniform(0.05, 0.25, n) * aref
    for leg in (1.0, -0.7, 0.5, -0.3, 0.2):
        state, _ = assert_same_step(p, state, np.zeros(n), (leg * amp)[:, None])
    assert state.depth.max() >= 2
    for frac in (0.05, 0.2, 0.5, 0.9, 1.2):                         # to opening
        state, r = assert_same_step(p, state, np.full(n, -frac * 0.4 * aref), np.zeros((n, 1)))
    assert np.any(r.open)


def test_kernel_equals_numpy_virgin_forces_and_sliding():
    p = MD
    aref = ALPHA_REF["md"]
    rng = np.random.default_rng(11)
    n = 50
    N = rng.uniform(1.0, 10.0, n)
    T = rng.normal(size=(n, 3))
    T *= (rng.uniform(0.0, 1.0, n) * p.friction * N / np.linalg.norm(T, axis=1))[:, None]
    T[:5] *= 0.0
    T[5:10] *= p.friction * N[5:10, None] / np.linalg.norm(T[5:10], axis=1)[:, None] * (1 - 1e-13)
    state = state_from_forces(p, N, T)
    for step in range(20):
        dn = rng.normal(0.0, 0.05, n) * aref
        dt = rng.normal(0.0, 1.0, (n, 3)) * aref                  # much sliding
        state, r = assert_same_step(p, state, dn, dt)
    assert np.any(r.sliding)


def test_kernel_equals_numpy_turning_normals_and_scalar_dn():
    p = MD
    aref = ALPHA_REF["md"]
    rng = np.random.default_rng(5)
    n = 20
    state = state_from_normal_force(p, rng.uniform(1.0, 10.0, n), dim=3)
    nrm = np.tile([0.0, 0.0, 1.0], (n, 1))
    for step in range(15):
        nrm = nrm + 0.05 * rng.normal(size=(n, 3))
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
        dt = rng.normal(0.0, 0.3, (n, 3)) * aref
        dt -= np.sum(dt * nrm, axis=1)[:, None] * nrm
        state, _ = assert_same_step(p, state, 0.01 * aref, dt, normals=nrm)


@SETTINGS
@given(law=st.sampled_from(["md", "hm", "lin", "md-shallow"]), dim=st.sampled_from([1, 3]),
       n0=st.sampled_from([0.0, 1e-9, 0.5, 10.0]),
       steps=st.lists(st.tuples(st.floats(-1.5, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
                                st.floats(-1.0, 1.0), st.sampled_from([0.0, 1e-4, 0.1, 1.0])),
                      min_size=1, max_size=25))
def test_kernel_equals_numpy_hypothesis(law, dim, n0, steps):
    p = LAWS[law]
    aref = ALPHA_REF[law]
    state = state_from_normal_force(p, [n0, 2.0 * n0 + 1.0], dim=dim)
    for da, t0, t1, t2, sc in steps:
        dt = np.array([[t0, t1, t2][:dim], [-t1, t2, t0][:dim]]) * sc * aref
        dn = np.array([da, 0.5 * da]) * aref
        try:
            a, _ = update(p, state, dn, dt, backend="numpy")
        except ReversalMemoryError as exc:
            with pytest.raises(ReversalMemoryError) as info:
                update(p, state, dn, dt, backend="numba")
            np.testing.assert_array_equal(info.value.contacts, exc.contacts)
            assert str(info.value) == str(exc)
            return
        state, _ = assert_same_step(p, state, dn, dt)


def test_trajectories_agree_over_many_steps():
    """Each backend follows its own state: a long 3D path stays together."""
    p = MD
    aref = ALPHA_REF["md"]
    rng = np.random.default_rng(42)
    n = 100
    sa = sb = state_from_normal_force(p, rng.uniform(2.0, 12.0, n), dim=3)
    for step in range(120):
        dn = rng.normal(0.0, 0.05, n) * aref
        dt = rng.normal(0.0, 0.2, (n, 3)) * aref
        sa, ra = update(p, sa, dn, dt, backend="numpy")
        sb, rb = update(p, sb, dn, dt, backend="numba")
    scale = p.friction * np.maximum(sa.normal_force, 1.0)
    assert np.all(np.linalg.norm(sa.tangential_force - sb.tangential_force, axis=1) <= 1e-9 * scale)
    np.testing.assert_allclose(sb.dissipated_energy, sa.dissipated_energy, rtol=1e-9, atol=0)
    np.testing.assert_array_equal(sa.depth, sb.depth)


def test_reversal_memory_error_is_the_same():
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.4, max_reversals=3)
    n = 6
    s = state_from_normal_force(p, np.full(n, 10.0), dim=1)
    amp = np.array([1e-6, 1e-6, 2e-7, 1e-6, 1e-6, 1e-6])
    s, _ = update(p, s, np.zeros(n), amp[:, None])
    errors = {}
    for backend in ("numpy", "numba"):
        st_, a = s, amp.copy()
        with pytest.raises(ReversalMemoryError) as info:
            for k in range(10):
                a = a * -0.7
                if k >= 2:
                    a[2] = 0.0                                      # contact 2 stops early
                st_, _r = update(p, st_, np.zeros(n), (2 * a)[:, None], backend=backend)
        errors[backend] = info.value
    assert str(errors["numba"]) == str(errors["numpy"])
    np.testing.assert_array_equal(errors["numba"].contacts, errors["numpy"].contacts)
    assert 2 not in errors["numba"].contacts


def test_reversal_memory_error_rising_n_checked_first():
    """As in the reference, overflowing reversals under rising N are reported first."""
    p = MindlinDeresiewicz(29e9, 0.2, 1e-3, friction=0.4, max_reversals=1)
    aref = float(hertz_approach_from_force(10.0, p))
    s = state_from_normal_force(p, np.full(4, 10.0), dim=1)
    s, _ = update(p, s, np.zeros(4), np.full((4, 1), 0.3 * aref))
    s, _ = update(p, s, np.zeros(4), np.full((4, 1), -0.1 * aref))     # one reversal each
    assert np.all(s.depth == 1)
    dn = np.array([0.0, 1e-4, 0.0, 1e-4]) * aref                        # 1, 3 rising
    dt = np.full((4, 1), 0.05 * aref)
    msgs = []
    for backend in ("numpy", "numba"):
        with pytest.raises(ReversalMemoryError) as info:
            update(p, s, dn, dt, backend=backend)
        msgs.append((str(info.value), list(info.value.contacts)))
    assert msgs[0] == msgs[1]
    assert msgs[1][1] == [1, 3]


def test_non_finite_and_bad_shapes_raise_the_same():
    p = MD
    s = state_from_normal_force(p, [1.0, 2.0], dim=3)
    for dn, dt, match in (([np.nan, 0.0], np.zeros((2, 3)), "d_normal must be finite"),
                          ([0.0, 0.0], [[0, np.inf, 0], [0, 0, 0]], "d_tangential must be finite"),
                          ([0.0], np.zeros((2, 3)), "d_normal must have shape"),
                          ([0.0, 0.0], np.zeros((2, 2)), "d_tangential must have shape")):
        for backend in ("numpy", "numba", "auto"):
            with pytest.raises(ValueError, match=match):
                update(p, s, dn, dt, backend=backend)


def test_backend_selection(monkeypatch):
    rod = Cylinder(1.0e8, 0.1, 3e-3, 2.5, math.radians(15))
    s = state_from_normal_force(rod, [100.0], dim=3)
    update(rod, s, [1e-8], [[1e-8, 0, 0]])                      # auto: NumPy fallback
    with pytest.raises(ValueError, match="does not support Cylinder"):
        update(rod, s, [1e-8], [[1e-8, 0, 0]], backend="numba")
    with pytest.raises(ValueError, match="backend must be one of"):
        update(MD, state_from_normal_force(MD, [1.0]), [0.0], [[0, 0, 0]], backend="fortran")
    # without numba: auto falls back, an explicit request fails
    monkeypatch.setattr(law_module, "_KERNEL", False)
    sm = state_from_normal_force(MD, [1.0])
    a, _ = update(MD, sm, [1e-7], [[1e-7, 0, 0]])
    b, _ = update(MD, sm, [1e-7], [[1e-7, 0, 0]], backend="numpy")
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    with pytest.raises(ImportError, match="needs numba"):
        update(MD, sm, [1e-7], [[1e-7, 0, 0]], backend="numba")


def test_kernel_is_pure_and_parallel_path_equals_serial(monkeypatch):
    from grainmech.contact import kernel as _kernel

    p = MD
    aref = ALPHA_REF["md"]
    rng = np.random.default_rng(9)
    n = 3000                                   # above the parallel threshold
    state = state_from_normal_force(p, rng.uniform(0.0, 12.0, n), dim=3)
    for _ in range(3):
        dn, dt = _random_increments(rng, n, 3, aref)
        state, _ = update(p, state, dn, dt, backend="numpy")
    dn, dt = _random_increments(rng, n, 3, aref, falling_bias=-0.1)
    before = [np.array(f, copy=True) for f in state]
    assert n >= _kernel.PARALLEL_THRESHOLD
    par = update(p, state, dn, dt, backend="numba")
    for b, f in zip(before, state):
        assert np.array_equal(b, f)
    monkeypatch.setattr(_kernel, "PARALLEL_THRESHOLD", 10**9)
    ser = update(p, state, dn, dt, backend="numba")
    for x, y in zip((*par[0], *par[1]), (*ser[0], *ser[1])):
        assert np.array_equal(x, y)
    assert_same_step(p, state, dn, dt)


def _kernel_step_inputs(seed: int, n: int) -> tuple:
    """Kernel inputs of one step of ``n`` 3D Mindlin-Deresiewicz contacts after four random
    steps of the reference law (reversals, sliding, opening), with a bias to falls of N:
    ``(constants, state, increment, N0, N1)``, the normal forces before and after."""
    from grainmech.contact import kernel as K
    from grainmech.contact.geometry import hertz_force, hertz_radius

    p = MD
    aref = ALPHA_REF["md"]
    rng = np.random.default_rng(seed)
    state = state_from_normal_force(p, rng.uniform(0.0, 12.0, n), dim=3)
    for _ in range(4):
        dn, dt = _random_increments(rng, n, 3, aref)
        state, _ = update(p, state, dn, dt, backend="numpy")
    dn, dt = _random_increments(rng, n, 3, aref, falling_bias=-0.1)
    st = K.KernelState(*(np.ascontiguousarray(x, dtype=t) for x, t in zip(
        (state.approach, state.normal_force, state.tangential_force, state.axis, state.direction, state.depth,
         state.reversals, state.dissipated_energy), (float, float, float, float, np.int8, np.int32, float, float))))
    E, R = p.effective_modulus, p.effective_radius
    N1 = hertz_force(np.maximum(st.approach + dn, 0.0), E, R)
    N0 = np.where((st.approach > 0) & (st.normal_force > 0), st.normal_force, 0.0)
    inc = K.KernelIncrement(dn, np.ascontiguousarray(dt), N1, hertz_radius(N0, E, R), hertz_radius(N1, E, R))
    return K.constants(p), st, inc, N0, N1


def test_deferring_law_copy_equals_per_call_kernel():
    """The mixed-control driver's law copy (``law_function(..., defer=True)``) against ``update_kernel``.

    Same increments and closed forms: every output equal bit for bit except the
    dissipation, which lacks the falling-N quadrature until the iterate is accepted
    (``rows`` called with ``lo = -1``) and then agrees to rounding.
    """
    from numba import njit

    from grainmech.contact import kernel as K

    n = 500
    kc, st, inc, N0, N1 = _kernel_step_inputs(17, n)
    status, ref, flags = K.update_kernel(kc, st, inc)
    assert status == 0 and not flags.any()

    out = K.new_output(n, 3, st.reversals.shape[1])
    scratch = K.KernelScratch(np.empty((n, 3)), np.empty((n, 3)), np.zeros(n, dtype=np.int8),
                              np.zeros((n, K.FALL_COLUMNS)))
    law = K.law_function(kc, st, inc, out, scratch, defer=True)

    @njit
    def call(f, lo, hi, kc, st, inc, out, scratch):
        f(lo, hi, kc, st, inc, out, scratch)

    call(law, 0, n, kc, st, inc, out, scratch)
    assert not scratch.flags.any()
    for name in K.KernelOutput._fields:
        if name != "dissipation":
            np.testing.assert_array_equal(getattr(out, name), getattr(ref, name), err_msg=name)
    deferred = scratch.fall[:, 0] > 0
    falling = (N1 < N0) & (N1 > 0) & (st.depth > 0)
    assert deferred.sum() >= 50 and np.all(deferred <= (N1 < N0))   # only falls are deferred
    assert np.any(deferred & falling)
    # before the acceptance the quadrature is missing, afterwards it is there
    d_out, d_ref = out.dissipation[deferred], ref.dissipation[deferred]
    assert np.all(d_out <= d_ref * (1 + 1e-13))
    assert np.sum(d_out < 0.99 * d_ref) >= 0.5 * deferred.sum()
    np.testing.assert_array_equal(out.dissipation[~deferred], ref.dissipation[~deferred])
    call(law, -1, n, kc, st, inc, out, scratch)
    assert not (scratch.fall[:, 0] > 0).any()
    np.testing.assert_allclose(out.dissipation, ref.dissipation, rtol=1e-13, atol=0)


@pytest.mark.parametrize("parallel", [False, True])
def test_specialised_3d_law_of_update_kernel_equals_generic_rows(monkeypatch, parallel):
    """``update_kernel`` runs 3D Mindlin-Deresiewicz contacts through the law copy of
    ``law_function`` (specialised to 3D, axis law inlined); it equals the generic ``rows``
    (which the other tests check against the NumPy reference) bit for bit, every output,
    on states with reversals, Masing branches, sliding and falls of ``N``."""
    from grainmech.contact import kernel as K

    n = 3000                                   # above the parallel threshold
    kc, st, inc, N0, N1 = _kernel_step_inputs(23, n)
    if not parallel:
        monkeypatch.setattr(K, "PARALLEL_THRESHOLD", 10**9)
    status, out, flags = K.update_kernel(kc, st, inc)
    assert status == 0 and not flags.any()
    ref = K.new_output(n, 3, st.reversals.shape[1])
    scratch = K.new_scratch(n, 3)
    assert (K._kernel_parallel if parallel else K._kernel_serial)(kc, st, inc, ref, scratch) == 0
    assert not scratch.flags.any()
    for name in K.KernelOutput._fields:
        np.testing.assert_array_equal(getattr(out, name), getattr(ref, name), err_msg=name)
    # the step exercised the law's branches
    assert ref.sliding.any() and (~ref.sliding & ~ref.open).any() and ref.open.any()
    assert np.sum((N1 < N0) & (N1 > 0) & (st.depth > 0)) >= 50
    assert np.any(ref.depth > st.depth) and np.any(ref.depth < st.depth)

"""The compiled mixed-control loop (driver/_mixed.py) against the NumPy reference.

The reference is the step loop of ``solver.run`` with the NumPy contact law
(``backend="numpy"``: kinematics of seed Eq. 2.13 by matrix products, Love-Weber stress
of Eq. 2.6 by ``love_weber_sum``, the Newton Jacobian ``sum w B^T K B`` by einsum). The
law's step tangent itself is checked against central differences of the NumPy law, an
independent check of the derivation (a consistent tangent gives Newton's quadratic
convergence: about two evaluations per step at gamma = 1e-4 instead of three).

Tolerances stated: stresses, strains, energies to 1e-9 relative (the Newton tolerance
rtol = 1e-9 bounds how far two runs whose iterates differ by rounding can drift); Newton
iterations: the totals within 2 %, no step more than one iteration apart.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.assembly import ContactSet
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import (LoadPath, MaterialPoint, SolverOptions, cyclic_simple_shear, evaluate, run,
                              segment, tangent)
from grainmech.driver.affine.point import consistent_tangent

pytest.importorskip("numba")

RADIUS = 1e-3
LAW = MindlinDeresiewicz(29e9, 0.15, RADIUS, friction=0.5)


def _point(degree: int, backend: str) -> MaterialPoint:
    from grainmech.fabric import sphere_rule

    normals, w = sphere_rule(degree)
    nv = 8 / (2 * (4 / 3 * np.pi * RADIUS ** 3) * 1.6)  # e = 0.6, 8 contacts per grain
    cs = ContactSet(normals, 2 * RADIUS * normals, nv * w, 0.0, 0.0)
    return MaterialPoint.isotropic(cs, LAW, 1e5, backend=backend)


def _agree(a, b, rtol=1e-9):
    assert a.success == b.success
    assert a.message == b.message
    assert a.stress.shape == b.stress.shape
    scale = np.abs(b.stress).max()
    assert np.abs(a.stress - b.stress).max() <= rtol * scale
    assert np.abs(a.strain - b.strain).max() <= rtol * np.abs(b.strain).max()
    assert np.abs(a.tangent - b.tangent).max() <= rtol * np.abs(b.tangent).max()
    for key in ("dissipation", "work", "stored"):
        x, y = getattr(a, key), getattr(b, key)
        assert np.abs(x - y).max() <= rtol * max(np.abs(y).max(), 1e-300), key
    assert np.allclose(a.sliding_fraction, b.sliding_fraction, rtol=0, atol=1e-9)
    ia, ib = a.iterations[1:], b.iterations[1:]
    assert np.abs(ia - ib).max() <= 1
    assert abs(int(ia.sum()) - int(ib.sum())) <= 0.02 * ib.sum()


@pytest.mark.parametrize("amplitude, max_mean", [(1e-5, 2.1), (1e-4, 2.3), (1e-3, 3.2)])
def test_compiled_loop_matches_numpy_reference(monkeypatch, amplitude, max_mean):
    """Cyclic simple shear at constant sigma_zz, 194 directions, 2 cycles x 100 steps."""
    from grainmech.driver.affine import _mixed

    calls = []
    seg = _mixed.mixed_segment
    monkeypatch.setattr(_mixed, "mixed_segment", lambda *a, **k: calls.append(1) or seg(*a, **k))
    path = cyclic_simple_shear(amplitude, 2, 100, constant="stress")
    a = run(_point(23, "auto"), path)
    assert calls, "the compiled loop was not used"
    b = run(_point(23, "numpy"), path)
    assert a.success, a.message
    _agree(a, b)
    # the step tangent makes Newton converge quadratically: the predictor (symmetric
    # tangent of the last step) and about one correction per step
    assert a.iterations[1:].mean() <= max_mean
    # the reported tangent is the symmetric one of seed Eq. 2.26 at the final state
    C = tangent(a.final.contacts, a.final.response)
    assert np.abs(a.final.tangent - C).max() <= 1e-12 * np.abs(C).max()


def test_step_tangent_equals_finite_differences_of_the_numpy_law():
    """d sigma / d eps of one trial increment (NumPy law, central differences) equals the
    Jacobian from the step tangent, on a Masing branch with a falling normal force."""
    pt = _point(23, "numpy")
    path = cyclic_simple_shear(1e-4, 1, 100, constant="stress")
    r = run(pt, LoadPath(path.stress_control[:31], path.increment[:31]))
    p = r.final
    de = np.array([0.0, 0.0, -4e-8, 0.0, -4e-6, 0.0])
    ev = evaluate(p, de)
    J = consistent_tangent(p.contacts, ev.response)
    Jfd = np.zeros((6, 6))
    h = 1e-6 * np.abs(de).max()
    for j in range(6):
        e = np.zeros(6)
        e[j] = h
        Jfd[:, j] = (evaluate(p, de + e).stress - evaluate(p, de - e).stress) / (2 * h)
    assert (p.state.depth > 0).any() and (ev.state.normal_force < p.state.normal_force).any()
    assert np.abs(J - Jfd).max() <= 1e-6 * np.abs(Jfd).max()
    # the compiled law returns the same step tangent, contact by contact
    from grainmech.contact.interface import make_law
    from grainmech.conventions import vector_to_strain

    delta = p.contacts.branch @ vector_to_strain(de)
    dn = np.einsum("ci,ci->c", delta, p.contacts.normals)
    dt = delta - dn[:, None] * p.contacts.normals
    _, rc = make_law(LAW, backend="auto").update(p.state, dn, dt)
    kmax = np.abs(ev.response.kn).max()
    assert np.abs(rc.t_delta - ev.response.t_delta).max() <= 1e-12 * kmax
    assert np.abs(rc.t_alpha - ev.response.t_alpha).max() <= 1e-12 * kmax
    # the continuum form (ks, ks_perp, ktn along the new axis) is measurably off
    old = consistent_tangent(p.contacts, ev.response._replace(t_delta=None, t_alpha=None))
    assert np.abs(old - Jfd).max() > 1e2 * np.abs(J - Jfd).max()


def test_control_switches_and_compiled_equals_step_loop():
    """Segments of different masks (stress path, then mixed shear, then strain) in one run:
    the compiled loop, segment by segment, equals the step loop with the same law."""
    pt = _point(11, "auto")
    path = (segment("SSSSSS", [2e4, 2e4, 5e4, 0, 0, 0], 10)
            + cyclic_simple_shear(2e-4, 1, 20, constant="stress")
            + segment("EEEEEE", [0, 0, 0, 0, 1e-4, 0], 5)
            + segment("EESEEE", [0, 0, -1e4, 0, 0, 0], 5))
    a = run(pt, path)
    b = run(pt, path, compiled=False)
    assert a.success, a.message
    _agree(a, b, rtol=1e-12)
    assert np.array_equal(a.iterations, b.iterations)


def test_newton_failure_inside_compiled_loop_keeps_the_steps_done():
    """A stress target in tension (contacts open, no stiffness): the compiled loop stops at
    the same step with the same message as the step loop and keeps the steps before."""
    pt = _point(11, "auto")
    path = cyclic_simple_shear(1e-4, 1, 20, constant="stress") + segment("EESEEE", [0, 0, -3e5, 0, 0, 0], 2)
    opts = SolverOptions(max_depth=2, max_iter=10)
    a = run(pt, path, options=opts)
    b = run(pt, path, options=opts.__class__(max_depth=2, max_iter=10, compiled=False))
    assert not a.success and a.status == 1
    assert a.message.startswith("step 21: stress target not reachable: ")
    assert "(after 2 halvings)" in a.message
    assert a.message == b.message
    assert len(a.stress) == 21  # the initial state and the 20 steps done
    _agree(a, b, rtol=1e-12)
    # the final point is the last converged state: continuing from it works
    more = run(a.final, cyclic_simple_shear(1e-4, 1, 8, constant="stress"))
    assert more.success, more.message
    assert np.allclose(a.final.stress, a.stress[-1], rtol=0, atol=1e-9 * np.abs(a.stress).max())


def test_newton_not_converging_is_reported_with_residual():
    """max_iter = 1 at a tight tolerance: 'Newton did not converge' with the residual and
    the tolerance, same as the step loop."""
    pt = _point(11, "auto")
    path = cyclic_simple_shear(1e-3, 1, 8, constant="stress")
    opts = dict(max_iter=1, max_depth=0, rtol=1e-12, rtol_accept=1e-12)
    a = run(pt, path, **opts)
    b = run(pt, path, compiled=False, **opts)
    assert not a.success
    assert "Newton did not converge in 1 iterations (residual" in a.message
    assert "(after 0 halvings)" in a.message
    assert a.message == b.message
    assert len(a.stress) == len(b.stress)


@pytest.mark.parametrize("n", [1, 2, 3, 6])
def test_small_dense_solve_and_condition_match_lapack(n: int) -> None:
    """The compiled loop's own LU solve and 2-norm condition agree with LAPACK (NumPy).

    ``np.linalg.solve`` (``dgesv``) and ``np.linalg.cond`` (singular values by ``dgesdd``)
    are what the NumPy reference step loop (``solver._solve``) uses; matrices with
    condition numbers from 1 to ~1e10, and exactly singular ones.
    """
    from grainmech.driver.affine._mixed import cond2, solve_small

    rng = np.random.default_rng(n)
    for _ in range(40):
        A = rng.normal(size=(n, n)) @ np.diag(10.0 ** rng.uniform(-5, 0, n)) @ rng.normal(size=(n, n))
        b = rng.normal(size=n)
        c = np.linalg.cond(A)
        assert cond2(A) == pytest.approx(c, rel=1e-8)
        x, ok = solve_small(A.copy(), b.copy())
        assert ok
        np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-13 * c, atol=1e-13 * c * np.abs(x).max())
    S = np.ones((n, n))  # rank one (zero matrix for n = 1 below)
    if n == 1:
        S[0, 0] = 0.0
    assert not np.isfinite(cond2(S)) or cond2(S) > 1e13
    assert n == 1 or np.linalg.cond(S) > 1e13
    _, ok = solve_small(np.zeros((n, n)), np.ones(n))
    assert not ok


def test_loop_is_compiled_once_for_the_law_and_the_pass_it_is_given():
    """The loop is compiled ahead of its call for the types of the law and of the pass
    (``kernel.law_signature``, ``_mixed.pass_signature``; meanwhile a worker may compile
    those two). The first-class function values it is then called with must have exactly
    these types: otherwise numba compiles the loop a second time, silently, and the first
    run pays for it twice."""
    from numba import types

    from grainmech.driver.affine import _mixed

    r = run(_point(23, "auto"), cyclic_simple_shear(1e-4, 1, 20, constant="stress"))
    assert r.success, r.message
    sigs = list(_mixed._segment_compiled.overloads)
    assert sigs
    assert all(isinstance(s[0], types.FunctionType) and isinstance(s[1], types.FunctionType) for s in sigs)
    # no two loops that differ only in the types of the functions passed
    assert len({s[2:] for s in sigs}) == len(sigs)


def test_compile_worker_can_be_switched_off(monkeypatch):
    """``GRAINMECH_COMPILE_WORKER=0``: no worker process; the law and the pass are then
    compiled in the calling process (the other tests of this file run with the default)."""
    from grainmech.driver.affine import _mixed

    monkeypatch.setenv("GRAINMECH_COMPILE_WORKER", "0")
    assert _mixed._start_worker(((0, False), (), False, ())) is None


def _assert_images(state, cs, group, rtol=0.0):
    """Every row of ``state`` is the image of its partner under each sign map of ``group``
    (vector fields mapped, the others equal), bit for bit (``rtol = 0``) or to ``rtol`` of
    the field's largest magnitude: the folding's premise."""
    from grainmech.driver.affine import _fold

    for g in group:
        img = _fold.images(cs.normals, cs.branch, cs.weights, g)
        assert img is not None, g
        for name, a in zip(state._fields, state):
            want = a * np.asarray(g, a.dtype) if name in _fold.VECTOR_FIELDS else a
            if rtol and a.dtype.kind == "f":
                np.testing.assert_allclose(a[img], want, rtol=0, atol=rtol * np.abs(a).max(),
                                           err_msg=f"{name} under {g}")
            else:
                np.testing.assert_array_equal(a[img], want, err_msg=f"{name} under {g}")


def _folded_equals_unfolded(monkeypatch, pt, path, mod, group_size):
    """The folded run (one row per orbit) against the unfolded one: stresses, tangents,
    energies and Newton iterations to rounding, the unfolded final state; the folded path
    taken (``mod.unfold`` called with a folding of ``group_size`` maps)."""
    from grainmech.driver.affine import _fold

    full = run(pt, path, options=SolverOptions(fold=False))
    assert full.success, full.message
    calls = []
    real = mod.unfold
    monkeypatch.setattr(mod, "unfold", lambda *a: calls.append(a[0]) or real(*a))
    folded = run(pt, path)
    assert calls and all(len(c.group) == group_size for c in calls), "the folded path was not taken"
    _agree(folded, full, rtol=1e-10)
    np.testing.assert_array_equal(folded.iterations, full.iterations)
    st = full.final.state
    for name, a, b in zip(st._fields, folded.final.state, st):
        if a.dtype.kind == "f":
            np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-8 * np.abs(b).max(), err_msg=name)
        else:
            np.testing.assert_array_equal(a, b, err_msg=name)
    return full, calls[0]


@pytest.mark.parametrize("constant", ["stress", "volume"])
def test_symmetric_rows_stay_images_and_folding_them_changes_nothing(monkeypatch, constant):
    """Folding by the path's symmetries (driver/_fold.py). Cyclic simple shear in xz
    (gamma_xz cycled, eps_xy = eps_yz = 0) with sigma_zz held (the compiled Newton loop) or
    at constant volume (the fused pass) is invariant under the antipodal map and the
    mirror y -> -y: an unfolded run keeps every row the exact image of its partner under
    the four maps of that group (T and the slip axis mapped bit for bit, every other field
    equal: the premise, checked on the law itself), and the folded run -- one row per orbit
    (5810 -> 1475 rows at degree 131; 194 -> 53 at degree 23), the orbit's weight -- gives the
    unfolded run's stresses, tangents, energies and Newton iterations to rounding, and its
    unfolded final state. Cyclic simple shear to 1e-3."""
    from grainmech.driver.affine import _fold, _fused, _mixed

    pt = _point(41, "auto")
    cs = pt.contacts
    path = cyclic_simple_shear(1e-3, 2, 40, constant=constant)
    assert _fold.path_mirrors(path.stress_control[0], path.increment, pt.stress) == ((1, -1, 1),)
    mod = _mixed if constant == "stress" else _fused
    # the isotropic start is symmetric to rounding only (its forces come from a matrix
    # product): the fold takes it, and the results agree to rounding
    full, f = _folded_equals_unfolded(monkeypatch, pt, path, mod, 4)
    assert sorted(map(tuple, f.group.tolist())) == [(-1, -1, -1), (-1, 1, -1), (1, -1, 1), (1, 1, 1)]
    assert len(f.rows) < len(cs) // 3
    # the premise, from an exactly symmetric start (the representatives' rows unfolded):
    # the unfolded run keeps every row the exact image of its partners
    st0 = type(pt.state)(*(f.unfold(a[f.rows], name) for name, a in zip(pt.state._fields, pt.state)))
    _assert_images(st0, cs, f.group)
    exact = MaterialPoint.from_forces(cs, LAW, st0.normal_force, st0.tangential_force)
    full = run(exact, path, options=SolverOptions(fold=False))
    assert full.success, full.message
    _assert_images(full.final.state, cs, f.group)
    # the folded sums' components: sigma_xy, sigma_yz are odd under y -> -y (zero), and so
    # are the tangent entries coupling them to the others
    sym = f.sym
    np.testing.assert_array_equal(sym[:6], [1, 1, 1, 0, 1, 0])
    S = sym[6:].reshape(6, 6)
    assert S[3, 5] == S[5, 3] == S[3, 3] == 1 and S[3, 4] == S[0, 5] == 0 and S[0, 4] == 1
    assert np.abs(full.stress[:, [3, 5]]).max() <= 1e-12 * np.abs(full.stress).max()


def test_triaxial_path_folds_by_all_three_mirrors(monkeypatch):
    """A drained cyclic triaxial path (eps_zz cycled, lateral and shear stresses held at
    their zero targets) is invariant under every mirror through a coordinate plane: the
    group of eight sign maps, ~1/8 of the rows; the folded Newton loop equals the
    unfolded one, and the unfolded state is the image of itself under all eight maps --
    to rounding: with the shear stresses held, the unfolded run's Newton corrects the shear
    strains by rounding-level amounts (its stress sums are symmetric only to rounding),
    so its rows are images to 1e-12, not bit for bit (the folded run keeps them at zero)."""
    from grainmech.driver.affine import _mixed
    from grainmech.driver.paths import cyclic_triaxial

    pt = _point(23, "auto")
    path = cyclic_triaxial(2e-4, 1, 40)
    _, f = _folded_equals_unfolded(monkeypatch, pt, path, _mixed, 8)
    assert len(f.rows) == 31  # of 194
    st0 = type(pt.state)(*(f.unfold(a[f.rows], name) for name, a in zip(pt.state._fields, pt.state)))
    exact = MaterialPoint.from_forces(pt.contacts, LAW, st0.normal_force, st0.tangential_force)
    full = run(exact, path, options=SolverOptions(fold=False))
    _assert_images(full.final.state, pt.contacts, f.group, rtol=1e-12)
    np.testing.assert_array_equal(f.sym[:6], [1, 1, 1, 0, 0, 0])


def test_segments_with_different_symmetries_fold_each_by_its_own_group(monkeypatch):
    """Drained triaxial compression (eight maps), then simple shear in xy with sigma_zz held
    (its path and the state allow the antipodal map and z -> -z), then simple shear in xz
    at constant volume (its path allows y -> -y, but the xy history left a state that is
    not symmetric under it: the antipodal map alone): each segment is folded by the group
    its path and its starting state allow, and the whole run equals the unfolded one to
    rounding with identical Newton iterations."""
    from grainmech.driver.affine import _mixed
    from grainmech.driver.paths import Control, concatenate, triaxial

    pt = _point(23, "auto")
    xy = np.zeros(6)
    xy[5] = 1.0
    xz = np.zeros(6)
    xz[4] = 1.0
    held = Control((False, False, True, False, False, False))
    path = concatenate([triaxial(1e-4, 10), segment(held, 1e-4 * xy, 10), segment("EEEEEE", 2e-4 * xz, 10)])
    full = run(pt, path, options=SolverOptions(fold=False))
    assert full.success, full.message
    groups: list = []
    real = _mixed.unfold

    def watch(folding, *a):
        g = sorted(map(tuple, folding.group.tolist()))
        if not groups or groups[-1] != g:
            groups.append(g)
        return real(folding, *a)

    monkeypatch.setattr(_mixed, "unfold", watch)
    folded = run(pt, path)
    assert len(groups) == 3 and len(groups[0]) == 8, groups
    assert groups[1] == [(-1, -1, -1), (-1, -1, 1), (1, 1, -1), (1, 1, 1)]   # z -> -z
    assert groups[2] == [(-1, -1, -1), (1, 1, 1)]                             # antipodal only
    _agree(folded, full, rtol=1e-10)
    np.testing.assert_array_equal(folded.iterations, full.iterations)


def test_compiled_loop_matches_reference_when_the_shear_turns_and_cycles_return():
    """Cyclic triaxial, simple shear in xy with sigma_zz held, then one cycle of simple
    shear in xz at constant volume (194 directions): the xz motion is at right angles to
    the slip axes the xy shear left, and the cycles come back to remembered levels. The
    compiled loop and the NumPy reference agree to 1e-10 in stress and tangent, with the
    same iterations. Before the two rounding rules of the law (hysteresis.PAR_TOL,
    TIE_TOL), the sign of a rounding-size displacement along an axis decided a reversal
    and a return to a remembered level closed the loop or not by rounding: the two parted
    by 5e-4 in stress and 3e-3 in tangent (folded and unfolded runs by up to 2.5e-5)."""
    from grainmech.driver.paths import Control, concatenate, cyclic_triaxial

    xy = np.zeros(6)
    xy[5] = 1.0
    held = Control((False, False, True, False, False, False))
    path = concatenate([cyclic_triaxial(1e-4, 1, 20), segment(held, 5e-5 * xy, 10),
                        cyclic_simple_shear(1e-4, 1, 20, constant="volume")])
    ref = run(_point(23, "numpy"), path, options=SolverOptions(compiled=False))
    for options in (SolverOptions(fold=False), SolverOptions()):
        r = run(_point(23, "auto"), path, options=options)
        _agree(r, ref, rtol=1e-10)
        np.testing.assert_array_equal(r.iterations, ref.iterations)


def _random_turning_path(rng):
    """Two or three segments: cycles or monotonic loading along one shear component, a
    random shear direction or the axis (then the lateral and shear stresses held), with
    sigma_zz held or at constant volume, amplitudes 1e-5 to 3e-4."""
    from grainmech.driver.paths import Control, concatenate, cycles

    segs = []
    for _ in range(rng.integers(2, 4)):
        d = np.zeros(6)
        kind = rng.integers(3)
        if kind == 0:
            d[rng.integers(3, 6)] = 1.0
        elif kind == 1:
            d[3:] = rng.normal(size=3)
        else:
            d[2] = 1.0
        held = Control((True, True, False, True, True, True) if kind == 2 else (False, False, True, False, False, False))
        if kind != 2 and rng.random() < 0.5:
            held = Control((False,) * 6)
        amp = float(10 ** rng.uniform(-5, -3.5))
        n = 4 * int(rng.integers(2, 7))
        d = d / np.abs(d).max()
        segs.append(cycles(held, d, amp, 1, n) if rng.random() < 0.5 else segment(held, amp * d, n // 2))
    return concatenate(segs)


def test_compiled_loop_matches_reference_on_random_turning_paths():
    """Twelve random paths of two or three segments (shear turning between components and
    directions, cycles back to remembered levels, sigma_zz held or constant volume, 194
    directions): the compiled loop (folded) and the NumPy reference agree to 1e-9 in
    stress and 1e-8 in tangent with the same iterations. The same twelve paths on commit
    145c694, before the law's rounding rules (hysteresis.PAR_TOL, TIE_TOL): two parted
    (tangents by 4.4e-4 and 8.2e-4); of 25 such paths six (stress up to 1.2e-4, tangent
    up to 3.6e-3); after: none, the largest difference 8.4e-14 in stress."""
    rng = np.random.default_rng(2)
    ref_pt, pt = _point(23, "numpy"), _point(23, "auto")
    for _ in range(12):
        path = _random_turning_path(rng)
        a = run(pt, path)
        r = run(ref_pt, path, options=SolverOptions(compiled=False))
        assert a.success and r.success, (a.message, r.message)
        assert np.abs(a.stress - r.stress).max() <= 1e-9 * np.abs(r.stress).max()
        assert np.abs(a.tangent - r.tangent).max() <= 1e-8 * np.abs(r.tangent).max()
        np.testing.assert_array_equal(a.iterations, r.iterations)


def test_path_mirrors_follow_the_zero_shear_components():
    """Which mirrors a path allows (driver/_fold.path_mirrors)."""
    from grainmech.driver.affine._fold import path_mirrors
    from grainmech.driver.paths import Control, parse_mask

    E = parse_mask("EEEEEE").array
    inc = np.zeros((3, 6))
    inc[:, 4] = 1e-5   # gamma_xz: x and z mirrors change its sign
    assert path_mirrors(E, inc) == ((1, -1, 1),)
    inc[1, 5] = 1e-9   # one step with gamma_xy too: no mirror at all
    assert path_mirrors(E, inc) == ()
    inc = np.zeros((3, 6))
    inc[:, 2] = -1e-5  # axial only: all three
    assert path_mirrors(E, inc) == ((-1, 1, 1), (1, -1, 1), (1, 1, -1))
    S = Control.all_stress().array
    # stress-controlled shear components: only with zero increments and zero targets
    assert path_mirrors(S, inc, np.array([1e5, 1e5, 1e5, 0, 0, 0])) == ((-1, 1, 1), (1, -1, 1), (1, 1, -1))
    assert path_mirrors(S, inc, np.array([1e5, 1e5, 1e5, 0, 0, 1.0])) == ((1, 1, -1),)  # sigma_xy = 1
    assert path_mirrors(S, inc) == ()  # targets unknown


def test_a_state_that_breaks_a_mirror_folds_by_the_rest():
    """A tangential force with a y-component on one row breaks y -> -y but keeps the
    antipodal symmetry (it is set on the row's antipode too): the group of two is taken."""
    from grainmech.driver.affine import _fold

    pt = _point(23, "auto")
    cs = pt.contacts
    keep, partner = _fold.antipodal_pairs(cs.normals, cs.branch, cs.weights)
    T = pt.state.tangential_force.copy()
    T[keep[4]] = [0.0, 1e-3, 0.0]
    T[partner[4]] = [0.0, -1e-3, 0.0]
    st = pt.state._replace(tangential_force=T)
    f = _fold.fold(cs, st, pt.response, True, ((1, -1, 1),))[0]
    assert f is not None and sorted(map(tuple, f.group.tolist())) == [(-1, -1, -1), (1, 1, 1)]
    assert len(f.rows) == len(cs) // 2
    # unfolding the representatives' rows gives the whole state back
    for name, a in zip(st._fields, st):
        np.testing.assert_array_equal(f.unfold(a[f.rows], name), a, err_msg=name)
    assert _fold.fold(cs, st, pt.response, False, ((1, -1, 1),))[0] is None


def test_no_folding_without_exact_antipodes_or_a_mirrored_state():
    """A set with a row dropped, or with one weight changed, has no pairing; a state in which
    one contact's tangential force is not the mirror of its antipode is not folded."""
    from grainmech.driver.affine import _fold

    pt = _point(41, "auto")
    cs = pt.contacts
    assert _fold.antipodal_pairs(cs.normals[1:], cs.branch[1:], cs.weights[1:]) is None
    w = cs.weights.copy()
    w[3] *= 1 + 1e-15
    assert _fold.antipodal_pairs(cs.normals, cs.branch, w) is None
    keep, partner = _fold.antipodal_pairs(cs.normals, cs.branch, cs.weights)
    assert _fold.is_mirrored(pt.state, pt.response, keep, partner)
    T = pt.state.tangential_force.copy()
    T[partner[5]] = [1e-3, 0.0, 0.0]
    assert not _fold.is_mirrored(pt.state._replace(tangential_force=T), pt.response, keep, partner)

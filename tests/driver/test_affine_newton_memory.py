"""The NumPy and compiled driver paths solve the same Newton problem, and plain symmetric
cycling does not fill the Mindlin-Deresiewicz reversal memory.

References: the consistent contact tangent ``K = ks_perp (I - nn) + kn nn + (ks - ks_perp) ee
+ ktn e n`` follows from the rate law of seed Eq. 3.11 (Thornton & Randall 1988);
Masing's rule (a closed loop is forgotten; Mindlin & Deresiewicz 1953, seed Eq. 3.13-3.15)
bounds the memory needed by constant-amplitude cycling.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.assembly import ContactSet
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint, SolverOptions, cyclic_simple_shear, run
from grainmech.driver.affine.point import consistent_tangent, evaluate, tangent
from grainmech.fabric import sphere_rule

RADIUS = 1e-3
LAW = MindlinDeresiewicz(29e9, 0.15, RADIUS, friction=0.5)


def _point(degree: int) -> MaterialPoint:
    normals, w = sphere_rule(degree)
    nv = 8 / (2 * (4 / 3 * np.pi * RADIUS ** 3) * 1.6)  # e = 0.6, 8 contacts per grain
    cs = ContactSet(normals, 2 * RADIUS * normals, nv * w, 0.0, 0.0)
    return MaterialPoint.isotropic(cs, LAW, 1e5)


def test_numpy_jacobian_equals_the_compiled_one():
    """The NumPy consistent tangent equals the compiled pass's Jacobian rows (sliding state)."""
    pytest.importorskip("numba")
    from grainmech.driver.affine.solver import _fused_evaluate

    pt = _point(23)
    de = np.array([0, 0, 1e-5, 0, 4e-4, 0.0])
    ev = evaluate(pt, de)
    J = consistent_tangent(pt.contacts, ev.response)
    Jc = _fused_evaluate(pt, de, np.ones(6, dtype=bool)).jacobian
    assert np.abs(J - Jc).max() <= 1e-9 * np.abs(Jc).max()
    assert ev.response.sliding.any() and (np.abs(ev.response.ktn) > 0).any()
    # the symmetric tangent (no coupling, ks along every tangential direction) is not it
    assert np.abs(tangent(pt.contacts, ev.response) - J).max() > 1e-3 * np.abs(J).max()


@pytest.mark.parametrize("degree, n_dirs", [(5, 14), (23, 194)])
def test_numpy_and_compiled_newton_agree(degree, n_dirs):
    """Mixed control EESEEE at gamma = 1e-3: same success, iterations per step and stresses.

    Before the NumPy path carried ``ks_perp``, ``ktn`` and the slip axis it failed on the
    14-direction set (step 27) and needed 886 instead of 378 iterations on 194 directions.
    """
    pytest.importorskip("numba")
    pt = _point(degree)
    assert len(pt.contacts.weights) == n_dirs
    path = cyclic_simple_shear(1e-3, 2, 40, constant="stress")
    a = run(pt, path, options=SolverOptions(compiled=True))
    b = run(pt, path, options=SolverOptions(compiled=False))
    assert a.success and b.success, (a.message, b.message)
    assert np.array_equal(a.iterations, b.iterations)
    assert np.abs(a.stress - b.stress).max() <= 1e-10 * np.abs(a.stress).max()
    assert np.abs(a.dissipation - b.dissipation).max() <= 1e-10 * a.dissipation.max()


@pytest.mark.parametrize("degree, n_dirs, n_iter", [(5, 14, 298), (23, 194, 268)])
def test_without_numba_the_driver_gives_the_compiled_answer(monkeypatch, degree, n_dirs, n_iter):
    """numba absent (the NumPy reference law, NumPy Jacobian) vs the compiled pass with its
    Jacobian rows: same success, same Newton iterations at every step, same stresses.

    ``n_iter`` is the compiled path's total, which the NumPy path must reproduce; it is not
    a reference value of its own (398 and 378 with the earlier continuum Jacobian, 298 and
    268 with the laws' step tangent).
    """
    pytest.importorskip("numba")
    from grainmech.contact import law as law_module

    pt = _point(degree)
    assert len(pt.contacts.weights) == n_dirs
    path = cyclic_simple_shear(1e-3, 2, 40, constant="stress")
    a = run(pt, path, options=SolverOptions(compiled=True))
    monkeypatch.setattr(law_module, "_KERNEL", False)  # as if numba were not installed
    b = run(pt, path, options=SolverOptions(compiled=True))
    assert a.success and b.success, (a.message, b.message)
    assert int(a.iterations.sum()) == n_iter
    assert np.array_equal(a.iterations, b.iterations)
    assert np.abs(a.stress - b.stress).max() <= 1e-10 * np.abs(a.stress).max()
    assert np.abs(a.dissipation - b.dissipation).max() <= 1e-10 * a.dissipation.max()


def test_compiled_pass_returns_the_consistent_tangent_terms():
    """The response of a compiled strain-controlled run carries ks_perp, ktn and the slip
    axis, so the NumPy consistent tangent rebuilt from it equals the compiled Jacobian."""
    pytest.importorskip("numba")
    from grainmech.driver.affine.solver import _fused_evaluate

    pt = _point(23)
    de = np.array([0, 0, 1e-5, 0, 4e-4, 0.0])
    ev = _fused_evaluate(pt, de, np.ones(6, dtype=bool))
    assert ev.response.ks_perp is not None and ev.response.ktn is not None
    J = consistent_tangent(pt.contacts, ev.response)
    assert np.abs(J - ev.jacobian).max() <= 1e-9 * np.abs(ev.jacobian).max()


@pytest.mark.slow
@pytest.mark.parametrize("constant", ["volume", "stress"])
def test_fifty_cycles_keep_the_memory_bounded(constant):
    """5810 directions, 50 cycles at 1e-6 ... 1e-3: every run succeeds, depth stays small.

    8 steps per cycle keep the test short; the memory problem it guards against (a
    reversal pushed at every half cycle and never erased) does not depend on the step.
    """
    pt = _point(131)
    assert len(pt.contacts.weights) == 5810
    for amp in (1e-6, 1e-5, 1e-4, 1e-3):
        r = run(pt, cyclic_simple_shear(amp, 50, 8, constant=constant))
        assert r.success, f"{constant} {amp}: {r.message}"
        assert r.final.state.depth.max() <= LAW.max_reversals


def test_contact_cli_fifty_cycles_with_a_varying_normal_force(tmp_path, cli):
    """`grainmech contact`: 50 one-dimensional displacement cycles, N cycled too (Thornton-
    Randall rules move every reversal level), then 50 at constant N: the run completes."""

    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[contact]\nlaw = "mindlin-deresiewicz"\nshear_modulus = "29 GPa"\npoisson = 0.22\n'
        'radius = "1 mm"\nfriction = 0.5\n[initial]\nnormal_force = "10 N"\n'
        + "".join('[[path]]\nsteps = 4\n'
                  f'tangential_displacement = "{0.4 * (-1) ** k} um"\nnormal_force = "{10 + (k % 3)} N"\n'
                  for k in range(100))
        + '[[path]]\nkind = "cycles"\ncount = 50\nsteps = 8\ntangential_displacement_amplitude = "0.3 um"\n')
    assert cli("contact", str(cfg), "-o", str(tmp_path / "out")).rc == 0
    rows = (tmp_path / "out" / "contact.csv").read_text().splitlines()
    assert len(rows) > 50 * 8 * 2


def test_rotating_tangential_path_keeps_the_memory_bounded():
    """A tangential displacement that rotates (circle, 50 turns) and one that goes back and
    forth along a line at constant N: the depth never grows past 2 (Masing's rule)."""
    from grainmech.contact import state_from_normal_force, update

    st = state_from_normal_force(LAW, np.array([10.0, 10.0]), 3)
    amp = 2e-7
    depth = []
    for k in range(50 * 16):
        t0, t1 = 2 * np.pi * k / 16, 2 * np.pi * (k + 1) / 16
        circle = amp * np.array([0.0, np.cos(t1) - np.cos(t0), np.sin(t1) - np.sin(t0)])
        line = amp * np.array([0.0, np.sin(t1) - np.sin(t0), 0.0])
        st, resp = update(LAW, st, np.zeros(2), np.stack([circle, line]))
        depth.append(st.depth.copy())
    depth = np.array(depth)
    assert depth.max() <= 2
    assert depth[-16:, 1].max() >= 1  # the line path does remember its reversal (seed Fig. 3.1)

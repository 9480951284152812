"""Strain-controlled cyclic simple shear with the Mindlin-Deresiewicz law.

Checks: loops close after the first cycle (Masing); G/Gmax falls
and damping rises monotonically with amplitude; G at the smallest amplitude equals the
small-strain modulus of the stiffness tensor (seed Eq. 2.26 with kt0 = 8 G* a) within 1 %;
energy balance over cycles; step-halving stability (stated tolerances).
"""

import numpy as np
import pytest

from grainmech.analysis import condensed_modulus, loop_properties, modulus_reduction
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint, cyclic_simple_shear, parse_mask, run
from grainmech.fabric import isotropic
from grainmech.material import Packing

PK = Packing.from_grains(isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)
LAW = MindlinDeresiewicz(29e9, 0.15, 1e-3, friction=0.5)
P0 = 1e5
AMPS = [1e-6, 1e-5, 1e-4, 3e-4]


@pytest.fixture(scope="module")
def point():
    return MaterialPoint.isotropic(PK, LAW, P0)


@pytest.fixture(scope="module")
def sweep(point):
    return modulus_reduction(point, AMPS, n_cycles=2, steps_per_cycle=40)


def test_loops_close_after_first_cycle(point):
    """Masing: cycle 3 retraces cycle 2 (constant sigma_zz, strain-controlled gamma_xz)."""
    spc = 40
    r = run(point, cyclic_simple_shear(1e-4, 3, spc))
    assert r.success, r.message
    c2 = r.stress[spc:2 * spc + 1, 4]
    c3 = r.stress[2 * spc:3 * spc + 1, 4]
    tau_a = 0.5 * (c2.max() - c2.min())
    # 1.3e-4 here: under varying N (Thornton-Randall) loops close up to a small shakedown
    assert np.abs(c3 - c2).max() < 5e-4 * tau_a
    # the drift of the cycle-end stress shrinks cycle after cycle
    assert abs(r.stress[3 * spc, 4] - r.stress[2 * spc, 4]) < 0.2 * abs(r.stress[2 * spc, 4] - r.stress[spc, 4])
    # the first cycle does not close (virgin loading from the isotropic state)
    assert abs(r.stress[spc, 4] - r.stress[0, 4]) > 1e-3 * tau_a
    assert np.allclose(r.stress[:, 2], P0, rtol=1e-8)  # sigma_zz held


def test_modulus_reduction_and_damping_monotonic(sweep):
    assert np.all(np.diff(sweep.G_ratio) < 0)
    assert np.all(np.diff(sweep.damping) > 0)
    assert sweep.G_ratio[-1] < 0.9 and sweep.damping[-1] > 0.03


def test_small_amplitude_modulus_equals_stiffness_tensor(point, sweep):
    """G(1e-6)/Gmax within 1 %; Gmax = C_55 condensed with sigma_zz free (= C_55 for isotropy)."""
    C = point.tangent
    G0 = condensed_modulus(C, 4, parse_mask("EESEEE").array)
    assert G0 == pytest.approx(C[4, 4], rel=1e-9)  # isotropic C: no coupling
    assert sweep.G[0] == pytest.approx(G0, rel=1e-2)
    assert sweep.G_max == pytest.approx(G0, rel=1e-12)


def test_energy_balance_over_cycles(point):
    """Work done on the point = change of stored energy + dissipation (contact backend).

    At constant sigma_zz the packing compacts a little every cycle (Thornton-Randall
    ratcheting), so a cycle is not closed: the stored energy drops by ~2 % of the loop
    work per cycle, and work = dissipation alone fails by that amount (the "2 %"
    discrepancy once reported here). With the stored-energy change the balance holds to
    the step discretisation: 4.5e-3 of the cycle's dissipation at 40 steps per cycle,
    < 1e-4 at 160 (measured). Only cycle-to-cycle differences are compared: the law's
    stored-energy estimate |T|^2/(2 kt0) is a lower bound inside a loop (it ignores the
    slipped annulus), with the same error at the same point of every steady cycle.
    Constant volume (every strain held, loops closed): work per steady cycle = dissipation
    to 7e-4 at 160 steps per cycle, converging with the step (5.8e-3 at 40, 1.4e-4 at 640).
    """
    spc = 160
    r = run(point, cyclic_simple_shear(1e-4, 3, spc))
    assert r.success, r.message
    d_cycle = r.dissipation[3 * spc] - r.dissipation[2 * spc]
    # the cycle is not closed: stored energy falls (compaction) by 1-4 % of the loop work
    w = r.work[3 * spc] - r.work[2 * spc]
    ds = r.stored[3 * spc] - r.stored[2 * spc]
    assert -0.04 * w < ds < -0.005 * w
    assert abs((w - ds) / d_cycle - 1) < 5e-4
    # constant volume: closed loops, work per cycle = dissipation
    rv = run(point, cyclic_simple_shear(1e-4, 3, spc, constant="volume"))
    wv = rv.work[3 * spc] - rv.work[2 * spc]
    dv = rv.dissipation[3 * spc] - rv.dissipation[2 * spc]
    assert abs(rv.stored[3 * spc] - rv.stored[2 * spc]) < 1e-9 * wv
    assert wv == pytest.approx(dv, rel=2e-3)


def test_step_halving_changes_cyclic_result_little(point, sweep):
    """40 -> 80 steps per cycle: G changes < 0.1 %, damping < 3 % (stated tolerances)."""
    fine = modulus_reduction(point, AMPS[1:], n_cycles=2, steps_per_cycle=80)
    assert np.allclose(fine.G, sweep.G[1:], rtol=1e-3)
    assert np.allclose(fine.damping, sweep.damping[1:], rtol=3e-2)


def test_loop_damping_matches_single_contact_mindlin(point):
    """Damping of the packing loop is positive and below the Masing upper bound 2/pi."""
    spc = 40
    r = run(point, cyclic_simple_shear(3e-4, 2, spc))
    lp = loop_properties(r.strain[spc:, 4], r.stress[spc:, 4])
    assert 0 < lp.damping < 2 / np.pi

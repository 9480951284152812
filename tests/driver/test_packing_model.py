"""Packing driver (grainmech.driver.packing): every grain in equilibrium along a path.

References: the relaxed tensor C_relaxed = C_affine - (1/V) B^T H^+ B (Lemaitre & Maloney
2006, Eq. 12; Kruyt & Rothenburg 1998; Agnolin & Roux 2007) computed independently by
grainmech.network.relaxed_stiffness; Love-Weber stress (seed Eq. 2.6); energy balance of a
closed strain cycle (work = dissipation + change of stored energy).
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.analysis import loop_properties
from grainmech.contact import Hertz, LinearSpring, MindlinDeresiewicz
from grainmech.driver import LoadPath, cyclic_simple_shear, triaxial
from grainmech.driver.packing import (
    PackingOptions,
    PackingPoint,
    equilibrate_network,
    packing_modulus_reduction,
    perturbed_fcc_network,
    run_packing,
    unbalanced_force_ratio,
)
from grainmech.errors import GrainmechError, ParameterError
from grainmech.network import contact_stiffnesses, random_network, relaxed_stiffness

G_GRAIN, NU = 29e9, 0.15
MD = MindlinDeresiewicz(G_GRAIN, NU, 1.0, friction=0.5)


@pytest.fixture(scope="module")
def packing():
    """~100 grains, disordered fcc (5 % vacancies), equilibrated with frictionless Hertz contacts."""
    return equilibrate_network(perturbed_fcc_network(3, seed=1, vacancies=0.05), MD)


@pytest.fixture(scope="module")
def point(packing):
    return PackingPoint.from_network(packing, MD)


def test_equilibrated_packing_is_stable(packing, point):
    assert point.n_grains == 103 and point.n_rattlers == 0
    assert unbalanced_force_ratio(point) < 1e-8
    # purely normal forces (frictionless preparation): the Love-Weber stress is symmetric
    f = packing.force
    n = packing.normals
    assert np.abs(f - np.einsum("ij,ij->i", f, n)[:, None] * n).max() < 1e-9 * np.abs(f).max()


def test_small_strain_secant_equals_relaxed_c55(packing, point):
    """(a) gamma -> 0: secant G of a constant-volume cycle = relaxed_stiffness C55 (to 1e-3)."""
    kn, ks, _ = contact_stiffnesses(packing, shear_modulus=G_GRAIN, poisson=NU, source="overlap")
    rr = relaxed_stiffness(packing, kn, ks)
    C55 = rr.C_relaxed[4, 4]
    # the check is not the affine tensor in disguise
    assert rr.C_affine[4, 4] / C55 - 1 > 0.02
    # the point's own relaxed tangent (GMRES on the same operator)
    assert point.tangent[4, 4] == pytest.approx(C55, rel=1e-6)
    r = run_packing(point, cyclic_simple_shear(1e-5, 1, 40, constant="volume"))
    assert r.success, r.message
    lp = loop_properties(r.strain[:, 4], r.stress[:, 4])
    assert lp.secant_modulus == pytest.approx(C55, rel=1e-3)
    assert r.residual.max() < 1e-6


@pytest.mark.parametrize("backend", ["pardiso", "cholespy", "superlu"])
def test_factorisations_agree(packing, point, backend):
    """Every factorisation of the elastic operator solves it to its precision (checked by
    the residual of the assembled operator, independent of the factor: round-off for
    cholespy and SuperLU, single precision for PARDISO) and gives the same relaxed tangent
    as ``relaxed_stiffness`` (the check above) and, refined by CG, the same elastic one."""
    import importlib.util

    if backend != "superlu" and importlib.util.find_spec({"pardiso": "pypardiso"}.get(backend, backend)) is None:
        pytest.skip(f"{backend} not installed")
    pt = PackingPoint.from_network(packing, MD, options=PackingOptions(factorization=backend))
    prec = pt.preconditioner()
    assert prec.factor.name == backend
    b = np.random.default_rng(3).standard_normal(pt.kinematics.n_free)
    x = prec.factor.solve(b)
    np.testing.assert_allclose(prec.factor.solve(b), x, rtol=1e-12, atol=0)  # the factor is kept
    K0 = pt.contact_stiffness()[1]
    from grainmech.driver.packing._operators import block_diagonal

    kin = pt.kinematics
    H = (kin.Gt @ (block_diagonal(K0) @ kin.G)).tocsr()
    # the factor is of H + S, S = regularization x diag(H) (PackingOptions.regularization;
    # a floor where the diagonal vanishes): the residual of that matrix, assembled here
    dg = H.diagonal()
    big = dg > 1e-3 * np.median(dg)
    np.testing.assert_allclose(prec.shift[big], pt.regularization * dg[big], rtol=1e-12)
    # PARDISO factors in single precision (a preconditioner, refined where it must be
    # exact): relative residual 1.4e-6 seen; the double-precision factorisations 1e-14
    tol = 1e-5 if backend == "pardiso" else 1e-8
    assert np.linalg.norm(H @ x + prec.shift * x - b) <= tol * np.linalg.norm(b)
    assert pt.tangent[4, 4] == pytest.approx(point.tangent[4, 4], rel=1e-8)
    # the elastic tangent is of H itself, whatever the shift: CG refinement with the factor
    Y, res = prec.exact_Y()
    assert res.max() <= 1e-10
    assert np.linalg.norm(H @ Y - prec.B0) <= 1e-9 * np.linalg.norm(prec.B0)


def test_regularization_leaves_the_equilibrium_alone(packing):
    """The shift of the elastic operator (PackingOptions.regularization) changes how the
    iterations reach equilibrium, not the equilibrium: G_max (C55 of the elastic tangent)
    and a cyclic loop at 1e-5 agree for shifts 1e-10 and 1e-3 (the loop converges to
    rtol = 1e-8 here; measured: stresses within 1e-11 of the largest, the bound 1e-8)."""
    out = []
    for reg in (1e-10, 1e-3):
        pt = PackingPoint.from_network(packing, MD, options=PackingOptions(regularization=reg))
        res = run_packing(pt, cyclic_simple_shear(1e-5, 1, 16, constant="volume"),
                          PackingOptions(regularization=reg))
        assert res.success, res.message
        out.append((pt.elastic_tangent, res.stress))
    np.testing.assert_allclose(out[1][0], out[0][0], rtol=0, atol=1e-9 * np.abs(out[0][0]).max())
    np.testing.assert_allclose(out[1][1], out[0][1], rtol=0, atol=1e-8 * np.abs(out[0][1]).max())
    with pytest.raises(ParameterError, match="regularization"):
        PackingOptions(regularization=0.5)
    with pytest.raises(ParameterError, match="reproducible"):
        PackingOptions(reproducible="yes")
    for bad in (-1e-3, 0.5, "1e-3"):
        with pytest.raises(ParameterError, match="rtol_step"):
            PackingOptions(rtol_step=bad)
    for bad in (-0.1, 1.5, True, "0.1", float("nan")):
        with pytest.raises(ParameterError, match="settle"):
            PackingOptions(settle=bad)
    for bad in (0.0, -0.01, True, "0.01", float("nan")):
        with pytest.raises(ParameterError, match="rest_step"):
            PackingOptions(rest_step=bad)
    assert PackingOptions(rest_step=float("inf")).rest_step == float("inf")


def test_anderson_and_newton_krylov_reach_the_same_equilibria(point):
    """Anderson-accelerated elastic iterations (PackingOptions.anderson, the default) and
    Newton-Krylov alone (anderson = 0) solve the same step equations, so they give the
    same path: a drained cyclic simple shear at 3e-3, where contacts reach the Coulomb
    limit and reverse, to within the acceptance tolerance of a step (the larger of
    rtol_accept = 1e-5 of the stress scale, 580 Pa here, and rtol_step = 1e-3 of the
    step's affine stress change, a few kPa; bound 1e-4 of the largest stress, 5.8 kPa),
    with the same damping."""
    out = []
    for m in (10, 0):
        opts = PackingOptions(anderson=m)
        res = run_packing(point, cyclic_simple_shear(3e-3, 1, 16, constant="stress"), opts)
        assert res.success, res.message
        out.append(res)
    aa, nk = out
    assert any("Anderson" in n for n in aa.notes) and not any("Anderson" in n for n in nk.notes)
    scale = np.abs(nk.stress).max()
    np.testing.assert_allclose(aa.stress, nk.stress, rtol=0, atol=1e-4 * scale)
    la = loop_properties(aa.strain[:, 4], aa.stress[:, 4])
    ln = loop_properties(nk.strain[:, 4], nk.stress[:, 4])
    assert la.damping > 0.002  # contacts slide (measured 0.47 %: this packing is under 58 MPa)
    assert la.damping == pytest.approx(ln.damping, abs=1e-4)
    for bad in (-1, 51, 2.5, True):
        with pytest.raises(ParameterError, match="anderson"):
            PackingOptions(anderson=bad)


def test_settled_stress_stops_the_iterations_with_the_same_loop():
    """PackingOptions.settle (default 0.1) stops a step's Anderson iterations once the
    stress is settled, before every grain is within rtol; settle = 0 iterates to rtol.
    On the shipped 'dense' packing (the built-in default's: Mindlin-Deresiewicz, quartz,
    drained cyclic simple shear at 1e-5, 20 steps) both give the same loop: stresses
    within 1e-4 of the shear stress amplitude, the same secant modulus to 1e-5 and
    damping to 1 %, with at most half the iterations (measured: 86 against 206; stress
    difference 1.3e-5 of the amplitude, damping 0.07 %)."""
    from grainmech.packing import QUARTZ, load_packing

    net = load_packing("dense")
    law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()),
                             friction=QUARTZ.friction)
    pt = PackingPoint.from_network(net, law)
    out = []
    for settle in (0.0, PackingOptions().settle):
        r = run_packing(pt, cyclic_simple_shear(1e-5, 1, 20, constant="stress"),
                        PackingOptions(settle=settle, law_backend="auto", tangent="none"))
        assert r.success, r.message
        out.append(r)
    exact, settled = out
    assert PackingOptions().settle == 0.1
    assert not any("settle" in n for n in exact.notes)
    assert any(n.startswith("20 (sub)steps stopped once the stress uncertainty left and the estimated "
                                 "stress change still to come") for n in settled.notes)
    assert exact.residual.max() < 1e-7 < settled.residual.max()
    assert settled.iterations.sum() <= 0.5 * exact.iterations.sum()
    amp = np.abs(exact.stress[:, 4] - exact.stress[0, 4]).max()
    assert np.abs(settled.stress - exact.stress).max() <= 1e-4 * amp
    le = loop_properties(exact.strain[:, 4], exact.stress[:, 4])
    ls = loop_properties(settled.strain[:, 4], settled.stress[:, 4])
    assert ls.secant_modulus == pytest.approx(le.secant_modulus, rel=1e-5)
    assert ls.damping == pytest.approx(le.damping, rel=1e-2)


@pytest.mark.parametrize("ks_ratio", [0.0, 0.5])
def test_linear_springs_follow_relaxed_tensor(packing, ks_ratio):
    """(b) linear springs, no Coulomb limit: stress change = relaxed C . strain at every amplitude."""
    Nmean = float(np.mean(packing.normal_force))
    kn = Nmean / (0.02 * 1.0)  # approach ~2 % of the radius: no contact opens below gamma = 1e-3
    law = LinearSpring(kn, ks_ratio * kn)
    pt = PackingPoint.from_network(packing, law)
    rr = relaxed_stiffness(packing, np.full(packing.n_contacts, kn), np.full(packing.n_contacts, ks_ratio * kn))
    for amp in (1e-6, 1e-4, 1e-3):
        r = run_packing(pt, cyclic_simple_shear(amp, 1, 8, constant="volume"), rtol=1e-10, tangent="start")
        assert r.success, r.message
        dsig = r.stress - r.stress[0]
        expect = r.strain[:, 4:5] * rr.C_relaxed[:, 4][None, :]
        assert np.abs(dsig - expect).max() <= 1e-4 * amp * rr.C_relaxed[4, 4]


def test_energy_balance_converges_with_step(point):
    """(c) second closed constant-volume cycle: work = dissipation (+ stored change), converging."""
    errs = []
    for spc in (8, 16, 32):
        r = run_packing(point, cyclic_simple_shear(1e-3, 2, spc, constant="volume"), tangent="start")
        assert r.success, r.message
        c2 = slice(spc, 2 * spc + 1)
        W = r.work[c2][-1] - r.work[c2][0]
        D = r.dissipation[c2][-1] - r.dissipation[c2][0]
        dU = r.stored[c2][-1] - r.stored[c2][0]
        assert D > 0
        errs.append(abs(W - D - dU) / D)
    assert errs[-1] < 2e-3
    assert errs[0] > errs[1] > errs[2]


def test_drained_triaxial_has_a_peak():
    """(d) sigma_3 held, axial strain driven: sigma1/sigma3 reaches a peak (grains rearrange)."""
    net = equilibrate_network(perturbed_fcc_network(3, seed=1, vacancies=0.05, overlap=0.004, disorder=0.0008), MD)
    pt = PackingPoint.from_network(net, MD)
    r = run_packing(pt, triaxial(0.012, 30), tangent="start")
    assert r.success, r.message
    ratio = r.stress[:, 2] / r.stress[:, 0]
    k = int(np.argmax(ratio))
    # seen: peak 5.17 at eps_a = 0.9 %, 5.05 at 1.2 %; sigma_3 held to 1e-8
    assert 3.0 < ratio[k] < 8.0
    assert 0 < k < len(ratio) - 1 and ratio[-1] < ratio[k] - 0.05
    assert np.abs(r.stress[:, 0] / r.stress[0, 0] - 1).max() < 1e-6
    assert r.sliding_fraction[k] > 0.3


def test_modulus_reduction_on_a_packing(point):
    mr = packing_modulus_reduction(point, [1e-5, 1e-3], n_cycles=1, steps_per_cycle=16)
    assert mr.success
    assert 0.98 < mr.G_ratio[0] <= 1.001
    assert mr.G_ratio[1] < mr.G_ratio[0]
    assert mr.damping[1] > mr.damping[0] >= 0


# ------------------------------------------------------------------------- bad input (e)

def test_unstable_packing_is_refused():
    net = random_network(60, seed=3)
    with pytest.raises(GrainmechError, match="not mechanically stable: unbalanced force ratio"):
        PackingPoint.from_network(net, MD)


def test_damping_of_frictionless_packing_is_refused(packing):
    pt = PackingPoint.from_network(packing, Hertz(G_GRAIN, NU, 1.0))
    with pytest.raises(GrainmechError, match="damping needs friction"):
        packing_modulus_reduction(pt, [1e-4])


def test_path_beyond_small_strain_keeps_results(point):
    r = run_packing(point, triaxial(0.05, 10), tangent="start")
    assert not r.success and r.status == 2
    assert "max_strain" in r.message and "results kept up to step 4" in r.message
    assert len(r.strain) == 5 and r.strain[-1, 2] == pytest.approx(0.02)


def test_fluctuation_bound_stops_the_run(point):
    r = run_packing(point, cyclic_simple_shear(1e-3, 1, 8, constant="volume"), max_fluctuation=1e-5,
                    tangent="start")
    assert not r.success and r.status == 2
    assert "displacement fluctuation" in r.message
    assert len(r.strain) >= 1


def test_bad_arguments_name_the_field(packing):
    with pytest.raises(ParameterError, match="forces"):
        PackingPoint.from_network(packing, MD, forces="magic")
    with pytest.raises(ParameterError, match="params"):
        PackingPoint.from_network(packing, object())
    with pytest.raises(ParameterError, match="tangent"):
        PackingOptions(tangent="sometimes")
    with pytest.raises(GrainmechError, match="exceeds mu N"):
        f = packing.force.copy()
        f[0] += 10 * np.linalg.norm(f[0]) * np.cross(packing.normals[0], [0.0, 0.0, 1.0])
        from dataclasses import replace
        PackingPoint.from_network(replace(packing, force=f, _cache={}), MD, max_unbalanced=1e9)


def test_zero_step_keeps_equilibrium(point):
    r = run_packing(point, LoadPath(np.zeros((2, 6), bool), np.zeros((2, 6))), tangent="start")
    assert r.success
    assert np.allclose(r.stress[-1], r.stress[0], rtol=0, atol=1e-8 * np.abs(r.stress[0]).max())


def test_mixed_control_holds_the_stress_targets(point):
    """Constant-stress cyclic simple shear keeps sigma_zz; an all-stress path reaches its target."""
    from grainmech.driver import isotropic_compression

    r = run_packing(point, cyclic_simple_shear(1e-4, 1, 8), tangent="start")
    assert r.success, r.message
    assert np.abs(r.stress[:, 2] - r.stress[0, 2]).max() <= 1e-7 * r.stress[0, 2]
    assert np.abs(r.strain[:, 2]).max() > 0  # the volume changes instead
    dp = 0.1 * r.stress[0, 0]
    r2 = run_packing(point, isotropic_compression(dp, 2), tangent="ends")
    assert r2.success, r2.message
    assert np.allclose(r2.stress[-1], point.stress + dp * np.array([1, 1, 1, 0, 0, 0]), rtol=0,
                       atol=1e-7 * point.stress[0])
    # stiffer under compression (Hertz): the final tangent is computed and exceeds the initial
    assert r2.tangent[-1][0, 0] > r2.tangent[0][0, 0] and np.isnan(r2.tangent[1]).all()


def test_results_are_driver_results(point):
    from grainmech.driver import DriverResult

    r = run_packing(point, cyclic_simple_shear(1e-5, 1, 4), tangent="start")
    assert isinstance(r, DriverResult)
    assert r.strain.shape == (5, 6) and r.residual.shape == (5,) and r.final.n_grains == point.n_grains
    assert np.all(r.dissipation >= 0) and np.all(np.diff(r.dissipation) >= -1e-12 * r.dissipation.max())


def test_at_stress_then_modulus_reduction(packing):
    """The run-config entry point: network + law + confining stress -> ModulusReduction."""
    p0 = PackingPoint.from_network(packing, MD).stress[:3].mean()
    pt = PackingPoint.at_stress(packing, MD, 0.5 * p0, n_steps=4)
    assert np.allclose(pt.stress, 0.5 * p0 * np.array([1, 1, 1, 0, 0, 0]), rtol=0, atol=1e-7 * p0)
    assert pt.strain[:3].sum() < 0  # unloading: the packing dilates
    mr = packing_modulus_reduction(pt, [1e-5], n_cycles=1, steps_per_cycle=8)
    g_full = PackingPoint.from_network(packing, MD).tangent[4, 4]
    # Hertz: G ~ p^(1/3) at fixed fabric (seed Eq. 3.7/3.11 with a ~ N^(1/3)); loose bound for the relaxed tensor
    assert 0.7 < mr.G_max / g_full < 0.9
    with pytest.raises(ParameterError, match="sigma"):
        PackingPoint.at_stress(packing, MD, -1.0)


def test_gmax_pressure_exponent_and_geometric_steps(packing):
    """``at_stress`` from the packing's own pressure p0 to p0/4 and 4 p0 (geometric steps,
    one per 25 % of pressure: 7 each way), then the elastic Gmax (``elastic_tangent``
    C_55). The exponent of G against p lies between Hertz's 1/3, what a packing whose
    every contact force scales with p gives at fixed fabric (contact stiffnesses
    ``~ a ~ N^(1/3)``, seed Eq. 3.7/3.11), and Hardin & Richart's (1963) 0.5 for sands,
    whose fabric changes (contacts gained under load, lost on unloading, raise it). The
    103-grain packing (coordination ~11, no gap closes within 4x) is near the Hertz end.
    The prepared point is in equilibrium: the imbalance its last step leaves is held."""
    p0 = float(PackingPoint.from_network(packing, MD).stress[:3].mean())
    ps, gs = [], []
    for f in (0.25, 1.0, 4.0):
        pt = PackingPoint.at_stress(packing, MD, f * p0) if f != 1.0 else PackingPoint.from_network(packing, MD)
        if f != 1.0:
            assert any(" in 7 stress-controlled steps" in n for n in pt.notes)
            assert unbalanced_force_ratio(pt) < 1e-10
            np.testing.assert_allclose(pt.stress, f * p0 * np.array([1, 1, 1, 0, 0, 0]), rtol=0, atol=1e-6 * p0)
        ps.append(f * p0)
        gs.append(pt.elastic_tangent[4, 4])
    n = np.polyfit(np.log(ps), np.log(gs), 1)[0]
    assert 1 / 3 - 0.02 <= n <= 0.5


def test_input_imbalance_held_or_relaxed(packing):
    """``imbalance="hold"`` keeps the input stress exactly and balances the input's residual
    forces by constant grain loads; ``"relax"`` removes them by moving the grains; both end
    in equilibrium (unbalanced ratio of the held/relaxed system below 1e-8)."""
    from dataclasses import replace

    rng = np.random.default_rng(7)
    f = packing.force * (1.0 + 1e-4 * rng.standard_normal((packing.n_contacts, 1)))  # a DEM-like imbalance
    net = replace(packing, force=f, _cache={})
    raw = PackingPoint.from_network(net, MD, imbalance="none")
    assert 1e-6 < unbalanced_force_ratio(raw) < 1e-3
    held = PackingPoint.from_network(net, MD, imbalance="hold")
    assert held.load is not None and unbalanced_force_ratio(held) < 1e-12
    np.testing.assert_array_equal(held.stress, raw.stress)
    relaxed = PackingPoint.from_network(net, MD, imbalance="relax")
    assert relaxed.load is None and unbalanced_force_ratio(relaxed) < 1e-8
    assert np.abs(relaxed.stress - raw.stress).max() < 1e-3 * np.abs(raw.stress).max()
    # a step from the held state converges and keeps the loads
    r = run_packing(held, cyclic_simple_shear(1e-5, 1, 8, constant="volume"), tangent="none")
    assert r.success and r.final.load is held.load and r.residual[1:].max() < 1e-6
    with pytest.raises(ParameterError, match="imbalance"):
        PackingPoint.from_network(net, MD, imbalance="ignore")


def test_held_load_drops_what_no_contact_resists(packing):
    """The held input imbalance of a grain is kept only where its closed contacts resist
    (``driver/packing/_iterations.held_load``): the part dropped lies in the grain's mechanisms
    (null space of its columns of ``G`` over its closed contacts, by SVD of the assembled
    kinematic matrix: an independent computation), and the part kept does no work on them.
    Grains held by 0, 1, 2 and 3+ closed contacts are made by opening contacts."""
    from dataclasses import replace
    from types import SimpleNamespace

    from grainmech.driver.packing._iterations import held_load

    pt = PackingPoint.from_network(packing, MD)
    kin = pt.kinematics
    rng = np.random.default_rng(11)
    pt = replace(pt, load=rng.standard_normal(kin.n_free), _cache={})
    opened = np.zeros(kin.n_contacts, bool)
    # grain 5: every contact but two opened; grain 9: all but one; grain 20: none left
    for g, keep in ((5, 2), (9, 1), (20, 0)):
        cs = np.flatnonzero((kin.a == g) | (kin.b == g))
        opened[cs[keep:]] = True
    kept = kin.full(held_load(pt, SimpleNamespace(open=opened)))
    load = kin.full(pt.load)
    G = kin.G.toarray()
    seen = set()
    for g in range(kin.n_grains):
        cols = np.flatnonzero(np.isin(np.flatnonzero(kin.free) // 6, [g]))
        dof = np.flatnonzero(kin.free)[cols] % 6
        rows = np.repeat(~opened & ((kin.a == g) | (kin.b == g)), 3)
        W = G[np.ix_(rows, cols)] if rows.any() else np.zeros((0, cols.size))
        R = pt.radii[g]
        Ws = W * np.where(dof >= 3, 1.0 / R, 1.0)  # rotations scaled by the radius
        sv = np.linalg.svd(Ws, compute_uv=False) if Ws.size else np.zeros(0)
        rank = int(np.sum(sv > 1e-6 * max(sv.max(initial=0.0), 1.0)))
        _, _, Vt = np.linalg.svd(Ws if Ws.size else np.zeros((1, cols.size)))
        N = Vt[rank:].T  # mechanisms of the grain, scaled coordinates
        sc = np.where(dof >= 3, R, 1.0)
        ls, ks = load[g][dof] / sc, kept[g][dof] / sc
        seen.add(N.shape[1] if g in (5, 9, 20) else -1)
        assert np.abs(N.T @ ks).max(initial=0.0) <= 1e-9 * np.abs(ls).max()          # no work on them
        np.testing.assert_allclose(ks, ls - N @ (N.T @ ls), rtol=0, atol=1e-9 * np.abs(ls).max())
    assert {1, 3, 6} <= seen  # rolling about two contact points; rotations about one; free


def test_trust_clip_is_per_grain():
    """Each grain's update is scaled by itself to the trust limit; grains inside it keep
    their Newton update (``driver/packing/_iterations.clip_grain_moves``)."""
    from grainmech.driver.packing._operators import Kinematics
    from grainmech.driver.packing._iterations import clip_grain_moves

    # three grains in a row, two contacts along x
    a, b = np.array([0, 1]), np.array([1, 2])
    n = np.tile([1.0, 0.0, 0.0], (2, 1))
    kin = Kinematics.build(a, b, n, 2.0 * n, np.ones(2), np.ones(2), 3)
    R = np.ones(3)
    dq = np.zeros((3, 6))
    dq[1, :3] = [0.3, 0.0, 0.0]         # inside the limit 1.0
    dq[2, :3] = [3.0, 4.0, 0.0]         # translation 5 -> scaled by 1/5
    dq[2, 3:] = [0.0, 0.0, 2.0]         # rotation scaled with it
    out = kin.full(clip_grain_moves(kin, dq.reshape(-1)[kin.free], R, 1.0))
    np.testing.assert_allclose(out[1], dq[1])
    np.testing.assert_allclose(out[2], dq[2] / 5.0)
    assert np.linalg.norm(out[2, :3]) == pytest.approx(1.0)


def test_committed_relaxation_agrees_with_newton(point):
    """Every step solved by committed relaxation (overdamped pseudo-time updates, each
    committed to the laws' history) ends in equilibrium and gives the loop Newton gives;
    the energy its updates remove (``relaxation_loss``: the work of the out-of-balance
    forces, a DEM's numerical damping) and the energy balance error
    ``work - dissipation - stored change - relaxation_loss`` vanish as the step shrinks.
    Seen (the same with PARDISO, cholespy and SuperLU) at 8 / 16 / 32 steps per cycle:
    loss 8.2 / 4.0 / 2.0 % of the dissipation (first order), balance error -9.18 / -5.50 /
    -3.42 % (ratios 0.60, 0.62: slower than first order). Asserted: the loss at least
    halves within 0.6, the error falls by at least 30 % per halving of the step."""
    forced = PackingOptions(max_iter=1, rtol_accept=1e-8, rtol_step=0.0, relax_depth=0, relax_iter=300,
                            tangent="none", anderson=0, accept_unbalanced=0.0)
    err, loss = [], []
    for spc in (8, 16):
        path = cyclic_simple_shear(1e-4, 2, spc, constant="volume")
        r = run_packing(point, path, forced)
        assert r.success, r.message
        assert any("committed relaxation" in n for n in r.notes)
        assert r.residual.max() < 1e-5
        err.append((r.work[-1] - r.dissipation[-1] - r.stored[-1] + r.stored[0] - r.relaxation_loss[-1])
                   / r.dissipation[-1])
        loss.append(r.relaxation_loss[-1] / r.dissipation[-1])
    assert abs(err[1]) < 0.7 * abs(err[0]) and 0 < loss[1] < 0.6 * loss[0]
    ref = run_packing(point, path, tangent="none")
    assert ref.success and ref.relaxation_loss[-1] == 0
    assert not any("committed relaxation" in n for n in ref.notes)
    lr, lp = (loop_properties(x.strain[16:, 4], x.stress[16:, 4]) for x in (ref, r))
    assert lp.secant_modulus == pytest.approx(lr.secant_modulus, rel=1e-2)
    assert lp.damping == pytest.approx(lr.damping, rel=0.1, abs=1e-4)


def test_elastic_tangent_from_the_factorisation_equals_gmres(packing):
    """``elastic_tangent`` from the factorised elastic operator (``(A0 - B0^T H0^-1 B0)/V``,
    no further solve) equals the GMRES condensation of the same operator to 1e-7, and the
    packing's relaxed C55 from ``relaxed_stiffness`` (independent assembly) to 1e-6."""
    from grainmech.driver.packing.tangent import relaxed_tangent

    pt = PackingPoint.from_network(packing, MD)
    C = pt.elastic_tangent
    Cg = relaxed_tangent(pt, pt.preconditioner(), 60, elastic=True, direct=False)
    assert np.abs(C - Cg).max() <= 1e-7 * np.abs(Cg).max()
    kn, ks, _ = contact_stiffnesses(packing, shear_modulus=G_GRAIN, poisson=NU, source="overlap")
    assert C[4, 4] == pytest.approx(relaxed_stiffness(packing, kn, ks).C_relaxed[4, 4], rel=1e-6)


def test_named_factorisation_not_installed_says_how_to_install(monkeypatch):
    """factorization = 'pardiso' (or 'cholespy') without the package: a GrainmechError naming
    the option and the install command, not an ImportError from deep inside."""
    import sys

    import scipy.sparse as sp

    from grainmech.driver.packing._operators import _Factor

    for backend, module in (("pardiso", "pypardiso"), ("cholespy", "cholespy")):
        monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
        with pytest.raises(GrainmechError, match=rf"factorization = '{backend}' needs {module}.*grainmech\[sparse\]"):
            _Factor(sp.eye(4).tocsr(), backend)
    assert _Factor(sp.eye(4).tocsr(), "auto").name == "superlu"  # auto falls back


def test_updates_leave_the_mechanisms_of_grains_alone(packing):
    """The rule for grains that lose contacts (``driver/packing/_iterations.hold_mechanisms``): an
    update keeps no part along a grain's mechanisms (null space of its columns of ``G`` over
    its closed contacts, by SVD of the assembled kinematic matrix: an independent
    computation) and the rest of it whole; a grain with no closed contact does not move at
    all; once its contacts close again the update is untouched. Grains held by 0, 1, 2
    closed contacts are made by opening contacts of the 103-grain packing."""
    from grainmech.driver.packing._iterations import hold_mechanisms

    pt = PackingPoint.from_network(packing, MD)
    kin = pt.kinematics
    x = np.random.default_rng(3).standard_normal(kin.n_free)
    closed = np.ones(kin.n_contacts, bool)
    np.testing.assert_array_equal(hold_mechanisms(kin, x, pt.radii, closed), x)  # 12 contacts each
    for g, keep in ((5, 2), (9, 1), (20, 0)):
        cs = np.flatnonzero((kin.a == g) | (kin.b == g))
        closed[cs[keep:]] = False
    out, full = kin.full(hold_mechanisms(kin, x, pt.radii, closed)), kin.full(x)
    np.testing.assert_array_equal(out[20], 0.0)
    G = kin.G.toarray()
    dims = set()
    for g in range(kin.n_grains):
        cols = np.flatnonzero(np.flatnonzero(kin.free) // 6 == g)
        dof = np.flatnonzero(kin.free)[cols] % 6
        rows = np.repeat(closed & ((kin.a == g) | (kin.b == g)), 3)
        sc = np.where(dof >= 3, pt.radii[g], 1.0)
        Ws = G[np.ix_(rows, cols)] / sc if rows.any() else np.zeros((1, cols.size))
        _, sv, Vt = np.linalg.svd(Ws)
        N = Vt[int(np.sum(sv > 1e-6 * max(sv.max(initial=0.0), 1.0))):].T
        dims.add(N.shape[1])
        d, o = full[g][dof] * sc, out[g][dof] * sc  # (u, R theta)
        np.testing.assert_allclose(o, d - N @ (N.T @ d), rtol=0, atol=1e-12 * np.abs(d).max())
    assert {0, 1, 3, 6} <= dims


def test_step_budget_stops_the_run_and_keeps_results():
    """PackingOptions.max_step_work: a step that spends its budget (residual evaluations plus
    GMRES iterations) stops the run with status 1, naming the budget and the out-of-balance
    measures reached, and keeps the steps before. On the shipped 'medium' packing at 1e-4
    the third step costs 261 (docs/models/packing.md, "Step budget"), so a budget of 100
    stops the run within its first steps. Every accepted step stays within the equilibrium
    bar of issue 29 (largest grain residual <= 0.05 of the mean contact force)."""
    from grainmech.driver.packing.options import ACCEPT_MAX_FORCE
    from grainmech.packing import QUARTZ, load_packing

    net = load_packing("medium")
    law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()),
                             friction=QUARTZ.friction)
    pt = PackingPoint.from_network(net, law)
    r = run_packing(pt, cyclic_simple_shear(1e-4, 1, 40, constant="stress"),
                    PackingOptions(law_backend="auto", tangent="none", max_step_work=100))
    assert not r.success and r.status == 1
    k = len(r.strain) - 1
    assert 1 <= k < 40
    assert f"step {k + 1}: no equilibrium found: no equilibrium within max_step_work = 100" in r.message
    assert "mean unbalanced force ratio" in r.message and f"results kept up to step {k}" in r.message
    assert r.cost.shape == (k + 1,) and r.cost[0] == 0 and np.all((r.cost[1:] > 0) & (r.cost[1:] <= 100))
    assert r.residual.max() <= ACCEPT_MAX_FORCE
    assert PackingOptions().max_step_work == 50000
    for bad in (50, 1.5e4, True):
        with pytest.raises(ParameterError, match="max_step_work"):
            PackingOptions(max_step_work=bad)


def test_rest_acceptance_is_bounded_by_the_step_stress_change(point):
    """PackingOptions.rest_step: a stalled (sub)step at rest by the DEM's measure (mean
    unbalanced force ratio <= accept_unbalanced) is accepted only when the stress uncertainty
    its out-of-balance forces leave, sum_p |M_p| here, is at most rest_step times the step's
    stress change (docs/models/packing.md, "Convergence and acceptance"). Out-of-balance
    moments of alternating sign on every grain (mean ratio 5e-5, at rest) against a step
    whose stress change makes that uncertainty 0.5 % (accepted) or 5 % (refused, but
    accepted with rest_step = inf) of it."""
    from grainmech.driver.packing.options import RunContext
    from grainmech.driver.packing.step import _StepSolve

    kin, R = point.kinematics, point.radii
    S, de, target = np.zeros(6, bool), np.zeros(6), np.zeros(6)
    opts = PackingOptions(rtol_accept=1e-8)  # the stress-scale test out of the way
    prec = point.preconditioner()
    probe = _StepSolve(point, S, de, target, RunContext(prec=prec, opts=opts), [0.0] * 5, 1.0, False)
    g = np.zeros((point.n_grains, 6))
    g[:, 3] = 5e-5 * probe.fref * R * np.where(np.arange(point.n_grains) % 2 == 0, 1.0, -1.0)
    rq = g.reshape(-1)[kin.free]
    amb = float(np.sum(np.abs(g[:, 3])))  # sum_p |M_p|, [N m]
    for share, inf_too, expected in ((0.005, False, True), (0.05, False, False), (0.05, True, True)):
        o = PackingOptions(rtol_accept=1e-8, rest_step=float("inf")) if inf_too else opts
        dsig = amb / point.volume / share  # the step's stress change [Pa]
        s = _StepSolve(point, S, de, target, RunContext(prec=prec, opts=o), [0.0] * 5, dsig, False)
        assert amb > s.amb_ok  # not accepted by the stress-uncertainty tests alone
        assert s.accept(rq, np.zeros(0)) is expected, (share, inf_too)
    # not at rest (mean ratio 2e-4 > accept_unbalanced = 1e-4): refused whatever rest_step
    s = _StepSolve(point, S, de, target, RunContext(prec=prec, opts=PackingOptions(rtol_accept=1e-8,
                   rest_step=float("inf"))), [0.0] * 5, amb / point.volume / 0.005, False)
    assert not s.accept(4.0 * rq, np.zeros(0))


def test_the_pinned_translation_is_the_best_held_grains() -> None:
    """The global translation is removed by pinning one grain's translation; its
    out-of-balance force is minus the sum of all the others' (``grain_residuals``), so it
    must be a grain that its contacts hold well. The first row of the shipped 'loose'
    packing is held by two weak contacts; the pinned grain is the one with the most
    force-carrying contacts instead, and that grain's residual equals minus the sum of the
    free grains' (contact forces are internal: they sum to zero)."""
    from grainmech.driver.packing._iterations import grain_residuals
    from grainmech.packing import QUARTZ, load_packing

    net = load_packing("loose")
    law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(np.mean(net.radii)),
                             friction=QUARTZ.friction)
    pt = PackingPoint.from_network(net, law)
    kin = pt.kinematics
    closed = pt.response.normal_force > 0
    count = np.bincount(kin.a[closed], minlength=pt.n_grains) + np.bincount(kin.b[closed], minlength=pt.n_grains)
    assert count[0] == count.max() >= 8
    first_row = int(np.flatnonzero(pt.grains == 0)[0]) if np.any(pt.grains == 0) else None
    assert first_row is None or count[first_row] <= 3  # the first row of 'loose' is weakly held
    assert not kin.free[:3].any() and kin.free[3:].all()
    # the pinned grain's residual (G^T f: +f on A, -f on B, f by A on B) from its own contacts
    f = pt.forces * 1.0
    c0 = int(np.flatnonzero(kin.a == 0)[0])
    f[c0] += 1e-3 * np.abs(f).max()  # unbalance the pinned grain and a neighbour
    g = grain_residuals(kin, kin.balance(f))
    mine = np.zeros(3)
    for c in np.flatnonzero((kin.a == 0) | (kin.b == 0)):
        mine += f[c] if kin.a[c] == 0 else -f[c]
    assert np.linalg.norm(mine) > 0.5e-3 * np.abs(f).max()
    assert np.allclose(g[0, :3], -g[1:, :3].sum(axis=0))
    assert np.allclose(g[0, :3], mine, atol=1e-9 * np.abs(f).max())


def test_a_tiny_tensile_input_force_is_taken_at_zero_a_large_one_is_refused(packing):
    """A contact about to open reports a tensile normal force from a DEM's normal dashpot
    (-5.8e-9 N on 'nevada-loose' re-settled at 50 kPa by LAMMPS, where the packing model's
    input check refused it as ``|T| = 0 exceeds mu N``): within 1e-3 of the mean normal
    force it is taken at zero (the point is the same as with that force zeroed, a note
    says so); a larger one is an error naming the contact."""
    import dataclasses

    from grainmech.driver.packing import _input

    law = MindlinDeresiewicz(29e9, 0.15, 2.5e-4, friction=0.5)
    N = np.einsum("ij,ij->i", packing.force, packing.normals)
    k = int(np.argmin(N))  # the weakest contact: made tensile
    tiny = dataclasses.replace(packing, force=packing.force - (N[k] + 1e-6 * np.mean(N))
                               * (np.arange(len(N)) == k)[:, None] * packing.normals)
    zeroed = dataclasses.replace(packing, force=packing.force - N[k] * (np.arange(len(N)) == k)[:, None]
                                 * packing.normals)
    a, b = (PackingPoint.from_network(n, law, max_unbalanced=0.1) for n in (tiny, zeroed))  # one force removed
    assert np.allclose(a.stress, b.stress, rtol=1e-9, atol=1e-9 * np.abs(b.stress).max())
    assert any("1 input contact(s) between load-bearing grains with a tensile normal force" in n for n in a.notes)
    assert not any("tensile" in n for n in b.notes)
    big = dataclasses.replace(packing, force=packing.force - (N[k] + 2 * _input.TENSILE_CAP * np.mean(N))
                              * (np.arange(len(N)) == k)[:, None] * packing.normals)
    with pytest.raises(GrainmechError, match=f"contact {k} carries a tensile normal force"):
        PackingPoint.from_network(big, law, max_unbalanced=0.1)

"""``grainmech run`` with ``[model] method``: the seed's affine model and the packing driver
in the main job (config, outputs, honest messages).

References: Gmax of the packing model is checked against
:func:`grainmech.network.relaxed_stiffness` (Lemaitre & Maloney 2006, Eq. 12) of the same
packing with Hertz-Mindlin stiffnesses ``kn = 2 E* a``, ``ks = 8 G* a`` (seed Eq. 3.5, 3.11),
computed independently of the packing driver; the affine Gmax stays the seed's
(seed Eq. 2.41, tested elsewhere).
"""

from __future__ import annotations

import contextlib
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from conftest import write_fcc_packing
from grainmech.analysis import condensed_modulus
from grainmech.errors import ConfigError, GrainmechError
from grainmech.jobs import CyclicOutcome, PathOutcome, RunComparison, compute_run, prepare_run
from grainmech.lammps.engine import lammps_available
from grainmech.network import contact_stiffnesses, relaxed_stiffness

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: the smooth-quartz run config the gmax_packing tests were worked out for (the former built-in default)
SMOOTH_RUN = Path(__file__).resolve().parents[1] / "data" / "smooth_quartz_run.toml"

G_GRAIN, NU = 29e9, 0.15


@pytest.fixture(scope="module")
def network_files(tmp_path_factory):
    """A 103-grain disordered fcc packing of 0.25 mm quartz-like spheres in equilibrium
    (frictionless preparation), written as grainmech NPZ network files."""
    d = tmp_path_factory.mktemp("packing")
    return d, write_fcc_packing(d)


MATERIAL = f"""
[microstructure]
void_ratio = 0.65
coordination = "chang"
radius = "0.25 mm"

[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "{G_GRAIN} Pa"
poisson = {NU}
friction = 0.5
"""


def _config(d, pressure: float, methods, kind: str = "cyclic") -> dict:
    text = f"""
[model]
method = {json.dumps(methods)}
network = "{(d / 'contacts.npz').as_posix()}"
particles = "{(d / 'particles.npz').as_posix()}"
{MATERIAL}
[initial]
pressure = "{pressure!r} Pa"

[quadrature]
degree = 11
"""
    if kind == "cyclic":
        text += """
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-6, 1e-5, 1e-4]
n_cycles = 2
steps_per_cycle = 24
"""
    else:
        text += """
[test]
kind = "path"
[[test.segments]]
control = "SSESSS"
change = ["0 Pa", "0 Pa", 2e-4, 0, 0, 0]
steps = 10
"""
    cfg = tomllib.loads(text)
    if "affine" not in methods:
        del cfg["microstructure"]
    return cfg


def _packing_pressure(net) -> float:
    """Mean Love-Weber stress of the network's stored forces (seed Eq. 2.6)."""
    s = np.einsum("ci,cj->ij", net.force, net.branch) / net.box.volume
    return float(np.trace(s) / 3)


def test_both_models_in_one_run(network_files):
    d, net = network_files
    p = _packing_pressure(net)
    cfg = _config(d, p, ["affine", "packing"])
    out = compute_run(cfg)
    assert isinstance(out, RunComparison) and out.success, out.message
    aff, pk = out.outcomes
    assert (aff.method, pk.method) == ("affine", "packing")
    # packing Gmax = relaxed tensor of the same packing (sigma_zz free), independent solver
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=G_GRAIN, poisson=NU, source="overlap")
    C = relaxed_stiffness(net, kn, ks).C_relaxed
    g_rel = condensed_modulus(C, 4, [False, False, True, False, False, False])
    assert pk.G_max == pytest.approx(g_rel, rel=1e-6)
    # at gamma -> 0 the secant of the last cycle equals it (every grain in equilibrium)
    assert pk.G[0] / pk.G_max == pytest.approx(1.0, abs=1e-3)
    assert pk.details["max_residual"] < 1e-6 and pk.details["grains"] == 103
    # the affine model on the analytical fabric is a different (stiffer-in-principle) model
    assert aff.G[0] / aff.G_max == pytest.approx(1.0, abs=1e-3)
    # damping grows with amplitude in both
    for o in (aff, pk):
        assert np.all(np.diff(o.damping) > 0)


def test_both_models_outputs(network_files, tmp_path):
    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["affine", "packing"])
    from grainmech.io.reports import write_run_outputs

    out = compute_run(cfg)
    summary = write_run_outputs(out, tmp_path / "o", cfg, "test")
    files = set(summary["files"])
    for m in ("affine", "packing"):
        assert {f"{m}_cycles_gamma_1.0e-06.csv", f"{m}_modulus_reduction.csv", f"{m}_loops.png"} <= files
    assert "modulus_reduction.png" in files
    js = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert js["methods"] == ["affine", "packing"]
    assert js["models"]["packing"]["details"]["grains"] == 103
    assert js["models"]["packing"]["G_max_Pa"] == pytest.approx(out.outcomes[1].G_max)
    header = (tmp_path / "o" / "packing_cycles_gamma_1.0e-06.csv").read_text().splitlines()[0]
    assert "equilibrium_residual [-]" in header
    page = (tmp_path / "o" / "index.html").read_text()
    assert "affine model" in page and "packing model" in page and "every grain" in page


def test_packing_path_and_packing_only(network_files):
    d, net = network_files
    out = compute_run(_config(d, _packing_pressure(net), ["packing"], kind="path"))
    assert isinstance(out, PathOutcome) and out.method == "packing" and out.success, out.message
    r = out.results[0]
    # sigma_xx, sigma_yy held while eps_zz is driven (drained compression)
    assert np.allclose(r.stress[:, :2], r.stress[0, :2], rtol=1e-7)
    assert r.stress[-1, 2] > r.stress[0, 2]
    assert r.residual.max() < 1e-6


def test_packing_brought_to_the_run_pressure(network_files):
    d, net = network_files
    p = _packing_pressure(net)
    out = compute_run(_config(d, 0.8 * p, ["packing"]))
    assert isinstance(out, CyclicOutcome) and out.success, out.message
    r0 = out.results[0]
    assert np.mean(r0.stress[0, :3]) == pytest.approx(0.8 * p, rel=1e-6)
    assert any("brought from the input stress" in n for n in out.details["notes"])


def test_model_config_errors(network_files):
    d, net = network_files
    base = _config(d, 1e5, ["affine", "packing"])
    bad = json.loads(json.dumps(base))
    bad["model"]["method"] = "relaxed"
    with pytest.raises(ConfigError, match=r"model\.method.*relaxed"):
        prepare_run(bad)
    bad = json.loads(json.dumps(base))
    bad["model"]["method"] = ["packing", "packing"]
    with pytest.raises(ConfigError, match=r"model\.method"):
        prepare_run(bad)
    bad = json.loads(json.dumps(base))
    bad["model"]["packing"] = "dense"
    with pytest.raises(ConfigError, match=r"exactly one of model\.packing"):
        prepare_run(bad)
    bad = json.loads(json.dumps(base))
    del bad["model"]["network"]
    with pytest.raises(ConfigError, match=r"exactly one of model\.packing"):
        prepare_run(bad)
    bad = json.loads(json.dumps(base))
    bad["model"]["method"] = "affine"
    with pytest.raises(ConfigError, match=r"model\.network.*does not use"):
        prepare_run(bad)
    bad = json.loads(json.dumps(base))
    bad["model"]["method"] = "packing"  # [microstructure] belongs to the affine model
    with pytest.raises(ConfigError, match=r"^microstructure: \[microstructure\] describes the affine model"):
        prepare_run(bad)
    bad = json.loads(json.dumps(base))
    bad["model"]["network"] = "no_such_file.npz"
    with pytest.raises(GrainmechError, match="no_such_file"):
        prepare_run(bad)


def test_frictionless_packing_asked_for_damping(network_files):
    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["packing"])
    cfg["contacts"] = {"law": "linear", "kn": "1e6 N/m", "ks": "5e5 N/m"}
    with pytest.raises(ConfigError, match="contacts.friction.*damping needs friction"):
        prepare_run(cfg)


@pytest.mark.parametrize("degree", [11, 23])
def test_affine_newton_at_a_tie_of_the_law(degree):
    """Regression: G = 29 GPa, nu = 0.15, mu = 0.5, 100 kPa, gamma = 1e-6 at constant sigma_zz
    failed ("Newton did not converge", residual 2e-3 Pa > 1e-4 Pa) although the step is
    converged to the resolution of the Mindlin-Deresiewicz memory (ties below 1e-6 of 2 mu N
    are ignored, so sigma_zz jumps by ~1e-8 of p across such a tie)."""
    out = compute_run(_affine_only_config(degree))
    assert out.success, out.message
    assert out.G[0] / out.G_max == pytest.approx(1.0, abs=1e-3)


def _affine_only_config(degree: int) -> dict:
    return tomllib.loads(MATERIAL + f"""
[initial]
pressure = "100 kPa"
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-6]
[quadrature]
degree = {degree}
""")


def test_unstable_packing_file_is_refused(network_files, tmp_path):
    """A packing whose stored forces are not in equilibrium (every other contact's force
    doubled) is refused with the unbalanced force ratio, before any loading."""
    d, net = network_files
    f = net.force.copy()
    f[::2] *= 2.0
    np.savez(tmp_path / "contacts.npz", id1=net.ids[net.i], id2=net.ids[net.j], fx=f[:, 0], fy=f[:, 1],
             fz=f[:, 2], delta=net.overlap)
    cfg = _config(d, _packing_pressure(net), ["affine", "packing"])
    cfg["model"]["network"] = (tmp_path / "contacts.npz").as_posix()
    out = compute_run(cfg)
    aff, pk = out.outcomes
    assert not out.success and aff.success and len(aff.G) == 3  # the affine results are kept
    assert not pk.success and pk.results == []
    assert "preparing the packing failed" in pk.message
    assert "not mechanically stable: unbalanced force ratio" in pk.message


def test_cli_reads_the_network_relative_to_the_config(network_files, cli, tmp_path):
    """`grainmech run CONFIG` with model.network relative to the config's folder (not the
    working directory); both models on one page, exit 0."""
    import shutil

    d, net = network_files
    cdir = tmp_path / "study"
    (cdir / "grains").mkdir(parents=True)
    for f in ("contacts.npz", "particles.npz"):
        shutil.copy(d / f, cdir / "grains" / f)
    text = (MATERIAL + f"""
[model]
method = ["affine", "packing"]
network = "grains/contacts.npz"
particles = "grains/particles.npz"
[initial]
pressure = "{_packing_pressure(net)!r} Pa"
[quadrature]
degree = 11
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-6, 1e-5]
steps_per_cycle = 16
""")
    (cdir / "run.toml").write_text(text)
    r = cli("run", cdir / "run.toml", "-o", tmp_path / "out")
    assert r.rc == 0, r.err
    assert "affine model (completed)" in r.out and "packing model (completed)" in r.out
    assert (tmp_path / "out" / "packing_modulus_reduction.csv").exists()


@contextlib.contextmanager
def _clocked_reporter(times: list[float], amplitudes: int | None = None):
    """``(reporter, said)``: a packing step reporter whose clock reads ``times`` in turn (the first: its creation)."""
    import grainmech.jobs as jobs
    from grainmech.jobs import _step_reporter

    clock = iter(times)
    said: list[str] = []
    real = jobs.time.perf_counter
    jobs.time.perf_counter = lambda: next(clock)
    try:
        yield _step_reporter(said.append, "[packing]", amplitudes), said
    finally:
        jobs.time.perf_counter = real


def test_packing_step_reporter_throttles_and_restarts_per_run():
    """The progress line of a long packing run: at most one per interval, never after the
    last step, the seconds counted from the start of the current run (amplitude) and of
    the first, the amplitude k/n, and an estimate of the time left once an amplitude has
    finished (seconds per step so far x steps left)."""
    from grainmech.jobs import PACKING_PROGRESS_EVERY

    assert PACKING_PROGRESS_EVERY == 10.0
    # created at t = 0; two amplitudes
    with _clocked_reporter([0.0, 1.0, 5.0, 11.0, 20.0, 35.0, 40.0, 70.0], 2) as (rep, said):
        for k, n in ((1, 4), (2, 4), (3, 4), (4, 4)):  # steps end at 1, 5, 11, 20
            rep(k, n)
        for k, n in ((1, 4), (2, 4), (3, 4)):  # second amplitude, from t = 20: steps end at 35, 40, 70
            rep(k, n)
    # 11 s after the start (no estimate yet); 15 s after the second amplitude began (t = 20):
    # 35 s for 5 steps, 7 s per step, 3 steps left; then 70 s for 7 steps, 1 left; the last
    # step of the first amplitude is silent
    assert said == ["[packing] amplitude 1/2, step 3/4, 11 s (total 11 s)",
                    "[packing] amplitude 2/2, step 1/4, 15 s (total 35 s), about 21 s left",
                    "[packing] amplitude 2/2, step 3/4, 50 s (total 70 s), about 10 s left"]


def test_packing_step_reporter_counts_only_the_amplitudes_it_runs():
    """A resumed series of 3 amplitudes that takes up 2 runs one: ``planned(1)`` makes the
    line say amplitude 1/1 and the time left cover only that amplitude's steps (not the
    two taken up)."""
    with _clocked_reporter([0.0, 11.0, 22.0], 3) as (rep, said):
        rep.planned(1)
        rep(1, 4)
        rep(2, 4)
    # the first amplitude run: no estimate before it ends, and its count is 1/1
    assert said == ["[packing] amplitude 1/1, step 1/4, 11 s (total 11 s)",
                    "[packing] amplitude 1/1, step 2/4, 22 s (total 22 s)"]


def test_path_step_reporter_estimates_from_the_first_step():
    with _clocked_reporter([0.0, 12.0, 30.0]) as (rep, said):
        rep(3, 10)
        rep(5, 10)
    assert said == ["[packing] step 3/10, 12 s (total 12 s), about 28 s left",
                    "[packing] step 5/10, 30 s (total 30 s), about 30 s left"]


def test_gmax_packing_beside_the_affine_model():
    """``[model] gmax_packing = 'medium'``: the packing's small-strain
    Gmax with every grain in equilibrium equals C55 of ``relaxed_stiffness`` on the same
    network (an independent assembly and solver; Hertz-Mindlin no-slip stiffnesses
    ``kn = 2 E* a``, ``ks = 8 G* a`` from the contact forces, seed Eq. 3.2, 3.7, 3.11),
    condensed with sigma_zz free (constant-stress cyclic simple shear), to 1e-3."""

    from grainmech.jobs import cyclic_control, packing_gmax
    from grainmech.packing import load_packing

    cfg = tomllib.loads(SMOOTH_RUN.read_text())
    cfg["model"] = {"gmax_packing": "medium"}  # the default until 2026-11-26 (now both models' curves)
    cfg["microstructure"]["void_ratio"] = 0.65
    spec = prepare_run(cfg)
    assert spec.methods == ("affine",) and spec.gmax_grains is not None
    said: list[str] = []
    pg = packing_gmax(spec, said.append)
    assert "error" not in pg and said
    net = load_packing("medium")
    kn, ks, used = contact_stiffnesses(net, shear_modulus=spec.law.shear_modulus, poisson=spec.law.poisson,
                                       source="force")
    rr = relaxed_stiffness(net, kn, ks)
    g_ref = condensed_modulus(rr.C_relaxed, 4, [bool(b) for b in cyclic_control("stress")])
    assert pg["G_max_Pa"] == pytest.approx(g_ref, rel=1e-3)
    # the grains' relaxation softens this loose frictional packing by about half against the
    # affine tensor of the same network (seen 156 / 307 MPa = 0.51)
    assert pg["G_max_Pa"] < 0.7 * rr.C_affine[4, 4]
    assert pg["void_ratio"] == pytest.approx(0.659, abs=1e-3)
    assert pg["empirical_G_max"]["G_round_Pa"] > 0


def test_gmax_packing_is_for_the_affine_model_alone():

    cfg = tomllib.loads(SMOOTH_RUN.read_text())
    cfg["model"] = {"method": ["affine", "packing"], "packing": "medium", "gmax_packing": "medium"}
    with pytest.raises(ConfigError, match=r"model\.gmax_packing.*method = 'affine' alone"):
        prepare_run(cfg)
    cfg["model"] = {"gmax_packing": "no-such"}
    with pytest.raises(ConfigError, match=r"model\.gmax_packing"):
        prepare_run(cfg)
    # beside G/Gmax curves only: a path test would silently leave it out
    path_cfg = tomllib.loads((EXAMPLES / "run_triaxial_path.toml").read_text())
    path_cfg.setdefault("model", {})["gmax_packing"] = "medium"
    with pytest.raises(ConfigError, match=r"model\.gmax_packing.*not with test\.kind"):
        prepare_run(path_cfg)


def test_failed_amplitude_is_written_with_the_rest(network_files, tmp_path):
    """A packing run that fails at its second amplitude (3 %: beyond the packing driver's
    small-strain bound of 2 %, so it stops during the ramp) keeps and writes everything:
    the first amplitude's loops and curves, and the failed amplitude's steps up to the
    failure in its own CSV (the writer used to index the completed amplitudes with the
    runs and crash with an IndexError, losing the finished results)."""
    from grainmech.io.reports import write_run_outputs

    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["packing"])
    cfg["test"]["amplitudes"] = [1e-6, 3e-2]
    cfg["test"]["steps_per_cycle"] = 16
    out = compute_run(cfg)
    assert not out.success and "amplitude 0.03" in out.message and "max_strain" in out.message
    assert len(out.G) == 1 and len(out.results) == 2
    np.testing.assert_array_equal(out.run_amplitudes, [1e-6, 3e-2])
    summary = write_run_outputs(out, tmp_path, cfg, "test")
    failed = tmp_path / "cycles_gamma_3.0e-02.csv"
    assert failed.name in summary["files"] and (tmp_path / "cycles_gamma_1.0e-06.csv").is_file()
    rows = np.loadtxt(failed, delimiter=",", skiprows=1, ndmin=2)
    assert len(rows) == len(out.results[1].strain) >= 2  # the steps before the strain bound
    header = failed.read_text().splitlines()[0].split(",")
    gxz = rows[:, [i for i, h in enumerate(header) if h.startswith("strain_xz")][0]]
    assert 0.0 < np.abs(gxz).max() <= 0.02  # stopped at the small-strain bound, not beyond


def test_packing_amplitudes_are_the_packing_models_own(network_files, tmp_path):
    """``[model] packing_amplitudes``: the packing model runs those, the affine model the
    test's; each model's files, curves and summary name its own amplitudes, and the
    report says which of the test's were not run with the packing model."""
    from grainmech.io.reports import write_run_outputs

    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["affine", "packing"])
    cfg["model"]["packing_amplitudes"] = [1e-6, 1e-5]
    out = compute_run(cfg)
    assert out.success, out.message
    aff, pk = out.outcomes
    np.testing.assert_array_equal(aff.amplitudes, [1e-6, 1e-5, 1e-4])
    np.testing.assert_array_equal(pk.amplitudes, [1e-6, 1e-5])
    np.testing.assert_array_equal(pk.run_amplitudes, [1e-6, 1e-5])
    assert pk.details["amplitudes_note"] == ("run at model.packing_amplitudes = [1e-06, 1e-05]; "
                                             "test.amplitudes [0.0001] were not run with this model")
    summary = write_run_outputs(out, tmp_path, cfg, "test")
    files = set(summary["files"])
    assert "affine_cycles_gamma_1.0e-04.csv" in files and "packing_cycles_gamma_1.0e-04.csv" not in files
    assert "packing_cycles_gamma_1.0e-05.csv" in files
    assert "test.amplitudes [0.0001] were not run with this model" in (tmp_path / "index.html").read_text()
    # errors name the key and the value
    bad = json.loads(json.dumps(cfg))
    bad["model"]["packing_amplitudes"] = [1e-6, -1e-5]
    with pytest.raises(ConfigError, match=r"^model\.packing_amplitudes = \[1e-06, -1e-05\]: every amplitude"):
        prepare_run(bad)
    bad["model"]["packing_amplitudes"] = []
    with pytest.raises(ConfigError, match=r"^model\.packing_amplitudes = \[\]: must be a non-empty list"):
        prepare_run(bad)
    bad["model"]["packing_amplitudes"] = [1e-6]
    bad["model"]["method"] = "affine"
    del bad["model"]["network"], bad["model"]["particles"]
    with pytest.raises(ConfigError, match=r"^model\.packing_amplitudes = \[1e-06\]: is for method = 'packing'"):
        prepare_run(bad)
    path = _config(d, _packing_pressure(net), ["packing"], kind="path")
    path["model"]["packing_amplitudes"] = [1e-6]
    with pytest.raises(ConfigError, match=r"^model\.packing_amplitudes = \[1e-06\]: is for test\.kind"):
        prepare_run(path)


def test_built_in_default_runs_three_models():
    """The built-in default ``grainmech run`` models a sand ('nevada-medium': Nevada-sand
    grading, D_r 0.58, rolling resistance mu_r = 0.25) with the affine model's curves, the
    packing model's where it holds (1e-6 ... 1e-4) and the DEM model's above it (here 3e-4
    only, to keep the suite short; the default adds 1e-3), with every Gmax beside
    Hardin-Richart's at the same void ratio and stress and Menq's curve for the grains' own
    grading. Checked against what no one here wrote into the run: the packing model's Gmax
    is C55 of ``relaxed_stiffness`` of the same shipped packing (independent assembly and
    solver, Lemaitre & Maloney 2006; no-slip Hertz-Mindlin stiffnesses from the contact
    forces, seed Eq. 3.2, 3.7, 3.11, and the rolling springs of Iwashita & Oda 1998 at the
    packing's contact forces), condensed with sigma_zz free, to 1e-3; at gamma = 1e-6 its
    secant G is that Gmax to 1 %; the affine model is stiffer than the packing (the seed's
    kinematic hypothesis is an upper bound); the DEM curve continues the packing's downwards
    (G/Gmax at 3e-4 below the packing's at 1e-4, damping above), every DEM state is an
    equilibrium (unbalanced force ratio below the setting's tol), and the DEM notes say that
    Mindlin-Deresiewicz ran as Hertz-Mindlin in LAMMPS and which rolling constants it ran."""
    from importlib import resources

    from grainmech.analysis.empirical import hardin_richart
    from grainmech.driver.packing import PackingPoint
    from grainmech.jobs import cyclic_control
    from grainmech.packing import load_packing, packing_info

    cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
    if not lammps_available():
        pytest.skip("LAMMPS (grainmech[dem]) is not installed")
    assert cfg["model"]["packing"] == "nevada-medium" and cfg["model"]["dem_amplitudes"] == [3e-4, 1e-3]
    cfg["model"]["dem_amplitudes"] = [3e-4]
    cfg["test"]["amplitudes"] = [1e-6, 1e-5, 1e-4, 3e-4]
    out = compute_run(cfg)
    assert isinstance(out, RunComparison) and out.success, out.message
    aff, pk, dm = out.outcomes
    assert (aff.method, pk.method, dm.method) == ("affine", "packing", "dem")
    assert len(aff.G) == 4 and len(pk.G) == 3 and list(dm.amplitudes) == [3e-4]
    net = load_packing("nevada-medium")
    spec = prepare_run(cfg)
    law = spec.law
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=law.shear_modulus, poisson=law.poisson, source="force")
    # the rolling constants as the packing model resolves them (rolling_constants, Iwashita & Oda
    # 1998, on the load-bearing contacts: k_roll 8.82e4 N/m; on every contact 8.75e4)
    consts = PackingPoint.from_network(net, spec.grain_law, rolling=spec.rolling).rolling
    assert consts.mu_roll == 0.25 and consts.k_roll == pytest.approx(8.82e4, rel=1e-3)
    rr = relaxed_stiffness(net, kn, ks, rolling=consts)
    g_ref = condensed_modulus(rr.C_relaxed, 4, [bool(b) for b in cyclic_control("stress")])
    assert pk.G_max == pytest.approx(g_ref, rel=1e-3)
    # at 1e-6 the secant G is Gmax within 1 % (the sand packing's weakest contacts slip already
    # there; Menq's curve gives 0.997)
    assert pk.G[0] / pk.G_max == pytest.approx(1.0, abs=1e-2)
    # G/Gmax falls and damping grows with the amplitude in every model
    for o in (aff, pk):
        assert np.all(np.diff(o.G / o.G_max) < 0) and np.all(np.diff(o.damping) > 0)
    assert dm.G_ratio[0] < pk.G_ratio[-1] and dm.damping[0] > pk.damping[-1]
    assert aff.G_max > 1.5 * pk.G_max
    # the affine model is flagged against Hardin-Richart (1963); the sand packing's Gmax is
    # within its factor 2 (1.40 x the angular-grain value at its e = 0.714, 100 kPa)
    assert aff.empirical_G_max["flag"] and not pk.empirical_G_max["flag"]
    assert 1.0 < pk.G_max / hardin_richart(packing_info("nevada-medium")["void_ratio"], 1e5).G_angular < 1.5
    assert pk.details["max_residual"] < 0.05
    assert dm.details["max_unbalanced"] < dm.details["settings"]["tol"]
    assert any("Mindlin-Deresiewicz" in n for n in dm.details["notes"])
    assert any("mu_r = 0.25" in n for n in dm.details["notes"])


def test_packing_options_bound_the_small_strain_range(network_files):
    """``[model.packing_options]`` reaches the packing model: a bound below what a cycle of
    1e-4 needs stops it with status OUT_OF_RANGE and a message naming the table; the
    default bounds complete the same run (see ``test_both_models_in_one_run``)."""
    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["packing"])
    cfg["model"]["packing_options"] = {"max_fluctuation": 1e-9}
    spec = prepare_run(cfg)
    assert spec.packing_options == {"max_fluctuation": 1e-9}
    out = compute_run(cfg)
    assert isinstance(out, CyclicOutcome) and not out.success
    assert "max_fluctuation = 1e-09" in out.message and "[model.packing_options]" in out.message


@pytest.mark.parametrize("table, key", [
    ({"max_fluctuation": 2.0}, "model.packing_options.max_fluctuation"),
    ({"max_strain": 0.5}, "model.packing_options.max_strain"),
    ({"max_fluctuation": -0.1}, "model.packing_options.max_fluctuation"),
    ({"max_fluct": 0.1}, "model.packing_options.max_fluct"),
])
def test_packing_options_errors_name_the_key(network_files, table, key):
    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["packing"])
    cfg["model"]["packing_options"] = table
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        prepare_run(cfg)


def test_packing_options_without_the_packing_model(network_files):
    d, net = network_files
    cfg = _config(d, _packing_pressure(net), ["affine"])
    del cfg["model"]["network"], cfg["model"]["particles"]
    cfg["model"]["packing_options"] = {"max_fluctuation": 0.2}
    with pytest.raises(ConfigError, match=r"model\.packing_options"):
        prepare_run(cfg)


@pytest.mark.parametrize("pressure", ["0.5 kPa", "200 MPa"])
def test_a_pressure_outside_a_packings_range_is_refused(network_files, pressure):
    """Issue 29, bad input: a run pressure below 1 kPa or above 100 MPa for a packing of
    grains is one ConfigError naming ``initial.pressure``."""
    d, net = network_files
    cfg = _config(d, 1.0, ["packing"])
    cfg["initial"]["pressure"] = pressure
    with pytest.raises(ConfigError, match=r"initial\.pressure.*outside the range"):
        prepare_run(cfg)

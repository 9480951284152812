"""Every cyclic amplitude against the envelope of sands, and the quality of its analysed loop
(issue 32): the checks, and where a user reads them (CSV, summary, page, figure, terminal,
site-response curves)."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import tomllib

import numpy as np
import pytest

from conftest import default_run_affine
from grainmech.errors import ConfigError
from grainmech.jobs import cyclic_envelope, envelope_and_loop_warnings, last_cycle_quality

DEFAULT_AMPS = "amplitudes = [1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3]"


def _cfg(amplitudes: str | None = None, model_extra: str = "") -> str:
    text = default_run_affine()
    if amplitudes is not None:
        text = text.replace(DEFAULT_AMPS, f"amplitudes = {amplitudes}")
    if model_extra:
        text = text.replace('[model]\nmethod = "affine"\n', f'[model]\nmethod = "affine"\n{model_extra}\n')
    return text


# ------------------------------------------------------------------------------ the checks
def test_cyclic_envelope_of_simple_shear_states():
    """sigma_xx = sigma_zz = p, tau_xz = t p: principal stresses p (1 +- t), sigma_yy = p.
    t = 0.5: ratio 3 (within 7.55); t = 0.8: ratio 9 (phi_mob = asin(8/10) = 53.13 deg,
    beyond); t = 1.55: sigma_3 < 0, unbounded."""
    p = 1e5

    def states(*ts):
        return np.array([[p, p, p, 0, t * p, 0] for t in ts])

    env = cyclic_envelope(states(0.0, 0.3, 0.5, -0.5, 0.0))
    assert not env["beyond_any"] and env["first_step"] is None
    assert env["max_ratio"] == pytest.approx(3.0) and env["max_tau_over_sigma_zz"] == pytest.approx(0.5)
    assert env["max_mobilised_friction_deg"] == pytest.approx(30.0)
    assert env["limit"] == pytest.approx(7.5486, rel=1e-4) and env["friction_angle_deg"] == 50.0
    env = cyclic_envelope(states(0.0, 0.5, -0.8, 0.0))
    assert env["beyond_any"] and env["first_step"] == 2 and list(env["beyond"]) == [False, False, True, False]
    assert env["max_ratio"] == pytest.approx(9.0)
    assert env["max_mobilised_friction_deg"] == pytest.approx(math.degrees(math.asin(0.8)))
    env = cyclic_envelope(states(0.0, 1.55))
    assert env["beyond_any"] and math.isinf(env["max_ratio"]) and env["max_mobilised_friction_deg"] == 90.0
    assert env["max_tau_over_sigma_zz"] == pytest.approx(1.55)


def test_amplitude_warnings_name_amplitude_and_cause():
    from grainmech.analysis import loop_quality

    p = 1e5
    inside = cyclic_envelope(np.array([[p, p, p, 0, 0.2 * p, 0]] * 2))
    beyond = cyclic_envelope(np.array([[p, p, p, 0, 0, 0], [p, p, p, 0, 1.55 * p, 0]]))
    ok = loop_quality([0, 1, 0, -1, 0], [0, 1, 0, -1, 0])
    drift = loop_quality([0, 1, 0, -1, 0], [0, 1, 0, -1, 0.3])
    w = envelope_and_loop_warnings("affine", [1e-5, 1e-3, 3e-4], [inside, beyond, inside], [ok, ok, drift])
    assert len(w) == 2
    assert w[0].startswith("affine model, amplitude 1.0e-03: beyond the envelope of sands from step 1 "
                           "(sigma1/sigma3 unbounded: sigma3 <= 0, limit 7.55")
    assert "cannot fail" in w[0]
    assert w[1].startswith("affine model, amplitude 3.0e-04: loop not closed: the analysed cycle ends 30 % of tau_a")


# --------------------------------------------------------------- the built-in default, affine
@pytest.fixture(scope="module")
def default_affine(tmp_path_factory):
    """The built-in default run with the affine model alone (all seven amplitudes)."""
    from grainmech.cli import main

    d = tmp_path_factory.mktemp("env")
    (d / "c.toml").write_text(_cfg())
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(["run", str(d / "c.toml"), "-o", str(d / "o"), "--quiet"])
    assert rc == 0
    return d / "o", out.getvalue(), err.getvalue()


def test_default_affine_loops_beyond_the_envelope_are_flagged(default_affine):
    """The affine loop at 1e-3 reaches tau_xz/sigma_zz = 1.55 (sigma_3 < 0) and the one at
    3e-4 sigma1/sigma3 = 19.9 (tau_xz/sigma_zz 0.98): both beyond Mohr-Coulomb 50 deg
    (7.55); 1e-4 stays within (2.69)."""
    out, stdout, stderr = default_affine
    s = json.loads((out / "summary.json").read_text())
    assert s["amplitudes"] == [1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3]
    assert s["beyond_envelope"] == [False] * 5 + [True, True]
    assert s["max_tau_over_sigma_zz"][-1] == pytest.approx(1.55, abs=0.01)
    assert s["max_stress_ratio"][-1] is None  # unbounded: sigma_3 <= 0
    assert s["max_stress_ratio"][-2] == pytest.approx(19.9, rel=0.02)
    assert s["max_stress_ratio"][-3] == pytest.approx(2.69, rel=0.02)
    assert s["max_tau_over_sigma_zz"][-2] == pytest.approx(0.98, rel=0.02)
    assert s["envelope"]["friction_angle_deg"] == 50.0 and s["site_response_excluded"] == [3e-4, 1e-3]
    # the step tables: the first state beyond is flagged, none before
    for a, first in zip((3e-4, 1e-3), s["first_step_beyond"][-2:]):
        rows = list(csv.DictReader(open(out / f"cycles_gamma_{a:.1e}.csv")))
        flags = [int(float(r["beyond_sand_envelope [0/1]"])) for r in rows]
        assert flags[first] == 1 and not any(flags[:first])
    assert s["first_step_beyond"][:5] == [None] * 5
    # modulus_reduction.csv: a 0/1 column
    rows = list(csv.DictReader(open(out / "modulus_reduction.csv")))
    assert [int(r["beyond_envelope [0/1]"]) for r in rows] == [0] * 5 + [1, 1]
    # unbounded (sigma_3 <= 0): an empty cell and a flag, never "inf"
    assert rows[-1]["max_stress_ratio_sigma1_sigma3 [-]"] == ""
    assert [int(r["max_stress_ratio_unbounded [0/1]"]) for r in rows] == [0] * 6 + [1]
    assert [int(r["value_flag [0/1]"]) for r in rows] == [0] * 7
    # site-response curves without them
    from grainmech.io.site_response import read_curves

    c = read_curves(out / "site_response_curves.csv")
    assert np.allclose(c.strain, [1e-6, 3e-6, 1e-5, 3e-5, 1e-4])
    assert "left out: 3.0e-04, 1.0e-03" in c.comment
    # the page and the terminal
    page = (out / "index.html").read_text()
    assert page.count("<td><b>beyond</b></td>") == 2 and page.count("<td>within</td>") == 5
    assert "Envelope of sands: Mohr-Coulomb" in page and "amplitudes beyond the envelope: 3.0e-04, 1.0e-03" in page
    marked = [ln for ln in stdout.splitlines() if "BEYOND ENVELOPE" in ln]
    assert len(marked) == 2 and "3.00e-04" in marked[0] and "1.00e-03" in marked[1]
    assert "unbounded" in marked[1]
    assert stderr.count("beyond the envelope of sands") == 2


def test_default_affine_loops_are_closed(default_affine):
    """The affine model's second cycle is closed and symmetric at every amplitude (its first
    is not: from virgin loading it ends 25 % of tau_a away at 1e-3)."""
    out, stdout, _ = default_affine
    s = json.loads((out / "summary.json").read_text())
    assert s["loop_warning"] == [False] * 7
    for q in s["loop_quality"]:
        assert q["stress_closure"] < 1e-3 and q["strain_closure"] < 1e-12 and q["asymmetry"] < 2e-3
        assert q["ok"] and q["closure_tolerance"] == 0.05 and q["asymmetry_tolerance"] == 0.10
    rows = list(csv.DictReader(open(out / "modulus_reduction.csv")))
    assert all(r["loop_warning [0/1]"] == "0" for r in rows)
    assert "loop not closed" not in stdout
    # the first cycle of the 1e-3 run, analysed the same way, is not closed
    from grainmech.analysis import loop_quality

    run = list(csv.DictReader(open(out / "cycles_gamma_1.0e-03.csv")))
    g = np.array([float(r["strain_xz [-]"]) for r in run[:41]])
    t = np.array([float(r["stress_xz [Pa]"]) for r in run[:41]])
    assert loop_quality(g, t).stress_closure == pytest.approx(0.25, abs=0.01)


def test_modulus_reduction_png_draws_beyond_points_hollow(tmp_path, monkeypatch):
    """The report passes the flags to plots.modulus_reduction / damping, which draw those
    points unfilled with a legend entry of their own."""
    from grainmech import plots

    fig, (a1, a2) = plots.subplots(1, 2)
    plots.modulus_reduction([1e-5, 1e-4, 1e-3], [0.99, 0.9, 0.3], ax=a1, hollow=[False, False, True])
    plots.damping([1e-5, 1e-4, 1e-3], [0.01, 0.05, 0.1], ax=a2, hollow=[False, False, True])
    for ax in (a1, a2):
        filled, empty = ax.lines[:2]
        assert list(filled.get_xdata()) == [1e-5, 1e-4] and list(empty.get_xdata()) == [1e-3]
        assert filled.get_markerfacecolor() != "none" and empty.get_markerfacecolor() == "none"
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert labels[:2] == ["grainmech", "beyond the envelope of sands (hollow)"]
    fig2, ax = plots.subplots()
    plots.modulus_reduction([1e-5, 1e-4], [0.99, 0.9], ax=ax)  # no flags: one filled series
    assert len(ax.lines) == 1 and ax.lines[0].get_markerfacecolor() != "none"

    seen = []
    real = plots.modulus_reduction

    def spy(*args, **kw):
        seen.append(kw.get("hollow"))
        return real(*args, **kw)

    monkeypatch.setattr(plots, "modulus_reduction", spy)
    from grainmech.cli import main

    (tmp_path / "c.toml").write_text(_cfg("[1e-5, 1e-3]"))
    assert main(["run", str(tmp_path / "c.toml"), "-o", str(tmp_path / "o"), "--quiet"]) == 0
    assert seen == [[False, True]]


# ------------------------------------------------------------------------ keep_beyond_envelope
def test_keep_beyond_envelope(tmp_path, cli):
    (tmp_path / "k.toml").write_text(_cfg("[1e-5, 1e-3]", "keep_beyond_envelope = true"))
    res = cli("run", tmp_path / "k.toml", "-o", tmp_path / "k", "--quiet")
    assert res.rc == 0
    s = json.loads((tmp_path / "k" / "summary.json").read_text())
    assert s["beyond_envelope"] == [False, True] and s["site_response_excluded"] == []
    assert s["envelope"]["keep_beyond_envelope"] is True
    from grainmech.io.site_response import read_curves

    c = read_curves(tmp_path / "k" / "site_response_curves.csv")
    assert np.allclose(c.strain, [1e-5, 1e-3]) and "kept beyond the envelope of sands" in c.comment
    # the point is still marked everywhere else
    assert "BEYOND ENVELOPE" in res.out and "beyond the envelope of sands" in res.err


def test_keep_beyond_envelope_key_is_checked():
    from grainmech.jobs import prepare_run

    cfg = tomllib.loads(_cfg("[1e-5]", "keep_beyond_envelope = 1"))
    with pytest.raises(ConfigError, match="model.keep_beyond_envelope"):
        prepare_run(cfg)
    assert prepare_run(tomllib.loads(_cfg("[1e-5]", "keep_beyond_envelope = true"))).keep_beyond_envelope
    assert not prepare_run(tomllib.loads(_cfg("[1e-5]"))).keep_beyond_envelope
    from pathlib import Path

    path_cfg = tomllib.loads((Path(__file__).resolve().parents[2] / "examples" / "run_triaxial_path.toml").read_text())
    path_cfg.setdefault("model", {})["keep_beyond_envelope"] = True
    with pytest.raises(ConfigError, match="model.keep_beyond_envelope.*cyclic-simple-shear"):
        prepare_run(path_cfg)


# ---------------------------------------------------------------------- a loop that drifts
def _drifted_outcome(drift: float):
    """The affine run at [1e-5, 1e-4] with the 1e-4 run's tau_xz drifting by ``drift`` x its
    analysed tau_a over the last cycle (as ratcheting would), through jobs._cyclic_outcome."""
    from grainmech.analysis import ModulusReduction
    from grainmech.jobs import _cyclic_outcome, execute_run, prepare_run

    cfg = tomllib.loads(_cfg("[1e-5, 1e-4]"))
    spec = prepare_run(cfg)
    out = execute_run(spec)
    r = out.results[1]
    n, spc = len(r.stress) - 1, spec.steps_per_cycle
    ta = out.loop_quality[1].tau_a
    s = r.stress.copy()
    s[n - spc:, 4] += drift * ta * np.linspace(0.0, 1.0, spc + 1)
    results = [out.results[0], dataclasses.replace(r, stress=s)]
    mr = ModulusReduction(out.amplitudes, out.G, out.damping, out.G_max, results)
    return cfg, spec, _cyclic_outcome(spec, "affine", mr, 1.0, out.point, spec.void_ratio)


def test_drifting_loop_is_warned_everywhere(tmp_path, monkeypatch, cli):
    cfg, spec, o = _drifted_outcome(0.2)
    assert [q.ok for q in o.loop_quality] == [True, False]
    assert o.loop_quality[1].stress_closure == pytest.approx(0.2 / (1 - 0.2 / 4), rel=0.01)  # peaks a quarter and three quarters in
    assert any(w.startswith("affine model, amplitude 1.0e-04: loop not closed") for w in o.warnings)
    assert last_cycle_quality(o.results[1], spec.steps_per_cycle) == o.loop_quality[1]
    # a 3 % drift stays within the 5 % tolerance
    assert _drifted_outcome(0.03)[2].loop_quality[1].ok

    import grainmech.jobs as jobs

    monkeypatch.setattr(jobs, "compute_run", lambda cfg, progress=None, records=None: o)
    (tmp_path / "c.toml").write_text(_cfg("[1e-5, 1e-4]"))
    res = cli("run", tmp_path / "c.toml", "-o", tmp_path / "o", "--quiet")
    assert res.rc == 0
    line = next(ln for ln in res.out.splitlines() if "amplitude  1.00e-04" in ln)
    assert line.endswith("WARNING: loop not closed/symmetric")
    assert "grainmech: warning: affine model, amplitude 1.0e-04: loop not closed" in res.err
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["loop_warning"] == [False, True] and not s["loop_quality"][1]["closed"]
    assert s["loop_quality"][1]["problems"][0].startswith("loop not closed")
    assert any("loop not closed" in w for w in s["warnings"])
    rows = list(csv.DictReader(open(tmp_path / "o" / "modulus_reduction.csv")))
    assert [r["loop_warning [0/1]"] for r in rows] == ["0", "1"]
    assert float(rows[1]["loop_stress_closure [-]"]) == pytest.approx(s["loop_quality"][1]["stress_closure"])
    page = (tmp_path / "o" / "index.html").read_text()
    assert "the analysed cycle of amplitude(s) 1.0e-04 is not a closed, symmetric loop" in page
    assert "(warning)</b>" in page
    # a loop warning does not exclude the amplitude from the site-response curves
    from grainmech.io.site_response import read_curves

    assert np.allclose(read_curves(tmp_path / "o" / "site_response_curves.csv").strain, [1e-5, 1e-4])


# ------------------------------------------------------------------------------ grains that rearrange
def _cv_run(dp: float, n: int = 8):
    """A stand-in completed constant-volume run: mean stress from 100 kPa to 100 (1 + dp) kPa,
    a closed elastic loop tau = 1e8 gamma."""
    from grainmech.driver.base import DriverResult

    g = 1e-4 * np.sin(np.linspace(0.0, 2 * np.pi, n + 1))
    p = 1e5 * (1.0 + dp * np.linspace(0.0, 1.0, n + 1))
    stress = np.zeros((n + 1, 6))
    stress[:, :3] = p[:, None]
    stress[:, 4] = 1e8 * g
    strain = np.zeros((n + 1, 6))
    strain[:, 4] = g
    z = np.zeros(n + 1)
    return DriverResult(success=True, status=0, message="done", strain=strain, stress=stress,
                        tangent=np.full((n + 1, 6, 6), np.nan), sliding_fraction=z, open_fraction=z, dissipation=z,
                        work=z, stored=z, substeps=np.ones(n + 1, int), iterations=np.ones(n + 1, int), final=None,
                        n_steps=n)


def test_packing_loops_whose_mean_stress_drifts_at_constant_volume_are_flagged(tmp_path, monkeypatch, cli):
    """Issue 29 (honest outputs): a packing-model loop at constant volume whose mean stress
    changes by more than REARRANGEMENT_DP is flagged. The cases are the measured ones of
    docs/models/packing.md ("Where the fixed geometry holds", Hertz-Mindlin): 'loose' at 3e-5
    (-0.0196; the DEM model's G differs by 6.9 %) and 1e-4 (-0.1177; +20 %) flagged, 'medium'
    at 1e-4 (-0.0028; within 0.2 % of the DEM) and 'dense' at 3e-4 (+0.0017; 1.0 %) not."""
    from grainmech.driver.loop import ModulusReduction
    from grainmech.jobs import REARRANGEMENT_DP, _cyclic_outcome, prepare_run, rearrangement_warnings, rearranging

    assert 0.0028 < REARRANGEMENT_DP < 0.0196
    runs = [_cv_run(d) for d in (-0.0028, +0.0017, -0.0196, -0.1177)]
    amps = [1e-4, 3e-4, 3e-5, 1e-4]
    assert rearranging("packing", "volume", runs) == [False, False, True, True]
    # constant stress (the measured link is at constant volume) and the other models: no flag
    assert rearranging("packing", "stress", runs) == [False] * 4
    assert rearranging("dem", "volume", runs) == [False] * 4
    w = rearrangement_warnings("packing", "volume", amps, runs)
    assert len(w) == 2
    assert w[0].startswith("packing model, amplitude 3.0e-05: the mean stress changed by -2.0 %")
    assert "-11.8 %" in w[1] and 'method = "dem"' in w[1]

    # in a run's outcome: the flags in details, the sentences in warnings
    cfg = tomllib.loads(f"""
[contacts]
law = "hertz-mindlin"
shear_modulus = "29 GPa"
poisson = 0.15
friction = 0.5
[initial]
pressure = "100 kPa"
[model]
method = "packing"
packing = "loose"
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-5, 3e-5]
n_cycles = 2
steps_per_cycle = 8
constant = "volume"
""")
    spec = prepare_run(cfg)
    pair = [_cv_run(-0.0028), _cv_run(-0.0196)]
    mr = ModulusReduction(amplitude=np.array([1e-5, 3e-5]), G=np.array([1e8, 1e8]), damping=np.zeros(2),
                          G_max=1e8, results=pair)
    o = _cyclic_outcome(spec, "packing", mr, 1.0, None, 0.717, {})
    assert o.details["rearranging"] == [False, True]
    assert [x for x in o.warnings if "rearrange" in x] == rearrangement_warnings("packing", "volume",
                                                                                 [1e-5, 3e-5], pair)
    # where a user reads it: the amplitude's line, stderr, summary.json
    import grainmech.jobs as jobs

    monkeypatch.setattr(jobs, "compute_run", lambda cfg, progress=None, records=None: o)
    (tmp_path / "c.toml").write_text(_cfg("[1e-5, 3e-5]"))
    res = cli("run", tmp_path / "c.toml", "-o", tmp_path / "o", "--quiet")
    assert res.rc == 0, res.err
    lines = {a: next(ln for ln in res.out.splitlines() if f"amplitude  {a}" in ln) for a in ("1.00e-05", "3.00e-05")}
    assert "GRAINS REARRANGE" in lines["3.00e-05"] and "GRAINS REARRANGE" not in lines["1.00e-05"]
    assert "grainmech: warning: packing model, amplitude 3.0e-05: the mean stress changed by -2.0 %" in res.err
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["details"]["rearranging"] == [False, True]

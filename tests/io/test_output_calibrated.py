"""calibrate writes the calibrated config; run and stiffness accept the coordination
relation m = (a - b e)(p/p_ref)^n that calibrate fits."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest

from grainmech.errors import ConfigError
from grainmech.jobs import compute_stiffness

EX = Path(__file__).resolve().parents[2] / "examples"

STIFF = {"microstructure": {"void_ratio": 0.65, "radius": "0.25 mm", "coordination": 8.0},
         "contacts": {"law": "hertz-mindlin", "shear_modulus": "44 GPa", "poisson": 0.08},
         "stress": {"pressure": "200 kPa"}}


def _with(cfg: dict, coordination) -> dict:
    return {**cfg, "microstructure": {**cfg["microstructure"], "coordination": coordination}}


def test_stiffness_accepts_the_relation_and_evaluates_it_at_the_mean_stress():
    """m = (a - b e)(p/p_ref)^n = (23 - 25*0.65)(200/100)^0.3 (seed Eq. 6.4 times a power)."""
    m = (23.0 - 25.0 * 0.65) * 2.0 ** 0.3
    rel = compute_stiffness(_with(STIFF, {"a": 23.0, "b": 25.0, "n": 0.3, "p_ref": "100 kPa"}))
    num = compute_stiffness(_with(STIFF, m))
    assert rel.engineering.as_dict()["G_xz"] == pytest.approx(num.engineering.as_dict()["G_xz"], rel=1e-12)
    # a stress tensor: its mean (trace / 3) is the pressure
    t = {**_with(STIFF, {"a": 23.0, "b": 25.0, "n": 0.3, "p_ref": "100 kPa"}),
         "stress": {"tensor": [["150 kPa", 0, 0], [0, "150 kPa", 0], [0, 0, "300 kPa"]]}}
    t_num = {**_with(STIFF, m), "stress": t["stress"]}
    assert compute_stiffness(t).engineering.as_dict()["E_zz"] == pytest.approx(
        compute_stiffness(t_num).engineering.as_dict()["E_zz"], rel=1e-12)


def test_relation_errors_name_the_key():
    with pytest.raises(ConfigError, match=r"microstructure\.coordination\.a: required key is missing"):
        compute_stiffness(_with(STIFF, {"b": 25.0}))
    with pytest.raises(ConfigError, match=r"microstructure\.coordination = .*gives coordination m = -"):
        compute_stiffness(_with(STIFF, {"a": 10.0, "b": 25.0}))
    with pytest.raises(ConfigError, match=r"unknown key 'c'"):
        compute_stiffness(_with(STIFF, {"a": 23.0, "c": 1.0}))
    no_stress = {k: v for k, v in _with(STIFF, {"a": 23.0, "n": 0.5}).items() if k != "stress"}
    with pytest.raises(ConfigError, match="needs the mean stress"):
        compute_stiffness(no_stress)


def test_run_accepts_the_relation(tmp_path):
    from conftest import default_run_affine

    cfg = tomllib.loads(default_run_affine())
    cfg["test"]["amplitudes"] = [1e-5]
    e, p = cfg["microstructure"]["void_ratio"], 1e5
    from grainmech.jobs import compute_run

    rel = compute_run(_with(cfg, {"a": 20.0, "b": 20.0, "n": 0.5, "p_ref": "50 kPa"}))
    num = compute_run(_with(cfg, (20.0 - 20.0 * e) * (p / 5e4) ** 0.5))
    assert rel.G_max == pytest.approx(num.G_max, rel=1e-12)


def test_calibrate_writes_a_config_that_stiffness_runs(tmp_path, cli):
    out = tmp_path / "cal"
    assert cli("calibrate", EX / "calibrate_hardin_black.toml", EX / "calibrate_hardin_black.csv",
               "-o", out, "--quiet", "--no-plot").rc == 0
    fit = json.loads((out / "fit.json").read_text())
    best = {q["path"]: q["value"] for q in fit["parameters"]}
    text = (out / "calibrated.toml").read_text()
    assert "# Run it with: grainmech stiffness calibrated.toml" in text
    cfg = tomllib.loads(text)
    assert cfg["microstructure"]["coordination"]["b"] == pytest.approx(best["microstructure.coordination.b"], rel=1e-9)
    assert cfg["contacts"]["shear_modulus"].endswith(" psi")
    assert float(cfg["contacts"]["shear_modulus"].split()[0]) == pytest.approx(best["contacts.shear_modulus"],
                                                                              rel=1e-9)
    # the same stiffness as the calibrated model predicts at that pressure and void ratio
    from grainmech.calibrate import load_problem
    from grainmech.calibrate.data import from_arrays
    from grainmech.calibrate.model import predict

    problem = load_problem(EX / "calibrate_hardin_black.toml", EX / "calibrate_hardin_black.csv")
    model = {k: v for k, v in cfg.items() if k != "stress"}
    p = float(cfg["stress"]["pressure"].split()[0])
    pred = predict("modulus-pressure", model, from_arrays({"pressure": [p], "void_ratio": [0.65], "G": [1.0]}),
                   problem.settings)
    res = cli("stiffness", str(out / "calibrated.toml"), "--json")
    assert res.rc == 0
    got = json.loads(res.out)["engineering"]["G_xz"]
    assert got == pytest.approx(float(pred["G"][0]), rel=1e-9)

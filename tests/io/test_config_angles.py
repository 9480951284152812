"""One rule for angles in every config (docs/config.md): the unit is required.

Before, a bare ``friction_angle`` was read in radians by ``run``/``stiffness`` and in
degrees by ``contact``/``calibrate``; and a calibration of a friction angle wrote the
radian value back as a bare number that the rod model then read in degrees.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from grainmech.errors import ConfigError

EX = Path(__file__).resolve().parents[2] / "examples"
DATA = Path(__file__).resolve().parents[2] / "src" / "grainmech" / "data"


def _toml(path: Path) -> dict:
    return tomllib.loads(path.read_text())


def _set(cfg: dict, dotted: str, value) -> dict:
    out = copy.deepcopy(cfg)
    d = out
    *head, last = dotted.split(".")
    for h in head:
        d = d.setdefault(h, {})
    d[last] = value
    return out


def test_section_angle_rule():
    from grainmech.io.config import Section

    assert Section({"a": "24 deg"}, "t").angle("a") == pytest.approx(math.radians(24))
    assert Section({"a": "0.5 rad"}, "t").angle("a") == pytest.approx(0.5)
    with pytest.raises(ConfigError, match=r"t\.a = 24: an angle needs its unit: write e\.g\. '24 deg'"):
        Section({"a": 24}, "t").angle("a")
    with pytest.raises(ConfigError, match=r"t\.a = '95 deg': must lie in \[0, 90 deg\)"):
        Section({"a": "95 deg"}, "t").angle("a", max_deg=90, max_inclusive=False)
    with pytest.raises(ConfigError, match="has units of"):
        Section({"a": "3 m"}, "t").angle("a")


@pytest.mark.parametrize("key", ["contacts.friction_angle", "reference.friction_angle"])
def test_run_config(key):
    from grainmech.jobs import prepare_run

    base = _toml(DATA / "default_run.toml")
    if key.startswith("contacts"):
        base["contacts"].pop("friction")
    with pytest.raises(ConfigError, match=f"{key} = 24: an angle needs its unit"):
        prepare_run(_set(base, key, 24))
    a = prepare_run(_set(base, key, "24 deg"))
    b = prepare_run(_set(base, key, f"{math.radians(24)!r} rad"))
    assert repr(a) == repr(b)


def test_contact_config(tmp_path, cli):
    text = (EX / "contact_cylinder_rods.toml").read_text()
    assert 'friction_angle = "15 deg"' in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('friction_angle = "15 deg"', "friction_angle = 15"))
    res = cli("contact", str(bad), "-o", str(tmp_path / "x"))
    assert res.rc == 2
    assert "friction_angle = 15: an angle needs its unit" in res.err
    outs = []
    for i, v in enumerate(['"15 deg"', f'"{math.radians(15)!r} rad"']):
        cfg = tmp_path / f"c{i}.toml"
        cfg.write_text(text.replace('"15 deg"', v))
        assert cli("contact", str(cfg), "-o", str(tmp_path / f"o{i}")).rc == 0
        outs.append((tmp_path / f"o{i}" / "contact.csv").read_text())
    assert outs[0] == outs[1]


def test_calibrate_config_and_fitted_angle_written_with_unit():
    from grainmech.calibrate.fit import problem_from_config

    cfg = _toml(EX / "calibrate_random_rods.toml")
    data = EX / "calibrate_random_rods.csv"
    with pytest.raises(ConfigError, match="friction_angle = 15: an angle needs its unit"):
        bad = problem_from_config(_set(cfg, "model.friction_angle", 15), data)
        bad.predict([p.start for p in bad.parameters], validate=True)
    # fit the friction angle: the value written into the model carries 'rad', and the
    # prediction at 20 deg equals that of a config that says "20 deg"
    fit_phi = _set(cfg, "parameters", [{"path": "friction_angle", "start": "15 deg",
                                        "lower": "5 deg", "upper": "40 deg"}])
    prob = problem_from_config(fit_phi, data)
    x = np.array([math.radians(20.0)])
    written = prob.config_at(x)
    assert written["friction_angle"] == f"{math.radians(20.0)!r} rad"
    fixed = _set(_set(cfg, "model.friction_angle", "20 deg"), "parameters",
                 [{"path": "psi", "start": 2.5, "lower": 1.0, "upper": 5.0}])
    ref = problem_from_config(fixed, data)
    assert cfg["model"]["psi"] == 2.5
    a, b = prob.predict(x), ref.predict([2.5])
    for k in a:
        assert np.allclose(a[k], b[k], rtol=1e-12, atol=0)


def test_sweep_writes_angles_with_their_unit():
    from grainmech.sweep.spec import load_sweep

    sw = load_sweep(EX / "sweep_cyclic_gmax.toml", check=False)
    vals = [pt.config["contacts"]["friction_angle"] for pt in sw.points]
    assert all(isinstance(v, str) and v.endswith(" rad") for v in vals)
    rad = [float(v.split()[0]) for v in vals]
    assert min(rad) >= math.radians(20) - 1e-12 and max(rad) <= math.radians(35) + 1e-12

"""What the main job says beside its numbers: the empirical small-strain modulus and the
stress-ratio envelope of sands."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from grainmech.analysis import hardin_richart, mohr_coulomb_ratio
from grainmech.errors import ParameterError
from grainmech.jobs import empirical_gmax_check, envelope_check

EX = Path(__file__).resolve().parents[2] / "examples"


def test_hardin_richart_against_the_psi_forms():
    """Hardin & Richart (1963): 2630 (2.17-e)^2/(1+e) sqrt(s) and 1230 (2.97-e)^2/(1+e) sqrt(s),
    G and s in psi (the round-grain form is seed Eq. 6.3); converted here independently."""
    psi = 6894.757
    for e, p in [(0.65, 1e5), (0.5, 3e5), (0.9, 5e4)]:
        hr = hardin_richart(e, p)
        s = p / psi
        assert hr.G_round == pytest.approx(2630 * (2.17 - e) ** 2 / (1 + e) * math.sqrt(s) * psi, rel=5e-4)
        assert hr.G_angular == pytest.approx(1230 * (2.97 - e) ** 2 / (1 + e) * math.sqrt(s) * psi, rel=5e-4)
    hr = hardin_richart(0.65, 1e5)
    assert hr.G_round == pytest.approx(96.7e6, rel=2e-3) and hr.G_angular == pytest.approx(105.4e6, rel=2e-3)
    assert hr.in_range_round and hr.in_range_angular
    with pytest.raises(ParameterError, match="void_ratio"):
        hardin_richart(2.5, 1e5)
    with pytest.raises(ParameterError, match="mean_stress"):
        hardin_richart(0.6, -1.0)


def test_mohr_coulomb_ratio():
    assert mohr_coulomb_ratio(math.radians(30)) == pytest.approx(3.0)
    assert mohr_coulomb_ratio(math.radians(50)) == pytest.approx(7.5486, rel=1e-4)


def test_gmax_check_flags_the_affine_default():
    """The default run's affine Gmax (407 MPa at e = 0.65, 100 kPa) is ~4x the empirical one."""
    chk = empirical_gmax_check(4.07e8, 0.65, 1e5)
    assert chk["flag"] and chk["ratio_round"] == pytest.approx(4.21, rel=1e-2)
    assert "upper bound" in chk["note"]
    ok = empirical_gmax_check(1.0e8, 0.65, 1e5)
    assert not ok["flag"]
    assert empirical_gmax_check(1e8, None, 1e5) is None


def test_envelope_check_marks_the_first_step_beyond():
    p = 1e5
    steps = [np.array([p, p, p, 0, 0, 0]), np.array([p, p, 5 * p, 0, 0, 0]), np.array([p, p, 9 * p, 0, 0, 0])]
    env = envelope_check(np.array(steps))
    assert env["first_step"] == 2
    assert list(env["beyond"]) == [False, False, True]
    assert env["ratio"][1] == pytest.approx(5.0)


def test_triaxial_path_output_flags_the_envelope(tmp_path, cli):
    res = cli("run", str(EX / "run_triaxial_path.toml"), "-o", str(tmp_path))
    assert res.rc == 0
    err = res.err  # a warning: on stderr, with the path's result line on stdout
    assert "grainmech: warning: the stress ratio sigma1/sigma3 leaves the envelope" in err
    assert "path: " in res.out and "final stress" in res.out and "warning" not in res.out
    summ = json.loads((tmp_path / "summary.json").read_text())
    first = summ["envelope"]["first_step_beyond"]
    assert first is not None and summ["envelope"]["max_ratio"] > 7.55
    head = (tmp_path / "path.csv").read_text().splitlines()
    cols = head[0].split(",")
    k = cols.index("beyond_sand_envelope [0/1]")
    flags = [float(r.split(",")[k]) for r in head[1:]]
    assert flags[first] == 1.0 and not any(flags[:first])
    assert "Warning:" in (tmp_path / "index.html").read_text()


def test_input_warnings_name_value_and_reason():
    import tomllib

    from grainmech.jobs import grain_modulus_warning, input_warnings

    base = tomllib.loads((Path(__file__).resolve().parents[2] / "src" / "grainmech" / "data"
                          / "default_run.toml").read_text())
    assert input_warnings(base) == []
    cfg = dict(base, initial={"pressure": 100})
    (w,) = input_warnings(cfg)
    assert w.startswith("initial.pressure = 100: a bare number is read in Pa")
    cfg = dict(base, test=dict(base["test"], amplitudes=[1e-4, 0.05]))
    (w,) = input_warnings(cfg)
    assert w.startswith("test.amplitudes = [0.05]: above 0.01")
    for m in (3.0, 13.0):
        (w,) = input_warnings(dict(base, microstructure=dict(base["microstructure"], coordination=m)))
        assert w.startswith(f"microstructure.coordination = {m:g}: outside 4-12")
    # Yanagisawa (seed Eq. 4.2) at e = 0.9: m = 3.183^(2.469-0.9) = 6.16, inside
    ms = dict(base["microstructure"], coordination="yanagisawa", void_ratio=0.9)
    assert input_warnings(dict(base, microstructure=ms)) == []

    class Law:
        shear_modulus = 44e9

    assert grain_modulus_warning(4e8, Law()) == []
    (w,) = grain_modulus_warning(5e10, Law())
    assert "above the grains' own shear modulus" in w


def test_mean_stress_change_per_amplitude(tmp_path, cli):
    """modulus_reduction.csv reports p_end/p_0 - 1 of each amplitude's run (its run CSV)."""
    import csv
    import tomllib


    from conftest import default_run_affine

    cfg = default_run_affine()
    cfg = cfg.replace("amplitudes = [1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3]", "amplitudes = [1e-5, 1e-3]")
    assert tomllib.loads(cfg)["test"]["amplitudes"] == [1e-5, 1e-3]
    (tmp_path / "c.toml").write_text(cfg)
    assert cli("run", str(tmp_path / "c.toml"), "-o", str(tmp_path / "o"), "--quiet").rc == 0
    rows = list(csv.DictReader(open(tmp_path / "o" / "modulus_reduction.csv")))
    for i, row in enumerate(rows):
        amp = float(row["shear_strain_amplitude [-]"])
        run = list(csv.DictReader(open(tmp_path / "o" / f"cycles_gamma_{amp:.1e}.csv")))
        p = [np.mean([float(r[f"stress_{c} [Pa]"]) for c in ("xx", "yy", "zz")]) for r in (run[0], run[-1])]
        assert float(row["mean_stress_change [-]"]) == pytest.approx(p[1] / p[0] - 1, abs=1e-8)  # CSV: 10 digits
    assert abs(float(rows[1]["mean_stress_change [-]"])) > 1e-3  # sigma_zz held, sigma_xx, sigma_yy free

"""Results on stdout, progress and warnings on stderr, for every command; the pressure
range and the plausibility warnings every command that reads a stress applies the same
way; calibration data and fitted grain moduli checked against physical ranges."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EX = ROOT / "examples"

TINY_RUN = """
[microstructure]
void_ratio = 0.65
coordination = 8.0
radius = "0.25 mm"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "44 GPa"
poisson = 0.08
friction = 0.5
[initial]
pressure = "100 kPa"
[quadrature]
degree = 5
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-5, 1e-4]
n_cycles = 2
steps_per_cycle = 16
"""

STIFFNESS = """
[microstructure]
void_ratio = 0.65
coordination = 8.0
radius = "0.25 mm"
[contacts]
law = "hertz-mindlin"
shear_modulus = "44 GPa"
poisson = 0.08
[stress]
pressure = "100 kPa"
"""


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT / "src")}


@pytest.mark.parametrize("quiet", [False, True])
def test_run_result_table_goes_to_a_redirected_stdout(tmp_path, quiet):
    """`grainmech run CONFIG -o DIR > file`: the result table is in the file, the progress
    lines are on stderr (none with --quiet), and the file has no progress line."""
    (tmp_path / "c.toml").write_text(TINY_RUN)
    with open(tmp_path / "result.txt", "w") as fh:
        p = subprocess.run([sys.executable, "-m", "grainmech", "run", "c.toml", "-o", "out",
                            *(["--quiet"] if quiet else [])], cwd=tmp_path, env=_env(), stdout=fh,
                           stderr=subprocess.PIPE, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    table = (tmp_path / "result.txt").read_text()
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert "Gmax = " in table and f"{s['G_max_Pa']:.4g} Pa" in table
    rows = [ln for ln in table.splitlines() if ln.strip().startswith("amplitude")]
    assert len(rows) == 2 and "G/Gmax" in rows[0] and f"{s['G_over_Gmax'][1]:6.3f}" in rows[1]
    assert "wrote" in table and "out" in table
    assert "[affine" not in table and "grainmech run:" not in table
    err = p.stderr.replace(
        "grainmech: compiling the contact-law kernels with numba (first run after installing or upgrading, "
        "10-20 s; later runs load them from the cache)\n", "")
    if quiet:
        assert err == ""
    else:
        assert err.startswith("grainmech run: c.toml\n") and "[affine 1/2]" in err and "[affine 2/2]" in err
        assert "G/Gmax" not in err and "Gmax =" not in err


def test_stiffness_results_on_stdout_warning_on_stderr(tmp_path, cli):
    cfg = tmp_path / "s.toml"
    cfg.write_text(STIFFNESS)
    res = cli("stiffness", cfg, "--quiet")
    assert res.rc == 0 and "engineering constants" in res.out and res.err == ""


def test_reproduce_progress_on_stderr_files_on_stdout(tmp_path, cli):
    res = cli("reproduce", "fig4.3", "-o", tmp_path / "r")
    assert res.rc == 0
    assert "Fig. 4.3: fig4_3.png, fig4_3.csv" in res.out and "computing" not in res.out
    assert "computing" in res.err and "fig4_3.png" not in res.err
    quiet = cli("reproduce", "fig4.3", "-o", tmp_path / "r", "--quiet")
    assert quiet.rc == 0 and quiet.err == "" and "fig4_3.png" in quiet.out


def test_calibrate_results_on_stdout_even_with_quiet(tmp_path, cli):
    res = cli("calibrate", EX / "calibrate_hardin_black.toml", EX / "calibrate_hardin_black.csv",
              "-o", tmp_path / "c", "--quiet", "--no-plot")
    assert res.rc == 0
    assert "contacts.shear_modulus" in res.out and "R^2" in res.out and "wrote" in res.out
    assert res.err == ""
    loud = cli("calibrate", EX / "calibrate_hardin_black.toml", EX / "calibrate_hardin_black.csv",
               "-o", tmp_path / "c", "--no-plot")
    assert loud.err.startswith("grainmech calibrate: modulus-pressure, 18 rows; fitting 3 parameter(s)")
    assert "R^2" not in loud.err


def test_contact_and_dem_results_on_stdout(tmp_path, cli):
    res = cli("contact", EX / "contact_md_growing_cycles.toml", "-o", tmp_path / "k", "--no-plot", "--quiet")
    assert res.rc == 0 and "contact.csv" in res.out and res.err == ""
    from grainmech.io.dem import write_table
    from grainmech.network import random_network

    c, p = tmp_path / "c.csv", tmp_path / "p.csv"
    write_table(random_network(60, seed=1), c, p)
    res = cli("dem", c, "--particles", p, "-o", tmp_path / "d", "--no-plots", "--quiet")
    assert res.rc == 0 and "coordination" in res.out and res.err == ""


# ------------------------------------------------------------------ pressure range

@pytest.mark.parametrize("value, shown", [('"1e12 Pa"', "'1e12 Pa'"), ('"2 GPa"', "'2 GPa'"),
                                          ('"0.5 Pa"', "'0.5 Pa'"), ("1e10", "10000000000.0")])
def test_absurd_pressure_refused_up_front_by_run_and_stiffness(tmp_path, cli, value, shown):
    run = tmp_path / "r.toml"
    run.write_text(TINY_RUN.replace('pressure = "100 kPa"', f"pressure = {value}"))
    res = cli("run", run, "-o", tmp_path / "o")  # not quiet: the error is the only line
    assert res.rc == 2 and not (tmp_path / "o").exists()
    assert res.err.count("\n") == 1 and res.out == ""
    assert res.err.startswith(f"grainmech: error: initial.pressure = {shown}: ")
    assert "outside 1 Pa to 1 GPa" in res.err
    st = tmp_path / "s.toml"
    st.write_text(STIFFNESS.replace('pressure = "100 kPa"', f"pressure = {value}"))
    res = cli("stiffness", st)
    assert res.rc == 2 and res.err.count("\n") == 1
    assert res.err.startswith(f"grainmech: error: stress.pressure = {shown}: ") and "outside 1 Pa to 1 GPa" in res.err


def test_pressure_range_edges_are_accepted():
    from grainmech.io.config import Section
    from grainmech.io.schema import build_pressure

    assert build_pressure(Section({"pressure": "1 GPa"}, "initial")) == pytest.approx(1e9)
    assert build_pressure(Section({"pressure": "1 Pa"}, "initial")) == pytest.approx(1.0)


def test_stress_tensor_and_pack_stress_use_the_same_range():
    import tomllib

    from grainmech.errors import ConfigError
    from grainmech.io.config import Section
    from grainmech.io.pack_config import build_pack_config
    from grainmech.io.schema import build_stress

    with pytest.raises(ConfigError, match=r"stress.tensor = .*outside 1 Pa to 1 GPa"):
        build_stress(Section({"tensor": [["0.1 Pa", 0, 0], [0, "0.1 Pa", 0], [0, 0, "0.1 Pa"]]}, "stress"), 3)
    cfg = tomllib.loads((EX / "pack_quartz_dense.toml").read_text())
    cfg["preparation"]["stress"] = "5 GPa"
    with pytest.raises(ConfigError, match=r"preparation.stress = '5 GPa': 5e\+09 Pa is outside 1 Pa to 1 GPa"):
        build_pack_config(cfg)


def test_bare_pressure_warns_the_same_in_run_and_stiffness(tmp_path, cli):
    run = tmp_path / "r.toml"
    run.write_text(TINY_RUN.replace('pressure = "100 kPa"', "pressure = 100"))
    r = cli("run", run, "-o", tmp_path / "o", "--quiet")  # --quiet keeps warnings
    assert r.rc == 0
    st = tmp_path / "s.toml"
    st.write_text(STIFFNESS.replace('pressure = "100 kPa"', "pressure = 100"))
    s = cli("stiffness", st, "--quiet")  # --quiet keeps warnings
    assert s.rc == 0
    tail = ': a bare number is read in Pa (100 Pa, below 1 kPa); write e.g. "100 kPa" if that was meant\n'
    # at 100 Pa the affine model's larger amplitudes also leave the envelope of sands (one
    # warning each, after the input warning)
    first, *rest = r.err.splitlines(keepends=True)
    assert first == "grainmech: warning: initial.pressure = 100" + tail
    assert rest and all("beyond the envelope of sands" in w for w in rest)
    assert s.err == "grainmech: warning: stress.pressure = 100" + tail
    assert "warning" not in s.out


# ------------------------------------------------------------------ calibration data and fit

def test_negative_modulus_in_calibration_data_is_refused_naming_the_row(tmp_path, cli):
    text = (EX / "calibrate_hardin_black.csv").read_text().replace("10,0.55,14081.7", "10,0.55,-14081.7")
    data = tmp_path / "d.csv"
    data.write_text(text)
    line = text.splitlines().index("10,0.55,-14081.7") + 1
    res = cli("calibrate", EX / "calibrate_hardin_black.toml", data, "-o", tmp_path / "o")
    assert res.rc == 2 and res.err.count("\n") == 1
    assert res.err.startswith(f"grainmech: error: {data}, line {line}, column 'G': value '-14081.7': "
                              "a measured modulus must be > 0")
    assert not (tmp_path / "o").exists()


def test_absurd_pressure_in_calibration_data_is_refused(tmp_path):
    from grainmech.calibrate.data import read_csv
    from grainmech.errors import GrainmechError

    p = tmp_path / "d.csv"
    p.write_text("pressure [GPa],G [MPa]\n0.1,50\n3,80\n")
    with pytest.raises(GrainmechError, match=r"line 3, column 'pressure': value '3': 3e\+09 Pa is outside 1 Pa to 1 GPa"):
        read_csv(p)


def test_fitted_grain_modulus_outside_the_mineral_range_is_flagged(tmp_path, cli):
    """The Hardin-Black example fits the affine model to a sand's measured moduli: the
    model is too stiff, so the fit lowers the grain modulus to 3.9 GPa, below every
    mineral's; the report (stdout and fit.json) says so."""
    res = cli("calibrate", EX / "calibrate_hardin_black.toml", EX / "calibrate_hardin_black.csv",
              "-o", tmp_path / "c", "--no-plot", "--quiet")
    assert res.rc == 0
    fit = json.loads((tmp_path / "c" / "fit.json").read_text())
    g = [p for p in fit["parameters"] if p["path"] == "contacts.shear_modulus"][0]["value_si"]
    assert g < 5e9
    (flag,) = fit["plausibility"]
    assert flag.startswith(f"fitted contacts.shear_modulus = {g / 1e9:.4g} GPa is outside 5-100 GPa")
    assert flag in fit["notes"] and f"WARNING: {flag}" in res.out


def test_plausibility_flags_only_grain_moduli_outside_the_range():
    from types import SimpleNamespace

    from grainmech.calibrate.fit import plausibility_flags

    params = [SimpleNamespace(path="contacts.shear_modulus"), SimpleNamespace(path="shear_modulus_equiv"),
              SimpleNamespace(path="contacts.shear_modulus2")]
    prob = SimpleNamespace(parameters=params)
    assert plausibility_flags(prob, [44e9, 1e8, 80e9]) == []  # quartz, a rod constant, steel
    flags = plausibility_flags(prob, [2e11, 1e8, 1e9])
    assert [f.split(" = ")[0] for f in flags] == ["fitted contacts.shear_modulus", "fitted contacts.shear_modulus2"]

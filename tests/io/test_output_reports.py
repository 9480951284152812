"""What a run's folder shows: reference curves with one stated choice, readable loops,
units in headers, every file linked from index.html."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import default_run_affine
from grainmech.cli import main

ROOT = Path(__file__).resolve().parents[2]
# the built-in default with the affine model alone, at the void ratio these reference
# numbers were worked out for (the default's was 0.65 until it ran both models, 2026-11-26)
CFG = default_run_affine().replace(
    "amplitudes = [1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3]", "amplitudes = [1e-6, 1e-4, 1e-3]").replace(
    "void_ratio = 0.57 ", "void_ratio = 0.65 ")
assert "void_ratio = 0.65 " in CFG


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    (d / "c.toml").write_text(CFG)
    assert main(["run", str(d / "c.toml"), "-o", str(d / "o"), "--quiet"]) == 0
    return d / "o"


def test_hardin_drnevich_reference_strain_is_empirical(default_run):
    """Hardin & Drnevich (1972): gamma_r = tau_max / Gmax with tau_max = p sin(phi')
    (default phi' = 33 deg) and Gmax from Hardin's angular-grain correlation
    G = 3230 (2.97 - e)^2 / (1 + e) sqrt(p) [kPa] (1230 psi form, Hardin & Richart 1963),
    e = 0.65, p = 100 kPa -- not the model's Gmax, which is ~4x larger."""
    s = json.loads((default_run / "summary.json").read_text())
    e, p_kpa = 0.65, 100.0
    g_emp = 3230.0 * (2.97 - e) ** 2 / (1 + e) * math.sqrt(p_kpa) * 1e3
    assert s["hardin_drnevich_G_max_Pa"] == pytest.approx(g_emp, rel=1e-9)
    assert s["hardin_drnevich_gamma_r"] == pytest.approx(1e5 * math.sin(math.radians(33)) / g_emp, rel=1e-9)
    assert s["hardin_drnevich_gamma_r"] > 3 * 1e5 * math.sin(math.radians(33)) / s["G_max_Pa"]
    # Darendeli (2001) Table 8.12, PI = 0, OCR = 1: gamma_r [%] = 0.0352 (p/1 atm)^0.3483
    assert s["darendeli_gamma_r"] == pytest.approx(0.0352e-2 * (1e5 / 101325) ** 0.3483, rel=1e-9)
    page = (default_run / "index.html").read_text()
    assert "reference strains come from correlations, not from the model" in page
    assert "Hardin-Richart (1963) angular grains" in page


def test_menq_beside_with_the_grading_it_used(default_run):
    """Menq (2003) at the run's mean stress: in summary.json (reference strain, grading and
    where it came from), in modulus_reduction.csv at the model's amplitudes, and on the page.
    This run has no grains (affine model): the default grading, the shipped packings' sand
    (Cu 1.3, D50 0.3 mm). gamma_r [%] = 0.12 Cu^-0.6 (p/p_a)^(0.5 Cu^-0.15)."""
    import csv

    from grainmech.analysis import menq_curve

    s = json.loads((default_run / "summary.json").read_text())
    assert (s["menq_uniformity_coefficient"], s["menq_d50_m"]) == (1.3, 3e-4)
    assert "default" in s["menq_grading_source"] and "no grains" in s["menq_grading_source"]
    assert s["menq_gamma_r"] == pytest.approx(0.12e-2 * 1.3 ** -0.6 * (1e5 / 101325) ** (0.5 * 1.3 ** -0.15),
                                              rel=1e-12)
    rows = list(csv.DictReader(open(default_run / "modulus_reduction.csv")))
    amps = [float(r["shear_strain_amplitude [-]"]) for r in rows]
    ref = menq_curve(amps, 1e5, 1.3, 3e-4)
    assert [float(r["menq_G_over_Gmax [-]"]) for r in rows] == pytest.approx(ref.G_ratio, rel=1e-9)
    assert [float(r["menq_damping [-]"]) for r in rows] == pytest.approx(ref.damping, rel=1e-9)
    assert {r["menq_uniformity_coefficient [-]"] for r in rows} == {"1.3"}
    assert {r["menq_d50 [m]"] for r in rows} == {"0.0003"}
    assert s["menq_G_over_Gmax"] == pytest.approx(ref.G_ratio, rel=1e-12)
    page = (default_run / "index.html").read_text()
    assert "Menq (2003)" in page and "the shipped packings&#x27; sand" in page


def test_menq_grading_from_grains_from_config_or_default():
    """Cu and D50 of Menq's curve: measured by mass on the grains the run used (shipped
    'dense': D50 0.298 mm, Cu 1.28), a [reference] key wins, and without grains the default."""
    import tomllib

    from grainmech.errors import ConfigError
    from grainmech.jobs import prepare_run

    cfg = tomllib.loads(CFG)
    ref = prepare_run(cfg).reference
    assert (ref["uniformity_coefficient"], ref["d50"]) == (1.3, 3e-4) and "default" in ref["grading_source"]
    grains = tomllib.loads(CFG)
    grains["model"] = {"method": "packing", "packing": "dense"}
    del grains["microstructure"]
    ref = prepare_run(grains).reference
    assert ref["d50"] == pytest.approx(0.298e-3, rel=2e-3) and ref["uniformity_coefficient"] == pytest.approx(
        1.278, rel=1e-3)
    assert ref["grading_source"] == "measured by mass on the 2000 grains of shipped packing 'dense'"
    grains["reference"] = {"d50": "0.2 mm"}
    ref = prepare_run(grains).reference
    assert ref["d50"] == pytest.approx(2e-4) and ref["uniformity_coefficient"] == pytest.approx(1.278, rel=1e-3)
    assert ref["grading_source"].startswith("Cu: measured by mass") and "D50: [reference] d50" in ref["grading_source"]
    for key, bad in (("d50", 0.2), ("uniformity_coefficient", 0.9)):
        cfg["reference"] = {key: bad}
        with pytest.raises(ConfigError, match=f"reference.{key}"):
            prepare_run(cfg)


def test_every_file_is_linked_and_named_by_what_it_holds(default_run):
    s = json.loads((default_run / "summary.json").read_text())
    assert {f for f in s["files"] if f.startswith("cycles_gamma_")} == {
        "cycles_gamma_1.0e-06.csv", "cycles_gamma_1.0e-04.csv", "cycles_gamma_1.0e-03.csv"}
    page = (default_run / "index.html").read_text()
    links = set(re.findall(r"href='([^']+)'", page))
    on_disk = {p.name for p in default_run.iterdir() if not p.name.startswith(".")}
    # resume/: the saved amplitudes --resume takes up (records, not results to read)
    assert (default_run / "resume" / "config.json").is_file()
    assert on_disk - {"index.html", "resume"} <= links


def test_every_csv_header_has_a_unit(default_run):
    for f in default_run.glob("*.csv"):
        if f.name == "site_response_curves.csv":  # the site-response tools' own format
            continue
        head = f.read_text().splitlines()[0].split(",")
        assert all(c == "step" or re.search(r"\[[^]]+\]$", c) for c in head), (f.name, head)


def test_loops_are_normalised_per_amplitude():
    """Each amplitude's loop spans -1..1 in both axes, however small its stresses."""
    from grainmech import plots

    class R:  # a minimal driver result: two loops decades apart in stress
        def __init__(self, a, tau):
            t = np.linspace(0, 2 * np.pi, 50)
            self.strain = np.zeros((50, 6))
            self.stress = np.zeros((50, 6))
            self.strain[:, 4] = a * np.sin(t)
            self.stress[:, 4] = 7.0 + tau * np.sin(t - 0.1)

    fig, ax = plots.subplots()
    plots.loops([R(1e-6, 10.0), R(1e-3, 1e5)], [1e-6, 1e-3], ax=ax)
    for line in ax.get_lines():
        x, y = line.get_data()
        assert np.max(np.abs(x)) == pytest.approx(1.0, rel=1e-3)
        assert np.max(np.abs(y)) == pytest.approx(1.0)
    assert ax.get_ylabel() and "[-]" in ax.get_ylabel() and "[-]" in ax.get_xlabel()
    assert "kPa" in ax.get_legend().get_texts()[0].get_text()

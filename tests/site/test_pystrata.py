"""`grainmech site` with pystrata (extra `site`): checked against pystrata itself (issue 31 item 6).

Skipped when pystrata is not installed.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

pystrata = pytest.importorskip("pystrata")

from test_profile import PROFILE  # noqa: E402

DOCS = Path(__file__).resolve().parents[2] / "docs"
MOTION = '\n[bedrock]\nvs = "760 m/s"\nunit_weight = "22 kN/m^3"\ndamping = 0.01\n' \
         '[motion]\nfile = "m.AT2"\nformat = "peer"\n'


def _at2(path: Path, n: int = 1000, dt: float = 0.01, pga: float = 0.2) -> None:
    """A PEER AT2 file of a windowed 3 Hz sine with a 0.7 Hz component (accelerations in g)."""
    t = np.arange(n) * dt
    a = (np.sin(2 * np.pi * 3 * t) + 0.5 * np.sin(2 * np.pi * 0.7 * t)) * np.sin(np.pi * t / t[-1]) ** 2
    a *= pga / np.abs(a).max()
    body = "\n".join("".join(f"{v:15.7E}" for v in a[k:k + 5]) for k in range(0, n, 5))
    path.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nsynthetic test motion\n"
                    f"ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= {n:6d}, DT= {dt:.4f} SEC\n{body}\n")


@pytest.fixture(scope="module")
def response(tmp_path_factory):
    from grainmech.cli import main

    d = tmp_path_factory.mktemp("strata")
    _at2(d / "m.AT2")
    (d / "p.toml").write_text(PROFILE + MOTION)
    rc = main(["site", str(d / "p.toml"), "-o", str(d / "out"), "--quiet"])
    return rc, d


def _column(layers, motion_file: Path) -> np.ndarray:
    """Surface spectrum (outcrop, 5 %) of a pystrata column built here by hand."""
    profile = pystrata.site.Profile(layers + [
        pystrata.site.Layer(pystrata.site.SoilType("Rock", 22.0, None, 0.01), 0, 760.0)],
        wt_depth=2.0).auto_discretize()
    # pystrata's own AT2 reader takes the older header only (docs/site-response.md): read
    # the NGA-West2 file by hand here, independently of grainmech's reader
    lines = motion_file.read_text().splitlines()
    dt = float(re.search(r"DT=\s*([0-9.]+)", lines[3]).group(1))
    accels = np.array([float(v) for ln in lines[4:] for v in ln.split()])
    motion = pystrata.motion.TimeSeriesMotion(motion_file.name, lines[1], dt, accels)
    calc = pystrata.propagation.EquivalentLinearCalculator()
    calc(motion, profile, profile.location("outcrop", index=-1))
    out = pystrata.output.ResponseSpectrumOutput(np.logspace(-1, 2, num=301),
                                                 pystrata.output.OutputLocation("outcrop", index=0), 0.05)
    out(calc)
    return np.ravel(out.values)


def test_darendeli_run_equals_pystratas_own_column(response):
    """With Darendeli's curves the run equals a pystrata column of DarendeliSoilType built
    here from the profile by hand (p' 24 and 55.3 kPa, 18 and 20.0 kN/m^3; the Vs of the
    run) -- same spectrum to 1e-6."""
    rc, d = response
    assert rc == 0
    s = json.loads((d / "out/summary.json").read_text())
    sr = s["site_response"]
    vs = sr["vs_m_s"]
    assert vs[1] == pytest.approx(200.0)  # the anchored layer runs at its measured Vs
    gamma2 = 2039.4 * 9.80665 / 1e3                     # kN/m^3
    p2 = (18.0 * 4 + gamma2 * 3 - 9.81 * 5) * (1 + 2 * 0.5) / 3  # kPa at 7 m, water table at 2 m
    layers = [pystrata.site.Layer(pystrata.site.DarendeliSoilType(18.0, stress_mean=24.0), 4.0, vs[0]),
              pystrata.site.Layer(pystrata.site.DarendeliSoilType(gamma2, stress_mean=p2), 6.0, vs[1])]
    ref = _column(layers, d / "m.AT2")
    got = np.asarray(sr["runs"]["darendeli"]["spectrum_g"])
    assert np.max(np.abs(got / ref - 1)) < 1e-6


def test_menq_run_equals_pystratas_own_column(response):
    """With Menq's curves the run equals a pystrata column of MenqSoilType built here by hand
    (the layers' p', unit weights and the run's Vs; affine layers: the default grading
    Cu 1.3, D50 0.3 mm, N = 10) -- same spectrum to 1e-6."""
    rc, d = response
    assert rc == 0
    s = json.loads((d / "out/summary.json").read_text())
    sr = s["site_response"]
    layers = [pystrata.site.Layer(pystrata.site.MenqSoilType(lay["unit_weight_N_m3"] / 1e3, uniformity_coeff=1.3,
                                                             diam_mean=0.3, stress_mean=lay["p_eff_Pa"] / 1e3,
                                                             num_cycles=10),
                                  lay["thickness_m"], vs) for lay, vs in zip(s["layers"], sr["vs_m_s"])]
    ref = _column(layers, d / "m.AT2")
    got = np.asarray(sr["runs"]["menq"]["spectrum_g"])
    assert np.max(np.abs(got / ref - 1)) < 1e-6
    head = (d / "out/response_spectra.csv").read_text().splitlines()[0]
    assert head == "period [s],Sa grainmech [g],Sa darendeli [g],Sa menq [g]"


def test_grainmech_run_equals_the_recipe_on_its_curve_files(response):
    """The run with grainmech's curves equals pystrata fed the curve files the command wrote
    (read back with read_curves, as the docs' recipe does) -- same spectrum to 1e-6."""
    from grainmech.io.site_response import read_curves

    rc, d = response
    s = json.loads((d / "out/summary.json").read_text())
    layers = []
    for lay, vs in zip(s["layers"], s["site_response"]["vs_m_s"]):
        c = read_curves(d / "out/curves" / f"{lay['slug']}.csv")
        name = lay["name"]
        soil = pystrata.site.SoilType(name, lay["unit_weight_N_m3"] / 1e3,
                                      pystrata.site.NonlinearProperty(name, c.strain, c.g_ratio, "mod_reduc"),
                                      pystrata.site.NonlinearProperty(name, c.strain, c.damping, "damping"))
        assert vs == pytest.approx(math.sqrt(c.g_max / (lay["unit_weight_N_m3"] / 9.80665)), rel=1e-9)
        layers.append(pystrata.site.Layer(soil, lay["thickness_m"], vs))
    ref = _column(layers, d / "m.AT2")
    got = np.asarray(s["site_response"]["runs"]["grainmech"]["spectrum_g"])
    assert np.max(np.abs(got / ref - 1)) < 1e-6
    for f in ("response.png", "response_spectra.csv", "response_strain_profile.csv", "response_pga_profile.csv"):
        assert (d / "out" / f).stat().st_size > 0
    assert "Site response (pystrata" in (d / "out/index.html").read_text()


def test_grainmech_darendeli_matches_pystratas():
    """G/Gmax identical (Darendeli 2001 Eq. with Table 8.12 phi1-phi5, mean stress in atm);
    damping within 5e-5 up to 1e-3 strain (pystrata's b uses -0.00566 for phi12, grainmech
    -0.0057; beyond, pystrata also makes the curve non-decreasing; docs/site-response.md)."""
    from grainmech.analysis import darendeli

    g = np.logspace(-6, -1.5, 20)
    for kpa in (24.0, 100.0, 300.0):
        ours = darendeli(g, kpa * 1e3)
        theirs = pystrata.site.DarendeliSoilType(18.0, stress_mean=kpa)
        assert np.max(np.abs(ours.G_ratio - theirs.mod_reduc.values)) < 1e-12
        small = g <= 1e-3
        assert np.max(np.abs(ours.damping[small] - theirs.damping.values[small])) < 5e-5


def test_recipe_in_docs_runs(tmp_path, monkeypatch):
    """The pystrata recipe of docs/site-response.md runs as printed on a curve file and an AT2 motion."""
    from grainmech.analysis import darendeli
    from grainmech.io.site_response import write_curves

    text = (DOCS / "site-response.md").read_text()
    section = text[text.index("## Recipe: pystrata"):]
    code = re.findall(r"```python\n(.*?)```", section, flags=re.S)[0]
    g = np.logspace(-6, -2, 9)
    dar = darendeli(g, 100e3)
    monkeypatch.chdir(tmp_path)
    write_curves("curves.csv", g, dar.G_ratio, dar.damping, g_max=80e6, source="test")
    _at2(tmp_path / "motion.AT2")
    ns: dict = {}
    exec(compile(code, "site-response.md", "exec"), ns)
    spectrum, strain = np.ravel(ns["spectrum"]), np.ravel(ns["max_strain"])
    assert spectrum.shape == (301,) and np.all(spectrum > 0)
    assert 1e-6 < strain.max() < 1e-2
    assert ns["vs"] == pytest.approx(math.sqrt(80e6 / (18e3 / 9.80665)))

"""`grainmech site`: stresses of a profile, Vs anchoring, outputs, resume, bad input.

The affine model throughout (seconds); the packing and DEM models are exercised by
examples/site_sand_column.toml (docs/site-profile.md gives its measured time) and the
packing model at small amplitudes in test_site_curves.py.
"""

from __future__ import annotations

import csv
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from grainmech.errors import ConfigError
from grainmech.site import jaky_k0, load_profile, read_profile

pytest.importorskip("distributed")

EX = Path(__file__).resolve().parents[2] / "examples"

PROFILE = """
[site]
water_table = "2 m"
k0 = 0.5
[model]
method = "affine"
[microstructure]
coordination = 8.0
radius = "0.25 mm"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "44 GPa"
poisson = 0.08
friction = 0.5
[quadrature]
degree = 5
[test]
amplitudes = [1e-6, 1e-5, 1e-4, 1e-3]
n_cycles = 2
steps_per_cycle = 16
[[layers]]
name = "top"
thickness = "4 m"
unit_weight = "18 kN/m^3"
void_ratio = 0.7
[[layers]]
name = "deep"
thickness = "6 m"
density = "2039.4 kg/m^3"
void_ratio = 0.6
vs = "200 m/s"
"""


def _write(tmp_path: Path, text: str = PROFILE, name: str = "p.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_stresses_at_mid_depth_by_hand(tmp_path):
    """Terzaghi's effective stress with hydrostatic water, worked by hand:
    top: z = 2 m, sigma_v = 18 * 2 = 36 kPa, u = 0, p' = (36 + 2 * 18) / 3 = 24 kPa;
    deep: z = 7 m, sigma_v = 72 + 20 * 3 = 132 kPa (rho g = 2039.4 * 9.80665 = 20.0 kN/m^3),
    u = 9.81 * 5 = 49.05 kPa, sigma'_v = 82.95 kPa, p' = 82.95 * 2 / 3 = 55.3 kPa."""
    prof = load_profile(_write(tmp_path))
    top, deep = prof.layers
    assert (top.mid, top.sigma_v, top.u, top.p_eff) == pytest.approx((2.0, 36e3, 0.0, 24e3))
    assert deep.mid == 7.0
    assert deep.unit_weight == pytest.approx(2039.4 * 9.80665)
    assert deep.sigma_v == pytest.approx(72e3 + 3 * 2039.4 * 9.80665)
    assert deep.u == pytest.approx(49.05e3)
    assert deep.sigma_v_eff == pytest.approx(deep.sigma_v - 49.05e3)
    assert deep.p_eff == pytest.approx(deep.sigma_v_eff * 2 / 3)
    assert deep.sigma_h_eff == pytest.approx(0.5 * deep.sigma_v_eff)


def test_jaky_rule():
    """Jaky (1944): K0 = 1 - sin(phi'); phi' = 30 deg gives 0.5."""
    assert jaky_k0(math.radians(30)) == pytest.approx(0.5)


def test_example_profile_reads_and_its_stated_stresses_hold():
    """examples/site_sand_column.toml: 30 m, three layers, water table; the mean effective
    stresses its header states (61, 112, 176 kPa)."""
    prof = load_profile(EX / "site_sand_column.toml")
    assert prof.depth == 30.0 and len(prof.layers) == 3 and prof.water_table == 5.0
    assert prof.methods == ("packing", "dem") and prof.motion is not None and prof.bedrock is not None
    assert [round(la.p_eff / 1e3, 1) for la in prof.layers] == [60.5, 112.2, 176.1]
    assert [la.packing_choice["packing"] for la in prof.layers] == ["nevada-loose", "nevada-medium", "nevada-medium"]
    assert prof.layers[0].k0 == pytest.approx(1 - math.sin(math.radians(33)))


@pytest.mark.parametrize("edit, where", [
    (('thickness = "4 m"', 'thickness = "0 m"'), "layers[0].thickness"),
    (('water_table = "2 m"', 'water_table = "12 m"'), "site.water_table"),
    (('unit_weight = "18 kN/m^3"', 'unit_weight = "9 kN/m^3"'), "layers[0].unit_weight"),
    (('vs = "200 m/s"', 'vs = "9000 m/s"'), "layers[1].vs"),
    (('void_ratio = 0.6', 'void_ratio = -0.6'), "layers[1].void_ratio"),
    (('name = "deep"', 'name = "deep"\nbogus = 1'), "layers[1].bogus"),
])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, cli, edit, where):
    p = _write(tmp_path, PROFILE.replace(*edit))
    out = tmp_path / "out"
    res = cli("site", p, "-o", out, "--quiet")
    assert res.rc == 2
    lines = res.err.strip().splitlines()
    assert len(lines) == 1 and where in lines[0], res.err
    assert not out.exists()


def test_vs_outside_grain_modulus_range_names_the_needed_modulus(tmp_path, cli):
    res = cli("site", _write(tmp_path, PROFILE.replace('vs = "200 m/s"', 'vs = "9000 m/s"')), "-o", tmp_path / "o")
    assert "deep" in res.err and "GPa" in res.err and "outside 1-1000 GPa" in res.err


@pytest.mark.parametrize("motion, where", [
    ("0,0\n0.01,0.1\n0.02,0.0\n0.035,0.1\n0.045,0\n0.055,0\n0.065,0\n0.075,0\n0.085,0\n", "non-uniform time step"),
])
def test_bad_motion_exit_2(tmp_path, cli, motion, where):
    (tmp_path / "m.csv").write_text(motion)
    text = PROFILE + ('\n[bedrock]\nvs = "760 m/s"\nunit_weight = "22 kN/m^3"\n'
                      '[motion]\nfile = "m.csv"\nformat = "two-column"\nunits = "g"\n')
    res = cli("site", _write(tmp_path, text), "-o", tmp_path / "o", "--quiet")
    assert res.rc == 2 and "motion.file" in res.err and where in res.err and "line 4 (t = 0.035 s)" in res.err
    assert not (tmp_path / "o").exists()
    res = cli("site", _write(tmp_path, text.replace('units = "g"', 'units = "furlong/fortnight^2"')),
              "-o", tmp_path / "o", "--quiet")
    assert res.rc == 2 and "motion.units" in res.err and "unknown acceleration units" in res.err


def test_motion_readers(tmp_path):
    """A PEER AT2 file (NGA header) and a two-column table with units -> accelerations in g."""
    from grainmech.io.motion import read_motion

    at2 = ("PEER NGA STRONG MOTION DATABASE RECORD\nTest event, station, comp 000\n"
           "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS=   10, DT=   .0050 SEC\n"
           "  .1000E-01  .2000E-01 -.3000E-01  .4000E-01  .5000E-01\n"
           "  .6000E-01  .7000E-01  .8000E-01  .9000E-01 -.1000E+00\n")
    (tmp_path / "r.AT2").write_text(at2)
    m = read_motion(tmp_path / "r.AT2", "peer", None)
    assert m.time_step == 0.005 and len(m.accel_g) == 10 and m.pga_g == pytest.approx(0.1)
    with pytest.raises(ConfigError, match="motion.units.*AT2 header.*says g"):
        read_motion(tmp_path / "r.AT2", "peer", "cm/s^2")
    (tmp_path / "t.csv").write_text("time,acc\n" + "".join(f"{0.02 * k:.2f},{981 * (k % 3)}\n" for k in range(9)))
    m = read_motion(tmp_path / "t.csv", "two-column", "cm/s^2")
    assert m.time_step == pytest.approx(0.02) and m.pga_g == pytest.approx(1962 / 980.665)


@pytest.fixture(scope="module")
def site_run(tmp_path_factory):
    """One run of PROFILE (affine), shared by the output tests."""
    from grainmech.cli import main

    d = tmp_path_factory.mktemp("site")
    p = d / "p.toml"
    p.write_text(PROFILE)
    rc = main(["site", str(p), "-o", str(d / "out"), "--quiet"])
    return rc, d / "out", p


def test_outputs_and_anchoring(site_run):
    """Files of the run; the anchored layer's Gmax equals rho vs^2 (exact for the affine
    model: forces fixed by the stress, stiffness ~ G^(2/3)); the fitted curve at p' in
    site-response format, the points beside."""
    from grainmech.analysis.hyperbola import modified_hyperbola
    from grainmech.io.site_response import read_curves
    from grainmech.site.curve import SITE_STRAINS

    rc, out, _ = site_run
    assert rc == 0
    for f in ("layers.csv", "summary.json", "index.html", "profile.png", "curves/01-top.csv",
              "curves/02-deep.csv", "curves/02-deep-darendeli.csv", "layers/01-top.json"):
        assert (out / f).stat().st_size > 0, f
    s = json.loads((out / "summary.json").read_text())
    deep = s["layers"][1]
    a = deep["anchor"]
    rho = 2039.4
    assert a["G_target_Pa"] == pytest.approx(rho * 200.0 ** 2)
    assert a["scale"] == pytest.approx((a["G_target_Pa"] / a["G_model_Pa"]) ** 1.5)
    assert a["grain_modulus_anchored_Pa"] == pytest.approx(44e9 * a["scale"])
    assert abs(a["mismatch"]) < 1e-9 and deep["G_max_Pa"] == pytest.approx(a["G_target_Pa"], rel=1e-9)
    assert deep["vs_model_m_s"] == pytest.approx(200.0, rel=1e-9)
    c = read_curves(out / "curves/02-deep.csv")
    # 1e-3 leaves the envelope of sands (affine model): left out of the fit, as of grainmech run's curve file
    assert deep["amplitudes"] == [1e-6, 1e-5, 1e-4, 1e-3] and deep["beyond_envelope"] == [False] * 3 + [True]
    assert deep["models"] == ["affine"] * 4 and deep["site_curve"]["left_out"] == [1e-3]
    assert c.g_max == pytest.approx(deep["G_max_Pa"]) and c.strain == pytest.approx(SITE_STRAINS, rel=1e-9)
    assert "amplitudes left out of the fit: [0.001]" in c.comment and "modified hyperbola" in c.comment
    fit = deep["fit"]
    assert fit["strain_range"] == [1e-6, 1e-4] and fit["n_points"] == 3
    assert c.g_ratio == pytest.approx(modified_hyperbola(SITE_STRAINS, fit["gamma_r"], fit["curvature"]), rel=1e-8)
    assert c.g_ratio[0] > 0.99 and np.all(np.diff(c.g_ratio) < 0)
    pts = list(csv.DictReader((out / "curves/02-deep-points.csv").open()))
    assert [float(p["G/Gmax"]) for p in pts] == pytest.approx(deep["G_ratio"], rel=1e-9)
    assert pts[-1]["flags"] == "beyond_envelope"
    rows = list(csv.DictReader((out / "layers.csv").open()))
    assert [r["status"] for r in rows] == ["ok", "ok"]
    assert float(rows[1]["grain modulus scale"]) == pytest.approx(a["scale"])
    assert float(rows[1]["fit gamma_r"]) == pytest.approx(fit["gamma_r"])
    assert float(rows[1]["fit G/Gmax rms residual"]) == pytest.approx(fit["g_residual_rms"])
    # 44 GPa x 0.0987 = 4.3 GPa: outside 10-100 GPa, said in the row and on the page
    assert "packing does not match the site's stiffness" in rows[1]["anchoring warning"]
    assert "times stiffer than the site" in rows[1]["anchoring warning"] and rows[0]["anchoring warning"] == ""
    assert "grain modulus outside 10-100 GPa" in (out / "index.html").read_text()


def test_hertz_two_thirds_rule_independently():
    """The rule the anchoring rests on, checked on the library directly: the affine Gmax of
    a packing of Mindlin-Deresiewicz spheres at fixed stress scales as G_grain^(2/3)."""
    import grainmech as gm
    from grainmech.analysis import condensed_modulus

    pk = gm.Packing.from_grains(gm.isotropic(3), void_ratio=0.6, coordination=8.0, radius=2.5e-4)

    def gmax(g):
        pt = gm.MaterialPoint.isotropic(pk, gm.MindlinDeresiewicz(g, 0.08, 2.5e-4, friction=0.5), 80e3)
        return condensed_modulus(pt.tangent, 4, [False, False, True, False, False, False])

    assert gmax(44e9 * 0.3) / gmax(44e9) == pytest.approx(0.3 ** (2 / 3), rel=1e-10)


def test_darendeli_beside_at_the_layer_mean_stress_in_atm(site_run):
    """Darendeli's reference strain at p' in atm (Darendeli 2001, Table 8.12, PI = 0, OCR = 1):
    gamma_r = 0.0352 % (p'/101.325 kPa)^0.3483 -- a slip to kPa or Pa would be off by 5x or 55x."""
    _, out, _ = site_run
    s = json.loads((out / "summary.json").read_text())
    for lay in s["layers"]:
        d = lay["darendeli"]
        assert d["gamma_r"] == pytest.approx(0.0352e-2 * (lay["p_eff_Pa"] / 101325.0) ** 0.3483, rel=1e-12)
        g = np.asarray(d["strain"])
        assert d["G_ratio"] == pytest.approx(1.0 / (1.0 + (g / d["gamma_r"]) ** 0.919), rel=1e-12)


def test_menq_beside_at_the_layer_mean_stress_and_grading(site_run):
    """Menq's (2003) curves at p' in atm and the run's grading (affine layers: no grains, the
    default Cu 1.3, D50 0.3 mm): gamma_r = 0.12 % Cu^-0.6 (p'/101.325 kPa)^(0.5 Cu^-0.15),
    written as curves/<layer>-menq.csv in the site-response format."""
    from grainmech.analysis import menq_curve
    from grainmech.io.site_response import read_curves

    _, out, _ = site_run
    s = json.loads((out / "summary.json").read_text())
    for lay in s["layers"]:
        m = lay["menq"]
        i = m["inputs"]
        assert (i["uniformity_coefficient"], i["d50_m"], i["n_cycles"]) == (1.3, 3e-4, 10.0)
        assert "default" in i["grading_source"]
        s_atm = lay["p_eff_Pa"] / 101325.0
        assert m["gamma_r"] == pytest.approx(0.12e-2 * 1.3 ** -0.6 * s_atm ** (0.5 * 1.3 ** -0.15), rel=1e-12)
        ref = menq_curve(lay["amplitudes"], lay["p_eff_Pa"], 1.3, 3e-4)
        assert m["at_amplitudes_G_ratio"] == pytest.approx(ref.G_ratio, rel=1e-12)
        c = read_curves(out / "curves" / f"{lay['slug']}-menq.csv")
        assert c.g_ratio == pytest.approx(m["G_ratio"], rel=1e-9) and c.damping == pytest.approx(m["damping"], rel=1e-9)
        assert "Menq (2003)" in c.comment and "Cu = 1.3, D50 = 0.3 mm" in c.comment
    assert "curves/02-deep-menq.csv" in s["files"]


def test_resume_on_dask_skips_every_saved_amplitude_and_reruns_changed_ones(site_run, tmp_path):
    """On a Dask client (as `--workers N` / `--scheduler`), with resume: a rerun on the same
    folder skips every saved amplitude; amplitudes whose files are gone (killed before they
    finished) run again, with the same result; a changed layer runs all of its amplitudes."""
    import shutil

    from grainmech.parallel import open_client
    from grainmech.site import run_site

    _, out, prof = site_run
    d = tmp_path / "out"
    shutil.copytree(out, d)
    deep = json.loads((d / "layers/02-deep.json").read_text())
    saved = sorted((d / "layers/02-deep").glob("affine-*.json"))
    assert len(saved) == 4 and (d / "layers/02-deep").glob("anchor-*.json")
    for f in saved[2:]:
        f.unlink()  # as if killed after two amplitudes of this layer
    with open_client() as client:
        s = run_site(load_profile(prof), d, client=client)
        assert (s["amplitudes_reused"], s["amplitudes_run"], s["succeeded"]) == (6, 2, 2)
        again = json.loads((d / "layers/02-deep.json").read_text())
        assert again["G_ratio"] == pytest.approx(deep["G_ratio"], rel=1e-12)
        assert again["anchor"]["scale"] == deep["anchor"]["scale"]
        # a changed profile is refused with resume, naming the key; without resume it runs again
        p2 = tmp_path / "p2.toml"
        p2.write_text(PROFILE.replace('void_ratio = 0.7', 'void_ratio = 0.72'))
        with pytest.raises(ConfigError, match=r"^layers\[0\]\.void_ratio = 0\.72: differs from the config of "
                                              r"the profile being resumed .*there: 0\.7\)"):
            run_site(load_profile(p2), d, client=client)
        s = run_site(load_profile(p2), d, client=client, resume=False)
    assert (s["amplitudes_reused"], s["amplitudes_run"]) == (0, 8)


def test_stopped_layer_is_reported_others_complete_exit_1(tmp_path, cli, monkeypatch):
    """A layer whose model stops: its row says so, the other layer completes, exit 1.
    (The affine model cannot stop: the run of the shallow layer is made to stop after its
    first amplitude, as a packing model does when it leaves its range.)"""
    import dataclasses

    import grainmech.jobs as jobs

    real = jobs.execute_run

    def stopping(spec, progress=None):
        if spec.pressure >= 30e3:
            return real(spec, progress)
        out = real(spec)  # the site's hook hears only the stopped outcome
        return dataclasses.replace(out, success=False, message="amplitude 1e-05: step 3 failed (test)",
                                   amplitudes=out.amplitudes[:1], G=out.G[:1], damping=out.damping[:1])

    monkeypatch.setattr(jobs, "execute_run", stopping)  # the in-process Dask worker sees it
    res = cli("site", _write(tmp_path), "-o", tmp_path / "o", "--quiet")
    assert res.rc == 1
    rows = list(csv.DictReader((tmp_path / "o/layers.csv").open()))
    assert rows[0]["status"] == "stopped" and "step 3 failed" in rows[0]["message"]
    assert rows[0]["amplitudes done"] == "1" and rows[1]["status"] == "ok" and rows[1]["amplitudes done"] == "4"
    assert "1 stopped" in res.out


def test_read_profile_takes_packing_and_dem_and_rejects_other_pairs():
    cfg = tomllib.loads(PROFILE.replace('method = "affine"', 'method = ["affine", "packing"]'))
    with pytest.raises(ConfigError, match="model.method"):
        read_profile(cfg)
    cfg = tomllib.loads(PROFILE.replace('method = "affine"\n', '').replace("void_ratio", "relative_density")
                        .replace("0.7", "0.3").replace("0.6", "0.5"))
    prof = read_profile(cfg)  # the default: the packing model, the DEM model beyond
    assert prof.methods == ("packing", "dem") and prof.layers[0].run_config["model"]["packing"] == "nevada-loose"


def test_anchoring_that_fails_in_the_model_stops_that_layer_only(tmp_path, cli, monkeypatch):
    """A model that cannot give its Gmax at a layer's stress (e.g. the packing brought to
    it fails) is not bad input: that layer's row says so, the other completes, exit 1."""
    import grainmech.site.layer as layer_mod
    from grainmech.errors import GrainmechError

    def broken(spec):
        raise GrainmechError("bringing the packing to the stress failed: step 4 (test)")

    monkeypatch.setattr(layer_mod, "model_gmax", broken)
    res = cli("site", _write(tmp_path), "-o", tmp_path / "o", "--quiet")
    assert res.rc == 1
    rows = list(csv.DictReader((tmp_path / "o/layers.csv").open()))
    assert rows[1]["status"] == "stopped" and "anchoring to the measured Vs failed" in rows[1]["message"]
    assert "step 4 (test)" in rows[1]["message"] and rows[0]["status"] == "ok"


def test_without_pystrata_curves_are_written_and_the_install_is_named(tmp_path, cli, monkeypatch):
    """With [motion] but no pystrata: the curve files the recipe reads, and how to install it."""
    import grainmech.site.strata as strata

    monkeypatch.setattr(strata, "pystrata_missing",
                        lambda: f"pystrata is not installed (test); install it with: {strata.INSTALL_HINT}")
    (tmp_path / "m.csv").write_text("".join(f"{0.01 * k:.2f},{0.01 * (k % 4)}\n" for k in range(50)))
    text = PROFILE + ('\n[bedrock]\nvs = "760 m/s"\nunit_weight = "22 kN/m^3"\n'
                      '[motion]\nfile = "m.csv"\nunits = "g"\n')
    res = cli("site", _write(tmp_path, text), "-o", tmp_path / "o", "--quiet")
    assert res.rc == 0
    assert 'pip install "grainmech[site]"' in res.out
    assert (tmp_path / "o/curves/01-top.csv").exists() and not (tmp_path / "o/response.png").exists()
    s = json.loads((tmp_path / "o/summary.json").read_text())
    assert s["site_response"]["run"] is False and "grainmech[site]" in s["site_response"]["reason"]

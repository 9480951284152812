"""`grainmech site`: the packing and DEM models per layer, the fitted hyperbola, the packing by
density, resume per amplitude, bad input.

Synthetic amplitude entries for the hand-over and the curve (the rule of grainmech run's
recommended curve, the fit recovering a known hyperbola); one real run of the packing
model at small amplitudes on the shipped sand packing at its own 100 kPa (seconds).
"""

from __future__ import annotations

import ast
import csv
import json
from pathlib import Path

import numpy as np
import pytest

from grainmech.analysis.hyperbola import modified_hyperbola
from grainmech.site.amplitudes import Recorder, amplitude_key, entries_of, plan_runs
from grainmech.site.curve import SITE_STRAINS, layer_curve
from grainmech.site.density import DENSITY_FLAG, choose_packing, sand_packings

SRC = Path(__file__).resolve().parents[2] / "src" / "grainmech"
KIND = "cyclic-simple-shear"

SAND = """
[site]
k0 = 1.0
[model]
method = ["packing", "dem"]
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "29 GPa"
poisson = 0.15
friction = 0.5
rolling_friction = 0.25
[test]
amplitudes = [1e-6, 1e-5]
n_cycles = 2
steps_per_cycle = 8
[[layers]]
name = "sand"
thickness = "10 m"
unit_weight = "20 kN/m^3"
relative_density = 0.5
"""


def _ok(method, a, G, gmax, moved=False, beyond=False, d=0.05):
    return {"method": method, "amplitude": a, "status": "ok", "G_Pa": G, "damping": d, "G_max_Pa": gmax,
            "moved": moved, "beyond": beyond, "loop_ok": True}


def test_plan_before_and_after_the_hand_over():
    amps = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2]
    both = ("packing", "dem")
    assert plan_runs(both, amps, {}) == [(both, amps)]
    # killed after two packing amplitudes: both models again on the rest
    e = entries_of([_ok("packing", 1e-6, 1, 1), _ok("packing", 1e-5, 1, 1)])
    assert plan_runs(both, amps, e) == [(both, [1e-4, 1e-3, 1e-2])]
    # the packing model's grains rearranged at 1e-4 (or it stopped there): the DEM model alone from 1e-4
    e = entries_of([_ok("packing", 1e-6, 1, 1), _ok("packing", 1e-5, 1, 1), _ok("packing", 1e-4, 1, 1, moved=True),
                    _ok("dem", 1e-3, 1, 1)])
    assert plan_runs(both, amps, e) == [(("dem",), [1e-4, 1e-2])]
    e = entries_of([_ok("packing", 1e-6, 1, 1), {"method": "packing", "amplitude": 1e-5, "status": "stopped"}])
    assert plan_runs(both, amps, e) == [(("dem",), [1e-5, 1e-4, 1e-3, 1e-2])]
    e = entries_of([_ok("packing", a, 1, 1) for a in amps])
    assert plan_runs(both, amps, e) == []  # the packing model ran everything: no DEM model
    assert plan_runs(("affine",), amps, entries_of([_ok("affine", 1e-6, 1, 1)])) == [(("affine",), amps[1:])]


def test_amplitude_key_ignores_the_list_and_the_methods_but_not_the_inputs():
    cfg = {"model": {"method": ["packing", "dem"], "packing": "nevada-medium"}, "test": {"amplitudes": [1e-6]},
           "initial": {"pressure": 1e5}, "contacts": {"shear_modulus": 29e9}}
    k = amplitude_key(cfg, 2000.0, "dem", 1e-3)
    other = json.loads(json.dumps(cfg))
    other["model"]["method"] = "dem"
    other["test"]["amplitudes"] = [1e-3, 1e-2]
    assert amplitude_key(other, 2000.0, "dem", 1e-3) == k
    other["contacts"]["shear_modulus"] = 30e9
    assert amplitude_key(other, 2000.0, "dem", 1e-3) != k
    assert amplitude_key(cfg, 2000.0, "packing", 1e-3) != k and amplitude_key(cfg, 2000.0, "dem", 1e-2) != k


def test_recorder_saves_each_amplitude_the_stop_and_the_hand_over():
    from types import SimpleNamespace

    from grainmech.outcomes import CyclicOutcome

    saved: list[dict] = []
    rec = Recorder(None, lambda m, a: f"{m}{a:g}", saved.append, {})
    runs = [SimpleNamespace(success=True), SimpleNamespace(success=False, message="step 3 failed")]
    out = CyclicOutcome(kind=KIND, pressure=1e5, results=runs, success=False, message="stopped", seconds=1.0,
                        point=None, method="packing", details={"rearranging": [False]},
                        amplitudes=np.array([1e-6]), G=np.array([9e7]), damping=np.array([0.01]), G_max=1e8,
                        run_amplitudes=np.array([1e-6, 1e-5]), envelope=[{"beyond_any": False}] * 2,
                        loop_quality=[SimpleNamespace(ok=True)])
    rec.amplitudes_done(out)
    rec.amplitudes_done(out)  # said twice (after the amplitude, and as the final outcome): saved once
    rec.handed_over([1e-5, 1e-4], "it stopped")
    assert [(e["method"], e["amplitude"], e["status"]) for e in saved] == [
        ("packing", 1e-6, "ok"), ("packing", 1e-5, "stopped"), ("packing", 1e-4, "handed")]
    assert saved[0]["G_Pa"] == 9e7 and saved[0]["G_max_Pa"] == 1e8 and saved[0]["key"] == "packing1e-06"
    assert "step 3 failed" in saved[1]["message"]


def test_curve_on_the_packing_gmax_dem_beyond_and_the_fit_recovers_the_hyperbola():
    """Points made from G/Gmax = 1/(1 + (g/3e-4)^0.9) times the packing model's Gmax (100 MPa);
    the DEM model's own Gmax (90 MPa) must not rescale its points (grainmech run's rule),
    the DEM point replaces the packing point where its grains rearrange, and the fit gives
    back gamma_r = 3e-4 and a = 0.9."""
    gr, a, gpk = 3e-4, 0.9, 1e8
    amps = [1e-6, 1e-5, 1e-4, 3e-4, 1e-3, 1e-2]
    G = gpk * modified_hyperbola(amps, gr, a)
    ents = [_ok("packing", x, g, gpk) for x, g in zip(amps[:2], G[:2])]
    ents.append(_ok("packing", 1e-4, 0.5 * G[2], gpk, moved=True))  # off: its grains rearrange
    ents += [_ok("dem", x, g, 0.9e8) for x, g in zip(amps[2:], G[2:])]
    c = layer_curve(("packing", "dem"), ents, 1e5, KIND)
    assert c["models"] == ["packing"] * 2 + ["dem"] * 4 and c["G_max_Pa"] == gpk
    assert c["G_ratio"] == pytest.approx(modified_hyperbola(amps, gr, a), rel=1e-12)
    assert c["fit"]["gamma_r"] == pytest.approx(gr, rel=1e-6) and c["fit"]["curvature"] == pytest.approx(a, rel=1e-6)
    assert c["fit"]["g_residual_rms"] < 1e-9 and c["fit_warning"] is None
    assert c["site_curve"]["strain"] == pytest.approx(SITE_STRAINS.tolist())
    assert c["site_curve"]["model_range"] == [1e-6, 1e-2]
    # points only to G/Gmax 0.9: the reference strain is an extrapolation, said so
    c = layer_curve(("packing", "dem"), ents[:2], 1e5, KIND)
    assert "extrapolation" in c["fit_warning"]
    assert layer_curve(("packing", "dem"), ents[:1], 1e5, KIND)["fit"] is None


def test_packing_by_relative_density_is_the_nearest_shipped_sand_packing():
    cands = sand_packings()
    assert {p.name for p in cands} >= {"nevada-medium", "nevada-loose"}
    for p in cands:  # each packing is its own nearest; its D_r from its summary and the grains' limits
        assert choose_packing("relative_density", p.relative_density, "k", "l")["packing"] == p.name
        assert p.relative_density == pytest.approx((p.e_max - p.void_ratio) / (p.e_max - p.e_min))
    c = choose_packing("void_ratio", 0.749, "k", "l")
    assert c["packing"] == "nevada-medium" and c["asked_relative_density"] == pytest.approx(
        (c["e_max"] - 0.749) / (c["e_max"] - c["e_min"]))
    far = max((0.0, 1.0), key=lambda d: min(abs(p.relative_density - d) for p in cands))
    c = choose_packing("relative_density", far, "k", "l")
    assert c["flag"] == (abs(c["difference"]) > DENSITY_FLAG)
    assert c["packing"] == min(cands, key=lambda p: abs(p.relative_density - far)).name


@pytest.mark.parametrize("edit, where, text", [
    (("relative_density = 0.5", "relative_density = 1.2"), "layers[0].relative_density", "lies in 0-1"),
    (("relative_density = 0.5", "relative_density = -0.1"), "layers[0].relative_density", "lies in 0-1"),
    (("relative_density = 0.5", "void_ratio = 0.3"), "layers[0].void_ratio", "no shipped sand packing reaches"),
    (("relative_density = 0.5", "void_ratio = 1.3"), "layers[0].void_ratio", "no shipped sand packing reaches"),
    (("relative_density = 0.5", "relative_density = 0.5\nvoid_ratio = 0.7"), "layers[0].void_ratio", "not both"),
])
def test_density_no_packing_reaches_is_bad_input(tmp_path, cli, edit, where, text):
    p = tmp_path / "p.toml"
    p.write_text(SAND.replace(*edit))
    res = cli("site", p, "-o", tmp_path / "o", "--quiet")
    lines = res.err.strip().splitlines()
    assert res.rc == 2 and len(lines) == 1 and where in lines[0] and text in lines[0] and "'sand'" in lines[0], res.err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("motion, text", [
    ("".join(f"{0.01 * k:.2f},{'nan' if k == 5 else 0.01}\n" for k in range(20)), "line 6: the acceleration is not"),
    ("".join(f"{0.01 * k:.2f},0.01\n" for k in range(20)).replace("0.07,", "0.05,"), "line 8: time 0.05 s does not "
                                                                                     "increase"),
    ("".join(f"{'nan' if k == 3 else f'{0.01 * k:.2f}'},0.01\n" for k in range(20)), "line 4: time nan"),
])
def test_bad_motion_rows_exit_2_nothing_written(tmp_path, cli, motion, text):
    (tmp_path / "m.csv").write_text(motion)
    p = tmp_path / "p.toml"
    p.write_text(SAND + '\n[bedrock]\nvs = "760 m/s"\nunit_weight = "22 kN/m^3"\n'
                 '[motion]\nfile = "m.csv"\nformat = "two-column"\nunits = "g"\n')
    res = cli("site", p, "-o", tmp_path / "o", "--quiet")
    lines = res.err.strip().splitlines()
    assert res.rc == 2 and len(lines) == 1 and "motion.file" in lines[0] and text in lines[0], res.err
    assert not (tmp_path / "o").exists()


def test_io_does_not_import_site():
    for f in (SRC / "io").glob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("grainmech.site"), f
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("grainmech.site") for a in node.names), f


def test_sand_layer_by_density_packing_model_and_resume_per_amplitude(tmp_path, cli):
    """A real run: D_r 0.5 takes 'nevada-medium' (D_r 0.58, within 0.1) at its own 100 kPa (k0 = 1, 10 m of 20 kN/m^3:
    p' = 100 kPa at 5 m), the packing model at 1e-6 and 1e-5 (its range: no DEM model);
    the row names the packing and its D_r; a rerun with --resume runs nothing, one after
    an amplitude file is deleted runs that one only, with the same G/Gmax (without
    --resume every amplitude runs again: test_profile.py)."""
    p = tmp_path / "p.toml"
    p.write_text(SAND)
    out = tmp_path / "o"
    res = cli("site", p, "-o", out, "--quiet")
    assert res.rc == 0, res.err
    s = json.loads((out / "summary.json").read_text())
    lay = s["layers"][0]
    assert lay["p_eff_Pa"] == pytest.approx(1e5) and lay["models"] == ["packing", "packing"]
    assert lay["density_choice"]["packing"] == "nevada-medium" and "nevada-medium" in lay["grains"]
    row = next(csv.DictReader((out / "layers.csv").open()))
    assert row["packing"] == "nevada-medium" and row["D_r differs > 0.1"] == "False"
    assert float(row["D_r packing"]) == pytest.approx(lay["density_choice"]["packing_relative_density"])
    assert row["models (amplitudes)"] == "packing 1e-06-1e-05 (2)"
    assert 0.9 < lay["G_ratio"][1] < lay["G_ratio"][0] <= 1.0
    files = sorted((out / "layers/01-sand").glob("packing-*.json"))
    assert len(files) == 2
    res = cli("site", p, "-o", out, "--quiet", "--resume")
    s2 = json.loads((out / "summary.json").read_text())
    assert res.rc == 0 and (s2["amplitudes_reused"], s2["amplitudes_run"]) == (2, 0)
    files[1].unlink()
    cli("site", p, "-o", out, "--quiet", "--resume")
    s3 = json.loads((out / "summary.json").read_text())
    assert (s3["amplitudes_reused"], s3["amplitudes_run"]) == (1, 1)
    assert s3["layers"][0]["G_ratio"] == pytest.approx(lay["G_ratio"], rel=1e-9)

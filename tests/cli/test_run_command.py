"""`grainmech run`: default-style cyclic simple shear and a path config, files and errors."""

import json

import numpy as np
import pytest

from conftest import CYCLIC

PATH = """
[microstructure]
void_ratio = 0.65
coordination = 6.75
radius = "0.25 mm"
[contacts]
law = "linear"
kn = "1e6 N/m"
ks = "5e5 N/m"
[initial]
pressure = "100 kPa"
[test]
kind = "path"
[[test.segments]]
control = "SSESSS"        # drained triaxial compression: eps_zz prescribed, other stresses held
change = [0, 0, 1e-4, 0, 0, 0]
steps = 5
[[test.segments]]
control = "EESEEE"
direction = [0, 0, 0, 0, 1, 0]
amplitude = 1e-5
n_cycles = 1
steps_per_cycle = 8
"""


def test_cyclic_simple_shear_outputs(tmp_path, cli):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CYCLIC)
    out = tmp_path / "out"
    res = cli("run", str(cfg), "-o", str(out), "--quiet")
    assert res.rc == 0
    for f in ("summary.json", "modulus_reduction.csv", "loops.png", "modulus_reduction.png", "cycles_gamma_1.0e-06.csv",
              "index.html"):
        assert (out / f).stat().st_size > 0
    page = (out / "index.html").read_text()
    assert page.count("data:image/png;base64,") == 2 and "Gmax" in page and "mindlin-deresiewicz" in page
    s = json.loads((out / "summary.json").read_text())
    assert s["success"] and s["initial_pressure_Pa"] == pytest.approx(1e5)
    ratio = np.array(s["G_over_Gmax"])
    # smallest amplitude: secant modulus equals the small-strain modulus within 1 %
    assert ratio[0] == pytest.approx(1.0, abs=0.01)
    assert np.all(np.diff(ratio) < 0) and np.all(np.diff(s["damping"]) > 0)
    # Gmax is the condensed tangent of the isotropic Hertz-Mindlin packing (closed form, Walton)
    from grainmech.closed_form import walton
    _, G_w = walton(44e9, 0.08, 1e5, porosity=0.65 / 1.65, coordination=6.75)
    assert s["G_max_Pa"] == pytest.approx(G_w, rel=1e-6)
    # the affine loop at 1e-3 leaves the envelope of sands (tau_xz/sigma_zz 1.45, sigma_3 < 0):
    # the one warning on stderr
    assert s["beyond_envelope"] == [False, False, True]
    (w,) = res.err.splitlines()
    assert w.startswith("grainmech: warning: affine model, amplitude 1.0e-03: beyond the envelope of sands")
    # site-response export: the same curves, strain and damping as decimals, without 1e-3
    from grainmech.io.site_response import read_curves
    curves = read_curves(out / "site_response_curves.csv")
    assert np.allclose(curves.strain, s["amplitudes"][:2]) and np.allclose(curves.g_ratio, ratio[:2])
    assert np.allclose(curves.damping, s["damping"][:2])
    assert s["site_response_excluded"] == [1e-3] and "left out: 1.0e-03" in curves.comment


def test_constant_volume_cyclic_simple_shear(tmp_path, cli):
    """test.constant = "volume": every strain but gamma_xz held; Gmax is plain C_55 and the
    smallest amplitude's secant modulus equals it within 1 %."""
    cfg = tmp_path / "v.toml"
    cfg.write_text(CYCLIC.replace('kind = "cyclic-simple-shear"', 'kind = "cyclic-simple-shear"\nconstant = "volume"'))
    out = tmp_path / "v"
    assert cli("run", str(cfg), "-o", str(out), "--quiet").rc == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["G_over_Gmax"][0] == pytest.approx(1.0, abs=0.01)
    import csv
    rows = list(csv.DictReader((out / "cycles_gamma_1.0e-06.csv").open()))
    assert max(abs(float(r["strain_zz [-]"])) for r in rows) == 0.0


def test_path_config_and_linear_law(tmp_path, cli):
    cfg = tmp_path / "p.toml"
    cfg.write_text(PATH)
    out = tmp_path / "o"
    assert cli("run", str(cfg), "-o", str(out), "--quiet").rc == 0
    import csv
    rows = list(csv.DictReader((out / "path.csv").open()))
    assert len(rows) == 1 + 5 + 8
    # linear law, drained triaxial: sigma_zz - p0 = E eps_zz (isotropic packing)
    from grainmech import fabric, material
    from grainmech.assembly import stiffness
    pk = material.Packing.from_grains(fabric.isotropic(3), void_ratio=0.65, coordination=6.75, radius=2.5e-4)
    C = stiffness(pk.contact_set(1e6, 5e5))
    E = 1 / np.linalg.inv(C)[2, 2]
    assert float(rows[5]["stress_zz [Pa]"]) - 1e5 == pytest.approx(E * 1e-4, rel=1e-8)
    assert float(rows[5]["stress_xx [Pa]"]) == pytest.approx(1e5, rel=1e-9)
    # soil-mechanics columns on this drained triaxial path (sigma_xx = sigma_yy = p0):
    # q = sigma_zz - p0, p = p0 + q/3, eps_v = trace of the strain, axial strain = eps_zz
    r = rows[5]
    q = float(r["stress_zz [Pa]"]) - 1e5
    assert float(r["q [Pa]"]) == pytest.approx(q, rel=1e-9)
    assert float(r["p [Pa]"]) == pytest.approx(1e5 + q / 3, rel=1e-9)
    assert float(r["q_over_p [-]"]) == pytest.approx(q / (1e5 + q / 3), rel=1e-9)
    assert float(r["axial_strain [-]"]) == pytest.approx(1e-4, rel=1e-9)
    ev = sum(float(r[f"strain_{c} [-]"]) for c in ("xx", "yy", "zz"))
    assert float(r["volumetric_strain [-]"]) == pytest.approx(ev, rel=1e-9, abs=1e-15)
    # deviatoric strain 2/3 (eps_a - eps_r) on an axisymmetric path
    ed = 2 / 3 * (float(r["strain_zz [-]"]) - float(r["strain_xx [-]"]))
    assert float(r["deviatoric_strain [-]"]) == pytest.approx(abs(ed), rel=1e-9)
    assert json.loads((out / "summary.json").read_text())["axial_direction"] == "zz"


@pytest.mark.parametrize("edit, needle", [
    (("friction = 0.5", ""), "contacts.friction"),
    (("kind = \"cyclic-simple-shear\"", "kind = \"torsion\""), "test.kind"),
    (("amplitudes = [1e-6, 1e-4, 1e-3]", "amplitudes = [1e-6, -1]"), "test.amplitudes"),
    (("pressure = \"100 kPa\"", "pressure = \"15 parsecs\""), "initial.pressure"),
    (("degree = 11", "degree = 11\nextra = 1"), "quadrature.extra"),
])
def test_bad_run_configs(tmp_path, edit, needle, cli):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CYCLIC.replace(*edit))
    res = cli("run", str(cfg), "-o", str(tmp_path / "o"), "--quiet")
    assert res.rc == 2
    err = res.err
    assert needle in err and "Traceback" not in err

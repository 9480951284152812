"""`grainmech stiffness`: config -> stiffness, JSON output, errors (exit 2, one line)."""

import json

import numpy as np
import pytest

from grainmech import closed_form as cf


def _write(tmp_path, text, name="c.toml"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


LINEAR = """
[microstructure]
void_ratio = 0.57
coordination = 9
radius = "0.01 in"
convention = "seed"
[fabric]
a20 = 0.2
a22 = 0.25
b22 = 0.1
[contacts]
law = "linear"
kn = "3800 lbf/in"
ks = "1900 lbf/in"
"""


def test_json_matches_seed_closed_form(tmp_path, cli):
    """Monoclinic fabric of seed Fig. 4.2 with Eq. 4.21-4.33 (seed convention, order seed)."""
    res = cli("stiffness", _write(tmp_path, LINEAR), "--json", "--order", "seed")
    assert res.rc == 0
    out = json.loads(res.out)
    assert out["order"] == ["zz", "yy", "xx", "yz", "xz", "xy"]
    kn = 3800 * 4.4482216152605 / 0.0254
    r = 0.01 * 0.0254
    NV = 3 * 9 / (4 * np.pi * r**3 * 1.57)
    ref = cf.spheres_second_order(0.2, 0.25, 0.1, kn, kn / 2, r**2 * NV, order="seed")
    np.testing.assert_allclose(out["stiffness"], ref, rtol=1e-10, atol=1e-10 * ref.max())
    # a 2nd-order fabric always has principal axes: b22 rotates them about z, so the
    # seed's "orthotropic with non-coincident axes" is orthotropic, not monoclinic
    assert out["symmetry"]["name"] == "orthotropic"
    assert out["symmetry"]["seed_name"] == "orthotropic with non-coincident stress axes"
    assert set(out["engineering"]) >= {"E_xx", "E_yy", "E_zz", "G_yz", "G_xz", "G_xy", "nu_xy"}


def test_default_run_is_isotropic_and_matches_walton(cli):
    res = cli("stiffness", "--json")
    assert res.rc == 0
    out = json.loads(res.out)
    assert out["symmetry"]["name"] == "isotropic"
    assert out["order"] == ["xx", "yy", "zz", "yz", "xz", "xy"]
    e = 0.65
    K, G = cf.walton(44e9, 0.08, 1e5, porosity=e / (1 + e), coordination=23 - 25 * e)
    C = np.array(out["stiffness"])
    assert C[3, 3] == pytest.approx(G, rel=1e-9)
    assert (C[0, 0] + 2 * C[0, 1]) / 3 == pytest.approx(K, rel=1e-9)
    assert out["mean_stress"] == pytest.approx(1e5, rel=1e-12)


def test_text_output_and_orders(tmp_path, cli):
    path = _write(tmp_path, LINEAR)
    res = cli("stiffness", path)
    assert res.rc == 0
    text = res.out
    assert "orthotropic" in text and "E_zz" in text
    res = cli("stiffness", path, "--json", "--order", "mandel")
    assert res.rc == 0
    mandel = np.array(json.loads(res.out)["stiffness"])
    res = cli("stiffness", path, "--json")
    assert res.rc == 0
    voigt = np.array(json.loads(res.out)["stiffness"])
    assert mandel[3, 3] == pytest.approx(2 * voigt[3, 3])


@pytest.mark.parametrize("edit, needle", [
    (("void_ratio = 0.57", "void_ratio = -1"), "microstructure.void_ratio = -1"),
    (("radius = \"0.01 in\"", "radius = \"0.01 blorps\""), "microstructure.radius"),
    (("radius = \"0.01 in\"", "radius = \"3 kg\""), "microstructure.radius"),
    (("law = \"linear\"", "law = \"elastoplastic\""), "contacts.law"),
    (("b22 = 0.1", "b22 = 0.1\nc33 = 1"), "fabric.c33"),
    (("a20 = 0.2", "a20 = 3.0"), "negative"),
    (("coordination = 9", "coordination = \"nonsense\""), "microstructure.coordination"),
])
def test_bad_configs_give_one_line_and_exit_2(tmp_path, edit, needle, cli):
    path = _write(tmp_path, LINEAR.replace(*edit))
    res = cli("stiffness", path)
    assert res.rc == 2
    err = res.err
    assert err.startswith("grainmech: error:") and needle in err
    assert "Traceback" not in err and err.count("\n") == 1


def test_missing_file_and_bad_toml(tmp_path, cli):
    res = cli("stiffness", str(tmp_path / "nope.toml"))
    assert res.rc == 2
    assert "not found" in res.err
    res = cli("stiffness", _write(tmp_path, "[packing\nx=1"))
    assert res.rc == 2
    assert "invalid TOML" in res.err

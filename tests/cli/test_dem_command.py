"""`grainmech dem`: files in, measures and both stiffness tensors out; errors exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest

from grainmech.io.dem import write_liggghts, write_table
from grainmech.network import lattice_network, random_network

MATERIAL = """
[material]
shear_modulus = "29 GPa"
poisson = 0.15
[relaxed]
solver = "direct"
"""


def test_cli_dem_lattice_json_and_files(tmp_path, cli):
    R, dl, G, nu = 1.0, 2e-3, 29e9, 0.15
    net = lattice_network("sc", 3, R, dl, shear_modulus=G, poisson=nu)
    c, p = tmp_path / "c.dump", tmp_path / "p.dump"
    write_liggghts(net, c, p)
    mat = tmp_path / "m.toml"
    mat.write_text(MATERIAL)
    out = tmp_path / "out"
    res = cli("dem", str(c), "--particles", str(p), "--material", str(mat), "--json", "-o", str(out))
    assert res.rc == 0
    obj = json.loads(res.out)
    for key in ("stress", "fabric", "coordination", "stiffness_affine", "stiffness_relaxed", "order"):
        assert key in obj
    assert obj["order"] == ["xx", "yy", "zz", "yz", "xz", "xy"]
    # analytic sc lattice: C11 = kn/d, C44 = ks/(2d), Hertz-Mindlin from the overlap
    Es = G / (1 - nu)
    Gs = G / (2 * (2 - nu))
    a = np.sqrt(R / 2 * dl)
    kn, ks, d = 2 * Es * a, 8 * Gs * a, 2 * R - dl
    for key in ("stiffness_affine", "stiffness_relaxed"):
        C = np.array(obj[key])
        np.testing.assert_allclose(np.diag(C), [kn / d] * 3 + [ks / (2 * d)] * 3, rtol=1e-9)
    assert obj["coordination"]["z"] == pytest.approx(6.0)
    assert obj["coordination"]["z_mechanical"] == pytest.approx(6.0)
    assert obj["stress"]["mean"] > 0
    assert obj["engineering_affine"]["E_xx"] == pytest.approx(kn / d, rel=1e-9)
    for name in ("summary.json", "stiffness_affine.csv", "stiffness_relaxed.csv", "engineering.csv", "rose.png",
                 "normal_density.png"):
        assert (out / name).stat().st_size > 0
    # no temp files left (the manifest of the run is the only hidden file)
    assert [f.name for f in out.iterdir() if f.name.startswith(".")] == [".grainmech-manifest.json"]
    row = (out / "stiffness_affine.csv").read_text().splitlines()[1].split(",")
    assert row[0] == "xx" and float(row[1]) == pytest.approx(kn / d, rel=1e-9)


def test_cli_dem_table_text_output_no_material(tmp_path, cli):
    net = random_network(60, seed=1)
    c, p = tmp_path / "c.csv", tmp_path / "p.csv"
    write_table(net, c, p)
    res = cli("dem", str(c), "--particles", str(p))
    assert res.rc == 0
    text = res.out
    assert "coordination" in text and "no contact law" in text


def test_cli_dem_errors_exit_2(tmp_path, cli):
    c, p = tmp_path / "c.csv", tmp_path / "p.csv"
    p.write_text("id,x,y,z,radius\n1,0,0,0,1\n")
    c.write_text("id1,id2,fx,fy,fz\n1,2,1,0,0\n")
    res = cli("dem", str(c), "--particles", str(p))
    assert res.rc == 2
    err = res.err
    assert err.count("\n") == 1 and "c.csv:2: particle id 2 (column id2)" in err
    mat = tmp_path / "m.toml"
    mat.write_text("[material]\nshear_modulus = 1e9\npoison = 0.2\n")
    assert cli("dem", str(c), "--particles", str(p), "--material", str(mat)).rc == 2


def test_progress_bar_on_a_terminal_only():
    """`grainmech dem` draws a bar for a large contact file on a terminal: redrawn per percent,
    ending at 100 % with a newline; nothing for a small file or when stderr is not a terminal."""
    import io

    from grainmech.cli.dem import PROGRESS_MIN_BYTES, _progress_bar

    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    assert _progress_bar(io.StringIO()) is None
    out = Tty()
    show = _progress_bar(out)
    assert show is not None
    total = 4 * PROGRESS_MIN_BYTES
    for done in (0, total // 3, total // 3 + 1, total):
        show(done, total)
    text = out.getvalue()
    assert text.count("\r") == 3  # 0 %, 33 % (once), 100 %
    assert "[########------" in text and " 33 % of 268 MB" in text
    assert text.endswith(" 100 % of 268 MB\n")
    small = Tty()
    show = _progress_bar(small)
    show(10, PROGRESS_MIN_BYTES - 1)
    assert small.getvalue() == ""

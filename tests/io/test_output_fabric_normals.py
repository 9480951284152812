"""[fabric] normals = FILE: a measured fabric from a list of contact normals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grainmech.errors import ConfigError
from grainmech.jobs import compute_stiffness

EX = Path(__file__).resolve().parents[2] / "examples"
NORMALS = EX / "fabric_normals_sand.csv"
BASE = {"microstructure": {"void_ratio": 0.65, "coordination": 7.0, "radius": "0.25 mm"},
        "contacts": {"law": "hertz-mindlin", "shear_modulus": "44 GPa", "poisson": 0.08},
        "stress": {"pressure": "100 kPa"}}


def _normals() -> np.ndarray:
    return np.loadtxt(NORMALS, delimiter=",", comments="#", skiprows=4)


def test_order_two_fit_is_the_measured_fabric_tensor():
    """An order-2 moment fit has exactly the sample fabric tensor N = <n n> (Kanatani 1984),
    so the stiffness equals that of [fabric] tensor = <n n> computed here with NumPy."""
    n = _normals()
    N = np.einsum("pi,pj->ij", n, n) / len(n)
    fit = compute_stiffness({**BASE, "fabric": {"normals": str(NORMALS), "fit_order": 2}})
    ref = compute_stiffness({**BASE, "fabric": {"tensor": N.tolist()}})
    np.testing.assert_allclose(fit.result.C, ref.result.C, rtol=1e-10, atol=1e-6 * np.abs(ref.result.C).max())
    # the file was drawn from seed Eq. 4.15 with a20 = 0.4: recovered within 3 standard errors
    f = fit.fabric_fit
    a20, se = f["seed_coefficients"]["(2, 0)"][0], f["seed_standard_errors"]["(2, 0)"][0]
    assert abs(a20 - 0.4) < 3 * se and se < 0.1
    assert f["n_normals"] == 1500 and f["p_value"] is not None and 0 < f["p_value"] <= 1


def test_cli_reads_the_file_relative_to_the_config_and_reports_the_fit(tmp_path, monkeypatch, cli):
    monkeypatch.chdir(tmp_path)  # not the examples folder
    res = cli("stiffness", str(EX / "stiffness_measured_fabric.toml"))
    assert res.rc == 0
    out = res.out
    assert "fabric fitted to 1500 normals" in out and "chi-square" in out
    res = cli("stiffness", str(EX / "stiffness_measured_fabric.toml"), "--json")
    assert res.rc == 0
    obj = json.loads(res.out)
    assert obj["fabric_fit"]["order"] == 2 and obj["fabric_fit"]["n_normals"] == 1500


def test_order_four_and_two_dimensional_normals(tmp_path):
    rng = np.random.default_rng(3)
    t = rng.uniform(0, np.pi, 4000)
    (tmp_path / "n2.txt").write_text("\n".join(f"{np.cos(a):.8f} {np.sin(a):.8f}" for a in t))
    out = compute_stiffness({**BASE, "fabric": {"normals": str(tmp_path / "n2.txt"), "fit_order": 4}})
    assert out.dim == 2 and out.fabric_fit["dim"] == 2
    # uniform angles: every fitted coefficient within 4 standard errors of zero
    for k, (a, b) in out.fabric_fit["seed_coefficients"].items():
        sa, sb = out.fabric_fit["seed_standard_errors"][k]
        assert abs(a) < 4 * sa and abs(b) < 4 * max(sb, 1e-12)


@pytest.mark.parametrize("text, fab, match", [
    ("0 0 1\n0 0 0\n", {}, r"fabric\.normals = .*normal on line 2 is zero"),
    ("0 0 1\n0 1 x\n", {}, r"line 2: not a row of numbers"),
    ("0 0 1\n0 1\n", {}, "same number of columns"),
    ("1 0 0 0\n", {}, "needs 2 or 3 columns"),
    ("0 0 1\n0 1 0\n", {"fit_order": 3}, r"fabric\.fit_order = 3: must be even"),
    ("0 0 1\n0 1 0\n", {"a20": 0.3}, r"fabric\.a20 = 0\.3: give either normals"),
    ("0 0 1\n0 1 0\n", {"dim": 2}, r"fabric\.dim = 2: but the normals"),
])
def test_bad_normals_files_name_the_key(tmp_path, text, fab, match):
    (tmp_path / "n.txt").write_text(text)
    with pytest.raises(ConfigError, match=match):
        compute_stiffness({**BASE, "fabric": {"normals": str(tmp_path / "n.txt"), **fab}})


def test_missing_file_names_the_key(tmp_path):
    with pytest.raises(ConfigError, match=r"fabric\.normals = .*file not found"):
        compute_stiffness({**BASE, "fabric": {"normals": str(tmp_path / "none.csv")}})

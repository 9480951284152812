"""Every config shipped in examples/ runs (README: 'Examples of every config kind are in examples/')."""

from pathlib import Path

import pytest

from grainmech.cli import main

EX = Path(__file__).resolve().parent.parent / "examples"


@pytest.mark.parametrize("path", sorted(EX.glob("stiffness_*.toml")), ids=lambda p: p.name)
def test_stiffness_examples(path, capsys):
    assert main(["stiffness", str(path), "--json"]) == 0
    assert '"stiffness"' in capsys.readouterr().out


@pytest.mark.parametrize("path", sorted(EX.glob("contact_*.toml")), ids=lambda p: p.name)
def test_contact_examples(path, tmp_path):
    assert main(["contact", str(path), "-o", str(tmp_path)]) == 0
    assert (tmp_path / "contact.csv").stat().st_size > 0


@pytest.mark.parametrize("path", sorted(EX.glob("run_*.toml")), ids=lambda p: p.name)
def test_run_examples(path, tmp_path):
    assert main(["run", str(path), "-o", str(tmp_path), "--quiet"]) == 0
    assert (tmp_path / "index.html").stat().st_size > 0


def test_dem_example(tmp_path):
    assert main(["dem", str(EX / "dem_liggghts_contacts.dump"), "--particles", str(EX / "dem_liggghts_particles.dump"),
                 "--material", str(EX / "dem_material.toml"), "-o", str(tmp_path)]) == 0
    assert (tmp_path / "summary.json").stat().st_size > 0


@pytest.mark.parametrize("path", sorted(EX.glob("sweep_*.toml")), ids=lambda p: p.name)
def test_sweep_examples(path, tmp_path, capsys):
    pytest.importorskip("distributed")
    assert main(["sweep", str(path), "-o", str(tmp_path), "--quiet", "--no-plots"]) == 0
    assert " 0 failed" in capsys.readouterr().out
    lines = (tmp_path / "sweep.csv").read_text().splitlines()
    assert len(lines) > 2 and "status" in lines[0]


@pytest.mark.parametrize("path", sorted(EX.glob("calibrate_*.toml")), ids=lambda p: p.name)
def test_calibrate_examples(path, tmp_path):
    """Each examples/calibrate_X.toml fits its data in calibrate_X.csv and converges."""
    assert main(["calibrate", str(path), str(path.with_suffix(".csv")), "-o", str(tmp_path), "--quiet"]) == 0
    assert (tmp_path / "fit.json").stat().st_size > 0

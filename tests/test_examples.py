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


def test_readme_python_example_runs():
    """The notebook-style example of README.md (section "Python") runs as printed and
    gives an isotropic stiffness and a falling G/Gmax curve."""
    import re

    import numpy as np

    text = (EX.parent / "README.md").read_text()
    section = text[text.index("## Python"):]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "README.md has no python block under '## Python'"
    code = blocks[0]
    assert len([ln for ln in code.splitlines() if ln.strip()]) <= 12
    matplotlib = pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    ns: dict = {}
    try:
        exec(compile(code, "README.md", "exec"), ns)
        C, mr, ax = ns["C"], ns["mr"], ns["ax"]
        assert isinstance(ax, matplotlib.axes.Axes)
    finally:
        plt.close("all")
    # isotropic: C11 = C12 + 2 C44 (Voigt), and G/Gmax falls from ~1 with amplitude
    assert C[0, 0] == pytest.approx(C[0, 1] + 2 * C[3, 3], rel=1e-10)
    assert mr.G_ratio[0] > 0.99 and np.all(np.diff(mr.G_ratio) < 0) and mr.G_ratio[-1] < 0.6
    assert np.all(np.diff(mr.damping) > 0)

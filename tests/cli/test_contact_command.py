"""``grainmech contact CONFIG.toml -o OUTDIR``: files, columns, physics, and user errors."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from grainmech.contact import MindlinDeresiewicz, md_dissipation_per_cycle, md_loading_displacement

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

REQUIRED = ("step", "normal_displacement", "tangential_displacement", "normal_force",
            "tangential_force", "dissipated_energy")


def _read(path: Path) -> dict[str, np.ndarray]:
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


BASE = """
[contact]
law = "mindlin-deresiewicz"
shear_modulus = "29 GPa"
poisson = 0.22
radius = "1 mm"
friction = 0.5

[initial]
normal_force = "10 N"

[[path]]
kind = "cycles"
count = 1
steps = 12
tangential_force_amplitude = "3 N"
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "c.toml"
    p.write_text(text)
    return p


def test_example_runs_and_writes_csv_and_png(tmp_path, cli):
    out = tmp_path / "out"
    assert cli("contact", str(EXAMPLES / "contact_md_growing_cycles.toml"), "-o", str(out)).rc == 0
    data = _read(out / "contact.csv")
    for col in REQUIRED:
        assert col in data
    assert data["step"][0] == 0 and np.all(np.diff(data["step"]) == 1)
    png = (out / "contact.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # no temp files left (the manifest of the run is the only hidden file)
    assert [f.name for f in out.iterdir() if f.name.startswith(".")] == [".grainmech-manifest.json"]
    # dissipation never decreases; |T| <= mu N
    assert np.all(np.diff(data["dissipated_energy"]) >= 0)
    assert np.all(np.abs(data["tangential_force"]) <= 0.5 * data["normal_force"] * (1 + 1e-9))
    # the last full cycle at 4 N dissipates the Mindlin–Deresiewicz energy
    p = MindlinDeresiewicz(29e9, 0.22, 1e-3, friction=0.5)
    seg = data["segment"] == 2
    idx = np.nonzero(seg)[0]
    # segment 2: ramp to +4 (20 steps) then two cycles of 80 steps; the second cycle is the last 80
    W = data["dissipated_energy"][idx[-1]] - data["dissipated_energy"][idx[-81]]
    assert W == pytest.approx(float(md_dissipation_per_cycle(4.0, 10.0, p)), rel=1e-8)


def test_first_loading_matches_mindlin_curve(tmp_path, cli):
    out = tmp_path / "o"
    assert cli("contact", str(_write(tmp_path, BASE)), "-o", str(out), "--no-plot").rc == 0
    assert not (out / "contact.png").exists()
    data = _read(out / "contact.csv")
    p = MindlinDeresiewicz(29e9, 0.22, 1e-3, friction=0.5)
    first = data["segment"] == 0
    T = data["tangential_force"][first]
    d = data["tangential_displacement"][first]
    np.testing.assert_allclose(d[:6], md_loading_displacement(T[:6], 10.0, p), rtol=1e-9)
    assert T[5] == pytest.approx(3.0, rel=1e-9)                  # steps/2 = 6 steps to +A


def test_units_and_plain_si_numbers_agree(tmp_path, cli):
    a, b = tmp_path / "a", tmp_path / "b"
    assert cli("contact", _write(tmp_path, BASE), "-o", a, "--no-plot").rc == 0
    si = BASE.replace('"29 GPa"', "29e9").replace('"1 mm"', "0.001").replace('"10 N"', "10.0") \
             .replace('"3 N"', "3.0")
    assert cli("contact", _write(tmp_path, si), "-o", b, "--no-plot").rc == 0
    da, db = _read(a / "contact.csv"), _read(b / "contact.csv")
    for k in REQUIRED:
        np.testing.assert_allclose(da[k], db[k], rtol=1e-12)


@pytest.mark.parametrize("edit, key", [
    (("friction = 0.5", "friction = 0.5\nfrictoin = 0.4"), "contact.frictoin"),
    (("poisson = 0.22", "poisson = 0.6"), "poisson"),
    (("friction = 0.5", "friction = -0.5"), "friction"),
    (('radius = "1 mm"', 'radius = "1 N"'), "contact.radius"),
    (('radius = "1 mm"', 'radius1 = "1 mm"'), "contact.radius1 = '1 mm': renamed: write 'radius'"),
    (("count = 1", "count = 1\nstepz = 3"), "path[0].stepz"),
    (('tangential_force_amplitude = "3 N"', 'tangential_force_amplitude = "6 N"'), "friction limit"),
    (('law = "mindlin-deresiewicz"', 'law = "mindlin"'), "contact.law"),
])
def test_user_errors_exit_2_with_one_line_naming_the_key(tmp_path, edit, key, cli):
    cfg = BASE.replace(*edit)
    res = cli("contact", _write(tmp_path, cfg), "-o", tmp_path / "o")
    assert res.rc == 2
    err = res.err
    assert key in err and err.count("\n") == 1


def test_missing_config_file_is_a_user_error(tmp_path, cli):
    assert cli("contact", str(tmp_path / "nope.toml"), "-o", str(tmp_path / "o")).rc == 2


def test_cylinder_example_runs(tmp_path, cli):
    out = tmp_path / "rods"
    assert cli("contact", str(EXAMPLES / "contact_cylinder_rods.toml"), "-o", str(out), "--no-plot").rc == 0
    data = _read(out / "contact.csv")
    assert np.all(np.isfinite(data["tangential_force"]))
    assert data["dissipated_energy"][-1] > 0


@pytest.mark.parametrize("amplitude", ['tangential_force_amplitude = "3 N"',
                                       'tangential_displacement_amplitude = "0.3 um"'])
def test_fifty_cycles_do_not_fill_the_reversal_memory(tmp_path, amplitude, cli):
    """50 symmetric cycles (force- or displacement-controlled, constant N) with
    ``max_reversals = 4``: Masing's rule erases every closed loop (Mindlin & Deresiewicz
    1953, seed Eq. 3.13-3.15), so the run completes and the last loop's dissipation equals
    the closed form of Mindlin et al. (1952) (``md_dissipation_per_cycle``) to 1 %."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(BASE.replace("friction = 0.5", "friction = 0.5\nmax_reversals = 4")
                   .replace("count = 1", "count = 50").replace("steps = 12", "steps = 16")
                   .replace('tangential_force_amplitude = "3 N"\n', "") + amplitude + "\n")
    assert cli("contact", str(cfg), "-o", str(tmp_path / "out"), "--no-plot").rc == 0
    c = _read(tmp_path / "out" / "contact.csv")
    assert len(c["step"]) == 1 + 8 + 50 * 2 * 16  # ramp to +A, then 50 cycles
    law = MindlinDeresiewicz(29e9, 0.22, 1e-3, friction=0.5)
    t = c["tangential_force"][-33:]
    t_star = 0.5 * (t.max() - t.min())
    d_loop = c["dissipated_energy"][-1] - c["dissipated_energy"][-33]
    assert d_loop == pytest.approx(md_dissipation_per_cycle(t_star, 10.0, law), rel=1e-2)

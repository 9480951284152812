"""Ctrl-C, closed pipes and --debug placement (the CLI's edge behaviour)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from grainmech import cli


def test_keyboard_interrupt_prints_one_line_and_exits_130(monkeypatch, capsys):
    import grainmech.cli.stiffness as st

    def boom(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(st, "run", boom)
    assert cli.main(["stiffness"]) == 130
    assert capsys.readouterr().err == "grainmech: interrupted\n"


def test_closed_pipe_ends_quietly():
    code = ("import sys; from grainmech.cli import main; sys.exit(main(['stiffness', '--json']))")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.read(5)
    p.stdout.close()  # the reader goes away, like `| head -c 5`
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0
    assert "Traceback" not in err and "BrokenPipe" not in err


@pytest.mark.parametrize("argv", [["--debug", "stiffness", "/no/such.toml"], ["stiffness", "/no/such.toml", "--debug"]])
def test_debug_before_or_after_the_subcommand(argv):
    from grainmech.errors import GrainmechError

    with pytest.raises(GrainmechError, match="config file not found"):
        cli.main(argv)


def test_without_debug_one_line(capsys):
    assert cli.main(["stiffness", "/no/such.toml"]) == 2
    assert capsys.readouterr().err.strip() == "grainmech: error: config file not found: /no/such.toml"


# ------------------------------------------------------------------ SIGTERM and partial runs
# A real `grainmech run` in a child process whose second (or first) amplitude is made to
# wait (the affine runs of TINY take a fraction of a second), so that the signal arrives
# at a known point: what a batch scheduler's stop or a Ctrl-C does mid-run.

TINY = """
[microstructure]
void_ratio = 0.65
coordination = 8.0
radius = "0.25 mm"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "44 GPa"
poisson = 0.08
friction = 0.5
[initial]
pressure = "100 kPa"
[quadrature]
degree = 5
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-5, 1e-4, 1e-3]
n_cycles = 2
steps_per_cycle = 16
"""

_SLOW_AT = """
import sys, time
import grainmech.driver as drv
real, calls = drv.run, []
def slow(*a, **k):
    calls.append(1)
    if len(calls) == int(sys.argv[1]):
        print("waiting in amplitude", len(calls), file=sys.stderr, flush=True)
        time.sleep(120)
    return real(*a, **k)
drv.run = slow
from grainmech.cli import main
sys.exit(main(sys.argv[2:]))
"""


def _default_sigint() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _run_until_waiting(tmp_path, amplitude: int, *extra: str):
    import os
    from pathlib import Path

    (tmp_path / "c.toml").write_text(TINY)
    (tmp_path / "slow.py").write_text(_SLOW_AT)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    p = subprocess.Popen([sys.executable, "slow.py", str(amplitude), "run", "c.toml", "-o", "out", "--quiet",
                          *extra], cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=_default_sigint)
    line = p.stderr.readline()
    assert line.startswith("waiting in amplitude"), line + p.stderr.read()
    return p


def _leftovers(out):
    return sorted(p.name for p in out.glob(".grainmech-staging-*")) + sorted(p.name for p in out.glob(".grainmech.lock"))


@pytest.mark.parametrize("sig, status, word", [("SIGTERM", 143, "terminated"), ("SIGINT", 130, "interrupted")])
def test_signal_after_an_amplitude_writes_it_as_an_interrupted_run(tmp_path, sig, status, word):
    import json
    import signal
    import time

    p = _run_until_waiting(tmp_path, 2)  # amplitude 1 finished, amplitude 2 running
    time.sleep(2.0)  # the message gives the run's real elapsed time, not the finished amplitude's
    p.send_signal(getattr(signal, sig))
    out_text, err = p.communicate(timeout=60)
    assert p.returncode == status
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0] == f'grainmech: {word}; the 1 finished amplitude(s) are in out (summary.json: "interrupted": true)'
    out = tmp_path / "out"
    assert _leftovers(out) == []
    s = json.loads((out / "summary.json").read_text())
    assert s["success"] is False and s["interrupted"] is True
    assert s["amplitudes"] == [1e-5] and len(s["G_over_Gmax"]) == 1
    assert s["message"].startswith(("terminated (SIGTERM)" if sig == "SIGTERM" else "interrupted (Ctrl-C)") + " after ")
    elapsed = float(s["message"].split(" after ")[1].split(" s;")[0])
    assert s["seconds"] == pytest.approx(elapsed, abs=0.2) and elapsed >= 2.0
    assert "affine model: 1 amplitude(s) finished" in s["message"]
    assert (out / "cycles_gamma_1.0e-05.csv").exists() and not list(out.glob("cycles_gamma_1.0e-04*"))
    assert "STOPPED" in (out / "index.html").read_text()
    manifest = json.loads((out / ".grainmech-manifest.json").read_text())
    assert manifest["success"] is False and "summary.json" in manifest["files"]
    assert out_text == ""  # no result table for a run that did not finish


def test_sigterm_before_any_amplitude_leaves_no_folder(tmp_path):
    import signal

    p = _run_until_waiting(tmp_path, 1)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143 and err == "grainmech: terminated\n"
    assert not (tmp_path / "out").exists()


def test_sigterm_before_any_amplitude_keeps_the_previous_run(tmp_path):
    import signal

    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    p = _run_until_waiting(tmp_path, 1)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143 and err == "grainmech: terminated\n"
    assert sorted(x.name for x in out.iterdir()) == ["summary.json"]
    assert (out / "summary.json").read_text() == "{}"


def test_terminated_is_handled_like_ctrl_c_in_process(monkeypatch, capsys):
    import grainmech.cli.stiffness as st
    from grainmech.errors import Terminated

    def boom(args):
        raise Terminated

    monkeypatch.setattr(st, "run", boom)
    assert cli.main(["stiffness"]) == 143
    assert capsys.readouterr().err == "grainmech: terminated\n"


def test_sigterm_handler_is_restored_after_the_command():
    import signal

    before = signal.getsignal(signal.SIGTERM)
    assert cli.main(["stiffness", "/no/such.toml"]) == 2
    assert signal.getsignal(signal.SIGTERM) is before


def test_interrupted_message_keeps_every_models_stop_reasons_and_the_hand_over():
    """A packing model that stopped (and handed amplitudes to the DEM model), a DEM model
    interrupted after one amplitude: the message keeps both, with the real elapsed time."""
    from types import SimpleNamespace

    from grainmech.cli.run import _interrupted_message, _Progress
    from grainmech.errors import Terminated

    say = _Progress(True, "")
    say.t0 -= 1200.0  # the run began 1200 s ago
    say.amplitudes_done(SimpleNamespace(method="packing", G=[1.0, 2.0], success=False,
                                        message="stopped at amplitude 0.0001: no equilibrium"))
    say.handed_over([1e-4], "it stopped (no equilibrium)")
    say.amplitudes_done(SimpleNamespace(method="dem", G=[1.0], success=False,
                                        message="interrupted after 1 of 3 amplitudes"))
    msg = _interrupted_message(Terminated("SIGTERM"), say)
    assert msg.startswith("terminated (SIGTERM) after 120")  # 1200.x s
    assert float(msg.split(" after ")[1].split(" s;")[0]) == pytest.approx(1200.0, abs=1.0)
    assert "packing model: 2 amplitude(s) finished, stopped: stopped at amplitude 0.0001: no equilibrium" in msg
    assert "dem model: 1 amplitude(s) finished;" in msg
    assert "handed to the DEM model: [0.0001] (it stopped (no equilibrium))" in msg

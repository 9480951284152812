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

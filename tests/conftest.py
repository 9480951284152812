"""Shared fixtures: every test runs in its own empty working directory (commands that
write to their default output folder, ``./grainmech-out/<command>``, write there), and
``cli`` runs the command line in-process."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import pytest


@pytest.fixture(autouse=True)
def _in_tmp_dir(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)


@dataclass
class CliRun:
    """Exit status and captured output of one ``grainmech`` invocation."""

    rc: int
    out: str
    err: str


@pytest.fixture
def cli(capsys) -> Callable[..., CliRun]:
    """``cli("run", "-o", "x")`` -> :class:`CliRun` (``grainmech.cli.main`` in-process)."""
    from grainmech.cli import main

    def run(*args: str) -> CliRun:
        capsys.readouterr()
        rc = main([str(a) for a in args])
        cap = capsys.readouterr()
        return CliRun(rc, cap.out, cap.err)

    return run

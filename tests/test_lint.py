"""The package passes its linters: ruff (pycodestyle, pyflakes, isort, bugbear, pyupgrade,
pydocstyle with the numpy convention) and mypy, both configured in pyproject.toml.

Each is run on the whole of ``src`` as CI does; a finding fails the test with the tool's
own report. Skipped (with the reason) only where the tool is not installed; the ``test``
extra installs both.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(module: str, *args: str) -> subprocess.CompletedProcess:
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed (pip install -e '.[test]')")
    return subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)


def test_ruff_reports_nothing():
    r = _run("ruff", "check", "--no-cache", "--output-format", "concise", "src")
    assert r.returncode == 0, f"ruff check src:\n{r.stdout}{r.stderr}"


def test_mypy_reports_nothing():
    r = _run("mypy", "--no-incremental", "--cache-dir", "/dev/null", "src")
    assert r.returncode == 0, f"mypy src:\n{r.stdout}{r.stderr}"

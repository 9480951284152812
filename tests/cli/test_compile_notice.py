"""The first run after installing tells the user that numba is compiling: once per process,
on a compilation, not on a cache load."""

from __future__ import annotations

import pytest

numba = pytest.importorskip("numba")


def test_notice_once_on_compilation_only(capsys):
    from grainmech.cli import COMPILE_NOTICE, _announce_compilation

    listener = _announce_compilation()
    assert _announce_compilation() is listener  # one listener per process
    listener.said = False  # as in a fresh process (earlier CLI tests may have compiled)
    capsys.readouterr()
    @numba.njit(cache=False)
    def add_one(x):
        return x + 1

    @numba.njit(cache=False)
    def add_two(x):
        return x + 2

    assert add_one(1) == 2 and add_two(1) == 3
    assert capsys.readouterr().err.count(COMPILE_NOTICE) == 1
    assert add_one(2) == 3  # already compiled: no event, no notice
    assert capsys.readouterr().err == ""

"""Progress helpers of long runs (jobs.progress): the time left of an amplitude and the
heartbeat that says a line at least every so many seconds; monkeypatched clocks, no LAMMPS."""

from __future__ import annotations

import threading

import pytest

from grainmech.jobs.progress import Heartbeat, StepClock


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_step_clock_estimates_the_time_left_once_a_step_is_done():
    clock = Clock()
    sc = StepClock(clock)
    sc.begin(40)
    assert sc.left() is None and sc.text() == ""  # no step done: no estimate
    clock.t += 30.0
    sc.step(10, 40)  # 3 s per step, 30 steps left
    assert sc.left() == pytest.approx(90.0)
    assert sc.text() == ", about 90 s left in this amplitude"
    clock.t += 60.0
    sc.step(30, 40)  # 90 s for 30 steps, 10 left
    assert sc.left() == pytest.approx(30.0)
    sc.begin(20)  # the next amplitude: its own rate
    assert sc.left() is None
    clock.t += 5.0
    sc.step(1, 20)
    assert sc.left() == pytest.approx(95.0)


def test_heartbeat_says_a_line_every_period_and_stops():
    lines: list[str] = []
    got = threading.Event()
    count = iter(range(100))

    def say(msg: str) -> None:
        lines.append(msg)
        if len(lines) >= 3:
            got.set()

    with Heartbeat(say, lambda: f"line {next(count)}", every=0.02):
        assert got.wait(5.0)
    n = len(lines)
    assert lines[:3] == ["line 0", "line 1", "line 2"]
    threading.Event().wait(0.1)
    assert len(lines) == n  # nothing after the block


def test_heartbeat_says_nothing_for_an_empty_line():
    lines: list[str] = []
    with Heartbeat(lines.append, lambda: "", every=0.01):
        threading.Event().wait(0.1)
    assert lines == []

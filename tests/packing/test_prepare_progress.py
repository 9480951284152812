"""Progress of ``grainmech pack``: lines on stderr with the stage, the stress against its
target, the void ratio, the unbalanced force ratio and the time left once it can be
estimated; the lines change nothing the preparation does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainmech.lammps.engine import lammps_available
from grainmech.packing import prepare as prep
from grainmech.packing.prepare import decay_time_left


def test_time_left_of_an_exponential_decay() -> None:
    """``y = y0 exp(-t / tau)`` sampled on 0 ... 10 s: the time to reach ``goal`` from the last
    sample is ``tau ln(y(10) / goal)`` (solve ``y(10) exp(-T / tau) = goal`` for T)."""
    tau, y0, goal = 4.0, 2e-3, 1e-5
    t = np.linspace(0.0, 10.0, 21)
    y = y0 * np.exp(-t / tau)
    assert decay_time_left(t, y, goal) == pytest.approx(tau * math.log(y0 * math.exp(-10.0 / tau) / goal), rel=1e-9)
    assert decay_time_left(t, y, 1.0) == 0.0  # already below the goal
    assert decay_time_left(t, y[::-1], goal) is None  # growing: no estimate
    assert decay_time_left(t[:2], y[:2], goal) is None  # too few samples
    assert decay_time_left(t, np.where(t > 5, 0.0, y), goal) is None  # a zero cannot be on a log scale


needs_lammps = pytest.mark.skipif(not lammps_available(), reason="LAMMPS (grainmech[dem]) is not installed")

PACK = ('[grains]\ncount = 120\ndistribution = "uniform"\nradius = "0.15 mm"\nspread = 0.1\nseed = 2\n'
        '[preparation]\nstress = "100 kPa"\nfriction = 0.5\nthreads = 1\n')


@needs_lammps
def test_pack_progress_lines_go_to_stderr(tmp_path, cli, monkeypatch) -> None:
    """120 grains with a line after every chunk (``PROGRESS_EVERY = 0``): both stages appear
    on stderr with the mean stress and its target, the void ratio and the unbalanced force
    ratio; stdout has only the result."""
    monkeypatch.setattr(prep, "PROGRESS_EVERY", 0.0)
    cfg = tmp_path / "p.toml"
    cfg.write_text(PACK)
    res = cli("pack", str(cfg), "-o", str(tmp_path / "out"), "--no-plot")
    assert res.rc == 0, res.err
    lines = res.err.splitlines()
    one = [x for x in lines if x.startswith("  stage 1 of 2 (compression, friction 0.5): step ")]
    two = [x for x in lines if x.startswith("  stage 2 of 2 (relaxation with the grain friction): step ")]
    assert one and two
    for x in one + two:
        assert "mean stress " in x and "(target 1e+05 Pa)" in x and ", void ratio " in x and "unbalanced" in x
    assert any("unbalanced force ratio " in x and "(stops below 1e-05)" in x for x in two)
    assert "stage" not in res.out and res.out.startswith("void ratio ")


@needs_lammps
def test_progress_lines_change_nothing(monkeypatch) -> None:
    """The same 120 grains without progress and with a line after every chunk: the same
    time steps and the same grains, bit for bit (the lines only read what the preparation
    computed)."""
    from grainmech.packing import QUARTZ, PackSettings, prepare_packing

    rng = np.random.default_rng(2)
    radii = 1.5e-4 * (1.0 + 0.1 * (2.0 * rng.random(120) - 1.0))
    settings = PackSettings(stress=(1e5, 1e5, 1e5), prep_friction=0.5, threads=1)
    quiet = prepare_packing(radii, QUARTZ, settings)
    monkeypatch.setattr(prep, "PROGRESS_EVERY", 0.0)
    said: list[str] = []
    loud = prepare_packing(radii, QUARTZ, settings, progress=said.append)
    assert len(said) > 10
    assert loud.summary["time_steps"] == quiet.summary["time_steps"]
    np.testing.assert_array_equal(loud.network.positions, quiet.network.positions)
    np.testing.assert_array_equal(loud.history[:, [0, 2, 3, 4, 5]], quiet.history[:, [0, 2, 3, 4, 5]])


def test_a_quiet_chunk_repeats_the_last_line(monkeypatch) -> None:
    """The heartbeat of ``grainmech pack``: no line for ``PACKING_PROGRESS_EVERY`` s (one long
    chunk of a large packing) repeats the last line with the seconds since."""
    import grainmech.jobs.pack as job

    said: list[str] = []
    last = job._LastLine(said.append)
    assert last.repeat() is None  # nothing said yet
    last.say("  stage 1 of 2 (compression, friction 0): step 200")
    assert said == ["  stage 1 of 2 (compression, friction 0): step 200"]
    assert last.repeat() is None  # just said
    monkeypatch.setattr(job, "PACKING_PROGRESS_EVERY", 0.0)
    again = last.repeat()
    assert again is not None and again.endswith("the last line:) stage 1 of 2 (compression, friction 0): step 200")

"""Progress timing of long runs: a line at most every few seconds, with an estimate of the time left."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["PACKING_PROGRESS_EVERY"]


#: seconds between two progress lines of a long packing run (at most; a batch job's log
#: shows the run is alive at least this often)
PACKING_PROGRESS_EVERY = 10.0


def _step_reporter(say: Callable[[str], None], tag: str, amplitudes: int | None = None,
                   every: float = PACKING_PROGRESS_EVERY) -> Callable[[int, int], None]:
    """``on_step(k, n)`` that reports the progress of a long run at most once every ``every`` seconds.

    The line says ``"<tag> amplitude a/m, step k/n, t s (total T s), about R s left"``:
    the amplitude (of ``amplitudes`` runs; without it, one path run and no amplitude),
    the step of the current run, the seconds since the current run began and since the
    first began, and, once one amplitude has finished (a path run: from the first step),
    an estimate of the time left: the seconds per step so far times the steps left
    (every amplitude has the same number of steps; larger amplitudes usually take longer
    per step, so the estimate tends to be low). The packing driver can take minutes
    per amplitude (committed relaxation at the strain reversals); the line tells the user
    that it is working and how far it is. A call with ``k`` not above the previous one
    starts the next run (amplitude); the last step of a run is silent.
    """
    start = time.perf_counter()
    state = {"t0": start, "last": start, "end": start, "k": 0.0, "run": 1, "done_steps": 0}

    def on_step(k: int, n: int) -> None:
        now = time.perf_counter()
        if k <= state["k"]:  # a new run (next amplitude): it started when the last one ended
            state["run"] += 1
            state["done_steps"] += int(state["k"])
            state["t0"] = state["last"] = state["end"]
        state["k"], state["end"] = k, now
        if now - state["last"] >= every and k < n:
            state["last"] = now
            where = f"amplitude {state['run']}/{amplitudes}, " if amplitudes else ""
            line = f"{tag} {where}step {k}/{n}, {now - state['t0']:.0f} s (total {now - start:.0f} s)"
            left_steps = n - k + (max(amplitudes - state["run"], 0) * n if amplitudes else 0)
            if state["done_steps"] or not amplitudes:
                rate = (now - start) / max(state["done_steps"] + k, 1)
                line += f", about {rate * left_steps:.0f} s left"
            say(line)

    return on_step

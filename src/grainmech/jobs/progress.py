"""Progress timing of long runs: a line at most every few seconds, with an estimate of the time left."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["PACKING_PROGRESS_EVERY", "StepClock", "StepReporter", "Heartbeat"]


#: seconds between two progress lines of a long packing run (at most; a batch job's log
#: shows the run is alive at least this often)
PACKING_PROGRESS_EVERY = 10.0


def _step_reporter(say: Callable[[str], None], tag: str, amplitudes: int | None = None,
                   every: float = PACKING_PROGRESS_EVERY) -> StepReporter:
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
    ``on_step.planned(m)`` sets the number of amplitudes to ``m`` before the first step (a
    resumed run: only those not taken up from the earlier run are counted and timed).
    """
    return StepReporter(say, tag, amplitudes, every)


class StepReporter:
    """The callable :func:`_step_reporter` returns: ``reporter(k, n)`` after each step, ``planned(m)``."""

    def __init__(self, say: Callable[[str], None], tag: str, amplitudes: int | None, every: float) -> None:
        self.say, self.tag, self.amplitudes, self.every = say, tag, amplitudes, float(every)
        self.start = time.perf_counter()
        self.t0 = self.last = self.end = self.start
        self.k, self.run, self.done_steps = 0, 1, 0

    def planned(self, m: int) -> None:
        """The series will run ``m`` amplitudes (a run of one path keeps no count)."""
        if self.amplitudes is not None:
            self.amplitudes = int(m)

    def __call__(self, k: int, n: int) -> None:
        """Step ``k`` of ``n`` of the current run is done: a line when one is due."""
        now = time.perf_counter()
        if k <= self.k:  # a new run (next amplitude): it started when the last one ended
            self.run += 1
            self.done_steps += int(self.k)
            self.t0 = self.last = self.end
        self.k, self.end = k, now
        amplitudes = self.amplitudes
        if now - self.last >= self.every and k < n:
            self.last = now
            where = f"amplitude {self.run}/{amplitudes}, " if amplitudes else ""
            line = f"{self.tag} {where}step {k}/{n}, {now - self.t0:.0f} s (total {now - self.start:.0f} s)"
            left_steps = n - k + (max(amplitudes - self.run, 0) * n if amplitudes else 0)
            if self.done_steps or not amplitudes:
                rate = (now - self.start) / max(self.done_steps + k, 1)
                line += f", about {rate * left_steps:.0f} s left"
            self.say(line)


class StepClock:
    """The time left of a run of amplitudes, each a path of steps, from the steps done so far.

    ``begin(n)`` starts an amplitude of ``n`` steps, ``step(k, n)`` records that its step
    ``k`` is done (a ``k`` not above the previous one also starts the next amplitude), and
    :meth:`left` estimates the seconds left in the current amplitude: the seconds per step
    of this amplitude so far times its steps left (None before its first step: no
    estimate yet). ``clock`` is the time source (``time.perf_counter``; tests pass their own).
    """

    def __init__(self, clock: Callable[[], float] = time.perf_counter) -> None:
        self.clock = clock
        self.t0 = clock()
        self.k, self.n = 0, 0

    def begin(self, n: int) -> None:
        """An amplitude of ``n`` steps starts now."""
        self.t0, self.k, self.n = self.clock(), 0, int(n)

    def step(self, k: int, n: int) -> None:
        """Step ``k`` of ``n`` is done."""
        if k <= self.k:  # the next amplitude's first step: it began when the last one ended
            self.k = 0
        self.k, self.n = int(k), int(n)

    def left(self) -> float | None:
        """Seconds left in the current amplitude (None: no step done yet)."""
        if self.k <= 0 or self.n <= 0:
            return None
        return (self.clock() - self.t0) / self.k * max(self.n - self.k, 0)

    def text(self) -> str:
        """``", about 40 s left in this amplitude"`` once an estimate is possible, else ``""``."""
        s = self.left()
        return "" if s is None else f", about {s:.0f} s left in this amplitude"


class Heartbeat:
    """A line at least every ``every`` seconds while a long step runs (a context manager).

    A daemon thread calls ``say(line())`` every ``every`` seconds between ``__enter__``
    and ``__exit__``; ``line()`` returns the text (None or "": nothing said this time).
    The work itself stays in the calling thread, so a signal (Ctrl-C, SIGTERM) stops it as
    before; the thread only reads what the work records.
    """

    def __init__(self, say: Callable[[str], None], line: Callable[[], str | None],
                 every: float = PACKING_PROGRESS_EVERY) -> None:
        import threading

        self.say, self.line, self.every = say, line, float(every)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat, name="grainmech-progress", daemon=True)

    def _beat(self) -> None:
        while not self._stop.wait(self.every):
            text = self.line()
            if text:
                self.say(text)

    def __enter__(self) -> Heartbeat:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)

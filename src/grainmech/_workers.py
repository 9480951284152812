"""Background Python processes that fill numba's on-disk cache (private).

The first run after installing compiles every kernel it uses. On a machine with a second
core, kernels that the run will need later are compiled meanwhile in a second Python
process, into numba's cache, from which the run then loads them
(``docs/performance.md``, "First run"). ``GRAINMECH_COMPILE_WORKER=0`` switches this off.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

__all__: list[str] = []


def start_worker(script: str, payload: Any) -> subprocess.Popen | None:
    """Start ``python -c script`` with ``(sys.path, payload)`` pickled on its stdin.

    The script reads them with ``path, payload = pickle.load(sys.stdin.buffer)`` and sets
    ``sys.path[:] = path`` first (it imports the same grainmech as this process). Its
    output goes nowhere. Returns None (nothing started) with ``GRAINMECH_COMPILE_WORKER=0``,
    on a single core, or when the process cannot be started.
    """
    if os.environ.get("GRAINMECH_COMPILE_WORKER", "1") == "0":
        return None
    try:
        ncpu = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        ncpu = os.cpu_count() or 1
    if ncpu < 2:
        return None
    try:
        p = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        assert p.stdin is not None
        p.stdin.write(pickle.dumps((list(sys.path), payload)))
        p.stdin.close()
    except (OSError, pickle.PicklingError):  # pragma: no cover - then the caller compiles
        return None
    return p


def finish(p: subprocess.Popen | None, ok: bool = True, timeout: float = 600.0) -> None:
    """Wait for a worker (killed at once when ``ok`` is False, e.g. after an interruption)."""
    if p is None:
        return
    if not ok:
        p.kill()
    try:
        p.wait(timeout=timeout)
    except subprocess.TimeoutExpired:  # pragma: no cover - a hung worker: the caller compiles
        p.kill()
        p.wait()


@contextmanager
def on_first_compile(start: Callable[[], subprocess.Popen | None]) -> Iterator[None]:
    """Call ``start()`` at the first numba compilation inside the block; wait for what it started on leaving.

    numba's compile event fires only when something is compiled (not when it is loaded
    from the cache), so later runs start nothing. ``start`` returns a worker
    (:func:`start_worker`) or None. On leaving the block the worker is waited for
    (:func:`finish`), or killed at once if the block raised.
    """
    from numba.core import event

    started: list = []

    class _OnCompile(event.Listener):
        def on_start(self, ev: object) -> None:
            if not started:
                started.append(start())

        def on_end(self, ev: object) -> None:
            pass

    ok = False
    try:
        with event.install_listener("numba:compile", _OnCompile()):
            yield
        ok = True
    finally:
        for p in started:
            finish(p, ok)

"""A DEM modulus-reduction series: amplitudes side by side in worker processes (:mod:`grainmech.driver.dem`)."""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import pickle
import queue
import signal
import threading
import traceback
from collections import deque
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection, wait
from typing import Any

import numpy as np

from grainmech.contact.rolling import RollingResistance
from grainmech.driver.base import DriverResult, Status
from grainmech.driver.dem.mpi import Tick, signal_text
from grainmech.driver.dem.run import DemResult, run_dem
from grainmech.driver.dem.settings import DemSettings, dem_material
from grainmech.driver.loop import ModulusReduction, cyclic_series
from grainmech.driver.paths import LoadPath, cyclic_simple_shear
from grainmech.elasticity import condensed_modulus
from grainmech.errors import GrainmechError, ParameterError
from grainmech.network import ContactNetwork

__all__ = ["DEM_MAX_AMPLITUDE", "DemSeries", "dem_modulus_reduction"]

#: largest cyclic amplitude the DEM model accepts (cells tilt; beyond it a simple-shear
#: cell of a 2000-grain packing is too thin for the shear band)
DEM_MAX_AMPLITUDE = 0.05

def _worker_init() -> None:
    """A DEM worker process leaves Ctrl-C and SIGTERM to the parent (which ends the pool).

    On Linux it also asks for SIGTERM when its parent ends (``prctl(PR_SET_PDEATHSIG)``),
    so that a parent killed without cleaning up (a script ended by ``kill``) leaves no
    LAMMPS running.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = os.getppid()
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        return
    if os.getppid() != parent:  # the parent ended before the request took effect
        os._exit(143)


#: niceness of a worker that runs an amplitude other than the largest of its batch (``_Pool``)
_BACKGROUND_NICE = 10


def _worker_main(net: ContactNetwork, law: Any, path: LoadPath, settings: DemSettings | None,
                 pressure: float | None, rolling: RollingResistance | None, background: bool,
                 conn: Connection) -> None:
    """One amplitude in its own worker process; progress and the answer go to the parent through ``conn``.

    ``background``: the worker lowers its own priority to niceness ``_BACKGROUND_NICE``
    first (``os.nice``). Messages: ``("step", k, n)``, ``("tick", time_steps, unbalanced)``,
    then one of ``("result", DemResult)``, ``("memory", text)`` (a :class:`MemoryError`:
    the amplitude fails, the others go on) or ``("error", exception, traceback text)``.
    """
    _worker_init()
    if background and hasattr(os, "nice"):
        try:
            os.nice(max(0, _BACKGROUND_NICE - os.nice(0)))
        except OSError:  # pragma: no cover - a system that refuses it: run at the same priority
            pass

    def on_step(k: int, n: int) -> None:
        conn.send(("step", k, n))

    def tick(steps: int, ub: float) -> None:
        conn.send(("tick", steps, ub))

    answer: tuple
    try:
        answer = ("result", run_dem(net, law, path, settings, pressure=pressure, on_step=on_step, tick=tick,
                                    rolling=rolling))
    except MemoryError as exc:
        answer = ("memory", f"it ran out of memory (MemoryError{': ' + str(exc) if str(exc) else ''})")
    except Exception as exc:  # passed to the parent, which raises it there
        answer = ("error", exc, traceback.format_exc())
    try:
        try:
            conn.send(answer)
        except (pickle.PicklingError, TypeError, AttributeError):  # an exception that cannot be pickled: its text
            conn.send(("error", GrainmechError(f"{type(answer[1]).__name__}: {answer[1]}"), answer[-1]))
        conn.close()
    except OSError:  # the parent has gone (it ended the pool): nobody to answer
        pass


def _stop_text(answer: tuple | None) -> str | None:
    """Why a worker's answer is a stop (died, out of memory, a run that did not succeed), or None."""
    if answer is None or answer[0] == "error":  # an error is raised when its amplitude is collected
        return None
    if answer[0] in ("died", "memory"):
        return str(answer[1])
    r = answer[1]
    return None if r.success or int(r.status) == Status.LIQUEFIED else str(r.message)


def _death(pid: int | None, exitcode: int | None) -> str:
    """Why a worker process ended without an answer, in words (``exitcode`` as :class:`multiprocessing.Process`)."""
    who = f"its worker process (pid {pid})"
    if exitcode is not None and exitcode < 0:
        return f"{who} was killed by {signal_text(-exitcode)}"
    return f"{who} ended with exit code {exitcode} before it answered"


class _Pool:
    """Amplitudes run side by side, each in a worker process of its own (each a LAMMPS on one core).

    At most ``workers`` run at once; the others wait in the order submitted. Each worker
    talks to the parent through a pipe of its own, so a worker that dies (killed, out of
    memory) ends only its amplitude: :meth:`result` answers a failed
    :class:`DemResult` naming the cause (signal or exit code) and the other amplitudes
    go on. A thread of the parent reads every pipe all the time (a worker never waits for
    the parent, which may be computing another model), reaps a worker when it ends and
    starts the next; the progress of the amplitude :meth:`result` waits for is passed on
    in the caller's thread, that of the others is dropped.

    The largest amplitude of each batch submitted together (:meth:`DemSeries.add`) is the
    longest run (more time steps per step, more servo corrections): its worker keeps the
    normal priority and the others run at niceness ``_BACKGROUND_NICE``, so that when the
    caller also computes (another model in the main process) the run that decides the
    wall time keeps its core and the shorter ones take what is left. The results do not
    depend on it (each LAMMPS is deterministic on one thread).
    """

    def __init__(self, workers: int) -> None:
        self.ctx = mp.get_context("spawn")
        self.workers = int(workers)
        self.calls: list[tuple] = []
        self.waiting: deque[int] = deque()
        self.running: dict[int, tuple[Any, Connection]] = {}
        self.answers: dict[int, tuple] = {}
        self.awaited = -1
        self.steps: dict[int, tuple[int, int]] = {}  # the latest step (k, n) of every running amplitude
        self.progress: queue.SimpleQueue[tuple] = queue.SimpleQueue()
        self.lock = threading.RLock()
        self.stop = threading.Event()
        self.reader = threading.Thread(target=self._read, name="grainmech-dem-pool", daemon=True)
        self.reader.start()

    def submit(self, *args: Any, background: bool = False, rolling: RollingResistance | None = None) -> None:
        with self.lock:
            self.calls.append((*args, rolling, background))
            self.waiting.append(len(self.calls) - 1)
            self._start()

    def _start(self) -> None:
        """Start waiting amplitudes while fewer than ``workers`` run (with the lock held)."""
        while self.waiting and len(self.running) < self.workers and not self.stop.is_set():
            i = self.waiting.popleft()
            recv, send = self.ctx.Pipe(duplex=False)
            proc = self.ctx.Process(target=_worker_main, args=(*self.calls[i], send), daemon=True,
                                    name=f"grainmech-dem-{i}")
            proc.start()
            send.close()  # the worker holds the only writing end: its death closes the pipe
            self.running[i] = (proc, recv)

    def _end(self, i: int, answer: tuple) -> None:
        """Amplitude ``i`` answered (or its worker died): reap the worker, start the next."""
        with self.lock:
            if i not in self.running:  # ended by close()
                return
            proc, conn = self.running.pop(i)
            self.steps.pop(i, None)
        conn.close()
        proc.join(timeout=30)
        if proc.is_alive():  # pragma: no cover - answered but does not exit
            proc.kill()
            proc.join()
        if answer[0] == "died":
            answer = ("died", _death(proc.pid, proc.exitcode))
        with self.lock:
            self.answers[i] = answer
            self._start()
        self.progress.put((i, "answer"))

    def _read(self) -> None:
        """The reader thread: every message of every worker, as it comes."""
        while not self.stop.is_set():
            with self.lock:
                conns = {id(conn): (i, conn) for i, (_, conn) in self.running.items()}
            if not conns:
                self.stop.wait(0.1)
                continue
            try:
                ready = wait([conn for _, conn in conns.values()], timeout=0.2)
            except OSError:  # a pipe closed by close() meanwhile
                continue
            for r in ready:
                i, conn = conns[id(r)]
                try:
                    msg = conn.recv()
                except (EOFError, OSError):  # the pipe closed with no answer: the worker is gone
                    if not self.stop.is_set():
                        self._end(i, ("died",))
                    continue
                if msg[0] in ("result", "memory", "error"):
                    self._end(i, msg)
                else:
                    if msg[0] == "step":
                        self.steps[i] = (int(msg[1]), int(msg[2]))
                    if i == self.awaited:
                        self.progress.put((i, *msg))

    def result(self, index: int, on_step: Callable[[int, int], None] | None, tick: Tick | None,
               on_other_stop: Callable[[int, str], None] | None = None,
               on_wait: Callable[[dict[int, tuple[int, int]]], None] | None = None) -> DemResult:
        """Wait for amplitude ``index``, passing on its progress meanwhile.

        Returns its :class:`DemResult`; a failed one (``success`` False) when its worker
        died or ran out of memory. An error raised in the worker is raised here.
        ``on_other_stop(i, message)`` hears meanwhile of another amplitude ``i`` that
        ended without success (the moment its worker answers, not when it is collected).
        ``on_wait(steps)`` is called about every half second while amplitude ``index`` waits
        for a worker (the others, larger ones first, hold them), with the latest step
        ``(k, n)`` of each amplitude running meanwhile (``{i: (k, n)}``).
        """
        self.awaited = index
        while True:
            with self.lock:
                if index in self.answers:
                    answer = self.answers.pop(index)
                    break
            try:
                i, kind, *msg = self.progress.get(timeout=0.5)
            except queue.Empty:
                if on_wait is not None:
                    with self.lock:
                        queued = index not in self.running
                        steps = {j: self.steps[j] for j in self.running if j in self.steps}
                    if queued:
                        on_wait(steps)
                continue
            if i == index and kind == "step" and on_step is not None:
                on_step(int(msg[0]), int(msg[1]))
            elif i == index and kind == "tick" and tick is not None:
                tick(int(msg[0]), float(msg[1]))
            elif i != index and kind == "answer" and on_other_stop is not None:
                with self.lock:
                    why = _stop_text(self.answers.get(i))
                if why is not None:
                    on_other_stop(i, why)
        self.awaited = -1
        if answer[0] == "result":
            return answer[1]
        if answer[0] == "error":
            exc = answer[1]
            if isinstance(exc, GrainmechError):
                raise exc
            raise exc from _WorkerTraceback(answer[2])
        return DemResult.failed(answer[1])

    def close(self) -> None:
        """End the pool; workers still running are stopped (interrupted run, failed amplitude)."""
        self.stop.set()
        self.reader.join(timeout=5)  # it stops within 0.2 s, unless it is reaping a worker that ended
        with self.lock:
            self.waiting.clear()
            running = list(self.running.values())
            self.running.clear()
        for proc, _ in running:
            if proc.is_alive():
                proc.terminate()
        for proc, conn in running:
            proc.join(timeout=10)
            if proc.is_alive():  # pragma: no cover - a worker that ignores SIGTERM
                proc.kill()
                proc.join()
            conn.close()


class _WorkerTraceback(Exception):
    """The traceback of an error raised in a worker process (the cause of the error raised in the parent)."""

    def __str__(self) -> str:
        return "\n" + str(self.args[0])


class DemSeries:
    """A DEM modulus-reduction series whose amplitudes may start before they are collected.

    ``DemSeries(...)`` checks the inputs and, with ``workers`` > 1, submits every
    amplitude to worker processes at once (each LAMMPS on one core); :meth:`add` submits
    more; :meth:`run` collects them in amplitude order through
    :func:`grainmech.driver.loop.cyclic_series` (with one worker, it runs them there);
    :meth:`close` ends the workers. A job that runs other models first starts the series
    before them, so the DEM amplitudes use the cores those models leave idle.
    """

    def __init__(self, net: ContactNetwork, law: Any, amplitudes: Sequence[float], *, n_cycles: int = 2,
                 steps_per_cycle: int = 16, waveform: str = "triangle", constant: str = "stress",
                 settings: DemSettings | None = None, pressure: float | None = None, workers: int = 1,
                 rolling: RollingResistance | None = None) -> None:
        dem_material(law)  # refuse a law LAMMPS cannot run before anything starts
        amps = np.asarray(amplitudes, dtype=float)
        if amps.ndim != 1 or amps.size == 0 or not np.all(np.isfinite(amps)) or np.any(amps <= 0):
            raise ParameterError("amplitudes", list(np.atleast_1d(amplitudes)), "must be a non-empty list of "
                                 "positive strains")
        if float(amps.max()) > DEM_MAX_AMPLITUDE:
            raise ParameterError("amplitudes", list(amps), f"the DEM model takes amplitudes up to "
                                 f"{DEM_MAX_AMPLITUDE:g}")
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
            raise ParameterError("workers", workers, "must be an integer >= 1")
        self.net, self.law, self.settings, self.pressure = net, law, settings, pressure
        self.rolling = rolling
        self.n_cycles, self.steps_per_cycle = n_cycles, steps_per_cycle
        self.waveform, self.constant = waveform, constant
        self.amplitudes: list[float] = []
        self.index: dict[float, int] = {}
        self.pool = _Pool(min(int(workers), amps.size)) if workers > 1 and amps.size > 1 else None
        self.add(amps)

    def _path(self, a: float) -> LoadPath:
        return cyclic_simple_shear(a, self.n_cycles, self.steps_per_cycle, self.waveform, constant=self.constant)

    def add(self, amplitudes: Sequence[float] | np.ndarray) -> None:
        """Add amplitudes to the series.

        With workers they are submitted at once, the largest first; ``_Pool`` runs all but
        the largest at a lower priority.
        """
        new = sorted({float(a) for a in np.asarray(amplitudes, dtype=float).ravel()} - set(self.index),
                     reverse=True)
        for k, a in enumerate(new):
            self.index[a] = len(self.index)
            self.amplitudes.append(a)
            if self.pool is not None:  # new[0], the largest, keeps the normal priority
                self.pool.submit(self.net, self.law, self._path(a), self.settings, self.pressure,
                                 background=k > 0, rolling=self.rolling)

    def run(self, *, progress: Callable[[int, float, Any], None] | None = None,
            on_step: Callable[[int, int], None] | None = None, tick: Tick | None = None,
            raise_on_failure: bool = True,
            on_amplitude: Callable[[ModulusReduction], None] | None = None,
            on_stop: Callable[[float, str], None] | None = None,
            on_wait: Callable[[dict[float, tuple[int, int]]], None] | None = None) -> ModulusReduction:
        """Collect the series in increasing amplitude (:func:`dem_modulus_reduction`).

        ``on_stop(amplitude, message)`` hears of each amplitude that fails once, when it
        fails: with workers, the moment its worker answers, even while the series still
        waits for a smaller amplitude. ``on_wait({amplitude: (k, n)})``: while the amplitude
        the series waits for has no worker yet, the steps of those running (``_Pool.result``).
        """
        tangents: list[np.ndarray] = []
        amps = np.array(sorted(self.amplitudes))
        told: set[float] = set()
        by_index = {i: a for a, i in self.index.items()}

        def stopped(a: float, why: str) -> None:
            if on_stop is not None and a not in told:
                told.add(a)
                on_stop(a, why)

        def one(path: LoadPath) -> DriverResult:
            a = float(amps[len(tangents)])
            if self.pool is not None:
                r = self.pool.result(self.index[a], on_step, tick, lambda i, why: stopped(by_index[i], why),
                                     None if on_wait is None else
                                     lambda steps: on_wait({by_index[i]: kn for i, kn in steps.items()}))
            else:
                r = run_dem(self.net, self.law, path, self.settings, pressure=self.pressure, on_step=on_step,
                            tick=tick, rolling=self.rolling)
            tangents.append(r.elastic_tangent)
            return r

        def gmax(path: LoadPath) -> float:
            # every amplitude starts from the same state: the first run that measured it
            # (a run whose process died has none)
            known = [t for t in tangents if np.all(np.isfinite(t))]
            if not known:
                return float("nan")
            return condensed_modulus(known[0], 4, path.stress_control[0])

        return cyclic_series(one, amps, gmax, n_cycles=self.n_cycles, steps_per_cycle=self.steps_per_cycle,
                             waveform=self.waveform, constant=self.constant, progress=progress,
                             raise_on_failure=raise_on_failure, on_amplitude=on_amplitude, on_stop=stopped)

    def close(self) -> None:
        """End the worker processes (idempotent)."""
        if self.pool is not None:
            self.pool.close()
            self.pool = None


def dem_modulus_reduction(net: ContactNetwork, law: Any, amplitudes: Sequence[float], *, n_cycles: int = 2,
                          steps_per_cycle: int = 16, waveform: str = "triangle", constant: str = "stress",
                          settings: DemSettings | None = None, pressure: float | None = None,
                          workers: int = 1,
                          progress: Callable[[int, float, Any], None] | None = None,
                          on_step: Callable[[int, int], None] | None = None, tick: Tick | None = None,
                          raise_on_failure: bool = True,
                          on_amplitude: Callable[[ModulusReduction], None] | None = None,
                          rolling: RollingResistance | None = None,
                          on_stop: Callable[[float, str], None] | None = None,
                          on_wait: Callable[[dict[float, tuple[int, int]]], None] | None = None) -> ModulusReduction:
    """G/Gmax and damping of a packing by DEM: cyclic simple shear ``gamma_xz`` per amplitude.

    Each amplitude starts from the same state (the packing loaded and relaxed anew; LAMMPS
    is deterministic on one thread), as the other models' series do
    (:func:`grainmech.driver.loop.cyclic_series`: the last of ``n_cycles`` cycles
    analysed). ``G_max`` is ``C_55`` of the relaxed small-strain tensor of that start state
    (:func:`grainmech.network.relaxed_stiffness` with the no-slip Hertz-Mindlin
    stiffnesses LAMMPS uses, condensed with the path's control: ``sigma_zz`` free at
    constant stress): the small-strain limit of the same DEM state, which LAMMPS' own
    strain probes reproduce to 0.13 % on 'dense' (``docs/packings.md``).

    ``workers`` > 1 runs the amplitudes side by side in that many processes (each
    LAMMPS runs on one core; the amplitudes are independent): the same results, in the
    time of the slowest amplitude per worker. Progress is passed on for the amplitude the
    series is waiting for. ``rolling``: rolling and twisting resistance (:mod:`grainmech.driver.dem`);
    ``G_max`` then comes from the relaxed tensor with the moment springs.
    """
    series = DemSeries(net, law, amplitudes, n_cycles=n_cycles, steps_per_cycle=steps_per_cycle,
                       waveform=waveform, constant=constant, settings=settings, pressure=pressure, workers=workers,
                       rolling=rolling)
    try:
        return series.run(progress=progress, on_step=on_step, tick=tick, raise_on_failure=raise_on_failure,
                          on_amplitude=on_amplitude, on_stop=on_stop, on_wait=on_wait)
    finally:
        series.close()

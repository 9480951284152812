"""A DEM modulus-reduction series: amplitudes side by side in worker processes (:mod:`grainmech.driver.dem`)."""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import queue
import signal
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from typing import Any

import numpy as np

from grainmech.contact.rolling import RollingResistance
from grainmech.driver.base import DriverResult
from grainmech.driver.dem.mpi import Tick
from grainmech.driver.dem.run import DemResult, run_dem
from grainmech.driver.dem.settings import DemSettings, dem_material
from grainmech.driver.loop import ModulusReduction, cyclic_series
from grainmech.driver.paths import LoadPath, cyclic_simple_shear
from grainmech.elasticity import condensed_modulus
from grainmech.errors import ParameterError
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


def _worker_run(net: ContactNetwork, law: Any, path: LoadPath, settings: DemSettings | None,
                pressure: float | None, rolling: RollingResistance | None, background: bool, index: int,
                q: Any) -> DemResult:
    """One amplitude in a worker process; progress goes to the parent through ``q``.

    ``background``: the worker lowers its own priority to niceness ``_BACKGROUND_NICE``
    first (``os.nice``; a process cannot raise it again, so it keeps it for later tasks).
    """
    if background and hasattr(os, "nice"):
        try:
            os.nice(max(0, _BACKGROUND_NICE - os.nice(0)))
        except OSError:  # pragma: no cover - a system that refuses it: run at the same priority
            pass

    def on_step(k: int, n: int) -> None:
        q.put((index, "step", k, n))

    def tick(steps: int, ub: float) -> None:
        q.put((index, "tick", steps, ub))

    return run_dem(net, law, path, settings, pressure=pressure, on_step=on_step, tick=tick, rolling=rolling)


class _Pool:
    """Amplitudes run side by side in worker processes (each a LAMMPS on one core).

    The largest amplitude of each batch submitted together (:meth:`DemSeries.add`) is the
    longest run (more time steps per step, more servo corrections): its worker keeps the
    normal priority and the others run at niceness ``_BACKGROUND_NICE``, so that when the
    caller also computes (another model in the main process) the run that decides the
    wall time keeps its core and the shorter ones take what is left. The results do not
    depend on it (each LAMMPS is deterministic on one thread).
    """

    def __init__(self, workers: int) -> None:
        ctx = mp.get_context("spawn")
        self.manager = ctx.Manager()
        self.queue = self.manager.Queue()
        self.ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
        self.futures: list[Future] = []

    def submit(self, *args: Any, background: bool = False, rolling: RollingResistance | None = None) -> None:
        call = (*args, rolling, background, len(self.futures), self.queue)
        self.futures.append(self.ex.submit(_worker_run, *call))

    def result(self, index: int, on_step: Callable[[int, int], None] | None, tick: Tick | None) -> DemResult:
        """Wait for amplitude ``index``, passing on its progress meanwhile."""
        fut = self.futures[index]
        while True:
            try:
                i, kind, a, b = self.queue.get(timeout=0.5)
                if i == index and kind == "step" and on_step is not None:
                    on_step(int(a), int(b))
                elif i == index and kind == "tick" and tick is not None:
                    tick(int(a), float(b))
            except queue.Empty:
                pass
            if fut.done():
                return fut.result()

    def close(self) -> None:
        """End the pool; workers still running are stopped (interrupted run, failed amplitude)."""
        for f in self.futures:
            f.cancel()
        procs = list(getattr(self.ex, "_processes", {}).values())
        self.ex.shutdown(wait=False, cancel_futures=True)
        for pr in procs:
            if pr.is_alive():
                pr.terminate()
        self.manager.shutdown()


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
            on_amplitude: Callable[[ModulusReduction], None] | None = None) -> ModulusReduction:
        """Collect the series in increasing amplitude (:func:`dem_modulus_reduction`)."""
        tangents: list[np.ndarray] = []
        amps = np.array(sorted(self.amplitudes))

        def one(path: LoadPath) -> DriverResult:
            a = float(amps[len(tangents)])
            if self.pool is not None:
                r = self.pool.result(self.index[a], on_step, tick)
            else:
                r = run_dem(self.net, self.law, path, self.settings, pressure=self.pressure, on_step=on_step,
                            tick=tick, rolling=self.rolling)
            tangents.append(r.elastic_tangent)
            return r

        def gmax(path: LoadPath) -> float:
            if not tangents:
                return float("nan")
            return condensed_modulus(tangents[0], 4, path.stress_control[0])

        return cyclic_series(one, amps, gmax, n_cycles=self.n_cycles, steps_per_cycle=self.steps_per_cycle,
                             waveform=self.waveform, constant=self.constant, progress=progress,
                             raise_on_failure=raise_on_failure, on_amplitude=on_amplitude)

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
                          rolling: RollingResistance | None = None) -> ModulusReduction:
    """G/Gmax and damping of a packing by DEM: cyclic simple shear ``gamma_xz`` per amplitude.

    Each amplitude starts from the same state (the packing loaded and relaxed anew; LAMMPS
    is deterministic on one thread), as the other models' series do
    (:func:`grainmech.driver.loop.cyclic_series`: the last of ``n_cycles`` cycles
    analysed). ``G_max`` is ``C_55`` of the relaxed small-strain tensor of that start state
    (:func:`grainmech.network.relaxed_stiffness` with the no-slip Hertz-Mindlin
    stiffnesses LAMMPS uses, condensed with the path's control: ``sigma_zz`` free at
    constant stress): the small-strain limit of the same DEM state, which LAMMPS' own
    strain probes reproduce to 0.13 % on 'dense' (``docs/packing.md``).

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
                          on_amplitude=on_amplitude)
    finally:
        series.close()

"""One path loop and one cyclic series for every kinematic model (``driver/base.py`` contract).

* :func:`follow_path` drives a :class:`~grainmech.driver.base.SteppingPoint` along a
  :class:`~grainmech.driver.paths.LoadPath` with mixed control: per step and component a
  control kind and an increment; targets do not drift (increments are added to an exact
  running target, not to the value reached); a component switching control restarts from
  the current value. A :class:`~grainmech.driver.base.StepFailure` ends the path with
  ``success`` False and every state before it kept. The affine model's step-by-step run
  (:func:`grainmech.driver.run`), the packing model
  (:func:`grainmech.driver.packing.run_packing`) and the DEM model use it; the affine
  model's compiled whole-path loops (its fast path) keep the same semantics.
* :func:`cyclic_series` runs strain-controlled cyclic simple shear (``gamma_xz``) at each
  amplitude with any model's runner and analyses the last cycle (:func:`loop_properties`:
  secant modulus and damping ratio of one closed loop): the modulus-reduction and damping
  curve, a :class:`ModulusReduction`. :func:`grainmech.driver.modulus_reduction` (affine),
  :func:`grainmech.driver.packing.packing_modulus_reduction` and the DEM model all use it.

For one closed stress-strain loop ``(gamma, tau)`` (engineering shear strain):

* amplitude ``gamma_a = (max gamma - min gamma)/2``, ``tau_a`` half the stress range
  between the two strain extremes;
* secant modulus ``G = tau_a / gamma_a``;
* dissipated energy ``dW = |oint tau d gamma|`` (trapezoidal loop area);
* damping ratio ``D = dW / (4 pi W)`` with ``W = tau_a gamma_a / 2`` (Kramer 1996, Sec. 6.4.2;
  Darendeli 2001, Ch. 2).

How far a cycle is from a closed, stationary loop is :func:`grainmech.analysis.loop_quality`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from grainmech.driver.base import DriverResult, Status, StepFailure, SteppingPoint
from grainmech.driver.paths import LoadPath, PathTargets, cyclic_simple_shear
from grainmech.errors import GrainmechError, ParameterError

__all__ = ["follow_path", "PathCheckpoint", "path_saves", "copied_rows", "restore_rows", "cyclic_series",
           "Recorder", "LoopProperties", "loop_properties", "ModulusReduction"]

#: ``record(point, step_index)`` -> None: what a model keeps of each state
Recorder = Callable[[Any, int], None]


@dataclass(frozen=True)
class LoopProperties:
    """Properties of one loop (units: strain dimensionless, stress and energy per volume)."""

    gamma_a: float
    tau_a: float
    secant_modulus: float
    dissipated: float
    stored: float
    damping: float


def loop_properties(gamma: Any, tau: Any) -> LoopProperties:
    """Secant modulus and damping ratio of one closed loop.

    Parameters
    ----------
    gamma, tau : arrays (k,)
        Engineering shear strain and shear stress along one full cycle (first and last
        points at the same strain).
    """
    g = np.asarray(gamma, dtype=float)
    t = np.asarray(tau, dtype=float)
    if g.ndim != 1 or g.shape != t.shape or g.size < 4:
        raise ParameterError("gamma/tau", (g.shape, t.shape), "must be 1-D arrays of equal length >= 4")
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(t))):
        raise ParameterError("gamma/tau", "non-finite", "must be finite")
    imax, imin = int(np.argmax(g)), int(np.argmin(g))
    ga = 0.5 * (g[imax] - g[imin])
    if ga <= 0:
        raise ParameterError("gamma", "constant", "the loop has zero strain amplitude")
    ta = 0.5 * (t[imax] - t[imin])
    dW = abs(float(np.sum(0.5 * (t[1:] + t[:-1]) * np.diff(g))))
    W = 0.5 * ta * ga
    D = dW / (4 * np.pi * W) if W > 0 else 0.0
    return LoopProperties(float(ga), float(ta), float(ta / ga), dW, float(W), float(D))


@dataclass(frozen=True)
class ModulusReduction:
    """Modulus reduction and damping against amplitude.

    Attributes
    ----------
    amplitude : (k,) engineering shear strain amplitudes
    G : (k,) secant moduli of the last cycle
    damping : (k,) damping ratios of the last cycle
    G_max : float
        Small-strain modulus from the initial tangent (:func:`condensed_modulus`).
    results : list of DriverResult
    success, message
        Whether every amplitude completed or liquefied, and what stopped the others.
    run_amplitudes : (len(results),) or None
        The amplitude of every run in ``results``.
    liquefied : tuple of str
        ``"amplitude a: <message>"`` of every amplitude whose run liquefied (the DEM model
        at constant volume: the test's answer, not a failure; no G or damping).
    """

    amplitude: np.ndarray
    G: np.ndarray
    damping: np.ndarray
    G_max: float
    results: list
    success: bool = True
    message: str = "done"
    run_amplitudes: np.ndarray | None = None
    liquefied: tuple = ()

    @property
    def completed(self) -> list:
        """The results of the completed amplitudes (aligned with ``amplitude``, ``G``, ``damping``)."""
        return [r for r in self.results if r.success][:len(self.G)]

    @property
    def G_ratio(self) -> np.ndarray:
        """Secant modulus ratio ``G / G_max`` [-] per amplitude, shape (n_amplitudes,)."""
        return self.G / self.G_max


@dataclass(frozen=True)
class PathCheckpoint:
    """Where a model's run along a path is saved, and the saved state it goes on from.

    For ``grainmech run --resume`` on a path test: the run is saved after each of the
    steps in ``after`` (the ends of the path's segments but the last) by
    ``save(k, state)``, ``state`` a picklable dict the model makes (its point, its
    recorded rows, the loop's running targets, :func:`follow_path`); ``resume`` is
    ``(k, state)`` of such a save: the run starts from it, after step ``k``, and its
    rows are the saved ones followed by the new ones.
    """

    after: tuple[int, ...] = ()
    save: Callable[[int, dict], None] | None = None
    resume: tuple[int, dict] | None = None


def path_saves(checkpoint: PathCheckpoint | None, state: Callable[[Any, PathTargets], dict]) -> dict:
    """:func:`follow_path`'s ``save_at`` and ``save`` for ``checkpoint`` (empty: nothing saved).

    ``state(point, targets)`` is the model's picklable state after a step; it is passed to
    ``checkpoint.save`` with the step.
    """
    if checkpoint is None or checkpoint.save is None:
        return {}
    save = checkpoint.save
    return {"save_at": tuple(checkpoint.after), "save": lambda k, point, targets: save(k, state(point, targets))}


def copied_rows(rows: dict[str, list]) -> dict[str, list]:
    """The rows a model recorded so far, as new lists (for a saved state)."""
    return {key: list(v) for key, v in rows.items()}


def restore_rows(rows: dict[str, list], saved: dict[str, list]) -> None:
    """Put the rows of a saved state (:func:`copied_rows`) into a run's own ``rows``."""
    for key, v in saved.items():
        rows[key][:] = v


def follow_path(point: SteppingPoint, path: LoadPath, record: Recorder, *,
                on_step: Callable[[int, int], None] | None = None,
                word_failure: Callable[[int, StepFailure], str] | None = None,
                check_targets: Callable[[int, np.ndarray, np.ndarray], None] | None = None,
                save_at: tuple[int, ...] = (),
                save: Callable[[int, SteppingPoint, PathTargets], None] | None = None,
                resume: tuple[int, PathTargets] | None = None,
                ) -> tuple[SteppingPoint, bool, Status, str]:
    """Drive ``point`` along ``path``; ``record(point, k)`` after the start (k = 0) and each step.

    Parameters
    ----------
    point : SteppingPoint
        The start state; its ``step(d_strain, stress_control, target)`` solves one step.
    path : LoadPath
    record : callable ``(point, k)``
        Called with the start state (``k = 0``) and after every step ``k`` that succeeded.
    on_step : callable ``(k, n)``, optional
        Progress: called after step ``k`` of ``n``.
    word_failure : callable ``(k, failure) -> str``, optional
        The message of a path that stopped at step ``k`` (1-based) with the
        :class:`StepFailure` ``failure``; default ``"step k: <cause>; results kept up to
        step k-1"``.
    check_targets : callable ``(k, stress_control, strain_targets)``, optional
        Called before step ``k`` (1-based) with its control mask and running strain
        targets; a model's range check: a :class:`StepFailure` it raises ends the path
        there, as a failed step does (the packing model's small-strain bound).
    save_at, save : tuple of int, callable ``(k, point, targets)``, optional
        After step ``k`` in ``save_at`` (not the last), ``save`` is called with the state
        and the running targets (:class:`PathCheckpoint`: a model saves them with its rows).
    resume : ``(k, targets)``, optional
        Go on from a saved state: ``point`` is the state after step ``k`` and ``targets``
        the running targets saved with it; ``record`` is not called for the start (the
        caller holds the rows up to step ``k``), the steps run from ``k + 1``.

    Returns
    -------
    (point, success, status, message)
        The last state reached, and how the path ended: ``"completed n steps"`` or the
        failure's message (``word_failure``).
    """
    if not isinstance(path, LoadPath):
        raise ParameterError("path", type(path).__name__, "must be a LoadPath")
    m = len(path)
    if resume is None:
        k0 = 0
        record(point, 0)
        targets = PathTargets(point.stress, point.strain)
    else:
        k0, targets = resume
        if not 0 <= k0 <= m:
            raise ParameterError("resume", k0, f"must be a step of the path (0-{m})")
    for k in range(k0, m):
        sc = np.asarray(path.stress_control[k], bool)
        new_t_stress, new_t_strain = targets.step(sc, path.increment[k], point.stress, point.strain)
        d_strain = np.where(sc, 0.0, new_t_strain - point.strain)
        try:
            if check_targets is not None:
                check_targets(k + 1, sc, new_t_strain)
            point = point.step(d_strain, sc, np.where(sc, new_t_stress, 0.0))
        except StepFailure as exc:
            message = (word_failure(k + 1, exc) if word_failure is not None
                       else f"step {k + 1}: {exc.cause}; results kept up to step {k}")
            return point, False, exc.status, message
        targets.reached(sc, new_t_stress, new_t_strain, point.stress, point.strain)
        record(point, k + 1)
        if on_step is not None:
            on_step(k + 1, m)
        if save is not None and k + 1 in save_at and k + 1 < m:
            save(k + 1, point, targets)
    return point, True, Status.DONE, f"completed {m} steps"


def cyclic_series(run_one: Callable[[LoadPath], DriverResult], amplitudes: ArrayLike,
                  g_max: Callable[[LoadPath], float], *, n_cycles: int = 2, steps_per_cycle: int = 80,
                  waveform: str = "triangle", constant: str = "stress",
                  progress: Callable[[int, float, Any], None] | None = None,
                  raise_on_failure: bool = True,
                  on_amplitude: Callable[[ModulusReduction], None] | None = None,
                  until: Callable[[float, DriverResult], str | None] | None = None,
                  on_stop: Callable[[float, str], None] | None = None) -> ModulusReduction:
    """Cyclic simple shear ``gamma_xz`` at each amplitude and the last cycle's secant G and damping.

    Parameters
    ----------
    run_one : callable ``(path) -> DriverResult``
        Runs one amplitude's path from the model's initial state.
    amplitudes : sequence of float
        Engineering shear strain amplitudes [-], each > 0.
    g_max : callable ``(path) -> float``
        The model's small-strain modulus for the path's control (called once, with the
        last path built) [Pa].
    n_cycles, steps_per_cycle, waveform, constant
        As :func:`grainmech.driver.cyclic_simple_shear`; the last cycle is analysed
        (:func:`loop_properties`: secant modulus, damping
        ``D = dW / (4 pi W)``, Kramer 1996 Sec. 6.4.2).
    progress : callable ``(index, amplitude, path)``, optional
        Called before each amplitude.
    raise_on_failure : bool
        If False, an amplitude that fails is recorded and the others still run (each
        starts from the model's initial state): the result has ``success`` False, a
        ``message`` naming every failed amplitude, ``G``/``damping``/``amplitude`` of the
        completed ones and ``results`` of every run in order (``run_amplitudes``).
        A run that ends :attr:`~grainmech.driver.base.Status.LIQUEFIED` (the DEM model at
        constant volume: the mean stress lost) is not a failure, whatever
        ``raise_on_failure``: it is the test's answer at that amplitude. It has no loop to
        analyse (no G, no damping); its message is in ``liquefied``, its steps in ``results``.
    on_amplitude : callable ``(ModulusReduction)``, optional
        Called after each completed amplitude with the series so far (a run stopped
        later can still write the finished amplitudes).
    until : callable ``(amplitude, result) -> str or None``, optional
        Called after each amplitude's run (with ``raise_on_failure`` False); a string ends
        the series there: the larger amplitudes are not run (they are left out of
        ``run_amplitudes``, for another model to run) and the message says why. The
        amplitudes run in the order given.
    on_stop : callable ``(amplitude, message)``, optional
        Called the moment an amplitude fails (with ``raise_on_failure`` False), before
        the next one runs: a long series reports a stop when it happens.

    Raises
    ------
    GrainmechError
        If an amplitude fails and ``raise_on_failure``.
    """
    amps = np.asarray(amplitudes, dtype=float)
    if amps.ndim != 1 or amps.size == 0 or np.any(amps <= 0) or not np.all(np.isfinite(amps)):
        raise ParameterError("amplitudes", amplitudes, "must be a non-empty list of positive strains")
    G, D, res, done = [], [], [], []
    failures: list[str] = []
    liquefied: list[tuple[float, str]] = []  # (amplitude, message) of runs that liquefied
    path = cyclic_simple_shear(float(amps[0]), n_cycles, steps_per_cycle, waveform, constant=constant)
    for i, a in enumerate(amps):
        path = cyclic_simple_shear(float(a), n_cycles, steps_per_cycle, waveform, constant=constant)
        if progress is not None:
            progress(i, float(a), path)
        r = run_one(path)
        res.append(r)
        if not r.success and int(r.status) == Status.LIQUEFIED:
            liquefied.append((float(a), r.message))
        elif not r.success:
            if raise_on_failure:
                raise GrainmechError(f"amplitude {a:g}: {r.message}")
            failures.append(f"amplitude {a:g}: {r.message}")
            if on_stop is not None:
                on_stop(float(a), r.message)
        else:
            last = slice(len(path) - steps_per_cycle, len(path) + 1)
            lp = loop_properties(r.strain[last, 4], r.stress[last, 4])
            G.append(lp.secant_modulus)
            D.append(lp.damping)
            done.append(float(a))
            if on_amplitude is not None:
                on_amplitude(ModulusReduction(np.array(done), np.array(G), np.array(D), float(g_max(path)),
                                              list(res), run_amplitudes=amps[:len(res)].copy(),
                                              liquefied=_named(liquefied)))
        why = until(float(a), r) if until is not None and i + 1 < amps.size else None
        if why:
            ended = f"amplitudes {[float(f'{x:.3g}') for x in amps[i + 1:]]} not run: {why}"
            break
    else:
        ended = ""
    message = "; ".join(failures) + (f" ({len(failures)} of {amps.size} amplitudes stopped, the others completed)"
                                      if failures and len(failures) < amps.size else "") if failures else "done"
    if liquefied:
        message += "; liquefied (the test's answer, no loop): " + ", ".join(f"amplitude {a:g}" for a, _ in liquefied)
    if ended:
        message = ended if message == "done" else f"{message}; {ended}"
    return ModulusReduction(np.array(done), np.array(G), np.array(D), float(g_max(path)), res, not failures, message,
                            run_amplitudes=amps[:len(res)].copy(), liquefied=_named(liquefied))


def _named(liquefied: list[tuple[float, str]]) -> tuple[str, ...]:
    """``ModulusReduction.liquefied``: ``"amplitude a: <message>"`` of each ``(a, message)``."""
    return tuple(f"amplitude {a:g}: {m}" for a, m in liquefied)

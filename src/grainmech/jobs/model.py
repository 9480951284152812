"""What every kinematic model of ``grainmech run`` shares: one run of a model to an outcome.

:func:`execute_model` runs a model's modulus-reduction series (cyclic simple shear) or its
path and turns the result into a :class:`~grainmech.outcomes.CyclicOutcome` or
:class:`~grainmech.outcomes.PathOutcome`; a model supplies its point and its two runs
(:class:`ModelRun`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.analysis.references import path_measures, reference_curves
from grainmech.driver.base import HandOver, KinematicModel
from grainmech.driver.loop import PathCheckpoint
from grainmech.driver.registry import resolve
from grainmech.io.records import RunRecords, amp_id
from grainmech.jobs.checks import (
    cyclic_envelope,
    empirical_gmax_check,
    envelope_check,
    grain_modulus_warning,
    last_cycle_quality,
    rearrangement_warnings,
    rearranging,
)
from grainmech.jobs.resume import listed, merged, reusable, saver
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, RunSpec
from grainmech.outcomes import (
    CyclicOutcome,
    PathOutcome,
    RunOutcome,
    curve_value_warnings,
    envelope_and_loop_warnings,
)

__all__ = ["ModelRun", "JobStep", "execute_model"]


@dataclass(frozen=True)
class JobStep:
    """Where a model stands in its run job (:func:`grainmech.jobs.run.execute_run`).

    Attributes
    ----------
    handed : HandOver or None
        The amplitudes an earlier model of the job left to this one, and why.
    later : tuple of KinematicModel
        The models that run after this one.
    early : object or None
        The DEM amplitudes started before the other models
        (:class:`grainmech.driver.dem.DemSeries`, :func:`grainmech.jobs.dem._start_dem_early`).
    records : RunRecords or None
        Where each finished amplitude or path is saved, and those an earlier run of the same
        config saved are taken up from (``grainmech run --resume``,
        :mod:`grainmech.jobs.resume`).
    """

    handed: HandOver | None = None
    later: tuple = ()
    early: Any = None
    records: RunRecords | None = None


@dataclass
class ModelRun:
    """One kinematic model at its initial state, ready for the test of a run (:func:`execute_model`).

    Attributes
    ----------
    model : KinematicModel
        The model (:data:`grainmech.driver.registry.MODELS`).
    point : object or None
        The initial state the outcome keeps (``None`` when there is none to keep).
    size : str
        What the model integrates over, for the progress lines (``"74 directions"``,
        ``"1000 grains"``).
    series : callable
        The model's modulus-reduction series of cyclic simple shear, called as
        ``series(amplitudes, n_cycles=, steps_per_cycle=, waveform=, constant=,
        progress=, raise_on_failure=False, on_amplitude=)`` (the keywords of
        :func:`grainmech.analysis.modulus_reduction`); returns a
        :class:`~grainmech.analysis.ModulusReduction`.
    path : callable
        ``path(load_path)``: the model's run along a mixed-control path (a
        :class:`~grainmech.driver.DriverResult`).
    void_ratio : float or None
        Void ratio of the input, for the comparison with Hardin & Richart (1963).
    details : dict
        What the outcome reports about the model's input (``RunOutcome.details``).
    finish : callable or None
        ``finish(results)`` adds to ``details`` what the runs tell (after their time is taken).
    so_far : callable or None
        ``so_far(results)``: what the details of the amplitudes done so far add (the
        outcome a run interrupted from here on writes).
    until : callable or None
        ``until(amplitude, result)``: where the series ends at a hand-over
        (:func:`grainmech.jobs.handover.series_end`), passed to ``series``.
    in_order : bool
        ``series`` runs the amplitudes in increasing order, whatever order it is given
        them in (the DEM model's workers); otherwise in the order given.
    planned : callable or None
        ``planned(n)``: the series will run ``n`` amplitudes (those not taken up from an
        earlier run), for the progress lines' count and time left.
    saves_segments : bool
        ``path(load_path, checkpoint=...)`` takes a
        :class:`~grainmech.driver.loop.PathCheckpoint`: the path is saved at the end of
        each of its segments and a resumed run goes on from the last one saved (every
        model); otherwise a resumed path runs from its beginning.
    """

    model: KinematicModel
    point: Any
    size: str
    series: Callable[..., Any]
    path: Callable[..., Any]
    void_ratio: float | None = None
    details: dict = field(default_factory=dict)
    finish: Callable[[list], None] | None = None
    so_far: Callable[[list], dict] | None = None
    until: Callable[[float, Any], str | None] | None = None
    in_order: bool = False
    planned: Callable[[int], None] | None = None
    saves_segments: bool = False


def execute_model(model: ModelRun, spec: RunSpec, say: Callable[[str], None],
                  step: JobStep | None = None) -> RunOutcome:
    """Run the test of ``spec`` with ``model``: a modulus-reduction series or a path.

    Cyclic simple shear: every amplitude of ``spec.amplitudes_of(model.model, handed)``
    (its own and those an earlier model handed over, ``step.handed``) from the initial
    state (a progress line before each; ``say.amplitudes_done`` after each, see
    :func:`_amplitudes_so_far`), then the :class:`~grainmech.outcomes.CyclicOutcome` with
    its checks (envelope of sands, loop quality, Gmax against the grains' modulus and
    Hardin & Richart). A path: one run, a :class:`~grainmech.outcomes.PathOutcome` with
    :func:`~grainmech.jobs.checks.envelope_check` of its stresses. ``seconds`` is the time
    of the runs alone.

    With ``step.records`` every finished amplitude (or path) is saved as it finishes, and
    those saved by an earlier run of the same config are taken up instead of run
    (:mod:`grainmech.jobs.resume`; ``say.reused(model, amplitudes)`` hears which, else a
    progress line says it).
    """
    step = step or JobStep()
    handed, records = step.handed, step.records
    m = model.model
    method = m.name
    if spec.kind == CYCLIC_SIMPLE_SHEAR:
        amps = spec.amplitudes_of(m, handed)
        kept, todo = reusable(records, method, sorted(amps) if model.in_order else amps, model.until)
        if kept:
            _say_reused(say, m, [a for a in amps if amp_id(a) in kept])

        def each(i: int, a: float, path: Any) -> None:
            say(f"[{method} {i + 1}/{len(todo)}] cyclic simple shear, amplitude {a:.3g} "
                f"({len(path)} steps, {model.size})")

        hook = getattr(say, "handed_over", None)
        if hook is not None and handed is not None:
            hook(list(handed.amplitudes), handed.why)  # kept for the message of a run interrupted from here on
        t0 = time.perf_counter()
        told = _amplitudes_so_far(say, spec, model, amps, t0, handed)
        save = saver(records, method)
        ordered = sorted(amps) if model.in_order else amps  # the order of the model's series
        form: dict[str, Any] = {"n_cycles": spec.n_cycles, "steps_per_cycle": spec.steps_per_cycle_of(m),
                                "waveform": spec.waveform, "constant": spec.constant}

        def so_far(mr: Any) -> None:
            save(mr)
            if told is not None:
                told(merged(ordered, kept, mr, until=model.until, complete=False, **form) if kept else mr)

        mr = None
        if todo and model.planned is not None:
            model.planned(len(todo))
        if todo:
            mr = model.series(todo, **form, progress=each, raise_on_failure=False,
                              on_amplitude=so_far if records is not None else told,
                              on_stop=lambda a, why: say(f"[{method}] amplitude {a:.3g} stopped: {why}"),
                              **({"until": model.until} if model.until is not None else {}))
            save(mr)
        if kept:
            mr = merged(ordered, kept, mr, until=model.until, **form)
        assert mr is not None  # amps is not empty (jobs.run runs no model without amplitudes)
        seconds = time.perf_counter() - t0
        if model.finish is not None:
            model.finish(list(mr.results))
        out = _cyclic_outcome(spec, m, mr, seconds, model.point, model.void_ratio, model.details, amps)
        done = getattr(say, "amplitudes_done", None)
        if done is not None:  # the model's own end (its stop reasons), for a run interrupted after it
            done(out)
        return out
    t0 = time.perf_counter()
    got = records.get(method) if records is not None else None
    if got is not None:
        r = got[0]
        _say_reused(say, m, None)
    else:
        cp = _path_checkpoint(model, spec, records)
        say(f"[{method}] path: {len(spec.path)} steps, {model.size}" + _path_start(model, spec, records, cp))
        r = model.path(spec.path, checkpoint=cp) if cp is not None else model.path(spec.path)
        if records is not None:
            records.save(method, None, r)
    seconds = time.perf_counter() - t0
    if model.finish is not None:
        model.finish([r])
    return PathOutcome(kind=spec.kind, pressure=spec.pressure, results=[r], success=r.success,
                       message=r.message, seconds=seconds, point=model.point,
                       warnings=_input_warnings(spec, m),
                       envelope=envelope_check(r.stress), method=method, details=model.details,
                       measures=path_measures(r))


def _path_checkpoint(model: ModelRun, spec: RunSpec, records: RunRecords | None) -> PathCheckpoint | None:
    """Where ``model``'s path is saved (the end of each segment but the last) and, resumed, its last save.

    None without records, for a model whose path is not saved at its segments' ends
    (``ModelRun.saves_segments``), or a path of one segment with nothing to take up.
    """
    if records is None or not model.saves_segments:
        return None
    name = model.model.name
    after = tuple(int(k) for k in spec.segment_ends[:-1])
    resume = records.step(name)
    if not after and resume is None:
        return None

    def save(k: int, state: dict) -> None:
        records.save_step(name, k, state)

    return PathCheckpoint(after=after, save=save, resume=resume)


def _path_start(model: ModelRun, spec: RunSpec, records: RunRecords | None, cp: PathCheckpoint | None) -> str:
    """What the path's progress line adds on a resumed run: where the path goes on from."""
    if records is None or not records.resume:
        return ""
    if cp is not None and cp.resume is not None:
        k = cp.resume[0]
        done = sum(1 for e in spec.segment_ends if e <= k)
        return (f" (going on from step {k + 1}: steps 1-{k}, its first {done} segment(s), taken up from the "
                "interrupted run)")
    if model.saves_segments:
        return " (from its beginning: no segment of it was finished)"
    return f" (from its beginning: the {model.model.title}'s path is saved only when it is finished)"


def _say_reused(say: Callable[[str], None], m: KinematicModel, amplitudes: list[float] | None) -> None:
    """Tell ``say.reused(model, amplitudes)`` (or a progress line) what was taken up (None: the model's path)."""
    hook = getattr(say, "reused", None)
    if hook is not None:
        hook(m.name, amplitudes)
    elif amplitudes is None:
        say(f"[{m.name}] reused the finished path of the {m.title}")
    else:
        say(f"[{m.name}] reused {len(amplitudes)} finished amplitude(s) of the {m.title}: {listed(amplitudes)}")


def _input_warnings(spec: RunSpec, m: KinematicModel) -> list:
    """The warnings of the analytical microstructure's input: a model's that needs no grains."""
    return [] if m.needs_grains else list(spec.warnings)


def _cyclic_outcome(spec: RunSpec, model: str | KinematicModel, mr: Any, seconds: float, point: Any,
                    void_ratio: float | None, details: dict | None = None,
                    amplitudes: list[float] | None = None) -> CyclicOutcome:
    """The :class:`~grainmech.outcomes.CyclicOutcome` of a model's modulus-reduction series ``mr``.

    ``amplitudes``: the list the series ran (default ``spec.amplitudes_of(model)``).
    """
    m = resolve(model)
    method = m.name
    listed = spec.amplitudes_of(m) if amplitudes is None else amplitudes
    amps = np.asarray(mr.amplitude, dtype=float)
    envelope = [cyclic_envelope(r.stress) for r in mr.results]
    quality = [last_cycle_quality(r, spec.steps_per_cycle_of(m)) for r in mr.completed]
    details = dict(details or {})
    if m.fixed_geometry:
        details["rearranging"] = rearranging(m, spec.constant, mr.completed)
    with np.errstate(divide="ignore", invalid="ignore"):  # a Gmax of 0 or NaN: flagged, not a warning of NumPy's
        ratio = np.asarray(mr.G, dtype=float) / float(mr.G_max)
    reference = dict(spec.reference or {})
    emp = empirical_gmax_check(mr.G_max, void_ratio, spec.pressure, m)
    return CyclicOutcome(
        kind=spec.kind, pressure=spec.pressure, results=list(mr.results), success=mr.success,
        message=mr.message, seconds=seconds, point=point, method=method, details=details,
        warnings=_input_warnings(spec, m)
        + grain_modulus_warning(mr.G_max, spec.law_of(m))
        + envelope_and_loop_warnings(m, amps, envelope, quality)
        + curve_value_warnings(method, amps, ratio, mr.damping)
        + rearrangement_warnings(m, spec.constant, amps, mr.completed)
        + [f"[{method}] {m}; no loop to analyse at this amplitude (its steps are written)"
           for m in mr.liquefied],
        amplitudes=amps, G=np.asarray(mr.G, dtype=float),
        damping=np.asarray(mr.damping, dtype=float), G_max=float(mr.G_max),
        reference=reference, empirical_G_max=emp,
        references=(reference_curves(amps, spec.pressure, reference, float(mr.G_max), emp)
                    if len(mr.G) else None),
        run_amplitudes=(np.asarray(mr.run_amplitudes, dtype=float) if mr.run_amplitudes is not None else
                        np.asarray(listed[:len(mr.results)], dtype=float)),
        envelope=envelope, loop_quality=quality, keep_beyond_envelope=spec.keep_beyond_envelope)


def _amplitudes_so_far(say: Any, spec: RunSpec, model: ModelRun, amplitudes: list[float], t0: float,
                       handed: HandOver | None = None) -> Callable[[Any], None] | None:
    """``on_amplitude`` of a modulus-reduction series that tells ``say.amplitudes_done``.

    If the progress callback ``say`` has a method ``amplitudes_done(outcome)``, it
    receives after each completed amplitude the :class:`CyclicOutcome` of the amplitudes
    done so far (``success`` False and ``message`` "interrupted after k of n amplitudes"
    until the last), and the model's final outcome when its series ends (its own message:
    why it stopped): what a caller can still write if the run is interrupted. A
    ``handed_over(amplitudes, why)`` method of ``say`` hears, when a model that takes over
    starts, which amplitudes were handed to it (``handed``) and why. ``None`` (no hook)
    otherwise.
    """
    done = getattr(say, "amplitudes_done", None)
    if done is None:
        return None
    n = len(amplitudes)

    def each(mr: Any) -> None:
        k = len(mr.G)
        if k < n:
            mr = dataclasses.replace(mr, success=False, message=f"interrupted after {k} of {n} amplitudes")
        det = dict(model.details or {})
        if model.so_far is not None:
            det.update(model.so_far(mr.results))
        if handed is not None:  # the hand-over note the finished outcome gets (jobs.dem)
            det["notes"] = [*det.get("notes", []), *([handed.note] if handed.note not in det.get("notes", []) else [])]
        done(_cyclic_outcome(spec, model.model, mr, time.perf_counter() - t0, model.point, model.void_ratio,
                             det or None, amplitudes))

    return each


def _max_residual(results: list) -> float:
    """Largest out-of-balance ratio of any step (``PackingResult.residual``)."""
    vals = [float(np.max(r.residual)) for r in results if len(getattr(r, "residual", ()))]
    return max(vals) if vals else float("nan")

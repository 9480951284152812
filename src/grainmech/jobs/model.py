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

from grainmech.jobs.checks import (
    cyclic_envelope,
    empirical_gmax_check,
    envelope_check,
    grain_modulus_warning,
    last_cycle_quality,
    rearrangement_warnings,
    rearranging,
)
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, RunSpec
from grainmech.outcomes import (
    CyclicOutcome,
    PathOutcome,
    RunOutcome,
    curve_value_warnings,
    envelope_and_loop_warnings,
)

__all__ = ["ModelRun", "execute_model"]


@dataclass
class ModelRun:
    """One kinematic model at its initial state, ready for the test of a run (:func:`execute_model`).

    Attributes
    ----------
    method : str
        The model (:data:`~grainmech.jobs.spec.RUN_METHODS`).
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
    """

    method: str
    point: Any
    size: str
    series: Callable[..., Any]
    path: Callable[[Any], Any]
    void_ratio: float | None = None
    details: dict = field(default_factory=dict)
    finish: Callable[[list], None] | None = None


def execute_model(model: ModelRun, spec: RunSpec, say: Callable[[str], None]) -> RunOutcome:
    """Run the test of ``spec`` with ``model``: a modulus-reduction series or a path.

    Cyclic simple shear: every amplitude of ``spec.amplitudes_of(model.method)`` from the
    initial state (a progress line before each; ``say.amplitudes_done`` after each, see
    :func:`_amplitudes_so_far`), then the :class:`~grainmech.outcomes.CyclicOutcome` with
    its checks (envelope of sands, loop quality, Gmax against the grains' modulus and
    Hardin & Richart). A path: one run, a :class:`~grainmech.outcomes.PathOutcome` with
    :func:`~grainmech.jobs.checks.envelope_check` of its stresses. ``seconds`` is the
    time of the runs alone.
    """
    method = model.method
    if spec.kind == CYCLIC_SIMPLE_SHEAR:
        amps = spec.amplitudes_of(method)

        def each(i: int, a: float, path: Any) -> None:
            say(f"[{method} {i + 1}/{len(amps)}] cyclic simple shear, amplitude {a:.3g} "
                f"({len(path)} steps, {model.size})")

        handed = getattr(say, "handed_over", None)
        if handed is not None and method == "dem" and spec.dem_handed:
            handed(*spec.dem_handed)  # kept for the message of a run interrupted from here on
        t0 = time.perf_counter()
        mr = model.series(amps, n_cycles=spec.n_cycles,
                          steps_per_cycle=spec.dem_steps_per_cycle if method == "dem" else spec.steps_per_cycle,
                          waveform=spec.waveform, constant=spec.constant, progress=each, raise_on_failure=False,
                          on_amplitude=_amplitudes_so_far(say, spec, method, model.point, model.void_ratio, t0,
                                                          model.details))
        seconds = time.perf_counter() - t0
        if model.finish is not None:
            model.finish(list(mr.results))
        out = _cyclic_outcome(spec, method, mr, seconds, model.point, model.void_ratio, model.details)
        done = getattr(say, "amplitudes_done", None)
        if done is not None:  # the model's own end (its stop reasons), for a run interrupted after it
            done(out)
        return out
    say(f"[{method}] path: {len(spec.path)} steps, {model.size}")
    t0 = time.perf_counter()
    r = model.path(spec.path)
    seconds = time.perf_counter() - t0
    if model.finish is not None:
        model.finish([r])
    return PathOutcome(kind=spec.kind, pressure=spec.pressure, results=[r], success=r.success,
                       message=r.message, seconds=seconds, point=model.point,
                       warnings=list(spec.warnings) if method == "affine" else [],
                       envelope=envelope_check(r.stress), method=method, details=model.details)


def _cyclic_outcome(spec: RunSpec, method: str, mr: Any, seconds: float, point: Any,
                    void_ratio: float | None, details: dict | None = None) -> CyclicOutcome:
    """The :class:`~grainmech.outcomes.CyclicOutcome` of a model's modulus-reduction series ``mr``."""
    amps = np.asarray(mr.amplitude, dtype=float)
    envelope = [cyclic_envelope(r.stress) for r in mr.results]
    spc = spec.dem_steps_per_cycle if method == "dem" else spec.steps_per_cycle
    quality = [last_cycle_quality(r, spc) for r in mr.completed]
    details = dict(details or {})
    if method == "packing":
        details["rearranging"] = rearranging(method, spec.constant, mr.completed)
    with np.errstate(divide="ignore", invalid="ignore"):  # a Gmax of 0 or NaN: flagged, not a warning of NumPy's
        ratio = np.asarray(mr.G, dtype=float) / float(mr.G_max)
    return CyclicOutcome(
        kind=spec.kind, pressure=spec.pressure, results=list(mr.results), success=mr.success,
        message=mr.message, seconds=seconds, point=point, method=method, details=details,
        warnings=(list(spec.warnings) if method == "affine" else [])
        + grain_modulus_warning(mr.G_max, spec.law if method == "affine" else spec.packing_law)
        + envelope_and_loop_warnings(method, amps, envelope, quality)
        + curve_value_warnings(method, amps, ratio, mr.damping)
        + rearrangement_warnings(method, spec.constant, amps, mr.completed)
        + [f"[{method}] {m}; no loop to analyse at this amplitude (its steps are written)"
           for m in mr.liquefied],
        amplitudes=amps, G=np.asarray(mr.G, dtype=float),
        damping=np.asarray(mr.damping, dtype=float), G_max=float(mr.G_max),
        reference=dict(spec.reference or {}),
        empirical_G_max=empirical_gmax_check(mr.G_max, void_ratio, spec.pressure, method),
        run_amplitudes=(np.asarray(mr.run_amplitudes, dtype=float) if mr.run_amplitudes is not None else
                        np.asarray(spec.amplitudes_of(method)[:len(mr.results)], dtype=float)),
        envelope=envelope, loop_quality=quality, keep_beyond_envelope=spec.keep_beyond_envelope)


def _amplitudes_so_far(say: Any, spec: RunSpec, method: str, point: Any, void_ratio: float | None,
                       t0: float, details: dict | None = None) -> Callable[[Any], None] | None:
    """``on_amplitude`` of a modulus-reduction series that tells ``say.amplitudes_done``.

    If the progress callback ``say`` has a method ``amplitudes_done(outcome)``, it
    receives after each completed amplitude the :class:`CyclicOutcome` of the amplitudes
    done so far (``success`` False and ``message`` "interrupted after k of n amplitudes"
    until the last), and the model's final outcome when its series ends (its own message:
    why it stopped): what a caller can still write if the run is interrupted. A
    ``handed_over(amplitudes, why)`` method of ``say`` hears, when the DEM model starts,
    which amplitudes the packing model handed to it and why. ``None`` (no hook) otherwise.
    """
    done = getattr(say, "amplitudes_done", None)
    if done is None:
        return None
    n = len(spec.amplitudes_of(method))

    def each(mr: Any) -> None:
        k = len(mr.G)
        if k < n:
            mr = dataclasses.replace(mr, success=False, message=f"interrupted after {k} of {n} amplitudes")
        det = dict(details or {})
        if method == "packing":
            det["max_residual"] = _max_residual(mr.results)
        if method == "dem" and spec.dem_handed:  # the hand-over note the finished outcome gets (jobs.dem)
            note = f"amplitudes {[float(f'{a:.3g}') for a in spec.dem_handed[0]]} were handed over from the " \
                   f"packing model: {spec.dem_handed[1]}"
            det["notes"] = [*det.get("notes", []), *([note] if note not in det.get("notes", []) else [])]
        done(_cyclic_outcome(spec, method, mr, time.perf_counter() - t0, point, void_ratio, det or None))

    return each


def _max_residual(results: list) -> float:
    """Largest out-of-balance ratio of any step (``PackingResult.residual``)."""
    vals = [float(np.max(r.residual)) for r in results if len(getattr(r, "residual", ()))]
    return max(vals) if vals else float("nan")

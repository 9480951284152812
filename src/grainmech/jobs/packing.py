"""The packing model in ``grainmech run`` (``[model] method = "packing"``) and a packing's Gmax.

Every grain of the packing in force and moment equilibrium at every step
(:mod:`grainmech.driver.packing`); :func:`packing_gmax` is its small-strain modulus alone
(``[model] gmax_packing`` beside the affine model).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from grainmech.analysis import condensed_modulus
from grainmech.driver import cyclic_simple_shear
from grainmech.driver.packing import PackingOptions, PackingPoint, packing_modulus_reduction, run_packing
from grainmech.errors import GrainmechError
from grainmech.jobs.checks import REARRANGEMENT_DP, empirical_gmax_check
from grainmech.jobs.model import ModelRun, _max_residual, execute_model
from grainmech.jobs.progress import _step_reporter
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, RunSpec
from grainmech.outcomes import CyclicOutcome, PathOutcome, RunOutcome, run_mean_stress_change

__all__ = ["PACKING_STRESS_TOLERANCE", "packing_gmax", "cyclic_control"]


#: relative difference between a packing's stress and the run's mean stress below which
#: the packing is used as it is (otherwise it is brought to the stress first)
PACKING_STRESS_TOLERANCE = 5e-3


def _execute_packing(spec: RunSpec, say: Callable[[str], None]) -> RunOutcome:
    """The packing driver (:mod:`grainmech.driver.packing`) on the packing of ``spec.grains``.

    Every grain is in force and moment equilibrium at every step.
    """
    src = spec.grains
    if src is None:
        raise ValueError("the packing model needs a packing (RunSpec.grains is None)")
    net = src.network
    opts = PackingOptions(law_backend="auto", **spec.packing_options)
    t0 = time.perf_counter()
    say(f"[packing] {src.label}: {net.n_particles} grains, {net.n_contacts} contacts, "
        f"void ratio {src.void_ratio:.3f}; equilibrium check and elastic factorisation")
    cyclic = spec.kind == CYCLIC_SIMPLE_SHEAR
    try:
        pt = PackingPoint.from_network(net, spec.packing_law, options=opts, rolling=spec.rolling)
        p0 = float(np.mean(pt.stress[:3]))
        if abs(p0 / spec.pressure - 1.0) > PACKING_STRESS_TOLERANCE:
            say(f"[packing] bringing the packing from p = {p0:.4g} Pa to {spec.pressure:.4g} Pa "
                "(stress-controlled, every grain in equilibrium)")
            pt = PackingPoint.at_stress(net, spec.packing_law, spec.pressure, options=opts, rolling=spec.rolling)
    except GrainmechError as exc:  # the other models' results still get written
        cls = CyclicOutcome if cyclic else PathOutcome
        return cls(kind=spec.kind, pressure=spec.pressure, results=[], success=False,
                   message=f"preparing the packing failed: {exc}", seconds=time.perf_counter() - t0,
                   point=None, method="packing",
                   details={"packing": src.label, "void_ratio": src.void_ratio})
    on_step = _step_reporter(say, "[packing]", len(spec.amplitudes_of("packing")) if cyclic else None)
    details = {"packing": src.label, "grains": int(pt.n_grains), "rattlers": int(pt.n_rattlers),
               "contacts_tracked": int(pt.n_contacts), "contacts_closed": int(np.sum(pt.initially_closed)),
               "void_ratio": src.void_ratio, "input_mean_stress_Pa": p0, "notes": list(pt.notes),
               "prepare_seconds": time.perf_counter() - t0}
    if cyclic and spec.packing_amplitudes is not None:
        amps = spec.amplitudes_of("packing")
        others = [a for a in spec.amplitudes if a not in amps]
        details["amplitudes_note"] = (
            f"run at model.packing_amplitudes = {[float(f'{a:.3g}') for a in amps]}"
            + (f"; test.amplitudes {[float(f'{a:.3g}') for a in others]} were not run with this model"
               if others else ""))

    def path(load_path: Any) -> Any:
        return run_packing(pt, load_path, opts, on_step=on_step)

    def finish(results: list) -> None:
        details["max_residual"] = _max_residual(results)

    # the reports use no tangent row (tangent="none": 1.7 s less on 'dense')
    series = partial(packing_modulus_reduction, pt, options=opts, on_step=on_step, tangent="none",
                     until=_hand_over(spec) if spec.one_list else None)
    model = ModelRun("packing", pt, f"{pt.n_grains} grains", series=series, path=path, void_ratio=src.void_ratio,
                     details=details, finish=finish)
    return execute_model(model, spec, say)


def packing_gmax(spec: RunSpec, say: Callable[[str], None]) -> dict:
    """Small-strain shear modulus of the packing ``spec.gmax_grains`` (``[model] gmax_packing``).

    The packing driver's ``Gmax`` (:func:`grainmech.driver.packing.packing_modulus_reduction`):
    ``C_55`` of :attr:`PackingPoint.elastic_tangent` (every grain in force and moment
    equilibrium, every closed contact at its no-slip stiffness, Mindlin & Deresiewicz
    1953), condensed with the test's control (``sigma_zz`` free at constant stress), at
    the run's mean stress, with the run's contact law; beside it Hardin & Richart's
    empirical value at the packing's own void ratio (:func:`empirical_gmax_check`). Only
    the small-strain modulus: no cyclic run of the packing (``method = "packing"`` does
    that, in minutes rather than seconds).

    Returns a JSON-ready dict: ``packing``, ``void_ratio``, ``grains``, ``G_max_Pa``,
    ``empirical_G_max`` (or ``error`` when the packing cannot be prepared).
    """
    src = spec.gmax_grains
    if src is None:
        raise ValueError("spec.gmax_grains is None")
    say(f"[packing Gmax] {src.label}: small-strain shear modulus with every grain in equilibrium")
    out: dict[str, Any] = {"packing": src.label, "void_ratio": src.void_ratio}
    # the NumPy law: a few evaluations only, and no compilation of the packing driver's
    # kernel variant in the first run
    opts = PackingOptions(law_backend="numpy", tangent="none")
    try:
        pt = PackingPoint.from_network(src.network, spec.law, options=opts, rolling=spec.rolling)
        p0 = float(np.mean(pt.stress[:3]))
        if abs(p0 / spec.pressure - 1.0) > PACKING_STRESS_TOLERANCE:
            pt = PackingPoint.at_stress(src.network, spec.law, spec.pressure, options=opts, rolling=spec.rolling)
        g = condensed_modulus(pt.elastic_tangent, 4, [bool(b) for b in cyclic_control(spec.constant)])
    except GrainmechError as exc:
        out["error"] = f"preparing the packing failed: {exc}"
        return out
    out.update(grains=int(pt.n_grains), G_max_Pa=float(g),
               empirical_G_max=empirical_gmax_check(g, src.void_ratio, spec.pressure, "packing"))
    return out


def cyclic_control(constant: str) -> np.ndarray:
    """Stress-controlled components (bool (6,)) of cyclic simple shear at ``constant`` stress or volume."""
    return np.asarray(cyclic_simple_shear(1e-6, 1, 8, constant=constant).stress_control[0], dtype=bool)


def _hand_over(spec: RunSpec) -> Callable[[float, Any], str | None]:
    """With one amplitude list and the DEM model after the packing model: where the packing model's series ends.

    The amplitudes run from the smallest; the first one the packing model stops on, or
    whose grains rearrange (its constant-volume cycles change the mean stress by more than
    ``REARRANGEMENT_DP``, where the fixed geometry's loops were 7-20 % off the DEM model's,
    ``docs/packing-driver.md``), ends the series: it and the larger ones go to the DEM
    model (:func:`grainmech.jobs.dem._hand_to_dem`), so that no amplitude is run twice.
    """
    def until(a: float, r: Any) -> str | None:
        if not r.success:
            return f"the packing model stopped at {a:.3g}; the DEM model runs them"
        if spec.constant == "volume" and abs(run_mean_stress_change(r)) > REARRANGEMENT_DP:
            return (f"at {a:.3g} the grains rearrange (mean stress changed by more than "
                    f"{100 * REARRANGEMENT_DP:g} % at constant volume); the DEM model runs them")
        return None

    return until

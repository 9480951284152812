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
from grainmech.driver.packing import PackingOptions, PackingPoint
from grainmech.driver.packing.model import PACKING
from grainmech.errors import GrainmechError
from grainmech.jobs.checks import empirical_gmax_check
from grainmech.jobs.handover import series_end, taker
from grainmech.jobs.model import JobStep, ModelRun, _max_residual, execute_model
from grainmech.jobs.progress import _step_reporter
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, RunSpec
from grainmech.outcomes import CyclicOutcome, PathOutcome, RunOutcome

__all__ = ["PACKING_STRESS_TOLERANCE", "packing_gmax", "cyclic_control"]


#: relative difference between a packing's stress and the run's mean stress below which
#: the packing is used as it is (otherwise it is brought to the stress first)
PACKING_STRESS_TOLERANCE = 5e-3


def _execute_packing(spec: RunSpec, say: Callable[[str], None], step: JobStep | None = None) -> RunOutcome:
    """The packing driver (:mod:`grainmech.driver.packing`) on the packing of ``spec.grains``.

    Every grain is in force and moment equilibrium at every step. With one amplitude list
    and a model after it that takes over (``step.later``), the series ends at the first
    amplitude it stops on or whose grains rearrange (:func:`grainmech.jobs.handover.series_end`).
    """
    step = step or JobStep()
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
        pt = PackingPoint.from_network(net, spec.grain_law, options=opts, rolling=spec.rolling)
        p0 = float(np.mean(pt.stress[:3]))
        if abs(p0 / spec.pressure - 1.0) > PACKING_STRESS_TOLERANCE:
            say(f"[packing] bringing the packing from p = {p0:.4g} Pa to {spec.pressure:.4g} Pa "
                "(stress-controlled, every grain in equilibrium)")
            pt = PackingPoint.at_stress(net, spec.grain_law, spec.pressure, options=opts, rolling=spec.rolling)
    except GrainmechError as exc:  # the other models' results still get written
        cls = CyclicOutcome if cyclic else PathOutcome
        return cls(kind=spec.kind, pressure=spec.pressure, results=[], success=False,
                   message=f"preparing the packing failed: {exc}", seconds=time.perf_counter() - t0,
                   point=None, method=PACKING.name,
                   details={"packing": src.label, "void_ratio": src.void_ratio})
    on_step = _step_reporter(say, "[packing]", len(spec.amplitudes_of(PACKING)) if cyclic else None)
    details = {"packing": src.label, **PACKING.details(pt), "void_ratio": src.void_ratio,
               "input_mean_stress_Pa": p0, "prepare_seconds": time.perf_counter() - t0}
    if src.description:
        details["packing_description"] = src.description
    if cyclic and spec.packing_amplitudes is not None:
        amps = spec.amplitudes_of(PACKING)
        others = [a for a in spec.amplitudes if a not in amps]
        details["amplitudes_note"] = (
            f"run at model.packing_amplitudes = {[float(f'{a:.3g}') for a in amps]}"
            + (f"; test.amplitudes {[float(f'{a:.3g}') for a in others]} were not run with this model"
               if others else ""))

    def so_far(results: list) -> dict:
        return {"max_residual": _max_residual(results)}

    def finish(results: list) -> None:
        details.update(so_far(results))

    to = taker(step.later)
    # the reports use no tangent row (tangent="none": 1.7 s less on 'dense')
    series = partial(PACKING.series, pt, options=opts, on_step=on_step, tangent="none")
    model = ModelRun(PACKING, pt, f"{pt.n_grains} grains", series=series,
                     path=partial(PACKING.path, pt, options=opts, on_step=on_step), void_ratio=src.void_ratio,
                     details=details, finish=finish, so_far=so_far,
                     until=series_end(spec, PACKING, to) if spec.one_list and to is not None else None,
                     planned=on_step.planned, saves_segments=True)
    return execute_model(model, spec, say, step)


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
               empirical_G_max=empirical_gmax_check(g, src.void_ratio, spec.pressure, PACKING))
    return out


def cyclic_control(constant: str) -> np.ndarray:
    """Stress-controlled components (bool (6,)) of cyclic simple shear at ``constant`` stress or volume."""
    return np.asarray(cyclic_simple_shear(1e-6, 1, 8, constant=constant).stress_control[0], dtype=bool)

"""``grainmech run``: every kinematic model of a config on one test, and its scalar outputs."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from grainmech.conventions import ORDER_3D, von_mises
from grainmech.driver.affine.model import AFFINE
from grainmech.driver.base import HandOver, KinematicModel
from grainmech.driver.dem.model import DEM
from grainmech.driver.packing.model import PACKING
from grainmech.io.records import RunRecords
from grainmech.jobs.affine import _execute_affine
from grainmech.jobs.dem import _execute_dem, _start_dem_early
from grainmech.jobs.handover import hand_over, stop_hint, taker
from grainmech.jobs.model import JobStep
from grainmech.jobs.packing import _execute_packing
from grainmech.jobs.run_config import prepare_run
from grainmech.jobs.schedule import compile_ahead
from grainmech.jobs.spec import CYCLIC_SIMPLE_SHEAR, RunSpec
from grainmech.outcomes import CyclicOutcome, RunComparison, RunOutcome

__all__ = ["execute_run", "compute_run", "run_scalars", "reference_strain", "MODEL_JOBS"]

#: the job of every registered model (:data:`grainmech.driver.registry.MODELS`): reads its
#: start from the spec, runs it through :func:`grainmech.jobs.model.execute_model`
MODEL_JOBS: dict[KinematicModel, Callable[..., RunOutcome]] = {
    AFFINE: _execute_affine, PACKING: _execute_packing, DEM: _execute_dem}


def execute_run(spec: RunSpec, progress: Callable[[str], None] | None = None,
                records: RunRecords | None = None) -> RunOutcome | RunComparison:
    """Drive the material point of every method of ``spec``.

    ``progress(message)`` is called before each run. ``records``: every finished
    amplitude or path is saved there as it finishes, and those an earlier run of the same
    config saved are taken up (:mod:`grainmech.jobs.resume`).

    Returns a :class:`CyclicOutcome` or a :class:`PathOutcome` for one method, a
    :class:`RunComparison` of them for several.
    """
    say = progress or (lambda msg: None)
    outs: list[RunOutcome] = []
    early = _start_dem_early(spec, say, records)
    try:
        _run_methods(spec, say, outs, early, records)
    finally:
        if early is not None:
            early.close()
    return outs[0] if len(outs) == 1 else RunComparison(outs)


def _run_methods(spec: RunSpec, say: Callable[[str], None], outs: list, early: Any = None,
                 records: RunRecords | None = None) -> None:
    """Run every model of ``spec`` in order, appending its outcome to ``outs``.

    The hand-over is a step of its own: a fixed-geometry model's outcome yields a
    :class:`~grainmech.driver.base.HandOver` (:func:`grainmech.jobs.handover.hand_over`)
    that the model taking over receives; with one amplitude list and nothing handed over,
    that model is not run. ``early``: the DEM amplitudes started before the other models.
    """
    handed: HandOver | None = None
    models = spec.models
    for i, m in enumerate(models):
        later = models[i + 1:]
        step = JobStep(handed=handed if m.takes_over else None, later=later, early=early, records=records)
        if m.takes_over:
            handed = None  # received
        if spec.kind == CYCLIC_SIMPLE_SHEAR and not spec.amplitudes_of(m, step.handed):
            src = next((p.title for p in models[:i] if p.fixed_geometry), "earlier model")
            say(f"[{m.name}] not run: the {src} ran every amplitude within its range (one amplitude list: "
                "each amplitude is run by one model)")
            continue
        # a packing run to come: its kernels compile in a second process meanwhile when
        # this one compiles (the first run after installing)
        with compile_ahead(spec, later):
            outs.append(MODEL_JOBS[m](spec, say, step))
        if not m.fixed_geometry:
            continue
        to = taker(later)
        handed = hand_over(spec, outs[-1], to) if to is not None else None
        if to is not None and handed is not None:
            say(f"[{m.name}] the {to.title} runs {list(handed.amplitudes)} too: {handed.why}")
        hint = stop_hint(spec, outs[-1], later)
        if hint:
            outs[-1].warnings.append(hint)


def compute_run(cfg: dict, progress: Callable[[str], None] | None = None,
                records: RunRecords | None = None) -> RunOutcome | RunComparison:
    """Config dict -> driver result (see :func:`execute_run`).

    No file writing but the ``records`` of finished amplitudes (``grainmech run``'s
    ``OUTDIR/resume``), which are checked against the config after it is read
    (:meth:`~grainmech.io.records.RunRecords.start`).
    """
    spec = prepare_run(cfg)
    if records is not None:
        records.start()
    return execute_run(spec, progress, records)


def reference_strain(amplitudes: Any, g_ratio: Any, level: float = 0.5) -> float:
    """Strain where G/Gmax falls to ``level`` (0.5: the reference strain gamma_r).

    Linear interpolation of G/Gmax in log(gamma) between the first pair of measured
    amplitudes (sorted) that brackets ``level``; NaN if the curve does not cross it.
    """
    a = np.asarray(amplitudes, dtype=float)
    r = np.asarray(g_ratio, dtype=float)
    order = np.argsort(a)
    a, r = a[order], r[order]
    for k in range(len(a) - 1):
        r0, r1 = r[k], r[k + 1]
        if np.isfinite(r0) and np.isfinite(r1) and (r0 - level) * (r1 - level) <= 0 and r0 != r1:
            t = (r0 - level) / (r0 - r1)
            return float(np.exp(np.log(a[k]) + t * (np.log(a[k + 1]) - np.log(a[k]))))
    return float("nan")


def _invariants(s: np.ndarray) -> tuple[float, float]:
    """Mean stress p and von Mises q = sqrt(3 J2) of a Voigt 6-vector (xx yy zz yz xz xy)."""
    return float(np.mean(s[:3])), float(von_mises(s))


def run_scalars(out: RunOutcome | RunComparison) -> dict[str, Any]:
    """Scalar outputs of a driver result.

    Cyclic simple shear: ``G_max [Pa]``, ``gamma_r`` (strain where G/Gmax = 0.5,
    interpolated in log strain; NaN if not reached), ``G/Gmax@<amplitude>`` and
    ``damping@<amplitude>`` for every amplitude, ``success``, ``message``.
    Path: final ``p [Pa]`` and ``q [Pa]``, the final stress and strain components,
    ``dissipation [J/m^3]``, ``n_steps``, ``success``, ``message``.
    Several methods (:class:`RunComparison`): each method's columns prefixed
    ``"<method>: "``, then the overall ``success`` and ``message``.
    """
    if isinstance(out, RunComparison):
        both: dict[str, Any] = {f"{o.method}: {k}": v for o in out.outcomes for k, v in run_scalars(o).items()}
        both["success"] = bool(out.success)
        both["message"] = str(out.message)
        return both
    row: dict[str, Any] = {}
    if isinstance(out, CyclicOutcome):
        gmax = float(out.G_max)
        amps = np.asarray(out.amplitudes, dtype=float)
        ratio = out.G_ratio
        damp = np.asarray(out.damping, dtype=float)
        row["G_max [Pa]"] = gmax
        row["gamma_r"] = reference_strain(amps, ratio) if len(amps) else float("nan")
        for a, g, d in zip(amps, ratio, damp):
            row[f"G/Gmax@{a:g}"] = float(g)
            row[f"damping@{a:g}"] = float(d)
    else:
        r = out.results[0]
        s, e = np.asarray(r.stress[-1], dtype=float), np.asarray(r.strain[-1], dtype=float)
        p, q = _invariants(s)
        row["p [Pa]"] = p
        row["q [Pa]"] = q
        for lab, v in zip(ORDER_3D, s):
            row[f"stress_{lab} [Pa]"] = float(v)
        for lab, v in zip(ORDER_3D, e):
            row[f"strain_{lab}"] = float(v)
        row["dissipation [J/m^3]"] = float(r.dissipation[-1])
        row["n_steps"] = int(r.n_steps)
    row["success"] = bool(out.success)
    row["message"] = str(out.message)
    return row

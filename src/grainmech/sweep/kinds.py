"""Run kinds of a sweep: ``config dict -> dict of scalar outputs``.

Each kind pairs the parser of :mod:`grainmech.jobs` (``prepare``: cheap, validates the
config) with a function computing one point's scalar outputs (``evaluate``). The
functions are module-level so process workers can unpickle them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech import jobs
from grainmech.outcomes import CyclicOutcome, RunComparison

__all__ = ["Kind", "SWEEP_KINDS", "run_point", "stiffness_point", "run_kind_point", "dem_point", "envelope_columns",
           "recommended_columns"]


def stiffness_point(cfg: dict, base_dir: str | Path | None = None) -> dict[str, Any]:
    """Scalar outputs of a ``stiffness`` config (:func:`grainmech.jobs.stiffness_scalars`)."""
    return jobs.stiffness_scalars(jobs.execute_stiffness(jobs.prepare_stiffness(cfg, base_dir)))


def run_kind_point(cfg: dict, base_dir: str | Path | None = None) -> dict[str, Any]:
    """Scalar outputs of a ``run`` (driver) config.

    :func:`grainmech.jobs.run_scalars`, then the envelope and value flags of every cyclic
    model's amplitudes (:func:`envelope_columns`) and, with several models, the recommended
    curve (:func:`recommended_columns`).
    """
    out = jobs.execute_run(jobs.prepare_run(cfg, base_dir))
    row = jobs.run_scalars(out)
    outs = list(out.outcomes) if isinstance(out, RunComparison) else [out]
    for o in outs:
        if isinstance(o, CyclicOutcome):
            pre = f"{o.method}: " if len(outs) > 1 else ""
            row.update({pre + k: v for k, v in envelope_columns(o).items()})
    if isinstance(out, RunComparison):
        row.update(recommended_columns(out))
    return row


def envelope_columns(o: CyclicOutcome) -> dict[str, Any]:
    """The envelope flags of a cyclic outcome as sweep columns.

    ``beyond_envelope@<amplitude>`` (1: a state of that amplitude's run beyond the envelope
    of sands, the amplitude ``grainmech run`` marks ``BEYOND ENVELOPE``: its G/Gmax and
    damping are not predictions for a sand), ``value_flag@<amplitude>`` (1: G/Gmax above 1 or
    not positive, damping outside [0, 1), a NaN), ``beyond_envelope_amplitudes`` (how many)
    and ``gamma_r_within_envelope`` (the reference strain from the amplitudes within the
    envelope only; ``gamma_r`` takes them all).
    """
    amps = np.asarray(o.amplitudes, dtype=float)
    beyond = o.beyond_envelope
    problems = o.value_problems
    row: dict[str, Any] = {}
    for a, b, p in zip(amps, beyond, problems):
        row[f"beyond_envelope@{a:g}"] = int(b)
        row[f"value_flag@{a:g}"] = int(p is not None)
    row["beyond_envelope_amplitudes"] = int(np.sum(beyond))
    keep = ~beyond
    row["gamma_r_within_envelope"] = (jobs.reference_strain(amps[keep], o.G_ratio[keep]) if keep.any()
                                      else float("nan"))
    return row


def recommended_columns(out: RunComparison) -> dict[str, Any]:
    """The recommended curve of a run with several models as sweep columns (none without one).

    ``recommended: G_max [Pa]``, ``recommended: G_max_model`` and per amplitude
    ``recommended: G/Gmax@<a>``, ``recommended: damping@<a>``, ``recommended: model@<a>`` and
    ``recommended: flags@<a>`` (:func:`grainmech.outcomes.recommended_curve`).
    """
    rec = out.recommended
    if rec is None:
        return {}
    row: dict[str, Any] = {"recommended: G_max [Pa]": rec.G_max, "recommended: G_max_model": rec.G_max_model}
    for a, r, d, m, f in zip(rec.amplitudes, rec.G_ratio, rec.damping, rec.models, rec.flags):
        row.update({f"recommended: G/Gmax@{a:g}": float(r), f"recommended: damping@{a:g}": float(d),
                    f"recommended: model@{a:g}": m, f"recommended: flags@{a:g}": ";".join(f)})
    return row


def dem_point(cfg: dict, base_dir: str | Path | None = None) -> dict[str, Any]:
    """Scalar outputs of a ``dem`` config (:func:`grainmech.jobs.dem_scalars`)."""
    return jobs.dem_scalars(jobs.execute_dem(jobs.prepare_dem(cfg, base_dir)))


def _prepare(name: str) -> Callable[[dict, Any], Any]:
    def prepare(cfg: dict, base_dir: Any = None) -> Any:
        return getattr(jobs, f"prepare_{name}")(cfg, base_dir)
    return prepare


@dataclass(frozen=True)
class Kind:
    """A run kind: ``prepare(cfg, base_dir)`` validates, ``evaluate(cfg, base_dir)`` computes."""

    name: str
    prepare: Callable[[dict, Any], Any]
    evaluate: Callable[[dict, Any], dict]
    #: outputs drawn against every numeric input in the summary plot
    headline: tuple[str, ...]
    #: most points per scheduler task: a dask task costs ~3 ms of scheduling, as much as
    #: a whole stiffness point, so cheap kinds are sent in batches
    batch: int = 1


SWEEP_KINDS: dict[str, Kind] = {
    "stiffness": Kind("stiffness", _prepare("stiffness"), stiffness_point, ("K_hill [Pa]", "G_hill [Pa]"),
                      batch=32),
    "run": Kind("run", _prepare("run"), run_kind_point, ("G_max [Pa]", "gamma_r", "p [Pa]", "q [Pa]")),
    "dem": Kind("dem", _prepare("dem"), dem_point, ("z", "p [Pa]", "K_hill_relaxed [Pa]", "G_hill_relaxed [Pa]")),
}


def run_point(task: tuple[str, dict, str | None]) -> dict[str, Any]:
    """Worker entry point: ``(kind, config, base_dir) -> scalar outputs``."""
    kind, cfg, base_dir = task
    return SWEEP_KINDS[kind].evaluate(cfg, base_dir)

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

from grainmech import jobs

__all__ = ["Kind", "SWEEP_KINDS", "run_point", "stiffness_point", "run_kind_point", "dem_point"]


def stiffness_point(cfg: dict, base_dir: str | Path | None = None) -> dict[str, Any]:
    """Scalar outputs of a ``stiffness`` config (:func:`grainmech.jobs.stiffness_scalars`)."""
    return jobs.stiffness_scalars(jobs.execute_stiffness(jobs.prepare_stiffness(cfg, base_dir)))


def run_kind_point(cfg: dict, base_dir: str | Path | None = None) -> dict[str, Any]:
    """Scalar outputs of a ``run`` (driver) config (:func:`grainmech.jobs.run_scalars`)."""
    return jobs.run_scalars(jobs.execute_run(jobs.prepare_run(cfg, base_dir)))


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

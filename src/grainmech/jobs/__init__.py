"""Config dict -> results, for every run kind (one implementation for the CLI and sweeps).

Each run kind is split in two steps so that a config can be checked cheaply before any
expensive work (used by :mod:`grainmech.sweep` to reject misspelt keys up front):

* ``prepare_<kind>(cfg, base_dir=None)`` reads and validates the config (strict keys,
  units at the edge) and returns a small spec object; it raises
  :class:`~grainmech.errors.ConfigError` naming the key and value.
* ``execute_<kind>(spec, ...)`` does the computation and returns a typed result.

``compute_<kind>(cfg)`` is both in one call, and ``<kind>_scalars(result)`` flattens a
result into a dict of scalar outputs (column name with unit -> number, bool or str), the
row of a sweep table.

Kinds, one module each: ``stiffness`` (:mod:`~grainmech.jobs.stiffness`, ``grainmech
stiffness``), ``run`` (:mod:`~grainmech.jobs.run`, ``grainmech run``: cyclic simple shear
or a mixed-control path with the affine, packing and DEM models of
:mod:`~grainmech.jobs.affine`, :mod:`~grainmech.jobs.packing`, :mod:`~grainmech.jobs.dem`
through :func:`~grainmech.jobs.model.execute_model`, dispatched through the model registry
:mod:`grainmech.driver.registry`, the hand-over between models a step of its own,
:mod:`~grainmech.jobs.handover`; its config read by
:mod:`~grainmech.jobs.run_config` into a :class:`~grainmech.jobs.spec.RunSpec`), ``dem``
(:mod:`~grainmech.jobs.network`, ``grainmech dem``: measures of a contact network; the
config names the files in a ``[network]`` table), ``contact``
(:mod:`~grainmech.jobs.contact`, ``grainmech contact``: one contact along a
force/displacement path) and ``pack`` (:mod:`~grainmech.jobs.pack`). Plausibility
checks are in :mod:`~grainmech.jobs.checks`, progress timing in
:mod:`~grainmech.jobs.progress`, compile-ahead scheduling in
:mod:`~grainmech.jobs.schedule`. Each ``execute_`` returns a typed result of
:mod:`grainmech.outcomes` (:class:`StiffnessOutcome`, :class:`CyclicOutcome` or
:class:`PathOutcome`, :class:`DemOutcome`, :class:`ContactOutcome`); files are written by
:mod:`grainmech.io.reports`.

Every name is imported from its module on first use (``from grainmech.jobs import
compute_stiffness`` does not import the drivers).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["prepare_stiffness", "execute_stiffness", "compute_stiffness", "stiffness_scalars",
           "prepare_run", "execute_run", "compute_run", "run_scalars", "reference_strain",
           "dem_options", "prepare_dem", "execute_dem", "compute_dem", "dem_scalars",
           "prepare_contact", "execute_contact", "compute_contact", "StiffnessOutcome", "RunOutcome",
           "CyclicOutcome", "PathOutcome", "RunComparison", "DemOutcome", "ContactOutcome",
           "RUN_TEST_KINDS", "RUN_METHODS", "PackingSource"]

#: name -> module that defines it (imported by :func:`__getattr__` on first use); every
#: name ``grainmech.jobs`` held as one module stays importable from here
_LAZY: dict[str, str] = {
    **dict.fromkeys(("StiffnessOutcome", "RunOutcome", "CyclicOutcome", "PathOutcome", "RunComparison",
                     "DemOutcome", "ContactOutcome", "envelope_and_loop_warnings", "packing_gmax_line"),
                    "grainmech.outcomes"),
    **dict.fromkeys(("CYCLIC_SIMPLE_SHEAR", "RUN_TEST_KINDS", "RUN_METHODS", "GRAIN_METHODS", "RunSpec",
                     "PackingSource", "_read_amplitudes"), "grainmech.jobs.spec"),
    **dict.fromkeys(("SMALL_STRAIN_LIMIT", "SPHERE_COORDINATION_RANGE", "GMAX_FLAG_FACTOR", "input_warnings",
                     "grain_modulus_warning", "empirical_gmax_check", "envelope_check", "cyclic_envelope",
                     "last_cycle_quality", "REARRANGEMENT_DP", "rearranging", "rearrangement_warnings"),
                    "grainmech.jobs.checks"),
    **dict.fromkeys(("PACKING_PROGRESS_EVERY", "_step_reporter", "time"), "grainmech.jobs.progress"),
    **dict.fromkeys(("ModelRun", "JobStep", "execute_model", "_cyclic_outcome", "_amplitudes_so_far",
                     "_max_residual"), "grainmech.jobs.model"),
    **dict.fromkeys(("hand_over", "series_end", "stop_hint", "taker"), "grainmech.jobs.handover"),
    "_execute_affine": "grainmech.jobs.affine",
    **dict.fromkeys(("PACKING_STRESS_TOLERANCE", "_execute_packing", "packing_gmax", "cyclic_control"),
                    "grainmech.jobs.packing"),
    **dict.fromkeys(("DEM_SETTING_KEYS", "DEM_PROGRESS_EVERY", "_check_dem", "_dem_settings", "_read_dem_keys",
                     "_read_dem_path_keys", "_check_dem_states", "_start_dem_early", "_execute_dem",
                     "_dem_reporter"), "grainmech.jobs.dem"),
    **dict.fromkeys(("prepare_run", "_read_methods", "_GmaxKey", "_read_grains", "_segments"),
                    "grainmech.jobs.run_config"),
    "compile_ahead": "grainmech.jobs.schedule",
    **dict.fromkeys(("execute_run", "compute_run", "run_scalars", "reference_strain", "MODEL_JOBS", "_run_methods",
                     "_invariants"), "grainmech.jobs.run"),
    **dict.fromkeys(("StiffnessSpec", "prepare_stiffness", "execute_stiffness", "compute_stiffness",
                     "stiffness_scalars", "_ENGINEERING_3D", "_ENGINEERING_2D"), "grainmech.jobs.stiffness"),
    **dict.fromkeys(("DemSpec", "dem_options", "prepare_dem", "execute_dem", "compute_dem", "dem_scalars",
                     "_names"), "grainmech.jobs.network"),
    **dict.fromkeys(("ContactSpec", "prepare_contact", "execute_contact", "compute_contact"),
                    "grainmech.jobs.contact"),
    "pack_job": "grainmech.jobs.pack",
}


def __getattr__(name: str) -> Any:
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'grainmech.jobs' has no attribute {name!r}")
    value = getattr(importlib.import_module(mod), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

"""Compile-ahead scheduling of ``grainmech run``: a later model's kernels compile while an earlier model runs.

The first run after installing compiles every numba kernel it uses. When the affine
model runs before the packing model in one job and numba compiles during the affine
run, :func:`grainmech.driver.packing.compiling_ahead` compiles the packing model's
kernels in a second process meanwhile (``docs/performance.md``, "First run"); the
DEM model's worker processes start early for the same reason
(:func:`grainmech.jobs.dem._start_dem_early`).
"""

from __future__ import annotations

import contextlib
from typing import Any

from grainmech.driver.packing import compiling_ahead
from grainmech.driver.packing.model import PACKING
from grainmech.jobs.spec import RunSpec

__all__ = ["compile_ahead"]


def compile_ahead(spec: RunSpec, later: tuple) -> Any:
    """Context manager around a model's run: the packing model's kernels compile meanwhile if it comes ``later``.

    Parameters
    ----------
    spec : RunSpec
        The run (its packing law and the packing's number of contacts size the kernels).
    later : tuple of KinematicModel
        The models that run after this one.

    Returns
    -------
    contextlib.AbstractContextManager
        :func:`~grainmech.driver.packing.compiling_ahead`, or a context that does nothing
        when no packing run follows.
    """
    if PACKING in later and spec.grain_law is not None and spec.grains is not None:
        return compiling_ahead(spec.grain_law, spec.grains.network.n_contacts)
    return contextlib.nullcontext()

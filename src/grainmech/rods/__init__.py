"""Rod packings (2D arrays of parallel rods, seed Ch. 5-6).

Rod packings (2D arrays of parallel rods, seed Ch. 5-6): regular and random packings as
contact sets, and the directional shear box (seed Sec. 5.3) on them.

* :mod:`~grainmech.rods.regular` - :class:`PeriodicRods`, :class:`RodContactSet`, the
  packings A-F (:data:`PACKINGS`, :func:`regular_packing`);
* :mod:`~grainmech.rods.shear_box` - :func:`shear_box_stiffness` (seed Eq. 3.8, 3.17,
  2.26), :func:`directional` (Eq. 6.1, 6.2 corrected), :func:`increment_strains`;
* :mod:`~grainmech.rods.random_packing` - generated random packings like the seed's
  (:func:`~grainmech.rods.random_packing.packing`) and their strains
  (:func:`~grainmech.rods.random_packing.strains`).
"""

from __future__ import annotations

from grainmech.rods.regular import PACKINGS, ROD, PeriodicRods, RodContactSet, packing_geometry, regular_packing
from grainmech.rods.shear_box import directional, increment_strains, shear_box_stiffness

__all__ = ["ROD", "RodContactSet", "PeriodicRods", "PACKINGS", "packing_geometry", "regular_packing",
           "shear_box_stiffness", "directional", "increment_strains"]

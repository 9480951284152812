"""Rod arrays (2D arrays of parallel rods, the seed's rod packings, Ch. 5-6).

Rod arrays (2D arrays of parallel rods, seed Ch. 5-6): regular and random arrays as
contact sets, and the directional shear box (seed Sec. 5.3) on them. ("Packing" in
grainmech names a packing of grains; the old names of these arrays, ``PACKINGS``,
``regular_packing``, ``packing_geometry`` and :mod:`grainmech.rods.random_packing`, work
for one release with a :class:`DeprecationWarning`.)

* :mod:`~grainmech.rods.regular` - :class:`PeriodicRods`, :class:`RodContactSet`, the
  arrays A-F (:data:`ARRAYS`, :func:`regular_array`);
* :mod:`~grainmech.rods.shear_box` - :func:`shear_box_stiffness` (seed Eq. 3.8, 3.17,
  2.26), :func:`directional` (Eq. 6.1, 6.2 corrected), :func:`increment_strains`;
* :mod:`~grainmech.rods.random_arrays` - generated random arrays like the seed's
  (:func:`~grainmech.rods.random_arrays.random_array`) and their strains
  (:func:`~grainmech.rods.random_arrays.strains`).
"""

from __future__ import annotations

from typing import Any

from grainmech._deprecated import renamed_attribute
from grainmech.rods.regular import (
    ARRAYS,
    ROD,
    PeriodicRods,
    RodContactSet,
    array_geometry,
    packing_geometry,
    regular_array,
    regular_packing,
)
from grainmech.rods.shear_box import directional, increment_strains, shear_box_stiffness

__all__ = ["ROD", "RodContactSet", "PeriodicRods", "ARRAYS", "array_geometry", "regular_array",
           "packing_geometry", "regular_packing", "shear_box_stiffness", "directional", "increment_strains"]


def __getattr__(name: str) -> Any:
    # ``PACKINGS``: the old name of :data:`ARRAYS` (one release, with a warning)
    return renamed_attribute(__name__, name, {"PACKINGS": "ARRAYS"}, globals())

"""Material-point driver: contact set + contact law + loading path.

Public API
----------
:class:`MaterialPoint` (``isotropic``, ``at_stress`` with ``initial="state-estimate"`` or
``"path-following"``, ``from_forces``), :func:`run` -> :class:`DriverResult`,
:class:`SolverOptions`, and the path builders of :mod:`grainmech.driver.paths`.
See ``docs/models/affine.md``. The affine model (the seed's material point) is in
:mod:`grainmech.driver.affine`, the packing model in :mod:`grainmech.driver.packing`, the
DEM model in :mod:`grainmech.driver.dem`.
"""

from grainmech.contact.interface import ContactLaw, make_law
from grainmech.driver.affine.point import MaterialPoint, evaluate, geometric_stiffness, geometry, tangent
from grainmech.driver.affine.solver import DriverResult, SolverOptions, modulus_reduction, run
from grainmech.driver.paths import (
    COMPONENTS,
    Control,
    LoadPath,
    concatenate,
    constant_mean_stress,
    cycles,
    cyclic_simple_shear,
    cyclic_triaxial,
    fig610_path,
    fig610_stress,
    isotropic_compression,
    parse_mask,
    segment,
    simple_shear,
    triaxial,
)

__all__ = [
    "COMPONENTS", "Control", "ContactLaw", "DriverResult", "LoadPath", "MaterialPoint",
    "SolverOptions", "concatenate", "constant_mean_stress", "cycles", "cyclic_simple_shear",
    "cyclic_triaxial", "evaluate", "fig610_path", "fig610_stress", "geometric_stiffness", "geometry",
    "isotropic_compression",
    "make_law", "modulus_reduction", "parse_mask", "run", "segment", "simple_shear", "tangent", "triaxial",
]

"""Fabric of granular packings: contact-normal densities, fabric tensors, packing density.

Implements seed Chapter 4 (Sec. 4.1): the 3D spherical-harmonic density (Eq. 4.7, 4.15),
the 2D Fourier density (Eq. 4.9, 4.34), fabric and coefficient tensors (Eq. 4.6, 4.10,
4.11; Kanatani 1984), fitting to measured normals, quadrature rules for the stiffness
integral (Eq. 2.41), and the packing density / coordination correlations (Eq. 4.1-4.5,
6.4).  See ``docs/fabric.md``.

Main entry points
-----------------
``SphericalDensity.from_seed(a20, a22, b22)``, ``FourierDensity.from_seed(a2, b2, a4, b4)``,
``isotropic(dim)``, ``density.directions(extra_degree) -> (normals, weights)``,
``fit_density(normals, order)``, ``fabric_tensor(normals, rank)``.
"""

from __future__ import annotations

import numpy as np

from grainmech.errors import ParameterError
from grainmech.fabric import _checks
from grainmech.fabric._base import NEGATIVE_TOL, DensityBase, DensityExtremum
from grainmech.fabric.coordination import (
    CORRELATIONS,
    NOMINAL_VOID_RATIO_RANGE,
    CorrelationRangeWarning,
    contact_ends_per_volume,
    contacts_per_volume,
    coordination_chang,
    coordination_field,
    coordination_filep,
    coordination_number,
    coordination_smith,
    coordination_yanagisawa,
    particles_per_volume,
    porosity,
    void_ratio_chang,
    void_ratio_from_porosity,
)
from grainmech.fabric.fit import DensityFit, NegativeDensityWarning, fabric_tensor, fit_density
from grainmech.fabric.fourier import FourierDensity
from grainmech.fabric.harmonics import (
    SphericalDensity,
    n_coefficients_3d,
    sh_degrees_orders,
    sh_index,
)
from grainmech.fabric.quadrature import (
    LEBEDEV_NEGATIVE_WEIGHT_ORDERS,
    LEBEDEV_ORDERS,
    LEBEDEV_POINTS,
    circle_rule,
    lebedev_order,
    sphere_rule,
    unit_rule,
)
from grainmech.fabric.tensors import (
    Anisotropy,
    anisotropy,
    deviatoric,
    fabric_from_phi,
    isotropic_moment,
    kanatani_factor,
    phi_from_fabric,
    rotate_tensor,
    symmetrize,
    trace,
)


def isotropic(dim: int, order: int = 0) -> SphericalDensity | FourierDensity:
    """Uniform contact-normal density ``1/(4 pi)`` (dim 3) or ``1/(2 pi)`` (dim 2).

    Parameters
    ----------
    dim : {3, 2}
    order : int, default 0
        Even order of the (all-zero) expansion; 0 gives the cheapest quadrature.
    """
    dim = _checks.as_dim(dim)
    cls = SphericalDensity if dim == 3 else FourierDensity
    return cls.isotropic(order)


def density_from_fabric_tensor(N: object, allow_negative: bool = False
                               ) -> SphericalDensity | FourierDensity:
    """Density of order ``rank(N)`` with fabric tensor ``N`` (2D or 3D from N's shape)."""
    A = np.asarray(N, dtype=float)
    dim = A.shape[0] if A.ndim else 0
    cls = SphericalDensity if dim == 3 else FourierDensity if dim == 2 else None
    if cls is None:
        raise ParameterError("N", f"array of shape {A.shape}", "must be (d, ..., d) with d = 2 or 3")
    return cls.from_fabric_tensor(A, allow_negative=allow_negative)


__all__ = [
    "Anisotropy",
    "CORRELATIONS",
    "CorrelationRangeWarning",
    "DensityBase",
    "DensityExtremum",
    "DensityFit",
    "FourierDensity",
    "LEBEDEV_NEGATIVE_WEIGHT_ORDERS",
    "LEBEDEV_ORDERS",
    "LEBEDEV_POINTS",
    "NEGATIVE_TOL",
    "NOMINAL_VOID_RATIO_RANGE",
    "NegativeDensityWarning",
    "SphericalDensity",
    "anisotropy",
    "circle_rule",
    "contact_ends_per_volume",
    "contacts_per_volume",
    "coordination_chang",
    "coordination_field",
    "coordination_filep",
    "coordination_number",
    "coordination_smith",
    "coordination_yanagisawa",
    "density_from_fabric_tensor",
    "deviatoric",
    "fabric_from_phi",
    "fabric_tensor",
    "fit_density",
    "isotropic",
    "isotropic_moment",
    "kanatani_factor",
    "lebedev_order",
    "n_coefficients_3d",
    "particles_per_volume",
    "phi_from_fabric",
    "porosity",
    "rotate_tensor",
    "sh_degrees_orders",
    "sh_index",
    "sphere_rule",
    "symmetrize",
    "trace",
    "unit_rule",
    "void_ratio_chang",
    "void_ratio_from_porosity",
]

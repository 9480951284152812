"""Elasticity of a stiffness tensor.

Elasticity of a stiffness tensor: checks, compliance, engineering constants, directional
moduli, averages, rotations and material-symmetry classification.

Modules: :mod:`~grainmech.elasticity.conversions` (input handling, checks, compliance,
Kelvin moduli, rotations), :mod:`~grainmech.elasticity.constants` (engineering and
isotropic constants, Voigt/Reuss/Hill averages, constructors),
:mod:`~grainmech.elasticity.directional` (directional moduli) and
:mod:`~grainmech.elasticity.symmetry` (symmetry class, natural frame, projection).

All functions take a stiffness in the library conventions of :mod:`grainmech.conventions`:

* 3D: a 6x6 *Voigt* matrix in the order ``(xx, yy, zz, yz, xz, xy)`` that maps the
  engineering strain ``(e_xx, e_yy, e_zz, 2 e_yz, 2 e_xz, 2 e_xy)`` to the stress, or a
  ``(3, 3, 3, 3)`` tensor ``C_ijkl``;
* 2D: a 3x3 Voigt matrix in the order ``(xx, yy, xy)`` or a ``(2, 2, 2, 2)`` tensor.  A 2D
  stiffness is treated as the 2D material's own stiffness (for a plane-strain stiffness
  the 2D "Young's modulus" is therefore the plane-strain modulus, e.g. ``E / (1 - nu^2)``
  for an isotropic solid).

Internally the *Mandel* (Kelvin) form is used wherever a rotation or a norm is needed: it
is an isometry, so the Frobenius norm of a 6x6 Mandel matrix equals the norm
``sqrt(C_ijkl C_ijkl)`` of the tensor, and a rotation acts as ``M' = K M K^T`` with an
orthogonal 6x6 ``K``.

Units: moduli come out in the units of the stiffness; Poisson's ratios and coupling
coefficients are dimensionless.

References
----------
Nye, J. F. (1957). *Physical Properties of Crystals*. Oxford: Clarendon Press.
Hill, R. (1952). The elastic behaviour of a crystalline aggregate. *Proc. Phys. Soc. A*
65, 349-354.
Lekhnitskii, S. G. (1981). *Theory of Elasticity of an Anisotropic Body*. Moscow: Mir.
Cowin, S. C. & Mehrabadi, M. M. (1987). On the identification of material symmetry for
anisotropic elastic materials. *Q. J. Mech. Appl. Math.* 40, 451-476.
Mehrabadi, M. M. & Cowin, S. C. (1990). Eigentensors of linear anisotropic elastic
materials. *Q. J. Mech. Appl. Math.* 43, 15-41.
Forte, S. & Vianello, M. (1996). Symmetry classes for elasticity tensors. *J. Elasticity*
43, 81-108.
Ting, T. C. T. (1996). *Anisotropic Elasticity: Theory and Applications*. Oxford UP.
Chang, C. S. (1988). The seed report, Section 4.3 and Table 1 (material symmetries).
"""

from __future__ import annotations

from grainmech.elasticity.constants import (
    EngineeringConstants,
    IsotropicConstants,
    PlaneEngineeringConstants,
    bulk_modulus,
    condensed_modulus,
    engineering_constants,
    isotropic_constants,
    isotropic_stiffness,
    orthotropic_stiffness,
    shear_modulus,
    transversely_isotropic_stiffness,
)
from grainmech.elasticity.conversions import (
    check_stiffness,
    compliance,
    contracted_tensors,
    kelvin_moduli,
    rotate_stiffness,
    rotation_about,
)
from grainmech.elasticity.directional import directional_poisson, directional_shear, directional_young
from grainmech.elasticity.symmetry import (
    N_INDEPENDENT,
    SEED_NAMES,
    SYMMETRY_CLASSES_2D,
    SYMMETRY_CLASSES_3D,
    SymmetryClass,
    symmetric_projection,
    symmetry_class,
)

__all__ = [
    "SYMMETRY_CLASSES_3D",
    "SYMMETRY_CLASSES_2D",
    "SEED_NAMES",
    "N_INDEPENDENT",
    "check_stiffness",
    "compliance",
    "kelvin_moduli",
    "contracted_tensors",
    "EngineeringConstants",
    "PlaneEngineeringConstants",
    "engineering_constants",
    "directional_young",
    "directional_poisson",
    "directional_shear",
    "bulk_modulus",
    "shear_modulus",
    "condensed_modulus",
    "IsotropicConstants",
    "isotropic_constants",
    "isotropic_stiffness",
    "transversely_isotropic_stiffness",
    "orthotropic_stiffness",
    "rotation_about",
    "rotate_stiffness",
    "SymmetryClass",
    "symmetry_class",
    "symmetric_projection",
]

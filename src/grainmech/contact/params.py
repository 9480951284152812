"""Parameters of the contact laws: frozen dataclasses that validate themselves.

Every class checks its fields in ``__post_init__`` and raises
:class:`~grainmech.errors.ParameterError` (a ``ValueError``) whose message names the field
and its value. Units: any consistent system (SI in the examples); the command line
converts quantities with units before building these objects.

Classes
-------
Hertz
    Elastic spheres (or a sphere on a flat) of possibly different radii and materials;
    normal law of Hertz (seed Eq. 3.1–3.7). Frictionless when used on its own.
HertzMindlin
    Hertz + Mindlin's no-slip tangential stiffness ``8 G* a`` (seed Eq. 3.11–3.12 with
    theta = 1) capped by Coulomb friction (the "HM no-slip" model of Di Renzo & Di Maio
    2004).
MindlinDeresiewicz
    Hertz + the Mindlin–Deresiewicz hysteretic tangential law for arbitrary histories of
    normal and tangential load (seed Eq. 3.9–3.16; Thornton & Randall 1988).
LinearSpring
    Linear normal and tangential springs with a Coulomb cap (Cundall & Strack 1979).
Cylinder
    Line contact of two parallel cylinders (rods): normal stiffness of seed Eq. 3.8 with
    the yield-reduced equivalent shear modulus, shear stiffness of seed Eq. 3.17, made
    hysteretic by the same Masing/Thornton–Randall rules as the sphere law.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from grainmech.contact.geometry import (
    cylinder_normal_stiffness,
    hertz_normal_stiffness,
    mindlin_tangential_stiffness_from_force,
)
from grainmech.errors import ParameterError

__all__ = [
    "Hertz",
    "HertzMindlin",
    "MindlinDeresiewicz",
    "LinearSpring",
    "Cylinder",
    "ContactParams",
]

#: default number of nested load reversals a hysteretic contact can remember
DEFAULT_MAX_REVERSALS = 16


def _as_float(name: str, value: Any) -> float:
    if isinstance(value, bool) or isinstance(value, str):
        raise ParameterError(name, value, "must be a number")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, value, "must be a number") from None
    if math.isnan(out):
        raise ParameterError(name, value, "must not be NaN")
    return out


def _positive(name: str, value: Any, *, allow_inf: bool = False) -> float:
    v = _as_float(name, value)
    if not v > 0.0:
        raise ParameterError(name, value, "must be positive")
    if math.isinf(v) and not allow_inf:
        raise ParameterError(name, value, "must be finite")
    return v


def _poisson(name: str, value: Any) -> float:
    v = _as_float(name, value)
    if not (-1.0 < v < 0.5):
        raise ParameterError(name, value, "Poisson's ratio must lie in the open interval (-1, 0.5)")
    return v


def _friction(name: str, value: Any, *, allow_inf: bool) -> float:
    v = _as_float(name, value)
    if v < 0.0:
        raise ParameterError(name, value, "friction coefficient must be >= 0")
    if math.isinf(v) and not allow_inf:
        raise ParameterError(name, value, "must be finite (use HertzMindlin for infinitely rough contacts)")
    return v


def _max_reversals(name: str, value: Any) -> int:
    if isinstance(value, bool) or not hasattr(value, "__index__"):
        raise ParameterError(name, value, "must be an integer")
    v = operator.index(value)
    if v < 1 or v > 4096:
        raise ParameterError(name, value, "must be between 1 and 4096")
    return v


@dataclass(frozen=True)
class Hertz:
    """Two elastic spheres in normal contact (Hertz; seed Eq. 3.1–3.7).

    Parameters
    ----------
    shear_modulus : float
        Shear modulus ``G1`` of body 1 [Pa].
    poisson : float
        Poisson's ratio ``nu1`` of body 1, in (-1, 0.5).
    radius1 : float
        Radius ``R1`` of body 1 [m].
    radius2 : float, optional
        Radius ``R2`` of body 2 [m]; ``None`` means equal to ``radius1`` (equal spheres),
        ``inf`` a flat.
    shear_modulus2, poisson2 : float, optional
        Elastic constants of body 2; ``None`` means the same material as body 1.

    Notes
    -----
    Derived constants (``E_i = 2 G_i (1 + nu_i)``):

    * effective radius, seed Eq. 3.3: ``1/R* = 1/R1 + 1/R2``;
    * contact modulus, seed Eq. 3.4: ``1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2
      = (1-nu1)/(2 G1) + (1-nu2)/(2 G2)``;
    * tangential modulus, seed Eq. 3.12: ``1/G* = (2-nu1)/G1 + (2-nu2)/G2``
      (Johnson 1985, Eq. 7.42 ff.), so that the no-slip tangential stiffness is
      ``8 G* a``.
    """

    shear_modulus: float
    poisson: float
    radius1: float
    radius2: float | None = None
    shear_modulus2: float | None = None
    poisson2: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "shear_modulus", _positive("shear_modulus", self.shear_modulus))
        object.__setattr__(self, "poisson", _poisson("poisson", self.poisson))
        object.__setattr__(self, "radius1", _positive("radius1", self.radius1))
        if self.radius2 is not None:
            object.__setattr__(self, "radius2", _positive("radius2", self.radius2, allow_inf=True))
        if self.shear_modulus2 is not None:
            object.__setattr__(self, "shear_modulus2",
                               _positive("shear_modulus2", self.shear_modulus2))
        if self.poisson2 is not None:
            object.__setattr__(self, "poisson2", _poisson("poisson2", self.poisson2))
        derived: tuple[float, ...]
        try:
            derived = (self.effective_modulus, self.effective_shear_modulus, self.effective_radius)
        except (ZeroDivisionError, OverflowError):
            derived = (math.inf,)
        if not all(math.isfinite(v) and v > 0 for v in derived):
            raise ParameterError("shear_modulus", self.shear_modulus,
                              "with the radii gives no finite contact modulus/radius (overflow): "
                              "use a consistent unit system")

    # -- derived constants -------------------------------------------------------
    @property
    def _g2(self) -> float:
        return self.shear_modulus if self.shear_modulus2 is None else self.shear_modulus2

    @property
    def _nu2(self) -> float:
        return self.poisson if self.poisson2 is None else self.poisson2

    @property
    def effective_radius(self) -> float:
        """``R*`` of seed Eq. 3.3, ``1/R* = 1/R1 + 1/R2`` [m]."""
        r2 = self.radius1 if self.radius2 is None else self.radius2
        return 1.0 / (1.0 / self.radius1 + 1.0 / r2)

    @property
    def effective_modulus(self) -> float:
        """Contact modulus ``E*`` of seed Eq. 3.4 [Pa]."""
        g1, n1, g2, n2 = self.shear_modulus, self.poisson, self._g2, self._nu2
        return 1.0 / ((1.0 - n1) / (2.0 * g1) + (1.0 - n2) / (2.0 * g2))

    @property
    def effective_shear_modulus(self) -> float:
        """Tangential modulus ``G*`` of seed Eq. 3.12, ``1/G* = sum (2-nu_i)/G_i`` [Pa]."""
        g1, n1, g2, n2 = self.shear_modulus, self.poisson, self._g2, self._nu2
        return 1.0 / ((2.0 - n1) / g1 + (2.0 - n2) / g2)

    @property
    def stiffness_ratio(self) -> float:
        """``r = kn / kt0 = 2E*a / (8G*a) = E* / (4 G*)`` (no-slip, same contact radius).

        For equal materials ``r = (2 - nu) / (2 (1 - nu))`` (Mindlin 1949).
        """
        return self.effective_modulus / (4.0 * self.effective_shear_modulus)

    @property
    def friction(self) -> float:
        """Friction coefficient: a bare :class:`Hertz` contact is frictionless (0)."""
        return 0.0

    @classmethod
    def for_equal_spheres(cls, shear_modulus: float, poisson: float, radius: float, **kwargs: Any):
        """Two equal spheres of one material: ``cls(shear_modulus, poisson, radius, **kwargs)``."""
        return cls(shear_modulus, poisson, radius, **kwargs)

    def stiffness(self, normal_force: Any) -> tuple[Any, Any]:
        """Tangent stiffnesses ``(kn, ks)`` at normal force ``N`` with no tangential force.

        ``kn = 2 E* a`` (seed Eq. 3.7) and ``ks = 8 G* a`` (seed Eq. 3.11 with theta = 1,
        Mindlin's no-slip value; 0 for a frictionless bare :class:`Hertz`), ``a`` from
        seed Eq. 3.2. Arrays of shape (n,) in, two arrays (n,) out [N/m].
        """
        kn = hertz_normal_stiffness(normal_force, self)
        if type(self) is Hertz or self.friction == 0.0:
            return kn, 0.0 * kn
        return kn, mindlin_tangential_stiffness_from_force(normal_force, self)


@dataclass(frozen=True)
class HertzMindlin(Hertz):
    """Hertz normal law + Mindlin no-slip tangential stiffness with a Coulomb cap.

    Same geometry and material fields as :class:`Hertz`, plus

    Parameters
    ----------
    friction : float, keyword-only
        Coulomb friction coefficient ``mu >= 0`` (``inf``: infinitely rough, no sliding;
        Walton 1987's "rough spheres").

    Notes
    -----
    Tangential stiffness ``8 G* a`` (seed Eq. 3.11 with theta = 1; Mindlin 1949), applied
    to the vector tangential displacement increment; ``|T| <= mu N`` by radial return.
    When the contact radius shrinks the accumulated tangential force is scaled by
    ``a_new / a_old`` (Thornton, Cummins & Cleary 2013, Eq. 18b; LAMMPS
    ``mindlin_rescale``), which keeps closed normal cycles free of spurious work.
    """

    friction: float = field(default=math.inf, kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "friction", _friction("friction", self.friction, allow_inf=True))


@dataclass(frozen=True)
class MindlinDeresiewicz(Hertz):
    """Hertz normal law + Mindlin–Deresiewicz hysteretic tangential law.

    Same geometry and material fields as :class:`Hertz`, plus

    Parameters
    ----------
    friction : float, keyword-only
        Coulomb friction coefficient ``mu``, finite and ``>= 0``.
    max_reversals : int, keyword-only
        Number of nested, still-open load-reversal points a contact can remember
        (default 16). A path that needs more raises
        :class:`~grainmech.contact.ReversalMemoryError`. See ``docs/contact-laws.md``.

    Notes
    -----
    Seed Eq. 3.9–3.16 (after Mindlin & Deresiewicz 1953 and Thornton & Randall 1988);
    the full algorithm, its 3D extension and the memory rules are in
    :mod:`grainmech.contact.law` and ``docs/contact-laws.md``.
    """

    friction: float = field(default=math.nan, kw_only=True)
    max_reversals: int = field(default=DEFAULT_MAX_REVERSALS, kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        if isinstance(self.friction, float) and math.isnan(self.friction):
            raise ParameterError("friction", None, "is required for MindlinDeresiewicz")
        object.__setattr__(self, "friction", _friction("friction", self.friction, allow_inf=False))
        object.__setattr__(self, "max_reversals", _max_reversals("max_reversals", self.max_reversals))

    #: exponent p of the stick-zone law theta = y**p (spheres: c/a = (1 - T/muN)**(1/3))
    stick_exponent = 1.0 / 3.0


@dataclass(frozen=True)
class LinearSpring:
    """Linear normal and tangential springs with a Coulomb cap (Cundall & Strack 1979).

    Parameters
    ----------
    kn : float
        Normal stiffness [N/m] (> 0).
    ks : float
        Tangential stiffness [N/m] (>= 0).
    friction : float, optional
        Coulomb coefficient ``mu >= 0``; ``inf`` (default) never slides.
    """

    kn: float
    ks: float
    friction: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(self, "kn", _positive("kn", self.kn))
        ks = _as_float("ks", self.ks)
        if ks < 0.0 or math.isinf(ks):
            raise ParameterError("ks", self.ks, "must be finite and >= 0")
        object.__setattr__(self, "ks", ks)
        object.__setattr__(self, "friction", _friction("friction", self.friction, allow_inf=True))

    def stiffness(self, normal_force: Any) -> tuple[Any, Any]:
        """Constant ``(kn, ks)`` broadcast to the shape of ``normal_force`` [N/m]."""
        shape = np.shape(normal_force)
        return np.full(shape, self.kn), np.full(shape, self.ks)


@dataclass(frozen=True)
class Cylinder:
    """Line contact of two parallel cylinders (rods), per unit length (seed Eq. 3.8, 3.17).

    Forces are per unit length of contact [N/m] and stiffnesses per unit length [Pa].

    Parameters
    ----------
    shear_modulus_equiv : float
        Equivalent (yield-reduced) shear modulus ``G`` of seed Eq. 3.8, smaller than the
        elastic one (Chang & Misra 1988a; the seed's Chapter 6 uses 15000–40000 psi) [Pa].
    poisson : float
        Poisson's ratio ``nu`` in (-1, 0.5).
    radius : float
        The radius ``R`` of seed Eq. 3.8 [m]: the rod radius for two equal rods (see
        ``docs/seed-errata.md``, R-3.8a: with this reading the seed's half-width
        ``a = (2 (1-nu) N R / (pi G))^(1/2)`` is Hertz's).
    psi : float
        The constant ``Psi`` of seed Eq. 3.17 (> 0); ``kn / ks = Psi`` at ``T = 0``.
    friction_angle : float
        Interparticle friction angle ``phi_mu`` [rad], in [0, pi/2).
    radius2 : float, optional
        Radius of the second rod; if given, ``R = 2 R1 R2 / (R1 + R2)`` (which is the rod
        radius for equal rods, i.e. twice the equivalent radius of Eq. 3.3).
    max_reversals : int, keyword-only
        Nested reversal points remembered by the hysteretic law (default 16).

    Notes
    -----
    Normal law (seed Eq. 3.8, used as the *tangent* stiffness, as the seed does)::

        1/Kn = (1 - nu)/(pi G) [2 ln(2R/a) - 1],   a = (2 (1-nu) N R / (pi G))^(1/2)

    which integrates exactly to the approach ``alpha(N) = 2 (1-nu) N/(pi G) ln(2R/a)``.
    It is valid while ``2 ln(2R/a) > 1`` (``a < 2R/sqrt(e)``).

    Tangential law (seed Eq. 3.17)::

        1/Ks = (Psi/Kn) [1 - T/(tan(phi_mu) N)]^(-1/2)

    on first loading; unloading/reloading follow Masing's rule and a varying normal
    force the Thornton–Randall rules exactly as for spheres, with stick exponent 1/2
    instead of 1/3 and no-slip stiffness ``Kn/Psi``.
    """

    shear_modulus_equiv: float
    poisson: float
    radius: float
    psi: float
    friction_angle: float
    radius2: float | None = None
    max_reversals: int = field(default=DEFAULT_MAX_REVERSALS, kw_only=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "shear_modulus_equiv",
                           _positive("shear_modulus_equiv", self.shear_modulus_equiv))
        object.__setattr__(self, "poisson", _poisson("poisson", self.poisson))
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        if self.radius2 is not None:
            object.__setattr__(self, "radius2", _positive("radius2", self.radius2, allow_inf=True))
        object.__setattr__(self, "psi", _positive("psi", self.psi))
        phi = _as_float("friction_angle", self.friction_angle)
        if not (0.0 <= phi < 0.5 * math.pi):
            raise ParameterError("friction_angle", self.friction_angle,
                              "must lie in [0, pi/2) radians (convert degrees with math.radians)")
        object.__setattr__(self, "friction_angle", phi)
        object.__setattr__(self, "max_reversals", _max_reversals("max_reversals", self.max_reversals))

    stick_exponent = 0.5

    @property
    def equivalent_radius(self) -> float:
        """The ``R`` used in Eq. 3.8 [m]."""
        if self.radius2 is None:
            return self.radius
        if math.isinf(self.radius2):
            return 2.0 * self.radius
        return 2.0 * self.radius * self.radius2 / (self.radius + self.radius2)

    @property
    def friction(self) -> float:
        """``mu = tan(phi_mu)``."""
        return math.tan(self.friction_angle)

    @property
    def stiffness_ratio(self) -> float:
        """``r = Kn / Ks0 = Psi`` (no-slip)."""
        return self.psi

    def stiffness(self, normal_force: Any) -> tuple[Any, Any]:
        """``(Kn, Ks)`` per unit length at ``N`` with ``T = 0``: seed Eq. 3.8 and Eq. 3.17 (``Kn/Psi``)."""
        kn = cylinder_normal_stiffness(normal_force, self)
        return kn, kn / self.psi

    @property
    def max_normal_force(self) -> float:
        """Largest force per length for which Eq. 3.8 is valid (``a = 2R/sqrt(e)``)."""
        G, nu, R = self.shear_modulus_equiv, self.poisson, self.equivalent_radius
        return 2.0 * math.pi * G * R / (math.e * (1.0 - nu))


ContactParams = Hertz | HertzMindlin | MindlinDeresiewicz | LinearSpring | Cylinder


def describe(params: ContactParams) -> dict[str, Any]:
    """Field names and values of a parameter object (for logs and output headers)."""
    return {f.name: getattr(params, f.name) for f in fields(params)}

"""Per-law closed forms behind one dispatch: :func:`law_forms` (the only ``isinstance`` chain).

Every parameter class of :mod:`grainmech.contact.params` maps to a :class:`LawForms`
object that gives, vectorised over contacts, the normal law ``N(alpha)`` and its inverse,
the tangent normal stiffness ``kn(N)``, the no-slip tangential stiffness ``kt0(N)``, the
constant ratio ``r = kn / kt0``, the elastic energy of the normal law, and whether the
law is hysteretic (``kind``) and supported by the compiled kernel. The incremental laws
(:mod:`grainmech.contact.law`), the compiled kernel's constants
(:func:`grainmech.contact.kernel.constants`) and the law interface
(:class:`grainmech.contact.interface.ContactLaw`) all ask this one place; code elsewhere
that branches on the kind of law asks :func:`normal_law` or the :class:`LawForms` flags.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.contact import geometry as geo
from grainmech.contact.params import ContactParams, Cylinder, Hertz, HertzMindlin, LinearSpring, MindlinDeresiewicz

__all__ = ["LawForms", "law_forms", "normal_law", "frictional", "LAW_KINDS"]

#: law kinds: hysteretic with reversal memory, elastic + Coulomb cap, frictionless
LAW_KINDS = ("md", "jenkins", "frictionless")


@dataclass(frozen=True)
class LawForms:
    """Closed forms of one contact law (subclasses per normal law).

    Attributes
    ----------
    params : the parameter object
    kind : {"md", "jenkins", "frictionless"}
        Mindlin-Deresiewicz-type memory law (seed Eq. 3.9-3.17), elastic tangential
        spring with a Coulomb cap, or no tangential force.
    linear : bool
        Linear normal spring (``N = kn alpha``).
    compiled : bool
        Supported by the compiled kernel (:mod:`grainmech.contact.kernel`).
    """

    params: Any
    kind: str
    linear: bool = False
    compiled: bool = True

    @property
    def spheres(self) -> bool:
        """Hertz contact of two spheres (what LAMMPS' ``pair_style granular`` integrates)."""
        return isinstance(self, _HertzForms)

    @property
    def max_reversals(self) -> int:
        """Reversal memory of the hysteretic law (0 for the others)."""
        return int(getattr(self.params, "max_reversals", 0)) if self.kind == "md" else 0

    @property
    def ratio(self) -> float:
        """``r = kn / kt0`` (constant for every law here)."""
        return float(self.params.stiffness_ratio)

    def normal_force(self, alpha: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """Normal force [N] (rods: [N/m]) at approach ``alpha`` [m], same shape."""
        raise NotImplementedError

    def approach_from_force(self, N: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """Approach [m] at normal force ``N`` [N] (rods: [N/m]); inverse of :meth:`normal_force`."""
        raise NotImplementedError

    def kn(self, N: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """Normal tangent stiffness ``dN/dalpha`` [N/m] at normal force ``N``, same shape."""
        raise NotImplementedError

    def kt0(self, N: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """No-slip tangential stiffness ``kt0`` [N/m] at normal force ``N``, same shape."""
        raise NotImplementedError

    def normal_energy(self, N: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        """Elastic energy stored by the normal law [J] (0 where not evaluated)."""
        return np.zeros_like(np.asarray(N, dtype=float))


class _HertzForms(LawForms):
    """Spheres: Hertz normal law (seed Eq. 3.1-3.7), Mindlin ``kt0 = 8 G* a`` (Eq. 3.11)."""

    def normal_force(self, alpha):
        return geo.hertz_normal_force(alpha, self.params)

    def approach_from_force(self, N):
        return geo.hertz_approach_from_force(N, self.params)

    def kn(self, N):
        return geo.hertz_normal_stiffness(N, self.params)

    def kt0(self, N):
        return geo.mindlin_tangential_stiffness_from_force(N, self.params)

    def normal_energy(self, N, alpha):
        return geo.hertz_energy(N, alpha)


class _CylinderForms(LawForms):
    """Rods: line contact per unit length (integral of seed Eq. 3.8), ``kt0 = kn / psi``."""

    def normal_force(self, alpha):
        return geo.cylinder_normal_force(alpha, self.params)

    def approach_from_force(self, N):
        return geo.cylinder_approach_from_force(N, self.params)

    def kn(self, N):
        return geo.cylinder_normal_stiffness(N, self.params)

    def kt0(self, N):
        return geo.cylinder_normal_stiffness(N, self.params) / self.params.psi


class _SpringForms(LawForms):
    """Linear springs ``kn``, ``ks`` (stiffness 0 while open)."""

    @property
    def ratio(self) -> float:
        p = self.params
        return p.kn / p.ks if p.ks > 0 else math.inf

    def normal_force(self, alpha):
        return geo.linear_normal_force(alpha, self.params)

    def approach_from_force(self, N):
        return np.maximum(N, 0.0) / self.params.kn

    def kn(self, N):
        return np.where(N > 0.0, self.params.kn, 0.0)

    def kt0(self, N):
        return np.where(N > 0.0, self.params.ks, 0.0)

    def normal_energy(self, N, alpha):
        return geo.spring_energy(N, alpha)


_CACHE: dict = {}


def law_forms(params: ContactParams) -> LawForms:
    """The :class:`LawForms` of a parameter object (cached per object).

    Raises
    ------
    TypeError
        If ``params`` is not a :mod:`grainmech.contact.params` object.
    """
    try:
        return _CACHE[params]
    except (KeyError, TypeError):
        pass
    if isinstance(params, Cylinder):
        forms: LawForms = _CylinderForms(params, "md", compiled=False)
    elif isinstance(params, Hertz):
        kind = ("md" if isinstance(params, MindlinDeresiewicz)
                else "jenkins" if isinstance(params, HertzMindlin) else "frictionless")
        forms = _HertzForms(params, kind)
    elif isinstance(params, LinearSpring):
        forms = _SpringForms(params, "jenkins", linear=True)
    else:
        raise TypeError(f"params must be a grainmech.contact parameter object, got {type(params).__name__}")
    try:
        _CACHE[params] = forms
    except TypeError:  # pragma: no cover - unhashable user subclass
        pass
    return forms


def normal_law(params: Any) -> str | None:
    """The normal law of a contact parameter object, for callers that branch on it.

    ``"hertz"`` (two spheres, seed Eq. 3.6: :class:`Hertz` and its frictional
    subclasses), ``"linear"`` (:class:`LinearSpring`), ``"cylinder"`` (rods, seed Eq. 3.8,
    forces per unit length); ``None`` for an object that is not a
    :mod:`grainmech.contact.params` object (e.g. a user's stiffness object).
    """
    try:
        forms = law_forms(params)
    except TypeError:
        return None
    return "cylinder" if isinstance(forms, _CylinderForms) else "linear" if forms.linear else "hertz"


def frictional(params: Any) -> bool:
    """Whether the contacts of a law carry a dissipative tangential (Coulomb) force.

    True for a law of kind ``"md"`` or ``"jenkins"`` (:class:`LawForms`) with a friction
    coefficient ``mu > 0`` (``inf`` included: infinitely rough), and for a
    :class:`LinearSpring` only when its tangential spring ``ks > 0`` as well; False for a
    frictionless law (bare :class:`Hertz`) and for an object that is not a
    :mod:`grainmech.contact.params` object. A frictional law is what gives a load cycle
    a loop with area (seed Eq. 3.9-3.17 for the hysteretic law).
    """
    try:
        forms = law_forms(params)
    except TypeError:
        return False
    if forms.kind == "frictionless":
        return False
    if forms.linear:
        return bool(params.ks > 0 and params.friction > 0)
    return bool(params.friction > 0)

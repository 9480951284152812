"""A granular material described by its fabric, and its small-strain stiffness under a stress state.

:class:`Microstructure` is the analytical input of grainmech: a contact-normal density
(seed Eq. 4.7 / 4.9) plus the number of contacts per volume and the branch length (Eq.
4.1), in either counting convention (``docs/conventions.md``); "packing" in grainmech
names a packing of grains (:mod:`grainmech.packing`). :func:`microstructure_stiffness`
computes the stiffness tensor (seed Eq. 2.41) for constant contact stiffnesses
(:class:`grainmech.contact.LinearSpring`) or for
Hertz-Mindlin contacts whose stiffness follows from the contact forces carrying an
isotropic stress (seed Sec. 4.2.2, Eq. 4.43).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from grainmech._deprecated import renamed_attribute, warn_renamed
from grainmech.assembly import ContactSet, love_weber_stress, stiffness
from grainmech.closed_form import packing_scale
from grainmech.contact.forms import normal_law
from grainmech.errors import GrainmechError, ParameterError

__all__ = [
    "Microstructure",
    "ContactStiffness",
    "HertzMindlinStiffness",  # noqa: F822 - resolved lazily by the module's __getattr__
    "normal_forces_for_stress",
    "StiffnessResult",
    "microstructure_stiffness",
    "packing_stiffness",
]

#: extra quadrature degree used when contact stiffness varies with direction (a
#: non-polynomial function of n: f^(1/3)); Lebedev of this degree resolves it to ~1e-10
#: for the fabrics accepted (checked against a doubled degree in the tests)
DEGREE_VARYING_STIFFNESS = 41


@dataclass(frozen=True)
class Microstructure:
    """Fabric density plus the density of contacts: the analytical description of a granular material.

    Called ``Packing`` before (that name still works for one release, with a
    :class:`DeprecationWarning`); "packing" now names a packing of grains only.

    Parameters
    ----------
    density : grainmech.fabric density
        ``SphericalDensity`` (3D) or ``FourierDensity`` (2D).
    contacts_per_volume : float
        Entries per unit volume (physical contacts, or the seed's Eq. 4.1 count).
    branch_length : float
        Length carried in the kinematics: centre-to-centre distance (physical) or the
        particle radius (seed).
    convention : {"physical", "seed"}
    radius : float or None
        Particle radius (needed for Hertz contacts); defaults from ``branch_length``.
    """

    density: Any
    contacts_per_volume: float
    branch_length: float
    convention: str = "physical"
    radius: float | None = None

    def __post_init__(self) -> None:
        for name in ("contacts_per_volume", "branch_length"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise ParameterError(name, v, "must be > 0")
        if self.convention not in ("physical", "seed"):
            raise ParameterError("convention", self.convention, "must be 'physical' or 'seed'")
        if self.radius is None:
            r = self.branch_length / 2 if self.convention == "physical" else self.branch_length
            object.__setattr__(self, "radius", r)

    @property
    def dim(self) -> int:
        """Space dimension of the fabric (2 or 3)."""
        return int(self.density.dim)

    @classmethod
    def from_grains(cls, density: Any, *, void_ratio: float, coordination: float, radius: float,
                    convention: str = "physical") -> Microstructure:
        """Equal grains of radius ``radius`` at void ratio e with coordination m (Eq. 4.1)."""
        nv, length = packing_scale(void_ratio, coordination, radius, dim=density.dim,
                                   convention=convention)
        if not (np.isfinite(nv) and nv > 0 and np.isfinite(length) and length > 0):
            raise GrainmechError(
                f"radius = {radius!r} with void_ratio = {void_ratio!r} and coordination = {coordination!r} "
                f"gives contacts_per_volume = {nv!r}, branch_length = {length!r} (overflow or underflow): "
                "give lengths in consistent units")
        return cls(density, nv, length, convention, float(radius))

    def contact_set(self, kn: Any = 0.0, ks: Any = 0.0, extra_degree: int = 4) -> ContactSet:
        """Quadrature contact set (seed Eq. 2.41); see :meth:`ContactSet.from_density`."""
        return ContactSet.from_density(self.density, contacts_per_volume=self.contacts_per_volume,
                                       branch_length=self.branch_length, kn=kn, ks=ks,
                                       extra_degree=extra_degree, convention=self.convention)


class ContactStiffness(Protocol):
    """Anything giving tangent contact stiffnesses from normal forces (array -> (kn, ks))."""

    def stiffness(self, normal_force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tangent stiffnesses ``(kn, ks)`` [N/m], each shaped like ``normal_force`` [N]."""
        ...


def __getattr__(name: str) -> Any:
    # ``HertzMindlinStiffness`` is :class:`grainmech.contact.HertzMindlin` (whose
    # ``stiffness(N)`` gives Hertz kn, seed Eq. 3.7, and Mindlin's no-slip ks, Eq. 3.11-3.12),
    # resolved lazily so that importing this module does not import the contact laws.
    if name == "HertzMindlinStiffness":
        from grainmech.contact import HertzMindlin

        return HertzMindlin
    # ``Packing``: the old name of :class:`Microstructure` (one release, with a warning)
    return renamed_attribute(__name__, name, {"Packing": "Microstructure"}, globals())


def normal_forces_for_stress(contacts: ContactSet, sigma: np.ndarray) -> np.ndarray:
    """Purely normal contact forces carrying the stress ``sigma`` (Love-Weber, Eq. 2.6).

    Seeks ``N_c = n_c . A . n_c`` (a quadratic form in the normal, the lowest-order
    field able to carry a general stress with a 2nd-order fabric) with the symmetric
    ``A`` solved from ``sum_c w_c N_c (n_c . l_c) n_c (x) n_c = sigma``. For an
    isotropic fabric and ``sigma = P I`` this is the seed's Eq. 4.43,
    ``N = 3 V P / (N l)``. Raises if any force comes out tensile (the stress cannot be
    carried by compressive normal forces of this form).

    Parameters
    ----------
    contacts : ContactSet
        Normals must be parallel to the branch vectors (spheres/discs).
    sigma : array (d, d)
        Compression positive.

    Returns
    -------
    array (n,)
        Normal forces, >= 0.
    """
    s = np.asarray(sigma, dtype=float)
    d = contacts.dim
    if s.shape != (d, d) or not np.all(np.isfinite(s)):
        raise GrainmechError(f"sigma must be a finite ({d}, {d}) array, got shape {s.shape}")
    n, l_, w = contacts.normals, contacts.branch, contacts.weights
    proj = np.einsum("ci,ci->c", n, l_)
    iu = np.triu_indices(d)
    # basis of symmetric A: E_ab (a<=b) -> N_c = sum_ab A_ab q_c,ab
    q = np.stack([n[:, a] * n[:, b] * (1.0 if a == b else 2.0) for a, b in zip(*iu)], axis=1)
    nn = np.stack([n[:, a] * n[:, b] for a, b in zip(*iu)], axis=1)
    M = (nn * (w * proj)[:, None]).T @ q
    rhs = s[iu]
    try:
        coef = np.linalg.solve(M, rhs)
    except np.linalg.LinAlgError:
        raise GrainmechError("the contact normals do not span space: no normal forces carry this stress") from None
    N = q @ coef
    scale = np.abs(N).max() if N.size else 0.0
    if np.any(N < -1e-12 * scale):
        i = int(np.argmin(N))
        raise GrainmechError(
            f"stress {s.tolist()} cannot be carried by compressive normal forces of this fabric: "
            f"the force along n = {np.round(n[i], 4).tolist()} would be {N[i]:.4g} (tension)")
    return np.clip(N, 0.0, None)


@dataclass(frozen=True)
class StiffnessResult:
    """Stiffness of a microstructure under a stress state.

    Attributes
    ----------
    C : array (6, 6) or (3, 3)
        Voigt stiffness in library order.
    contacts : ContactSet
        The quadrature set with the contact stiffnesses used.
    normal_forces : array (n,)
        Normal force per quadrature direction (zeros for constant stiffness).
    stress : array (d, d)
        Love-Weber stress of those forces (equals the requested stress).
    """

    C: np.ndarray
    contacts: ContactSet
    normal_forces: np.ndarray
    stress: np.ndarray = field(repr=False)


def microstructure_stiffness(microstructure: Microstructure, contact: ContactStiffness,
                             stress: Any = None) -> StiffnessResult:
    """Small-strain stiffness of a microstructure (seed Eq. 2.41) at a given stress.

    Parameters
    ----------
    microstructure : Microstructure
    contact : ContactStiffness
        Contact parameters with ``stiffness(N)``: :class:`grainmech.contact.LinearSpring`
        (constant stiffnesses, seed Sec. 4.2.1) or a Hertz law such as
        :class:`grainmech.contact.HertzMindlin` (seed Eq. 3.7, 3.11).
    stress : float or array (d, d), optional
        Isotropic pressure P (float) or a stress tensor, compression positive. Required
        when the contact stiffness depends on the force (not for ``LinearSpring``).

    Returns
    -------
    StiffnessResult
    """
    d = microstructure.dim
    const = normal_law(contact) == "linear"
    if stress is None:
        if not const:
            raise GrainmechError("a stress (or pressure) is needed for force-dependent contact stiffness")
        sigma = np.zeros((d, d))
    else:
        sigma = np.asarray(stress, dtype=float)
        if sigma.ndim == 0:
            if not np.isfinite(sigma) or sigma <= 0:
                raise ParameterError("pressure", float(sigma), "must be > 0")
            sigma = float(sigma) * np.eye(d)
    # constant stiffness or uniform forces: a degree-4 integrand is exact
    isotropic_fabric = microstructure.density.order == 0 and np.allclose(sigma, sigma[0, 0] * np.eye(d))
    extra = 4 if const or isotropic_fabric else DEGREE_VARYING_STIFFNESS
    geom = microstructure.contact_set(extra_degree=extra)
    N = np.zeros(len(geom)) if stress is None else normal_forces_for_stress(geom, sigma)
    with np.errstate(all="ignore"):
        kn, ks = contact.stiffness(N)
    bad = ~(np.isfinite(kn) & np.isfinite(ks))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise GrainmechError(
            f"contact stiffness is not finite (kn = {float(np.asarray(kn)[i]):.4g}, "
            f"ks = {float(np.asarray(ks)[i]):.4g} "
            f"at normal force {N[i]:.4g}): the inputs overflow; check radius ({microstructure.radius:.4g}), "
            "void_ratio, coordination, shear_modulus, poisson and the pressure for a consistent unit system")
    cs = geom.with_stiffness(kn, ks)
    s = love_weber_stress(N[:, None] * cs.normals, cs.branch, cs.weights).stress
    C = stiffness(cs)
    if not np.all(np.isfinite(C)):
        raise GrainmechError("the stiffness overflows: check radius, void_ratio, coordination, the contact "
                             "stiffness or shear_modulus and the pressure for a consistent unit system")
    return StiffnessResult(C, cs, N, s)


def packing_stiffness(packing: Microstructure, contact: ContactStiffness, stress: Any = None) -> StiffnessResult:
    """:func:`microstructure_stiffness` under its old name (deprecated: warns, removed in the next release)."""
    warn_renamed(f"{__name__}.packing_stiffness", f"{__name__}.microstructure_stiffness")
    return microstructure_stiffness(packing, contact, stress)

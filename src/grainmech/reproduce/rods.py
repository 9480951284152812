"""Seed Figs. 5.2, 6.1-6.2: the six regular rod packings and their apparent moduli.

Packings A-F of seed Fig. 5.2 (Sec. 5.2): 2D arrays of parallel aluminium rods, per unit
rod length. The seed's text does not contain Fig. 5.2; it states only that A is square,
B hexagonal, C "a mixture of square packing and hexagonal packing" whose modulus and
Poisson's ratio "are average of those of packing A and packing B", D "shows the similar
isotropic behavior as that of packing B, however, the magnitude of the modulus of packing
D is much smaller", and E (rods of 0.5 and 0.25 in) and F (0.75 and 0.5 in) are two-size
packings whose moduli and Poisson's ratios are anisotropic (Sec. 6.1.1). A and B follow
from their names; **C-F are our reconstructions** (:data:`PACKINGS`, each with the reason
for the choice in its ``note``), built as real periodic rod arrays: a unit cell with rod
centres and diameters, the contacts found from the geometry (centre distance equal to the
sum of the radii), never a hand-set stiffness.

The response is that of the directional shear box (seed Sec. 5.3): an isotropic stress of
2.5 psi, then a stress increment along the direction ``alpha`` measured from the y axis
towards x. Rod contacts of seed Eq. 3.8 / 3.17 (:class:`grainmech.contact.Cylinder`,
``G = 15000 psi``, ``Psi = 2.5``, ``nu = 0.1``, ``phi_mu = 15 deg``, Sec. 6.1.1); apparent
modulus seed Eq. 6.1 ``E = d sigma_alpha / eps_alpha`` and Poisson's ratio Eq. 6.2 corrected
(``docs/seed-errata.md``) ``nu = -eps_(alpha+90) / eps_alpha``. The shared helpers
(:func:`shear_box_stiffness`, :func:`directional`, :func:`increment_strains`) are also used
by :mod:`grainmech.reproduce.random_rods` (Figs. 6.3-6.6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.assembly import ContactSet, static_contact_forces, stiffness
from grainmech.contact import Cylinder, cylinder_normal_stiffness, cylinder_tangential_stiffness
from grainmech.conventions import stress_to_vector, vector_to_strain
from grainmech.errors import GrainmechError
from grainmech.reproduce._base import FigureData, long_table
from grainmech.tensors import directional_poisson, directional_young

__all__ = ["ROD", "RodContactSet", "PeriodicRods", "PACKINGS", "packing_geometry",
           "regular_packing", "shear_box_stiffness", "directional", "increment_strains",
           "apparent", "fig5_2", "fig6_1", "fig6_2"]

#: Seed Sec. 5.2, 5.3, 6.1.1 (psi, in).
ROD = {"diameter": 0.5, "shear_modulus_equiv": 15000.0, "poisson": 0.1, "psi": 2.5,
       "friction_angle_deg": 15.0, "pressure": 2.5, "increment": 0.5}


# --------------------------------------------------------------------------- geometry

@dataclass(frozen=True)
class RodContactSet(ContactSet):
    """A :class:`~grainmech.assembly.ContactSet` of rod contacts that knows its rods.

    Extra attributes (all optional; a plain ``ContactSet`` is read as equal rods of
    radius ``|l|/2``):

    radius1, radius2 : array (n,)
        Radii of the two rods at each contact (the ``R1, R2`` of seed Eq. 3.8 / 3.3).
    particles : int
        Number of rods in the periodic cell.
    cell_area : float
        Area of the periodic cell (the ``V`` of the weights ``1/V``, per unit length).
    solid_area : float
        Total cross-section area of the rods in the cell.
    """

    radius1: Any = None
    radius2: Any = None
    particles: int | None = None
    cell_area: float | None = None
    solid_area: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("radius1", "radius2"):
            v = getattr(self, name)
            if v is None:
                continue
            a = np.array(v, dtype=float).reshape(-1)
            if a.shape != (len(self),) or not np.all(np.isfinite(a)) or np.any(a <= 0):
                raise GrainmechError(f"{name} must be {len(self)} positive radii, got {v!r}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def with_stiffness(self, kn: Any, ks: Any) -> "RodContactSet":
        """Same geometry and rods with new contact stiffnesses."""
        return RodContactSet(self.normals, self.branch, self.weights, kn, ks, self.convention,
                             radius1=self.radius1, radius2=self.radius2, particles=self.particles,
                             cell_area=self.cell_area, solid_area=self.solid_area)


def _pairs_by_images(lattice: np.ndarray, pos: np.ndarray, cutoff: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All pairs (i, j, l = x_j + shift - x_i) with ``|l| <= cutoff``, each pair once."""
    reach = int(math.ceil(cutoff / min(np.linalg.norm(lattice, axis=1)))) + 1
    I, J, L = [], [], []
    k = len(pos)
    for n1 in range(-reach, reach + 1):
        for n2 in range(-reach, reach + 1):
            shift = n1 * lattice[0] + n2 * lattice[1]
            for i in range(k):
                for j in range(i, k):
                    if i == j and (n1, n2) <= (0, 0):
                        continue  # self, and each self-image pair once
                    l_ = pos[j] + shift - pos[i]
                    if np.linalg.norm(l_) <= cutoff:
                        I.append(i), J.append(j), L.append(l_)
    return np.array(I, dtype=int), np.array(J, dtype=int), np.array(L, dtype=float).reshape(-1, 2)


def _pairs_by_tree(box: float, pos: np.ndarray, cutoff: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs in a square periodic box of side ``box`` (minimum image), each pair once."""
    from scipy.spatial import cKDTree

    x = np.mod(pos, box)
    p = cKDTree(x, boxsize=box).query_pairs(cutoff, output_type="ndarray")
    i, j = p[:, 0], p[:, 1]
    l_ = x[j] - x[i]
    l_ -= box * np.round(l_ / box)
    return i, j, l_


@dataclass(frozen=True)
class PeriodicRods:
    """A periodic 2D array of rods: a cell, rod centres and diameters.

    Parameters
    ----------
    name : str
        Short name (``"A"`` ... ``"F"``, ``"one-size"``, ``"two-size"``).
    label : str
        Legend label.
    lattice : array (2, 2)
        Rows are the cell vectors ``a1, a2`` [length].
    positions : array (k, 2)
        Rod centres [length].
    diameters : array (k,)
        Rod diameters [length].
    note : str
        Why this arrangement (for reconstructions: what in the seed's text it rests on).
    """

    name: str
    label: str
    lattice: np.ndarray
    positions: np.ndarray
    diameters: np.ndarray
    note: str = ""
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def cell_area(self) -> float:
        """``|det(a1, a2)|``."""
        return float(abs(np.linalg.det(np.asarray(self.lattice, dtype=float))))

    @property
    def solid_area(self) -> float:
        """Sum of the rod cross-sections ``pi d^2/4``."""
        return float(np.sum(np.pi * np.asarray(self.diameters) ** 2 / 4))

    @property
    def void_ratio(self) -> float:
        """``e = (cell area - solid area) / solid area`` (seed Eq. 4.1 for discs)."""
        return self.cell_area / self.solid_area - 1.0

    def contacts(self, rel_tol: float = 1e-9, *, allow_overlap: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pairs of rods in contact: ``(i, j, l)`` with branch vector ``l`` from i to j.

        A contact is a pair whose centre distance is at most ``(r_i + r_j)(1 + rel_tol)``
        (each physical contact once). Unless ``allow_overlap`` (soft-disc packings), an
        overlap deeper than 1e-9 of ``r_i + r_j`` is an error: the arrangement would not be
        realisable with rigid rods.
        """
        key = ("contacts", rel_tol, allow_overlap)
        if key in self._cache:
            return self._cache[key]
        lat = np.asarray(self.lattice, dtype=float)
        pos = np.asarray(self.positions, dtype=float)
        r = np.asarray(self.diameters, dtype=float) / 2
        cutoff = 2 * r.max() * (1 + rel_tol)
        if len(pos) > 50 and np.allclose(lat, lat[0, 0] * np.eye(2)):
            i, j, l_ = _pairs_by_tree(lat[0, 0], pos, cutoff)
        else:
            i, j, l_ = _pairs_by_images(lat, pos, cutoff)
        dist = np.linalg.norm(l_, axis=1)
        touch = r[i] + r[j]
        if not allow_overlap and np.any(dist < touch * (1 - 1e-9)):
            k = int(np.argmin(dist / touch))
            raise GrainmechError(f"packing {self.name}: rods {i[k]} and {j[k]} overlap "
                                 f"(distance {dist[k]:.6g} < {touch[k]:.6g})")
        keep = dist <= touch * (1 + rel_tol)
        out = (i[keep], j[keep], l_[keep])
        self._cache[key] = out
        return out

    def coordination(self, rel_tol: float = 1e-9, *, allow_overlap: bool = False) -> float:
        """Mean number of contacts per rod, ``m = 2 N_c / N_p`` (seed Sec. 6.1.2)."""
        return 2.0 * len(self.contacts(rel_tol, allow_overlap=allow_overlap)[0]) / len(self.diameters)

    def contact_set(self, rel_tol: float = 1e-9, *, scale: float = 1.0,
                    allow_overlap: bool = False) -> RodContactSet:
        """Physical contact set (each contact once, centre-to-centre branch, ``w = 1/V``).

        ``scale`` multiplies every length (e.g. 0.0254 for inches -> metres).
        """
        i, j, l_ = self.contacts(rel_tol, allow_overlap=allow_overlap)
        if len(i) == 0:
            raise GrainmechError(f"packing {self.name}: no contacts")
        r = np.asarray(self.diameters, dtype=float) / 2
        n = l_ / np.linalg.norm(l_, axis=1)[:, None]
        return RodContactSet(n, scale * l_, 1.0 / (scale ** 2 * self.cell_area), 0.0, 0.0,
                             "physical", radius1=scale * r[i], radius2=scale * r[j],
                             particles=len(r), cell_area=scale ** 2 * self.cell_area,
                             solid_area=scale ** 2 * self.solid_area)


def _two_size_centred(name: str, big: float, small: float, why: str) -> PeriodicRods:
    """Rows of touching large rods along x; one small rod nested between four large rods.

    Centred rectangular cell ``a1 = (D, 0)``, ``a2 = (0, 2h)``, large rod at the corner,
    small rod at ``(D/2, h)`` touching all four large rods:
    ``h = sqrt(((D + d)/2)^2 - (D/2)^2)``. Needs ``2h >= D`` (large rows do not overlap)
    and ``d <= D`` (small rods do not touch each other).
    """
    h = math.sqrt(((big + small) / 2) ** 2 - (big / 2) ** 2)
    if 2 * h < big or small > big:
        raise GrainmechError(f"two-size cell {name}: diameters {big}, {small} do not fit")
    return PeriodicRods(name, f"{name} (two sizes {big:g}/{small:g} in)",
                        np.array([[big, 0.0], [0.0, 2 * h]]),
                        np.array([[0.0, 0.0], [big / 2, h]]), np.array([big, small]), why)


def _build_packings(d: float = ROD["diameter"]) -> dict[str, PeriodicRods]:
    s3 = math.sqrt(3.0)
    two_size = ("Same recipe for E and F: rows of touching large rods along x, one small "
                "rod nested in each gap between four large rods (a centred rectangular "
                "cell, the simplest periodic two-size array in which every rod is held "
                "by contacts). Reconstruction: the seed states only the diameters and that "
                "the response is anisotropic.")
    return {
        "A": PeriodicRods("A", "A (square)", np.array([[d, 0.0], [0.0, d]]),
                          np.zeros((1, 2)), np.array([d]),
                          "Square: the seed's name; rows along x and y (stiffest along y, "
                          "Sec. 6.1.1)."),
        "B": PeriodicRods("B", "B (hexagonal)", np.array([[d, 0.0], [d / 2, s3 / 2 * d]]),
                          np.zeros((1, 2)), np.array([d]),
                          "Hexagonal: the seed's name; one row along x."),
        "C": PeriodicRods("C", "C (square + hexagonal rows)",
                          np.array([[d, 0.0], [0.0, (2 + s3) * d]]),
                          np.array([[0.0, 0.0], [0.0, d], [d / 2, (1 + s3 / 2) * d],
                                    [d / 2, (2 + s3 / 2) * d]]), np.full(4, d),
                          "Reconstruction of 'a mixture of square packing and hexagonal "
                          "packing': rows along x stacked alternately square (directly "
                          "above) and hexagonal (offset d/2), the smallest periodic "
                          "mixture; coordination 5 and area per rod 0.933 d^2, exactly "
                          "the means of A (4, d^2) and B (6, 0.866 d^2)."),
        "D": PeriodicRods("D", "D (kagome: B with every 4th rod missing)",
                          np.array([[2 * d, 0.0], [d, s3 * d]]),
                          np.array([[0.0, 0.0], [d, 0.0], [d / 2, s3 / 2 * d]]), np.full(3, d),
                          "Reconstruction of 'isotropic like B, modulus much smaller': the "
                          "kagome array, i.e. hexagonal packing B with one rod in four "
                          "removed in order. Its contact normals keep B's six-fold symmetry "
                          "(hence isotropic in 2D) with half B's contacts per area "
                          "(coordination 4, e = 0.47). The honeycomb (B with every third "
                          "rod removed, coordination 3) would be the other candidate."),
        "E": _two_size_centred("E", 0.5, 0.25, two_size),
        "F": _two_size_centred("F", 0.75, 0.5, two_size),
    }


#: The six regular packings of seed Fig. 5.2 (A, B from the seed; C-F reconstructed), in.
PACKINGS: dict[str, PeriodicRods] = _build_packings()

_ALIASES = {"square": "A", "hexagonal": "B", "mixed": "C", "kagome": "D",
            "two-size-e": "E", "two-size-f": "F"}


def packing_geometry(kind: str) -> PeriodicRods:
    """Regular packing ``"A"``-``"F"`` (or ``square``, ``hexagonal``, ``mixed``, ``kagome``,
    ``two-size-E``, ``two-size-F``), lengths in inches (seed Sec. 5.2)."""
    key = _ALIASES.get(str(kind).lower(), str(kind).upper())
    if key not in PACKINGS:
        raise GrainmechError(f"packing must be one of A-F or {', '.join(_ALIASES)}; got {kind!r}")
    return PACKINGS[key]


def regular_packing(kind: str, diameter: float = ROD["diameter"]) -> RodContactSet:
    """Physical contact set (each contact once, branch = centre-to-centre) of a lattice.

    ``kind`` as in :func:`packing_geometry`. All lengths are scaled by
    ``diameter / 0.5 in``: ``diameter`` is the diameter of the seed's 0.5 in rods (for E
    the large rods, for F the small ones), in any length unit. E.g. ``square``: normals
    along x and y, one rod per ``d^2``, 2 contacts per rod; ``hexagonal``: normals at 0, 60,
    120 deg from x, one rod per ``(sqrt 3/2) d^2``, 3 contacts per rod.
    """
    if not np.isfinite(diameter) or diameter <= 0:
        raise GrainmechError(f"diameter must be > 0, got {diameter!r}")
    return packing_geometry(kind).contact_set(scale=diameter / ROD["diameter"])


# --------------------------------------------------------------------------- mechanics

def _rod_radii(cs: ContactSet) -> tuple[np.ndarray, np.ndarray]:
    r1 = getattr(cs, "radius1", None)
    r2 = getattr(cs, "radius2", None)
    if r1 is None or r2 is None:  # equal rods touching: |l| = 2 R
        r = np.linalg.norm(cs.branch, axis=1) / 2
        return r, r
    return np.asarray(r1, dtype=float), np.asarray(r2, dtype=float)


def shear_box_stiffness(cs: ContactSet, *, G: float, psi: float, nu: float, phi_mu: float,
                        pressure: float) -> np.ndarray:
    """Tangent 2D stiffness (Voigt 3x3, ``xx, yy, xy``) of rods under isotropic pressure.

    Contact forces from the static estimate ``f = sigma . F^-1 . l`` (exact Love-Weber
    inverse of seed Eq. 2.6, :func:`grainmech.assembly.static_contact_forces`) at
    ``sigma = pressure I``; normal stiffness seed Eq. 3.8 at that normal force (rod radii
    ``R1, R2`` per contact, ``R = 2 R1 R2/(R1 + R2)``), tangential stiffness seed Eq. 3.17
    on first loading at that tangential force (``Ks = Kn/Psi`` when ``T = 0``); stiffness
    seed Eq. 2.26 in the physical counting (each contact once, branch vector).

    Parameters
    ----------
    cs : ContactSet
        2D rod contacts (:class:`RodContactSet` for unequal rods; a plain set is read as
        equal rods of radius ``|l|/2``).
    G, psi, nu, phi_mu : float
        Equivalent shear modulus [stress], ``Psi``, Poisson's ratio, friction angle [rad].
    pressure : float
        Isotropic stress, compression positive [stress].

    Returns
    -------
    array (3, 3)
        Voigt stiffness [stress units of ``G``].
    """
    if cs.dim != 2:
        raise GrainmechError(f"rod packings are 2D; the contact set has dimension {cs.dim}")
    if not np.isfinite(pressure) or pressure <= 0:
        raise GrainmechError(f"pressure must be > 0, got {pressure!r}")
    f = static_contact_forces(cs, pressure * np.eye(2))
    n = cs.normals
    N = np.einsum("ci,ci->c", f, n)
    T = f[:, 1] * n[:, 0] - f[:, 0] * n[:, 1]
    r1, r2 = _rod_radii(cs)
    kn, ks = np.zeros(len(cs)), np.zeros(len(cs))
    pairs = np.round(np.column_stack([r1, r2]) / r1.max(), 9)
    for key in np.unique(pairs, axis=0):
        sel = np.all(pairs == key, axis=1)
        a, b = r1[sel][0], r2[sel][0]
        p = Cylinder(G, nu, a, psi, phi_mu, radius2=None if abs(a - b) <= 1e-9 * a else b)
        kn[sel] = cylinder_normal_stiffness(N[sel], p)
        ks[sel] = cylinder_tangential_stiffness(N[sel], T[sel], p)
    return stiffness(ContactSet(cs.normals, cs.branch, cs.weights, kn, ks, cs.convention))


def _alpha_dirs(alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Loading direction ``d = (sin a, cos a)`` (from y towards x) and ``d + 90 deg``."""
    a = np.asarray(alpha, dtype=float)
    return (np.stack([np.sin(a), np.cos(a)], axis=-1), np.stack([np.cos(a), -np.sin(a)], axis=-1))


def directional(C: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Apparent modulus (seed Eq. 6.1) and Poisson's ratio (Eq. 6.2 corrected) along alpha.

    ``E = d sigma_alpha / eps_alpha`` and ``nu = -eps_(alpha+90) / eps_alpha`` for a
    uniaxial stress increment along ``d = (sin alpha, cos alpha)``; ``alpha`` [rad] from y
    towards x.
    """
    d, m = _alpha_dirs(alpha)
    return directional_young(C, d), directional_poisson(C, d, m)


def increment_strains(C: np.ndarray, alpha: np.ndarray, increment: float) -> dict[str, np.ndarray]:
    """Strains for a uniaxial stress increment ``increment d (x) d`` along alpha.

    ``eps = S : (Delta sigma d (x) d)`` with ``S = C^-1`` (compression positive); the
    seed's directional-shear-box loading (Sec. 5.3). Returns the tensor components
    ``eps_xx, eps_yy, eps_xy`` (``eps_xy`` is half the engineering shear strain) and the
    normal strains ``eps_alpha``, ``eps_alpha90`` along ``d`` and ``d + 90 deg``.
    """
    d, m = _alpha_dirs(alpha)
    dsig = increment * d[..., :, None] * d[..., None, :]
    eps = vector_to_strain(np.einsum("ab,...b->...a", np.linalg.inv(C), stress_to_vector(dsig)))
    return {"eps_xx": eps[..., 0, 0], "eps_yy": eps[..., 1, 1], "eps_xy": eps[..., 0, 1],
            "eps_alpha": np.einsum("...i,...ij,...j->...", d, eps, d),
            "eps_alpha90": np.einsum("...i,...ij,...j->...", m, eps, m)}


def _rod_stiffness(cs: ContactSet) -> np.ndarray:
    return shear_box_stiffness(cs, G=ROD["shear_modulus_equiv"], psi=ROD["psi"], nu=ROD["poisson"],
                               phi_mu=math.radians(ROD["friction_angle_deg"]),
                               pressure=ROD["pressure"])


def apparent(kind: str, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Apparent modulus and Poisson's ratio (Eq. 6.1, 6.2 corrected) of packing ``kind``.

    Tangent stiffness at the 2.5 psi isotropic state (:func:`shear_box_stiffness` with the
    seed's Sec. 6.1.1 constants). ``alpha`` [rad] from y towards x. Returns ``E`` [psi],
    ``nu``, ``C`` (Voigt 3x3, psi).
    """
    C = _rod_stiffness(regular_packing(kind))
    E, nu = directional(C, alpha)
    return E, nu, C


# --------------------------------------------------------------------------- figures

_TEXT = (
    "Inputs: the seed's rod contacts (Eq. 3.8, 3.17; G = 15000 psi, Psi = 2.5, nu = 0.1, "
    "phi_mu = 15 deg), 2.5 psi isotropic stress, rods 0.5 in (E: 0.5/0.25 in, F: 0.75/0.5 "
    "in). Our choices (unstated by the seed, none tuned to a curve): A with contacts along x "
    "and y, B with one lattice row along x; C-F are RECONSTRUCTIONS (seed Fig. 5.2 is not "
    "in the text; see Fig. 5.2 here): C alternating square and hexagonal rows, D the kagome "
    "array (B with every 4th rod missing), E and F rows of large rods with one small rod "
    "nested between four large ones. Contact forces from the static estimate f = sigma.F^-1.l "
    "(tangential forces, hence a reduced Ks by Eq. 3.17, appear where the branch fabric is "
    "anisotropic); the moduli are the tangent at the 2.5 psi state (the seed applies a "
    "finite 0.5 psi increment: a secant would differ by a few per cent); physical counting "
    "(the seed's Eq. 2.26 counting halves every modulus, nu unchanged). Measured points are "
    "not in the text.")

ORDER = ("A", "B", "C", "D", "E", "F")


def _table(alpha: np.ndarray) -> tuple[dict, dict]:
    blocks, meta = [], {}
    for key in ORDER:
        E, nu, _ = apparent(key, alpha)
        blocks.append({"packing": PACKINGS[key].label, "alpha_deg": np.degrees(alpha),
                       "E": E, "nu": nu})
        meta[key] = (E, nu)
    return long_table(blocks), meta


def _summary(meta: dict, alpha: np.ndarray, idx: int) -> str:
    i45 = int(np.argmin(np.abs(alpha - np.pi / 4)))
    i90 = int(np.argmin(np.abs(alpha - np.pi / 2)))
    fmt = "{:.4g}" if idx == 0 else "{:.3f}"
    parts = []
    for key in ORDER:
        v = meta[key][idx]
        parts.append(f"{key}: {fmt.format(v[0])} / {fmt.format(v[i45])} / {fmt.format(v[i90])}")
    return "; ".join(parts)


def fig6_1(n: int = 145) -> FigureData:
    """Seed Fig. 6.1: apparent modulus versus alpha for packings A-F (polar)."""
    alpha = np.linspace(0, 2 * np.pi, n)
    table, meta = _table(alpha)
    Ea, Eb = meta["A"][0], meta["B"][0]
    i45 = int(np.argmin(np.abs(alpha - np.pi / 4)))
    caption = (
        "Seed Fig. 6.1: apparent modulus E = d sigma_alpha/eps_alpha (Eq. 6.1) versus the "
        "loading direction alpha (from y) for the six regular packings. The seed: A (square) "
        "is stiffest along y and softest at 45 deg; B (hexagonal) is isotropic; C's modulus "
        "is the average of A's and B's; D is isotropic and much softer than B; E and F are "
        "anisotropic. Ours, E [psi] at alpha = 0 / 45 / 90 deg: " + _summary(meta, alpha, 0)
        + f". A {Ea[0]:.4g} psi at 0 deg, {Ea[i45]:.4g} psi at 45 deg (minimum); B "
        f"{Eb.min():.4g}-{Eb.max():.4g} psi (isotropic). " + _TEXT)
    Ed = meta["D"][0]
    return FigureData("6.1", "Rod packings A-F: apparent modulus (seed Fig. 6.1)", caption,
                      table, {"E_A_0": float(Ea[0]), "E_A_45": float(Ea[i45]),
                              "E_B_spread": float(np.ptp(Eb) / Eb.mean()),
                              "E_D_spread": float(np.ptp(Ed) / Ed.mean()),
                              "E_D_over_B": float(Ed.mean() / Eb.mean())})


def fig6_2(n: int = 145) -> FigureData:
    """Seed Fig. 6.2: apparent Poisson's ratio versus alpha for packings A-F (polar)."""
    alpha = np.linspace(0, 2 * np.pi, n)
    table, meta = _table(alpha)
    nua, nub = meta["A"][1], meta["B"][1]
    i45 = int(np.argmin(np.abs(alpha - np.pi / 4)))
    caption = (
        "Seed Fig. 6.2: apparent Poisson's ratio nu = -eps_(alpha+90)/eps_alpha (Eq. 6.2, "
        "corrected: the print is the reciprocal) versus alpha for the six regular packings. "
        "The seed: A's Poisson's ratio is largest at 45 deg (and, from the lattice, 0 along "
        "the rows), B is isotropic, C the average of A and B, D like B, E and F anisotropic. "
        f"Ours: A nu = {abs(nua[0]):.4f} at 0 deg and {nua[i45]:.4f} at 45 deg (maximum); B "
        f"nu = {nub.mean():.4f} in every direction; nu at 0 / 45 / 90 deg: "
        + _summary(meta, alpha, 1) + ". Lattice closed forms with k = Ks/Kn = 1/Psi: A at "
        "45 deg nu = (1 - k)/(1 + k), B and D nu = (1 - k)/(3 + k) (any six-fold array; "
        "tested). " + _TEXT)
    return FigureData("6.2", "Rod packings A-F: apparent Poisson's ratio (seed Fig. 6.2)",
                      caption, table, {"nu_A_0": float(nua[0]), "nu_A_45": float(nua[i45]),
                                       "nu_B_spread": float(np.ptp(nub))})


def _tile(p: PeriodicRods, span: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rod centres/diameters of the images of ``p`` inside ``[0, span]^2`` (plus a margin)."""
    lat, pos = np.asarray(p.lattice), np.asarray(p.positions)
    reach = int(math.ceil(2 * span / min(np.linalg.norm(lat, axis=1)))) + 2
    xs, ds, owner = [], [], []
    for n1 in range(-reach, reach + 1):
        for n2 in range(-reach, reach + 1):
            x = pos + n1 * lat[0] + n2 * lat[1]
            xs.append(x), ds.append(p.diameters), owner.append(np.arange(len(pos)))
    x, d = np.concatenate(xs), np.concatenate(ds)
    m = np.all((x > -0.5) & (x < span + 0.5), axis=1)
    return x[m], d[m], np.concatenate(owner)[m]


def fig5_2(span: float = 2.0) -> FigureData:
    """Seed Fig. 5.2 (reconstructed): the six regular packings, a few cells of each.

    Rows of the table: one per rod image (``item = "rod"``: centre, diameter) and one per
    contact image (``item = "contact"``: the branch vector from ``x, y`` to ``x2, y2``)
    in a ``span`` x ``span`` in window, and one per unit cell corner (``item = "cell"``).
    """
    blocks, meta = [], {}
    for key in ORDER:
        p = PACKINGS[key]
        x, d, owner = _tile(p, span)
        blocks.append({"packing": p.label, "item": "rod", "x": x[:, 0], "y": x[:, 1],
                       "x2": x[:, 0], "y2": x[:, 1], "diameter": d})
        i, j, l_ = p.contacts()
        segs = []
        for c in range(len(i)):
            start = x[owner == i[c]]
            segs.append(np.column_stack([start, start + l_[c]]))
        s = np.concatenate(segs)
        blocks.append({"packing": p.label, "item": "contact", "x": s[:, 0], "y": s[:, 1],
                       "x2": s[:, 2], "y2": s[:, 3], "diameter": 0.0})
        lat = np.asarray(p.lattice)
        corners = np.array([[0, 0], lat[0], lat[0] + lat[1], lat[1], [0, 0]])
        blocks.append({"packing": p.label, "item": "cell", "x": corners[:, 0], "y": corners[:, 1],
                       "x2": corners[:, 0], "y2": corners[:, 1], "diameter": 0.0})
        meta[key] = {"void_ratio": p.void_ratio, "coordination": p.coordination(),
                     "contacts_per_area": len(i) / p.cell_area, "rods_per_cell": len(p.diameters)}
    stats = "; ".join(f"{k}: e = {v['void_ratio']:.3f}, m = {v['coordination']:.2f}, "
                      f"{v['contacts_per_area']:.2f} contacts/in^2" for k, v in meta.items())
    notes, seen = [], {}
    for k in ORDER:  # E and F share one recipe: say it once
        note = PACKINGS[k].note
        if note in seen:
            notes[seen[note]] = notes[seen[note]].replace(":", f", {k}:", 1)
            continue
        seen[note] = len(notes)
        notes.append(f"{k}: {note}")
    notes = " ".join(notes)
    caption = (
        "Seed Fig. 5.2 (the six regular packings of Sec. 5.2) is not in the text of the seed; "
        "this figure draws the arrays used for Figs. 6.1-6.2: rods (circles), contacts "
        "(branch vectors, lines) and one unit cell (dashed). A and B follow from the seed's "
        "names; C-F are RECONSTRUCTIONS from the seed's statements (Sec. 5.2, 6.1.1), not "
        "the seed's drawings, and nothing was tuned to the seed's curves. " + notes
        + " Geometry: " + stats + ".")
    return FigureData("5.2", "Six regular rod packings, A-B from the seed, C-F reconstructed "
                      "(seed Fig. 5.2)", caption, long_table(blocks), meta)

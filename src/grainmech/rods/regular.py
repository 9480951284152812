"""Regular periodic rod arrays (the seed's regular packings, Sec. 5.2, Fig. 5.2).

Regular periodic rod arrays (the seed's "regular packings", Sec. 5.2, Fig. 5.2): 2D
arrays of parallel rods per unit rod length, their contacts found from the geometry, as
contact sets. (:data:`ARRAYS`, :func:`array_geometry` and :func:`regular_array` were
``PACKINGS``, ``packing_geometry`` and ``regular_packing``; the old names work for one
release, with a :class:`DeprecationWarning`.)

Arrays A-F: A is square, B hexagonal; the seed's text does not contain Fig. 5.2 and
describes C-F only in words, so **C-F are reconstructions** (:data:`ARRAYS`, each with
the reason for the choice in its ``note``), built as real periodic rod arrays: a unit cell
with rod centres and diameters, the contacts found from the geometry (centre distance equal
to the sum of the radii), never a hand-set stiffness. ``docs/reproduce.md`` compares them
with the seed's Figs. 6.1-6.2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from grainmech._deprecated import renamed_attribute, warn_renamed
from grainmech.assembly import ContactSet
from grainmech.errors import GrainmechError

__all__ = ["ROD", "RodContactSet", "PeriodicRods", "ARRAYS", "array_geometry", "regular_array",
           "packing_geometry", "regular_packing"]


#: Seed Sec. 5.2, 5.3, 6.1.1 (psi, in).
ROD = {"diameter": 0.5, "shear_modulus_equiv": 15000.0, "poisson": 0.1, "psi": 2.5,
       "friction_angle_deg": 15.0, "pressure": 2.5, "increment": 0.5}



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

    def with_stiffness(self, kn: Any, ks: Any) -> RodContactSet:
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
                        I.append(i)
                        J.append(j)
                        L.append(l_)
    return np.array(I, dtype=int), np.array(J, dtype=int), np.array(L, dtype=float).reshape(-1, 2)


def _pairs_by_tree(box: float, pos: np.ndarray, cutoff: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs in a square periodic box of side ``box`` (minimum image), each pair once."""
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
        w = np.asarray(1.0 / (scale ** 2 * self.cell_area))  # one weight for every contact (0-d: broadcast)
        return RodContactSet(n, scale * l_, w, np.zeros(len(i)), np.zeros(len(i)),
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


def _build_arrays(d: float = ROD["diameter"]) -> dict[str, PeriodicRods]:
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


#: The six regular arrays of seed Fig. 5.2 (A, B from the seed; C-F reconstructed), in.
ARRAYS: dict[str, PeriodicRods] = _build_arrays()

_ALIASES = {"square": "A", "hexagonal": "B", "mixed": "C", "kagome": "D",
            "two-size-e": "E", "two-size-f": "F"}


def array_geometry(kind: str) -> PeriodicRods:
    """Regular rod array by name, lengths in inches (seed Sec. 5.2).

    Regular array ``"A"``-``"F"`` (or ``square``, ``hexagonal``, ``mixed``, ``kagome``,
    ``two-size-E``, ``two-size-F``), lengths in inches (seed Sec. 5.2).
    """
    key = _ALIASES.get(str(kind).lower(), str(kind).upper())
    if key not in ARRAYS:
        raise GrainmechError(f"packing must be one of A-F or {', '.join(_ALIASES)}; got {kind!r}")
    return ARRAYS[key]


def regular_array(kind: str, diameter: float = ROD["diameter"]) -> RodContactSet:
    """Physical contact set (each contact once, branch = centre-to-centre) of a lattice.

    ``kind`` as in :func:`array_geometry`. All lengths are scaled by
    ``diameter / 0.5 in``: ``diameter`` is the diameter of the seed's 0.5 in rods (for E
    the large rods, for F the small ones), in any length unit. E.g. ``square``: normals
    along x and y, one rod per ``d^2``, 2 contacts per rod; ``hexagonal``: normals at 0, 60,
    120 deg from x, one rod per ``(sqrt 3/2) d^2``, 3 contacts per rod.
    """
    if not np.isfinite(diameter) or diameter <= 0:
        raise GrainmechError(f"diameter must be > 0, got {diameter!r}")
    return array_geometry(kind).contact_set(scale=diameter / ROD["diameter"])


def packing_geometry(kind: str) -> PeriodicRods:
    """:func:`array_geometry` under its old name (deprecated: warns, removed in the next release)."""
    warn_renamed(f"{__name__}.packing_geometry", f"{__name__}.array_geometry")
    return array_geometry(kind)


def regular_packing(kind: str, diameter: float = ROD["diameter"]) -> RodContactSet:
    """:func:`regular_array` under its old name (deprecated: warns, removed in the next release)."""
    warn_renamed(f"{__name__}.regular_packing", f"{__name__}.regular_array")
    return regular_array(kind, diameter)


def __getattr__(name: str) -> Any:
    # ``PACKINGS``: the old name of :data:`ARRAYS` (one release, with a warning)
    return renamed_attribute(__name__, name, {"PACKINGS": "ARRAYS"}, globals())

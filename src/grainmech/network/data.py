"""Contact-network data: the simulation cell and the contacts.

Contact-network data: the simulation cell (:class:`Box`) and the contacts
(:class:`ContactNetwork`) in grainmech's counting convention (``docs/conventions.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from grainmech.errors import GrainmechError

__all__ = ["Box", "ContactNetwork", "solid_volume", "void_ratio"]

#: rows per block of the input checks of ContactNetwork (bounded temporaries)
_CHECK_BLOCK = 1 << 16


def solid_volume(radii: ArrayLike) -> float:
    """Volume of the spheres of radii ``radii``, ``V_s = sum 4/3 pi r^3`` [length^3]."""
    return float(np.sum(4.0 / 3.0 * np.pi * np.asarray(radii, dtype=float) ** 3))


def void_ratio(volume: float, solid: float) -> float:
    """Void ratio ``e = V / V_s - 1`` of a cell of volume ``V`` holding solid volume ``V_s`` [-]."""
    return float(volume / solid - 1.0)


@dataclass(frozen=True)
class Box:
    """Simulation cell: ``origin`` and cell vectors (rows of ``cell``).

    Parameters
    ----------
    origin : array (d,)
        Lower corner [length].
    cell : array (d, d)
        Rows are the cell vectors ``a, b, c``; for a LAMMPS triclinic box
        ``a = (lx, 0, 0)``, ``b = (xy, ly, 0)``, ``c = (xz, yz, lz)`` [length].
    periodic : array (d,) of bool
        Periodicity along each cell vector.
    """

    origin: np.ndarray
    cell: np.ndarray
    periodic: np.ndarray

    def __post_init__(self) -> None:
        o = np.asarray(self.origin, dtype=float)
        c = np.asarray(self.cell, dtype=float)
        p = np.asarray(self.periodic, dtype=bool)
        d = o.shape[0] if o.ndim == 1 else -1
        if d not in (2, 3) or c.shape != (d, d) or p.shape != (d,):
            raise GrainmechError(f"box: origin (d,), cell (d, d), periodic (d,) expected, got "
                                 f"{o.shape}, {c.shape}, {p.shape}")
        if not (np.all(np.isfinite(o)) and np.all(np.isfinite(c))):
            raise GrainmechError("box: origin and cell must be finite")
        if abs(np.linalg.det(c)) <= 0:
            raise GrainmechError(f"box: cell vectors are degenerate (volume 0): {c.tolist()}")
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "cell", c)
        object.__setattr__(self, "periodic", p)

    @classmethod
    def orthogonal(cls, lo: ArrayLike, hi: ArrayLike, periodic: ArrayLike = True) -> Box:
        """Axis-aligned box from its bounds ``lo``, ``hi`` (d,) and periodic flags (d,) or one for all."""
        lo_ = np.asarray(lo, dtype=float)
        hi_ = np.asarray(hi, dtype=float)
        per = np.broadcast_to(np.asarray(periodic, dtype=bool), lo_.shape)
        return cls(lo_, np.diag(hi_ - lo_), per.copy())

    @property
    def dim(self) -> int:
        """Space dimension (2 or 3)."""
        return int(self.origin.shape[0])

    @property
    def volume(self) -> float:
        """Cell volume ``|det(cell)|`` (area in 2D)."""
        return float(abs(np.linalg.det(self.cell)))

    def minimum_image(self, d: np.ndarray) -> np.ndarray:
        """Shortest periodic image of separation vectors ``d`` (n, dim).

        Uses fractional coordinates (``s = d cell^-1``, ``s -= round(s)`` along periodic
        directions), exact for cells that are not extremely skewed and separations below
        half the cell size.
        """
        d = np.asarray(d, dtype=float)
        if not self.periodic.any():
            return d
        inv = np.linalg.inv(self.cell)
        # einsum, not matmul: an (n, 3) @ (3, 3) product goes to a threaded BLAS call that
        # is ~10x slower on a busy machine
        s = np.einsum("ij,jk->ik", d, inv)
        for k in np.flatnonzero(self.periodic):
            s[:, k] -= np.rint(s[:, k])
        return np.einsum("ij,jk->ik", s, self.cell)

    def shift_of(self, raw: np.ndarray, imaged: np.ndarray) -> np.ndarray:
        """Integer cell shifts ``k`` with ``imaged = raw + k cell`` (n, dim)."""
        return np.rint((np.asarray(imaged) - np.asarray(raw)) @ np.linalg.inv(self.cell)).astype(np.int64)


@dataclass(frozen=True, eq=False)
class ContactNetwork:
    """A measured contact network in grainmech's convention (see module notes).

    Parameters
    ----------
    ids : int array (P,)
        Particle ids as in the source file.
    positions : array (P, d)
        Particle centres [length].
    radii : array (P,) or None
        Particle radii [length]; needed for the Hertz law and the rotations.
    box : Box
        Cell; its volume is ``V`` in the weights ``1/V``.
    i, j : int arrays (C,)
        Row indices (into ``ids``) of particles A and B of each contact.
    force : array (C, d)
        Force exerted by A on B, compression positive [force].
    branch : array (C, d)
        ``x_B - x_A`` (periodic minimum image) [length].
    overlap : array (C,) or None
        Overlap (approach) ``R_A + R_B - |l|`` or the DEM's own value [length].
    contact_point : array (C, d) or None
        Contact point from the file [length].
    kn, ks : array (C,) or None
        Contact stiffnesses given in the file [force/length].
    source : str
        Description of the origin (file names) for reports.
    moment : array (C, 3) or None
        Contact moment exerted by A on B (rolling and twisting resistance,
        :mod:`grainmech.contact.rolling`: A receives ``-M``, B ``+M``) [force x length];
        ``None``: the contacts carry no moments.
    """

    ids: np.ndarray
    positions: np.ndarray
    radii: np.ndarray | None
    box: Box
    i: np.ndarray
    j: np.ndarray
    force: np.ndarray
    branch: np.ndarray
    overlap: np.ndarray | None = None
    contact_point: np.ndarray | None = None
    kn: np.ndarray | None = None
    ks: np.ndarray | None = None
    source: str = ""
    moment: np.ndarray | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        d = self.box.dim
        P = len(self.ids)
        C = len(self.i)
        if np.shape(self.positions) != (P, d):
            raise GrainmechError(f"positions must have shape ({P}, {d}), got {np.shape(self.positions)}")
        if self.radii is not None and np.shape(self.radii) != (P,):
            raise GrainmechError(f"radii must have shape ({P},), got {np.shape(self.radii)}")
        if np.shape(self.j) != (C,) or np.shape(self.force) != (C, d) or np.shape(self.branch) != (C, d):
            raise GrainmechError("i, j (C,), force and branch (C, d) must describe the same contacts")
        for name in ("overlap", "kn", "ks"):
            v = getattr(self, name)
            if v is not None and np.shape(v) != (C,):
                raise GrainmechError(f"{name} must have shape ({C},), got {np.shape(v)}")
        if self.moment is not None and np.shape(self.moment) != (C, 3):
            raise GrainmechError(f"moment must have shape ({C}, 3), got {np.shape(self.moment)}")
        # the checks run over blocks of rows: whole-array temporaries (norm's squares are
        # (C, d) floats) would add 0.3x the kept arrays to the peak memory of a reader
        for name in ("positions", "radii", "force", "branch", "overlap", "contact_point", "kn", "ks", "moment"):
            v = getattr(self, name)
            if v is None:
                continue
            for a in range(0, len(v), _CHECK_BLOCK):
                blk = np.asarray(v[a:a + _CHECK_BLOCK], float)
                if not np.isfinite(blk).all():
                    bad = np.argwhere(~np.isfinite(blk))[0]
                    raise GrainmechError(f"{name} has a non-finite value at row {a + int(bad[0])}")
        if C and (self.i.min() < 0 or self.j.max() >= P or self.j.min() < 0 or self.i.max() >= P):
            raise GrainmechError("contact particle indices out of range")
        for a in range(0, C, _CHECK_BLOCK):
            b = np.asarray(self.branch[a:a + _CHECK_BLOCK], float)
            zero = np.flatnonzero(~(np.einsum("ij,ij->i", b, b) > 0))
            if zero.size:
                k = a + int(zero[0])
                raise GrainmechError(f"contact {k} ({self.ids[self.i[k]]}-{self.ids[self.j[k]]}) has a zero "
                                     "branch vector (coincident centres)")

    @property
    def dim(self) -> int:
        """Space dimension (2 or 3)."""
        return self.box.dim

    @property
    def volume(self) -> float:
        """Volume (3D) or area (2D) of the cell [length^d]."""
        return self.box.volume

    @property
    def n_particles(self) -> int:
        """Number of particles ``P``."""
        return int(len(self.ids))

    @property
    def n_contacts(self) -> int:
        """Number of contacts ``C``."""
        return int(len(self.i))

    @property
    def branch_length(self) -> np.ndarray:
        """Length of each branch vector, shape (C,) [length]."""
        if "L" not in self._cache:
            self._cache["L"] = np.linalg.norm(self.branch, axis=1)
        return self._cache["L"]

    @property
    def normals(self) -> np.ndarray:
        """Unit normals A -> B along the branch vector (spheres), (C, d)."""
        if "n" not in self._cache:
            self._cache["n"] = self.branch / self.branch_length[:, None]
        return self._cache["n"]

    @property
    def void_ratio(self) -> float:
        """Void ratio ``e = V / V_s - 1`` of the cell, ``V_s`` the volume of every sphere (rattlers included)."""
        return void_ratio(self.volume, solid_volume(self.require_radii("the void ratio")))

    def effective_radii(self, what: str) -> np.ndarray:
        """``R* = R_A R_B / (R_A + R_B)`` of every contact (C,) [length] (seed Eq. 3.3).

        ``what`` names the computation for the error of a network without radii.
        """
        R = self.require_radii(what)
        return R[self.i] * R[self.j] / (R[self.i] + R[self.j])

    def require_radii(self, what: str) -> np.ndarray:
        """Particle radii (P,) [length], or an error saying that ``what`` needs them.

        Parameters
        ----------
        what : str
            The computation that needs the radii, for the message.

        Raises
        ------
        GrainmechError
            If the network has no radii (e.g. a contact file read without particles).
        """
        if self.radii is None:
            raise GrainmechError(f"{what} needs the particle radii, which this network ({self.source}) lacks")
        return self.radii

    @property
    def normal_force(self) -> np.ndarray:
        """Normal force ``N = f . n`` (compression positive), (C,)."""
        return np.einsum("ij,ij->i", self.force, self.normals)

    def subset(self, contacts: np.ndarray) -> ContactNetwork:
        """The same particles with only the selected contacts (bool mask or indices)."""
        sel = np.asarray(contacts)
        def pick(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[sel]

        return ContactNetwork(self.ids, self.positions, self.radii, self.box, self.i[sel], self.j[sel],
                              self.force[sel], self.branch[sel], pick(self.overlap),
                              pick(self.contact_point), pick(self.kn), pick(self.ks), self.source,
                              pick(self.moment))

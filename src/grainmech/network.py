"""Measured contact networks (DEM output): measures, affine and relaxed stiffness.

A :class:`ContactNetwork` holds the particles (ids, centres, radii), the simulation cell
(:class:`Box`, periodic and possibly triclinic) and the contacts in grainmech's counting
convention (``docs/conventions.md``): every physical contact once, from particle ``A``
(``i``) to particle ``B`` (``j``), branch vector ``l = x_B - x_A`` (minimum image across
periodic boundaries), unit normal ``n = l/|l|`` (spheres), and the force ``f`` exerted
**by A on B**, compression positive (``N = f . n >= 0`` for a compressive contact).
Readers in :mod:`grainmech.io.dem` convert DEM files to this form.

Measures
--------
* :func:`network_stress` - Love (1927) / Weber (1966) average stress, seed Eq. 2.6-2.7,
  ``sigma = (1/V) sum_c f_c (x) l_c`` with its skew part (zero at equilibrium).
* :func:`network_fabric` - contact-normal and branch-vector fabric tensors of rank 2 and
  4 (seed Eq. 4.6) and the anisotropy of the rank-2 tensors.
* :func:`coordination` - coordination numbers with and without rattlers.
* :func:`contact_stiffnesses` - per-contact ``kn``, ``ks`` from the Hertz-Mindlin law
  (seed Eq. 3.2, 3.5, 3.7, 3.11-3.12) using each contact's overlap or normal force.

Stiffness
---------
* :func:`affine_stiffness` - the kinematic-hypothesis tensor of seed Eq. 2.26 with the
  full tangential projector ``ks (I - n n)`` (weights ``1/V``).
* :func:`relaxed_stiffness` - the exact small-strain tangent of the network: the
  particles (translations and rotations, periodic cell, rattlers removed) are allowed
  to relax to equilibrium under each unit strain,
  ``C_relaxed = C_affine - (1/V) B^T H^+ B`` (the "non-affine correction" of
  Lemaitre & Maloney 2006; Agnolin & Roux 2007; Kruyt & Rothenburg 1998).

Also: :func:`network_report` (everything above as a JSON-ready dict, used by
``grainmech dem``), :func:`closed_form_from_fit` (seed Eq. 4.21-4.33 from the fitted
fabric), :func:`plot_rose` and :func:`plot_normal_density` (matplotlib, imported lazily),
and synthetic periodic networks :func:`lattice_network` (sc, fcc) and
:func:`random_network` for tests and benchmarks. See ``docs/dem.md``.

Stiffness terms only: the contact stiffness ``K = kn n n + ks (I - n n)`` is used
unchanged; with ``geometric=True`` the term ``-(N/|l|) (I - n n)`` (the rotation of a
pre-loaded normal force with the branch vector) is added to ``K``, i.e. ``ks`` becomes
``ks - N/|l|``. The change ``f (x) dl`` of the stress under strain and the change of
volume are not included in either tensor.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from grainmech.assembly import ContactSet, StressResult, love_weber_stress, stiffness
from grainmech.errors import GrainmechError

__all__ = [
    "Box",
    "ContactNetwork",
    "network_stress",
    "network_fabric",
    "FabricResult",
    "coordination",
    "CoordinationResult",
    "rattlers",
    "rattler_threshold",
    "contact_stiffnesses",
    "affine_stiffness",
    "relaxed_stiffness",
    "RelaxedResult",
    "strain_map",
    "lattice_network",
    "random_network",
    "network_report",
    "closed_form_from_fit",
    "plot_rose",
    "plot_normal_density",
]


# --------------------------------------------------------------------------- geometry

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
    def orthogonal(cls, lo: Sequence[float], hi: Sequence[float],
                   periodic: Sequence[bool] | bool = True) -> "Box":
        """Axis-aligned box from its bounds."""
        lo_ = np.asarray(lo, dtype=float)
        hi_ = np.asarray(hi, dtype=float)
        per = np.broadcast_to(np.asarray(periodic, dtype=bool), lo_.shape)
        return cls(lo_, np.diag(hi_ - lo_), per.copy())

    @property
    def dim(self) -> int:
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
        s = d @ inv
        s[:, self.periodic] -= np.round(s[:, self.periodic])
        return s @ self.cell

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
        for name in ("positions", "radii", "force", "branch", "overlap", "contact_point", "kn", "ks"):
            v = getattr(self, name)
            if v is not None and not np.all(np.isfinite(v)):
                bad = np.argwhere(~np.isfinite(np.asarray(v, float)))[0]
                raise GrainmechError(f"{name} has a non-finite value at row {int(bad[0])}")
        if C and (self.i.min() < 0 or self.j.max() >= P or self.j.min() < 0 or self.i.max() >= P):
            raise GrainmechError("contact particle indices out of range")
        L = np.linalg.norm(self.branch, axis=1)
        if C and not np.all(L > 0):
            k = int(np.flatnonzero(~(L > 0))[0])
            raise GrainmechError(f"contact {k} ({self.ids[self.i[k]]}-{self.ids[self.j[k]]}) has a zero "
                                 "branch vector (coincident centres)")

    @property
    def dim(self) -> int:
        return self.box.dim

    @property
    def volume(self) -> float:
        return self.box.volume

    @property
    def n_particles(self) -> int:
        return int(len(self.ids))

    @property
    def n_contacts(self) -> int:
        return int(len(self.i))

    @property
    def branch_length(self) -> np.ndarray:
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
    def normal_force(self) -> np.ndarray:
        """Normal force ``N = f . n`` (compression positive), (C,)."""
        return np.einsum("ij,ij->i", self.force, self.normals)

    def subset(self, contacts: np.ndarray) -> "ContactNetwork":
        """The same particles with only the selected contacts (bool mask or indices)."""
        sel = np.asarray(contacts)
        pick = (lambda a: None if a is None else a[sel])
        return ContactNetwork(self.ids, self.positions, self.radii, self.box, self.i[sel], self.j[sel],
                              self.force[sel], self.branch[sel], pick(self.overlap),
                              pick(self.contact_point), pick(self.kn), pick(self.ks), self.source)


# --------------------------------------------------------------------------- measures

def network_stress(net: ContactNetwork) -> StressResult:
    """Love-Weber average stress of the network (Love 1927; Weber 1966; seed Eq. 2.6-2.7).

    ``sigma_ij = (1/V) sum_c f_i l_j`` with ``f`` the force by A on B and ``l = x_B - x_A``;
    compression positive. The skew part (``StressResult.skew``, ratio ``skew_ratio``) is
    the mean torque density and vanishes when every particle is in moment equilibrium.

    Returns
    -------
    StressResult
        Stress in force/length^2 (3D) or force/length (2D).
    """
    return love_weber_stress(net.force, net.branch, 1.0 / net.volume)


@dataclass(frozen=True)
class FabricResult:
    """Fabric tensors of a network (seed Eq. 4.6).

    Attributes
    ----------
    normal2, normal4 : arrays (d, d), (d, d, d, d)
        ``<n (x) n>``, ``<n (x) n (x) n (x) n>`` over contacts (unit trace).
    branch2, branch4 : arrays
        Branch fabric ``sum l^(x)k / sum |l|^k`` (k = 2, 4): the normal fabric of the
        branch directions weighted by ``|l|^k``; equal to the normal fabric for equal
        spheres.
    normal_anisotropy, branch_anisotropy : grainmech.fabric.Anisotropy
        Anisotropy of the rank-2 tensors (deviatoric norm, principal axes).
    n_contacts : int
    """

    normal2: np.ndarray
    normal4: np.ndarray
    branch2: np.ndarray
    branch4: np.ndarray
    normal_anisotropy: Any
    branch_anisotropy: Any
    n_contacts: int


def network_fabric(net: ContactNetwork, *, force_carrying: bool = False) -> FabricResult:
    """Contact-normal and branch-vector fabric tensors of rank 2 and 4 and anisotropy.

    Parameters
    ----------
    net : ContactNetwork
    force_carrying : bool
        Only contacts with ``N > 0``.
    """
    from grainmech.fabric import anisotropy, fabric_tensor

    sel = net.normal_force > 0 if force_carrying else slice(None)
    n = net.normals[sel]
    if n.shape[0] == 0:
        raise GrainmechError(f"{net.source or 'network'}: no contacts to compute a fabric from")
    L = net.branch_length[sel]
    N2 = fabric_tensor(n, 2)
    N4 = fabric_tensor(n, 4)
    B2 = fabric_tensor(n, 2, weights=L ** 2)
    B4 = fabric_tensor(n, 4, weights=L ** 4)
    return FabricResult(N2, N4, B2, B4, anisotropy(N2), anisotropy(B2), int(n.shape[0]))


def rattlers(net: ContactNetwork, min_contacts: int | None = None,
             carrying: np.ndarray | None = None) -> np.ndarray:
    """Rattler mask, found by iterative removal.

    A particle is a rattler if it has fewer than ``min_contacts`` force-carrying contacts
    with non-rattlers (default ``d + 1``: 4 in 3D, 3 in 2D, the minimum for a frictional
    sphere to be held by non-parallel contacts with positive normal forces). Removal is
    repeated until no further particle drops out.

    Parameters
    ----------
    net : ContactNetwork
    min_contacts : int, optional
    carrying : bool array (C,), optional
        Force-carrying contacts; default ``N > 0``.

    Returns
    -------
    bool array (P,)
        True for rattlers (including particles without any contact).
    """
    m = net.dim + 1 if min_contacts is None else int(min_contacts)
    if m < 0:
        raise GrainmechError(f"min_contacts must be >= 0, got {m}")
    keep_c = net.normal_force > 0 if carrying is None else np.asarray(carrying, dtype=bool)
    P = net.n_particles
    alive = np.ones(P, dtype=bool)
    ci, cj = net.i[keep_c], net.j[keep_c]
    while True:
        ok = alive[ci] & alive[cj]
        deg = np.bincount(ci[ok], minlength=P) + np.bincount(cj[ok], minlength=P)
        drop = alive & (deg < m)
        if not drop.any():
            return ~alive
        alive &= ~drop


def rattler_threshold(dim: int, frictional: bool, rotations: bool = True) -> int:
    """Fewest force-carrying contacts that can hold a grain (the rattler rule).

    * frictionless grains (no tangential stiffness): ``d + 1`` contacts, the minimum for
      positive normal forces along non-parallel lines to balance any load;
    * frictional grains with rotations (tangential springs): 2 - a grain pressed between
      two neighbours is held (its tangential springs resist sliding and, with the rotation
      fixed by the moment balance, rolling is resisted too), which is Thornton's (2000)
      "mechanical" coordination rule (particles with zero or one contact excluded).

    Applying the frictionless rule ``d + 1`` to a loose frictional packing removes grains
    that are in fact held, and iterated, it can remove every grain.
    """
    if frictional and rotations:
        return 2
    return dim + 1


@dataclass(frozen=True)
class CoordinationResult:
    """Coordination numbers (see :func:`coordination`)."""

    z: float
    z_force: float
    z_mechanical: float
    n_particles: int
    n_contacts: int
    n_force_carrying: int
    n_rattlers: int
    rattler_fraction: float
    min_contacts: int
    definition: str


def coordination(net: ContactNetwork, min_contacts: int | None = None) -> CoordinationResult:
    """Coordination numbers with and without rattlers.

    * ``z = 2 C / P``: all ``C`` listed contacts over all ``P`` particles;
    * ``z_force = 2 C_f / P``: force-carrying contacts (``N > 0``) only;
    * ``z_mechanical = 2 C_f' / P'`` (Thornton 2000): rattlers removed iteratively
      (:func:`rattlers`, fewer than ``min_contacts`` = d + 1 force-carrying contacts),
      counting only force-carrying contacts between the ``P'`` remaining particles.
    """
    m = net.dim + 1 if min_contacts is None else int(min_contacts)
    carrying = net.normal_force > 0
    ratt = rattlers(net, m, carrying)
    P, C, Cf = net.n_particles, net.n_contacts, int(carrying.sum())
    alive = ~ratt
    Cm = int((carrying & alive[net.i] & alive[net.j]).sum())
    Pm = int(alive.sum())
    return CoordinationResult(
        z=2.0 * C / P if P else 0.0, z_force=2.0 * Cf / P if P else 0.0,
        z_mechanical=2.0 * Cm / Pm if Pm else 0.0, n_particles=P, n_contacts=C,
        n_force_carrying=Cf, n_rattlers=int(ratt.sum()), rattler_fraction=float(ratt.mean()) if P else 0.0,
        min_contacts=m,
        definition=(f"z = 2C/P; z_force counts contacts with N > 0; z_mechanical removes rattlers "
                    f"(particles with fewer than {m} force-carrying contacts, iteratively) and "
                    "counts force-carrying contacts among the rest"))


# --------------------------------------------------------------------------- contact law

def contact_stiffnesses(net: ContactNetwork, *, shear_modulus: float | None = None,
                        poisson: float | None = None, source: str = "auto",
                        kn: float | None = None, ks: float | None = None) -> tuple[np.ndarray, np.ndarray, str]:
    """Per-contact tangent stiffnesses ``kn``, ``ks`` [force/length].

    Parameters
    ----------
    net : ContactNetwork
    shear_modulus, poisson : float
        Grain elastic constants (Hertz-Mindlin law).
    source : {"auto", "overlap", "force", "columns", "constant"}
        * ``overlap``: contact radius ``a = sqrt(R* alpha)`` (seed Eq. 3.5) from the
          overlap ``alpha`` (file column, else ``R_A + R_B - |l|``);
        * ``force``: ``a = (3 N R* / (4 E*))^(1/3)`` (seed Eq. 3.2) from ``N = f . n``;
        * ``columns``: ``kn``, ``ks`` columns of the file;
        * ``constant``: the given ``kn``, ``ks`` for every contact;
        * ``auto``: columns if present, else constant if given, else overlap if
          available (radii or overlap column), else force.
        Then ``kn = 2 E* a`` (Eq. 3.7) and ``ks = 8 G* a`` (Eq. 3.11-3.12, no slip) with
        ``1/R* = 1/R_A + 1/R_B`` and the effective moduli of :class:`grainmech.contact.Hertz`.

    Returns
    -------
    kn, ks : arrays (C,)
    used : str
        The source actually used.
    """
    if source not in ("auto", "overlap", "force", "columns", "constant"):
        raise GrainmechError(f"stiffness source must be auto, overlap, force, columns or constant, got {source!r}")
    if source == "auto":
        if net.kn is not None and net.ks is not None:
            source = "columns"
        elif kn is not None:
            source = "constant"
        elif net.overlap is not None or net.radii is not None:
            source = "overlap"
        else:
            source = "force"
    C = net.n_contacts
    if source == "columns":
        if net.kn is None or net.ks is None:
            raise GrainmechError(f"{net.source}: stiffness source 'columns' needs kn and ks columns "
                                 "in the contact file")
        return np.asarray(net.kn, float), np.asarray(net.ks, float), source
    if source == "constant":
        if kn is None:
            raise GrainmechError("stiffness source 'constant' needs kn (and ks)")
        kn_ = float(kn)
        ks_ = float(kn if ks is None else ks)
        if not (np.isfinite(kn_) and np.isfinite(ks_) and kn_ >= 0 and ks_ >= 0):
            raise GrainmechError(f"kn, ks must be finite and >= 0, got {kn_!r}, {ks_!r}")
        return np.full(C, kn_), np.full(C, ks_), source
    if shear_modulus is None or poisson is None:
        raise GrainmechError(f"stiffness source {source!r} (Hertz-Mindlin) needs the grain shear_modulus "
                             "and poisson (give --material CONFIG.toml)")
    from grainmech.contact import Hertz

    hz = Hertz(shear_modulus, poisson, 1.0)  # E*, G* do not depend on the radii
    Es, Gs = hz.effective_modulus, hz.effective_shear_modulus
    if net.radii is None:
        raise GrainmechError(f"{net.source}: the Hertz-Mindlin law needs particle radii (give a particle file)")
    Ra, Rb = net.radii[net.i], net.radii[net.j]
    Rs = Ra * Rb / (Ra + Rb)
    if source == "overlap":
        alpha = net.overlap if net.overlap is not None else Ra + Rb - net.branch_length
        a = np.sqrt(Rs * np.maximum(alpha, 0.0))
    else:
        a = np.cbrt(0.75 * np.maximum(net.normal_force, 0.0) * Rs / Es)
    return 2.0 * Es * a, 8.0 * Gs * a, source


def _effective_ks(net: ContactNetwork, ks: np.ndarray, geometric: bool) -> np.ndarray:
    if not geometric:
        return np.asarray(ks, float)
    return np.asarray(ks, float) - net.normal_force / net.branch_length


# --------------------------------------------------------------------------- affine

def strain_map(branch: np.ndarray) -> np.ndarray:
    """Per-contact map ``E_c`` (C, d, m) from the Voigt strain vector to ``eps . l``.

    ``(eps . l)_i = sum_a E[c, i, a] e_a`` with ``e = (e_xx, e_yy, e_zz, 2e_yz, 2e_xz,
    2e_xy)`` (3D) or ``(e_xx, e_yy, 2e_xy)`` (2D): under the kinematic hypothesis (seed
    Eq. 2.13) this is the displacement of A relative to B (compression positive).
    """
    l_ = np.asarray(branch, float)
    C, d = l_.shape
    if d == 3:
        E = np.zeros((C, 3, 6))
        E[:, 0, 0] = l_[:, 0]
        E[:, 1, 1] = l_[:, 1]
        E[:, 2, 2] = l_[:, 2]
        E[:, 1, 3] = 0.5 * l_[:, 2]
        E[:, 2, 3] = 0.5 * l_[:, 1]
        E[:, 0, 4] = 0.5 * l_[:, 2]
        E[:, 2, 4] = 0.5 * l_[:, 0]
        E[:, 0, 5] = 0.5 * l_[:, 1]
        E[:, 1, 5] = 0.5 * l_[:, 0]
    else:
        E = np.zeros((C, 2, 3))
        E[:, 0, 0] = l_[:, 0]
        E[:, 1, 1] = l_[:, 1]
        E[:, 0, 2] = 0.5 * l_[:, 1]
        E[:, 1, 2] = 0.5 * l_[:, 0]
    return E


def affine_stiffness(net: ContactNetwork, kn: np.ndarray, ks: np.ndarray, *,
                     geometric: bool = False, mandel: bool = False) -> np.ndarray:
    """Affine (kinematic-hypothesis) stiffness of the network, seed Eq. 2.26.

    ``C_ijkl = sym (1/V) sum_c K_ik l_j l_l`` with ``K = kn n n + ks (I - n n)`` (full
    tangential projector), every contact once with its branch vector.

    Parameters
    ----------
    net : ContactNetwork
    kn, ks : arrays (C,)
        Contact stiffnesses [force/length] (see :func:`contact_stiffnesses`).
    geometric : bool
        Add ``-(N/|l|) (I - n n)`` to ``K`` (see module notes); default stiffness terms only.
    mandel : bool
        Mandel instead of Voigt matrix.

    Returns
    -------
    array (6, 6) (3D) or (3, 3) (2D)
        Library order ``(xx, yy, zz, yz, xz, xy)``, Voigt [stress].
    """
    ks_e = _effective_ks(net, ks, geometric)
    if np.any(ks_e < 0):
        # the assembly kernel requires ks >= 0: assemble directly
        E = strain_map(net.branch)
        K = _local_K(net.normals, np.asarray(kn, float), ks_e)
        Cv = np.einsum("cia,cij,cjb->ab", E, K, E) / net.volume
        from grainmech.conventions import voigt_to_mandel
        return voigt_to_mandel(Cv) if mandel else Cv
    cs = ContactSet(net.normals, net.branch, 1.0 / net.volume, kn, ks_e)
    return stiffness(cs, mandel=mandel)


def _local_K(n: np.ndarray, kn: np.ndarray, ks: np.ndarray) -> np.ndarray:
    d = n.shape[1]
    nn = n[:, :, None] * n[:, None, :]
    return (kn - ks)[:, None, None] * nn + ks[:, None, None] * np.eye(d)[None]


# --------------------------------------------------------------------------- relaxed

@dataclass(frozen=True)
class RelaxedResult:
    """Result of :func:`relaxed_stiffness`.

    Attributes
    ----------
    C_relaxed, C_affine : arrays (6, 6)
        Voigt, library order, of the network the solve used (rattlers removed).
    correction : array (6, 6)
        ``C_affine - C_relaxed = (1/V) B^T H^+ B`` (positive semi-definite).
    displacements : array (P, 6, 6) or None
        Non-affine fluctuation per particle (translation 3, rotation 3) for each unit
        strain column; zero rows for rattlers.
    n_particles, n_contacts, n_rattlers : int
    solver : str
        ``"direct"`` (SuperLU) or ``"cg"`` (block-Jacobi preconditioned CG).
    iterations : int
    residual : float
        ``max_k |H q_k + B_k| / max(|B_k|, 1e-6 |B_k|_gross)`` where the gross norm is
        taken before cancellation between contacts.
    """

    C_relaxed: np.ndarray
    C_affine: np.ndarray
    correction: np.ndarray
    displacements: np.ndarray | None
    n_particles: int
    n_contacts: int
    n_rattlers: int
    solver: str
    iterations: int
    residual: float


def _cross_matrix(r: np.ndarray) -> np.ndarray:
    """[r]_x with [r]_x v = r x v, shape (C, 3, 3)."""
    X = np.zeros(r.shape[:-1] + (3, 3))
    X[..., 0, 1] = -r[..., 2]
    X[..., 0, 2] = r[..., 1]
    X[..., 1, 0] = r[..., 2]
    X[..., 1, 2] = -r[..., 0]
    X[..., 2, 0] = -r[..., 1]
    X[..., 2, 1] = r[..., 0]
    return X


def _assemble(net: ContactNetwork, alive_idx: np.ndarray, ci: np.ndarray, cj: np.ndarray,
              n: np.ndarray, l_: np.ndarray, kn: np.ndarray, ks: np.ndarray,
              rA: np.ndarray, rB: np.ndarray, rotations: bool):
    """Block Hessian H (BSR, b x b blocks) and B (ndof, m) of the relaxed problem."""
    import scipy.sparse as sp

    d = n.shape[1]
    b = 2 * d if (rotations and d == 3) else (d + 1 if rotations else d)
    P = alive_idx.size
    C = ci.size
    K = _local_K(n, kn, ks)  # (C, d, d)
    # Delta = G_A q_A + G_B q_B + E e;  G_A = [I, -[rA]x], G_B = [-I, +[rB]x]
    GA = np.zeros((C, d, b))
    GB = np.zeros((C, d, b))
    GA[:, :, :d] = np.eye(d)
    GB[:, :, :d] = -np.eye(d)
    if rotations:
        if d == 3:
            GA[:, :, 3:] = -_cross_matrix(rA)
            GB[:, :, 3:] = _cross_matrix(rB)
        else:  # theta e_z x r = theta (-r_y, r_x)
            GA[:, 0, 2], GA[:, 1, 2] = -rA[:, 1], rA[:, 0]
            GB[:, 0, 2], GB[:, 1, 2] = rB[:, 1], -rB[:, 0]
    KGA = K @ GA
    KGB = K @ GB
    GAt = np.swapaxes(GA, 1, 2)
    GBt = np.swapaxes(GB, 1, 2)
    HAA = GAt @ KGA
    HBB = GBt @ KGB
    HAB = GAt @ KGB
    E = strain_map(l_)
    m = E.shape[2]
    KE = K @ E
    BA = GAt @ KE  # (C, b, m)
    BB = GBt @ KE
    # diagonal blocks
    diag = np.zeros((P, b, b))
    np.add.at(diag, ci, HAA)
    np.add.at(diag, cj, HBB)
    rows = np.concatenate([np.arange(P), ci, cj])
    cols = np.concatenate([np.arange(P), cj, ci])
    blocks = np.concatenate([diag, HAB, np.swapaxes(HAB, 1, 2)])
    order = np.lexsort((cols, rows))
    rows, cols, blocks = rows[order], cols[order], blocks[order]
    key = rows * P + cols
    first = np.concatenate([[True], key[1:] != key[:-1]])
    starts = np.flatnonzero(first)
    blocks = np.add.reduceat(blocks, starts, axis=0)
    rows, cols = rows[starts], cols[starts]
    indptr = np.searchsorted(rows, np.arange(P + 1))
    H = sp.bsr_matrix((blocks, cols, indptr), shape=(P * b, P * b))
    Bm = np.zeros((P, b, m))
    np.add.at(Bm, ci, BA)
    np.add.at(Bm, cj, BB)
    Caff = np.einsum("cia,cib->ab", E, KE)
    # size of B before cancellation between contacts (scale for residuals)
    bref = np.sqrt(np.einsum("cia,cia->a", BA, BA) + np.einsum("cia,cia->a", BB, BB))
    return H, Bm.reshape(P * b, m), Caff, diag, b, bref


def _block_cg(H, rhs: np.ndarray, diag_blocks: np.ndarray, tol: float, maxiter: int,
              ref: np.ndarray) -> tuple[np.ndarray, int, float]:
    """Block-Jacobi preconditioned CG, all right-hand sides at once (columns independent)."""
    P, b, _ = diag_blocks.shape
    # pseudo-inverse of each diagonal block (handles zero rotation blocks)
    Minv = np.linalg.pinv(diag_blocks, hermitian=True)

    def prec(r):
        return np.matmul(Minv, r.reshape(P, b, -1)).reshape(r.shape)

    x = np.zeros_like(rhs)
    r = rhs.copy()
    z = prec(r)
    p = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    nb = np.maximum(np.linalg.norm(rhs, axis=0), ref)
    nb[nb == 0] = 1.0
    it = 0
    res = np.linalg.norm(r, axis=0) / nb
    while it < maxiter and res.max() > tol:
        Hp = H @ p
        pHp = np.einsum("ij,ij->j", p, Hp)
        active = pHp > 0
        alpha = np.where(active, rz / np.where(active, pHp, 1.0), 0.0)
        x += p * alpha
        r -= Hp * alpha
        z = prec(r)
        rz_new = np.einsum("ij,ij->j", r, z)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        p = z + p * beta
        rz = rz_new
        it += 1
        res = np.linalg.norm(r, axis=0) / nb
    return x, it, float(res.max())


def relaxed_stiffness(net: ContactNetwork, kn: np.ndarray, ks: np.ndarray, *,
                      remove_rattlers: bool = True, min_contacts: int | None = None,
                      rotations: bool = True, geometric: bool = False, solver: str = "auto",
                      tol: float = 1e-10, maxiter: int = 20000,
                      return_displacements: bool = False) -> RelaxedResult:
    """Relaxed (non-affine) small-strain stiffness of a contact network.

    Each particle ``p`` has a fluctuation ``q_p = (u_p, theta_p)`` on top of the affine
    field ``-eps x`` (compression-positive strain); periodic images share ``q``. The
    displacement of contact point ``A`` relative to ``B`` is

        ``Delta_c = eps . l_c + u_A - u_B + theta_A x r_A - theta_B x r_B``,

    with lever arms ``r_A = R_A n``, ``r_B = -R_B n`` (centre to contact point), and the
    force by A on B is ``f_c = K_c Delta_c``, ``K = kn n n + ks (I - n n)``. Writing
    ``Delta = G q + E e`` the energy density is ``(1/2V) sum_c Delta^T K Delta``;
    minimising over ``q`` (equilibrium of forces and moments on every particle) gives
    ``H q = -B e`` with ``H = sum G^T K G``, ``B = sum G^T K E`` and

        ``C_relaxed = C_affine - (1/V) B^T H^+ B``

    (Lemaitre & Maloney 2006, Eq. 12; Agnolin & Roux 2007; Kruyt & Rothenburg 1998).
    ``B`` lies in the range of ``H`` (a zero mode ``z`` has ``K G z = 0``), so the
    product does not depend on the zero modes: the global translation is pinned (one
    particle's translation fixed) and the remaining floppy modes (e.g. free rotations of
    frictionless grains) are removed by a relative regularisation ``1e-12 diag(H)``.

    Parameters
    ----------
    net : ContactNetwork
        3D (rotations 3 per particle) or 2D (1 per particle).
    kn, ks : arrays (C,)
        Contact stiffnesses [force/length].
    remove_rattlers : bool
        Drop rattlers (:func:`rattlers`; contacts counted as carrying when ``kn > 0``
        and ``N > 0`` if forces are present) and their contacts before solving.
    min_contacts : int, optional
        Rattler threshold; default :func:`rattler_threshold` (2 when any contact has a
        tangential stiffness and rotations are on, else ``d + 1``). If nothing is left
        after removal the function raises :class:`~grainmech.errors.GrainmechError`
        instead of returning zeros.
    rotations : bool
        Include particle rotations (needs radii; without radii the lever arms are
        ``|l|/2``).
    geometric : bool
        Add the geometric term ``-(N/|l|) (I - n n)`` to ``K`` (default off).
    solver : {"auto", "direct", "cg"}
        ``direct`` uses SuperLU; ``cg`` block-Jacobi preconditioned conjugate gradients
        on all 6 right-hand sides at once; ``auto`` is direct up to 15000 unknowns
        (about 2500 particles; SuperLU fill-in grows fast for 3D networks beyond).
    tol, maxiter : CG tolerance (relative residual) and iteration cap.

    Returns
    -------
    RelaxedResult
        Voigt matrices in library order [stress]; ``C_affine`` is that of the solved
        (rattler-free) network.
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    if solver not in ("auto", "direct", "cg"):
        raise GrainmechError(f"solver must be 'auto', 'direct' or 'cg', got {solver!r}")
    d = net.dim
    kn = np.asarray(kn, float)
    ks_e = _effective_ks(net, ks, geometric)
    if kn.shape != (net.n_contacts,) or ks_e.shape != (net.n_contacts,):
        raise GrainmechError(f"kn and ks must have shape ({net.n_contacts},)")
    if not (np.all(np.isfinite(kn)) and np.all(np.isfinite(ks_e))):
        raise GrainmechError("kn and ks must be finite")
    stiff = kn > 0
    if min_contacts is None:
        min_contacts = rattler_threshold(d, bool(np.any(ks_e[stiff] > 0)), rotations)
    if remove_rattlers:
        carrying = stiff & (net.normal_force > 0) if np.any(net.force) else stiff
        ratt = rattlers(net, min_contacts, carrying)
    else:
        carrying = stiff
        ratt = np.zeros(net.n_particles, dtype=bool)
    alive = ~ratt
    csel = (kn != 0) | (ks_e != 0)
    csel &= alive[net.i] & alive[net.j]
    alive_idx = np.flatnonzero(alive)
    m = 6 if d == 3 else 3
    if alive_idx.size == 0 or not csel.any():
        raise GrainmechError(
            f"relaxed stiffness: nothing is left to solve - {int(ratt.sum())} of {net.n_particles} "
            f"particles are rattlers (fewer than {min_contacts} force-carrying contacts, removed "
            f"iteratively; {int(carrying.sum())} of {net.n_contacts} contacts carry force and have "
            "kn > 0). Check the contact forces/stiffnesses, or lower min_contacts")
    newidx = -np.ones(net.n_particles, dtype=np.int64)
    newidx[alive_idx] = np.arange(alive_idx.size)
    ci, cj = newidx[net.i[csel]], newidx[net.j[csel]]
    n = net.normals[csel]
    l_ = net.branch[csel]
    if net.radii is not None:
        RA, RB = net.radii[net.i[csel]], net.radii[net.j[csel]]
    else:
        RA = RB = 0.5 * net.branch_length[csel]
    rA = RA[:, None] * n
    rB = -RB[:, None] * n
    H, B, Caff, diag, b, bref = _assemble(net, alive_idx, ci, cj, n, l_, kn[csel], ks_e[csel], rA, rB, rotations)
    V = net.volume
    P = alive_idx.size
    ndof = P * b
    rhs = -B
    # pin the translation of particle 0 (global translation mode)
    free = np.ones(ndof, dtype=bool)
    free[:d] = False
    use_direct = solver == "direct" or (solver == "auto" and ndof <= 15000)
    Hc = H.tocsr()
    if use_direct:
        Hf = Hc[free][:, free].tocsc()
        dg = Hf.diagonal()
        scale = float(np.max(np.abs(dg))) if dg.size else 1.0
        reg = 1e-12 * np.where(dg > 0, dg, scale)
        Hf = (Hf + sp.diags(reg)).tocsc()
        try:
            lu = spla.splu(Hf)
        except RuntimeError as exc:  # exactly singular even after regularisation
            raise GrainmechError(f"relaxed stiffness: factorisation failed ({exc})") from None
        q = np.zeros((ndof, m))
        q[free] = lu.solve(rhs[free])
        iters = 1
        name = "direct"
    else:
        q, iters, _ = _block_cg(Hc, rhs, diag, tol, maxiter, 1e-6 * bref)
        name = "cg"
    R = Hc @ q - rhs
    nb = np.maximum(np.linalg.norm(rhs, axis=0), 1e-6 * bref)
    scale_r = np.where(nb > 0, nb, 1.0)
    residual = float(np.max(np.linalg.norm(R, axis=0) / scale_r))
    corr = B.T @ q  # = -B^T H^+ B  (q solves H q = -B)
    Ca = Caff / V
    Cr = Ca + corr / V
    Cr = 0.5 * (Cr + Cr.T)
    correction = Ca - Cr
    disp = None
    if return_displacements:
        disp = np.zeros((net.n_particles, b, m))
        disp[alive_idx] = q.reshape(P, b, m)
    if name == "cg" and residual > max(tol * 100, 1e-6):
        raise GrainmechError(f"relaxed stiffness: CG did not converge in {iters} iterations "
                             f"(relative residual {residual:.3g}); raise maxiter or use solver='direct'")
    return RelaxedResult(Cr, Ca, correction, disp, int(P), int(csel.sum()), int(ratt.sum()), name,
                         int(iters), residual)


# --------------------------------------------------------------------------- synthetic networks

def _hertz_forces(net_pos: np.ndarray, radii: np.ndarray, I: np.ndarray, J: np.ndarray, br: np.ndarray,
                  shear_modulus: float, poisson: float) -> tuple[np.ndarray, np.ndarray]:
    from grainmech.contact import Hertz

    Es = Hertz(shear_modulus, poisson, 1.0).effective_modulus
    Ra, Rb = radii[I], radii[J]
    Rs = Ra * Rb / (Ra + Rb)
    L = np.linalg.norm(br, axis=1)
    alpha = np.maximum(Ra + Rb - L, 0.0)
    N = 4.0 / 3.0 * Es * np.sqrt(Rs) * alpha ** 1.5  # seed Eq. 3.6
    return N[:, None] * br / L[:, None], alpha


def lattice_network(kind: str, n_cells: int, radius: float, overlap: float, *,
                    shear_modulus: float = 29e9, poisson: float = 0.15) -> ContactNetwork:
    """Periodic simple-cubic (``"sc"``) or face-centred-cubic (``"fcc"``) packing of equal
    Hertz spheres, every nearest-neighbour pair in contact with the given ``overlap``.

    The nearest-neighbour distance is ``2 radius - overlap``; the cell is
    ``n_cells`` conventional cubes per side (``n_cells >= 3`` so that no pair of particles
    touches twice across the periodic boundaries). Forces follow Hertz (seed Eq. 3.6),
    compression positive.
    """
    if kind not in ("sc", "fcc"):
        raise GrainmechError(f"kind must be 'sc' or 'fcc', got {kind!r}")
    if n_cells < 3:
        raise GrainmechError(f"n_cells must be >= 3, got {n_cells}")
    dnn = 2.0 * radius - overlap
    if kind == "sc":
        a = dnn
        basis = np.zeros((1, 3))
    else:
        a = dnn * np.sqrt(2.0)
        basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    grid = np.stack(np.meshgrid(*[np.arange(n_cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
    pos = ((grid[:, None, :] + basis[None]) * a).reshape(-1, 3)
    L = n_cells * a
    box = Box.orthogonal([0, 0, 0], [L, L, L], True)
    from scipy.spatial import cKDTree

    tree = cKDTree(np.mod(pos, L), boxsize=L)
    pairs = tree.query_pairs(dnn * (1 + 1e-6), output_type="ndarray")
    I, J = pairs[:, 0], pairs[:, 1]
    br = box.minimum_image(pos[J] - pos[I])
    radii = np.full(len(pos), float(radius))
    f, alpha = _hertz_forces(pos, radii, I, J, br, shear_modulus, poisson)
    return ContactNetwork(np.arange(1, len(pos) + 1), pos, radii, box, I, J, f, br, alpha,
                          source=f"{kind} lattice {n_cells}^3")


def random_network(n_particles: int, *, coordination: float = 7.0, cell: np.ndarray | None = None,
                   radius_range: tuple[float, float] = (0.8, 1.2), shear_modulus: float = 29e9,
                   poisson: float = 0.15, tangential: float = 0.3,
                   seed: int | np.random.Generator | None = 0) -> ContactNetwork:
    """Disordered periodic network of polydisperse Hertz spheres (for tests and benchmarks).

    Centres are uniform in the cell; the radii are scaled so that the ``coordination *
    n / 2`` closest pairs (by gap relative to the radius sum) overlap. Normal forces follow
    Hertz from the overlap; tangential forces are random with ``|T| <= tangential N``. The
    network is *not* in equilibrium (use it for stiffness and I/O, not for the skew check).

    Parameters
    ----------
    cell : array (3, 3), optional
        Cell vectors (rows); default a cube of side ``(n_particles)^(1/3) * 2``. Orthogonal
        cells use a k-d tree; general (triclinic) cells a direct search (n <= 4000).
    """
    rng = np.random.default_rng(seed)
    n = int(n_particles)
    if n < 2:
        raise GrainmechError("n_particles must be >= 2")
    side = 2.0 * n ** (1.0 / 3.0)
    cellm = np.diag([side] * 3) if cell is None else np.asarray(cell, float)
    box = Box(np.zeros(3), cellm, np.ones(3, bool))
    s = rng.random((n, 3))
    pos = s @ cellm
    r0 = rng.uniform(radius_range[0], radius_range[1], n)
    target = int(round(coordination * n / 2))
    diag = np.allclose(cellm, np.diag(np.diag(cellm)))
    # candidate pairs: generous cutoff from the mean spacing
    spacing = (box.volume / n) ** (1.0 / 3.0)
    cut = 2.2 * spacing * radius_range[1] / np.mean(radius_range)
    if diag:
        from scipy.spatial import cKDTree

        Ls = np.diag(cellm)
        tree = cKDTree(np.mod(pos, Ls), boxsize=Ls)
        pairs = tree.query_pairs(cut, output_type="ndarray")
        I, J = pairs[:, 0], pairs[:, 1]
    else:
        if n > 4000:
            raise GrainmechError("random_network: triclinic cells are limited to 4000 particles")
        I, J = np.triu_indices(n, 1)
    br = box.minimum_image(pos[J] - pos[I])
    ratio = np.linalg.norm(br, axis=1) / (r0[I] + r0[J])
    if target > ratio.size:
        raise GrainmechError("random_network: coordination too high for the candidate search")
    k = np.argpartition(ratio, target - 1)[:target]
    scale = ratio[k].max() * (1 + 1e-9)
    radii = r0 * scale * (1 + 1e-3)  # all selected pairs overlap by at least ~0.1 %
    I, J, br = I[k], J[k], br[k]
    fN, alpha = _hertz_forces(pos, radii, I, J, br, shear_modulus, poisson)
    nrm = br / np.linalg.norm(br, axis=1)[:, None]
    t = rng.normal(size=(target, 3))
    t -= np.einsum("ij,ij->i", t, nrm)[:, None] * nrm
    t /= np.linalg.norm(t, axis=1)[:, None]
    Nmag = np.linalg.norm(fN, axis=1)
    f = fN + (tangential * rng.random(target) * Nmag)[:, None] * t
    return ContactNetwork(np.arange(1, n + 1), pos, radii, box, I, J, f, br, alpha,
                          source=f"random network n={n}")


# --------------------------------------------------------------------------- report

def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k) if not isinstance(k, tuple) else ",".join(map(str, k)): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if np.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def closed_form_from_fit(fit: Any, net: ContactNetwork, kn: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """Seed closed form (Eq. 4.21-4.33) from a fitted 2nd-order density (3D).

    Uses ``a20, a22, b22`` of the fit (``a21, b21`` are left out, as in Eq. 4.15, so the
    prediction assumes z is a principal fabric axis), the mean ``kn``, ``ks`` over the
    contacts and ``scale = (C/V) <|l|^2>`` (physical counting convention).
    """
    from grainmech.closed_form import spheres_second_order

    sp_ = fit.density.truncated(2).seed_parameters if hasattr(fit.density, "truncated") else fit.density.seed_parameters
    scale = net.n_contacts / net.volume * float(np.mean(net.branch_length ** 2))
    return spheres_second_order(sp_["a20"], sp_["a22"], sp_["b22"], float(np.mean(kn)), float(np.mean(ks)), scale)


def network_report(net: ContactNetwork, *, shear_modulus: float | None = None, poisson: float | None = None,
                   stiffness_source: str = "auto", kn: float | None = None, ks: float | None = None,
                   geometric: bool = False, relaxed: bool = True, solver: str = "auto",
                   remove_rattlers: bool = True, min_contacts: int | None = None,
                   fit_order: int = 2) -> dict:
    """All measures of a network as a JSON-ready dict (used by ``grainmech dem``).

    Keys: ``source``, ``n_particles``, ``n_contacts``, ``volume``, ``box``, ``stress``,
    ``fabric``, ``coordination``, ``stiffness_affine``, ``stiffness_relaxed``,
    ``stiffness_closed_form``, ``engineering_affine``, ``engineering_relaxed``,
    ``order`` (library Voigt order), ``notes``.
    """
    import warnings

    from grainmech.conventions import order_for
    from grainmech.fabric import fit_density
    from grainmech.tensors import engineering_constants

    d = net.dim
    notes: list[str] = []
    st = network_stress(net)
    fab = network_fabric(net)
    if min_contacts is None:
        # frictional if the law has tangential stiffness or the file has tangential forces
        ft = net.force - net.normal_force[:, None] * net.normals if net.n_contacts else net.force
        frictional = (shear_modulus is not None or (ks is not None and ks > 0)
                      or (net.ks is not None and bool(np.any(net.ks > 0))) or bool(np.any(ft != 0)))
        min_contacts = rattler_threshold(d, frictional)
        notes.append(f"rattlers: fewer than {min_contacts} force-carrying contacts "
                     f"({'frictional: 2' if frictional else 'frictionless: d + 1'}), removed iteratively")
    co = coordination(net, min_contacts)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_density(net.normals, fit_order, on_negative="allow")
    out: dict[str, Any] = {
        "source": net.source, "n_particles": net.n_particles, "n_contacts": net.n_contacts,
        "volume": net.volume,
        "box": {"origin": net.box.origin, "cell": net.box.cell, "periodic": net.box.periodic},
        "stress": {"tensor": st.stress, "skew": st.skew, "skew_ratio": st.skew_ratio, "mean": st.mean,
                   "convention": "compression positive; sigma = (1/V) sum f (x) l (Love-Weber)"},
        "fabric": {
            "normal2": fab.normal2, "normal4": fab.normal4, "branch2": fab.branch2, "branch4": fab.branch4,
            "normal_anisotropy": {"deviator_norm": fab.normal_anisotropy.deviator_norm,
                                  "amplitude": fab.normal_anisotropy.amplitude,
                                  "principal_values": fab.normal_anisotropy.principal_values,
                                  "principal_axes": fab.normal_anisotropy.principal_axes},
            "branch_anisotropy": {"deviator_norm": fab.branch_anisotropy.deviator_norm,
                                  "amplitude": fab.branch_anisotropy.amplitude,
                                  "principal_values": fab.branch_anisotropy.principal_values,
                                  "principal_axes": fab.branch_anisotropy.principal_axes},
            "fit": {"order": fit_order, "seed_coefficients": fit.seed_coefficients,
                    "seed_standard_errors": fit.seed_standard_errors, "chi2": fit.chi2, "dof": fit.dof,
                    "p_value": fit.p_value, "message": fit.message},
        },
        "coordination": {k: getattr(co, k) for k in co.__dataclass_fields__},
        "order": list(order_for(d)),
        "shear": "engineering (Voigt)",
    }
    have_law = (shear_modulus is not None and poisson is not None) or kn is not None or \
        (net.kn is not None and net.ks is not None)
    if not have_law:
        notes.append("no contact law (give --material): stiffness tensors not computed")
        out.update(stiffness_affine=None, stiffness_relaxed=None, stiffness_closed_form=None,
                   engineering_affine=None, engineering_relaxed=None, notes=notes)
        return _jsonable(out)
    knv, ksv, used = contact_stiffnesses(net, shear_modulus=shear_modulus, poisson=poisson,
                                         source=stiffness_source, kn=kn, ks=ks)
    out["stiffness_source"] = used
    Ca = affine_stiffness(net, knv, ksv, geometric=geometric)
    out["stiffness_affine"] = Ca
    notes.append("affine: seed Eq. 2.26, full tangential projector, all contacts, stiffness terms only"
                 + (" + geometric term -(N/|l|)(I - nn)" if geometric else ""))

    def eng(C):
        try:
            return engineering_constants(C).as_dict()
        except Exception as exc:  # singular stiffness: report why instead of NaN
            notes.append(f"engineering constants not available: {exc}")
            return None

    out["engineering_affine"] = eng(Ca)
    if d == 3:
        try:
            out["stiffness_closed_form"] = closed_form_from_fit(
                fit_density(net.normals, 2, on_negative="allow") if fit_order != 2 else fit, net, knv, ksv)
            notes.append("closed form: seed Eq. 4.21-4.33 with the fitted a20, a22, b22, mean kn, ks and "
                         "(C/V)<l^2>")
        except GrainmechError as exc:
            out["stiffness_closed_form"] = None
            notes.append(f"closed form not available: {exc}")
    else:
        out["stiffness_closed_form"] = None
    if relaxed:
        rr = relaxed_stiffness(net, knv, ksv, remove_rattlers=remove_rattlers, min_contacts=min_contacts,
                               geometric=geometric, solver=solver)
        out["stiffness_relaxed"] = rr.C_relaxed
        out["stiffness_affine_solved_network"] = rr.C_affine
        out["engineering_relaxed"] = eng(rr.C_relaxed) if np.any(rr.C_relaxed) else None
        out["relaxed"] = {"solver": rr.solver, "iterations": rr.iterations, "residual": rr.residual,
                          "n_particles": rr.n_particles, "n_contacts": rr.n_contacts,
                          "n_rattlers": rr.n_rattlers}
        notes.append("relaxed: C_affine - (1/V) B^T H^+ B, translations and rotations, rattlers "
                     f"{'removed' if remove_rattlers else 'kept'}")
    else:
        out["stiffness_relaxed"] = None
        out["engineering_relaxed"] = None
    out["notes"] = notes
    return _jsonable(out)


# --------------------------------------------------------------------------- plots (matplotlib, lazy)

def plot_rose(net: ContactNetwork, bins: int = 36, weights: str = "count") -> Any:
    """Rose diagrams of the contact normals in the xy, xz and yz planes.

    Each normal (and its opposite) is projected on the plane; the histogram of the in-plane
    angle is drawn in polar axes, weighted by contact count or by the normal force
    (``weights="force"``). Returns a matplotlib ``Figure`` (matplotlib imported here only).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    n = net.normals
    w = np.ones(len(n)) if weights == "count" else np.maximum(net.normal_force, 0.0)
    planes = [("xy", 0, 1), ("xz", 0, 2), ("yz", 1, 2)] if net.dim == 3 else [("xy", 0, 1)]
    fig, axes = plt.subplots(1, len(planes), subplot_kw={"projection": "polar"},
                             figsize=(4 * len(planes), 4), squeeze=False)
    edges = np.linspace(0, 2 * np.pi, bins + 1)
    for ax, (name, a, b) in zip(axes[0], planes):
        ang = np.arctan2(n[:, b], n[:, a])
        ang = np.concatenate([np.mod(ang, 2 * np.pi), np.mod(ang + np.pi, 2 * np.pi)])
        wt = np.concatenate([w, w]) * np.concatenate([np.hypot(n[:, a], n[:, b])] * 2)
        h, _ = np.histogram(ang, edges, weights=wt)
        ax.bar(edges[:-1], h / max(h.max(), 1e-300), width=edges[1] - edges[0], align="edge",
               edgecolor="k", linewidth=0.3)
        ax.set_title(f"{name} plane ({weights})")
        ax.set_yticklabels([])
    fig.tight_layout()
    return fig


def plot_normal_density(net: ContactNetwork, bins: int | None = None) -> Any:
    """Equal-area (Lambert azimuthal, upper hemisphere, z up) density of the contact normals.

    ``n`` and ``-n`` are identified (``n_z >= 0``); the point ``(x, y) = sqrt(2/(1+n_z))
    (n_x, n_y)`` preserves area, so the histogram divided by the uniform expectation is
    the normalised density (1 for an isotropic fabric). 3D only. Returns a ``Figure``.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    if net.dim != 3:
        raise GrainmechError("plot_normal_density is for 3D networks")
    n = net.normals * np.where(net.normals[:, 2:3] < 0, -1.0, 1.0)
    if bins is None:  # about 10 normals per cell on average
        bins = int(np.clip(np.sqrt(4.0 / np.pi * len(n) / 10.0), 6, 60))
    k = np.sqrt(2.0 / (1.0 + n[:, 2]))
    x, y = k * n[:, 0], k * n[:, 1]
    R = np.sqrt(2.0)
    h, xe, ye = np.histogram2d(x, y, bins=bins, range=[[-R, R], [-R, R]])
    cell = (xe[1] - xe[0]) * (ye[1] - ye[0])
    # fraction of each cell inside the projection disc (8 x 8 sub-samples per cell)
    sub = (np.arange(8) + 0.5) / 8
    sx = (xe[:-1, None] + sub[None] * (xe[1] - xe[0])).ravel()
    sy = (ye[:-1, None] + sub[None] * (ye[1] - ye[0])).ravel()
    inside = (sx[:, None] ** 2 + sy[None, :] ** 2 <= R * R).reshape(bins, 8, bins, 8)
    frac = inside.mean(axis=(1, 3))
    expected = len(n) * cell * frac / (np.pi * R * R)
    dens = np.ma.masked_where(frac < 0.25, h / np.where(frac > 0, expected, 1.0))
    fig, ax = plt.subplots(figsize=(5, 4.5))
    im = ax.pcolormesh(xe, ye, dens.T, shading="flat", cmap="viridis")
    ax.add_patch(plt.Circle((0, 0), R, fill=False, color="k", lw=0.8))
    ax.set_aspect("equal")
    ax.set_xlabel("x (equal-area projection)")
    ax.set_ylabel("y")
    ax.set_title("normal density / isotropic\n(equal-area, upper hemisphere, z up)", fontsize=10)
    fig.colorbar(im, ax=ax)
    return fig

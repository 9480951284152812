"""Measures of a contact network.

Measures of a contact network: Love-Weber stress, fabric tensors, rattlers,
coordination numbers and per-contact stiffnesses of the Hertz-Mindlin law.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.assembly import StressResult, love_weber_stress
from grainmech.contact.geometry import hertz_kn, hertz_radius, hertz_radius_from_approach, mindlin_kt0
from grainmech.contact.params import Hertz
from grainmech.errors import GrainmechError
from grainmech.fabric import anisotropy, fabric_tensor
from grainmech.network.data import ContactNetwork

__all__ = ["network_stress", "network_fabric", "FabricResult", "rattlers", "rattler_threshold",
           "coordination", "CoordinationResult", "contact_stiffnesses"]


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
    hz = Hertz(shear_modulus, poisson, 1.0)  # E*, G* do not depend on the radii
    Es, Gs = hz.effective_modulus, hz.effective_shear_modulus
    if net.radii is None:
        raise GrainmechError(f"{net.source}: the Hertz-Mindlin law needs particle radii (give a particle file)")
    Ra, Rb = net.radii[net.i], net.radii[net.j]
    Rs = Ra * Rb / (Ra + Rb)
    if source == "overlap":
        alpha = net.overlap if net.overlap is not None else Ra + Rb - net.branch_length
        a = hertz_radius_from_approach(alpha, Rs)
    else:
        a = hertz_radius(net.normal_force, Es, Rs)
    return hertz_kn(a, Es), mindlin_kt0(a, Gs), source


def _effective_ks(net: ContactNetwork, ks: np.ndarray, geometric: bool) -> np.ndarray:
    if not geometric:
        return np.asarray(ks, float)
    return np.asarray(ks, float) - net.normal_force / net.branch_length

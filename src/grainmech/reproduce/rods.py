"""Seed Figs. 6.1-6.2: apparent modulus and Poisson's ratio of regular rod packings.

Packings A (square) and B (hexagonal) of seed Fig. 5.2: equal aluminium rods of 0.5 in
diameter, 2D (per unit rod length). Rod contacts of seed Eq. 3.8 / 3.17
(:class:`grainmech.contact.Cylinder`: ``G = 15000 psi``, ``Psi = 2.5``, ``nu = 0.1``,
``phi_mu = 15 deg``, Sec. 6.1.1), an isotropic stress of 2.5 psi (Sec. 5.3). Apparent
modulus seed Eq. 6.1 ``E = d sigma_alpha / eps_alpha`` and Poisson's ratio Eq. 6.2
corrected (``docs/seed-errata.md``) ``nu = -eps_(alpha+90) / eps_alpha`` for a uniaxial
stress increment along ``alpha`` measured from the y axis towards x. Only packings A and
B are built; C-F are not reconstructed.
"""

from __future__ import annotations

import math

import numpy as np

from grainmech.assembly import ContactSet, static_contact_forces, stiffness
from grainmech.contact import Cylinder, cylinder_normal_stiffness, cylinder_tangential_stiffness
from grainmech.reproduce._base import FigureData, long_table
from grainmech.tensors import directional_poisson, directional_young

__all__ = ["ROD", "regular_packing", "apparent", "fig6_1", "fig6_2"]

#: Seed Sec. 5.2, 5.3, 6.1.1 (psi, in).
ROD = {"diameter": 0.5, "shear_modulus_equiv": 15000.0, "poisson": 0.1, "psi": 2.5,
       "friction_angle_deg": 15.0, "pressure": 2.5, "increment": 0.5}


def regular_packing(kind: str, diameter: float = ROD["diameter"]) -> ContactSet:
    """Physical contact set (each contact once, branch = centre-to-centre) of a lattice.

    ``square``: normals along x and y, one rod per ``d^2``, 2 contacts per rod.
    ``hexagonal``: normals at 0, 60, 120 deg from x, one rod per ``(sqrt 3/2) d^2``,
    3 contacts per rod.
    """
    d = diameter
    if kind == "square":
        ang, area = np.radians([0.0, 90.0]), d * d
    elif kind == "hexagonal":
        ang, area = np.radians([0.0, 60.0, 120.0]), math.sqrt(3) / 2 * d * d
    else:
        raise ValueError(f"unknown packing {kind!r}")
    n = np.column_stack([np.cos(ang), np.sin(ang)])
    return ContactSet(n, d * n, 1.0 / area, 0.0, 0.0, "physical")


def apparent(kind: str, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Apparent modulus and Poisson's ratio (Eq. 6.1, 6.2 corrected) of packing ``kind``.

    Tangent stiffness at the 2.5 psi isotropic state (contact forces from the exact
    Love-Weber inverse; ``Kn`` of Eq. 3.8 at that force, ``Ks = Kn/Psi`` of Eq. 3.17 at
    ``T = 0``). ``alpha`` [rad] from y towards x. Returns ``E, nu, C``.
    """
    cs = regular_packing(kind)
    p = Cylinder(ROD["shear_modulus_equiv"], ROD["poisson"], ROD["diameter"] / 2, ROD["psi"],
                 math.radians(ROD["friction_angle_deg"]))
    f = static_contact_forces(cs, ROD["pressure"] * np.eye(2))
    N = np.einsum("ci,ci->c", f, cs.normals)
    kn = cylinder_normal_stiffness(N, p)
    ks = cylinder_tangential_stiffness(N, np.zeros_like(N), p)
    C = stiffness(cs.with_stiffness(kn, ks))
    d = np.column_stack([np.sin(alpha), np.cos(alpha)])
    m = np.column_stack([np.cos(alpha), -np.sin(alpha)])
    return directional_young(C, d), directional_poisson(C, d, m), C


_TEXT = (
    "Inputs: the seed's rod contacts (Eq. 3.8, 3.17; G = 15000 psi, Psi = 2.5, nu = 0.1, "
    "phi_mu = 15 deg), rods 0.5 in in diameter, 2.5 psi isotropic stress. Our choices: "
    "square packing A with contacts along x and y, hexagonal packing B with one lattice "
    "row along x; the moduli are the tangent at the 2.5 psi state (the seed applies a "
    "finite 0.5 psi increment, 20 % of the confining stress: a secant would differ by a "
    "few per cent and leave the shapes); physical counting (the seed's Eq. 2.26 counting "
    "halves every modulus and leaves nu unchanged). Packings C-F and the measured points "
    "are not reproduced.")


def _table(alpha: np.ndarray) -> tuple[dict, dict]:
    blocks, meta = [], {}
    for label, kind in (("A (square)", "square"), ("B (hexagonal)", "hexagonal")):
        E, nu, _ = apparent(kind, alpha)
        blocks.append({"packing": label, "alpha_deg": np.degrees(alpha), "E": E, "nu": nu})
        meta[kind] = (E, nu)
    return long_table(blocks), meta


def fig6_1(n: int = 145) -> FigureData:
    """Seed Fig. 6.1: apparent modulus versus alpha for packings A and B (polar)."""
    alpha = np.linspace(0, 2 * np.pi, n)
    table, meta = _table(alpha)
    Ea, Eb = meta["square"][0], meta["hexagonal"][0]
    i45 = int(np.argmin(np.abs(alpha - np.pi / 4)))
    caption = (
        "Seed Fig. 6.1 (packings A and B only): apparent modulus E = d sigma_alpha/eps_alpha "
        "(Eq. 6.1) versus the loading direction alpha (from y). The seed: A (square) is "
        "stiffest along y and softest at alpha = 45 deg; B (hexagonal) is isotropic. Ours: "
        f"A {Ea[0]:.4g} psi at 0 deg, {Ea[i45]:.4g} psi at 45 deg (minimum); B "
        f"{Eb.min():.4g}-{Eb.max():.4g} psi (isotropic). " + _TEXT)
    return FigureData("6.1", "Rod packings A and B: apparent modulus (seed Fig. 6.1)", caption,
                      table, {"E_A_0": float(Ea[0]), "E_A_45": float(Ea[i45]),
                              "E_B_spread": float(np.ptp(Eb) / Eb.mean())})


def fig6_2(n: int = 145) -> FigureData:
    """Seed Fig. 6.2: apparent Poisson's ratio versus alpha for packings A and B (polar)."""
    alpha = np.linspace(0, 2 * np.pi, n)
    table, meta = _table(alpha)
    nua, nub = meta["square"][1], meta["hexagonal"][1]
    i45 = int(np.argmin(np.abs(alpha - np.pi / 4)))
    caption = (
        "Seed Fig. 6.2 (packings A and B only): apparent Poisson's ratio "
        "nu = -eps_(alpha+90)/eps_alpha (Eq. 6.2, corrected: the print is the reciprocal) "
        "versus alpha. The seed: A's Poisson's ratio is largest at 45 deg (and, from the "
        "lattice, 0 along the rows), B is isotropic. Ours: A nu = "
        f"{abs(nua[0]):.4f} at 0 deg and {nua[i45]:.4f} at 45 deg (maximum); B "
        f"nu = {nub.mean():.4f} in every direction. Lattice closed forms with k = Ks/Kn = "
        "1/Psi: A at 45 deg nu = (1 - k)/(1 + k), B nu = (1 - k)/(3 + k) (tested). " + _TEXT)
    return FigureData("6.2", "Rod packings A and B: apparent Poisson's ratio (seed Fig. 6.2)",
                      caption, table, {"nu_A_0": float(nua[0]), "nu_A_45": float(nua[i45]),
                                       "nu_B_spread": float(np.ptp(nub))})

"""Seed Figs. 5.2, 6.1-6.2: the six regular rod packings and their apparent moduli.

Packings A-F of seed Fig. 5.2 (Sec. 5.2): 2D arrays of parallel aluminium rods, per unit
rod length. The seed's text does not contain Fig. 5.2; it states only that A is square,
B hexagonal, C "a mixture of square packing and hexagonal packing" whose modulus and
Poisson's ratio "are average of those of packing A and packing B", D "shows the similar
isotropic behavior as that of packing B, however, the magnitude of the modulus of packing
D is much smaller", and E (rods of 0.5 and 0.25 in) and F (0.75 and 0.5 in) are two-size
packings whose moduli and Poisson's ratios are anisotropic (Sec. 6.1.1). A and B follow
from their names; **C-F are our reconstructions** (:data:`~grainmech.rods.ARRAYS`, each with the reason
for the choice in its ``note``; :mod:`grainmech.rods.regular`), built as real periodic rod arrays: a unit cell with rod
centres and diameters, the contacts found from the geometry (centre distance equal to the
sum of the radii), never a hand-set stiffness.

The response is that of the directional shear box (seed Sec. 5.3): an isotropic stress of
2.5 psi, then a stress increment along the direction ``alpha`` measured from the y axis
towards x. Rod contacts of seed Eq. 3.8 / 3.17 (:class:`grainmech.contact.Cylinder`,
``G = 15000 psi``, ``Psi = 2.5``, ``nu = 0.1``, ``phi_mu = 15 deg``, Sec. 6.1.1); apparent
modulus seed Eq. 6.1 ``E = d sigma_alpha / eps_alpha`` and Poisson's ratio Eq. 6.2 corrected
(``docs/seed-errata.md``) ``nu = -eps_(alpha+90) / eps_alpha``, computed by
:mod:`grainmech.rods.shear_box`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainmech.assembly import ContactSet
from grainmech.reproduce._base import FigureData, long_table
from grainmech.rods import ARRAYS, ROD, PeriodicRods, directional, regular_array, shear_box_stiffness

__all__ = ["apparent", "fig5_2", "fig6_1", "fig6_2"]

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
    C = _rod_stiffness(regular_array(kind))
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
        blocks.append({"packing": ARRAYS[key].label, "alpha_deg": np.degrees(alpha),
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
    xs: list[np.ndarray] = []
    ds: list[np.ndarray] = []
    owner: list[np.ndarray] = []
    for n1 in range(-reach, reach + 1):
        for n2 in range(-reach, reach + 1):
            xs.append(pos + n1 * lat[0] + n2 * lat[1])
            ds.append(np.asarray(p.diameters, dtype=float))
            owner.append(np.arange(len(pos)))
    x, d = np.concatenate(xs), np.concatenate(ds)
    m = np.all((x > -0.5) & (x < span + 0.5), axis=1)
    return x[m], d[m], np.concatenate(owner)[m]


def fig5_2(span: float = 2.0) -> FigureData:
    """Seed Fig. 5.2 (reconstructed): the six regular packings, a few cells of each.

    Rows of the table: one per rod image (``item = "rod"``: centre, diameter) and one per
    contact image (``item = "contact"``: the branch vector from ``x, y`` to ``x2, y2``)
    in a ``span`` x ``span`` in window, and one per unit cell corner (``item = "cell"``).
    """
    blocks: list[dict[str, Any]] = []
    meta: dict[str, dict[str, float]] = {}
    for key in ORDER:
        p = ARRAYS[key]
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
    notes: list[str] = []
    seen: dict[str, int] = {}
    for k in ORDER:  # E and F share one recipe: say it once
        note = ARRAYS[k].note
        if note in seen:
            notes[seen[note]] = notes[seen[note]].replace(":", f", {k}:", 1)
            continue
        seen[note] = len(notes)
        notes.append(f"{k}: {note}")
    notes_text = " ".join(notes)
    caption = (
        "Seed Fig. 5.2 (the six regular packings of Sec. 5.2) is not in the text of the seed; "
        "this figure draws the arrays used for Figs. 6.1-6.2: rods (circles), contacts "
        "(branch vectors, lines) and one unit cell (dashed). A and B follow from the seed's "
        "names; C-F are RECONSTRUCTIONS from the seed's statements (Sec. 5.2, 6.1.1), not "
        "the seed's drawings, and nothing was tuned to the seed's curves. " + notes_text
        + " Geometry: " + stats + ".")
    return FigureData("5.2", "Six regular rod packings, A-B from the seed, C-F reconstructed "
                      "(seed Fig. 5.2)", caption, long_table(blocks), meta)

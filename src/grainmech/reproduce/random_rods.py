"""Seed Figs. 6.3-6.6: random rod packings, their branch vectors and strains.

The seed (Sec. 5.2, 6.1.2) tested two random rod assemblies in the directional shear box:

* one size: 271 rods of 0.5 in, ``N = 1372`` contacts, ``e = 0.179``, ``m = 5.06``;
* two sizes: 229 rods of 0.5 in and 190 rods of 0.25 in, ``N = 1991``, ``e = 0.179``,
  ``m = 4.75``.

The seed's ``N`` counts each contact from both rods (``N = m N_p``: 5.06 x 271 = 1371,
4.75 x 419 = 1990), i.e. ``N = 2 N_c`` physical contacts. The rod coordinates were digitised
from photographs and are not in the text, so
:func:`~grainmech.rods.random_arrays.random_array` **generates** a packing with the seed's
rods and void ratio: the rods are placed at random (seeded) in a square periodic cell
whose area gives ``e = 0.179`` exactly (``A_cell = (1 + e) sum pi d^2/4``), then the
overlaps are removed by minimising the harmonic overlap energy
``U = sum_pairs (1/2) max(r_i + r_j - |x_j - x_i|, 0)^2`` (L-BFGS, the soft-disc
quench of O'Hern et al. 2003, Phys. Rev. E 68, 011306). Contacts are the pairs whose centre
distance is at most ``(r_i + r_j)(1 + CONTACT_TOL)`` (``CONTACT_TOL = 1 %``, fixed before
looking at the coordination and not tuned: the precision of contacts read off a
photograph, as the seed's were). :func:`~grainmech.rods.random_arrays.array_stats` reports what this gives next to the
seed's numbers; the quench does **not** reproduce the seed's coordination (see
``docs/reproduce.md``).

Strains (:func:`strains`): the seed's directional-shear-box test (Sec. 5.3), 2.5 psi
isotropic then 0.5 psi along ``alpha``; rod contacts seed Eq. 3.8 / 3.17 with the stiff
(``G = 40000 psi, Psi = 1``), soft (15000 psi, 2.5) and best-fit (25000 psi, 2.0) constants
of Sec. 6.1.2, ``nu = 0.1``, ``phi_mu = 15 deg``; the tangent stiffness of
:func:`grainmech.rods.shear_box_stiffness` (shared with Figs. 6.1-6.2). The packings and
strains are computed by :mod:`grainmech.rods.random_arrays`.
Everything here is SI (m, Pa) unless a name says psi/in.
"""

from __future__ import annotations

import math

import numpy as np

from grainmech.reproduce._base import FigureData, long_table
from grainmech.rods.random_arrays import CONSTANTS, CONTACT_TOL, PSI_PA, array_stats, generate, random_array, strains

__all__ = ["SEED_STATS", "fig6_3", "fig6_4", "fig6_5", "fig6_6"]

#: The seed's reported statistics (Sec. 6.1.2); ``contacts`` counts each contact twice.
SEED_STATS: dict[str, dict[str, float]] = {
    "one-size": {"contacts": 1372, "void_ratio": 0.179, "coordination": 5.06},
    "two-size": {"contacts": 1991, "void_ratio": 0.179, "coordination": 4.75},
}


# --------------------------------------------------------------------------- figures

_COMMON = (
    "The seed's packings are not in the text: ours are GENERATED (seeded random placement "
    "in a square periodic cell sized for e = 0.179 exactly, then an overlap-energy quench; "
    "contacts = centre distance <= (r_i + r_j)(1 + 1 %), a tolerance fixed beforehand, not "
    "tuned). The seed's N counts every contact from both rods (N = m x rods).")


def _stats_text(kind: str, seed: int = 0) -> tuple[str, dict]:
    st = array_stats(random_array(kind, seed))
    s = SEED_STATS[kind]
    _, rec = generate(kind, seed)
    text = (f"Achieved ({st['particles']} rods, seed {seed}): N = {st['contacts']} "
            f"(seed {s['contacts']:.0f}, {100 * (st['contacts'] / s['contacts'] - 1):+.0f} %), "
            f"e = {st['void_ratio']:.4f} (seed {s['void_ratio']}), m = {st['coordination']:.2f} "
            f"(seed {s['coordination']}, {100 * (st['coordination'] / s['coordination'] - 1):+.0f} %); "
            f"largest residual overlap {100 * rec['max_overlap']:.3f} % of r_i + r_j.")
    return text, {**st, "max_overlap": rec["max_overlap"]}


def _rose(kind: str, fig_id: str, bins: int = 36) -> FigureData:
    p, _ = generate(kind, 0)
    i, j, l_ = p.contacts(CONTACT_TOL, allow_overlap=True)
    ang = np.degrees(np.arctan2(np.concatenate([l_[:, 0], -l_[:, 0]]),
                                np.concatenate([l_[:, 1], -l_[:, 1]]))) % 360  # from y towards x
    edges = np.linspace(0, 360, bins + 1)
    counts, _ = np.histogram(ang, edges)
    centres = 0.5 * (edges[1:] + edges[:-1])
    frac = counts / counts.sum()
    # second-order Fourier fabric of the branch directions (seed Eq. 4.34, angle from y)
    t = np.radians(ang)
    a2, b2 = 2 * np.mean(np.cos(2 * t)), 2 * np.mean(np.sin(2 * t))
    a4, b4 = 2 * np.mean(np.cos(4 * t)), 2 * np.mean(np.sin(4 * t))
    lengths = np.linalg.norm(l_, axis=1)
    text, st = _stats_text(kind)
    blocks = [
        {"item": "rose", "angle_deg": centres, "fraction": frac, "x": np.nan, "y": np.nan,
         "diameter": np.nan},
        {"item": "rod", "angle_deg": np.nan, "fraction": np.nan, "x": p.positions[:, 0],
         "y": p.positions[:, 1], "diameter": p.diameters},
    ]
    what = "one size (271 rods of 0.5 in)" if kind == "one-size" else \
        "two sizes (229 rods of 0.5 in, 190 of 0.25 in)"
    caption = (
        f"Seed Fig. {fig_id}: distribution of the branch vectors (centre-to-centre, both "
        f"senses) of the random packing of {what}, in {bins} sectors of 10 deg, angle from "
        f"y towards x; right: the packing (periodic cell {p.lattice[0, 0]:.2f} in square). "
        f"The seed's rose (from its photographs; 'BRANCH LENGTH = 0.5 in') is not in the "
        f"text. " + text + f" Fourier fabric of the branch directions (seed Eq. 4.34): "
        f"a2 = {a2:+.3f}, b2 = {b2:+.3f}, a4 = {a4:+.3f}, b4 = {b4:+.3f} (0 = isotropic; "
        f"sampling noise ~ 2/sqrt(2 N_c) = {2 / math.sqrt(len(l_) * 2):.3f}); branch length "
        f"{lengths.min():.3f}-{lengths.max():.3f} in. " + _COMMON)
    return FigureData(fig_id, f"Branch vectors of the {kind} random rod packing (seed Fig. {fig_id})",
                      caption, long_table(blocks),
                      {**st, "a2": a2, "b2": b2, "a4": a4, "b4": b4, "box_in": float(p.lattice[0, 0])})


def fig6_3() -> FigureData:
    """Seed Fig. 6.3: branch vector distribution, one-size random packing (generated)."""
    return _rose("one-size", "6.3")


def fig6_4() -> FigureData:
    """Seed Fig. 6.4: branch vector distribution, two-size random packing (generated)."""
    return _rose("two-size", "6.4")


def _strain_fig(kind: str, fig_id: str) -> FigureData:
    alpha = np.linspace(0.0, 90.0, 37)
    cs = random_array(kind, 0)
    blocks, meta = [], {}
    for name, (G, psi) in CONSTANTS.items():
        eps = strains(cs, alpha, G=G * PSI_PA, psi=psi)
        blocks.append({"constants": f"{name} (G = {G:g} psi, Psi = {psi:g})", "alpha_deg": alpha,
                       "eps_xx": eps["eps_xx"], "eps_yy": eps["eps_yy"], "eps_xy": eps["eps_xy"]})
        meta[name] = {k: (float(eps[k][0]), float(eps[k][18])) for k in ("eps_xx", "eps_yy", "eps_xy")}
    text, st = _stats_text(kind)
    e = meta
    caption = (
        f"Seed Fig. {fig_id}: strains eps_xx, eps_yy, eps_xy (tensor shear; compression "
        f"positive) versus the direction alpha of the major principal stress (from y), "
        f"{kind} random packing, for 2.5 psi isotropic + 0.5 psi along alpha (Sec. 5.3), "
        f"rod contacts Eq. 3.8/3.17 with the seed's stiff (G = 40000 psi, Psi = 1), best-fit "
        f"(25000, 2.0) and soft (15000, 2.5) constants, nu = 0.1, phi_mu = 15 deg (Sec. 6.1.2). "
        f"The seed: the measured strains lie between the stiff and soft predictions, eps_xx "
        f"is small and scattered. Ours, eps_yy at alpha = 0 / eps_xy at 45 deg: stiff "
        f"{e['stiff']['eps_yy'][0]:.3g} / {e['stiff']['eps_xy'][1]:.3g}, best fit "
        f"{e['best fit']['eps_yy'][0]:.3g} / {e['best fit']['eps_xy'][1]:.3g}, soft "
        f"{e['soft']['eps_yy'][0]:.3g} / {e['soft']['eps_xy'][1]:.3g}; eps_xx at 0 deg "
        f"(soft) {e['soft']['eps_xx'][0]:.3g}. Tangent stiffness at the 2.5 psi state "
        f"(static contact-force estimate), physical counting; the measured points are not in "
        f"the text. " + text + " " + _COMMON)
    return FigureData(fig_id, f"Strains vs alpha, {kind} random rod packing (seed Fig. {fig_id})",
                      caption, long_table(blocks), {**meta, "stats": st})


def fig6_5() -> FigureData:
    """Seed Fig. 6.5: strains versus alpha, one-size random packing."""
    return _strain_fig("one-size", "6.5")


def fig6_6() -> FigureData:
    """Seed Fig. 6.6: strains versus alpha, two-size random packing."""
    return _strain_fig("two-size", "6.6")

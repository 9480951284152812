"""Seed Figs. 4.3-4.7: moduli of random sphere packings with constant contact stiffnesses.

Closed forms of seed Eq. 4.21-4.33 (:func:`grainmech.closed_form.spheres_second_order`)
with the seed's Sec. 4.4 inputs ``n_bar = 9``, ``e = 0.57``, ``r = 0.01 in``,
``Kn = 3800 lbf/in`` (the seed prints "psi"; a contact stiffness is a force per length),
in the seed's counting convention (Eq. 4.1: ``N/V = 3 n_bar/(4 pi r^3 (1+e))`` with the
centre-to-contact length ``r``; ``docs/conventions.md``) so that the moduli are the
seed's own numbers. The physical convention gives exactly twice every modulus and the
same Poisson's ratios.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from grainmech.closed_form import packing_scale, spheres_second_order
from grainmech.elasticity import engineering_constants
from grainmech.reproduce._base import FigureData, long_table

__all__ = ["INPUTS", "FABRICS", "moduli", "fig4_3", "fig4_4", "fig4_5", "fig4_6", "fig4_7"]

#: Seed Sec. 4.4 inputs (units lbf, in, psi).
INPUTS = {"coordination": 9.0, "void_ratio": 0.57, "radius": 0.01, "kn": 3800.0}
#: Fabrics of Figs. 4.4-4.6: name -> (a20, a22, b22).
FABRICS = {"isotropic": (0.0, 0.0, 0.0), "transversely isotropic": (0.8, 0.0, 0.0),
           "orthotropic": (0.2, 0.25, 0.0)}
#: Ks/Kn used for the ratios of Fig. 4.7 (the seed does not state it): mid-range value;
#: 0.25 shown dashed for comparison.
FIG47_KS_KN = (0.5, 0.25)
_KEYS = ("E_xx", "E_yy", "E_zz", "nu_zx", "nu_zy", "nu_xy", "G_xz", "G_yz", "G_xy")


def _scale(convention: str = "seed") -> float:
    nv, length = packing_scale(INPUTS["void_ratio"], INPUTS["coordination"], INPUTS["radius"],
                               dim=3, convention=convention)
    return nv * length**2


def moduli(a20: float, a22: float, b22: float, ks_kn: float,
           convention: str = "seed") -> dict[str, float]:
    """Engineering constants (psi) of seed Eq. 4.21-4.33 at the Sec. 4.4 inputs.

    Poisson's ratios ``nu_ij`` are strain ``j`` over strain ``i`` under stress along ``i``
    (:func:`grainmech.tensors.engineering_constants`).
    """
    kn = INPUTS["kn"]
    C = spheres_second_order(a20, a22, b22, kn, ks_kn * kn, _scale(convention))
    return engineering_constants(C).as_dict()


@cache
def _sweep(n: int = 41) -> dict[str, dict[str, np.ndarray]]:
    ratio = np.linspace(0.0, 1.0, n)
    out = {}
    for name, f in FABRICS.items():
        rows = [moduli(*f, r) for r in ratio]
        d = {k: np.array([row[k] for row in rows]) for k in _KEYS}
        d["ks_kn"] = ratio
        out[name] = d
    return out


def _table(names: list[str], keys: tuple[str, ...]) -> dict[str, np.ndarray]:
    sw = _sweep()
    return long_table([{"fabric": nm, "ks_kn": sw[nm]["ks_kn"],
                        **{k: sw[nm][k] for k in keys}} for nm in names])


_INPUT_TEXT = ("Inputs (seed Sec. 4.4): n_bar = 9, e = 0.57, r = 0.01 in, Kn = 3800 lbf/in, "
               "Ks/Kn from 0 to 1; seed counting convention (Eq. 4.1, each contact counted "
               "from both particles with the centre-to-contact length r), so the moduli are "
               "the seed's numbers; the physical convention (docs/conventions.md) doubles "
               "every modulus and leaves Poisson's ratios unchanged.")


def fig4_3() -> FigureData:
    """Seed Fig. 4.3: isotropic packing, E and nu versus Ks/Kn."""
    sw = _sweep()["isotropic"]
    E, nu = sw["E_zz"], sw["nu_zx"]
    G = sw["G_xz"]
    table = {"ks_kn": sw["ks_kn"], "E": E, "nu": nu, "G": G}
    decreasing = bool(np.all(np.diff(nu) < 0))
    caption = (
        "Seed Fig. 4.3: Young's modulus and Poisson's ratio of a statistically isotropic "
        "packing versus Ks/Kn (Eq. 4.21-4.33 with a20 = a22 = b22 = 0). The seed states "
        "that E increases and nu decreases with Ks/Kn, with the maximum nu = 0.25 at "
        f"Ks/Kn = 0. Ours: nu(0) = {nu[0]:.6f}, nu(1) = {abs(nu[-1]):.3g}, nu strictly "
        f"decreasing: {decreasing}; E rises from {E[0]:.4g} psi to {E[-1]:.4g} psi "
        "(isotropic closed form with k = Ks/Kn: nu = (1 - k)/(4 + k), "
        "E = (N/V) r^2 Kn (2 + 3k)/(3 (4 + k))). The seed's statement is reproduced. " + _INPUT_TEXT)
    return FigureData("4.3", "Isotropic packing: E and nu versus Ks/Kn (seed Fig. 4.3)",
                      caption, table, {"nu0": float(nu[0]), "nu_decreasing": decreasing,
                                       "E0": float(E[0]), "E1": float(E[-1])})


def fig4_4() -> FigureData:
    """Seed Fig. 4.4: Young's moduli of the transversely isotropic and orthotropic packings."""
    sw = _sweep()
    ti, orth = sw["transversely isotropic"], sw["orthotropic"]
    i = len(ti["ks_kn"]) // 2
    caption = (
        "Seed Fig. 4.4: Young's moduli versus Ks/Kn for the transversely isotropic "
        "(a20 = 0.8; E_xx = E_yy, E_zz) and orthotropic (a20 = 0.2, a22 = 0.25; E_xx, E_yy, "
        "E_zz) packings. The seed states only that more contacts along a direction stiffen "
        "it (a20 > 0: z; a22 > 0: y). Ours at Ks/Kn = 0.5: transversely isotropic "
        f"E_zz = {ti['E_zz'][i]:.4g}, E_xx = {ti['E_xx'][i]:.4g} psi; orthotropic "
        f"E_yy = {orth['E_yy'][i]:.4g}, E_zz = {orth['E_zz'][i]:.4g}, "
        f"E_xx = {orth['E_xx'][i]:.4g} psi; all rise with Ks/Kn. " + _INPUT_TEXT)
    return FigureData("4.4", "Young's moduli versus Ks/Kn (seed Fig. 4.4)", caption,
                      _table(["transversely isotropic", "orthotropic"], ("E_xx", "E_yy", "E_zz")))


def fig4_5() -> FigureData:
    """Seed Fig. 4.5: Poisson's ratios of the transversely isotropic and orthotropic packings."""
    sw = _sweep()
    ti = sw["transversely isotropic"]
    caption = (
        "Seed Fig. 4.5: Poisson's ratios versus Ks/Kn for the transversely isotropic "
        "(nu_zx = nu_zy, nu_xy) and orthotropic (nu_zx, nu_zy, nu_xy) packings. nu_ij is "
        "the lateral strain along j over the axial strain along i under uniaxial stress "
        "along i (the seed does not define its index order; for the transversely isotropic "
        "packing the seed's equalities nu_zx = nu_zy hold in either reading). Ours, "
        f"transversely isotropic at Ks/Kn = 0: nu_zx = {ti['nu_zx'][0]:.4f}, "
        f"nu_xy = {ti['nu_xy'][0]:.4f}; all ratios decrease with Ks/Kn and vanish at "
        "Ks/Kn = 1 (every off-diagonal stiffness of Eq. 4.21-4.33 is proportional to "
        "Kn - Ks). " + _INPUT_TEXT)
    return FigureData("4.5", "Poisson's ratios versus Ks/Kn (seed Fig. 4.5)", caption,
                      _table(["transversely isotropic", "orthotropic"], ("nu_zx", "nu_zy", "nu_xy")))


def fig4_6() -> FigureData:
    """Seed Fig. 4.6: shear moduli of the transversely isotropic and orthotropic packings."""
    sw = _sweep()
    ti = sw["transversely isotropic"]
    gxy_check = ti["E_xx"] / (2 * (1 + ti["nu_xy"]))
    err = float(np.max(np.abs(gxy_check / ti["G_xy"] - 1)))
    caption = (
        "Seed Fig. 4.6: shear moduli versus Ks/Kn (G_zx = G_zy and G_xy for the "
        "transversely isotropic packing; G_zx, G_zy, G_xy for the orthotropic one). The "
        "seed notes that for the transversely isotropic packing G_xy = E_xx/(2(1 + nu_xy)), "
        f"leaving 5 independent constants: ours satisfies it to {err:.1e}. " + _INPUT_TEXT)
    return FigureData("4.6", "Shear moduli versus Ks/Kn (seed Fig. 4.6)", caption,
                      _table(["transversely isotropic", "orthotropic"], ("G_xz", "G_yz", "G_xy")),
                      {"gxy_identity_error": err})


def fig4_7(n: int = 61) -> FigureData:
    """Seed Fig. 4.7: transversely isotropic / isotropic moduli and Poisson's ratios vs a20."""
    a20 = np.linspace(-1.0, 2.0, n)
    blocks = []
    for k in FIG47_KS_KN:
        iso = moduli(0, 0, 0, k)
        rows = [moduli(a, 0, 0, k) for a in a20]
        blocks.append({
            "ks_kn": np.full(n, k), "a20": a20,
            "E_zz_ratio": np.array([r["E_zz"] for r in rows]) / iso["E_zz"],
            "E_xx_ratio": np.array([r["E_xx"] for r in rows]) / iso["E_xx"],
            "nu_zx_ratio": np.array([r["nu_zx"] for r in rows]) / iso["nu_zx"],
            "nu_xy_ratio": np.array([r["nu_xy"] for r in rows]) / iso["nu_xy"],
        })
    table = long_table(blocks)
    j = int(np.argmin(np.abs(a20 - 0.8)))
    b = blocks[0]
    caption = (
        "Seed Fig. 4.7: ratios of the moduli and Poisson's ratios of a transversely "
        "isotropic packing (a22 = b22 = 0) to those of the isotropic packing, versus a20. "
        "The seed concludes that a more anisotropic packing is more anisotropic "
        "mechanically. The seed does not state Ks/Kn for this figure; we use 0.5 (middle "
        "of the range of Figs. 4.3-4.6; solid) and show 0.25 (dashed); a20 spans the whole "
        "range -1 <= a20 <= 2 in which Eq. 4.15 is non-negative. The ratios do not depend "
        "on n_bar, e, r or Kn. Ours at a20 = 0.8, Ks/Kn = 0.5: "
        f"E_zz/E = {b['E_zz_ratio'][j]:.3f}, E_xx/E = {b['E_xx_ratio'][j]:.3f}, "
        f"nu_zx/nu = {b['nu_zx_ratio'][j]:.3f}, nu_xy/nu = {b['nu_xy_ratio'][j]:.3f}; "
        "the spread grows with |a20|, as the seed says.")
    return FigureData("4.7", "Anisotropy ratios versus a20 (seed Fig. 4.7)", caption, table)

"""Seed Figs. 6.7-6.9: shear modulus of isotropic Hertz-Mindlin sphere packings.

Theory: :func:`grainmech.closed_form.isotropic_hertz_mindlin` (seed Eq. 4.43-4.45, with
erratum E-4.45), i.e. a statistically isotropic packing of equal spheres under an
isotropic pressure, Hertz normal and Mindlin no-slip tangential contact stiffnesses. The
shear modulus is independent of the particle radius: ``N/V ~ r^-3``, ``l ~ r``, the
contact force ``~ r^2`` and the contact stiffnesses ``~ r``, so ``(N/V) l^2 k`` has no
``r``. Coordination from void ratio: seed Eq. 4.2 (Fig. 6.7) and Eq. 6.4 (Figs. 6.8, 6.9).
Units: psi, in.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike

from grainmech.closed_form import isotropic_hertz_mindlin, walton
from grainmech.fabric import CorrelationRangeWarning, coordination_number
from grainmech.reproduce._base import FigureData, long_table

__all__ = ["hardin_black", "shear_modulus", "pressure_exponent", "fig6_7", "fig6_8", "fig6_9",
           "GLASS", "SAND"]

#: Seed Sec. 6.2 (glass balls): G, nu; void ratio chosen by us (not in the text).
GLASS = {"shear_modulus": 5.75e6, "poisson": 0.13, "void_ratio": 0.6, "radius": 0.01}
#: Seed Sec. 6.3.1 (sand, Hardin-Black comparison).
SAND = {"shear_modulus": 7.5e6, "poisson": 0.13, "radius": 0.01}
MEASURED_EXPONENT = 0.42


def hardin_black(void_ratio: np.ndarray | float, sigma: np.ndarray | float) -> np.ndarray:
    """Hardin and Black (1968) shear modulus of Ottawa sand, seed Eq. 6.3 (psi).

    ``G = 2630 (2.17 - e)^2 sigma^(1/2) / (1 + e)``, ``sigma`` in psi.
    """
    e = np.asarray(void_ratio, dtype=float)
    return 2630.0 * (2.17 - e) ** 2 * np.sqrt(np.asarray(sigma, dtype=float)) / (1.0 + e)


def shear_modulus(shear_modulus: float, poisson: float, pressure: ArrayLike, void_ratio: float,
                  coordination: float, radius: float, convention: str) -> np.ndarray:
    """Packing shear modulus (seed Eq. 4.44-4.45 family) at each pressure."""
    return np.array([isotropic_hertz_mindlin(shear_modulus, poisson, p, void_ratio=void_ratio,
                                             coordination=coordination, radius=radius,
                                             convention=convention).G
                     for p in np.atleast_1d(pressure)])


def pressure_exponent(pressure: np.ndarray, modulus: np.ndarray) -> float:
    """Least-squares slope of ``log G`` against ``log sigma``."""
    return float(np.polyfit(np.log(pressure), np.log(modulus), 1)[0])


def _coordination(e: np.ndarray | float, name: str) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CorrelationRangeWarning)
        return np.asarray(coordination_number(e, name), dtype=float)


def fig6_7(n: int = 30) -> FigureData:
    """Seed Fig. 6.7: shear modulus of a glass-ball packing versus confining pressure."""
    p = np.geomspace(2.0, 60.0, n)
    e = GLASS["void_ratio"]
    m = float(_coordination(e, "yanagisawa"))
    args = (GLASS["shear_modulus"], GLASS["poisson"], p, e, m, GLASS["radius"])
    g_seed = shear_modulus(*args, "seed")
    g_phys = shear_modulus(*args, "physical")
    g_walton = np.array([walton(GLASS["shear_modulus"], GLASS["poisson"], pi,
                                porosity=e / (1 + e), coordination=m)[1] for pi in p])
    x_seed, x_phys = pressure_exponent(p, g_seed), pressure_exponent(p, g_phys)
    walton_err = float(np.max(np.abs(g_phys / g_walton - 1)))
    caption = (
        "Seed Fig. 6.7: shear modulus of packings of uniform glass balls (resonant column, "
        "Yanagisawa 1983) versus confining pressure. The seed's theory (statistically "
        "isotropic packing, G = 5.75e6 psi, nu = 0.13, coordination from Eq. 4.2) rises as "
        "sigma_c^0.33, the measurements as sigma_c^0.42. Ours: isotropic Hertz-Mindlin "
        "(Eq. 4.43-4.45, erratum E-4.45), fitted exponent "
        f"{x_seed:.6f} (seed convention) and {x_phys:.6f} (physical), i.e. 1/3 exactly, as "
        "Hertz contacts with no change of fabric require; the measured 0.42 (dotted slope "
        "guide only; the seed's data points are not in the text and are not reproduced) "
        "needs something the model lacks (e.g. contacts forming with pressure). Two "
        "curves: the seed's counting convention (solid, the seed's own formula) and the "
        "physical one (dashed, each contact counted once; twice the seed's value, and equal "
        f"to Walton's 1987 rough-sphere modulus to {walton_err:.1e}). Inputs the seed does "
        f"not state: void ratio e = {e} (a typical loose-to-medium packing of uniform glass "
        f"balls), giving m = {m:.3f} by Eq. 4.2; pressures 2-60 psi (about 14-410 kPa, the "
        "usual resonant-column range); the particle radius does not enter (0.01 in used).")
    table = {"sigma_c": p, "G_seed": g_seed, "G_physical": g_phys, "G_walton_rough": g_walton}
    return FigureData("6.7", "Glass balls: shear modulus versus confining pressure (seed Fig. 6.7)",
                      caption, table, {"exponent_seed": x_seed, "exponent_physical": x_phys,
                                       "coordination": m, "walton_error": walton_err})


def fig6_8(n: int = 57) -> FigureData:
    """Seed Fig. 6.8: coordination number versus void ratio, Eq. 4.2-4.5 and 6.4."""
    e = np.linspace(0.35, 0.91, n)
    table = {"void_ratio": e}
    for name in ("yanagisawa", "smith", "filep", "field", "chang"):
        table[f"m_{name}"] = _coordination(e, name)
    at06 = {name: float(_coordination(0.6, name))
            for name in ("yanagisawa", "smith", "filep", "field", "chang")}
    caption = (
        "Seed Fig. 6.8: coordination number versus void ratio. The seed fits a straight "
        "line, Eq. 6.4 e = (23 - m)/25, to measured data (not given in the text, so not "
        "plotted) and uses it for Fig. 6.9. Shown with the correlations of Eq. 4.2 "
        "(Yanagisawa 1983), 4.3 (Smith et al. 1929), 4.4 (Filep 1936) and 4.5 (Field 1963) "
        "over e = 0.35-0.91 (face-centred cubic to simple cubic packing of equal spheres). "
        "Eq. 6.4 is much steeper than the others: it exceeds the kissing number 12 below "
        "e = 0.44 and falls to 0.25 at e = 0.91; at e = 0.6 the five give "
        f"{min(at06.values()):.2f}-{max(at06.values()):.2f} "
        f"(Eq. 6.4: {at06['chang']:.2f}; Eq. 4.2: {at06['yanagisawa']:.2f}).")
    return FigureData("6.8", "Coordination number versus void ratio (seed Fig. 6.8)", caption, table)


def fig6_9(n: int = 36) -> FigureData:
    """Seed Fig. 6.9: theory (Eq. 6.4 coordination) versus Hardin-Black Eq. 6.3."""
    G, nu, r = SAND["shear_modulus"], SAND["poisson"], SAND["radius"]
    e = np.linspace(0.45, 0.80, n)
    m = _coordination(e, "chang")
    blocks = []
    for s in (10.0, 20.0, 40.0):
        blocks.append({
            "panel": "void ratio", "sigma": s, "void_ratio": e, "coordination": m,
            "G_seed": np.array([shear_modulus(G, nu, s, ei, mi, r, "seed")[0] for ei, mi in zip(e, m)]),
            "G_physical": np.array([shear_modulus(G, nu, s, ei, mi, r, "physical")[0]
                                    for ei, mi in zip(e, m)]),
            "G_hardin_black": hardin_black(e, s)})
    e0 = 0.6
    m0 = float(_coordination(e0, "chang"))
    p = np.geomspace(5.0, 100.0, n)
    g0 = shear_modulus(G, nu, p, e0, m0, r, "seed")
    blocks.append({"panel": "pressure", "sigma": p, "void_ratio": e0, "coordination": m0,
                   "G_seed": g0, "G_physical": shear_modulus(G, nu, p, e0, m0, r, "physical"),
                   "G_hardin_black": hardin_black(e0, p)})
    # radius independence: same moduli at a 100 times larger radius
    g_big = shear_modulus(G, nu, p, e0, m0, 100 * r, "seed")
    radius_dev = float(np.max(np.abs(g_big / g0 - 1)))
    table = long_table(blocks)
    hb20 = float(hardin_black(e0, 20.0))
    th20 = float(shear_modulus(G, nu, 20.0, e0, m0, r, "seed")[0])
    th20p = float(shear_modulus(G, nu, 20.0, e0, m0, r, "physical")[0])
    caption = (
        "Seed Fig. 6.9: shear modulus from the theory compared with Hardin and Black's "
        "(1968) Eq. 6.3, G = 2630 (2.17 - e)^2 sigma^0.5/(1 + e) psi, for Ottawa sand. "
        "Theory: G = 7.5e6 psi, nu = 0.13, coordination from Eq. 6.4 (m = 23 - 25 e). The "
        "seed uses a 'modified contact law for rough inelastic non-conforming bodies' "
        "(Chang, Misra and Somasega 1988a) that the report does not give; we use "
        "Hertz-Mindlin (no slip) instead, so the theory here rises as sigma^(1/3), not "
        "sigma^(1/2). Left: G versus e at sigma = 10, 20, 40 psi (e = 0.45-0.80, where "
        "Eq. 6.4 gives m = 11.75-3); right: G versus sigma at e = 0.6 (m = 8). Solid: seed "
        "counting convention; dash-dot: physical (twice as stiff); dashed: Hardin-Black. "
        f"At e = 0.6, sigma = 20 psi: Hardin-Black {hb20:.4g} psi, theory {th20:.4g} psi "
        f"(seed) / {th20p:.4g} psi (physical). The theory falls faster with e than "
        "Hardin-Black because Eq. 6.4's coordination does. The particle radius is "
        "irrelevant: a 100 times larger radius changes the moduli by "
        f"{radius_dev:.1e} (round-off).")
    return FigureData("6.9", "Theory versus Hardin-Black (seed Fig. 6.9)", caption, table,
                      {"radius_deviation": radius_dev, "hb_e06_s20": hb20, "theory_e06_s20": th20})

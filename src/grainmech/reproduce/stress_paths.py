"""Seed Figs. 6.10-6.12: moduli of an isotropic packing along three initial-stress paths.

Sec. 6.3.2 of the seed: start at ``sigma1 = sigma2 = sigma3 = 10 psi``; (1) compression
(sigma1 up), (2) constant mean stress, (3) reduced compression (sigma3 = sigma2 down);
sigma1 along z; ``G = 7.5e6 psi``, ``nu = 0.13``, ``phi_mu = 24 deg``. Each state is set
up by the seed's estimate (:meth:`grainmech.driver.MaterialPoint.at_stress` with
``initial="state-estimate"``) and, beside it, by following the path with the contact
laws' history (:func:`grainmech.driver.run`). Moduli are the engineering constants of the
tangent stiffness. Units: psi, in.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint, fig610_path, fig610_stress, geometry, run
from grainmech.elasticity import engineering_constants
from grainmech.fabric import coordination_number, isotropic
from grainmech.material import Microstructure
from grainmech.reproduce._base import FigureData, long_table, progress

__all__ = ["PATHS", "INPUTS", "critical_ratio", "compute", "fig6_10", "fig6_11", "fig6_12"]

PATHS = ("compression", "constant-mean", "reduced-compression")
#: Seed Sec. 6.3.2 inputs plus our choices for what it leaves unstated (see captions).
INPUTS = {"shear_modulus": 7.5e6, "poisson": 0.13, "friction_angle_deg": 24.0, "p0": 10.0,
          "void_ratio": 0.6, "radius": 0.01, "extra_degree": 131}
RATIOS = tuple(float(r) for r in np.arange(1.0, 4.0 + 1e-9, 0.125))
_KEYS = ("E_zz", "E_xx", "G_xz", "G_xy")


def critical_ratio(friction_angle_deg: float = INPUTS["friction_angle_deg"]) -> float:
    """``R* = (1 + sin phi_mu)/(1 - sin phi_mu)``: onset of sliding in the state estimate.

    For an isotropic fabric the estimate gives ``f ~ sigma . n``; ``T/N`` is largest where
    ``tan t = sqrt(R)`` and reaches ``tan phi_mu`` at ``R*`` (``docs/models/affine.md``).
    """
    s = math.sin(math.radians(friction_angle_deg))
    return (1 + s) / (1 - s)


def _setup(extra_degree: int):
    e = INPUTS["void_ratio"]
    m = float(coordination_number(e, "chang"))
    pk = Microstructure.from_grains(isotropic(3), void_ratio=e, coordination=m, radius=INPUTS["radius"],
                             convention="seed")
    cs = geometry(pk, extra_degree=extra_degree)
    law = MindlinDeresiewicz(INPUTS["shear_modulus"], INPUTS["poisson"], INPUTS["radius"],
                             friction=math.tan(math.radians(INPUTS["friction_angle_deg"])))
    return cs, law, m


@lru_cache(maxsize=8)
def compute(ratios: tuple[float, ...] = RATIOS, n_steps: int = 36,
            extra_degree: int = int(INPUTS["extra_degree"])) -> dict[str, np.ndarray]:
    """Moduli and sliding fractions on the three paths, by both methods (long table).

    Parameters
    ----------
    ratios : tuple of float
        Stress ratios sigma1/sigma3 for the state estimate.
    n_steps : int
        Steps of the path-following runs from 1 to ``max(ratios)`` (every step reported).
    extra_degree : int
        Lebedev rule of the isotropic fabric (131: 5810 directions).

    Returns
    -------
    dict of columns: ``method, path, ratio, ratio_reached, sigma1, sigma3, E_zz, E_xx,
    G_xz, G_xy, sliding`` (``ratio`` is the requested sigma1/sigma3; ``ratio_reached`` the
    ratio of the point's stress, smaller than requested where the estimate's friction
    cap acts).
    """
    cs, law, _ = _setup(extra_degree)
    p0 = INPUTS["p0"]
    blocks = []
    for j, kind in enumerate(PATHS, 1):
        progress(f"  path {kind} ({j}/{len(PATHS)}): state estimate at {len(ratios)} stress ratios ...")
        rows = []
        for R in ratios:
            s1, s3 = fig610_stress(kind, p0, R)
            pt = MaterialPoint.at_stress(cs, law, [s3, s3, s1, 0, 0, 0], initial="state-estimate")
            ec = engineering_constants(pt.tangent).as_dict()
            rows.append([R, pt.stress[2] / pt.stress[0], pt.stress[2], pt.stress[0],
                         *(ec[k] for k in _KEYS), pt.fractions()[0]])
        a = np.array(rows)
        blocks.append(_block("state estimate", kind, a))
        progress(f"  path {kind} ({j}/{len(PATHS)}): following the path in {n_steps} steps ...")
        pt0 = MaterialPoint.isotropic(cs, law, p0)
        res = run(pt0, fig610_path(kind, p0, max(ratios), n_steps), engineering=True)
        ratio = res.stress[:, 2] / res.stress[:, 0]
        a = np.column_stack([ratio, ratio, res.stress[:, 2], res.stress[:, 0],
                             *(res.engineering[k] for k in _KEYS), res.sliding_fraction])
        blocks.append(_block("path following", kind, a))
    return long_table(blocks)


def _block(method: str, kind: str, a: np.ndarray) -> dict:
    names = ("ratio", "ratio_reached", "sigma1", "sigma3", *_KEYS, "sliding")
    return {"method": method, "path": kind, **{n: a[:, i] for i, n in enumerate(names)}}


_INPUT_TEXT = (
    "Inputs: the seed's G = 7.5e6 psi, nu = 0.13, phi_mu = 24 deg, 10 psi isotropic start, "
    "Hertz-Mindlin-Deresiewicz contacts. Not stated by the seed, chosen by us: a "
    "statistically isotropic fabric (the seed: 'an isotropic packing'), e = 0.6 with m = 8 "
    "from Eq. 6.4 (the relation of the preceding section), r = 0.01 in, a 5810-direction "
    "Lebedev rule (wiggles below 1 % remain: the contact shear stiffness "
    "(1 - T/(mu N))^(1/3) is not smooth near sliding), the seed counting convention "
    "(the physical one doubles every modulus; "
    "ratios and sliding fractions are the same). Solid: the seed's state estimate "
    "(Sec. 6.3.2; x = requested sigma1/sigma3); dashed: following the path from 10 psi "
    "with the contact laws' history. Vertical line: R* = (1 + sin phi_mu)/(1 - sin phi_mu) "
    "= {rstar:.3f}, where the estimate starts sliding (the seed: 'about 2.3').")


def _at(t: dict, method: str, kind: str, key: str, R: float) -> float:
    sel = (t["method"] == method) & (t["path"] == kind)
    x, y = t["ratio"][sel], t[key][sel]
    return float(np.interp(R, x, y))


def fig6_10() -> FigureData:
    """Seed Fig. 6.10: the three stress paths in the (sigma3, sigma1) plane."""
    rstar = critical_ratio()
    p0 = INPUTS["p0"]
    blocks = []
    for kind in PATHS:
        R = np.linspace(1.0, 4.0, 61)
        s = np.array([fig610_stress(kind, p0, r) for r in R])
        blocks.append({"path": kind, "ratio": R, "sigma1": s[:, 0], "sigma3": s[:, 1]})
    caption = (
        "Seed Fig. 6.10: the three initial-stress paths from sigma1 = sigma2 = sigma3 = "
        "10 psi: (1) compression, sigma1 up at constant sigma3 = sigma2; (2) constant mean "
        "stress, sigma1 up and sigma3 = sigma2 down; (3) reduced compression, sigma3 = "
        "sigma2 down at constant sigma1; sigma1 along z. Drawn up to sigma1/sigma3 = 4 "
        "(our choice; the seed's range is not legible in the text). The dotted line "
        f"sigma1 = R* sigma3, R* = {rstar:.3f}, is where the seed's state estimate first "
        "makes contacts slide for phi_mu = 24 deg.")
    return FigureData("6.10", "Initial-stress paths (seed Fig. 6.10)", caption, long_table(blocks),
                      {"R_star": rstar})


def fig6_11() -> FigureData:
    """Seed Fig. 6.11: E_zz and E_xx versus sigma1/sigma3 on the three paths."""
    t = compute()
    rstar = critical_ratio()
    est = "state estimate"
    trend = {k: _at(t, est, k, "E_zz", 2.25) / _at(t, est, k, "E_zz", 1.0) for k in PATHS}
    drop = {k: _at(t, est, k, "E_zz", 3.0) / _at(t, est, k, "E_zz", 2.25) for k in PATHS}
    caption = (
        "Seed Fig. 6.11: Young's moduli E_zz (vertical) and E_xx versus sigma1/sigma3. The "
        "seed: with increasing ratio E_zz increases on the compression path, decreases on "
        "the reduced-compression path and decreases only slightly on the constant-mean "
        "path; beyond about 2.3 the moduli drop appreciably as many contacts slide. Ours "
        "(state estimate), E_zz(2.25)/E_zz(1) = "
        f"{trend['compression']:.3f} (compression), {trend['constant-mean']:.3f} (constant "
        f"mean), {trend['reduced-compression']:.3f} (reduced compression): the signs of the "
        "seed's three trends (the rise on the compression path is small here); "
        "E_zz(3)/E_zz(2.25) = "
        + ", ".join(f"{drop[k]:.3f}" for k in PATHS)
        + ": the drop past R*. Path following slides later, so its moduli fall later and "
        "more gradually. " + _INPUT_TEXT.format(rstar=rstar))
    return FigureData("6.11", "Young's moduli versus stress ratio (seed Fig. 6.11)", caption,
                      _subset(t, ("E_zz", "E_xx")), {"R_star": rstar, "trend": trend, "drop": drop})


def fig6_12() -> FigureData:
    """Seed Fig. 6.12: G_zx and G_xy (and the sliding fraction) versus sigma1/sigma3."""
    t = compute()
    rstar = critical_ratio()
    est = "state estimate"
    sel = (t["method"] == est) & (t["path"] == "compression")
    first = t["ratio"][sel][np.argmax(t["sliding"][sel] > 0)]
    drop = {k: _at(t, est, k, "G_xz", 3.0) / _at(t, est, k, "G_xz", 2.25) for k in PATHS}
    caption = (
        "Seed Fig. 6.12: shear moduli G_zx and G_xy versus sigma1/sigma3, with (our "
        "addition) the fraction of sliding contacts. The seed: like the Young's moduli, "
        "the shear moduli drop appreciably beyond a ratio of about 2.3. Ours (state "
        f"estimate): no contact slides below R* = {rstar:.3f}; on our ratio grid sliding is "
        f"first seen at {first:.3f}; G_zx(3)/G_zx(2.25) = "
        + ", ".join(f"{drop[k]:.3f}" for k in PATHS)
        + " on the compression, constant-mean and reduced-compression paths. "
        + _INPUT_TEXT.format(rstar=rstar))
    return FigureData("6.12", "Shear moduli and sliding versus stress ratio (seed Fig. 6.12)",
                      caption, _subset(t, ("G_xz", "G_xy", "sliding")),
                      {"R_star": rstar, "first_sliding_ratio": float(first), "drop": drop})


def _subset(t: dict, keys: tuple[str, ...]) -> dict[str, np.ndarray]:
    base = ("method", "path", "ratio", "ratio_reached", "sigma1", "sigma3")
    return {k: t[k] for k in (*base, *keys)}

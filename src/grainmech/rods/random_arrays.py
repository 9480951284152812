"""Random rod arrays like the seed's and their shear-box strains.

Random rod arrays like the seed's "random packings" (Sec. 5.2, 6.1.2), generated, and
their strains in the directional shear box (Sec. 5.3). (This module was
``grainmech.rods.random_packing``, with :func:`random_array` called ``packing`` and
:func:`array_stats` called ``packing_stats``; the old names work for one release, with a
:class:`DeprecationWarning`.)

The seed (Sec. 5.2, 6.1.2) tested two random rod assemblies in the directional shear box:

* one size: 271 rods of 0.5 in, ``N = 1372`` contacts, ``e = 0.179``, ``m = 5.06``;
* two sizes: 229 rods of 0.5 in and 190 rods of 0.25 in, ``N = 1991``, ``e = 0.179``,
  ``m = 4.75``.

The seed's ``N`` counts each contact from both rods (``N = m N_p``: 5.06 x 271 = 1371,
4.75 x 419 = 1990), i.e. ``N = 2 N_c`` physical contacts. The rod coordinates were digitised
from photographs and are not in the text, so :func:`random_array` **generates** an array with
the seed's rods and void ratio: the rods are placed at random (seeded) in a square periodic
cell whose area gives ``e = 0.179`` exactly (``A_cell = (1 + e) sum pi d^2/4``), then the
overlaps are removed by minimising the harmonic overlap energy
``U = sum_pairs (1/2) max(r_i + r_j - |x_j - x_i|, 0)^2`` (L-BFGS, the soft-disc
quench of O'Hern et al. 2003, Phys. Rev. E 68, 011306). Contacts are the pairs whose centre
distance is at most ``(r_i + r_j)(1 + CONTACT_TOL)`` (``CONTACT_TOL = 1 %``, fixed before
looking at the coordination and not tuned: the precision of contacts read off a
photograph, as the seed's were). :func:`array_stats` reports what this gives next to the
seed's numbers; the quench does **not** reproduce the seed's coordination (see
``docs/reproduce.md``).

Strains (:func:`strains`): the seed's directional-shear-box test (Sec. 5.3), 2.5 psi
isotropic then 0.5 psi along ``alpha``; rod contacts seed Eq. 3.8 / 3.17 with the stiff
(``G = 40000 psi, Psi = 1``), soft (15000 psi, 2.5) and best-fit (25000 psi, 2.0) constants
of Sec. 6.1.2, ``nu = 0.1``, ``phi_mu = 15 deg``; the tangent stiffness of
:func:`grainmech.rods.shear_box_stiffness`. The seed's Figs. 6.3-6.6 are drawn by
:mod:`grainmech.reproduce.random_rods`.
Everything here is SI (m, Pa) unless a name says psi/in.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from grainmech.assembly import ContactSet
from grainmech.errors import GrainmechError
from grainmech.rods.regular import PeriodicRods, RodContactSet
from grainmech.rods.shear_box import increment_strains, shear_box_stiffness

__all__ = ["ROD_KINDS", "CONTACT_TOL", "CONSTANTS", "PSI_PA", "INCH_M", "generate", "random_array",
           "array_stats", "strains"]


#: Unit conversions (exact definitions).
INCH_M = 0.0254
PSI_PA = 4.4482216152605 / INCH_M ** 2

#: Rods of each random array (seed Sec. 5.2): diameters [in] and counts.
ROD_KINDS: dict[str, dict] = {
    "one-size": {"diameters": (0.5,), "counts": (271,), "void_ratio": 0.179},
    "two-size": {"diameters": (0.5, 0.25), "counts": (229, 190), "void_ratio": 0.179},
}

#: Gap tolerance of the contact criterion, relative to ``r_i + r_j`` (fixed a priori).
CONTACT_TOL = 0.01

#: The three sets of contact constants of seed Sec. 6.1.2 (G [psi], Psi).
CONSTANTS: dict[str, tuple[float, float]] = {
    "stiff": (40000.0, 1.0), "best fit": (25000.0, 2.0), "soft": (15000.0, 2.5)}


def _kind(kind: str) -> str:
    k = str(kind).strip().lower()
    if k not in ROD_KINDS:
        raise GrainmechError(f"kind must be one of {', '.join(ROD_KINDS)}; got {kind!r}")
    return k


def _quench(r: np.ndarray, box: float, x0: np.ndarray) -> tuple[np.ndarray, dict]:
    """Minimise the harmonic overlap energy of discs ``r`` in a periodic square ``box``."""
    n = len(r)
    skin = 0.3 * r.max()
    cutoff = 2 * r.max() + skin
    state: dict = {"ref": None, "pairs": None}

    def neighbours(x: np.ndarray) -> np.ndarray:
        ref = state["ref"]
        if ref is not None:
            dx = x - ref
            dx -= box * np.round(dx / box)
            if np.max(np.abs(dx)) < skin / 2.5:
                return state["pairs"]
        state["ref"] = x.copy()
        state["pairs"] = cKDTree(np.mod(x, box), boxsize=box).query_pairs(cutoff, output_type="ndarray")
        return state["pairs"]

    def energy(flat: np.ndarray) -> tuple[float, np.ndarray]:
        x = flat.reshape(n, 2)
        p = neighbours(x)
        i, j = p[:, 0], p[:, 1]
        d = x[j] - x[i]
        d -= box * np.round(d / box)
        dist = np.sqrt(np.einsum("ij,ij->i", d, d))
        ov = r[i] + r[j] - dist
        m = ov > 0
        i, j, d, dist, ov = i[m], j[m], d[m], dist[m], ov[m]
        f = (ov / dist)[:, None] * d
        g = np.empty((n, 2))
        for c in range(2):
            g[:, c] = np.bincount(i, f[:, c], n) - np.bincount(j, f[:, c], n)
        return 0.5 * float(ov @ ov), g.ravel()

    res = minimize(energy, x0.ravel(), jac=True, method="L-BFGS-B",
                   options={"maxiter": 3000, "ftol": 1e-13, "gtol": 1e-9 * r.max(), "maxcor": 10})
    return np.mod(res.x.reshape(n, 2), box), {"energy": float(res.fun), "iterations": int(res.nit)}


@lru_cache(maxsize=8)
def generate(kind: str, seed: int = 0) -> tuple[PeriodicRods, dict]:
    """Generated random array ``kind`` (lengths in inches) and the quench's record.

    Rods of :data:`ROD_KINDS` placed uniformly at random (``numpy.random.default_rng(seed)``)
    in a square periodic cell of area ``(1 + e) sum pi d^2/4`` with ``e = 0.179``, then
    relaxed by minimising the harmonic overlap energy (module docstring). The record has
    ``energy`` (residual, in^2), ``iterations``, ``max_overlap`` (relative to ``r_i + r_j``).
    """
    k = _kind(kind)
    seed = _seed(seed)
    spec = ROD_KINDS[k]
    d = np.concatenate([np.full(c, dd) for dd, c in zip(spec["diameters"], spec["counts"])])
    r = d / 2
    box = math.sqrt((1 + spec["void_ratio"]) * np.sum(np.pi * r ** 2))
    rng = np.random.default_rng(int(seed))
    x, rec = _quench(r, box, rng.random((len(r), 2)) * box)
    p = PeriodicRods(k, f"{k} random (seed {seed})", box * np.eye(2), x, d,
                     "Generated: random placement + overlap-energy quench at the seed's e.")
    i, j, l_ = p.contacts(CONTACT_TOL, allow_overlap=True)
    rec["max_overlap"] = float(max(0.0, np.max(1 - np.linalg.norm(l_, axis=1) / (r[i] + r[j]))))
    return p, rec


@lru_cache(maxsize=8)
def _random_array(kind: str, seed: int) -> RodContactSet:
    p, _ = generate(kind, seed)
    return p.contact_set(CONTACT_TOL, scale=INCH_M, allow_overlap=True)


def random_array(kind: str, seed: int = 0) -> RodContactSet:
    """Contact set (SI: m, 1/m^2) of the generated random rod array ``kind``.

    Parameters
    ----------
    kind : {"one-size", "two-size"}
        The seed's random packing (array) A (271 rods of 0.5 in) or B (229 of 0.5 in + 190 of
        0.25 in), Sec. 5.2.
    seed : int
        Seed of the random placement (cached per ``(kind, seed)``).

    Returns
    -------
    RodContactSet
        Physical counting (each contact once, centre-to-centre branch vector, weight
        ``1/A_cell``), with the rod radii per contact, the number of rods and the areas.
    """
    return _random_array(_kind(kind), _seed(seed))


def _seed(seed: object) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise GrainmechError(f"seed must be an integer >= 0, got {seed!r}")
    return int(seed)


def array_stats(cs: ContactSet) -> dict:
    """Statistics of a rod array in the seed's terms (Sec. 6.1.2).

    Returns
    -------
    dict
        ``contacts``: the seed's ``N``, each contact counted from both rods (``2 N_c``);
        ``physical_contacts``: ``N_c``; ``particles``; ``void_ratio``
        ``e = (A_cell - A_solid)/A_solid``; ``coordination`` ``m = 2 N_c / N_p``;
        ``mean_branch_length`` [length unit of ``cs``].

    Raises
    ------
    GrainmechError
        If ``cs`` does not carry its rods (use :func:`random_array` or
        :func:`grainmech.rods.regular_array`).
    """
    np_ = getattr(cs, "particles", None)
    a_cell, a_solid = getattr(cs, "cell_area", None), getattr(cs, "solid_area", None)
    if np_ is None or a_cell is None or a_solid is None:
        raise GrainmechError("array_stats needs a RodContactSet (from random_array() or "
                             "rods.regular_array()) that records its rods and cell area")
    nc = len(cs)
    return {"contacts": 2 * nc, "physical_contacts": nc, "particles": int(np_),
            "void_ratio": a_cell / a_solid - 1.0, "coordination": 2.0 * nc / np_,
            "mean_branch_length": float(np.mean(np.linalg.norm(cs.branch, axis=1)))}


def strains(cs: ContactSet, alpha_deg: np.ndarray, *, G: float, psi: float, nu: float = 0.1,
            phi_mu_deg: float = 15.0, pressure: float = 2.5 * PSI_PA,
            increment: float = 0.5 * PSI_PA) -> dict[str, np.ndarray]:
    """Incremental strains of a rod array in the directional shear box (seed Sec. 5.3).

    Isotropic stress ``pressure``, then a stress increment ``increment`` along the
    direction ``alpha`` (from the y axis towards x); strains ``eps = C^-1 : Delta sigma``
    with the tangent stiffness at the isotropic state
    (:func:`grainmech.rods.shear_box_stiffness`: static contact forces, seed
    Eq. 3.8 normal and Eq. 3.17 tangential rod-contact stiffness, Eq. 2.26 physical
    counting). Compression positive.

    Parameters
    ----------
    cs : ContactSet
        2D rod contacts in SI (e.g. :func:`random_array`); a plain ContactSet is read as equal
        rods touching (radius ``|l|/2``).
    alpha_deg : array
        Directions of the major principal stress increment [deg].
    G : float
        Equivalent shear modulus ``G~`` of seed Eq. 3.8 [Pa] (Sec. 6.1.2: 40000, 25000 or
        15000 psi).
    psi : float
        ``Psi`` of seed Eq. 3.17 (1.0, 2.0 or 2.5).
    nu : float
        Poisson's ratio of the rods (0.1).
    phi_mu_deg : float
        Interparticle friction angle [deg] (15).
    pressure, increment : float
        Isotropic stress and the increment [Pa] (2.5 psi and 0.5 psi).

    Returns
    -------
    dict
        ``eps_xx``, ``eps_yy``, ``eps_xy`` (tensor shear, half the engineering strain),
        ``eps_alpha``, ``eps_alpha90``: arrays shaped like ``alpha_deg``, dimensionless.
    """
    checks = {"G": G, "psi": psi, "pressure": pressure, "increment": increment}
    for name, v in checks.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                or not np.isfinite(v) or v <= 0:
            raise GrainmechError(f"{name} must be a finite number > 0, got {v!r}")
    if not np.isfinite(nu) or not -1 < nu < 0.5:
        raise GrainmechError(f"nu must be in (-1, 0.5), got {nu!r}")
    if not np.isfinite(phi_mu_deg) or not 0 <= phi_mu_deg < 90:
        raise GrainmechError(f"phi_mu_deg must be in [0, 90), got {phi_mu_deg!r}")
    a = np.asarray(alpha_deg, dtype=float)
    if not np.all(np.isfinite(a)):
        raise GrainmechError(f"alpha_deg must be finite, got {alpha_deg!r}")
    C = shear_box_stiffness(cs, G=float(G), psi=float(psi), nu=float(nu),
                            phi_mu=math.radians(phi_mu_deg), pressure=float(pressure))
    return increment_strains(C, np.radians(a), float(increment))

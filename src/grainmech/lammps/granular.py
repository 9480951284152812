"""The granular model LAMMPS runs: the grains' material, the cell, the grains and the contact model.

LAMMPS' ``pair_style granular`` with ``hertz/material`` normal force
``N = (4/3) E* R*^(1/2) delta^(3/2)`` (Hertz 1882; seed Eq. 3.6), ``tangential mindlin``
with the no-slip stiffness ``k_t = 8 G* a``, ``a = (R* delta)^(1/2)`` and the Coulomb cap
``|T| <= mu N`` (Mindlin 1949; seed Eq. 3.11), viscous normal and tangential damping set
by a coefficient of restitution, and optionally ``rolling sds`` / ``twisting sds``
(:mod:`grainmech.lammps.rolling`). Used by the preparation of packings
(:mod:`grainmech.packing.prepare`) and the LAMMPS session of the DEM model
(:mod:`grainmech.lammps.session`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.contact.geometry import hertz_kn, hertz_radius
from grainmech.contact.rolling import RollingResistance
from grainmech.errors import GrainmechError

__all__ = ["GrainMaterial", "pair_coeff", "critical_time_step", "SORT_MIN_GRAINS", "atom_modify", "setup_lammps",
           "resume_lammps", "measure_moments"]


@dataclass(frozen=True)
class GrainMaterial:
    """Grain material (SI units).

    Parameters
    ----------
    name : str
    shear_modulus : float
        ``G`` [Pa].
    poisson : float
        ``nu`` [-].
    density : float
        Grain density [kg/m^3].
    friction : float
        Coulomb coefficient between grains ``mu`` [-].
    restitution : float
        Coefficient of restitution of the contact damping (a numerical device for
        quasi-static preparation) [-].
    rolling : RollingResistance or None
        Rolling and twisting resistance between grains (``grainmech pack``'s relaxation
        stage and final packing); None: none. The DEM model of ``grainmech run`` takes its
        rolling resistance from the run's ``[contacts]`` table instead.
    """

    name: str
    shear_modulus: float
    poisson: float
    density: float
    friction: float
    restitution: float = 0.1
    rolling: RollingResistance | None = None

    def __post_init__(self) -> None:
        for k, lo in (("shear_modulus", 0.0), ("density", 0.0)):
            v = getattr(self, k)
            if not (math.isfinite(v) and v > lo):
                raise ValueError(f"{k} = {v!r}: must be finite and > 0")
        if not -1 < self.poisson < 0.5:
            raise ValueError(f"poisson = {self.poisson!r}: must lie in (-1, 0.5)")
        if not (math.isfinite(self.friction) and self.friction >= 0):
            raise ValueError(f"friction = {self.friction!r}: must be finite and >= 0")
        if not 0 < self.restitution <= 1:
            raise ValueError(f"restitution = {self.restitution!r}: must lie in (0, 1]")

    @property
    def young(self) -> float:
        """``E = 2 G (1 + nu)`` [Pa]."""
        return 2.0 * self.shear_modulus * (1.0 + self.poisson)

    @property
    def e_star(self) -> float:
        """Contact modulus of two equal grains ``E* = E / (2 (1 - nu^2))`` [Pa] (seed Eq. 3.6)."""
        return self.young / (2.0 * (1.0 - self.poisson ** 2))




def pair_coeff(mat: GrainMaterial, mu: float, rolling: str = "") -> str:
    """``pair_coeff`` of the granular model (module notes); ``NULL`` k_t = 8 G* a.

    ``rolling``: the ``rolling sds ... twisting sds ...`` suffix of rolling resistance
    (:func:`grainmech.lammps.rolling.rolling_pair_suffix`), empty without it.
    """
    return (f"pair_coeff * * hertz/material {mat.young:.10g} {mat.restitution:.6g} {mat.poisson:.6g} "
            f"tangential mindlin NULL 1.0 {mu:.10g} damping coeff_restitution{rolling}")


def critical_time_step(radii: np.ndarray, mat: GrainMaterial, stress: float, safety: float = 0.2) -> float:
    """Time step ``safety * sqrt(m_min / kn_max)`` [s] of a Hertz packing at mean stress ``stress``.

    The mean contact force at mean stress ``p`` is ``F = p pi d^2 / (z phi)`` with
    ``z phi ~ 3`` (Love-Weber stress of equal spheres, seed Eq. 2.6, ``p = z phi F / (pi d^2)``);
    ``kn_max`` is the Hertz stiffness ``kn = 2 E* a``, ``a = (R* delta)^(1/2)`` (seed Eq. 3.5)
    of the two smallest grains carrying 10 times that force, ``m_min`` the smallest mass.
    """
    r = np.asarray(radii, float)
    rmin, rbar = float(r.min()), float(r.mean())
    F = 10.0 * stress * math.pi * (2.0 * rbar) ** 2 / 3.0
    kn = float(hertz_kn(hertz_radius(F, mat.e_star, 0.5 * rmin), mat.e_star))
    m_min = mat.density * 4.0 / 3.0 * math.pi * rmin ** 3
    return safety * math.sqrt(m_min / kn)


#: more grains than this: LAMMPS sorts its atoms spatially (``atom_modify sort``, every 1000
#: time steps into bins of half the neighbour cutoff, LAMMPS' own default), so that
#: neighbours sit close in memory. Measured on 'dense' tiled and its grains shuffled (the
#: order of a packing made from a random gas; ``benchmarks/bench_lammps_sort.py``), time
#: steps per CPU second sorted against unsorted: 1.9x at 36 000 grains, 3.1x at 100 000; at
#: 2000 and 8000 grains 1.0-1.4x, within the scatter of those runs on shared cores
#: (``docs/performance.md``). Up to this size a run stays bit-identical to an unsorted one
#: (the shipped packings, the tests and the tables of the docs were made unsorted).
SORT_MIN_GRAINS = 5000


def atom_modify(n_grains: int) -> str:
    """The ``atom_modify`` command for ``n_grains`` grains: a map by ID, sorted above ``SORT_MIN_GRAINS``."""
    return "atom_modify map array " + ("sort 1000 0.0" if n_grains > SORT_MIN_GRAINS else "sort 0 0")


def setup_lammps(lmp: Any, positions: np.ndarray, radii: np.ndarray, cell: np.ndarray,
                 mat: GrainMaterial, mu: float, stress: float, ids: np.ndarray | None = None,
                 rolling: str = "") -> dict:
    """Create the periodic triclinic cell and the grains, the granular model, integrator, pressure and contact computes.

    ``cell`` rows ``a = (lx,0,0)``, ``b = (xy,ly,0)``, ``c = (xz,yz,lz)`` with the origin at
    0; ``rolling``: the ``rolling sds ... twisting sds ...`` suffix of the ``pair_coeff``
    (:func:`grainmech.lammps.rolling.rolling_pair_suffix`; with it the contact moments are measured too,
    :func:`measure_moments`). Returns the numerical constants used.
    """
    n = len(radii)
    a, b, c = cell
    lx, ly, lz = a[0], b[1], c[2]
    xy, xz, yz = b[0], c[0], c[1]
    rmin = float(np.min(radii))
    lmp.commands([
        "units si", "atom_style sphere", atom_modify(n), "boundary p p p",
        "comm_modify vel yes",
        f"region cell prism 0 {lx:.17g} 0 {ly:.17g} 0 {lz:.17g} {xy:.17g} {xz:.17g} {yz:.17g}",
        "create_box 1 cell"])
    tags = np.arange(1, n + 1) if ids is None else np.asarray(ids, int)
    lmp.create_atoms(tags, np.ones(n, int), positions)
    if lmp.natoms() != n:
        raise GrainmechError(f"LAMMPS created {lmp.natoms()} of {n} grains (positions outside the cell?)")
    tag = lmp.atom("id")
    rowof = {int(t): k for k, t in enumerate(tags)}
    rows = np.array([rowof[int(t)] for t in tag])
    lmp.atom_view("radius")[:] = radii[rows]
    lmp.atom_view("rmass")[:] = mat.density * 4.0 / 3.0 * np.pi * radii[rows] ** 3
    dt = critical_time_step(radii, mat, stress)
    _model(lmp, mat, mu, rolling, rmin, dt)
    return {"dt": dt}


def _model(lmp: Any, mat: GrainMaterial, mu: float, rolling: str, rmin: float, dt: float) -> None:
    """The granular model, integrator, time step, pressure and contact computes of a cell with its grains."""
    lmp.commands([
        "pair_style granular", pair_coeff(mat, mu, rolling),
        f"neighbor {0.3 * rmin:.10g} bin", "neigh_modify delay 0 every 1 check yes",
        "fix integrate all nve/sphere", f"timestep {dt:.10g}",
        "compute press all pressure NULL virial",
        "thermo_style custom step c_press", "thermo_modify norm no",
        "compute cpair all pair/local force p1 p2 p3 p10 p11 p12 cutoff radius",
        "compute cids all property/local patom1 patom2 cutoff radius",
    ])
    if rolling:
        measure_moments(lmp)


def resume_lammps(lmp: Any, restart: str, mat: GrainMaterial, mu: float, dt: float, rolling: str = "") -> None:
    """Read a LAMMPS restart file written by :func:`setup_lammps`'s system and set its model up again.

    The restart file keeps the cell, the grains (positions, velocities, spins, radii,
    masses) and the contacts' spring history (LAMMPS' ``fix NEIGH_HISTORY``, taken up
    when ``pair_style granular`` is given again); the pair coefficients, neighbor
    settings, fixes and computes are given again as :func:`setup_lammps` gives them.
    """
    lmp.commands(["atom_modify map array", f"read_restart {restart}", "comm_modify vel yes"])
    lmp.command(atom_modify(lmp.natoms()).replace("atom_modify map array ", "atom_modify "))
    _model(lmp, mat, mu, rolling, float(np.min(lmp.atom_all("radius"))), dt)


def measure_moments(lmp: Any) -> None:
    """Define the compute that gives :func:`network_from_lammps` the contacts' rolling and twisting moments.

    ``compute pair/local p5 p6 p7 p9`` of ``pair_style granular``: the rolling force
    ``F_r`` (3) and the signed twisting torque ``M_t`` of each pair (LAMMPS
    ``PairGranular::single``); defined once, after a ``pair_coeff`` with ``rolling`` or
    ``twisting`` (without them LAMMPS does not set these values).
    """
    if not lmp.has_id("compute", "croll"):
        lmp.command("compute croll all pair/local p5 p6 p7 p9 cutoff radius")

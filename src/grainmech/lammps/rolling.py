"""Rolling and twisting resistance in LAMMPS: the ``pair_coeff`` suffix, its dashpots, its constants.

The law is :mod:`grainmech.contact.rolling`; LAMMPS runs it as ``rolling sds`` /
``twisting sds`` after ``tangential mindlin`` (:meth:`~grainmech.contact.rolling.RollingConstants.lammps`).
Used by the preparation (:mod:`grainmech.packing.prepare`), the LAMMPS session
(:mod:`grainmech.lammps.session`) and the DEM model.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from grainmech.contact.params import HertzMindlin
from grainmech.contact.rolling import RollingConstants, RollingResistance, rolling_constants

if TYPE_CHECKING:  # for the annotations only
    from grainmech.network import ContactNetwork

__all__ = ["ROLLING_DAMPING", "rolling_damping", "rolling_pair_suffix", "grain_law", "rolling_for_stress",
           "rolling_of_network"]


#: rolling and twisting dashpots of LAMMPS' ``rolling sds`` / ``twisting sds`` as a
#: fraction of the critical damping of a grain rocking on one contact (:func:`rolling_damping`)
ROLLING_DAMPING = 0.5


def rolling_damping(consts: RollingConstants, radius: float, density: float,
                    fraction: float = ROLLING_DAMPING) -> tuple[float, float]:
    """``(gamma_roll, gamma_twist)`` of LAMMPS' ``rolling sds`` / ``twisting sds``: ``fraction`` of critical.

    Two grains of radius ``radius`` [m] and density ``density`` [kg/m^3], each of moment of
    inertia ``I = (2/5) m R^2``, rocking against each other on one contact have the
    reduced inertia ``I_eff = I / 2``. With the rolling moment stiffness
    ``k_roll R*^2`` (``R* = consts.mean_radius``) the critical moment damping is
    ``2 sqrt(k_roll R*^2 I_eff)``; LAMMPS' rolling dashpot acts on the rolling velocity
    ``R* (omega_i - omega_j) x n`` with a force ``gamma_roll v`` whose moment is
    ``R*`` times it, a moment damping ``gamma_roll R*^2``, hence
    ``gamma_roll = fraction 2 sqrt(k_roll I_eff) / R*``. The twisting dashpot is a moment
    damping itself: ``gamma_twist = fraction 2 sqrt(k_twist I_eff)`` (the spring-dashpot
    "type C" model, Ai et al. 2011, Eq. 17-19, with its damping ratio ``eta_r = fraction``).

    A dashpot acts on the relative spin only: at an equilibrium state (every grain at
    rest) it exerts nothing, so it changes the path between recorded states, not the
    states (the same holds for the contacts' normal and tangential damping).
    """
    m = density * 4.0 / 3.0 * math.pi * radius ** 3
    i_eff = 0.5 * 0.4 * m * radius ** 2
    Rs = consts.mean_radius
    g_roll = fraction * 2.0 * math.sqrt(consts.k_roll * i_eff) / Rs if consts.mu_roll > 0 else 0.0
    g_twist = fraction * 2.0 * math.sqrt(consts.k_twist * i_eff) if consts.twist_cap > 0 else 0.0
    return g_roll, g_twist


def rolling_pair_suffix(consts: RollingConstants | None, radius: float, density: float) -> str:
    """The ``rolling sds ... twisting sds ...`` suffix of a ``pair_coeff`` (empty for ``None``).

    The constants of ``consts`` (:meth:`~grainmech.contact.rolling.RollingConstants.lammps`:
    LAMMPS' rolling displacement ``xi = R* (omega x n)`` with ``F_r = -k_roll xi`` capped
    at ``mu_roll N`` and torque ``R* n x F_r`` is the moment spring ``k_roll R*^2`` capped
    at ``mu_r R* N``) and the dashpots of :func:`rolling_damping`.
    """
    if consts is None:
        return ""
    return consts.lammps(*rolling_damping(consts, radius, density))


def grain_law(mat: Any, radius: float) -> HertzMindlin:
    """The Hertz-Mindlin law of two grains of ``mat`` of radius ``radius`` (for :func:`rolling_constants`)."""
    return HertzMindlin(mat.shear_modulus, mat.poisson, radius, friction=mat.friction if mat.friction > 0 else math.inf)


def rolling_for_stress(rolling: RollingResistance, mat: Any, radii: np.ndarray,
                       stress: float) -> RollingConstants:
    """Rolling constants of a packing not made yet, at mean stress ``stress`` [Pa].

    The mean contact force at mean stress ``p`` is taken as ``F = p pi d^2 / 3`` (the
    Love-Weber stress of equal spheres ``p = z phi F / (pi d^2)``, seed Eq. 2.6, with
    ``z phi ~ 3``) and the mean effective radius as half the mean radius;
    :func:`~grainmech.contact.rolling.rolling_constants` ties ``k_roll`` to the Mindlin
    stiffness at that force (Iwashita & Oda 1998) unless it is given.
    """
    rbar = float(np.mean(radii))
    F = stress * math.pi * (2.0 * rbar) ** 2 / 3.0
    return rolling_constants(rolling, grain_law(mat, rbar), np.array([F]), np.array([0.5 * rbar]))


def rolling_of_network(rolling: RollingResistance, mat: Any, net: ContactNetwork) -> RollingConstants:
    """Rolling constants of the packing ``net`` (its contacts' normal forces and effective radii)."""
    R = net.require_radii("rolling resistance")
    return rolling_constants(rolling, grain_law(mat, float(np.median(R))), net.normal_force,
                             net.effective_radii("rolling resistance"))

"""Rolling and twisting resistance at a contact: elastic–plastic moment springs.

A sphere model stands in for angular grains by resisting the relative rotation of two
grains in contact (Iwashita & Oda 1998, J. Eng. Mech. 124(3); Ai, Chen, Rotter & Ooi 2011,
Powder Technol. 206(3), the elastic–plastic spring–dashpot "type C" model). With the
relative rotation ``omega = theta_A - theta_B`` of the two grains of a contact of unit
normal ``n`` and effective radius ``R* = R_A R_B / (R_A + R_B)`` (seed Eq. 3.3):

* **Rolling** (the part of ``omega`` normal to ``n``): a moment
  ``M_r = k_roll R*^2 omega_perp`` accumulated incrementally and capped at
  ``|M_r| <= mu_r R* N`` by radial return (the elastic–plastic rolling spring of Iwashita & Oda 1998 and of
  Ai et al. 2011's "type C" model). ``k_roll`` [force/length] is one constant of the packing; by default it is the
  Mindlin tangential stiffness ``k_t = 8 G* a`` (seed Eq. 3.11 with theta = 1) at the
  packing's mean contact force and mean effective radius, so that the rolling stiffness is
  ``k_t R*^2`` as in Iwashita & Oda's and LIGGGHTS' EPSD2 form. This is LAMMPS'
  ``rolling sds k_roll gamma_roll mu_roll`` exactly: its rolling displacement
  ``xi = R* (omega x n)`` with ``F_r = -k_roll xi`` capped at ``mu_roll N`` and torque
  ``R* n x F_r`` gives the moment stiffness ``k_roll R*^2`` and the cap ``mu_roll R* N``.
* **Twisting** (the part along ``n``): a moment ``M_t = k_twist psi``, ``psi = n . omega``,
  capped at ``|M_t| <= c_twist N``, a spring and cap of the same kind as the rolling one:
  ``k_twist = k_roll R̄*^2`` and ``c_twist = mu_t R̄*`` with the packing's mean effective
  radius ``R̄*`` and ``mu_t`` the twisting coefficient (default ``mu_r``). One constant
  each, as LAMMPS' ``twisting sds k_twist gamma_twist mu_twist`` carries them.

A contact that opens (``N <= 0``) loses its moments. The moments are work-conjugate to
``omega``: the out-of-balance moment of grain A gains ``+M`` and that of B ``-M``
(the sign of the contact force ``f`` conjugate to the relative displacement in
:mod:`grainmech.driver.packing`). Contact moments do not enter the Love–Weber stress
(seed Eq. 2.6 sums forces times branch vectors); they enter the grains' moment balance.

The affine model (the seed's kinematic hypothesis) has no grain rotation: rolling
resistance is inert there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from grainmech.contact.geometry import hertz_contact_radius_from_force, mindlin_kt0
from grainmech.errors import GrainmechError, ParameterError

__all__ = ["RollingResistance", "RollingConstants", "RollingResponse", "rolling_constants", "rolling_update",
           "rolling_elastic_stiffness", "moment_energy"]


def _coefficient(name: str, value: Any) -> float:
    if isinstance(value, (bool, str)):
        raise ParameterError(name, value, "must be a number")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, value, "must be a number") from None
    if not math.isfinite(v) or v < 0.0:
        raise ParameterError(name, value, "must be finite and >= 0")
    return v


@dataclass(frozen=True)
class RollingResistance:
    """Rolling and twisting resistance of the grain contacts (module notes).

    Parameters
    ----------
    friction : float
        Rolling-friction coefficient ``mu_r >= 0`` (dimensionless): ``|M_r| <= mu_r R* N``.
        0 switches rolling and twisting resistance off.
    stiffness : float or None
        ``k_roll`` [force/length], the rolling moment stiffness being ``k_roll R*^2``;
        ``None`` (default): the Mindlin tangential stiffness ``8 G* a`` at the packing's
        mean contact force and mean effective radius (Iwashita & Oda 1998; EPSD2).
    twisting_friction : float or None
        ``mu_t >= 0``: ``|M_t| <= mu_t R̄* N``; ``None``: equal to ``friction``.
    """

    friction: float
    stiffness: float | None = None
    twisting_friction: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "friction", _coefficient("rolling_friction", self.friction))
        if self.stiffness is not None:
            k = _coefficient("rolling_stiffness", self.stiffness)
            if not k > 0.0:
                raise ParameterError("rolling_stiffness", self.stiffness, "must be > 0 (omit it for k_t)")
            object.__setattr__(self, "stiffness", k)
        if self.twisting_friction is not None:
            object.__setattr__(self, "twisting_friction",
                               _coefficient("twisting_friction", self.twisting_friction))

    @property
    def active(self) -> bool:
        """Whether any moment is resisted (``mu_r > 0`` or ``mu_t > 0``)."""
        return self.friction > 0.0 or (self.twisting_friction or 0.0) > 0.0

    @property
    def mu_twist(self) -> float:
        """``mu_t`` (``friction`` when not given)."""
        return self.friction if self.twisting_friction is None else self.twisting_friction


@dataclass(frozen=True)
class RollingConstants:
    """The rolling law of one packing, resolved (module notes).

    Attributes
    ----------
    mu_roll : float
        ``mu_r`` [-].
    k_roll : float
        Rolling stiffness coefficient [force/length]; moment stiffness ``k_roll R*^2``.
    k_twist : float
        Twisting moment stiffness [force x length / rad].
    twist_cap : float
        ``c_twist = mu_t R̄*`` [length]: ``|M_t| <= c_twist N``.
    mean_radius : float
        ``R̄*`` [length], the mean effective radius the constants were resolved with.
    source : str
        How ``k_roll`` was chosen (for run notes).
    """

    mu_roll: float
    k_roll: float
    k_twist: float
    twist_cap: float
    mean_radius: float
    source: str = ""

    def lammps(self, gamma_roll: float = 0.0, gamma_twist: float = 0.0) -> str:
        """The ``rolling sds ... twisting sds ...`` part of a LAMMPS ``pair_coeff`` (module notes)."""
        out = ""
        if self.mu_roll > 0.0:
            out += f" rolling sds {self.k_roll:.10g} {gamma_roll:.10g} {self.mu_roll:.10g}"
        if self.twist_cap > 0.0:
            out += f" twisting sds {self.k_twist:.10g} {gamma_twist:.10g} {self.twist_cap:.10g}"
        return out


def rolling_constants(rolling: RollingResistance, params: Any, normal_force: np.ndarray,
                      effective_radius: np.ndarray) -> RollingConstants:
    """Resolve ``rolling`` on a packing whose contacts carry ``normal_force`` (module notes).

    Parameters
    ----------
    rolling : RollingResistance
    params : Hertz-type contact law parameters (``effective_shear_modulus``,
        ``effective_modulus``) or :class:`~grainmech.contact.LinearSpring` (``ks``).
    normal_force : array (C,)
        Normal forces of the contacts [force]; the mean is over those carrying force.
    effective_radius : array (C,)
        ``R*`` of the contacts [length].

    Raises
    ------
    GrainmechError
        If no contact carries force (the default stiffness cannot be chosen) or the law
        has no tangential stiffness to tie ``k_roll`` to.
    """
    N = np.asarray(normal_force, float)
    Rs = np.asarray(effective_radius, float)
    carrying = N > 0
    if not carrying.any():
        raise GrainmechError("rolling resistance: no contact carries force, so the rolling stiffness "
                             "(k_t at the mean contact force) cannot be chosen; give contacts.rolling_stiffness")
    Rbar = float(Rs[carrying].mean())
    if rolling.stiffness is not None:
        k, source = float(rolling.stiffness), f"rolling stiffness k_roll = {rolling.stiffness:.4g} N/m (given)"
    elif hasattr(params, "ks") and hasattr(params, "kn"):  # linear springs: their tangential stiffness
        k, source = float(params.ks), f"rolling stiffness k_roll = k_t = {params.ks:.4g} N/m (linear spring)"
    elif hasattr(params, "effective_shear_modulus"):
        Nbar = float(N[carrying].mean())
        a = float(hertz_contact_radius_from_force(Nbar, _with_radius(params, Rbar)))
        k = float(mindlin_kt0(a, params.effective_shear_modulus))
        source = (f"rolling stiffness k_roll = 8 G* a = {k:.4g} N/m at the mean contact force {Nbar:.4g} N "
                  f"and mean R* {Rbar:.4g} m (Iwashita & Oda 1998)")
    else:
        raise GrainmechError(f"rolling resistance: the contact law {type(params).__name__} has no tangential "
                             "stiffness to tie the rolling stiffness to; give contacts.rolling_stiffness")
    if not (math.isfinite(k) and k > 0.0):
        raise GrainmechError(f"rolling resistance: the rolling stiffness came out as {k!r}; "
                             "give contacts.rolling_stiffness")
    return RollingConstants(rolling.friction, k, k * Rbar * Rbar, rolling.mu_twist * Rbar, Rbar, source)


def _with_radius(params: Any, radius: float) -> Any:
    """``params`` of two equal spheres whose effective radius is ``radius``."""
    return replace(params, radius1=2.0 * radius, radius2=None)


def rolling_elastic_stiffness(consts: RollingConstants, n: np.ndarray, effective_radius: np.ndarray,
                              closed: np.ndarray | None = None) -> np.ndarray:
    """Elastic moment stiffness (C, 3, 3): ``k_roll R*^2 (I - n n) + k_twist n n`` [force x length].

    Open contacts (``closed`` False) give zero. Rolling terms are present only with
    ``mu_roll > 0``, twisting ones only with ``twist_cap > 0``.
    """
    n = np.asarray(n, float)
    Rs = np.asarray(effective_radius, float)
    nn = n[:, :, None] * n[:, None, :]
    kr = consts.k_roll * Rs * Rs if consts.mu_roll > 0 else np.zeros_like(Rs)
    kt = consts.k_twist if consts.twist_cap > 0 else 0.0
    K = kr[:, None, None] * (np.eye(3) - nn) + kt * nn
    if closed is not None:
        K = np.where(np.asarray(closed, bool)[:, None, None], K, 0.0)
    return K


def moment_energy(consts: RollingConstants, moment: np.ndarray, n: np.ndarray,
                  effective_radius: np.ndarray) -> np.ndarray:
    """Elastic energy (C,) [energy] held by the moment springs of :func:`rolling_update`.

    ``|M_r|^2 / (2 k_roll R*^2) + M_t^2 / (2 k_twist)`` with ``M_t = M . n`` and
    ``M_r = M - M_t n``; a part whose resistance is off (``mu_roll = 0``, no twisting cap)
    holds none.
    """
    M = np.asarray(moment, float)
    n = np.asarray(n, float)
    Rs = np.asarray(effective_radius, float)
    mt = np.einsum("ci,ci->c", M, n)
    e = np.zeros(len(mt))
    if consts.mu_roll > 0:
        e += np.maximum(np.einsum("ci,ci->c", M, M) - mt * mt, 0.0) / (2.0 * consts.k_roll * Rs * Rs)
    if consts.twist_cap > 0:
        e += mt * mt / (2.0 * consts.k_twist)
    return e


@dataclass(frozen=True)
class RollingResponse:
    """Result of :func:`rolling_update` (C contacts).

    Attributes
    ----------
    moment : array (C, 3)
        New contact moment ``M`` (rolling part normal to ``n`` plus twisting part along it)
        [force x length].
    tangent : array (C, 3, 3)
        Consistent ``dM / d omega`` at fixed ``N``.
    dmoment_dnormal : array (C, 3)
        ``dM / dN`` (non-zero on a cap: the cap moves with the normal force).
    rolling, twisting : bool arrays (C,)
        Rolling / twisting at its cap.
    dissipated : array (C,)
        Work dissipated in this increment [energy].
    """

    moment: np.ndarray
    tangent: np.ndarray
    dmoment_dnormal: np.ndarray
    rolling: np.ndarray
    twisting: np.ndarray
    dissipated: np.ndarray


def rolling_update(consts: RollingConstants, n: np.ndarray, effective_radius: np.ndarray,
                   normal_force: np.ndarray, moment: np.ndarray, d_omega: np.ndarray) -> RollingResponse:
    """One increment of the rolling and twisting springs (elastic predictor, radial return).

    Ai et al. (2011) (rolling; the "type C" model without its dashpot, which
    acts only on rates) and the same rule for twisting (Marshall 2009, Eq. 30, 34, 44 with
    one constant stiffness and cap, as LAMMPS ``twisting sds``).

    Parameters
    ----------
    consts : RollingConstants
    n : array (C, 3)
        Unit contact normals (fixed over the increment).
    effective_radius : array (C,)
        ``R*`` [length].
    normal_force : array (C,)
        Normal force at the end of the increment [force] (``<= 0``: open, moments vanish).
    moment : array (C, 3)
        Moment at the start of the increment.
    d_omega : array (C, 3)
        Increment of the relative rotation ``theta_A - theta_B`` [rad].
    """
    n = np.asarray(n, float)
    Rs = np.asarray(effective_radius, float)
    N = np.asarray(normal_force, float)
    m0 = np.asarray(moment, float)
    dw = np.asarray(d_omega, float)
    C = n.shape[0]
    closed = N > 0
    nn = n[:, :, None] * n[:, None, :]
    P = np.eye(3) - nn
    # rolling: the part normal to n
    tangent = np.zeros((C, 3, 3))
    dmdN = np.zeros((C, 3))
    diss = np.zeros(C)
    m_new = np.zeros((C, 3))
    roll = np.zeros(C, bool)
    twist = np.zeros(C, bool)
    if consts.mu_roll > 0.0:
        kr = consts.k_roll * Rs * Rs
        mr0 = m0 - np.einsum("ci,ci->c", m0, n)[:, None] * n
        dwp = dw - np.einsum("ci,ci->c", dw, n)[:, None] * n
        tr = mr0 + kr[:, None] * dwp
        mag = np.linalg.norm(tr, axis=1)
        cap = consts.mu_roll * Rs * np.maximum(N, 0.0)
        roll = closed & (mag > cap)
        safe = np.where(mag > 0, mag, 1.0)
        t = tr / safe[:, None]
        ratio = np.where(roll, cap / safe, 1.0)
        mr = tr * ratio[:, None]
        K_el = kr[:, None, None] * P
        K_pl = (kr * ratio)[:, None, None] * (P - t[:, :, None] * t[:, None, :])
        tangent += np.where(roll[:, None, None], K_pl, K_el)
        dmdN += np.where(roll[:, None], consts.mu_roll * Rs[:, None] * t, 0.0)
        diss += np.where(roll, cap * (mag - cap) / np.where(kr > 0, kr, 1.0), 0.0)
        m_new += mr
    if consts.twist_cap > 0.0:
        mt0 = np.einsum("ci,ci->c", m0, n)
        tr_t = mt0 + consts.k_twist * np.einsum("ci,ci->c", dw, n)
        cap_t = consts.twist_cap * np.maximum(N, 0.0)
        twist = closed & (np.abs(tr_t) > cap_t)
        mt = np.where(twist, np.sign(tr_t) * cap_t, tr_t)
        tangent += np.where(twist, 0.0, consts.k_twist)[:, None, None] * nn
        dmdN += np.where(twist, consts.twist_cap * np.sign(tr_t), 0.0)[:, None] * n
        diss += np.where(twist, cap_t * (np.abs(tr_t) - cap_t) / consts.k_twist, 0.0)
        m_new += mt[:, None] * n
    m_new = np.where(closed[:, None], m_new, 0.0)
    tangent = np.where(closed[:, None, None], tangent, 0.0)
    dmdN = np.where(closed[:, None], dmdN, 0.0)
    return RollingResponse(m_new, tangent, dmdN, roll, twist, np.where(closed, diss, 0.0))

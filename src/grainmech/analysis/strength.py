"""Strength from a monotonic path: mobilised, peak and critical-state friction angles.

For a stress state with principal stresses ``sigma_1 >= sigma_3`` (compression positive,
effective stresses) the mobilised friction angle is the Mohr-Coulomb one for zero
cohesion,

    ``sin(phi_mob) = (sigma_1 - sigma_3) / (sigma_1 + sigma_3)``

(e.g. Wood 1990, *Soil behaviour and critical state soil mechanics*, Sec. 4.2; on a
triaxial compression path ``q/p = 6 sin(phi) / (3 - sin(phi))``). The **peak** angle is
its largest value along the path. The **critical state** is reached when the stress ratio
and the volume no longer change with shear strain (Schofield & Wroth 1968): the angle is
the mean of ``phi_mob`` over the last ``tail`` fraction of the axial strain, reported with
the dilatancy rate ``d eps_v / d eps_a`` there and whether it is small enough
(``|rate| <= rate_tol``) to call the state critical.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainmech.conventions import von_mises
from grainmech.errors import ParameterError

__all__ = ["StrengthResult", "mobilised_friction_angle", "path_strength"]


def mobilised_friction_angle(stress: np.ndarray) -> np.ndarray:
    """Mobilised friction angle ``phi_mob`` [deg] of each Voigt stress row (module notes).

    Parameters
    ----------
    stress : array (k, 6)
        Voigt ``xx yy zz yz xz xy`` [Pa], compression positive.

    Returns
    -------
    ndarray (k,)
        NaN where the state is not compressive (``sigma_1 + sigma_3 <= 0``).
    """
    s = np.atleast_2d(np.asarray(stress, dtype=float))
    if s.shape[-1] != 6:
        raise ParameterError("stress", s.shape, "must have 6 Voigt components per row")
    T = np.empty((len(s), 3, 3))
    for k, (i, j) in enumerate(((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))):
        T[:, i, j] = T[:, j, i] = s[:, k]
    ev = np.linalg.eigvalsh(T)
    s1, s3 = ev[:, 2], ev[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(s1 + s3 > 0, (s1 - s3) / np.where(s1 + s3 > 0, s1 + s3, 1.0), np.nan)
    return np.degrees(np.arcsin(np.clip(ratio, -1.0, 1.0)))


@dataclass(frozen=True)
class StrengthResult:
    """Peak and critical-state strength of a monotonic path (:func:`path_strength`)."""

    peak_friction_angle_deg: float
    peak_axial_strain: float
    peak_q_over_p: float
    critical_friction_angle_deg: float
    critical_q_over_p: float
    dilatancy_rate: float
    critical: bool
    final_axial_strain: float
    note: str

    def as_dict(self) -> dict:
        """JSON-ready dict."""
        return dict(self.__dict__)


def path_strength(stress: np.ndarray, axial_strain: np.ndarray, volumetric_strain: np.ndarray, *,
                  tail: float = 0.2, rate_tol: float = 0.05) -> StrengthResult:
    """Peak and critical-state friction angles of a monotonic shearing path (module notes).

    Parameters
    ----------
    stress : (k, 6) Voigt stresses [Pa], compression positive
    axial_strain, volumetric_strain : (k,) decimal, compression positive, from the start
    tail : float
        Fraction of the final axial strain over which the critical state is averaged.
    rate_tol : float
        Largest ``|d eps_v / d eps_a|`` over the tail for the state to count as critical.
    """
    s = np.asarray(stress, dtype=float)
    ea = np.asarray(axial_strain, dtype=float)
    ev = np.asarray(volumetric_strain, dtype=float)
    if not (0 < tail < 1):
        raise ParameterError("tail", tail, "must lie in (0, 1)")
    if len(s) < 3 or len(ea) != len(s) or len(ev) != len(s):
        raise ParameterError("stress", len(s), "needs at least 3 states with matching strain arrays")
    phi = mobilised_friction_angle(s)
    p = s[:, :3].mean(axis=1)
    q = von_mises(s)
    qp = q / np.where(p > 0, p, np.nan)
    k = int(np.nanargmax(phi))
    a_end = float(np.abs(ea[-1]))
    sel = np.abs(ea) >= (1.0 - tail) * a_end
    if sel.sum() < 2:
        sel = np.zeros(len(s), bool)
        sel[-2:] = True
    x, y = ea[sel] - ea[sel].mean(), ev[sel] - ev[sel].mean()
    # least-squares slope d eps_v / d eps_a over the tail (NaN when the axial strain does not change there)
    slope = float(np.dot(x, y) / np.dot(x, x)) if float(np.dot(x, x)) > 0 else float("nan")
    critical = bool(np.isfinite(slope) and abs(slope) <= rate_tol)
    note = (f"critical state: the last {100 * tail:.0f} % of the axial strain ({a_end:.3g}) shears at a "
            f"dilatancy rate d eps_v / d eps_a = {slope:.3g}"
            + ("" if critical else f", above {rate_tol:g}: the volume still changes, the angle is the end of "
               "the path, not a critical state (strain further)"))
    return StrengthResult(float(phi[k]), float(ea[k]), float(qp[k]), float(np.nanmean(phi[sel])),
                          float(np.nanmean(qp[sel])), slope, critical, float(ea[-1]), note)

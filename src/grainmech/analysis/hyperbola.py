"""The modified hyperbola of Darendeli (2001) and Menq (2003), fitted to a model's points.

Modulus reduction (Darendeli 2001, Ch. 9, the "modified hyperbolic model"; Menq 2003
takes the same form for sands and gravels)::

    G/Gmax = 1 / (1 + (gamma / gamma_r)^a)

with the reference strain ``gamma_r`` (where ``G/Gmax = 0.5``) and the curvature ``a``.
Damping in the same authors' form::

    D = b (G/Gmax)^0.1 D_Masing(gamma; gamma_r, a) + D_min

``D_Masing`` the Masing damping of the modified hyperbola (Darendeli 2001, Eq. 9.4:
:func:`grainmech.analysis.empirical.masing_damping_modified`), ``b`` the scaling of the
Masing damping and ``D_min`` the small-strain damping. Past the peak of
``(G/Gmax)^0.1 D_Masing`` (at ``gamma / gamma_r`` of about 65 for ``a = 0.86``) the
damping is held at its peak, as Menq's curve and pystrata's running maximum do.

:func:`fit_hyperbola` fits ``gamma_r`` and ``a`` to a model's G/Gmax points, then ``b`` and
``D_min`` to its damping points with that ``gamma_r`` and ``a`` (both by
:func:`scipy.optimize.least_squares` with bounds), and reports each fit's residual: the
curve a site-response program then takes at every strain, with nothing held at the last
measured value.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from grainmech.analysis.empirical import masing_damping_modified, masing_damping_peak
from grainmech.errors import GrainmechError

__all__ = ["modified_hyperbola", "hyperbola_damping", "HyperbolaFit", "fit_hyperbola",
           "GAMMA_R_BOUNDS", "CURVATURE_BOUNDS", "MASING_SCALING_BOUNDS", "D_MIN_BOUNDS"]

#: bounds of the fitted reference strain [decimal] (soils: about 1e-5 ... 1e-2)
GAMMA_R_BOUNDS = (1e-7, 1.0)
#: bounds of the fitted curvature ``a`` (Darendeli's 0.919, Menq's 0.86 + 0.1 log10(p'/p_a))
CURVATURE_BOUNDS = (0.2, 3.0)
#: bounds of the fitted Masing scaling ``b`` (Darendeli's 0.63 at N = 10; Masing's rule: 1)
MASING_SCALING_BOUNDS = (0.0, 2.0)
#: bounds of the fitted small-strain damping [decimal]
D_MIN_BOUNDS = (0.0, 0.2)


def _positive(gamma: Any, name: str = "gamma") -> np.ndarray:
    g = np.asarray(gamma, dtype=float)
    if g.size and not (np.all(np.isfinite(g)) and np.all(g > 0)):
        raise GrainmechError(f"{name}: shear strains must be finite and > 0 (decimal, not percent)")
    return g


def modified_hyperbola(gamma: Any, gamma_r: float, curvature: float) -> np.ndarray:
    """``G/Gmax = 1 / (1 + (gamma/gamma_r)^a)`` (Darendeli 2001, Ch. 9; Menq 2003).

    Parameters
    ----------
    gamma : array
        Shear strain amplitudes (decimal, > 0).
    gamma_r : float
        Reference strain (decimal): ``G/Gmax = 0.5`` there.
    curvature : float
        ``a``.
    """
    g = _positive(gamma)
    return 1.0 / (1.0 + (g / float(gamma_r)) ** float(curvature))


def hyperbola_damping(gamma: Any, gamma_r: float, curvature: float, masing_scaling: float,
                      d_min: float) -> np.ndarray:
    """``D = b (G/Gmax)^0.1 D_Masing + D_min`` of the modified hyperbola (decimal).

    Darendeli (2001, Eq. 9.4 for ``D_Masing``; the form of his and Menq's 2003 damping);
    held at its peak beyond ``gamma / gamma_r`` =
    :func:`grainmech.analysis.empirical.masing_damping_peak` (``a``), as Menq's curve.
    """
    g = _positive(gamma)
    g = np.minimum(g, masing_damping_peak(curvature) * float(gamma_r))
    ratio = 1.0 / (1.0 + (g / float(gamma_r)) ** float(curvature))
    return float(masing_scaling) * ratio ** 0.1 * masing_damping_modified(g, gamma_r, curvature) + float(d_min)


@dataclass(frozen=True)
class HyperbolaFit:
    """A modified hyperbola fitted by :func:`fit_hyperbola`.

    Attributes
    ----------
    gamma_r, curvature : float
        Reference strain (decimal) and curvature ``a`` of ``G/Gmax``.
    masing_scaling, d_min : float
        ``b`` and ``D_min`` (decimal) of the damping; NaN when no damping was fitted.
    g_residual : float
        Root mean square of ``G/Gmax`` (fit - points) over the points fitted.
    g_max_error : float
        Largest ``|G/Gmax|`` difference at a point.
    damping_residual : float
        Root mean square of the damping (fit - points) [decimal]; NaN without damping.
    damping_max_error : float
        Largest damping difference at a point [decimal].
    strain_range : tuple of float
        Smallest and largest strain of the points fitted.
    n_points : int
    at_bound : list of str
        Parameters that ended on a bound (the fit is then constrained there, not free).
    """

    gamma_r: float
    curvature: float
    masing_scaling: float
    d_min: float
    g_residual: float
    g_max_error: float
    damping_residual: float
    damping_max_error: float
    strain_range: tuple
    n_points: int
    at_bound: list

    def g_ratio(self, gamma: Any) -> np.ndarray:
        """Fitted ``G/Gmax`` at ``gamma``."""
        return modified_hyperbola(gamma, self.gamma_r, self.curvature)

    def damping(self, gamma: Any) -> np.ndarray:
        """Fitted damping ratio at ``gamma`` (NaN without a damping fit)."""
        if not np.isfinite(self.masing_scaling):
            return np.full(np.shape(gamma), np.nan)
        return hyperbola_damping(gamma, self.gamma_r, self.curvature, self.masing_scaling, self.d_min)

    def as_dict(self) -> dict:
        """JSON-ready form (plain floats)."""
        return {"gamma_r": self.gamma_r, "curvature": self.curvature, "masing_scaling": self.masing_scaling,
                "d_min": self.d_min, "g_residual_rms": self.g_residual, "g_max_error": self.g_max_error,
                "damping_residual_rms": self.damping_residual, "damping_max_error": self.damping_max_error,
                "strain_range": list(self.strain_range), "n_points": self.n_points, "at_bound": list(self.at_bound)}


def _on_bound(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, names: list[str]) -> list[str]:
    out = []
    for v, a, b, n in zip(x, lo, hi, names):
        if abs(v - a) <= 1e-6 * max(abs(a), 1e-12) or abs(v - b) <= 1e-6 * max(abs(b), 1e-12):
            out.append(n)
    return out


def fit_hyperbola(gamma: Any, g_ratio: Any, damping: Any = None) -> HyperbolaFit:
    """Fit the modified hyperbola to points of ``G/Gmax`` (and damping) against strain.

    ``gamma_r`` and ``a`` by least squares on ``G/Gmax`` (residuals in ``G/Gmax``, the
    reference strain in log space, bounds :data:`GAMMA_R_BOUNDS`, :data:`CURVATURE_BOUNDS`);
    then, with them held, ``b`` and ``D_min`` by least squares on the damping (bounds
    :data:`MASING_SCALING_BOUNDS`, :data:`D_MIN_BOUNDS`; linear in both, so the minimum is
    unique).

    Parameters
    ----------
    gamma : array (n,)
        Shear strain amplitudes (decimal, > 0), n >= 2.
    g_ratio : array (n,)
        ``G/Gmax`` at them (finite).
    damping : array (n,), optional
        Damping ratios (decimal) at them; NaN entries are left out of the damping fit.

    Returns
    -------
    HyperbolaFit

    Raises
    ------
    GrainmechError
        Fewer than two points, or strains / ratios not finite.
    """
    g = _positive(gamma)
    r = np.asarray(g_ratio, dtype=float)
    ok = np.isfinite(r)
    if g.shape != r.shape:
        raise GrainmechError(f"gamma and g_ratio must have the same length (got {g.size} and {r.size})")
    if int(ok.sum()) < 2:
        raise GrainmechError(f"a modified hyperbola needs at least two finite G/Gmax points (got {int(ok.sum())})")
    g, r = g[ok], r[ok]
    damp = None if damping is None else np.asarray(damping, dtype=float)[ok]
    # start: gamma_r where the points cross 0.5 (log interpolation), else from the point nearest 0.5
    k = int(np.argmin(np.abs(r - 0.5)))
    rk = float(np.clip(r[k], 0.02, 0.98))
    gr0 = float(g[k] * ((1.0 - rk) / rk) ** (1.0 / 0.9))
    lo = np.array([np.log(GAMMA_R_BOUNDS[0]), CURVATURE_BOUNDS[0]])
    hi = np.array([np.log(GAMMA_R_BOUNDS[1]), CURVATURE_BOUNDS[1]])
    x0 = np.clip([np.log(gr0), 0.9], lo + 1e-9, hi - 1e-9)

    def res_g(x: np.ndarray) -> np.ndarray:
        return modified_hyperbola(g, float(np.exp(x[0])), float(x[1])) - r

    sol = least_squares(res_g, x0, bounds=(lo, hi), x_scale=[1.0, 0.3], xtol=1e-12, ftol=1e-12, gtol=1e-12)
    gamma_r, a = float(np.exp(sol.x[0])), float(sol.x[1])
    rg = res_g(sol.x)
    at_bound = _on_bound(sol.x, lo, hi, ["gamma_r", "curvature"])
    b = dmin = d_rms = d_max = float("nan")
    if damp is not None and int(np.isfinite(damp).sum()) >= 2:
        m = np.isfinite(damp)
        gd, dd = g[m], damp[m]
        gh = np.minimum(gd, masing_damping_peak(a) * gamma_r)
        basis = (1.0 / (1.0 + (gh / gamma_r) ** a)) ** 0.1 * masing_damping_modified(gh, gamma_r, a)
        lo_d = np.array([MASING_SCALING_BOUNDS[0], D_MIN_BOUNDS[0]])
        hi_d = np.array([MASING_SCALING_BOUNDS[1], D_MIN_BOUNDS[1]])

        def res_d(y: np.ndarray) -> np.ndarray:
            return y[0] * basis + y[1] - dd

        y0 = np.clip([0.6, max(float(dd.min()), 0.0)], lo_d, hi_d)
        sd = least_squares(res_d, y0, bounds=(lo_d, hi_d), xtol=1e-14, ftol=1e-14, gtol=1e-14)
        b, dmin = float(sd.x[0]), float(sd.x[1])
        rd = res_d(sd.x)
        d_rms, d_max = float(np.sqrt(np.mean(rd ** 2))), float(np.max(np.abs(rd)))
        at_bound += _on_bound(sd.x, lo_d, hi_d, ["masing_scaling", "d_min"])
    return HyperbolaFit(gamma_r, a, b, dmin, float(np.sqrt(np.mean(rg ** 2))), float(np.max(np.abs(rg))),
                        d_rms, d_max, (float(g.min()), float(g.max())), int(g.size), at_bound)

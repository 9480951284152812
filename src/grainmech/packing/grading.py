"""Grain-size distributions the way a laboratory reports them, and how they are sampled.

Three forms (all diameters in metres):

* :class:`SieveCurve` - sieve sizes with the percent passing (by mass, ASTM D6913 /
  ISO 17892-4), increasing in both;
* :class:`D50Cu` - median size ``D50`` and coefficient of uniformity ``Cu = D60/D10``,
  read as a log-normal mass distribution (``ln D ~ N(ln D50, s)`` with
  ``s = ln Cu / (z_0.6 - z_0.1)``, ``z_q`` the standard normal quantile);
* :class:`UniformRadius` - one radius with a uniform spread (number-based):
  ``R ~ U(R (1 - w), R (1 + w))``.

Measuring. :func:`measured_grading` reads the grading of a set of grains back the way a
sieve analysis would: ``D10``, ``D50``, ``D60`` by mass (volume, ``~ D^3``) and
``Cu = D60 / D10``.

Sampling. A sieve curve and D50-Cu give *mass* fractions. A grain of diameter ``D``
carries mass ``~ D^3``, so the *number* density is the mass density times ``D^-3``.
:meth:`GradingBase.sample` draws ``n`` diameters from the mass curve (inverse CDF,
linear in ``log D`` between sieve sizes), then resamples them with weights ``D^-3``
(importance resampling from a pool of ``pool`` times ``n`` draws), which gives a number
sample whose mass curve is the lab curve.

Truncation. A periodic cell of a few thousand grains cannot hold fines 100 times smaller
than its largest grains (there would be millions of them, and they mostly sit loose in
the pores as rattlers). Every distribution is cut at ``D_min = D_max / max_ratio``
(default ``max_ratio = 4``) and at the top at the curve's ``D_max`` (a sieve curve) or
its 99.9 % mass quantile (D50-Cu): grains below ``D_min`` are not represented. The cut
mass fraction is returned (:attr:`Sample.cut_fines`, :attr:`Sample.cut_coarse`); the
packing then stands for the sand with its fines removed (the fines' contribution to
stiffness through the force network is small while they are rattlers, but the void ratio
of the real sand is lower than the packing's by the volume of the fines).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from grainmech.errors import ParameterError

__all__ = ["SieveCurve", "D50Cu", "UniformRadius", "Sample", "GradingBase", "MeasuredGrading",
           "measured_grading"]

#: standard normal quantiles for D60 and D10
_Z60, _Z10 = float(norm.ppf(0.6)), float(norm.ppf(0.1))


@dataclass(frozen=True)
class Sample:
    """Sampled grain radii and what was cut from the distribution.

    Attributes
    ----------
    radii : array (n,)
        Grain radii [m].
    d_min, d_max : float
        Diameters kept [m].
    cut_fines, cut_coarse : float
        Mass fractions of the distribution below ``d_min`` and above ``d_max``.
    """

    radii: np.ndarray
    d_min: float
    d_max: float
    cut_fines: float
    cut_coarse: float


class GradingBase:
    """Common sampling of mass-based distributions (see module notes)."""

    def mass_cdf(self, d: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """Mass fraction finer than diameter ``d`` [m] (0-1), same shape."""
        raise NotImplementedError

    def mass_quantile(self, q: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """Diameter [m] at mass fraction ``q`` (0-1) finer; inverse of :meth:`mass_cdf`."""
        raise NotImplementedError

    def upper(self) -> float:  # pragma: no cover - abstract
        """Largest diameter [m] of the distribution (a high quantile for open-ended ones)."""
        raise NotImplementedError

    def sample(self, n: int, rng: np.random.Generator, *, max_ratio: float = 4.0,
               pool: int = 20) -> Sample:
        """``n`` radii [m] drawn from this mass curve.

        ``n`` radii with the number distribution of this mass curve, truncated to
        ``[D_max / max_ratio, D_max]`` (module notes).
        """
        if n < 1:
            raise ValueError(f"n = {n}: need at least one grain")
        if not max_ratio > 1:
            raise ValueError(f"max_ratio = {max_ratio}: must be > 1")
        d_max = self.upper()
        d_min = max(d_max / max_ratio, float(self.mass_quantile(np.array([0.0]))[0]))
        f_lo, f_hi = (float(v) for v in self.mass_cdf(np.array([d_min, d_max])))
        if f_hi - f_lo <= 0:
            raise ValueError("the grading curve holds no mass between D_max/max_ratio and D_max")
        q = rng.uniform(f_lo, f_hi, pool * n)
        d = self.mass_quantile(q)
        w = d ** -3.0
        pick = rng.choice(d.size, size=n, replace=True, p=w / w.sum())
        return Sample(0.5 * d[pick], d_min, d_max, f_lo, 1.0 - f_hi)


class SieveCurve(GradingBase):
    """Sieve sizes [m] and percent passing by mass (0-100), both increasing.

    The curve is linear in ``log D`` between sieves (the usual semi-log plot). The first
    percent passing must be 0 and the last 100 (the range of sizes present); a curve
    that is not is not extended by guessing: a ParameterError names the key.
    """

    def __init__(self, sizes: Sequence[float], passing: Sequence[float], *, key: str = "grading") -> None:
        d = np.asarray(sizes, float)
        p = np.asarray(passing, float)
        if d.ndim != 1 or d.size < 2 or d.shape != p.shape:
            raise ParameterError(f"{key}.sizes", list(sizes), "sizes and passing need the same length >= 2")
        if not np.all(d > 0):
            raise ParameterError(f"{key}.sizes", list(sizes), "sizes must be positive")
        if np.any(np.diff(d) <= 0):
            raise ParameterError(f"{key}.sizes", list(sizes), "sieve sizes must increase")
        if np.any(np.diff(p) < 0) or p[-1] <= p[0]:
            raise ParameterError(f"{key}.passing", list(passing), "percent passing must increase with size")
        if abs(p[0]) > 1e-9 or abs(p[-1] - 100) > 1e-9:
            raise ParameterError(f"{key}.passing", list(passing),
                              "must start at 0 and end at 100 (percent passing at the smallest and "
                              "largest size present)")
        self.sizes, self.passing = d, p / 100.0

    def mass_cdf(self, d: np.ndarray) -> np.ndarray:
        """Mass fraction finer than ``d`` [m], linear in ``log d`` between sieves."""
        return np.interp(np.log(d), np.log(self.sizes), self.passing)

    def mass_quantile(self, q: np.ndarray) -> np.ndarray:
        # strictly increasing part only (flat steps carry no mass)
        """Diameter [m] at mass fraction ``q`` finer (log-linear between sieves, flat steps skipped)."""
        keep = np.concatenate([[True], np.diff(self.passing) > 0])
        return np.exp(np.interp(q, self.passing[keep], np.log(self.sizes[keep])))

    def upper(self) -> float:
        """Largest sieve size [m]."""
        return float(self.sizes[-1])


class D50Cu(GradingBase):
    """Log-normal mass distribution from ``d50`` and the coefficient of uniformity.

    Median diameter ``d50`` [m] and coefficient of uniformity ``cu = D60/D10 >= 1``
    as a log-normal mass distribution (module notes); ``cu = 1`` is one size.
    """

    def __init__(self, d50: float, cu: float, *, key: str = "grading") -> None:
        if not d50 > 0:
            raise ParameterError(f"{key}.d50", d50, "must be > 0")
        if not cu >= 1:
            raise ParameterError(f"{key}.cu", cu, "the coefficient of uniformity D60/D10 must be >= 1")
        self.d50, self.cu = float(d50), float(cu)
        self.s = float(np.log(cu) / (_Z60 - _Z10))

    def mass_cdf(self, d: np.ndarray) -> np.ndarray:
        """Mass fraction finer than ``d`` [m] of the log-normal mass distribution (a step for ``cu = 1``)."""
        if self.s == 0:
            return (np.asarray(d) >= self.d50).astype(float)
        return norm.cdf((np.log(d) - np.log(self.d50)) / self.s)

    def mass_quantile(self, q: np.ndarray) -> np.ndarray:
        """Diameter [m] at mass fraction ``q`` finer (log-normal quantile; ``d50`` for ``cu = 1``)."""
        if self.s == 0:
            return np.full(np.shape(q), self.d50)
        return self.d50 * np.exp(self.s * norm.ppf(np.clip(q, 1e-12, 1 - 1e-12)))

    def upper(self) -> float:
        """The 99.9 % mass quantile [m] (the log-normal has no largest size)."""
        return float(self.mass_quantile(np.array([0.999]))[0])

    def sample(self, n: int, rng: np.random.Generator, *, max_ratio: float = 4.0, pool: int = 20) -> Sample:
        """``n`` radii [m] (one size for ``cu = 1``, else :meth:`GradingBase.sample`)."""
        if self.s == 0:
            return Sample(np.full(n, 0.5 * self.d50), self.d50, self.d50, 0.0, 0.0)
        return super().sample(n, rng, max_ratio=max_ratio, pool=pool)


class UniformRadius:
    """Radii with a uniform spread about ``radius``.

    Radius ``radius`` [m] with a uniform spread ``spread`` in ``[0, 1)``: ``R`` uniform
    (by number) in ``[radius (1 - spread), radius (1 + spread)]``; nothing is cut.
    """

    def __init__(self, radius: float, spread: float = 0.0, *, key: str = "grading") -> None:
        if not radius > 0:
            raise ParameterError(f"{key}.radius", radius, "must be > 0")
        if not 0 <= spread < 1:
            raise ParameterError(f"{key}.spread", spread, "must lie in [0, 1)")
        self.radius, self.spread = float(radius), float(spread)

    def sample(self, n: int, rng: np.random.Generator, *, max_ratio: float = 4.0, pool: int = 20) -> Sample:
        """``n`` radii [m], uniform by number in ``[radius (1 - spread), radius (1 + spread)]``."""
        lo, hi = self.radius * (1 - self.spread), self.radius * (1 + self.spread)
        r = rng.uniform(lo, hi, n) if self.spread > 0 else np.full(n, self.radius)
        return Sample(r, 2 * lo, 2 * hi, 0.0, 0.0)


@dataclass(frozen=True)
class MeasuredGrading:
    """The grading of a set of grains by mass (see :func:`measured_grading`).

    Attributes
    ----------
    d10, d50, d60 : float
        Diameters [m] with 10, 50 and 60 % of the grains' mass finer.
    cu : float
        Coefficient of uniformity ``D60 / D10`` (1 for grains of one size).
    n_grains : int
        Grains measured.
    """

    d10: float
    d50: float
    d60: float
    cu: float
    n_grains: int


def measured_grading(radii: Sequence[float] | np.ndarray) -> MeasuredGrading:
    """``D10``, ``D50``, ``D60`` and ``Cu = D60 / D10`` of grains by mass, as a sieve analysis gives them.

    Each grain of diameter ``D = 2 R`` carries mass ``~ D^3`` (one grain density). The
    grains sorted by size form a mass curve: the mass fraction finer than grain ``i`` is
    taken at the middle of its own mass, ``(M_{<i} + m_i / 2) / M``, and the curve is
    linear in ``log D`` between grains (the semi-log plot of a sieve curve; sizes beyond
    the first and last grain's points are those grains' sizes). Every grain counts,
    rattlers too: a sieve weighs them all.

    Parameters
    ----------
    radii : array (n,)
        Grain radii [m] (> 0, finite; n >= 1).

    Returns
    -------
    MeasuredGrading
        Example: the shipped packing 'dense' (2000 grains drawn from ``D50 = 0.3 mm``,
        ``Cu = 1.3``, sizes cut to a ratio of 2.5) gives ``D50 = 0.298 mm``,
        ``Cu = 1.28``.
    """
    r = np.asarray(radii, dtype=float).ravel()
    if r.size == 0 or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise ParameterError("radii", f"{r.size} values", "need at least one grain, every radius finite and > 0")
    d = np.sort(2.0 * r)
    m = d ** 3
    frac = (np.cumsum(m) - 0.5 * m) / m.sum()
    logd = np.log(d)
    d10, d50, d60 = (float(np.exp(np.interp(q, frac, logd))) for q in (0.1, 0.5, 0.6))
    return MeasuredGrading(d10, d50, d60, d60 / d10, int(d.size))

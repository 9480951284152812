"""Behaviour shared by the 3D (spherical-harmonic) and 2D (Fourier) densities (private).

A subclass stores its coefficients and implements

* ``_normalised(n)``  -> ``|S| xi(n)`` at validated unit normals (..., d)
  (``|S| = 4 pi`` or ``2 pi``; equals 1 for the isotropic density),
* ``_degree_part(n, k)`` -> the degree-``k`` harmonic part of ``|S| xi``,
* ``_coefficients_from_values(points, weights, values)`` -> constructor keywords of the
  projection of a function ``values = |S| f(points)`` sampled on a rule exact for the
  needed degree,
* class attribute ``dim``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, ClassVar, Self

import numpy as np
from scipy.optimize import minimize, minimize_scalar
from scipy.spatial import SphericalVoronoi

from grainmech.conventions import seed_angles, seed_theta
from grainmech.errors import NegativeDensityError, ParameterError
from grainmech.fabric import _checks
from grainmech.fabric import tensors as _t
from grainmech.fabric.quadrature import unit_rule

#: A density whose normalised value ``|S| xi`` is below ``-NEGATIVE_TOL`` somewhere is
#: rejected as negative (``|S| xi = 1`` for the isotropic density).
NEGATIVE_TOL = 1e-10


@dataclass(frozen=True)
class DensityExtremum:
    """Location and value of the minimum (or maximum) of a density over directions.

    Attributes
    ----------
    value : float
        ``xi`` at the extremum, 1/sr (3D) or 1/rad (2D).
    normalised : float
        ``|S| xi`` there (1 for the isotropic density; negative means invalid).
    normal : ndarray, shape (d,)
        Direction in library components (the antipode has the same value).
    seed_angles : tuple of float
        ``(gamma, beta)`` in 3D (seed Eq. 2.19) or ``(theta,)`` in 2D (Eq. 4.35), radians.
    """

    value: float
    normalised: float
    normal: np.ndarray
    seed_angles: tuple[float, ...]

    def describe(self) -> str:
        """One-line human readable description (used in error messages)."""
        comp = ", ".join(f"{c:.6g}" for c in self.normal)
        names = "(x, y, z)" if len(self.normal) == 3 else "(x, y)"
        if len(self.seed_angles) == 2:
            ang = (f"seed angles gamma = {np.degrees(self.seed_angles[0]):.4g} deg, "
                   f"beta = {np.degrees(self.seed_angles[1]):.4g} deg")
        else:
            ang = f"seed angle theta = {np.degrees(self.seed_angles[0]):.4g} deg"
        return (f"xi = {self.value:.6g} (|S| xi = {self.normalised:.6g}) at n{names} = "
                f"({comp}), {ang}")


def _fibonacci_hemisphere(p: int) -> np.ndarray:
    i = np.arange(p)
    z = (i + 0.5) / p
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


@lru_cache(maxsize=8)
def _covered_grid(dim: int, order: int) -> tuple[np.ndarray, float]:
    """The extremum-search grid and its covering radius [rad].

    Every direction (or its antipode) lies within the returned angle of a grid point.
    3D: the Fibonacci half-sphere grid of :meth:`DensityBase._extremum`; the covering
    radius of the grid and its antipodes is the largest vertex-to-generator angle of their
    spherical Voronoi diagram.  2D: ``N`` equally spaced angles on the half circle, radius
    ``pi / (2 N)``.
    """
    L = max(order, 2)
    if dim == 3:

        grid = _fibonacci_hemisphere(max(2000, 40 * (L + 1) ** 2))
        pts = np.vstack([grid, -grid])
        sv = SphericalVoronoi(pts)
        cover = max(float(np.max(sv.vertices[reg] @ pts[i] * -1.0 + 1.0))
                    for i, reg in enumerate(sv.regions))  # 1 - cos(angle)
        radius = float(np.arccos(1.0 - cover))
    else:
        t = np.linspace(0.0, np.pi, max(720, 60 * L), endpoint=False)
        grid = np.stack([np.sin(t), np.cos(t)], axis=-1)
        radius = np.pi / (2 * len(t))
    grid.setflags(write=False)
    return grid, radius


@dataclass(frozen=True, eq=False)
class DensityBase:
    """Common API of :class:`SphericalDensity` and :class:`FourierDensity`."""

    dim: ClassVar[int] = 0
    #: expansion order (a dataclass field of each subclass)
    order: int

    # ---- hooks (subclasses also define the dataclass field ``order: int``) -----------
    def _normalised(self, n: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _anisotropy_bound(self) -> float:
        """An upper bound of ``max |(|S| xi) - 1|`` from the coefficients alone."""
        return np.inf

    def _degree_part(self, n: np.ndarray, k: int) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    @classmethod
    def _coefficients_from_values(cls, pts: np.ndarray, w: np.ndarray, values: np.ndarray,
                                  order: int) -> dict[str, Any]:  # pragma: no cover
        raise NotImplementedError

    # ---- basic -------------------------------------------------------------------
    @property
    def measure(self) -> float:
        """``|S|``: 4 pi (sphere) or 2 pi (circle)."""
        return 4.0 * np.pi if self.dim == 3 else 2.0 * np.pi

    def _validate_after_init(self) -> None:
        if not getattr(self, "allow_negative", False):
            self.check_nonnegative()

    def __call__(self, normals: object) -> np.ndarray:
        """Density ``xi(n)`` at unit normals.

        Parameters
        ----------
        normals : array_like, shape (..., d)
            Unit vectors in library components.

        Returns
        -------
        ndarray, shape (...)
            ``xi`` in 1/sr (3D, integrates to 1 over ``dOmega``) or 1/rad (2D).
        """
        n = _checks.as_normals(normals, self.dim)
        return self._normalised(n) / self.measure

    # ---- quadrature ----------------------------------------------------------------
    def directions(self, extra_degree: int = 4) -> tuple[np.ndarray, np.ndarray]:
        """Quadrature directions weighted by the density.

        ``sum_k weights[k] f(normals[k]) = integral f(n) xi(n) dOmega`` exactly for every
        polynomial ``f`` in the components of ``n`` of degree ``<= extra_degree``
        (seed Eq. 2.41 with ``f`` the contact-stiffness integrand: degree 4 for a linear
        contact law).  ``weights = w_q * |S| * xi(n_q)`` with ``w_q`` the rule's weights
        (summing to 1), so ``sum(weights) = 1`` (Eq. 4.8) up to round-off.

        Parameters
        ----------
        extra_degree : int, default 4
            Polynomial degree of the integrand apart from the density.

        Returns
        -------
        normals : ndarray, shape (k, d)
            Unit vectors (Lebedev points in 3D, uniform points on the circle in 2D).
        weights : ndarray, shape (k,)
            Non-negative for a valid density (the Lebedev rules used have positive
            weights); may be negative only for a density built with
            ``allow_negative=True``.
        """
        extra = _checks.as_int(extra_degree, "extra_degree", 0)
        cache = self.__dict__.setdefault("_directions_cache", {})
        if extra not in cache:
            pts, w = unit_rule(self.dim, self.order + extra)
            cache[extra] = (np.array(pts), w * self._normalised(pts))
        pts, wts = cache[extra]
        return pts.copy(), wts.copy()

    def fabric_tensor(self, rank: int = 2) -> np.ndarray:
        """Fabric tensor ``N = integral n^(x)rank xi dOmega`` (seed Eq. 4.6), exact.

        Returns
        -------
        ndarray, shape (d,) * rank
        """
        rank = _checks.as_int(rank, "rank", 0)
        if rank > _t.MAX_RANK:
            raise ParameterError("rank", rank, f"rank above {_t.MAX_RANK} not supported")
        pts, wts = self.directions(rank)
        return (wts @ _t.outer_power(pts, rank)).reshape((self.dim,) * rank)

    def coefficient_tensors(self) -> dict[int, np.ndarray]:
        """Kanatani's traceless coefficient tensors ``{k: phi_(k)}`` (seed Eq. 4.10).

        ``xi(n) = (1/|S|)[1 + sum_k phi_(k) . n^k]`` for ``k = 2, 4, ..., order``.
        ``phi_(k) = F_k * mean_n[h_k(n) n^(x)k]`` with ``h_k`` the degree-``k`` part of
        ``|S| xi`` (see :mod:`grainmech.fabric.tensors`).
        """
        out: dict[int, np.ndarray] = {}
        for k in range(2, self.order + 1, 2):
            pts, w = unit_rule(self.dim, 2 * k)
            h = self._degree_part(pts, k)
            out[k] = (_t.kanatani_factor(k, self.dim) * ((w * h) @ _t.outer_power(pts, k))
                      ).reshape((self.dim,) * k)
        return out

    # ---- constructors shared by both dimensions --------------------------------------
    @classmethod
    def _project(cls, func: Callable[[np.ndarray], np.ndarray], order: int, degree: int,
                 allow_negative: bool) -> Self:
        pts, w = unit_rule(cls.dim, order + degree)
        vals = np.asarray(func(np.array(pts)), dtype=float)
        kw = cls._coefficients_from_values(pts, w, vals, order)
        # cls is one of the dataclass subclasses, whose fields these are
        return cls(order=order, allow_negative=allow_negative, **kw)  # type: ignore[call-arg]

    @classmethod
    def isotropic(cls, order: int = 0) -> Self:
        """The uniform density ``1/|S|`` (all coefficients zero)."""
        order = _checks.as_even_order(order)
        return cls._project(lambda p: np.ones(len(p)), order, 0, False)

    @classmethod
    def from_coefficient_tensors(cls, phis: Mapping[int, object],
                                 allow_negative: bool = False, tol: float = 1e-8) -> Self:
        """Density ``(1/|S|)[1 + sum_k phi_(k) . n^k]`` (seed Eq. 4.10, 4.16, 4.35).

        Parameters
        ----------
        phis : mapping {int: array}
            Traceless symmetric tensors keyed by even rank ``k >= 2``; the order of the
            density is the largest rank.  Non-traceless input is refused (the trace
            would change the normalisation and the lower orders).
        """
        ph, d = _t._check_phis(phis, cls.dim, tol)
        if d != cls.dim:
            raise ParameterError("phis", f"{d}D tensors", f"{cls.__name__} needs {cls.dim}D tensors")
        order = max(ph, default=0)

        def f(p: np.ndarray) -> np.ndarray:
            return 1.0 + sum((_t.contract_normals(A, p) for A in ph.values()), np.zeros(len(p)))

        return cls._project(f, order, order, allow_negative)

    @classmethod
    def from_fabric_tensor(cls, N: object, allow_negative: bool = False,
                           tol: float = 1e-8) -> Self:
        """Density of order ``L`` with the given rank-``L`` fabric tensor (seed Eq. 4.11).

        ``N`` fixes all lower fabric tensors by traces, hence all ``phi_(k)`` for
        ``k <= L`` (:func:`grainmech.fabric.tensors.phi_from_fabric`).  The density
        returned has exactly the fabric tensors ``N`` and its traces.
        """
        A = _t._check_tensor(N, "N", cls.dim)
        return cls.from_coefficient_tensors(_t.phi_from_fabric(A, tol), allow_negative)

    @classmethod
    def from_function(cls, func: Callable[[np.ndarray], np.ndarray], order: int,
                      degree: int | None = None, normalise: bool = False,
                      allow_negative: bool = False) -> Self:
        """Project a function of the normal onto the harmonics up to ``order``.

        Parameters
        ----------
        func : callable
            ``func(normals (k, d)) -> (k,)`` values of a density (1/sr or 1/rad).
        order : int
            Even expansion order of the result.
        degree : int, optional
            Polynomial degree of ``func`` (the projection is exact if ``func`` is a
            polynomial of at most this degree).  Default ``order``.
        normalise : bool
            Divide by the integral of ``func`` first; otherwise the integral must be 1.
        """
        order = _checks.as_even_order(order)
        deg = order if degree is None else _checks.as_int(degree, "degree", 0)
        pts, w = unit_rule(cls.dim, order + deg)
        vals = _checks.as_finite_array(func(np.array(pts)), "func(normals)")
        if vals.shape != (len(w),):
            raise ParameterError("func(normals)", f"array of shape {vals.shape}",
                              f"must return one value per normal, shape ({len(w)},)")
        total = 4.0 * np.pi if cls.dim == 3 else 2.0 * np.pi
        integral = total * float(w @ vals)
        if normalise:
            if not integral > 0:
                raise ParameterError("func", integral, "integral must be positive to normalise")
            vals = vals / integral
        elif abs(integral - 1.0) > 1e-8:
            raise ParameterError("func", f"integral {integral:.12g}",
                              "a density must integrate to 1 (seed Eq. 4.8); pass normalise=True")
        return cls._project(lambda p: total * np.asarray(func(p), dtype=float)
                            / (integral if normalise else 1.0), order, deg, allow_negative)

    # ---- transformations ---------------------------------------------------------------
    def rotated(self, R: object) -> Self:
        """Density of the rotated normals ``n' = R n``: ``xi'(n') = xi(R^T n')``.

        Exact: ``xi o R^T`` is again a polynomial of degree ``order``, projected with a
        rule of degree ``2 * order``.  ``R`` may be any orthogonal matrix (a reflection
        too).  The fabric tensors transform as ``N' = R..R N`` (seed Eq. 2.28).
        """
        Rm = _checks.as_rotation(R, self.dim)
        return self._project(lambda p: self._normalised(p @ Rm), self.order, self.order,
                             bool(getattr(self, "allow_negative", False)))

    def shrunk(self, factor: float) -> Self:
        """``(1/|S|)[1 + factor (|S| xi - 1)]``: scale all anisotropic coefficients."""
        f = _checks.as_scalar(factor, "factor")
        return self._project(lambda p: 1.0 + f * (self._normalised(p) - 1.0), self.order,
                             self.order, bool(getattr(self, "allow_negative", False)))

    # ---- extrema and validity ---------------------------------------------------------
    def _extremum(self, sign: float) -> DensityExtremum:
        """Robust search for min (sign=+1) or max (sign=-1) of |S| xi."""
        L = max(self.order, 2)
        if self.dim == 3:
            grid = _fibonacci_hemisphere(max(2000, 40 * (L + 1) ** 2))
        else:
            t = np.linspace(0.0, np.pi, max(720, 60 * L), endpoint=False)
            grid = np.stack([np.sin(t), np.cos(t)], axis=-1)
        vals = sign * self._normalised(grid)
        # the refinements minimise values divided by the grid's largest magnitude: scale
        # free, so that huge coefficients (a config value of 5e153) do not overflow the
        # BFGS search's gradient norms (the density is linear in its coefficients)
        fscale = float(np.max(np.abs(vals))) if np.all(np.isfinite(vals)) else 1.0
        fscale = fscale if fscale > 0.0 else 1.0
        order_idx = np.argsort(vals)
        spacing = np.sqrt(2 * np.pi / len(grid)) if self.dim == 3 else np.pi / len(grid)
        cands: list[np.ndarray] = []
        for i in order_idx:
            p = grid[i]
            if all(abs(float(p @ c)) < np.cos(4 * spacing) for c in cands):
                cands.append(p)
            if len(cands) >= 6:
                break
        best_val, best_n = np.inf, grid[order_idx[0]]
        for c in cands:
            if self.dim == 3:
                a = np.array([1.0, 0.0, 0.0]) if abs(c[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
                t1 = np.cross(c, a)
                t1 /= np.linalg.norm(t1)
                t2 = np.cross(c, t1)

                def to_n(u: np.ndarray, c=c, t1=t1, t2=t2) -> np.ndarray:
                    v = c + u[0] * t1 + u[1] * t2
                    return v / np.linalg.norm(v)

                res = minimize(lambda u: float(sign * self._normalised(to_n(u)[None])[0]) / fscale,
                               np.zeros(2), method="BFGS", options={"gtol": 1e-12})
                n_opt = to_n(res.x)
                v = float(sign * self._normalised(n_opt[None])[0])
            else:
                th0 = float(seed_theta(c))

                def g(th: float) -> float:
                    return float(sign * self._normalised(np.array([[np.sin(th), np.cos(th)]]))[0])

                res = minimize_scalar(lambda th: g(th) / fscale, bounds=(th0 - 3 * spacing, th0 + 3 * spacing),
                                      method="bounded", options={"xatol": 1e-12})
                n_opt = np.array([np.sin(res.x), np.cos(res.x)])
                v = float(g(res.x))
            if v < best_val:
                best_val, best_n = v, n_opt
        # canonical representative of the antipodal pair: gamma <= 90 deg (beta < 180 deg
        # on the equator) / theta < 180 deg
        if self.dim == 3:
            if abs(best_n[2]) > 1e-7:
                if best_n[2] < 0:
                    best_n = -best_n
            elif best_n[0] < -1e-7 or (abs(best_n[0]) <= 1e-7 and best_n[1] < 0):
                best_n = -best_n        # on the equator: beta in [0, 180 deg)
        if self.dim == 2 and seed_theta(best_n) >= np.pi:
            best_n = -best_n
        value = sign * best_val
        if self.dim == 3:
            g_, b_ = seed_angles(best_n)
            ang: tuple[float, ...] = (float(g_), float(b_))
        else:
            ang = (float(seed_theta(best_n)),)
        return DensityExtremum(value=value / self.measure, normalised=value,
                               normal=best_n, seed_angles=ang)

    def minimum(self) -> DensityExtremum:
        """Smallest value of ``xi`` over all directions (dense grid + BFGS refinement).

        The grid has ``max(2000, 40 (L+1)^2)`` points on the half sphere (``max(720, 60 L)``
        on the half circle); the six lowest well-separated grid points are refined with
        :func:`scipy.optimize.minimize` (BFGS in tangent-plane coordinates) or
        :func:`scipy.optimize.minimize_scalar`.
        """
        return self._extremum(1.0)

    def maximum(self) -> DensityExtremum:
        """Largest value of ``xi`` over all directions (same search as :meth:`minimum`)."""
        return self._extremum(-1.0)

    def check_nonnegative(self) -> None:
        """Raise :class:`NegativeDensityError` if ``xi < 0`` somewhere (beyond round-off).

        The message gives the minimum value, the direction and the seed's angles, or,
        for a coefficient that no non-negative density can have
        (:meth:`_impossible_coefficient`), that coefficient and its bound.
        """
        bad = self._impossible_coefficient()
        if bad is not None:
            raise NegativeDensityError(
                f"{type(self).__name__} of order {self.order} is negative somewhere: {bad}. Reduce the "
                f"anisotropy coefficients, or pass allow_negative=True to keep it anyway.")
        if self._certainly_positive():
            return
        m = self.minimum()
        if m.normalised < -NEGATIVE_TOL:
            raise NegativeDensityError(
                f"{type(self).__name__} of order {self.order} is negative: minimum "
                f"{m.describe()}. Reduce the anisotropy coefficients, or pass "
                f"allow_negative=True to keep it anyway.")

    @property
    def is_nonnegative(self) -> bool:
        """True if ``xi >= 0`` everywhere (to round-off)."""
        if self._impossible_coefficient() is not None:
            return False
        return self._certainly_positive() or self.minimum().normalised >= -NEGATIVE_TOL

    def _impossible_coefficient(self) -> str | None:
        """A coefficient larger than any non-negative density of unit mean allows (its description), or None.

        Each coefficient is the mean of a bounded function over the density, so it is
        bounded by that function's maximum (the subclasses say which). Checked before any
        evaluation: coefficients of 1e154 and more overflow the grid values.
        """
        return None

    def _certainly_positive(self) -> bool:
        """True when ``xi > 0`` everywhere is proven without a refined minimum search.

        First by the coefficient bound (:meth:`_anisotropy_bound` below 1), else from the
        grid values:
        ``|S| xi`` is a polynomial of degree ``L`` on the sphere (trigonometric of degree
        ``L`` on the circle); along any great circle it is a trigonometric polynomial of
        degree ``<= L``, so Bernstein's inequality bounds its slope by ``L max|f|``.  With
        the grid's covering radius ``h`` (:func:`_covered_grid`),
        ``max|f| <= max_grid|f| / (1 - L h)`` and ``f >= min_grid f - L h max|f|``.
        """
        L = int(self.order)
        if L == 0 or self._anisotropy_bound() < 1.0:
            return True
        grid, h = _covered_grid(self.dim, L)
        if L * h >= 0.5:
            return False
        vals = self._normalised(grid)
        bound = float(np.max(np.abs(vals))) / (1.0 - L * h)
        return float(np.min(vals)) - L * h * bound > 0.0

    # ---- sampling -----------------------------------------------------------------------
    def sample(self, size: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """Random unit normals distributed with density ``xi`` (rejection sampling).

        Parameters
        ----------
        size : int
            Number of normals.
        rng : numpy Generator or seed, optional

        Returns
        -------
        ndarray, shape (size, d)
        """
        size = _checks.as_int(size, "size", 0)
        if not self.is_nonnegative:
            raise NegativeDensityError("cannot sample a density that is negative somewhere")
        gen = np.random.default_rng(rng)
        bound = self.maximum().normalised * (1.0 + 1e-9) + 1e-12
        out: list[np.ndarray] = []
        have = 0
        while have < size:
            m = max(1024, int(1.2 * (size - have) * bound))
            if self.dim == 3:
                v = gen.normal(size=(m, 3))
                v /= np.linalg.norm(v, axis=1, keepdims=True)
            else:
                t = gen.uniform(0.0, 2 * np.pi, m)
                v = np.stack([np.sin(t), np.cos(t)], axis=-1)
            keep = gen.uniform(0.0, bound, m) < self._normalised(v)
            out.append(v[keep])
            have += int(keep.sum())
        return np.concatenate(out)[:size]

    def anisotropy(self) -> _t.Anisotropy:
        """Anisotropy measures of the second-order fabric tensor (see :func:`anisotropy`)."""
        return _t.anisotropy(self.fabric_tensor(2))

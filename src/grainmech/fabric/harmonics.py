r"""3D contact-normal density as an even real spherical-harmonic expansion (seed Eq. 4.7).

The seed writes (Eq. 4.7, with the seed's angles of Eq. 2.19: polar angle ``gamma`` from z,
azimuth ``beta`` from y towards x)::

    xi(gamma, beta) = (1/4 pi) [ 1 + sum'_{k=2,4,..} { a_k0 P_k(cos gamma)
                      + sum_{m=1..k} P_k^m(cos gamma) (a_km cos m beta + b_km sin m beta) } ]

with the *unnormalised* associated Legendre functions of Rodrigues' formula (Eq. 4.13),
which carry **no** Condon-Shortley phase: ``P_2^2(cos gamma) = 3 sin^2 gamma`` (Eq. 4.14).

Internally :class:`SphericalDensity` stores the coefficients on the orthonormal real
harmonics ``Y_km`` of :mod:`grainmech.fabric._basis` (same angles, same sign convention)::

    xi(n) = 1/(4 pi) + sum_{k=2,4..L} sum_{m=-k..k} c_km Y_km(n),   c_km = integral xi Y_km dOmega

so ``c_km = E[Y_km(n)]`` is simply the mean of ``Y_km`` over the contact normals (the
basis of the moment estimator in :mod:`grainmech.fabric.fit`).  The conversion to the
seed's coefficients is, with ``N_km = sqrt((2k+1)/(4 pi) (k-m)!/(k+m)!)``::

    a_k0 = 4 pi N_k0 c_k0,   a_km = 4 pi sqrt(2) N_km c_km,   b_km = 4 pi sqrt(2) N_km c_k,-m

The coefficient vector is ordered by degree ``k = 2, 4, ..., L`` and, within a degree,
``m = -k, ..., k`` (:func:`sh_index`); it has ``(L + 1)(L + 2)/2 - 1`` entries.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from grainmech.errors import ParameterError
from grainmech.fabric import _checks
from grainmech.fabric._base import DensityBase
from grainmech.fabric._basis import real_sh, seed_factor, sh_index_arrays

__all__ = ["SphericalDensity", "sh_index", "sh_degrees_orders", "n_coefficients_3d"]


def n_coefficients_3d(order: int) -> int:
    """Number of anisotropic coefficients of an even order-``L`` expansion: (L+1)(L+2)/2 - 1."""
    L = _checks.as_even_order(order)
    return (L + 1) * (L + 2) // 2 - 1


def sh_index(k: int, m: int) -> int:
    """Position of ``c_km`` in :attr:`SphericalDensity.coefficients` (k even >= 2, |m| <= k)."""
    k = _checks.as_even_order(k, "k")
    m = _checks.as_int(m, "m")
    if k < 2 or abs(m) > k:
        raise ParameterError("(k, m)", (k, m), "need even k >= 2 and |m| <= k")
    return n_coefficients_3d(k - 2) + (m + k)


def sh_degrees_orders(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Arrays ``(k, m)`` labelling the coefficient vector of an order-``L`` density."""
    L = _checks.as_even_order(order)
    return sh_index_arrays(range(2, L + 1, 2))


@dataclass(frozen=True, eq=False)
class SphericalDensity(DensityBase):
    """Centrosymmetric density of contact normals on the unit sphere (seed Eq. 4.7, 4.8).

    Parameters
    ----------
    order : int
        Even expansion order ``L`` (0 = isotropic).
    coefficients : array_like, shape ((L+1)(L+2)/2 - 1,)
        Orthonormal real-SH coefficients ``c_km = integral xi Y_km dOmega`` (1/sr), ordered
        as :func:`sh_degrees_orders`.  Usually built with a ``from_*`` constructor.
    allow_negative : bool, default False
        If False, a density that is negative in some direction raises
        :class:`~grainmech.errors.NegativeDensityError` (message gives the minimum value,
        the direction and the seed angles).

    Notes
    -----
    ``integral xi dOmega = 1`` holds by construction (Eq. 4.8).  Frozen; the coefficient
    array is read-only.
    """

    order: int
    coefficients: np.ndarray
    allow_negative: bool = False

    dim = 3
    _ks: np.ndarray = field(init=False, repr=False, compare=False)  # degree of each coefficient
    _ms: np.ndarray = field(init=False, repr=False, compare=False)  # order of each coefficient

    def __post_init__(self) -> None:
        L = _checks.as_even_order(self.order)
        c = _checks.as_finite_array(self.coefficients, "coefficients").reshape(-1).copy()
        if c.shape != (n_coefficients_3d(L),):
            raise ParameterError("coefficients", f"array of shape {np.shape(self.coefficients)}",
                              f"order {L} needs {n_coefficients_3d(L)} coefficients")
        c.setflags(write=False)
        object.__setattr__(self, "order", L)
        object.__setattr__(self, "coefficients", c)
        object.__setattr__(self, "allow_negative", bool(self.allow_negative))
        ks, ms = sh_degrees_orders(L)
        object.__setattr__(self, "_ks", ks)
        object.__setattr__(self, "_ms", ms)
        self._validate_after_init()

    # ---- hooks ------------------------------------------------------------------------
    def _normalised(self, n: np.ndarray) -> np.ndarray:
        if self.order == 0:
            return np.ones(n.shape[:-1])
        return 1.0 + 4.0 * np.pi * (real_sh(n, self._ks, self._ms) @ self.coefficients)

    def _impossible_coefficient(self) -> str | None:
        """``|c_km| > sqrt((2k + 1) / (4 pi))``: impossible for ``xi >= 0``.

        ``c_km = int xi Y_km dOmega`` with ``int xi dOmega = 1``, so ``|c_km| <= max |Y_km|``,
        and the addition theorem (``sum_m Y_km^2 = (2k + 1) / (4 pi)``) bounds ``|Y_km|``.
        """
        c = np.asarray(self.coefficients)
        bound = np.sqrt((2 * self._ks + 1) / (4.0 * np.pi))
        over = np.nonzero(np.abs(c) > bound * (1.0 + 1e-12))[0]  # (round-off: a point mass attains the bound)
        if over.size == 0:
            return None
        j = int(over[0])
        return (f"coefficient c_({int(self._ks[j])},{int(self._ms[j])}) = {c[j]:.4g} exceeds "
                f"sqrt((2k+1)/(4 pi)) = {bound[j]:.4g}, the largest any non-negative density allows")

    def _anisotropy_bound(self) -> float:
        """``sum_k ||c_k|| sqrt(4 pi (2k + 1))``, a bound of the anisotropic part.

        By the addition theorem, ``sum_m Y_km(n)^2 = (2k + 1) / (4 pi)``, so Cauchy-Schwarz bounds the degree-k part
        of ``4 pi sum c_km Y_km`` by ``||c_k|| sqrt(4 pi (2k + 1))``.
        """
        c = np.asarray(self.coefficients)
        return float(sum(np.linalg.norm(c[self._ks == k]) * np.sqrt(4.0 * np.pi * (2 * k + 1))
                         for k in np.unique(self._ks)))

    def _degree_part(self, n: np.ndarray, k: int) -> np.ndarray:
        sel = self._ks == k
        if not np.any(sel):
            return np.zeros(n.shape[:-1])
        return 4.0 * np.pi * (real_sh(n, self._ks[sel], self._ms[sel]) @ self.coefficients[sel])

    @classmethod
    def _coefficients_from_values(cls, pts: np.ndarray, w: np.ndarray, values: np.ndarray,
                                  order: int) -> dict:
        ks, ms = sh_degrees_orders(order)
        if len(ks) == 0:
            return {"coefficients": np.zeros(0)}
        return {"coefficients": (w * values) @ real_sh(pts, ks, ms)}

    # ---- seed convention -------------------------------------------------------------------
    @classmethod
    def from_seed(cls, a20: float = 0.0, a22: float = 0.0, b22: float = 0.0,
                  allow_negative: bool = False) -> SphericalDensity:
        """Second-order density of seed Eq. 4.15 (equivalently Eq. 4.16-4.17).

        ``xi = (1/4 pi)[1 + a20 P2(cos gamma) + 3 sin^2 gamma (a22 cos 2 beta + b22 sin 2 beta)]``;
        in library components ``phi_zz = a20``, ``phi_yy = -a20/2 + 3 a22``,
        ``phi_xx = -a20/2 - 3 a22``, ``phi_xy = 3 b22``.

        Examples
        --------
        The transversely isotropic fabric of the seed's Fig. 4.2:

        >>> d = SphericalDensity.from_seed(a20=0.8)
        >>> round(float(d.coefficient_tensors()[2][2, 2]), 12)      # phi_zz = a20
        0.8
        """
        a20 = _checks.as_scalar(a20, "a20")
        a22 = _checks.as_scalar(a22, "a22")
        b22 = _checks.as_scalar(b22, "b22")
        return cls.from_seed_coefficients({(2, 0): (a20, 0.0), (2, 2): (a22, b22)},
                                          order=2, allow_negative=allow_negative)

    @classmethod
    def from_seed_coefficients(cls, coeffs: Mapping[tuple[int, int], tuple[float, float]],
                               order: int | None = None,
                               allow_negative: bool = False) -> SphericalDensity:
        """Density from the seed's coefficients ``{(k, m): (a_km, b_km)}`` (Eq. 4.7, 4.13).

        Parameters
        ----------
        coeffs : mapping
            Keys ``(k, m)`` with ``k`` even >= 2 and ``0 <= m <= k``; values
            ``(a_km, b_km)`` multiplying ``P_k^m cos m beta`` and ``P_k^m sin m beta`` with
            the seed's unnormalised, phase-free ``P_k^m`` (``P_2^2 = 3 sin^2 gamma``).
            ``b_k0`` must be 0.  Missing entries are 0.
        order : int, optional
            Expansion order; default the largest ``k`` among the keys (0 if empty).
        """
        if not isinstance(coeffs, Mapping):
            raise ParameterError("coeffs", type(coeffs).__name__,
                              "must be a mapping {(k, m): (a_km, b_km)}")
        kmax = 0
        parsed: dict[tuple[int, int], tuple[float, float]] = {}
        for key, val in coeffs.items():
            try:
                k, m = key
            except (TypeError, ValueError):
                raise ParameterError("coeffs key", key, "must be a pair (k, m)") from None
            k = _checks.as_even_order(k, "k")
            m = _checks.as_int(m, "m")
            if k < 2 or not 0 <= m <= k:
                raise ParameterError("coeffs key", key, "need even k >= 2 and 0 <= m <= k")
            try:
                a, b = (float(x) for x in val)
            except (TypeError, ValueError):
                raise ParameterError(f"coeffs[{key}]", val, "must be a pair (a_km, b_km)") from None
            if not (np.isfinite(a) and np.isfinite(b)):
                raise ParameterError(f"coeffs[{key}]", val, "must be finite")
            if m == 0 and b != 0.0:
                raise ParameterError(f"coeffs[{key}]", val, "b_k0 must be 0 (sin 0 = 0)")
            parsed[(k, m)] = (a, b)
            kmax = max(kmax, k)
        L = kmax if order is None else _checks.as_even_order(order)
        if L < kmax:
            raise ParameterError("order", order, f"smaller than the highest degree given ({kmax})")
        c = np.zeros(n_coefficients_3d(L))
        for (k, m), (a, b) in parsed.items():
            f = seed_factor(k, m)
            c[sh_index(k, m)] = a / f
            if m > 0:
                c[sh_index(k, -m)] = b / f
        return cls(order=L, coefficients=c, allow_negative=allow_negative)

    def seed_coefficients(self) -> dict[tuple[int, int], tuple[float, float]]:
        """The seed's ``{(k, m): (a_km, b_km)}`` for even ``2 <= k <= order``, ``0 <= m <= k``.

        Inverse of :meth:`from_seed_coefficients` (Eq. 4.7 with Rodrigues' ``P_k^m``,
        Eq. 4.13, no Condon-Shortley phase).
        """
        out: dict[tuple[int, int], tuple[float, float]] = {}
        for k in range(2, self.order + 1, 2):
            for m in range(0, k + 1):
                f = seed_factor(k, m)
                a = f * self.coefficients[sh_index(k, m)]
                b = f * self.coefficients[sh_index(k, -m)] if m > 0 else 0.0
                out[(k, m)] = (float(a), float(b))
        return out

    @property
    def seed_parameters(self) -> dict[str, float]:
        """Second-order seed parameters ``a20, a22, b22`` (Eq. 4.15) plus ``a21, b21``.

        ``a21``/``b21`` multiply ``P_2^1 cos beta``/``P_2^1 sin beta`` (``P_2^1 = 3 sin gamma
        cos gamma``); Eq. 4.15 leaves them out (so z is a principal axis of the seed's
        ``phi``); they are zero for densities built by :meth:`from_seed` and in general
        equal ``2 phi_yz / 3`` and ``2 phi_xz / 3``.
        """
        if self.order < 2:
            return {"a20": 0.0, "a22": 0.0, "b22": 0.0}
        sc = self.seed_coefficients()
        return {"a20": sc[(2, 0)][0], "a22": sc[(2, 2)][0], "b22": sc[(2, 2)][1],
                "a21": sc[(2, 1)][0], "b21": sc[(2, 1)][1]}

    def truncated(self, order: int) -> SphericalDensity:
        """Keep the harmonics of degree ``<= order`` (or zero-pad to a higher order)."""
        L = _checks.as_even_order(order)
        c = np.zeros(n_coefficients_3d(L))
        n = min(len(c), len(self.coefficients))
        c[:n] = self.coefficients[:n]
        return SphericalDensity(order=L, coefficients=c, allow_negative=self.allow_negative)

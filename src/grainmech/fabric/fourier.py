r"""2D contact-normal density as an even Fourier series (seed Eq. 4.9, 4.34).

::

    xi(theta) = (1/2 pi) [1 + sum'_{k=2,4,..,L} (a_k cos k theta + b_k sin k theta)]

with the seed's angle ``theta`` measured from the y axis, ``n = (n_y, n_x) = (cos theta,
sin theta)`` (Eq. 4.35; :func:`grainmech.conventions.seed_normal_2d`), so that
``integral_0^2pi xi dtheta = 1``.

Normalisation: the seed's Eq. 4.35 prints ``1/(4 pi)`` in front of the tensor form; the
correct factor is ``1/(2 pi)`` as in Eq. 4.9, 4.10b and 4.34 (see
``docs/seed-errata.md``, F1): with ``1/(4 pi)`` the density would integrate to 1/2
and ``phi_ij`` would be ``8 (N_ij - delta_ij/2)``, contradicting Eq. 4.11's factor 4.

Tensor form (library components, ``cos 2 theta = n_y^2 - n_x^2``,
``sin 2 theta = 2 n_x n_y``, ``cos 4 theta = n_y^4 - 6 n_x^2 n_y^2 + n_x^4``,
``sin 4 theta = 4 n_x n_y^3 - 4 n_x^3 n_y``)::

    phi_yy = a2, phi_xx = -a2, phi_xy = b2
    phi_yyyy = phi_xxxx = a4, phi_xxyy (all 6 index orders) = -a4,
    phi_xyyy (4 orders) = b4, phi_xxxy (4 orders) = -b4

Moment property: ``a_k = 2 E[cos k theta]``, ``b_k = 2 E[sin k theta]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from grainmech.conventions import seed_theta
from grainmech.errors import ParameterError
from grainmech.fabric import _checks
from grainmech.fabric._base import DensityBase

__all__ = ["FourierDensity"]


@dataclass(frozen=True, eq=False)
class FourierDensity(DensityBase):
    """Centrosymmetric density of contact normals on the unit circle (seed Eq. 4.9).

    Parameters
    ----------
    order : int
        Even expansion order ``L`` (0 = isotropic).
    a, b : array_like, shape (L/2,)
        The seed's ``a_k``, ``b_k`` for ``k = 2, 4, ..., L`` (dimensionless).
    allow_negative : bool, default False
        If False, a density negative somewhere raises
        :class:`~grainmech.errors.NegativeDensityError`.
    """

    order: int
    a: np.ndarray
    b: np.ndarray
    allow_negative: bool = False

    dim = 2
    _k: np.ndarray = field(init=False, repr=False, compare=False)  # degrees 2, 4, ..., order

    def __post_init__(self) -> None:
        L = _checks.as_even_order(self.order)
        arrs = {}
        for name in ("a", "b"):
            v = _checks.as_finite_array(getattr(self, name), name).reshape(-1).copy()
            if v.shape != (L // 2,):
                raise ParameterError(name, f"array of shape {np.shape(getattr(self, name))}",
                                  f"order {L} needs {L // 2} coefficients (k = 2, 4, ..., {L})")
            v.setflags(write=False)
            arrs[name] = v
        object.__setattr__(self, "order", L)
        object.__setattr__(self, "a", arrs["a"])
        object.__setattr__(self, "b", arrs["b"])
        object.__setattr__(self, "allow_negative", bool(self.allow_negative))
        object.__setattr__(self, "_k", np.arange(2, L + 1, 2))
        self._validate_after_init()

    # ---- hooks ----------------------------------------------------------------------------
    def _normalised(self, n: np.ndarray) -> np.ndarray:
        if self.order == 0:
            return np.ones(n.shape[:-1])
        th = seed_theta(n)[..., None] * self._k
        return 1.0 + np.cos(th) @ self.a + np.sin(th) @ self.b

    def _impossible_coefficient(self) -> str | None:
        """``sqrt(a_k^2 + b_k^2) > 2``: impossible for ``xi >= 0``.

        ``a_k cos k theta + b_k sin k theta = r_k cos(k theta - phi_k)`` with ``r_k`` twice
        the mean of ``cos(k theta - phi_k)`` weighted by the normalised density (mean 1),
        so ``r_k <= 2``. Each of ``|a_k|``, ``|b_k|`` is compared first (no overflow).
        """
        for j, k in enumerate(self._k):
            a, b = float(self.a[j]), float(self.b[j])
            if abs(a) > 2.0 or abs(b) > 2.0 or np.hypot(a, b) > 2.0 * (1.0 + 1e-12):  # (round-off of a bound attained)
                return (f"coefficients a_{int(k)} = {a:.4g}, b_{int(k)} = {b:.4g}: sqrt(a^2 + b^2) exceeds 2, "
                        "the largest any non-negative density allows")
        return None

    def _anisotropy_bound(self) -> float:
        """``sum_k sqrt(a_k^2 + b_k^2)``, the largest possible ``|a_k cos + b_k sin|`` summed."""
        return float(np.sum(np.hypot(self.a, self.b)))

    def _degree_part(self, n: np.ndarray, k: int) -> np.ndarray:
        if k < 2 or k > self.order or k % 2:
            return np.zeros(n.shape[:-1])
        j = k // 2 - 1
        th = k * seed_theta(n)
        return self.a[j] * np.cos(th) + self.b[j] * np.sin(th)

    @classmethod
    def _coefficients_from_values(cls, pts: np.ndarray, w: np.ndarray, values: np.ndarray,
                                  order: int) -> dict:
        k = np.arange(2, order + 1, 2)
        th = seed_theta(pts)[:, None] * k
        return {"a": 2.0 * (w * values) @ np.cos(th), "b": 2.0 * (w * values) @ np.sin(th)}

    # ---- seed convention ------------------------------------------------------------------
    @classmethod
    def from_seed(cls, a2: float = 0.0, b2: float = 0.0, a4: float = 0.0, b4: float = 0.0,
                  allow_negative: bool = False) -> FourierDensity:
        """Density of seed Eq. 4.34: ``(1/2 pi)[1 + a2 cos 2t + b2 sin 2t + a4 cos 4t + b4 sin 4t]``.

        The order is 4 if ``a4`` or ``b4`` is non-zero, else 2.
        """
        a2, b2, a4, b4 = (_checks.as_scalar(v, k_) for k_, v in
                          (("a2", a2), ("b2", b2), ("a4", a4), ("b4", b4)))
        coeffs = {2: (a2, b2)}
        if a4 != 0 or b4 != 0:
            coeffs[4] = (float(a4), float(b4))
        return cls.from_seed_coefficients(coeffs, allow_negative=allow_negative)

    @classmethod
    def from_seed_coefficients(cls, coeffs: Mapping[int, tuple[float, float]],
                               order: int | None = None,
                               allow_negative: bool = False) -> FourierDensity:
        """Density from ``{k: (a_k, b_k)}`` (Eq. 4.9), ``k`` even >= 2; missing entries 0.

        ``order`` defaults to the largest ``k`` given.
        """
        if not isinstance(coeffs, Mapping):
            raise ParameterError("coeffs", type(coeffs).__name__, "must be a mapping {k: (a_k, b_k)}")
        parsed: dict[int, tuple[float, float]] = {}
        for key, val in coeffs.items():
            k = _checks.as_even_order(key, "k")
            if k < 2:
                raise ParameterError("k", key, "must be >= 2 (k = 0 is fixed by normalisation)")
            try:
                a, b = (float(x) for x in val)
            except (TypeError, ValueError):
                raise ParameterError(f"coeffs[{key}]", val, "must be a pair (a_k, b_k)") from None
            if not (np.isfinite(a) and np.isfinite(b)):
                raise ParameterError(f"coeffs[{key}]", val, "must be finite")
            parsed[k] = (a, b)
        kmax = max(parsed, default=0)
        L = kmax if order is None else _checks.as_even_order(order)
        if L < kmax:
            raise ParameterError("order", order, f"smaller than the highest degree given ({kmax})")
        a_k = np.zeros(L // 2)
        b_k = np.zeros(L // 2)
        for k, (ak, bk) in parsed.items():
            a_k[k // 2 - 1] = ak
            b_k[k // 2 - 1] = bk
        return cls(order=L, a=a_k, b=b_k, allow_negative=allow_negative)

    def seed_coefficients(self) -> dict[int, tuple[float, float]]:
        """``{k: (a_k, b_k)}`` for ``k = 2, 4, ..., order`` (Eq. 4.9)."""
        return {int(k): (float(a), float(b)) for k, a, b in zip(self._k, self.a, self.b)}

    @property
    def seed_parameters(self) -> dict[str, float]:
        """``a2, b2, a4, b4`` of Eq. 4.34 (zero where the order is lower)."""
        sc = self.seed_coefficients()
        return {"a2": sc.get(2, (0.0, 0.0))[0], "b2": sc.get(2, (0.0, 0.0))[1],
                "a4": sc.get(4, (0.0, 0.0))[0], "b4": sc.get(4, (0.0, 0.0))[1]}

    @property
    def coefficients(self) -> np.ndarray:
        """Orthonormal Fourier coefficients of the density, interleaved ``[c2, s2, c4, s4, ...]``.

        Orthonormal coefficients ``integral xi f_k dtheta`` on ``cos(k t)/sqrt(pi)``,
        ``sin(k t)/sqrt(pi)``, interleaved ``[c2, s2, c4, s4, ...]`` (= a_k / (2 sqrt(pi))).
        """
        return (np.stack([self.a, self.b], axis=-1).reshape(-1) / (2.0 * np.sqrt(np.pi)))

    def truncated(self, order: int) -> FourierDensity:
        """Keep the terms with ``k <= order`` (or zero-pad to a higher order)."""
        L = _checks.as_even_order(order)
        a = np.zeros(L // 2)
        b = np.zeros(L // 2)
        n = min(L // 2, len(self.a))
        a[:n], b[:n] = self.a[:n], self.b[:n]
        return FourierDensity(order=L, a=a, b=b, allow_negative=self.allow_negative)

r"""Fabric tensors and densities estimated from measured contact normals.

Estimator
---------
:func:`fit_density` uses the *moment* (orthogonal-projection) estimator: with an
orthonormal basis ``f_j`` of the even harmonics up to order ``L`` (real spherical
harmonics ``Y_km`` in 3D, ``cos k theta / sqrt(pi)``, ``sin k theta / sqrt(pi)`` in 2D),
the true coefficients are ``c_j = integral xi f_j dOmega = E[f_j(n)]``, so the estimate is
the (weighted) sample mean::

    c_j_hat = sum_i w_i f_j(n_i) / sum_i w_i

Why this one: it is the least-squares (L2) projection of the empirical distribution onto
the harmonics of degree ``<= L``; it is linear, unbiased, has a closed-form covariance,
needs no iteration or starting point, is independent of the sign of each normal (even
harmonics), and it reproduces exactly the empirical fabric tensors ``N_(2) ... N_(L)``
(Kanatani 1984: the fitted density has the measured fabric tensors; equivalently
``phi_(k) = F_k dev N_(k)``, seed Eq. 4.11).  Maximum likelihood would be somewhat more
efficient for strongly anisotropic data but is nonlinear and needs positivity constraints.
The price of the moment estimator is that the fitted truncated series can be negative in
some directions; :func:`fit_density` detects that (``on_negative``).

Standard errors: ``Cov(c_hat) = sum_i w_i'^2 (f(n_i) - c_hat)(f(n_i) - c_hat)^T / (1 - sum_i w_i'^2)``
with ``w' = w / sum w`` (for equal weights this is the usual ``s^2 / n``).  Each physical
contact should be passed **once** (either sign): passing both ``n`` and ``-n`` doubles
the apparent sample size.

Goodness of fit: Pearson chi-square on equal-area bins of the half sphere (rings equally
spaced in ``cos gamma`` times equal sectors in ``beta``) or equal bins of ``theta`` in
``[0, pi)``, using centrosymmetry to fold ``-n`` onto ``n``.  The p-value uses
``dof = bins - 1 - (number of fitted coefficients)``; since the coefficients are moment
rather than minimum-chi-square estimates, the true null distribution lies between
``chi2(dof)`` and ``chi2(bins - 1)`` (Chernoff and Lehmann 1954), so the p-value is slightly
on the small (conservative-for-acceptance) side.  With weights the counts are scaled to
Kish's effective sample size ``n_eff = (sum w)^2 / sum w^2``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.stats import chi2 as _chi2

from grainmech.errors import NegativeDensityError, ParameterError
from grainmech.fabric import _checks
from grainmech.fabric import tensors as _t
from grainmech.fabric._base import NEGATIVE_TOL, DensityBase, DensityExtremum
from grainmech.fabric._basis import fourier_index_arrays, real_fourier, real_sh, seed_factor
from grainmech.fabric.fourier import FourierDensity
from grainmech.fabric.harmonics import SphericalDensity, sh_degrees_orders

__all__ = ["fabric_tensor", "fit_density", "DensityFit", "NegativeDensityWarning"]

_CHUNK = 65536


class NegativeDensityWarning(UserWarning):
    """A fitted density is negative in some directions (kept because on_negative='warn')."""


def fabric_tensor(normals: object, rank: int = 2, weights: object | None = None) -> np.ndarray:
    """Empirical fabric tensor ``N = <n^(x)rank>`` (seed Eq. 4.6a) from unit normals.

    Parameters
    ----------
    normals : array_like, shape (p, d)
        Unit contact normals (d = 2 or 3), library components.  The sign of each normal
        does not matter for even ``rank``.
    rank : int, default 2
        Tensor rank (0..12).
    weights : array_like, shape (p,), optional
        Non-negative weights (e.g. one per contact); normalised to sum 1.

    Returns
    -------
    ndarray, shape (d,) * rank
        Trace of the rank-2 tensor is 1.
    """
    n = _checks.as_normals(normals)
    if n.ndim != 2 or n.shape[0] == 0:
        raise ParameterError("normals", f"array of shape {n.shape}", "must have shape (p, d) with p >= 1")
    rank = _checks.as_int(rank, "rank", 0)
    if rank > _t.MAX_RANK:
        raise ParameterError("rank", rank, f"rank above {_t.MAX_RANK} not supported")
    p, d = n.shape
    w = np.full(p, 1.0 / p) if weights is None else _checks.as_weights(weights, p)
    w = w / w.sum()
    acc = np.zeros(d ** rank)
    for s in range(0, p, _CHUNK):
        acc += w[s:s + _CHUNK] @ _t.outer_power(n[s:s + _CHUNK], rank)
    return acc.reshape((d,) * rank)


@dataclass(frozen=True, eq=False)
class DensityFit:
    """Result of :func:`fit_density`.

    Attributes
    ----------
    density : SphericalDensity or FourierDensity
        The fitted density (shrunk if ``on_negative='shrink'`` had to act; built with
        ``allow_negative=True`` if it is negative and ``on_negative`` was 'warn'/'allow').
    coefficients : ndarray, shape (p,)
        Unshrunk orthonormal-basis estimates (sample means of the basis functions):
        ``c_km`` ordered as :func:`~grainmech.fabric.harmonics.sh_degrees_orders` in 3D;
        ``[c_2, s_2, c_4, s_4, ...]`` on ``cos/sin(k theta)/sqrt(pi)`` in 2D.
    covariance : ndarray, shape (p, p)
        Estimated sampling covariance of ``coefficients``.
    standard_errors : ndarray, shape (p,)
        ``sqrt(diag(covariance))``.
    seed_coefficients, seed_standard_errors : dict
        Estimates and standard errors in the seed's convention: ``{(k, m): (a, b)}`` (3D,
        Eq. 4.7) or ``{k: (a, b)}`` (2D, Eq. 4.9); unshrunk.
    n_normals : int
        Number of normals used.
    n_effective : float
        Kish effective sample size (``= n_normals`` without weights).
    chi2, dof, p_value : float or None
        Pearson chi-square statistic on equal-area bins, its degrees of freedom and the
        p-value (None when there are too few normals for a test; see ``message``).
    n_bins : int
    min_expected : float or None
        Smallest expected bin count (the chi-square approximation wants >= 5).
    minimum : DensityExtremum
        Minimum of the unshrunk fitted density.
    shrink_factor : float
        1, or the factor applied to the anisotropic part by ``on_negative='shrink'``.
    message : str
        Notes about the fit (negativity, small expected counts, skipped test).
    """

    density: DensityBase
    coefficients: np.ndarray
    covariance: np.ndarray
    standard_errors: np.ndarray
    seed_coefficients: dict
    seed_standard_errors: dict
    n_normals: int
    n_effective: float
    chi2: float | None
    dof: int | None
    p_value: float | None
    n_bins: int
    min_expected: float | None
    minimum: DensityExtremum
    shrink_factor: float
    message: str


def _basis(n: np.ndarray, order: int) -> np.ndarray:
    if n.shape[1] == 3:
        ks, ms = sh_degrees_orders(order)
        return real_sh(n, ks, ms)
    ks, ss = fourier_index_arrays(range(2, order + 1, 2))
    return real_fourier(n, ks, ss)


def _density_from_coefficients(c: np.ndarray, order: int, dim: int) -> DensityBase:
    if dim == 3:
        return SphericalDensity(order=order, coefficients=c, allow_negative=True)
    s = 2.0 * np.sqrt(np.pi)
    return FourierDensity(order=order, a=s * c[0::2], b=s * c[1::2], allow_negative=True)


def _seed_from_vector(v: np.ndarray, order: int, dim: int) -> dict:
    out: dict = {}
    if dim == 3:
        ks, ms = sh_degrees_orders(order)
        idx = {(int(k), int(m)): i for i, (k, m) in enumerate(zip(ks, ms))}
        for k in range(2, order + 1, 2):
            for m in range(0, k + 1):
                f = seed_factor(k, m)
                a = f * v[idx[(k, m)]]
                b = f * v[idx[(k, -m)]] if m > 0 else 0.0
                out[(k, m)] = (float(a), float(b))
    else:
        s = 2.0 * np.sqrt(np.pi)
        for j, k in enumerate(range(2, order + 1, 2)):
            out[k] = (float(s * v[2 * j]), float(s * v[2 * j + 1]))
    return out


def _bin_edges_count(n_eff: float, n_par: int, dim: int, n_bins: int | None) -> int:
    if n_bins is not None:
        return _checks.as_int(n_bins, "n_bins", 2)
    # Mann and Wald (1942) rule of thumb, about 2 n^(2/5) equiprobable classes
    target = int(min(max(2.0 * n_eff ** 0.4, n_par + 10), 800))
    if dim == 3:
        B = max(2, int(np.sqrt(target / 2.0)))
        return 2 * B * B
    return max(4, target)


def _chi_square(n: np.ndarray, w: np.ndarray, density: DensityBase, n_bins: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Observed weight fractions and expected probabilities on equal-area bins."""
    d = n.shape[1]
    if d == 3:
        B = max(1, int(round(np.sqrt(n_bins / 2.0))))
        if 2 * B * B != n_bins:
            raise ParameterError("n_bins", n_bins, "in 3D must be 2 B^2 (B rings x 2B sectors), "
                              "e.g. 8, 18, 32, 50, 72, 98, 128, ...")
        S = 2 * B
        f = np.where(n[:, 2:3] < 0, -n, n)
        z = np.clip(f[:, 2], 0.0, 1.0)
        beta = np.mod(np.arctan2(f[:, 0], f[:, 1]), 2 * np.pi)
        ring = np.minimum((z * B).astype(int), B - 1)
        sec = np.minimum((beta / (2 * np.pi) * S).astype(int), S - 1)
        obs = np.bincount(ring * S + sec, weights=w, minlength=B * S)
        # expected: 2 * integral over the bin of xi sin(gamma) dgamma dbeta (Gauss-Legendre)
        q = density.order // 2 + 8
        x, gw = np.polynomial.legendre.leggauss(q)
        zed = np.linspace(0.0, 1.0, B + 1)
        g_edges = np.arccos(zed)  # decreasing
        g_lo, g_hi = g_edges[1:], g_edges[:-1]
        gam = (0.5 * (g_hi - g_lo))[:, None] * x + (0.5 * (g_hi + g_lo))[:, None]   # (B, q)
        gwt = (0.5 * (g_hi - g_lo))[:, None] * gw * np.sin(gam)
        b_edges = np.linspace(0.0, 2 * np.pi, S + 1)
        bet = (0.5 * np.diff(b_edges))[:, None] * x + (0.5 * (b_edges[1:] + b_edges[:-1]))[:, None]
        bwt = (0.5 * np.diff(b_edges))[:, None] * gw                                  # (S, q)
        G, Bt = np.meshgrid(gam.ravel(), bet.ravel(), indexing="ij")
        pts = np.stack([np.sin(G) * np.sin(Bt), np.sin(G) * np.cos(Bt), np.cos(G)], axis=-1)
        vals = density._normalised(pts.reshape(-1, 3)).reshape(B, q, S, q) / density.measure
        exp = 2.0 * np.einsum("iajb,ia,jb->ij", vals, gwt, bwt).ravel()
    else:
        M = n_bins
        th = np.mod(np.arctan2(n[:, 0], n[:, 1]), np.pi)
        idx = np.minimum((th / np.pi * M).astype(int), M - 1)
        obs = np.bincount(idx, weights=w, minlength=M)
        e = np.linspace(0.0, np.pi, M + 1)
        assert isinstance(density, FourierDensity)
        ks = np.arange(2, density.order + 1, 2)
        t0, t1 = e[:-1, None], e[1:, None]
        integ = (e[1:] - e[:-1]) + (((np.sin(ks * t1) - np.sin(ks * t0)) / ks) @ density.a
                                    - ((np.cos(ks * t1) - np.cos(ks * t0)) / ks) @ density.b
                                    if len(ks) else 0.0)
        exp = 2.0 * integ / (2.0 * np.pi)
    return obs, exp


def fit_density(normals: object, order: int, weights: object | None = None,
                on_negative: Literal["warn", "raise", "shrink", "allow"] = "warn",
                n_bins: int | None = None) -> DensityFit:
    """Fit a contact-normal density of even ``order`` to measured unit normals.

    Parameters
    ----------
    normals : array_like, shape (p, d)
        Unit contact normals (d = 3: spherical harmonics, seed Eq. 4.7; d = 2: Fourier
        series, Eq. 4.9).  One entry per physical contact; the sign is irrelevant.
    order : int
        Even expansion order ``L`` (2 and 4 are typical).
    weights : array_like, shape (p,), optional
        Non-negative weights (e.g. normal force, for a force-weighted distribution).
    on_negative : {'warn', 'raise', 'shrink', 'allow'}
        What to do if the fitted series is negative somewhere: warn
        (:class:`NegativeDensityWarning`) and return it with ``allow_negative=True``;
        raise :class:`~grainmech.errors.NegativeDensityError`; shrink the anisotropic
        part by the largest factor ``lambda <= 1`` that makes the minimum zero
        (``lambda = 1/(1 - m)`` with ``m = |S| min xi``; keeps the principal directions,
        biases the amplitudes towards isotropy); or silently allow it.
    n_bins : int, optional
        Number of chi-square bins (3D: ``2 B^2``); chosen from the sample size if omitted
        (``2 n_eff^(2/5)`` bins after Mann and Wald 1942, at least ``p + 10``, at most
        800, then coarsened until every expected count is at least 5 where possible).

    Returns
    -------
    DensityFit
    """
    n = _checks.as_normals(normals)
    if n.ndim != 2:
        raise ParameterError("normals", f"array of shape {n.shape}", "must have shape (p, d)")
    p, d = n.shape
    L = _checks.as_even_order(order)
    if on_negative not in ("warn", "raise", "shrink", "allow"):
        raise ParameterError("on_negative", on_negative, "must be 'warn', 'raise', 'shrink' or 'allow'")
    if p < 2:
        raise ParameterError("normals", f"array of shape {n.shape}", "need at least 2 normals")
    w = np.full(p, 1.0 / p) if weights is None else _checks.as_weights(weights, p)
    w = w / w.sum()
    sw2 = float(w @ w)
    n_eff = 1.0 / sw2
    npar = (L + 1) * (L + 2) // 2 - 1 if d == 3 else L
    c = np.zeros(npar)
    cov = np.zeros((npar, npar))
    if npar:
        for s in range(0, p, _CHUNK):
            c += w[s:s + _CHUNK] @ _basis(n[s:s + _CHUNK], L)
        for s in range(0, p, _CHUNK):
            r = _basis(n[s:s + _CHUNK], L) - c
            cov += (r * (w[s:s + _CHUNK] ** 2)[:, None]).T @ r
        cov /= max(1.0 - sw2, 1e-300)
    se = np.sqrt(np.diag(cov))
    raw = _density_from_coefficients(c, L, d)
    m = raw.minimum()
    notes: list[str] = []
    dens: DensityBase = raw
    lam = 1.0
    if m.normalised < -NEGATIVE_TOL:
        text = (f"fitted order-{L} density is negative somewhere: minimum {m.describe()}")
        if on_negative == "raise":
            raise NegativeDensityError(text + "; use on_negative='shrink' or a lower order")
        if on_negative == "shrink":
            lam = 1.0 / (1.0 - m.normalised) * (1.0 - 1e-9)
            dens = _density_from_coefficients(lam * c, L, d)
            dens = type(dens)(**{**_fields(dens), "allow_negative": False})
            notes.append(text + f"; anisotropic part shrunk by factor {lam:.6g}")
        elif on_negative == "warn":
            warnings.warn(text, NegativeDensityWarning, stacklevel=2)
            notes.append(text)
        else:
            notes.append(text)
    else:
        dens = type(raw)(**{**_fields(raw), "allow_negative": False})
    # goodness of fit (of the unshrunk estimate)
    nb = _bin_edges_count(n_eff, npar, d, n_bins)
    chi2 = dof = pval = min_exp = None
    obs, exp = _chi_square(n, w, raw, nb)
    if n_bins is None:
        # coarsen automatically until every expected count is >= 5 (if possible)
        while n_eff * exp.min() < 5.0:
            smaller = (2 * (int(round(np.sqrt(nb / 2))) - 1) ** 2 if d == 3
                       else int(nb * 0.8))
            if smaller - 1 - npar < 1 or smaller < (8 if d == 3 else 4):
                break
            nb = smaller
            obs, exp = _chi_square(n, w, raw, nb)
    dof_ = nb - 1 - npar
    if dof_ < 1:
        notes.append(f"chi-square test skipped: {nb} bins leave no degrees of freedom for "
                     f"{npar} coefficients (need more normals or n_bins)")
    else:
        E = n_eff * exp
        O = n_eff * obs
        min_exp = float(E.min())
        if min_exp <= 0:
            notes.append("chi-square test skipped: a bin has non-positive expected count "
                         "(fitted density negative there)")
        else:
            chi2 = float(np.sum((O - E) ** 2 / E))
            dof = int(dof_)
            pval = float(_chi2.sf(chi2, dof))
            if min_exp < 5:
                notes.append(f"smallest expected bin count {min_exp:.3g} < 5: chi-square "
                             "approximation is rough")
    return DensityFit(
        density=dens, coefficients=c, covariance=cov, standard_errors=se,
        seed_coefficients=_seed_from_vector(c, L, d),
        seed_standard_errors={k: (abs(a), abs(b)) for k, (a, b) in
                              _seed_from_vector(se, L, d).items()},
        n_normals=p, n_effective=n_eff, chi2=chi2, dof=dof, p_value=pval, n_bins=nb,
        min_expected=min_exp, minimum=m, shrink_factor=lam, message="; ".join(notes))


def _fields(dens: DensityBase) -> dict:
    if isinstance(dens, SphericalDensity):
        return {"order": dens.order, "coefficients": dens.coefficients}
    assert isinstance(dens, FourierDensity)
    return {"order": dens.order, "a": dens.a, "b": dens.b}

"""Orthonormal real harmonic bases in the seed's angles (private).

3D: real spherical harmonics of degree ``k`` and order ``m = -k..k`` in the seed's polar
angle ``gamma`` (from z) and azimuth ``beta`` (from y towards x), orthonormal with respect
to ``dOmega = sin(gamma) dgamma dbeta``::

    Y_k0      = N_k0 P_k(cos gamma)
    Y_km      = sqrt(2) N_km P_k^m(cos gamma) cos(m beta)     (m > 0)
    Y_k,-m    = sqrt(2) N_km P_k^m(cos gamma) sin(m beta)     (m > 0)
    N_km      = sqrt((2k + 1) / (4 pi) * (k - m)! / (k + m)!)

where ``P_k^m`` is the seed's associated Legendre function (Rodrigues, Eq. 4.13, *no*
Condon-Shortley phase, so ``P_2^2 = 3 sin^2 gamma``, Eq. 4.14).  They are computed from
:func:`scipy.special.sph_harm_y` ``(k, m, polar, azimuth)``, which includes the
Condon-Shortley phase ``(-1)^m``; the factor is removed here.

2D: ``1/sqrt(2 pi)`` for ``k = 0`` and ``cos(k theta)/sqrt(pi)``, ``sin(k theta)/sqrt(pi)``
for ``k >= 1``, theta the seed angle from the y axis (Eq. 4.9, 4.34).
"""

from __future__ import annotations

from math import factorial

import numpy as np
from scipy.special import sph_harm_y

from grainmech.conventions import seed_angles, seed_theta


def sh_index_arrays(degrees: list[int] | range) -> tuple[np.ndarray, np.ndarray]:
    """(k, m) of each basis function, degrees in the given order, m = -k..k."""
    ks, ms = [], []
    for k in degrees:
        for m in range(-k, k + 1):
            ks.append(k)
            ms.append(m)
    return np.array(ks, dtype=int), np.array(ms, dtype=int)


def sh_norm(k: int, m: int) -> float:
    """N_km = sqrt((2k+1)/(4 pi) (k-|m|)!/(k+|m|)!)."""
    m = abs(m)
    return float(np.sqrt((2 * k + 1) / (4 * np.pi) * factorial(k - m) / factorial(k + m)))


def seed_factor(k: int, m: int) -> float:
    """Factor from the orthonormal coefficient ``c_k(+-m)`` to the seed's ``a_km`` (or ``b_km``).

    ``a_km = 4 pi N_km c_km`` for ``m = 0`` and ``4 pi sqrt(2) N_km c_k(+-m)`` otherwise
    (seed Eq. 4.7 with Rodrigues' ``P_k^m``, Eq. 4.13, no Condon-Shortley phase;
    :func:`sh_norm`).
    """
    return 4.0 * np.pi * sh_norm(k, m) * (np.sqrt(2.0) if m != 0 else 1.0)


def real_sh(n: np.ndarray, ks: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """Real orthonormal spherical harmonics at unit normals.

    Parameters
    ----------
    n : ndarray, shape (..., 3)
        Unit normals, library (x, y, z) components.
    ks, ms : ndarray of int, shape (c,)
        Degree and order of each requested basis function.

    Returns
    -------
    ndarray, shape (..., c)
    """
    gamma, beta = seed_angles(n)
    am = np.abs(ms)
    z = sph_harm_y(ks, am, gamma[..., None], beta[..., None])
    phase = np.where(am % 2 == 1, -1.0, 1.0)
    root2 = np.sqrt(2.0)
    out = np.where(ms > 0, root2 * phase * z.real,
                   np.where(ms < 0, root2 * phase * z.imag, z.real))
    return np.asarray(out, dtype=float)


def fourier_index_arrays(degrees: list[int] | range) -> tuple[np.ndarray, np.ndarray]:
    """(k, s) per 2D basis function: s = +1 for cos, -1 for sin (k >= 1), 0 for k = 0."""
    ks, ss = [], []
    for k in degrees:
        if k == 0:
            ks.append(0)
            ss.append(0)
        else:
            ks += [k, k]
            ss += [1, -1]
    return np.array(ks, dtype=int), np.array(ss, dtype=int)


def real_fourier(n: np.ndarray, ks: np.ndarray, ss: np.ndarray) -> np.ndarray:
    """Orthonormal (w.r.t. dtheta) Fourier basis at unit normals (..., 2) -> (..., c)."""
    theta = seed_theta(n)[..., None]
    arg = ks * theta
    return np.where(ss > 0, np.cos(arg) / np.sqrt(np.pi),
                    np.where(ss < 0, np.sin(arg) / np.sqrt(np.pi),
                             np.full_like(arg, 1.0 / np.sqrt(2.0 * np.pi))))


def harmonic_basis(n: np.ndarray, k: int) -> np.ndarray:
    """All orthonormal harmonics of degree exactly ``k`` at normals (..., d) -> (..., c)."""
    d = n.shape[-1]
    if d == 3:
        ks, ms = sh_index_arrays([k])
        return real_sh(n, ks, ms)
    ks, ss = fourier_index_arrays([k])
    return real_fourier(n, ks, ss)

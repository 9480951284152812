"""Directional apparent modulus and Poisson's ratio in a plane (seed Eq. 6.1-6.2).

A uniaxial stress increment ``d sigma`` in direction ``alpha`` of a coordinate plane
(angle measured from the plane's first axis towards its second) gives the strains
``eps_alpha`` along ``alpha`` and ``eps_(alpha+90)`` across it (in the plane). The seed
defines

* Eq. 6.1: ``E_alpha = d sigma_alpha / eps_alpha``;
* Eq. 6.2, corrected (``docs/seed-errata.md``): ``nu = -eps_(alpha+90) / eps_alpha``
  (the print has the ratio upside down, which is the reciprocal of Poisson's ratio).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainmech.conventions import stress_to_vector, vector_to_strain
from grainmech.errors import ParameterError

__all__ = ["apparent_moduli"]

_AX = {"x": 0, "y": 1, "z": 2}


def apparent_moduli(C: Any, alpha: Any, plane: str = "xz") -> tuple[np.ndarray, np.ndarray]:
    """Apparent Young's modulus (Eq. 6.1) and Poisson's ratio (Eq. 6.2 corrected).

    Parameters
    ----------
    C : (6, 6) Voigt stiffness, library order
    alpha : array of angles [rad] in ``plane`` from its first axis towards its second
    plane : str, two distinct axes, e.g. ``"xz"``

    Returns
    -------
    E, nu : arrays like ``alpha``
    """
    C = np.asarray(C, dtype=float)
    if C.shape != (6, 6) or not np.all(np.isfinite(C)):
        raise ParameterError("C", C.shape, "must be a finite (6, 6) Voigt matrix")
    if len(plane) != 2 or plane[0] == plane[1] or any(c not in _AX for c in plane):
        raise ParameterError("plane", plane, "must be two distinct axes of x, y, z, e.g. 'xz'")
    S = np.linalg.inv(C)
    a = np.atleast_1d(np.asarray(alpha, dtype=float))
    i, j = _AX[plane[0]], _AX[plane[1]]
    E = np.empty_like(a)
    nu = np.empty_like(a)
    for k, ang in enumerate(a):
        d = np.zeros(3)
        d[i], d[j] = np.cos(ang), np.sin(ang)
        m = np.zeros(3)
        m[i], m[j] = -np.sin(ang), np.cos(ang)
        eps = vector_to_strain(S @ stress_to_vector(np.outer(d, d)))
        e_a = d @ eps @ d
        e_p = m @ eps @ m
        E[k] = 1.0 / e_a
        nu[k] = -e_p / e_a
    return E, nu

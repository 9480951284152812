"""The directional shear box of the seed (Sec. 5.3) on a rod packing.

The directional shear box of the seed (Sec. 5.3) on a rod packing: tangent stiffness
under isotropic pressure, apparent modulus and Poisson's ratio along a direction, and the
strains of a uniaxial stress increment.
"""

from __future__ import annotations

import numpy as np

from grainmech.assembly import ContactSet, static_contact_forces, stiffness
from grainmech.contact import Cylinder, cylinder_normal_stiffness, cylinder_tangential_stiffness
from grainmech.conventions import stress_to_vector, vector_to_strain
from grainmech.elasticity import directional_poisson, directional_young
from grainmech.errors import GrainmechError

__all__ = ["shear_box_stiffness", "directional", "increment_strains"]


def _rod_radii(cs: ContactSet) -> tuple[np.ndarray, np.ndarray]:
    r1 = getattr(cs, "radius1", None)
    r2 = getattr(cs, "radius2", None)
    if r1 is None or r2 is None:  # equal rods touching: |l| = 2 R
        r = np.linalg.norm(cs.branch, axis=1) / 2
        return r, r
    return np.asarray(r1, dtype=float), np.asarray(r2, dtype=float)


def shear_box_stiffness(cs: ContactSet, *, G: float, psi: float, nu: float, phi_mu: float,
                        pressure: float) -> np.ndarray:
    """Tangent 2D stiffness (Voigt 3x3, ``xx, yy, xy``) of rods under isotropic pressure.

    Contact forces from the static estimate ``f = sigma . F^-1 . l`` (exact Love-Weber
    inverse of seed Eq. 2.6, :func:`grainmech.assembly.static_contact_forces`) at
    ``sigma = pressure I``; normal stiffness seed Eq. 3.8 at that normal force (rod radii
    ``R1, R2`` per contact, ``R = 2 R1 R2/(R1 + R2)``), tangential stiffness seed Eq. 3.17
    on first loading at that tangential force (``Ks = Kn/Psi`` when ``T = 0``); stiffness
    seed Eq. 2.26 in the physical counting (each contact once, branch vector).

    Parameters
    ----------
    cs : ContactSet
        2D rod contacts (:class:`RodContactSet` for unequal rods; a plain set is read as
        equal rods of radius ``|l|/2``).
    G, psi, nu, phi_mu : float
        Equivalent shear modulus [stress], ``Psi``, Poisson's ratio, friction angle [rad].
    pressure : float
        Isotropic stress, compression positive [stress].

    Returns
    -------
    array (3, 3)
        Voigt stiffness [stress units of ``G``].
    """
    if cs.dim != 2:
        raise GrainmechError(f"rod packings are 2D; the contact set has dimension {cs.dim}")
    if not np.isfinite(pressure) or pressure <= 0:
        raise GrainmechError(f"pressure must be > 0, got {pressure!r}")
    f = static_contact_forces(cs, pressure * np.eye(2))
    n = cs.normals
    N = np.einsum("ci,ci->c", f, n)
    T = f[:, 1] * n[:, 0] - f[:, 0] * n[:, 1]
    r1, r2 = _rod_radii(cs)
    kn, ks = np.zeros(len(cs)), np.zeros(len(cs))
    pairs = np.round(np.column_stack([r1, r2]) / r1.max(), 9)
    for key in np.unique(pairs, axis=0):
        sel = np.all(pairs == key, axis=1)
        a, b = r1[sel][0], r2[sel][0]
        p = Cylinder(G, nu, a, psi, phi_mu, radius2=None if abs(a - b) <= 1e-9 * a else b)
        kn[sel] = cylinder_normal_stiffness(N[sel], p)
        ks[sel] = cylinder_tangential_stiffness(N[sel], T[sel], p)
    return stiffness(ContactSet(cs.normals, cs.branch, cs.weights, kn, ks, cs.convention))


def _alpha_dirs(alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Loading direction ``d = (sin a, cos a)`` (from y towards x) and ``d + 90 deg``."""
    a = np.asarray(alpha, dtype=float)
    return (np.stack([np.sin(a), np.cos(a)], axis=-1), np.stack([np.cos(a), -np.sin(a)], axis=-1))


def directional(C: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Apparent modulus (seed Eq. 6.1) and Poisson's ratio (Eq. 6.2 corrected) along alpha.

    ``E = d sigma_alpha / eps_alpha`` and ``nu = -eps_(alpha+90) / eps_alpha`` for a
    uniaxial stress increment along ``d = (sin alpha, cos alpha)``; ``alpha`` [rad] from y
    towards x.
    """
    d, m = _alpha_dirs(alpha)
    return directional_young(C, d), directional_poisson(C, d, m)


def increment_strains(C: np.ndarray, alpha: np.ndarray, increment: float) -> dict[str, np.ndarray]:
    """Strains for a uniaxial stress increment ``increment d (x) d`` along alpha.

    ``eps = S : (Delta sigma d (x) d)`` with ``S = C^-1`` (compression positive); the
    seed's directional-shear-box loading (Sec. 5.3). Returns the tensor components
    ``eps_xx, eps_yy, eps_xy`` (``eps_xy`` is half the engineering shear strain) and the
    normal strains ``eps_alpha``, ``eps_alpha90`` along ``d`` and ``d + 90 deg``.
    """
    d, m = _alpha_dirs(alpha)
    dsig = increment * d[..., :, None] * d[..., None, :]
    eps = vector_to_strain(np.einsum("ab,...b->...a", np.linalg.inv(C), stress_to_vector(dsig)))
    return {"eps_xx": eps[..., 0, 0], "eps_yy": eps[..., 1, 1], "eps_xy": eps[..., 0, 1],
            "eps_alpha": np.einsum("...i,...ij,...j->...", d, eps, d),
            "eps_alpha90": np.einsum("...i,...ij,...j->...", m, eps, m)}

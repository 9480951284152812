"""What a strain increment does to an affine material point: stress, tangents, fractions.

Kinematic hypothesis (seed Eq. 2.13): each row of the contact set gets the relative
displacement ``delta = d eps . l``; the laws update the forces, the stress is the
Love-Weber average (seed Eq. 2.6) and the tangents are assembled from the laws' tangent
stiffnesses (seed Eq. 2.26). The first-order finite-deformation correction of seed
Eq. 2.36-2.38 (errata E-2.34) is :func:`geometric_stiffness`. Shared by the point
(:mod:`grainmech.driver.affine.point`) and the step solver
(:mod:`grainmech.driver.affine.solver`); the names are also importable from the point's module.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.assembly import ContactSet, love_weber_stress, love_weber_sum, stiffness, stiffness_from_arrays
from grainmech.contact.law import ContactResponse
from grainmech.conventions import stress_to_vector, vector_to_strain, vector_to_stress

__all__ = ["Evaluation", "evaluate", "tangent", "consistent_tangent", "geometric_stiffness"]


@dataclass(frozen=True)
class Evaluation:
    """Result of applying a strain increment to a point (not yet accepted)."""

    state: Any
    response: ContactResponse
    stress: np.ndarray  # (6,)


def contact_stress(cs: ContactSet, resp: ContactResponse) -> np.ndarray:
    """Love-Weber stress (6,) [Pa] of the contact forces of ``resp`` on ``cs`` (seed Eq. 2.6), symmetrised.

    Non-finite forces raise the error of :func:`grainmech.assembly.love_weber_stress`,
    which names the contact.
    """
    f = resp.normal_force[:, None] * cs.normals + resp.tangential_force
    if not np.all(np.isfinite(f)):
        return stress_to_vector(love_weber_stress(f, cs.branch, cs.weights).stress)  # raises, naming the contact
    full = love_weber_sum(f, cs.branch, cs.weights)
    return stress_to_vector(0.5 * (full + full.T))


def tangent(cs: ContactSet, resp: ContactResponse) -> np.ndarray:
    """Voigt tangent (6, 6) from per-contact tangent stiffnesses (seed Eq. 2.26)."""
    kn = np.maximum(resp.kn, 0.0)
    ks = np.maximum(resp.ks, 0.0)
    if not (np.all(np.isfinite(kn)) and np.all(np.isfinite(ks))):
        return stiffness(cs.with_stiffness(kn, ks))  # raises, naming the contact
    return stiffness_from_arrays(cs.normals, cs.branch, cs.weights, np.ascontiguousarray(kn, dtype=float),
                             np.ascontiguousarray(ks, dtype=float))


def _project(x: np.ndarray, branch: np.ndarray) -> np.ndarray:
    """Rows ``B_c^T x_c`` (C, 6): the Voigt vector of ``sym(x_c (x) l_c)`` (seed Eq. 2.13).

    ``B_c`` maps an engineering strain increment to the contact's relative displacement,
    ``delta_c = B_c d eps`` (``delta_i = d eps_ij l_j``), so ``B_c^T f_c`` is the contact's
    Love-Weber stress contribution (seed Eq. 2.6) per unit weight.
    """
    l = branch
    return np.stack([l[:, 0] * x[:, 0], l[:, 1] * x[:, 1], l[:, 2] * x[:, 2],
                     0.5 * (l[:, 2] * x[:, 1] + l[:, 1] * x[:, 2]),
                     0.5 * (l[:, 2] * x[:, 0] + l[:, 0] * x[:, 2]),
                     0.5 * (l[:, 1] * x[:, 0] + l[:, 0] * x[:, 1])], axis=1)


def consistent_tangent(cs: ContactSet, resp: ContactResponse) -> np.ndarray:
    """Newton Jacobian (6, 6) ``d sigma / d eps`` of the last law update (not symmetric).

    ``C = sum_c w_c B_c^T K_c B_c`` (seed Eq. 2.26) with the consistent contact tangent
    ``K = ks_perp (I - n n) + kn n n + (ks - ks_perp) e e + ktn e n`` (``e`` the slip axis,
    ``ktn`` the Thornton-Randall coupling ``d tau / d alpha``; see
    :class:`~grainmech.contact.ContactResponse`). The compiled pass of
    :mod:`grainmech.driver.affine._fused` assembles the same matrix; a law without ``ks_perp``
    gives :func:`tangent`. Only 3D contact sets carry the extra terms.
    """
    if cs.normals.shape[1] == 3 and resp.t_delta is not None and resp.t_alpha is not None:
        return _step_jacobian(cs, resp)
    if resp.ks_perp is None or resp.axis is None or cs.normals.shape[1] != 3:
        return tangent(cs, resp)
    ksp = np.maximum(resp.ks_perp, 0.0)
    ks = np.maximum(resp.ks, 0.0)
    C = tangent(cs, resp._replace(ks=ksp))
    w = cs.weights
    v = _project(resp.axis, cs.branch)
    u = _project(cs.normals, cs.branch)
    C += (v * (w * (ks - ksp))[:, None]).T @ v
    C += (v * (w * resp.ktn)[:, None]).T @ u
    return C


def _step_jacobian(cs: ContactSet, resp: ContactResponse) -> np.ndarray:
    """``sum_c w_c B_c^T K_c B_c`` with the law's step tangent (algorithmic, not symmetric).

    ``K = (kn n + t_alpha) n^T + t_delta (I - n n)`` (``ContactResponse.t_delta``,
    ``t_alpha``), ``B_c`` as in :func:`_project` (seed Eq. 2.13, 2.26).
    """
    if resp.t_delta is None or resp.t_alpha is None:
        raise ValueError("the law's response carries no step tangent (t_delta, t_alpha)")
    n = cs.normals
    l = cs.branch
    kn = np.maximum(resp.kn, 0.0)
    proj = np.eye(3)[None] - np.einsum("ci,cj->cij", n, n)
    K = (np.einsum("ci,cj->cij", kn[:, None] * n + resp.t_alpha, n)
         + np.einsum("cij,cjk->cik", resp.t_delta, proj))
    B = np.zeros((len(l), 3, 6))
    B[:, 0, 0], B[:, 1, 1], B[:, 2, 2] = l[:, 0], l[:, 1], l[:, 2]
    B[:, 1, 3], B[:, 2, 3] = 0.5 * l[:, 2], 0.5 * l[:, 1]
    B[:, 0, 4], B[:, 2, 4] = 0.5 * l[:, 2], 0.5 * l[:, 0]
    B[:, 0, 5], B[:, 1, 5] = 0.5 * l[:, 1], 0.5 * l[:, 0]
    return np.einsum("c,ciq,cij,cjr->qr", cs.weights, B, K, B, optimize=True)


def sliding_open_fractions(cs: ContactSet, resp: ContactResponse) -> tuple[float, float]:
    """Weighted fractions of the contacts of ``cs`` that slide and that are open in ``resp`` [-]."""
    w = cs.weights
    tot = float(w.sum())
    if tot <= 0:
        return 0.0, 0.0
    return float(np.dot(w, resp.sliding) / tot), float(np.dot(w, resp.open) / tot)


def evaluate(point: Any, d_strain: np.ndarray) -> Evaluation:
    """Apply a total strain increment (6,) from the converged ``point`` (pure).

    ``point`` is a :class:`~grainmech.driver.affine.point.MaterialPoint` (its
    ``contacts``, ``law`` and ``state``).

    ``delta_c = d eps . l_c``; ``d_n = delta . n``; ``d_t = delta - d_n n`` (seed Eq. 2.13).
    """
    cs = point.contacts
    de = vector_to_strain(np.asarray(d_strain, dtype=float))
    delta = cs.branch @ de  # de symmetric: delta_i = de_ij l_j
    dn = np.einsum("ci,ci->c", delta, cs.normals)
    dt = delta - dn[:, None] * cs.normals
    st, resp = point.law.update(point.state, dn, dt)
    return Evaluation(st, resp, contact_stress(cs, resp))


def geometric_stiffness(stress: np.ndarray) -> np.ndarray:
    """First-order finite-deformation correction as a (6, 6) Voigt matrix ``G(sigma)``.

    Seed Eq. 2.36-2.38 with the index correction of errata E-2.34:
    ``Delta sigma = sigma_dot + sym(sigma D^T) - sigma tr D``, where ``sigma_dot`` is the
    increment of the contact (Love-Weber, reference-geometry) stress and ``D`` the
    displacement gradient, tension positive. The driver prescribes no spin, so
    ``D = -d eps`` (``d eps`` compression positive, symmetric) and

    ``Delta sigma - sigma_dot = -(sigma d eps + d eps sigma)/2 + sigma tr(d eps) = G(sigma) : d eps``.

    The relation is linear in the stress-like quantities, so it holds unchanged with
    compression-positive stresses. Example: ``sigma = p I`` and ``d eps = e I`` give
    ``+2 p e I`` (the volume shrinks by ``3e``, the branch vectors by ``e``).

    Parameters
    ----------
    stress : (6,) current stress, library order

    Returns
    -------
    (6, 6) array acting on engineering strain increments.
    """
    sig = vector_to_stress(np.asarray(stress, dtype=float))
    G = np.zeros((6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = 1.0
        E = vector_to_strain(e)
        G[:, k] = stress_to_vector(-0.5 * (sig @ E + E @ sig) + sig * np.trace(E))
    return G

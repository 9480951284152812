"""Affine (kinematic-hypothesis) stiffness of a contact network, seed Eq. 2.26."""

from __future__ import annotations

import numpy as np

from grainmech.assembly import ContactSet, stiffness
from grainmech.network.data import ContactNetwork

__all__ = ["affine_stiffness", "strain_map", "contact_matrix", "effective_ks"]


def effective_ks(net: ContactNetwork, ks: np.ndarray, geometric: bool) -> np.ndarray:
    """Tangential stiffness used in the assembly, (C,) [force/length].

    ``ks`` itself, or with ``geometric=True`` ``ks - N/|l|``: the rotation of a pre-loaded
    normal force ``N`` with the branch vector adds ``-(N/|l|) (I - n n)`` to the contact
    stiffness (Bagi 2007; Kruyt 2003), which may make the result negative.
    """
    if not geometric:
        return np.asarray(ks, float)
    return np.asarray(ks, float) - net.normal_force / net.branch_length


def contact_matrix(n: np.ndarray, kn: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """Contact stiffness matrices ``K`` (C, d, d) [force/length] (seed Eq. 2.20).

    Contact stiffness ``K = kn n (x) n + ks (I - n (x) n)`` (seed Eq. 2.20 with the full
    tangential projector), (C, d, d) [force/length].
    """
    d = n.shape[1]
    nn = n[:, :, None] * n[:, None, :]
    return (kn - ks)[:, None, None] * nn + ks[:, None, None] * np.eye(d)[None]


def strain_map(branch: np.ndarray) -> np.ndarray:
    """Per-contact map ``E_c`` (C, d, m) from the Voigt strain vector to ``eps . l``.

    ``(eps . l)_i = sum_a E[c, i, a] e_a`` with ``e = (e_xx, e_yy, e_zz, 2e_yz, 2e_xz,
    2e_xy)`` (3D) or ``(e_xx, e_yy, 2e_xy)`` (2D): under the kinematic hypothesis (seed
    Eq. 2.13) this is the displacement of A relative to B (compression positive).
    """
    l_ = np.asarray(branch, float)
    C, d = l_.shape
    if d == 3:
        E = np.zeros((C, 3, 6))
        E[:, 0, 0] = l_[:, 0]
        E[:, 1, 1] = l_[:, 1]
        E[:, 2, 2] = l_[:, 2]
        E[:, 1, 3] = 0.5 * l_[:, 2]
        E[:, 2, 3] = 0.5 * l_[:, 1]
        E[:, 0, 4] = 0.5 * l_[:, 2]
        E[:, 2, 4] = 0.5 * l_[:, 0]
        E[:, 0, 5] = 0.5 * l_[:, 1]
        E[:, 1, 5] = 0.5 * l_[:, 0]
    else:
        E = np.zeros((C, 2, 3))
        E[:, 0, 0] = l_[:, 0]
        E[:, 1, 1] = l_[:, 1]
        E[:, 0, 2] = 0.5 * l_[:, 1]
        E[:, 1, 2] = 0.5 * l_[:, 0]
    return E


def affine_stiffness(net: ContactNetwork, kn: np.ndarray, ks: np.ndarray, *,
                     geometric: bool = False, mandel: bool = False) -> np.ndarray:
    """Affine (kinematic-hypothesis) stiffness of the network, seed Eq. 2.26.

    ``C_ijkl = sym (1/V) sum_c K_ik l_j l_l`` with ``K = kn n n + ks (I - n n)`` (full
    tangential projector), every contact once with its branch vector, assembled by
    :func:`grainmech.assembly.stiffness`.

    Parameters
    ----------
    net : ContactNetwork
    kn, ks : arrays (C,)
        Contact stiffnesses [force/length] (see :func:`contact_stiffnesses`).
    geometric : bool
        Add ``-(N/|l|) (I - n n)`` to ``K`` (:func:`effective_ks`); default stiffness
        terms only.
    mandel : bool
        Mandel instead of Voigt matrix.

    Returns
    -------
    array (6, 6) (3D) or (3, 3) (2D)
        Library order ``(xx, yy, zz, yz, xz, xy)``, Voigt [stress].

    Notes
    -----
    The tensor is linear in ``(kn, ks)``. A negative effective ``ks`` (geometric term
    larger than ``ks``) is assembled as ``C(kn, ks+) - C(0, ks-)`` with
    ``ks = ks+ - ks-``, both parts non-negative as the assembly requires.
    """
    kn = np.asarray(kn, float)
    ks_e = effective_ks(net, ks, geometric)
    w = np.asarray(1.0 / net.volume)  # one weight for every contact (0-d: broadcast)
    neg = ks_e < 0
    C = stiffness(ContactSet(net.normals, net.branch, w, kn, np.where(neg, 0.0, ks_e)), mandel=mandel)
    if np.any(neg):
        C = C - stiffness(ContactSet(net.normals, net.branch, w, np.zeros_like(kn), np.where(neg, -ks_e, 0.0)),
                          mandel=mandel)
    return C

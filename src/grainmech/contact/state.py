"""Contact state and response arrays of the contact laws, and the state constructors.

Structure of arrays, contact axis first (``n`` contacts, ``dim`` in 1..3). The law that
advances a state is :func:`grainmech.contact.update` (:mod:`grainmech.contact.law`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from grainmech.contact.forms import law_forms
from grainmech.contact.params import ContactParams

__all__ = ["ContactState", "ContactResponse", "initial_state", "state_from_normal_force",
           "state_from_approach", "state_from_forces", "reversal_forces", "law_kind", "max_reversals"]

class ContactState(NamedTuple):
    """State of ``n`` contacts (structure of arrays, contact axis first).

    Attributes
    ----------
    approach : ndarray, shape (n,)
        Cumulative normal approach ``alpha`` [m]; ``<= 0`` means open (gap ``-alpha``).
    normal_force : ndarray, shape (n,)
        ``N >= 0`` [N] (per unit length for rods).
    tangential_force : ndarray, shape (n, dim)
        Tangential force vector ``T`` in the global frame [N].
    axis : ndarray, shape (n, dim)
        Unit memory (slip) axis ``e`` of the hysteretic law; zero while undefined.
    direction : ndarray of int8, shape (n,)
        ``s = +-1``: direction along ``e`` of the current branch.
    depth : ndarray of int32, shape (n,)
        Number ``k`` of remembered (still open) load reversals.
    reversals : ndarray, shape (n, max_reversals)
        Invariants ``P_j = mu N + s_j tau_j`` of the remembered reversals, ``j < k``
        (see :func:`reversal_forces` for the forces ``T*``, ``T**`` themselves).
    sliding : ndarray of bool, shape (n,)
        ``|T| = mu N`` (gross sliding) at the end of the last step.
    dissipated_energy : ndarray, shape (n,)
        Cumulative frictional dissipation [J].
    """

    approach: np.ndarray
    normal_force: np.ndarray
    tangential_force: np.ndarray
    axis: np.ndarray
    direction: np.ndarray
    depth: np.ndarray
    reversals: np.ndarray
    sliding: np.ndarray
    dissipated_energy: np.ndarray

    @property
    def n_contacts(self) -> int:
        """Number of contacts ``n``."""
        return int(self.approach.shape[0])

    @property
    def dim(self) -> int:
        """Dimension of the tangential vectors (2 or 3)."""
        return int(self.tangential_force.shape[1])

    @property
    def open(self) -> np.ndarray:
        """Contacts without compression (``alpha <= 0``)."""
        return self.approach <= 0.0

    def take(self, index: ArrayLike) -> ContactState:
        """Sub-state of the contacts ``index`` (copies)."""
        idx = np.asarray(index)
        return ContactState(*(np.array(f[idx]) for f in self))


class ContactResponse(NamedTuple):
    """What the assembly needs from one step of the law.

    Attributes
    ----------
    normal_force : ndarray, shape (n,)
        ``N`` at the end of the step [N].
    tangential_force : ndarray, shape (n, dim)
        ``T`` at the end of the step [N].
    kn : ndarray, shape (n,)
        Tangent normal stiffness ``dN/dalpha`` (seed Eq. 3.7 / 3.8) [N/m]; 0 when open.
    ks : ndarray, shape (n,)
        Tangent tangential stiffness along the slip axis (seed Eq. 3.11:
        ``8 G* a theta`` with theta of the current branch, Eq. 3.13-3.15; theta = 1 after
        a no-slip step of rising ``N``, Eq. 3.10; 0 when sliding or open) [N/m].
    ks_perp : ndarray, shape (n,)
        Tangent stiffness across the slip axis (no-slip value ``8 G* a``) [N/m].
        For a contact with no tangential force ``ks == ks_perp``, so the isotropic form
        ``ks (I - n n)`` is exact there.
    ktn : ndarray, shape (n,)
        Coupling ``d tau / d alpha = s mu (1 - theta) kn`` along the slip axis [N/m]
        (Thornton & Randall's ``mu dN (1 - theta)`` term).
    axis : ndarray, shape (n, dim)
        Unit slip axis ``e`` (zero if undefined); ``T = tau e + T_perp``.
    sliding : ndarray of bool, shape (n,)
        ``|T| = mu N``.
    open : ndarray of bool, shape (n,)
        Contact open at the end of the step.
    dissipation : ndarray, shape (n,)
        Energy dissipated during the step (>= 0) [J].
    t_delta : ndarray, shape (n, dim, dim), optional
        Step tangent ``dT1 / d d_t``: derivative of the end-of-step tangential force with
        respect to the step's tangential displacement (in the tangent plane) [N/m].
    t_alpha : ndarray, shape (n, dim), optional
        Step tangent ``dT1 / d alpha``: derivative with respect to the step's normal
        approach [N/m]. With ``t_delta``: the consistent (algorithmic) tangent of the
        update, ``df = (kn n + t_alpha) n^T + t_delta (I - n n)`` for ``f = N n + T``;
        ``None`` for a response not produced by a step (``ContactLaw.response``).
    """

    normal_force: np.ndarray
    tangential_force: np.ndarray
    kn: np.ndarray
    ks: np.ndarray
    ks_perp: np.ndarray
    ktn: np.ndarray
    axis: np.ndarray
    sliding: np.ndarray
    open: np.ndarray
    dissipation: np.ndarray
    t_delta: np.ndarray | None = None
    t_alpha: np.ndarray | None = None


# ---------------------------------------------------------------------------------------
# Law kind
# ---------------------------------------------------------------------------------------
def law_kind(params: ContactParams) -> str:
    """``"md"`` (hysteretic memory law), ``"jenkins"`` (elastic + Coulomb) or ``"frictionless"``."""
    return law_forms(params).kind


def max_reversals(params: ContactParams) -> int:
    """Reversal memory of the law's state (``max_reversals`` of a hysteretic law, else 0)."""
    return law_forms(params).max_reversals


# ---------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------
def row_dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise dot product, summed in a fixed order (results independent of n)."""
    out = u[:, 0] * v[:, 0]
    for j in range(1, u.shape[1]):
        out = out + u[:, j] * v[:, j]
    return out


def row_norm(v: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean norm, from :func:`row_dot` (results independent of n)."""
    return np.sqrt(row_dot(v, v))


# ---------------------------------------------------------------------------------------
# State constructors
# ---------------------------------------------------------------------------------------
def _empty_state(params: ContactParams, n: int, dim: int) -> ContactState:
    if dim not in (1, 2, 3):
        raise ValueError(f"dim must be 1, 2 or 3, got {dim!r}")
    if n < 0:
        raise ValueError(f"n_contacts must be >= 0, got {n!r}")
    m = max_reversals(params)
    return ContactState(
        approach=np.zeros(n),
        normal_force=np.zeros(n),
        tangential_force=np.zeros((n, dim)),
        axis=np.zeros((n, dim)),
        direction=np.ones(n, dtype=np.int8),
        depth=np.zeros(n, dtype=np.int32),
        reversals=np.zeros((n, m)),
        sliding=np.zeros(n, dtype=bool),
        dissipated_energy=np.zeros(n),
    )


def initial_state(params: ContactParams, n_contacts: int, dim: int = 3) -> ContactState:
    """State of ``n_contacts`` virgin contacts just touching (``alpha = N = T = 0``).

    Parameters
    ----------
    params : contact parameter object
    n_contacts : int
    dim : {1, 2, 3}
        Dimension of the tangential vectors (3 for 3D assemblies; 2 for planar ones,
        where the tangent line is 1D; 1 for a scalar tangential law).
    """
    law_kind(params)
    return _empty_state(params, int(n_contacts), int(dim))


def state_from_approach(params: ContactParams, approach: ArrayLike, dim: int = 3) -> ContactState:
    """Virgin contacts (no tangential force, no memory) at a given approach.

    Parameters
    ----------
    approach : array_like, shape (n,)
        ``alpha`` [m]; ``<= 0`` gives open contacts.
    """
    alpha = np.atleast_1d(np.asarray(approach, dtype=float)).copy()
    if alpha.ndim != 1:
        raise ValueError(f"approach must be 1-D, got shape {alpha.shape}")
    if not np.all(np.isfinite(alpha)):
        raise ValueError("approach must be finite")
    st = _empty_state(params, alpha.shape[0], int(dim))
    N = law_forms(params).normal_force(alpha)
    return st._replace(approach=alpha, normal_force=N)


def state_from_normal_force(params: ContactParams, normal_force: ArrayLike, dim: int = 3) -> ContactState:
    """Virgin contacts compressed by given normal forces (e.g. an isotropic state).

    Parameters
    ----------
    normal_force : array_like, shape (n,)
        ``N >= 0`` [N] (per unit length for rods). The approach follows from the normal
        law (seed Eq. 3.1 for spheres, the integral of Eq. 3.8 for rods).
    """
    N = np.atleast_1d(np.asarray(normal_force, dtype=float)).copy()
    if N.ndim != 1:
        raise ValueError(f"normal_force must be 1-D, got shape {N.shape}")
    if not np.all(np.isfinite(N)) or np.any(N < 0):
        raise ValueError("normal_force must be finite and >= 0")
    alpha = law_forms(params).approach_from_force(N)
    st = _empty_state(params, N.shape[0], int(dim))
    return st._replace(approach=alpha, normal_force=N)


def state_from_forces(params: ContactParams, normal_force: ArrayLike, tangential_force: ArrayLike,
                      dim: int | None = None) -> ContactState:
    """Contacts at given normal and tangential forces, reached by monotonic loading.

    Each contact is placed on its virgin (skeleton) branch at ``|T|`` along ``T/|T|``:
    no reversal remembered, memory axis ``T/|T|`` (seed Eq. 3.13 then gives the tangent).

    Parameters
    ----------
    normal_force : array_like, shape (n,)
        ``N >= 0``.
    tangential_force : array_like, shape (n, dim)
        ``T`` with ``|T| <= mu N`` (in the tangent plane; the caller projects).
    dim : int, optional
        Defaults to ``tangential_force.shape[1]``.

    Raises
    ------
    ValueError
        If ``|T| > mu N`` for some contact (the message names ``tangential_force``).
    """
    T = np.asarray(tangential_force, dtype=float)
    if T.ndim != 2:
        raise ValueError(f"tangential_force must have shape (n, dim), got {T.shape}")
    d = T.shape[1] if dim is None else int(dim)
    st = state_from_normal_force(params, normal_force, dim=d)
    if T.shape != st.tangential_force.shape:
        raise ValueError(f"tangential_force must have shape {st.tangential_force.shape}, got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ValueError("tangential_force must be finite")
    mag = row_norm(T)
    muN = float(params.friction) * st.normal_force if law_kind(params) != "frictionless" \
        else np.zeros_like(mag)
    bad = mag > muN * (1.0 + 1e-12)
    if np.any(bad):
        i = int(np.nonzero(bad)[0][0])
        raise ValueError(f"tangential_force: |T| = {mag[i]:.6g} exceeds mu N = {muN[i]:.6g} "
                         f"at contact {i}")
    with np.errstate(divide="ignore", invalid="ignore"):
        axis = np.where((mag > 0)[:, None], T / np.where(mag > 0, mag, 1.0)[:, None], 0.0)
    sliding = (mag > 0) & (mag >= muN * (1.0 - 1e-12))
    return st._replace(tangential_force=T.copy(), axis=axis, sliding=sliding)


def reversal_forces(params: ContactParams, state: ContactState) -> np.ndarray:
    """Remembered reversal forces ``T_j`` (along the memory axis), NaN-padded.

    ``T_j = s_j (P_j - mu N)`` with ``s_j = s (-1)^(k-1-j)`` the direction of the branch
    that started at reversal ``j``. For a single closed cycle these are the seed's ``T*``
    (``j`` with ``s_j = -1``) and ``T**`` (``s_j = +1``), shifted by ``+- mu dN`` since
    they were recorded, as Thornton & Randall prescribe.

    Returns
    -------
    ndarray, shape (n, max_reversals)
    """
    m = state.reversals.shape[1]
    j = np.arange(m)[None, :]
    k = state.depth[:, None]
    sj = state.direction[:, None].astype(float) * np.where((k - 1 - j) % 2 == 0, 1.0, -1.0)
    muN = params.friction * state.normal_force[:, None]
    out = sj * (state.reversals - muN)
    return np.where(j < k, out, np.nan)

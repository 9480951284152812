r"""Incremental contact laws: ``update(params, state, d_normal, d_tangential)``.

Every law is a pure function over a *structure of arrays* (contact axis first): it
never modifies its input state, and applying it to ``n`` contacts gives what applying
it to each contact alone gives (to rounding). Laws: Mindlin–Deresiewicz and rods (below),
elastic tangential springs with a Coulomb cap (:class:`~grainmech.contact.LinearSpring`,
:class:`~grainmech.contact.HertzMindlin`), frictionless Hertz.

State and response
------------------
:class:`ContactState` holds, per contact, the approach ``alpha`` (cumulative; ``<= 0``
means open), the normal force ``N``, the tangential force vector ``T`` (global frame,
shape ``(n, dim)``), and for the hysteretic laws the memory of the tangential law (see
below). :class:`ContactResponse` returns the forces and the tangent stiffnesses the
assembly needs (``kn``, ``ks`` along the slip axis, ``ks_perp`` across it, and the
coupling ``ktn = dT/dalpha`` along the slip axis).

Normal laws
-----------
Hertz (seed Eq. 3.6), rods (integral of seed Eq. 3.8), linear springs. A contact that
would carry tension opens: ``N = T = 0`` and all memory is wiped; it closes again when
the approach becomes positive (the part of a step spent open is skipped: a step that
closes the contact applies the fraction ``alpha_new / (alpha_new - alpha_old)`` of the
tangential increment, a step that opens it first unloads ``N`` to zero).

Mindlin–Deresiewicz tangential law (seed Eq. 3.9–3.16)
------------------------------------------------------
Along the memory axis ``e`` the tangential force ``tau = T . e`` follows the rate law
of Thornton & Randall (1988), which the seed writes as Eq. 3.11:

.. math::

    d\tau = 8 G^* a\, \theta\, d\delta + s\, \mu\, dN\, (1 - \theta)

with ``s = +1`` on a loading and ``-1`` on an unloading branch (the seed's "negative sign
evoked during unloading"), and ``theta`` from Eq. 3.13–3.15. We write these in terms of
two *invariants* (the key to an exact and memory-safe implementation):

* the current state's distance from the friction limit it is moving towards,
  ``Q = mu N - s tau``;
* for every remembered reversal ``j`` (where a branch of direction ``s_j`` started at
  ``tau_j``), ``P_j = mu N + s_j tau_j``: its distance from the opposite limit.

Thornton & Randall's rule that ``T*`` and ``T**`` move by ``+- mu dN`` when ``N``
changes means exactly that every ``P_j`` is constant, and their "point 2" (Eq. 3.16) is
a change of ``N`` at constant ``Q``. With ``y`` defined by

* virgin (skeleton) branch, no reversal remembered: ``y = Q / (mu N)``, which is
  ``1 - |T|/(mu N)`` (Eq. 3.13);
* branch started at the last reversal ``k``: ``y = (Q + P_k) / (2 mu N)``, which is
  ``1 - |T - T_k| / (2 mu N)`` (Eq. 3.14, 3.15);

``theta = y**p`` with ``p = 1/3`` for spheres (and ``1/2`` for rods, Eq. 3.17).
At constant ``N`` ``z = y**(1-p)`` falls linearly with the displacement, so each branch
is integrated *exactly* (no step-size error at constant normal force); under a falling
``N`` at fixed displacement ``z - 1/c = (z_0 - 1/c) (N_0/N)**(1-p)`` (``c = 1`` virgin,
``2`` Masing), again exact. Events inside a step (a branch reaching the reversal point
that opened it, Masing's memory rule; a reversal erased by a falling ``N``; sliding)
are located exactly and the step continues on the next branch. When ``N`` rises, the
step follows Thornton & Randall: ``N`` (and ``a``) first, on the no-slip boundary
``dT = s mu dN`` (``d delta = mu r d alpha``, ``r = kn/kt0``), then the rest of the
displacement at the new ``N``. If ``|d delta| <= mu r d alpha`` (seed Eq. 3.10/3.16, i.e.
``8 G a |d delta| <= mu dN``) the whole step is elastic, ``dT = 8 G* a d delta``
(theta = 1), with ``a`` averaged along the step (exact for a straight step).

Across the memory axis the law is elastic with the no-slip stiffness (first-order
exact for any element at the Coulomb limit; Kuhn & Daouadji 2020), and the total force
is capped at ``|T| <= mu N`` by radial return, which wipes the memory. While no reversal
is remembered the axis follows the force. See ``docs/contact-laws.md`` for the
justification and for the memory depth.

Energy dissipated
-----------------
Rate ``mu N g(y) w / kt0`` with ``w = s kt0 d delta - mu dN > 0`` the slip driver and
``g(y) = 1 - y - (y**p - y)/(1 - p)`` (``(2 - 3 theta + theta^3)/2`` for spheres): the
Iwan (parallel-slider) representation of the loading curve, equal to the rate of the
method of dimensionality reduction (Popov & Hess 2015). It is never negative and its
integral over a closed cycle equals the loop area ``oint T d delta``.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from grainmech.contact import geometry as geo
from grainmech.contact._errors import ReversalMemoryError
from grainmech.contact.forms import law_forms

__all__ = [
    "ContactState",
    "ContactResponse",
    "initial_state",
    "state_from_normal_force",
    "state_from_approach",
    "state_from_forces",
    "update",
    "reversal_forces",
    "law_kind",
    "max_reversals",
    "compiled_kernel",
]

_EPS = 1e-12
#: Relative size (of ``2 mu N``) below which two tangential force levels of the hysteretic
#: law count as the same point. A branch that stops this close to the reversal point it
#: heads for has closed its loop (Masing's rule: the loop is erased), and a reversal this
#: close to the point where the current branch started is a wiggle (it pops instead of
#: pushing). Without it, memory grows without bound under plain symmetric cycling: a
#: loop that closes exactly at a step end is a tie decided by rounding, and when the
#: normal force drifts slowly (ratcheting at constant sigma_zz) each new reversal lands a
#: few 1e-8 mu N inside the previous one and is nested under it. Merging two levels this
#: close changes the tangential force by at most ``1e-6 * 2 mu N``, far below any
#: resolution of contact forces or stresses, and changes the loop area by a relative
#: amount of the same order.
_REV_TOL = 1e-6
#: When the reversal memory is full, the remembered loop that came closest to closing is
#: forgotten if its shortfall is at most this fraction of ``2 mu N`` (see
#: :func:`_merge_closest_loop`); a deeper, genuinely nested history stops the law with
#: :class:`~grainmech.contact.ReversalMemoryError`. Slow drift of the normal force under
#: constant-stress cycling nests loops whose ends differ by ~1e-6 ``mu N`` per cycle: the
#: reversal invariants ``P_j`` are constant (Thornton & Randall) while ``N`` ratchets, so
#: a branch at constant strain amplitude stops just short of the level it started from,
#: and without this rule 50 cycles at gamma = 1e-4 and constant sigma_zz (5810 directions)
#: exhaust 16 levels after about 9 cycles. Forgetting a loop moves every later force by at
#: most its shortfall, i.e. by at most 0.1 % of the friction limit ``2 mu N`` of the loop.
_MERGE_TOL = 1e-3
#: Gauss–Legendre rule for the dissipation while N falls (integrand smooth, >= 0)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)


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
        return int(self.approach.shape[0])

    @property
    def dim(self) -> int:
        return int(self.tangential_force.shape[1])

    @property
    def open(self) -> np.ndarray:
        """Contacts without compression (``alpha <= 0``)."""
        return self.approach <= 0.0

    def take(self, index: ArrayLike) -> "ContactState":
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


# ---------------------------------------------------------------------------------------
# Per-law closed forms (normal law and no-slip tangential stiffness)
# ---------------------------------------------------------------------------------------
def law_kind(params: object) -> str:
    """``"md"`` (hysteretic memory law), ``"jenkins"`` (elastic + Coulomb) or ``"frictionless"``."""
    return law_forms(params).kind


def max_reversals(params: object) -> int:
    """Reversal memory of the law's state (``max_reversals`` of a hysteretic law, else 0)."""
    return law_forms(params).max_reversals


def _secant_kt(params: object, N0: np.ndarray, N1: np.ndarray, a0: np.ndarray,
               a1: np.ndarray) -> np.ndarray:
    """Mean no-slip stiffness along a straight step: ``int kt0 dalpha / dalpha = dN / (r dalpha)``.

    Exact for a step that is straight in (alpha, delta) because ``kt0 = kn / r`` and
    ``kn = dN/dalpha``. Falls back to ``kt0(N1)`` when the approach does not change.
    """
    forms = law_forms(params)
    if forms.linear:
        return np.where((N0 > 0) | (N1 > 0), params.ks, 0.0)  # type: ignore[attr-defined]
    r = forms.ratio
    da = a1 - a0
    dN = N1 - N0
    ok = np.abs(da) > 1e-14 * np.maximum(np.abs(a0), np.abs(a1))
    with np.errstate(divide="ignore", invalid="ignore"):
        sec = np.where(ok, dN / (r * np.where(ok, da, 1.0)), 0.0)
    return np.where(ok, sec, forms.kt0(N1))


# ---------------------------------------------------------------------------------------
# State constructors
# ---------------------------------------------------------------------------------------
def _empty_state(params: object, n: int, dim: int) -> ContactState:
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


def initial_state(params: object, n_contacts: int, dim: int = 3) -> ContactState:
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


def state_from_approach(params: object, approach: ArrayLike, dim: int = 3) -> ContactState:
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


def state_from_normal_force(params: object, normal_force: ArrayLike, dim: int = 3) -> ContactState:
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


def state_from_forces(params: object, normal_force: ArrayLike, tangential_force: ArrayLike,
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
    mag = _norm(T)
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


def reversal_forces(params: object, state: ContactState) -> np.ndarray:
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
    muN = params.friction * state.normal_force[:, None]  # type: ignore[attr-defined]
    out = sj * (state.reversals - muN)
    return np.where(j < k, out, np.nan)


# ---------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------
def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise dot product, summed in a fixed order (results independent of n)."""
    out = u[:, 0] * v[:, 0]
    for j in range(1, u.shape[1]):
        out = out + u[:, j] * v[:, j]
    return out


def _norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(_dot(v, v))


def _check_increments(state: ContactState, d_normal: ArrayLike,
                      d_tangential: ArrayLike, *, check_finite: bool = True
                      ) -> tuple[np.ndarray, np.ndarray]:
    n, dim = state.n_contacts, state.dim
    dn = np.asarray(d_normal, dtype=float)
    if dn.ndim == 0:
        dn = np.full(n, float(dn))
    if dn.shape != (n,):
        raise ValueError(f"d_normal must have shape ({n},), got {dn.shape}")
    dt = np.asarray(d_tangential, dtype=float)
    if dim == 1 and dt.shape == (n,):
        dt = dt[:, None]
    if dt.shape != (n, dim):
        raise ValueError(f"d_tangential must have shape ({n}, {dim}), got {dt.shape}")
    if check_finite:
        _check_finite(dn, dt)
    return dn, dt


def _check_finite(dn: np.ndarray, dt: np.ndarray, status: int | None = None) -> None:
    """Raise the errors of non-finite increments (``status`` from the compiled kernel)."""
    if (status == 1) if status is not None else not np.all(np.isfinite(dn)):
        raise ValueError("d_normal must be finite")
    if (status == 2) if status is not None else not np.all(np.isfinite(dt)):
        raise ValueError("d_tangential must be finite")


def _reproject(T: np.ndarray, e: np.ndarray, normals: ArrayLike | None) -> tuple[np.ndarray, np.ndarray]:
    """Rotate T and e into the plane normal to ``normals`` keeping their magnitudes."""
    if normals is None:
        return T, e
    nrm = np.asarray(normals, dtype=float)
    if nrm.shape != T.shape:
        raise ValueError(f"normals must have shape {T.shape}, got {nrm.shape}")
    ln = _norm(nrm)
    if np.any(ln <= 0) or not np.all(np.isfinite(ln)):
        raise ValueError("normals must be finite non-zero vectors")
    nrm = nrm / ln[:, None]

    def proj(v: np.ndarray) -> np.ndarray:
        vp = v - _dot(v, nrm)[:, None] * nrm
        a, b = _norm(v), _norm(vp)
        scale = np.where(b > 0, a / np.where(b > 0, b, 1.0), 0.0)
        return vp * scale[:, None]

    return proj(T), proj(e)


# ---------------------------------------------------------------------------------------
# Public entry point
# ---------------------------------------------------------------------------------------
def update(params: object, state: ContactState, d_normal: ArrayLike, d_tangential: ArrayLike,
           *, normals: ArrayLike | None = None, backend: str = "auto"
           ) -> tuple[ContactState, ContactResponse]:
    """Advance ``n`` contacts by one increment of relative displacement (pure function).

    Parameters
    ----------
    params : Hertz, HertzMindlin, MindlinDeresiewicz, LinearSpring or Cylinder
    state : ContactState
        State at the start of the increment (not modified).
    d_normal : array_like, shape (n,)
        Increment of approach ``d alpha`` [m] (positive closes the contact).
    d_tangential : array_like, shape (n, dim)
        Increment of tangential relative displacement [m], already projected on the
        tangent plane by the caller.
    normals : array_like, shape (n, dim), optional
        Current contact normals. If given, the stored tangential force and memory axis
        are first rotated into the current tangent plane (magnitudes kept), for contacts
        whose normal turns.
    backend : {"auto", "numpy", "numba"}
        ``numpy``: the vectorised reference implementation of this module. ``numba``:
        the compiled per-contact kernel of :mod:`grainmech.contact.kernel` (same
        algorithm, agrees to rounding; :class:`MindlinDeresiewicz`,
        :class:`HertzMindlin`, :class:`LinearSpring` and frictionless :class:`Hertz`;
        raises ``ValueError`` for other laws and ``ImportError`` without numba).
        ``auto`` (default): ``numba`` when numba is importable and the law is
        supported, else ``numpy``.

    Returns
    -------
    new_state : ContactState
    response : ContactResponse

    Raises
    ------
    ReversalMemoryError
        If a hysteretic contact needs more nested reversals than ``max_reversals``.
    ContactDomainError
        Rod contacts loaded beyond the validity of seed Eq. 3.8.
    """
    kind = law_kind(params)
    if state.reversals.shape[1] != max_reversals(params):
        raise ValueError(f"state was built for max_reversals = {state.reversals.shape[1]}, "
                         f"params have {max_reversals(params)}; build it with initial_state(params, ...)")
    kernel = compiled_kernel(params, backend)
    dn, dt = _check_increments(state, d_normal, d_tangential,
                               check_finite=kernel is None or normals is not None)
    T0, e0 = _reproject(state.tangential_force, state.axis, normals)
    if kernel is not None:
        return _update_compiled(kernel, params, state, T0, e0, dn, dt)

    alpha0 = state.approach
    alpha1 = alpha0 + dn
    N0 = state.normal_force
    N1 = law_forms(params).normal_force(alpha1)
    closed0 = alpha0 > 0.0
    closed1 = alpha1 > 0.0

    # A step that closes an open contact: only the part of the path in contact counts.
    closing = closed1 & ~closed0
    frac = np.ones_like(alpha0)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(closing, alpha1 / (alpha1 - alpha0), 1.0)
    a0_eff = np.where(closing, 0.0, alpha0)
    N0_eff = np.where(closed0, N0, 0.0)
    dt_eff = dt * frac[:, None]
    virgin_reset = ~closed0  # an open contact has no tangential force and no memory
    T0 = np.where(virgin_reset[:, None], 0.0, T0)

    if kind == "md":
        out = _md_update(params, state, T0, e0, N0_eff, N1, a0_eff, alpha1, dt_eff, virgin_reset)
    elif kind == "jenkins":
        out = _jenkins_update(params, T0, N0_eff, N1, a0_eff, alpha1, dt_eff)
    else:
        out = _frictionless_update(params, T0, N1)
    T1, e1, s1, k1, P1, slide, diss, ks, ks_perp, ktn = out

    kn = law_forms(params).kn(N1)
    new_state = ContactState(
        approach=alpha1,
        normal_force=N1,
        tangential_force=T1,
        axis=e1,
        direction=s1,
        depth=k1,
        reversals=P1,
        sliding=slide,
        dissipated_energy=state.dissipated_energy + diss,
    )
    resp = ContactResponse(
        normal_force=N1,
        tangential_force=T1,
        kn=kn,
        ks=ks,
        ks_perp=ks_perp,
        ktn=ktn * kn,
        axis=e1,
        sliding=slide,
        open=~closed1,
        dissipation=diss,
    )
    return new_state, resp


# ---------------------------------------------------------------------------------------
# Compiled backend (grainmech.contact.kernel): selection and dispatch
# ---------------------------------------------------------------------------------------
_BACKENDS = ("auto", "numpy", "numba")
_KERNEL: object = None   # the module once imported; False if numba is unavailable


def _load_kernel() -> object:
    """Import :mod:`grainmech.contact.kernel` once (``False`` when numba is missing)."""
    global _KERNEL
    if _KERNEL is None:
        try:
            from grainmech.contact import kernel
        except ImportError:
            _KERNEL = False
        else:
            _KERNEL = kernel
    return _KERNEL


def compiled_kernel(params: object, backend: str = "auto") -> object:
    """The compiled kernel module (:mod:`grainmech.contact.kernel`) for ``backend``, or ``None``.

    Parameters
    ----------
    params : contact parameter object
    backend : {"auto", "numpy", "numba"}
        ``numpy``: always ``None`` (the reference path). ``auto``: the kernel when numba is
        importable and supports the law (spheres and linear springs, not rods), else
        ``None``. ``numba``: the kernel, or an error.

    Raises
    ------
    ValueError
        Unknown ``backend``, or ``numba`` for a law the kernel does not support.
    ImportError
        ``numba`` requested but numba is not importable.
    """
    if backend == "numpy":
        return None
    if backend not in _BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(map(repr, _BACKENDS))}, got {backend!r}")
    supported = law_forms(params).compiled
    if backend == "numba":
        if not supported:
            raise ValueError(f"backend='numba' does not support {type(params).__name__} "
                             f"(use backend='numpy' or 'auto')")
        mod = _load_kernel()
        if mod is False:
            raise ImportError("backend='numba' needs numba, which is not importable")
        return mod
    if not supported:
        return None
    mod = _load_kernel()
    return None if mod is False else mod


def _update_compiled(kernel: object, params: object, state: ContactState, T0: np.ndarray,
                     e0: np.ndarray, dn: np.ndarray, dt: np.ndarray
                     ) -> tuple[ContactState, ContactResponse]:
    """:func:`update` through the compiled kernel (validated, re-projected inputs)."""
    def c(x: np.ndarray, dtype: object) -> np.ndarray:
        # C-contiguous and writeable (a read-only array would compile another variant)
        x = np.ascontiguousarray(x, dtype=dtype)
        return x if x.flags.writeable else x.copy()

    K = kernel  # type: Any
    forms = law_forms(params)
    alpha0 = c(state.approach, dtype=float)
    dn = c(dn, dtype=float)
    # the closed forms of the normal law, vectorised as in the reference path
    N1 = forms.normal_force(alpha0 + dn)
    if forms.linear:
        rad0 = rad1 = N1
    else:
        rad1 = geo.hertz_contact_radius_from_force(N1, params)  # type: ignore[arg-type]
        rad0 = geo.hertz_contact_radius_from_force(
            np.where(alpha0 > 0.0, state.normal_force, 0.0), params)  # type: ignore[arg-type]
    st = K.KernelState(alpha0, c(state.normal_force, dtype=float), c(T0, dtype=float),
                       c(e0, dtype=float), c(state.direction, dtype=np.int8),
                       c(state.depth, dtype=np.int32), c(state.reversals, dtype=float),
                       c(state.dissipated_energy, dtype=float))
    status, out, flags = K.update_kernel(K.constants(params), st,
                                         K.KernelIncrement(dn, c(dt, dtype=float), N1, rad0, rad1))
    if status:
        _check_finite(dn, dt, status)
    if flags.any():
        for code in (1, 2):  # the reference raises for the rising-N reversals first
            bad = np.nonzero(flags == code)[0]
            if bad.size:
                raise ReversalMemoryError(bad, max_reversals(params))
        raise RuntimeError("Mindlin-Deresiewicz branch integration did not terminate")  # pragma: no cover
    new_state = ContactState(out.approach, out.normal_force, out.tangential_force, out.axis,
                             out.direction, out.depth, out.reversals, out.sliding,
                             st.dissipated_energy + out.dissipation)
    resp = ContactResponse(out.normal_force, out.tangential_force, out.kn, out.ks, out.ks_perp,
                           out.ktn, out.axis, out.sliding, out.open, out.dissipation)
    return new_state, resp


# ---------------------------------------------------------------------------------------
# Frictionless and elastic–Coulomb (Jenkins) tangential laws
# ---------------------------------------------------------------------------------------
_LawOut = tuple  # (T1, e1, s1, k1, P1, sliding, dissipation, ks, ks_perp, ktn/kn)


def _frictionless_update(params: object, T0: np.ndarray, N1: np.ndarray) -> _LawOut:
    n, dim = T0.shape
    z = np.zeros(n)
    return (np.zeros((n, dim)), np.zeros((n, dim)), np.ones(n, dtype=np.int8),
            np.zeros(n, dtype=np.int32), np.zeros((n, 0)), np.zeros(n, dtype=bool),
            z, z.copy(), z.copy(), z.copy())


def _jenkins_update(params: object, T0: np.ndarray, N0: np.ndarray, N1: np.ndarray, a0: np.ndarray,
                    a1: np.ndarray, dt: np.ndarray) -> _LawOut:
    """Elastic tangential spring with Coulomb cap and radial return.

    ``T_trial = rho T_old + kbar d_delta``; ``rho = kt(N1)/kt(N0) < 1`` when the contact
    area shrinks (Thornton, Cummins & Cleary 2013, Eq. 18b), else 1; ``kbar`` the mean
    no-slip stiffness along the step. ``|T| <= mu N`` by radial return; the energy lost
    in the rescaling and in the slip is counted as dissipation.
    """
    n, dim = T0.shape
    mu = params.friction
    kt0 = law_forms(params).kt0(N0)
    kt1 = law_forms(params).kt0(N1)
    closed1 = N1 > 0.0
    rising = N1 > N0
    kbar = np.where(rising, _secant_kt(params, N0, N1, a0, a1), kt1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where((kt0 > 0) & (kt1 < kt0), kt1 / np.where(kt0 > 0, kt0, 1.0), 1.0)
        Tn0 = _norm(T0)
        diss = np.where(kt0 > 0, (1.0 - rho) * Tn0 ** 2 / (2.0 * np.where(kt0 > 0, kt0, 1.0)), 0.0)
    trial = rho[:, None] * T0 + kbar[:, None] * dt
    tn = _norm(trial)
    cap = mu * N1 if math.isfinite(mu) else np.full(n, np.inf)
    cap = np.where(closed1, cap, 0.0)
    over = tn > cap
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(over, cap / np.where(tn > 0, tn, 1.0), 1.0)
        slip = np.where(over & (kt1 > 0), (tn - cap) / np.where(kt1 > 0, kt1, 1.0), 0.0)
        diss = diss + np.where(over, np.where(over, cap, 0.0) * slip, 0.0)
    T1 = trial * scale[:, None]
    # energy of a spring that loses contact (stiffness -> 0 or cap -> 0) is dissipated
    T1 = np.where(closed1[:, None], T1, 0.0)
    t1n = _norm(T1)
    with np.errstate(divide="ignore", invalid="ignore"):
        e1 = np.where((t1n > 0)[:, None], T1 / np.where(t1n > 0, t1n, 1.0)[:, None], 0.0)
    # "sliding" = at the Coulomb limit after the step (as for the hysteretic law)
    slide = closed1 & (cap > 0) & (t1n >= cap * (1.0 - 1e-12))
    if math.isfinite(mu):
        slide = slide | (closed1 & (mu == 0.0))
    ks = np.where(slide | ~closed1, 0.0, kt1)
    ks_perp = np.where(closed1, kt1, 0.0)
    ktn = np.where(slide, mu if math.isfinite(mu) else 0.0, 0.0)
    return (T1, e1, np.ones(n, dtype=np.int8), np.zeros(n, dtype=np.int32), np.zeros((n, 0)),
            slide, diss, ks, ks_perp, ktn)


# ---------------------------------------------------------------------------------------
# Mindlin–Deresiewicz (and rod) hysteretic law
# ---------------------------------------------------------------------------------------
class _Stack:
    """Copy-on-write view of the reversal invariants (the input state is never written)."""

    def __init__(self, P: np.ndarray) -> None:
        self.P = P
        self.copied = False

    def write(self, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray) -> None:
        if not self.copied:
            self.P = self.P.copy()
            self.copied = True
        self.P[rows, cols] = vals


def _merge_closest_loop(stack: _Stack, row: int, k: int, Q: float, muN: float) -> int:
    """Full memory: forget the remembered loop that came closest to closing; new depth.

    Remembered levels ``P_0 .. P_{k-1}`` and the reversal about to be pushed
    (``P_k = Q``) alternate in direction; ``|P_j - P_{j+2}|`` is how far the branch from
    reversal ``j + 1`` stopped short of closing the loop ``(j, j + 1)`` (Masing's rule
    erases a loop whose branch reaches its start). The pair with the smallest shortfall is
    erased as if it had closed, which moves later forces by at most that shortfall. Done
    only when it is at most :data:`_MERGE_TOL` ``* 2 mu N``; otherwise the depth is
    returned unchanged and the caller reports the exhausted memory.
    """
    if k < 2:
        return k
    levels = np.append(stack.P[row, :k], Q)
    gaps = np.abs(levels[:-2] - levels[2:])
    j = int(np.argmin(gaps))
    if gaps[j] > _MERGE_TOL * 2.0 * muN:
        return k
    keep = np.r_[stack.P[row, :j], stack.P[row, j + 2:k]]
    if not stack.copied:
        stack.P = stack.P.copy()
        stack.copied = True
    stack.P[row, :k - 2] = keep
    return k - 2


def _top(P: np.ndarray, rows: np.ndarray, k: np.ndarray, back: int) -> np.ndarray:
    """``P[row, k - back]`` where ``k - back >= 0``, else 0."""
    col = k - back
    ok = col >= 0
    out = np.zeros(rows.shape[0])
    if P.shape[1] and np.any(ok):
        out[ok] = P[rows[ok], col[ok]]
    return out


def _binom(a: float, k: int) -> float:
    out = 1.0
    for j in range(k):
        out *= (a - j) / (j + 1)
    return out


_SERIES_TERMS = 12


def _h_series(m: float) -> np.ndarray:
    """Coefficients of ``H(z) = int_z^1 g = sum_k c_k eps^(k+1)``, ``eps = 1 - z``."""
    c = np.zeros(_SERIES_TERMS + 1)
    for k in range(2, _SERIES_TERMS + 1):
        a_k = (-1.0) ** k * ((m - 1.0) * _binom(m, k) - m * _binom(m - 1.0, k))
        c[k] = a_k / (k + 1)
    return c


def _g_series(p: float) -> np.ndarray:
    """Coefficients of ``g(y) = sum_k b_k eps^k``, ``eps = 1 - y`` (starts at k = 2: g ~ p eps^2/2)."""
    b = np.zeros(_SERIES_TERMS + 1)
    for k in range(2, _SERIES_TERMS + 1):
        b[k] = -_binom(p, k) * (-1.0) ** k / (1.0 - p)
    return b


def _H(z: np.ndarray, m: float) -> np.ndarray:
    """``H(z) = int_z^1 g(z') dz'`` with ``g(z) = 1 + (m-1) z^m - m z^(m-1)`` (``m = 1/(1-p)``).

    ``g`` is the fraction of ``mu N`` carried by slipping elements, written in ``z``;
    ``H`` vanishes like ``(1-z)^3`` at ``z = 1``, so a series is used there to avoid
    cancellation (results then do not depend on rounding of the power function).
    """
    z = np.clip(z, 0.0, 1.0)
    eps = 1.0 - z
    G1 = 1.0 + (m - 1.0) / (m + 1.0) - 1.0
    direct = G1 - (z + (m - 1.0) * z ** (m + 1.0) / (m + 1.0) - z ** m)
    coef = _h_series(m)
    # sum_k c_k eps^(k+1)
    ser = np.zeros_like(eps)
    for k in range(len(coef) - 1, 1, -1):
        ser = ser * eps + coef[k]
    ser = ser * eps ** 3
    return np.where(eps < 0.05, ser, direct)


def _g_of_y(y: np.ndarray, p: float) -> np.ndarray:
    """Fraction of ``mu N`` carried by the slipping elements: ``1 - y - (y^p - y)/(1-p)``."""
    y = np.clip(y, 0.0, 1.0)
    eps = 1.0 - y
    direct = 1.0 - y - (y ** p - y) / (1.0 - p)
    b = _g_series(p)
    ser = np.zeros_like(eps)
    for k in range(len(b) - 1, 1, -1):
        ser = ser * eps + b[k]
    ser = ser * eps ** 2
    return np.maximum(np.where(eps < 0.02, ser, direct), 0.0)


def _md_update(params: object, state: ContactState, T0: np.ndarray, e0: np.ndarray, N0: np.ndarray,
               N1: np.ndarray, a0: np.ndarray, a1: np.ndarray, dt: np.ndarray,
               virgin_reset: np.ndarray) -> _LawOut:
    """Hysteretic law in 3D: scalar law along the memory axis, elastic across (module notes)."""
    n, dim = T0.shape
    mu = float(params.friction)
    p = float(params.stick_exponent)
    m_exp = 1.0 / (1.0 - p)
    r = law_forms(params).ratio
    maxrev = max_reversals(params)

    s = np.where(virgin_reset, 1, state.direction).astype(np.int8)
    k = np.where(virgin_reset, 0, state.depth).astype(np.int32)
    stack = _Stack(state.reversals)
    diss = np.zeros(n)

    # ---- memory axis: a contact with no force and no memory takes the direction of motion
    tn0 = _norm(T0)
    dtn = _norm(dt)
    fresh = (k == 0) & (tn0 == 0.0) & (dtn > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(fresh[:, None], dt / np.where(dtn > 0, dtn, 1.0)[:, None], e0)
    s = np.where(fresh, 1, s).astype(np.int8)
    e = np.where(virgin_reset[:, None] & ~fresh[:, None], 0.0, e)

    tau = _dot(T0, e)
    tperp = T0 - tau[:, None] * e
    d_par = _dot(dt, e)
    d_perp = dt - d_par[:, None] * e

    kt0_0 = law_forms(params).kt0(N0)
    kt0_1 = law_forms(params).kt0(N1)
    rising = N1 > N0
    falling = N1 < N0
    kbar = np.where(rising, _secant_kt(params, N0, N1, a0, a1), kt0_1)

    # ---- across the axis: elastic (no-slip) with rescaling when the area shrinks
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where((kt0_0 > 0) & (kt0_1 < kt0_0), kt0_1 / np.where(kt0_0 > 0, kt0_0, 1.0), 1.0)
        tp2 = _dot(tperp, tperp)
        diss += np.where(kt0_0 > 0, (1.0 - rho) * tp2 / (2.0 * np.where(kt0_0 > 0, kt0_0, 1.0)), 0.0)
    tperp = rho[:, None] * tperp + kbar[:, None] * d_perp

    # ---- along the axis: the 1D Mindlin–Deresiewicz / Thornton–Randall law
    if mu > 0.0:
        tau, s, k, d_diss, elastic = _md_axis(params, mu, p, m_exp, r, maxrev, stack, tau, s, k,
                                              N0, N1, a0, a1, kbar, kt0_1, d_par, rising, falling)
        diss += d_diss
    else:
        tau = np.zeros(n)
        k = np.zeros(n, dtype=np.int32)
        elastic = np.zeros(n, dtype=bool)

    muN1 = mu * N1
    closed1 = N1 > 0.0

    # ---- recombine, Coulomb cap on the total force (only the perpendicular part can break it)
    T1 = tau[:, None] * e + tperp
    t1n = _norm(T1)
    over = closed1 & (t1n > muN1 * (1.0 + 1e-12))
    if np.any(over):
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(over, muN1 / np.where(t1n > 0, t1n, 1.0), 1.0)
            slip = np.where(over & (kt0_1 > 0), (t1n - muN1) / np.where(kt0_1 > 0, kt0_1, 1.0), 0.0)
        diss += np.where(over, muN1 * slip, 0.0)
        T1 = T1 * scale[:, None]
        t1n = _norm(T1)
        with np.errstate(divide="ignore", invalid="ignore"):
            e = np.where(over[:, None], T1 / np.where(t1n > 0, t1n, 1.0)[:, None], e)
        tau = np.where(over, t1n, tau)
        s = np.where(over, 1, s).astype(np.int8)
        k = np.where(over, 0, k).astype(np.int32)
        tperp = np.where(over[:, None], 0.0, tperp)

    # ---- a force below the resolution of the law (1e-14 mu N, where Q = mu N - s tau
    # cannot resolve it) with no memory is a virgin contact: its axis is then reset, so
    # that a rounding residue never defines a memory axis
    t1n = _norm(T1)
    negligible = closed1 & (k == 0) & (t1n <= 1e-14 * muN1)
    if np.any(negligible):
        T1 = np.where(negligible[:, None], 0.0, T1)
        tau = np.where(negligible, 0.0, tau)
        tperp = np.where(negligible[:, None], 0.0, tperp)
        e = np.where(negligible[:, None], 0.0, e)
        s = np.where(negligible, 1, s).astype(np.int8)

    # ---- no reversal remembered: the memory axis follows the force
    realign = closed1 & (k == 0) & (_dot(tperp, tperp) > 0.0)
    if np.any(realign):
        t1n = _norm(T1)
        sg = np.where(_dot(T1, e) < 0.0, -1.0, 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            e_new = sg[:, None] * T1 / np.where(t1n > 0, t1n, 1.0)[:, None]
        e = np.where(realign[:, None], e_new, e)
        tau = np.where(realign, sg * t1n, tau)
        tperp = np.where(realign[:, None], 0.0, tperp)
        T1 = tau[:, None] * e + tperp
    # virgin branch is symmetric: s points away from zero force
    flip = (k == 0) & (s * tau < 0.0)
    s = np.where(flip, -s, s).astype(np.int8)

    # ---- opened contacts lose force and memory
    T1 = np.where(closed1[:, None], T1, 0.0)
    e = np.where(closed1[:, None], e, 0.0)
    s = np.where(closed1, s, 1).astype(np.int8)
    k = np.where(closed1, k, 0).astype(np.int32)

    # ---- tangents at the end of the step
    Ptop = _top(stack.P, np.arange(n), k, 1)
    c = np.where(k > 0, 2.0, 1.0)
    Q = muN1 - s * tau
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.where(muN1 > 0, (Q + Ptop) / (c * np.where(muN1 > 0, muN1, 1.0)), 0.0)
    y = np.clip(y, 0.0, 1.0)
    slide = closed1 & ((k == 0) & (Q <= _EPS * muN1) | (mu == 0.0))
    # tangent of the step: theta = 1 after a no-slip step of rising N (seed Eq. 3.10),
    # else seed Eq. 3.11 with theta of the current branch (Eq. 3.13-3.15)
    theta = np.where(slide, 0.0, np.where(elastic, 1.0, y ** p))
    ks = np.where(closed1, kt0_1 * theta, 0.0)
    ks_perp = np.where(closed1, kt0_1, 0.0)
    ktn = np.where(closed1, s * mu * (1.0 - theta), 0.0)
    return T1, e, s, k, stack.P, slide, diss, ks, ks_perp, ktn


def _md_axis(params: object, mu: float, p: float, m_exp: float, r: float, maxrev: int, stack: _Stack,
             tau: np.ndarray, s: np.ndarray, k: np.ndarray, N0: np.ndarray, N1: np.ndarray,
             a0: np.ndarray, a1: np.ndarray, kbar: np.ndarray, kt1: np.ndarray, d: np.ndarray,
             rising: np.ndarray, falling: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Scalar Mindlin–Deresiewicz law along the memory axis (vectorised over contacts).

    Works with ``Q = mu N - s tau`` and the reversal invariants ``P_j``; returns the new
    ``tau, s, k`` (the stack is updated in place on its copy) and the dissipation.
    """
    n = tau.shape[0]
    diss = np.zeros(n)
    muN0 = mu * N0
    muN1 = mu * N1
    Q = np.clip(muN0 - s * tau, 0.0, 2.0 * muN0)   # 0 <= Q <= 2 mu N (rounding)
    s = s.copy()
    k = k.copy()

    def reverse(mask: np.ndarray, new_dir: np.ndarray, muN: np.ndarray) -> None:
        """Start a branch in direction new_dir (= -s) for contacts in mask, at force level muN
        (``Q``, ``s``, ``k`` are modified in place)."""
        idx = np.nonzero(mask)[0]
        if idx.size == 0:
            return
        kk = k[idx]
        muNi = muN[idx]
        Qi = Q[idx]
        # Masing's rule at a tie: a branch that stopped within rounding of the reversal
        # point it was heading for has closed its loop; erase that loop before turning
        Qt = np.where(kk >= 2, _top(stack.P, idx, kk, 2), _top(stack.P, idx, kk, 1))
        closing = (kk > 0) & (Qi - Qt <= _REV_TOL * 2.0 * muNi)
        Qi = np.where(closing, np.minimum(Qi, Qt), Qi)
        kk = np.where(closing, np.maximum(kk - 2, 0), kk)
        Pt = _top(stack.P, idx, kk, 1)
        skeleton_zero = (kk == 0) & (Qi >= muNi * (1.0 - _REV_TOL))      # virgin at T ~ 0
        fresh = (kk > 0) & (Qi + Pt >= 2.0 * muNi * (1.0 - _REV_TOL))     # at the reversal point
        push = ~skeleton_zero & ~fresh
        full = push & (kk >= maxrev)
        if np.any(full):
            for jj in np.nonzero(full)[0]:
                kk[jj] = _merge_closest_loop(stack, int(idx[jj]), int(kk[jj]), float(Qi[jj]),
                                             float(muNi[jj]))
                if kk[jj] >= maxrev:
                    raise ReversalMemoryError(idx[full], maxrev)
        pi = idx[push]
        if pi.size:
            stack.write(pi, kk[push], Qi[push])
        k[idx] = np.where(push, kk + 1, np.where(fresh, kk - 1, kk))
        Q[idx] = 2.0 * muNi - Qi
        s[idx] = new_dir[idx]

    dsign = np.sign(d).astype(np.int8)
    u = np.zeros(n)

    # ---------- rising N: elastic (Eq. 3.10) or N-first on the no-slip boundary
    dalpha = a1 - a0
    bound = mu * r * np.maximum(dalpha, 0.0)
    elastic = rising & (np.abs(d) <= bound)
    if np.any(elastic):
        tau_e = tau + kbar * d
        Q = np.where(elastic, muN1 - s * tau_e, Q)
    slip_up = rising & ~elastic
    if np.any(slip_up):
        rev = slip_up & (dsign != s)
        reverse(rev, dsign, muN0)
        # N first: Q and every P are invariant, tau moves by s mu dN
        u = np.where(slip_up, np.abs(d) - bound, u)

    # ---------- falling N at fixed displacement (exact), then the displacement
    if np.any(falling):
        Q, s, k, dd = _falling_n(params, mu, p, m_exp, stack, Q, s, k, N0, N1, falling)
        diss += dd
    flat = ~rising & (d != 0.0) & (N1 > 0.0)
    if np.any(flat):
        rev = flat & (dsign != s)
        reverse(rev, dsign, muN1)
        u = np.where(flat, np.abs(d), u)

    # ---------- displacement u >= 0 along s at constant N1 (exact branch integration)
    act = (u > 0.0) & (N1 > 0.0)
    it = 0
    while np.any(act):
        it += 1
        if it > 2 * maxrev + 4:  # pragma: no cover - each pass removes an event
            raise RuntimeError("Mindlin-Deresiewicz branch integration did not terminate")
        idx = np.nonzero(act)[0]
        kk = k[idx]
        c = np.where(kk > 0, 2.0, 1.0)
        Pt = _top(stack.P, idx, kk, 1)
        Qt = np.where(kk >= 2, _top(stack.P, idx, kk, 2), np.where(kk == 1, Pt, 0.0))
        muN = muN1[idx]
        K = kt1[idx]
        ui = u[idx]
        y = np.clip((Q[idx] + Pt) / (c * muN), 0.0, 1.0)
        yt = np.clip((Qt + Pt) / (c * muN), 0.0, 1.0)
        z = y ** (1.0 - p)
        zt = yt ** (1.0 - p)
        # lam u can overflow for a vanishing contact (mu N -> 0): that means sliding
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            lam = (1.0 - p) * K / (c * muN)
            zend = z - lam * ui
            hit = ~(zend > zt)
            zstop = np.where(hit, zt, zend)
            pref = c * muN * muN / ((1.0 - p) * K)
            used = np.where(hit, np.where(np.isfinite(lam), (z - zt) / lam, 0.0), ui)
        diss[idx] += pref * np.maximum(_H(zstop, m_exp) - _H(z, m_exp), 0.0)
        rem = np.maximum(ui - used, 0.0)
        Qnew = np.where(hit, Qt, c * muN * zstop ** m_exp - Pt)
        # events: sliding on the virgin branch, or Masing's rule (pop 1 or 2 reversals)
        sl = hit & (kk == 0)
        diss[idx] += np.where(sl, muN * rem, 0.0)
        rem = np.where(sl, 0.0, rem)
        Qnew = np.where(sl, 0.0, Qnew)
        k[idx] = np.where(hit & (kk >= 2), kk - 2, np.where(hit & (kk == 1), 0, kk))
        Q[idx] = Qnew
        u[idx] = np.where(hit, rem, 0.0)
        act = (u > 0.0) & (N1 > 0.0)

    tau_new = s * (muN1 - Q)
    # contacts at constant N with no displacement keep their force exactly
    still = ~rising & ~falling & (d == 0.0)
    tau_new = np.where(still, tau, tau_new)
    # the opened contacts
    tau_new = np.where(N1 > 0.0, tau_new, 0.0)
    # clamp rounding: |tau| <= mu N
    tau_new = np.clip(tau_new, -muN1, muN1)
    return tau_new, s, k, diss, elastic & (N1 > 0.0)


def _falling_n(params: object, mu: float, p: float, m_exp: float, stack: _Stack, Q: np.ndarray,
               s: np.ndarray, k: np.ndarray, N0: np.ndarray, N1: np.ndarray, mask: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Exact integration of a fall of N (N0 -> N1 < N0) at fixed tangential displacement.

    Rate law (Thornton & Randall 1988, seed Eq. 3.11 with d delta = 0):
    ``d tau = s mu dN (1 - theta)``, every ``P_j`` constant. In ``z = y**(1-p)``:
    ``z - 1/c = (z0 - 1/c) (N0/N)**(1-p)``. Events: sliding (virgin branch, ``z = 0``),
    erasure of the last reversal (``y = 1``), and Masing closure (``Q = Q_target``).
    """
    n = Q.shape[0]
    diss = np.zeros(n)
    Q = Q.copy()
    s = s.copy()
    k = k.copy()
    Na = N0.copy()
    Nb = N1
    act = mask & (Na > Nb)
    q = 1.0 - p
    it = 0
    while np.any(act):
        it += 1
        if it > 2 * max(max_reversals(params), 1) + 6:  # pragma: no cover
            raise RuntimeError("falling-N integration did not terminate")
        idx = np.nonzero(act)[0]
        kk = k[idx]
        c = np.where(kk > 0, 2.0, 1.0)
        Pt = _top(stack.P, idx, kk, 1)
        Qt = np.where(kk >= 2, _top(stack.P, idx, kk, 2), np.where(kk == 1, Pt, 0.0))
        na = Na[idx]
        nb = Nb[idx]
        muNa = mu * na
        y0 = np.clip((Q[idx] + Pt) / (c * muNa), 0.0, 1.0)
        z0 = y0 ** q

        # candidate event levels (largest N first); 0 means "no event in (0, na)"
        sliding_now = (kk == 0) & (z0 <= 0.0)
        n_slide = np.where((kk == 0) & (z0 < 1.0), na * np.clip(1.0 - z0, 0.0, 1.0) ** m_exp, 0.0)
        n_slide = np.where(sliding_now, na, n_slide)
        n_erase = np.where((kk > 0) & (z0 > 0.5), na * np.clip(2.0 * z0 - 1.0, 0.0, 1.0) ** m_exp, 0.0)

        def zfun(Nv: np.ndarray, sel=slice(None)) -> np.ndarray:
            with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
                ratio = (na[sel] / np.maximum(Nv, 1e-300)) ** q
            return np.clip(1.0 / c[sel] + (z0[sel] - 1.0 / c[sel]) * ratio, 0.0, 1.0)

        def Qfun(Nv: np.ndarray, sel=slice(None)) -> np.ndarray:
            return c[sel] * mu * Nv * zfun(Nv, sel) ** m_exp - Pt[sel]

        # Masing target reached while N falls (Q decreases monotonically with N): bisection
        # on the candidates only (each contact's result independent of the others)
        n_target = np.zeros_like(na)
        cand = (kk > 0) & (Qfun(nb) <= Qt)
        if np.any(cand):
            ci = np.nonzero(cand)[0]
            lo = nb[ci].copy()
            hi = na[ci].copy()
            qt = Qt[ci]
            for _ in range(64):
                mid = 0.5 * (lo + hi)
                below = Qfun(mid, ci) <= qt
                lo = np.where(below, mid, lo)
                hi = np.where(below, hi, mid)
            n_target[ci] = hi
        n_event = np.maximum.reduce([n_slide, n_erase, n_target])
        n_event = np.where(sliding_now, 0.0, n_event)   # sliding: no further event, go to nb
        n_stop = np.maximum(n_event, nb)

        # dissipation on [n_stop, na]: Gauss–Legendre in t = N^(1/3) (integrand >= 0; for
        # Hertz contacts kt0 ~ N^(1/3), so the sliding part mu^2 N/kt0 dN is a polynomial in t)
        ta, tb = np.cbrt(na), np.cbrt(n_stop)
        half = 0.5 * (ta - tb)
        mid = 0.5 * (ta + tb)
        acc = np.zeros_like(na)
        for xg, wg in zip(_GL_X, _GL_W):
            tg = mid + half * xg
            Ng = tg * tg * tg
            yg = np.where(sliding_now, 0.0, zfun(Ng) ** m_exp)
            gg = _g_of_y(yg, p)
            kt = law_forms(params).kt0(Ng)
            with np.errstate(divide="ignore", invalid="ignore"):
                f = np.where(kt > 0, mu * mu * Ng * gg / np.where(kt > 0, kt, 1.0), 0.0)
            acc += wg * f * 3.0 * tg * tg
        diss[idx] += half * acc

        # state at n_stop
        z_stop = np.where(sliding_now, 0.0, zfun(n_stop))
        Qi = np.where(sliding_now, 0.0, c * mu * n_stop * z_stop ** m_exp - Pt)
        ev = n_event >= nb
        ev = ev & (n_event > 0.0) & ~(sliding_now)
        is_slide = ev & (kk == 0) & (n_slide >= n_event)
        is_target = ev & (kk > 0) & (n_target >= n_event) & (n_target > 0)
        is_erase = ev & (kk > 0) & ~is_target & (n_erase >= n_event)
        Qi = np.where(is_slide, 0.0, Qi)
        Qi = np.where(is_target, Qt, Qi)
        # erasure of the last reversal: back on the previous branch, direction flips
        Qi = np.where(is_erase, Pt, Qi)
        s[idx] = np.where(is_erase, -s[idx], s[idx])
        newk = np.where(is_erase, kk - 1, kk)
        newk = np.where(is_target & (kk >= 2), kk - 2, np.where(is_target & (kk == 1), 0, newk))
        k[idx] = newk
        Q[idx] = Qi
        Na[idx] = n_stop
        act = mask & (Na > Nb)
    return Q, s, k, diss

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
from types import ModuleType
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, DTypeLike

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
from grainmech.contact.hysteresis import LawOut, axis_tangent, md_update, secant_kt
from grainmech.contact.params import ContactParams, Cylinder, Hertz, MindlinDeresiewicz
from grainmech.contact.state import (  # noqa: F401
    ContactResponse,
    ContactState,
    initial_state,
    law_kind,
    max_reversals,
    reversal_forces,
    row_dot,
    row_norm,
    state_from_approach,
    state_from_forces,
    state_from_normal_force,
)


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
    ln = row_norm(nrm)
    if np.any(ln <= 0) or not np.all(np.isfinite(ln)):
        raise ValueError("normals must be finite non-zero vectors")
    nrm = nrm / ln[:, None]

    def proj(v: np.ndarray) -> np.ndarray:
        vp = v - row_dot(v, nrm)[:, None] * nrm
        a, b = row_norm(v), row_norm(vp)
        scale = np.where(b > 0, a / np.where(b > 0, b, 1.0), 0.0)
        return vp * scale[:, None]

    return proj(T), proj(e)


# ---------------------------------------------------------------------------------------
# Public entry point
# ---------------------------------------------------------------------------------------
def update(params: ContactParams, state: ContactState, d_normal: ArrayLike, d_tangential: ArrayLike,
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
        md = cast("MindlinDeresiewicz | Cylinder", params)  # the laws of kind "md" (law_forms)
        out = md_update(md, state, T0, e0, N0_eff, N1, a0_eff, alpha1, dt_eff, virgin_reset)
    elif kind == "jenkins":
        out = _jenkins_update(params, T0, N0_eff, N1, a0_eff, alpha1, dt_eff)
    else:
        out = _frictionless_update(params, T0, N1)
    T1, e1, s1, k1, P1, slide, diss, ks, ks_perp, ktn = out[:10]

    kn = law_forms(params).kn(N1)
    if len(out) > 10:  # the hysteretic law's step tangent
        t_delta, t_alpha = out[10] * frac[:, None, None], out[11]
    else:
        t_delta, t_alpha = axis_tangent(e1, ks, ks_perp, ktn * kn)
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
        t_delta=t_delta,
        t_alpha=t_alpha,
    )
    return new_state, resp


# ---------------------------------------------------------------------------------------
# Compiled backend (grainmech.contact.kernel): selection and dispatch
# ---------------------------------------------------------------------------------------
_BACKENDS = ("auto", "numpy", "numba")
_KERNEL: ModuleType | bool | None = None   # the module once imported; False if numba is unavailable


def _load_kernel() -> ModuleType | bool | None:
    """Import :mod:`grainmech.contact.kernel` once (``False`` when numba is missing)."""
    global _KERNEL
    if _KERNEL is None:
        try:
            # imported on use: the kernel needs numba (optional); without it the NumPy laws run
            from grainmech.contact import kernel
        except ImportError:
            _KERNEL = False
        else:
            _KERNEL = kernel
    return _KERNEL


def compiled_kernel(params: ContactParams, backend: str = "auto") -> ModuleType | None:
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
        if not isinstance(mod, ModuleType):
            raise ImportError("backend='numba' needs numba, which is not importable")
        return mod
    if not supported:
        return None
    mod = _load_kernel()
    return mod if isinstance(mod, ModuleType) else None


def _writeable(x: np.ndarray, dtype: DTypeLike = float) -> np.ndarray:
    """``x`` C-contiguous and writeable (a read-only array would compile another variant of the kernel)."""
    x = np.ascontiguousarray(x, dtype=dtype)
    return x if x.flags.writeable else x.copy()


class CompiledUpdate:
    """The compiled update from one fixed start state, its inputs converted once.

    :func:`update` through the compiled kernel converts the start state to the kernel's
    contiguous arrays and evaluates the start contact radii on every call. A caller that
    advances the *same* start state by many trial increments (the Newton or Anderson
    iterations of one step of the packing driver) builds this once and calls it per
    trial: the same kernel on the same inputs, so the same results bit for bit as
    ``update(params, state, dn, dt, backend=...)`` (``normals=None``, no re-projection).

    Parameters
    ----------
    kernel : module
        :func:`compiled_kernel` of the law (not None).
    params : ContactParams
    state : ContactState
        Start state (not modified: the kernel only reads it; contiguous arrays of the
        kernel's dtypes are used as they are, others converted once).
    T0, e0 : arrays (n, dim), optional
        The start tangential force and memory axis if they differ from the state's
        (re-projected onto turned normals by :func:`update`).
    """

    def __init__(self, kernel: ModuleType, params: ContactParams, state: ContactState,
                 T0: np.ndarray | None = None, e0: np.ndarray | None = None) -> None:
        c = _writeable
        if state.reversals.shape[1] != max_reversals(params):
            raise ValueError(f"state was built for max_reversals = {state.reversals.shape[1]}, "
                             f"params have {max_reversals(params)}; build it with initial_state(params, ...)")
        self.kernel, self.params, self.forms = kernel, params, law_forms(params)
        self.n, self.dim = state.n_contacts, state.dim
        self.alpha0 = c(state.approach, dtype=float)
        # spheres (the compiled laws other than linear springs): the start radius (seed Eq.
        # 3.2) of every contact, from the start state's normal force
        self.hertz = cast(Hertz, params) if self.forms.spheres else None
        self.rad0 = (geo.hertz_contact_radius_from_force(np.where(self.alpha0 > 0.0, state.normal_force, 0.0),
                                                         self.hertz) if self.hertz is not None else None)
        K = kernel
        self.st = K.KernelState(self.alpha0, c(state.normal_force, dtype=float),
                                c(state.tangential_force if T0 is None else T0, dtype=float),
                                c(state.axis if e0 is None else e0, dtype=float), c(state.direction, dtype=np.int8),
                                c(state.depth, dtype=np.int32), c(state.reversals, dtype=float),
                                c(state.dissipated_energy, dtype=float))
        self.kc = K.constants(params)

    def __call__(self, dn: np.ndarray, dt: np.ndarray) -> tuple[ContactState, ContactResponse]:
        """New state and response for increments ``dn`` (n,) and ``dt`` (n, dim), float64 arrays."""
        dn, dt = _writeable(dn), _writeable(dt)
        if dn.shape != (self.n,) or dt.shape != (self.n, self.dim):
            raise ValueError(f"increments of shape {dn.shape}, {dt.shape} for {self.n} contacts in {self.dim}D")
        K, params = self.kernel, self.params
        # the closed forms of the normal law, vectorised as in the reference path
        N1 = self.forms.normal_force(self.alpha0 + dn)
        if self.hertz is not None:
            rad1 = geo.hertz_contact_radius_from_force(N1, self.hertz)
            rad0 = self.rad0
        else:  # linear springs: the kernel does not use the radii
            rad0 = rad1 = N1
        st = self.st
        status, out, flags = K.update_kernel(self.kc, st, K.KernelIncrement(dn, dt, N1, rad0, rad1))
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
                               out.ktn, out.axis, out.sliding, out.open, out.dissipation, out.t_delta,
                               out.t_alpha)
        return new_state, resp


def _update_compiled(kernel: ModuleType, params: ContactParams, state: ContactState, T0: np.ndarray,
                     e0: np.ndarray, dn: np.ndarray, dt: np.ndarray
                     ) -> tuple[ContactState, ContactResponse]:
    """:func:`update` through the compiled kernel (validated, re-projected inputs)."""
    return CompiledUpdate(kernel, params, state, T0, e0)(dn, dt)


# ---------------------------------------------------------------------------------------
# Frictionless and elastic–Coulomb (Jenkins) tangential laws
# ---------------------------------------------------------------------------------------


def _frictionless_update(params: ContactParams, T0: np.ndarray, N1: np.ndarray) -> LawOut:
    n, dim = T0.shape
    z = np.zeros(n)
    return (np.zeros((n, dim)), np.zeros((n, dim)), np.ones(n, dtype=np.int8),
            np.zeros(n, dtype=np.int32), np.zeros((n, 0)), np.zeros(n, dtype=bool),
            z, z.copy(), z.copy(), z.copy())


def _jenkins_update(params: ContactParams, T0: np.ndarray, N0: np.ndarray, N1: np.ndarray, a0: np.ndarray,
                    a1: np.ndarray, dt: np.ndarray) -> LawOut:
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
    kbar = np.where(rising, secant_kt(params, N0, N1, a0, a1), kt1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where((kt0 > 0) & (kt1 < kt0), kt1 / np.where(kt0 > 0, kt0, 1.0), 1.0)
        Tn0 = row_norm(T0)
        diss = np.where(kt0 > 0, (1.0 - rho) * Tn0 ** 2 / (2.0 * np.where(kt0 > 0, kt0, 1.0)), 0.0)
    trial = rho[:, None] * T0 + kbar[:, None] * dt
    tn = row_norm(trial)
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
    t1n = row_norm(T1)
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

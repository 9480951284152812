"""Compiled (numba) per-contact law: :func:`rows` advances a chunk of contacts by one increment.

Part of the compiled kernel :mod:`grainmech.contact.kernel` (its module notes state how it
agrees with the NumPy reference :mod:`grainmech.contact.law`): the 3D treatment of a
contact (re-projection onto the memory axis, the perpendicular part), the Coulomb cap and
the step tangents, around the law along the axis of :mod:`grainmech.contact._kernel_axis`.

The module-level constants ``_LAW``, ``_LINEAR``, ``_DEFER`` and ``_DIM`` are the
compile-time specialisation of :func:`rows`: :func:`grainmech.contact.kernel.law_function`
compiles copies of it whose globals (this module's, updated) fix them. Only :func:`rows`
reads them; it passes the dimension and the normal law to its phases (one contact's
start, the frictionless, spring and hysteretic laws), which LLVM inlines into it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainmech.contact._kernel_axis import (
    clip01,
    fall_dissipation,
    md_axis,
    normal_stiffness,
    noslip_stiffness,
    pow_p,
    reversal_at,
    secant_kt,
)
from grainmech.contact._kernel_types import EPS, JIT_NO_NRT, LAW_FRICTIONLESS, LAW_JENKINS
from grainmech.contact.geometry import hertz_kn, mindlin_kt0

# the tolerance of the reference law (a value, so that the compiled code is self-contained)
from grainmech.contact.hysteresis import PAR_TOL

__all__ = ["rows"]

# compile-time specialisation of :func:`rows` (:func:`law_function`): the law code and
# normal law a copy is compiled for; -1 (the generic ``rows``) decides from ``kc`` at run
# time. numba prunes the branches of the other laws from a copy before typing them.
_LAW = -1
_LINEAR = -1
# 1 in the copies that leave the falling-N dissipation quadrature to fall_dissipation
# (law_function(..., defer=True), the mixed-control driver): a Newton evaluation that is
# not accepted does not need it
_DEFER = 0
# the dimension of the contact forces a copy is compiled for (0: the arrays' shape): a
# constant lets the compiler unroll the per-contact vector loops and keep the rows in
# registers (the law of the mixed-control driver took ~17 % less time)
_DIM = 0
# the phases of :func:`rows` (one contact's step): inlined into it by LLVM (``forceinline``,
# not numba's IR inlining, which multiplies the compile time), so that the code a copy
# of ``rows`` runs is the one function it was before the split
_JIT_PHASE: dict = {**JIT_NO_NRT, "forceinline": True}




# ---------------------------------------------------------------------------------------
# One contact: 3D treatment, Coulomb cap, tangents
# ---------------------------------------------------------------------------------------
@njit(**JIT_NO_NRT)
def _dot_rows(A, i, B, j, dim):
    """``A[i, :dim] . B[j, :dim]`` (``dim`` a compile-time constant in a specialised copy of :func:`rows`)."""
    out = A[i, 0] * B[j, 0]
    for c in range(1, dim):
        out = out + A[i, c] * B[j, c]
    return out


@njit(**JIT_NO_NRT)
def _axis_tangent(i, e, ks, ksp, ktn, tdel, talp, dim):
    """Step tangent of the form ``ks e e + ks_perp (I - e e)``, ``dT/d alpha = ktn e``."""
    for c in range(dim):
        talp[i, c] = ktn * e[i, c]
        for c2 in range(dim):
            tdel[i, c, c2] = (ks - ksp) * e[i, c] * e[i, c2] + (ksp if c == c2 else 0.0)


@njit(**JIT_NO_NRT)
def _cap_tangent(i, T, tn, muN1, mukn, tdel, talp, dim):
    """Step derivatives through the radial return ``T = mu N1 t/|t|`` of the trial ``t = T[i]``.

    With ``|t| = tn`` the step derivatives become ``mu kn t/|t| + g (I - t t/|t|^2) dT_trial/d alpha`` and
    ``g (I - t t/|t|^2) dT_trial/d d_t`` with ``g = mu N1/|t|``.
    """
    g = muN1 / tn if tn > 0.0 else 0.0
    inv = 1.0 / tn if tn > 0.0 else 0.0
    # (I - t t) x = x - t (t . x)
    ta = 0.0
    for c in range(dim):
        ta += T[i, c] * inv * talp[i, c]
    for c in range(dim):
        talp[i, c] = mukn * T[i, c] * inv + g * (talp[i, c] - T[i, c] * inv * ta)
    for c2 in range(dim):
        tc = 0.0
        for c in range(dim):
            tc += T[i, c] * inv * tdel[i, c, c2]
        for c in range(dim):
            tdel[i, c, c2] = g * (tdel[i, c, c2] - T[i, c] * inv * tc)


# ---------------------------------------------------------------------------------------
# The phases of one contact's step (rows calls them in this order; each is inlined into
# the caller by LLVM, ``forceinline``, so that a specialised copy of rows unrolls their
# vector loops with its constant dimension as before the split)
# ---------------------------------------------------------------------------------------
@njit(**_JIT_PHASE)
def _start_row(i, kc, state, inc, out, scratch, defer, lin, dim):
    """Start of contact ``i``'s step: the effective increment, the normal law, the stiffnesses.

    Writes ``dp[i]`` (the tangential increment in contact, ``dt_eff``), ``T1[i]`` (the
    start force, zero for an open contact), the reversal row, the approach, ``N``, the
    open flag and ``kn`` of the output; ``lin``: the linear-spring normal law (the
    copy's constant or ``kc.linear``). Returns ``(a0e, a1, N0, N1, frac, virgin, closed1,
    rising, kn, kt00, kt01, kbar, rho)``: the approach in contact at the start and at the
    end, the normal forces, the fraction of the step in contact, no force at the start,
    closed at the end, rising ``N``, ``kn`` and ``kt0`` at the end (seed Eq. 3.7, 3.11
    with theta = 1), ``kt0`` at the start, the secant no-slip stiffness and the rescaling
    ``rho = kt0(N1)/kt0(N0)`` of a shrinking contact area.
    """
    E, R, Gs, kn_lin, ks_lin, linear, r = kc.E, kc.R, kc.Gs, kc.kn_lin, kc.ks_lin, kc.linear, kc.r
    alpha0, N0s, T0s, _e0s, _dir0, _depth0, P0, _diss0 = state
    dn, dt, N1s, rad0, rad1 = inc
    alpha1o, N1o, T1, _e1, _s1o, _k1o, P1, _sl, _di, _ks, _ksp, _ktn, kn_o, open_o, _td, _ta = out
    _tp, dp, _flags, fall = scratch
    a0 = alpha0[i]
    a1 = a0 + dn[i]
    N1 = N1s[i]             # seed Eq. 3.6 (or kn alpha), evaluated by the caller
    closed0 = a0 > 0.0
    closing = (a1 > 0.0) and not closed0
    # a step that closes an open contact: only the part of the path in contact counts
    frac = a1 / (a1 - a0) if closing else 1.0
    a0e = 0.0 if closing else a0
    N0 = N0s[i] if closed0 else 0.0
    virgin = not closed0
    for c in range(dim):
        dp[i, c] = dt[i, c] * frac                    # dt_eff (kept in dp until split)
        T1[i, c] = 0.0 if virgin else T0s[i, c]       # T0 (an open contact has no force)
    for c in range(P0.shape[1]):
        P1[i, c] = P0[i, c]
    if defer:
        fall[i, 0] = 0.0

    alpha1o[i] = a1
    N1o[i] = N1
    open_o[i] = not (a1 > 0.0)
    if lin:
        kn = normal_stiffness(N1, linear, E, R, kn_lin)
        kt01 = noslip_stiffness(N1, linear, E, R, Gs, ks_lin)
    else:
        # contact radius (seed Eq. 3.2, by the caller) for kn = 2 E* a (Eq. 3.7) and
        # kt0 = 8 G* a (Eq. 3.11 with theta = 1)
        a_1 = rad1[i]
        kn = hertz_kn(a_1, E)
        kt01 = mindlin_kt0(a_1, Gs)
    kn_o[i] = kn
    closed1 = N1 > 0.0
    if lin:
        kt00 = noslip_stiffness(N0, linear, E, R, Gs, ks_lin)
    else:
        kt00 = mindlin_kt0(rad0[i], Gs)
    rising = N1 > N0
    kbar = secant_kt(N0, N1, a0e, a1, linear, r, ks_lin, kt01) if rising else kt01
    if (kt00 > 0.0) and (kt01 < kt00):
        rho = kt01 / kt00
    else:
        rho = 1.0
    return a0e, a1, N0, N1, frac, virgin, closed1, rising, kn, kt00, kt01, kbar, rho


@njit(**_JIT_PHASE)
def _frictionless_row(i, out, dim):
    """Contact ``i`` of a frictionless law: no tangential force, no dissipation."""
    _a, _n, T1, e1, s1o, k1o, _P, slide_o, diss_o, ks_o, ksp_o, ktn_o, _kn_o, _op, tdel, talp = out
    for c in range(dim):
        T1[i, c] = 0.0
        e1[i, c] = 0.0
    s1o[i] = 1
    k1o[i] = 0
    slide_o[i] = False
    diss_o[i] = 0.0
    ks_o[i] = 0.0
    ksp_o[i] = 0.0
    ktn_o[i] = 0.0
    _axis_tangent(i, e1, ks_o[i], ksp_o[i], ktn_o[i], tdel, talp, dim)


@njit(**_JIT_PHASE)
def _spring_row(i, kc, out, scratch, N1, closed1, kn, kt00, kt01, kbar, rho, dim):
    """Contact ``i`` of the elastic spring with a Coulomb cap (Hertz-Mindlin, linear springs).

    Elastic spring (seed Eq. 3.11 with theta = 1), rescaled by ``rho`` when the contact
    area shrinks, Coulomb cap ``|T| <= mu N`` by radial return; writes the force, axis,
    sliding flag, dissipation and tangents of row ``i`` of ``out``.
    """
    mu, mu_finite = kc.mu, kc.mu_finite
    _a, _n, T1, e1, s1o, k1o, _P, slide_o, diss_o, ks_o, ksp_o, ktn_o, _kn_o, _op, tdel, talp = out
    dp = scratch.dp
    Tn0 = math.sqrt(_dot_rows(T1, i, T1, i, dim))
    diss = (1.0 - rho) * Tn0 ** 2 / (2.0 * kt00) if kt00 > 0.0 else 0.0
    for c in range(dim):
        T1[i, c] = rho * T1[i, c] + kbar * dp[i, c]
    tn = math.sqrt(_dot_rows(T1, i, T1, i, dim))
    cap = mu * N1 if mu_finite else math.inf
    if not closed1:
        cap = 0.0
    over = tn > cap
    scale = 1.0
    if over:
        scale = cap / tn if tn > 0.0 else cap
        slip = (tn - cap) / kt01 if kt01 > 0.0 else 0.0
        diss = diss + cap * slip
    for c in range(dim):
        T1[i, c] = T1[i, c] * scale if closed1 else 0.0
    t1n = math.sqrt(_dot_rows(T1, i, T1, i, dim))
    for c in range(dim):
        e1[i, c] = T1[i, c] / t1n if t1n > 0.0 else 0.0
    slide = closed1 and (cap > 0.0) and (t1n >= cap * (1.0 - 1e-12))
    if mu_finite:
        slide = slide or (closed1 and mu == 0.0)
    s1o[i] = 1
    k1o[i] = 0
    slide_o[i] = slide
    diss_o[i] = diss
    ks_o[i] = 0.0 if (slide or not closed1) else kt01
    ksp_o[i] = kt01 if closed1 else 0.0
    ktn_o[i] = ((mu if mu_finite else 0.0) if slide else 0.0) * kn
    _axis_tangent(i, e1, ks_o[i], ksp_o[i], ktn_o[i], tdel, talp, dim)


@njit(**_JIT_PHASE)
def _md_split(i, state, out, scratch, virgin, dim):
    """Hysteretic law, contact ``i``: its memory axis ``e`` and the split along and across it.

    The axis is the start's (a virgin contact's is taken from its motion); ``T1[i]`` and
    ``dp[i]`` are split into ``tau e + tp`` and ``d_par e + dp`` (``tp[i]``, ``dp[i]``
    keep the parts across). Returns ``(s, k, fresh, dtn, tau, d_par)``: branch direction,
    memory depth, axis just taken from the motion, ``|dt_eff|``, the force and the
    increment along the axis.
    """
    _a0, _N0, _T0, e0s, dir0, depth0, _P0, _d0 = state
    _a, _n, T1, e1, _s, _k, _P, _sl, _di, _ks, _ksp, _ktn, normal_stiffness, _op, _td, _ta = out
    tp, dp = scratch.tp, scratch.dp
    s = 1 if virgin else int(dir0[i])
    k = 0 if virgin else int(depth0[i])
    tn0 = math.sqrt(_dot_rows(T1, i, T1, i, dim))
    dtn = math.sqrt(_dot_rows(dp, i, dp, i, dim))
    fresh = (k == 0) and (tn0 == 0.0) and (dtn > 0.0)
    for c in range(dim):
        if fresh:
            e1[i, c] = dp[i, c] / dtn
        elif virgin:
            e1[i, c] = 0.0
        else:
            e1[i, c] = e0s[i, c]
    if fresh:
        s = 1
    tau = _dot_rows(T1, i, e1, i, dim)
    d_par = _dot_rows(dp, i, e1, i, dim)
    if abs(d_par) <= PAR_TOL * dtn:  # rounding only: at right angles to the axis (law.py)
        d_par = 0.0
    for c in range(dim):
        tp[i, c] = T1[i, c] - tau * e1[i, c]
        dp[i, c] = dp[i, c] - d_par * e1[i, c]
    return s, k, fresh, dtn, tau, d_par


@njit(**_JIT_PHASE)
def _md_across(i, scratch, a0e, a1, rising, linear, lin, kt00, kt01, kbar, rho, dim):
    """Hysteretic law, contact ``i``, across the axis: elastic (no slip), rescaled when the area shrinks.

    Advances ``tp[i]``; returns ``(dissipation, dkbar, drr)``: the energy released by the
    rescaling and the step derivatives of ``kbar`` and ``rho`` with respect to the
    approach ``a1`` (Hertz: ``kt0 = kn / r ~ a1**(1/2)``, ``d kt0 / d a1 = kt0 / (2 a1)``;
    linear springs: 0; ``drr = (d rho / d a1) / rho``).
    """
    tp, dp = scratch.tp, scratch.dp
    diss = 0.0
    tp2 = _dot_rows(tp, i, tp, i, dim)
    if kt00 > 0.0:
        diss += (1.0 - rho) * tp2 / (2.0 * kt00)
    for c in range(dim):
        tp[i, c] = rho * tp[i, c] + kbar * dp[i, c]
    dkt1 = 0.0 if (linear or not (a1 > 0.0)) else kt01 / (2.0 * a1)
    if rising:
        da = a1 - a0e
        if lin:
            dkbar = 0.0
        elif abs(da) > 1e-14 * max(abs(a0e), abs(a1)):
            dkbar = (kt01 - kbar) / da     # d/da1 of the secant (N1 - N0) / (r da)
        else:
            dkbar = 0.5 * dkt1
        drr = 0.0
    else:
        dkbar = dkt1
        drr = dkt1 / kt01 if ((kt00 > 0.0) and (kt01 < kt00) and (kt01 > 0.0)) else 0.0  # (d rho / d a1) / rho
    # a subnormal approach (at touch) overflows kt0 / (2 a1): the derivative of a
    # Hertz-type stiffness is singular there; its terms are dropped, not made NaN
    if not abs(dkbar) < np.inf:
        dkbar = 0.0
    if not abs(drr) < np.inf:
        drr = 0.0
    return diss, dkbar, drr


@njit(**_JIT_PHASE)
def _md_trial_tangent(i, kc, out, scratch, tau, s, k, elastic, dPn, kpush, muN1, kn, kt01, kbar, dkbar, drr,
                      d_par, fresh, dtn, frac, dim):
    """Hysteretic law, contact ``i``: step tangent of the trial force ``tau e + T_perp`` (before the cap).

    Along ``e`` ``d tau/d d = kbar`` (no-slip step of rising N) or ``8 G* a theta`` (seed
    Eq. 3.11 at constant N1, exact for the z-integration), ``d tau/d a1`` = the secant's
    derivative, or ``s mu (1 - theta) kn`` (Thornton-Randall coupling, exact for spheres
    after a rise or a fall of N); across ``e`` ``kbar`` (``tau/|d|`` for an axis just
    taken from the motion), ``d T_perp/d a1`` from ``kbar(a1)`` and ``rho(a1)``. Writes
    ``tdel[i]``, ``talp[i]``; returns ``(tha_ok, tha)``: theta of the end state, valid
    while ``tau``, ``s``, ``k`` hold.
    """
    mu, p = kc.mu, kc.p
    _a, _n, _T1, e1, _s, _k, P1, _sl, _di, _ks, _ksp, _ktn, normal_stiffness, _op, tdel, talp = out
    tp, dp = scratch.tp, scratch.dp
    tha_ok = False
    tha = 0.0
    if mu > 0.0:
        if elastic:
            a_e = kbar
            a_n = d_par * dkbar
        else:
            tha_ok = True
            Qa = muN1 - s * tau
            Pa = reversal_at(P1, i, k, 1)
            ca = 2.0 if k > 0 else 1.0
            ya = clip01((Qa + Pa) / (ca * muN1)) if muN1 > 0.0 else 0.0
            if (k == 0) and (Qa <= EPS * muN1):
                tha = 0.0
            else:
                tha = pow_p(ya, p, kc.sph)
            a_e = kt01 * tha
            a_n = s * mu * (1.0 - tha) * kn
            if k == kpush:
                # a branch started at N1 by a pushed reversal: Q + P_top = 2 mu N1 z^m
                # with z = 1 at its start, so dQ/dN1 = 2 mu theta - dP/dN1 (not mu theta)
                a_n += s * (dPn - mu * tha) * kn
    else:
        a_e = 0.0
        a_n = 0.0
    b_p = (tau / dtn if dtn > 0.0 else kbar) if fresh else kbar
    for c in range(dim):
        talp[i, c] = a_n * e1[i, c] + dkbar * dp[i, c] + drr * (tp[i, c] - kbar * dp[i, c])
        for c2 in range(dim):
            ee = e1[i, c] * e1[i, c2]
            tdel[i, c, c2] = ((a_e - b_p) * ee + (b_p if c == c2 else 0.0)) * frac  # d dt_eff/d dt = frac
    return tha_ok, tha


@njit(**_JIT_PHASE)
def _md_cap(i, out, scratch, tau, s, k, diss, tha_ok, closed1, mu, muN1, kn, kt01, dim):
    """Hysteretic law, contact ``i``: recombine ``T = tau e + T_perp``, Coulomb cap, axis rules.

    The cap on the total force by radial return (wipes the memory; its tangent through
    :func:`_cap_tangent`), a force below the resolution of the Q formulation without
    memory made virgin, the memory axis following the force when no reversal is
    remembered, the virgin branch's direction pointing away from zero force, an opened
    contact losing force and memory. Returns ``(tau, s, k, dissipation, tha_ok)``.
    """
    _a, _n, T1, e1, _s, _k, _P, _sl, _di, _ks, _ksp, _ktn, normal_stiffness, _op, tdel, talp = out
    tp = scratch.tp
    for c in range(dim):
        T1[i, c] = tau * e1[i, c] + tp[i, c]
    t1n = math.sqrt(_dot_rows(T1, i, T1, i, dim))
    if closed1 and (t1n > muN1 * (1.0 + 1e-12)):
        tha_ok = False
        # radial return T = mu N1 t / |t|: dT = mu dN t + (mu N1/|t|) (I - t t) dT_trial
        _cap_tangent(i, T1, t1n, muN1, mu * kn, tdel, talp, dim)
        scale = muN1 / t1n if t1n > 0.0 else muN1
        slip = (t1n - muN1) / kt01 if kt01 > 0.0 else 0.0
        diss += muN1 * slip
        for c in range(dim):
            T1[i, c] = T1[i, c] * scale
        t1n = math.sqrt(_dot_rows(T1, i, T1, i, dim))
        for c in range(dim):
            e1[i, c] = T1[i, c] / t1n if t1n > 0.0 else T1[i, c]
            tp[i, c] = 0.0
        tau = t1n
        s = 1
        k = 0

    # a force below the resolution of the Q formulation, without memory: virgin contact
    if closed1 and (k == 0) and (t1n <= 1e-14 * muN1):
        tha_ok = False
        for c in range(dim):
            T1[i, c] = 0.0
            tp[i, c] = 0.0
            e1[i, c] = 0.0
        tau = 0.0
        s = 1

    # no reversal remembered: the memory axis follows the force
    if closed1 and (k == 0) and (_dot_rows(tp, i, tp, i, dim) > 0.0):
        tha_ok = False
        t1n = math.sqrt(_dot_rows(T1, i, T1, i, dim))
        sg = -1.0 if _dot_rows(T1, i, e1, i, dim) < 0.0 else 1.0
        for c in range(dim):
            e1[i, c] = sg * T1[i, c] / (t1n if t1n > 0.0 else 1.0)
            tp[i, c] = 0.0
        tau = sg * t1n
    # (the reference recombines T = tau e + T_perp here)
    for c in range(dim):
        T1[i, c] = tau * e1[i, c] + tp[i, c]
    # the virgin branch is symmetric: s points away from zero force
    if (k == 0) and (s * tau < 0.0):
        s = -s
        tha_ok = False

    # opened contacts lose force and memory
    if not closed1:
        for c in range(dim):
            T1[i, c] = 0.0
            e1[i, c] = 0.0
        s = 1
        k = 0
    return tau, s, k, diss, tha_ok


@njit(**_JIT_PHASE)
def _md_end(i, kc, out, tau, s, k, diss, closed1, elastic, tha_ok, tha, muN1, kn, kt01, dim):
    """Hysteretic law, contact ``i``: the end state's branch, sliding flag and tangents into ``out``.

    theta = 1 after a no-slip step of rising N (seed Eq. 3.10), else Eq. 3.11 with theta
    of the current branch (Eq. 3.13-3.15); an open contact's step tangents are zero.
    """
    mu, p = kc.mu, kc.p
    _a, _n, _T1, _e1, s1o, k1o, P1, slide_o, diss_o, ks_o, ksp_o, ktn_o, normal_stiffness, _op, tdel, talp = out
    Ptop = reversal_at(P1, i, k, 1)
    c2 = 2.0 if k > 0 else 1.0
    Q = muN1 - s * tau
    y = (Q + Ptop) / (c2 * muN1) if muN1 > 0.0 else 0.0
    y = clip01(y)
    slide = closed1 and (((k == 0) and (Q <= EPS * muN1)) or (mu == 0.0))
    if slide:
        theta = 0.0
    elif elastic:
        theta = 1.0
    elif tha_ok:
        theta = tha
    else:
        theta = pow_p(y, p, kc.sph)
    s1o[i] = s
    k1o[i] = k
    slide_o[i] = slide
    diss_o[i] = diss
    ks_o[i] = kt01 * theta if closed1 else 0.0
    ksp_o[i] = kt01 if closed1 else 0.0
    ktn_o[i] = (s * mu * (1.0 - theta) if closed1 else 0.0) * kn
    if not closed1:
        for c in range(dim):
            talp[i, c] = 0.0
            for c2 in range(dim):
                tdel[i, c, c2] = 0.0


@njit(**JIT_NO_NRT)
def rows(lo, hi, kc, state, inc, out, scratch):
    """Advance contacts ``lo <= i < hi`` by one increment (the per-contact law).

    Parameters
    ----------
    lo, hi : int
    kc : KernelConstants
    state : KernelState
        Start of the step (``tangential_force``, ``axis`` already re-projected).
    inc : KernelIncrement
    out : KernelOutput
        Rows ``lo:hi`` of every array are written.
    scratch : KernelScratch
        Rows ``lo:hi`` of ``tp``, ``dp`` are work space; ``flags[i]`` is set non-zero for
        a contact the law could not advance (reversal memory full, no termination);
        ``fall`` receives the deferred falling-N segments (copies made with ``defer``,
        :func:`law_function`; untouched otherwise).

    A copy made with ``defer`` called with ``lo < 0`` advances nothing: it adds the
    falling-N dissipation recorded for contacts ``-lo - 1 <= i < hi`` by its last call
    (:func:`fall_dissipation`) to ``out.dissipation`` (for the iterate the caller accepts;
    the quadrature is compiled with the law, not with the caller).

    Per contact, in phases: the start (:func:`_start_row`: effective increment, normal
    law, stiffnesses), then the law -- frictionless (:func:`_frictionless_row`), elastic
    spring with a Coulomb cap (:func:`_spring_row`), or hysteretic (seed Eq. 3.9-3.16):
    the split along and across the memory axis (:func:`_md_split`, :func:`_md_across`),
    the law along the axis (:func:`md_axis`), the trial step tangent
    (:func:`_md_trial_tangent`), the Coulomb cap and the axis rules (:func:`_md_cap`) and
    the end state's tangents (:func:`_md_end`).
    """
    mu, linear = kc.mu, kc.linear
    diss_o = out.dissipation
    flags, fall = scratch.flags, scratch.fall
    defer = _DEFER == 1
    if defer and lo < 0:
        # the accepted iterate of a deferring copy: its falling-N dissipation
        for i in range(-lo - 1, hi):
            if fall[i, 0] > 0.0:
                diss_o[i] += fall_dissipation(i, fall, kc)
                fall[i, 0] = 0.0
        return
    dim = _DIM if _DIM > 0 else state.tangential_force.shape[1]
    lin = _LINEAR == 1 or (_LINEAR < 0 and linear)
    for i in range(lo, hi):
        a0e, a1, N0, N1, frac, virgin, closed1, rising, kn, kt00, kt01, kbar, rho = _start_row(
            i, kc, state, inc, out, scratch, defer, lin, dim)
        if _LAW == LAW_FRICTIONLESS or (_LAW < 0 and kc.law == LAW_FRICTIONLESS):
            _frictionless_row(i, out, dim)
            continue
        if _LAW == LAW_JENKINS or (_LAW < 0 and kc.law == LAW_JENKINS):
            _spring_row(i, kc, out, scratch, N1, closed1, kn, kt00, kt01, kbar, rho, dim)
            continue

        # ---- hysteretic law (seed Eq. 3.9-3.16): memory axis, split along/across it
        s, k, fresh, dtn, tau, d_par = _md_split(i, state, out, scratch, virgin, dim)
        falling = N1 < N0
        diss, dkbar, drr = _md_across(i, scratch, a0e, a1, rising, linear, lin, kt00, kt01, kbar, rho, dim)

        # along the axis: the 1D Mindlin-Deresiewicz / Thornton-Randall law
        elastic = False
        dPn = 0.0
        kpush = -1
        if mu > 0.0:
            tau, s, k, d_diss, elastic, flag, dPn, kpush = md_axis(
                tau, s, k, out.reversals, i, N0, N1, a0e, a1, kbar, kt00, kt01, d_par, rising, falling, kc,
                defer, fall)
            if flag != 0:
                flags[i] = flag
                continue
            diss += d_diss
        else:
            tau = 0.0
            k = 0

        muN1 = mu * N1
        tha_ok, tha = _md_trial_tangent(i, kc, out, scratch, tau, s, k, elastic, dPn, kpush, muN1, kn, kt01, kbar,
                                        dkbar, drr, d_par, fresh, dtn, frac, dim)
        tau, s, k, diss, tha_ok = _md_cap(i, out, scratch, tau, s, k, diss, tha_ok, closed1, mu, muN1, kn, kt01,
                                          dim)
        _md_end(i, kc, out, tau, s, k, diss, closed1, elastic, tha_ok, tha, muN1, kn, kt01, dim)

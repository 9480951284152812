"""Compiled (numba) Mindlin–Deresiewicz law of one contact along its memory axis.

Part of the compiled kernel :mod:`grainmech.contact.kernel` (its module notes state how it
agrees with the NumPy reference :mod:`grainmech.contact.law`): the closed forms of the
normal law and of the no-slip tangential stiffness (seed Eq. 3.2, 3.6–3.7, 3.11–3.12), the
powers of the stick exponent, the energy functions of the Iwan representation, the
reversal memory and the law along the memory axis with the dissipation of a fall of
``N`` (seed Eq. 3.9–3.16). :func:`grainmech.contact.kernel.rows` calls them per contact.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from grainmech.contact._kernel_types import (
    FALL_FIELDS,
    FALL_SEGMENTS,
    FLAG_MEMORY_FLAT,
    FLAG_MEMORY_RISING,
    FLAG_NO_TERMINATION,
    JIT_INNER,
    JIT_NO_NRT,
)
from grainmech.contact.geometry import hertz_kn, hertz_radius, mindlin_kt0

# the tolerances of the reference law (values, so that the compiled code is self-contained)
from grainmech.contact.hysteresis import MERGE_TOL, REV_TOL, TIE_TOL

__all__ = ["fall_dissipation"]

# the branch integration of :func:`md_axis`, a phase of it: inlined into it by LLVM, so
# that the law's code stays one function (as in the copies that inline md_axis itself)
_JIT_BRANCH: dict = {**JIT_NO_NRT, "forceinline": True}


# ---------------------------------------------------------------------------------------
# Closed forms of the normal law and of the no-slip tangential stiffness
# ---------------------------------------------------------------------------------------
@njit(**JIT_INNER)
def clip01(x):
    """``x`` clipped to ``[0, 1]``."""
    return min(max(x, 0.0), 1.0)


@njit(**JIT_INNER)
def normal_stiffness(N, linear, E, R, kn_lin):
    """Tangent normal stiffness: Hertz ``2 E* a`` (seed Eq. 3.7) or ``kn``; 0 when open."""
    if linear:
        return kn_lin if N > 0.0 else 0.0
    return hertz_kn(hertz_radius(N, E, R), E)


@njit(**JIT_INNER)
def noslip_stiffness(N, linear, E, R, Gs, ks_lin):
    """No-slip tangential stiffness ``8 G* a`` (seed Eq. 3.11 with theta = 1, Eq. 3.12) or ``ks``."""
    if linear:
        return ks_lin if N > 0.0 else 0.0
    return mindlin_kt0(hertz_radius(N, E, R), Gs)


@njit(**JIT_INNER)
def secant_kt(N0, N1, a0, a1, linear, r, ks_lin, kt1):
    """Mean no-slip tangential stiffness along a straight step [N/m].

    Mean no-slip stiffness along a straight step, ``dN / (r d alpha)`` (``kt0 = kn / r``);
    ``kt1 = kt0(N1)`` if the approach does not change.
    """
    if linear:
        return ks_lin if (N0 > 0.0 or N1 > 0.0) else 0.0
    da = a1 - a0
    dN = N1 - N0
    if abs(da) > 1e-14 * max(abs(a0), abs(a1)):
        return dN / (r * da)
    return kt1



# ---------------------------------------------------------------------------------------
# Powers of the stick exponent. Spheres (p = 1/3): y**(2/3) = cbrt(y)**2, z**(3/2) =
# z sqrt(z), y**(1/3) = cbrt(y) -- the same values to a few ulp, several times cheaper
# than the general power (which dominated the kernel's time).
# ---------------------------------------------------------------------------------------
@njit(**JIT_INNER)
def _pow_q(y, q, sph):
    """``y**q`` with ``q = 1 - p``."""
    if sph:
        c = np.cbrt(y)
        return c * c
    return y ** q


@njit(**JIT_INNER)
def _pow_m(z, m, sph):
    """``z**m`` with ``m = 1/(1 - p)``."""
    if sph:
        return z * math.sqrt(z)
    return z ** m


@njit(**JIT_INNER)
def pow_p(y, p, sph):
    """``y**p`` (theta, seed Eq. 3.13-3.15)."""
    if sph:
        return np.cbrt(y)
    return y ** p

# ---------------------------------------------------------------------------------------
# Energy functions of the Iwan representation (module notes of grainmech.contact.law)
# ---------------------------------------------------------------------------------------
@njit(**JIT_INNER)
def _H(z, m, hcoef, sph):
    """``H(z) = int_z^1 g`` of the Mindlin-Deresiewicz branch integral.

    ``H(z) = int_z^1 g`` with ``g(z) = 1 + (m-1) z^m - m z^(m-1)``, ``m = 1/(1-p)``;
    series in ``1 - z`` near 1 (``H ~ (1-z)^3``).

    ``sph`` (spheres, ``p = 1/3``, ``m = 3/2``): ``z^m = z sqrt(z)``, the same value to a
    few ulp as the general power (the law's decisions never depend on ``H``).
    """
    z = clip01(z)
    eps = 1.0 - z
    if eps < 0.05:
        ser = 0.0
        for j in range(len(hcoef) - 1, 1, -1):
            ser = ser * eps + hcoef[j]
        return ser * eps ** 3
    G1 = 1.0 + (m - 1.0) / (m + 1.0) - 1.0
    if sph:
        zm = z * math.sqrt(z)
        zm1 = z * zm
    else:
        zm = z ** m
        zm1 = z ** (m + 1.0)
    return G1 - (z + (m - 1.0) * zm1 / (m + 1.0) - zm)


@njit(**JIT_INNER)
def _g_of_y(y, p, m, gcoef, theta, sph):
    """Fraction of ``mu N`` carried by slipping elements, ``1 - y - (y^p - y)/(1-p)`` (>= 0).

    ``m = 1/(1-p)`` (a product instead of a division: the function serves the dissipation
    quadrature only, which agrees with the reference to rounding); ``theta``: ``y**p`` if
    already known (``< 0``: compute it).
    """
    y = clip01(y)
    eps = 1.0 - y
    if eps < 0.02:
        ser = 0.0
        for j in range(len(gcoef) - 1, 1, -1):
            ser = ser * eps + gcoef[j]
        v = ser * eps ** 2
    else:
        th = theta if theta >= 0.0 else pow_p(y, p, sph)
        v = 1.0 - y - (th - y) * m
    return max(v, 0.0)


# ---------------------------------------------------------------------------------------
# Mindlin–Deresiewicz law along the memory axis (one contact)
# ---------------------------------------------------------------------------------------
@njit(**JIT_NO_NRT)
def reversal_at(P, row, k, back):
    """``P[row, k - back]`` if ``k - back >= 0`` else 0."""
    col = k - back
    if col >= 0:
        return P[row, col]
    return 0.0


@njit(**JIT_NO_NRT)
def _branch(P, row, k):
    """The current branch of a memory of depth ``k``: ``(c, P_top, Q_target)``.

    ``c = 2`` on a Masing branch, 1 on the virgin one; ``P_top`` the invariant of the last
    reversal (0 without); ``Q_target`` the ``Q`` at which the branch closes its loop (the
    reversal before the last, or ``P_top`` on the first loop; 0 on the virgin branch).
    """
    c = 2.0 if k > 0 else 1.0
    Pt = reversal_at(P, row, k, 1)
    if k >= 2:
        Qt = reversal_at(P, row, k, 2)
    elif k == 1:
        Qt = Pt
    else:
        Qt = 0.0
    return c, Pt, Qt


@njit(**JIT_NO_NRT)
def _merge_closest_loop(P, row, k, Q, muN):
    """Full memory: forget the loop that came closest to closing (law._merge_closest_loop)."""
    best = -1
    gmin = MERGE_TOL * 2.0 * muN
    for j in range(k - 1):
        nxt = P[row, j + 2] if j + 2 < k else Q
        g = abs(P[row, j] - nxt)
        if g <= gmin and (best < 0 or g < gmin):
            gmin = g
            best = j
    if best < 0:
        return k
    for j in range(best, k - 2):
        P[row, j] = P[row, j + 2]
    return k - 2


@njit(**JIT_NO_NRT)
def _reverse(Q, k, muN, P, row, maxrev):
    """Start a branch in the opposite direction at force level ``muN``.

    A virgin contact at ``T ~ 0`` only turns; a reversal at the point where the current
    branch started erases it (pop); otherwise the reversal is remembered (push ``P = Q``).
    On the new branch ``Q' = 2 mu N - Q``. Returns ``(Q, k, overflow, pushed)``.
    """
    if k > 0:
        # Masing's rule at a tie: the loop closed within rounding of its target (law.py)
        Qt = reversal_at(P, row, k, 2) if k >= 2 else reversal_at(P, row, k, 1)
        if Q - Qt <= REV_TOL * 2.0 * muN:
            Q = min(Q, Qt)
            k = max(k - 2, 0)
    Pt = reversal_at(P, row, k, 1)
    skeleton_zero = (k == 0) and (Q >= muN * (1.0 - REV_TOL))
    fresh = (k > 0) and (Q + Pt >= 2.0 * muN * (1.0 - REV_TOL))
    if not skeleton_zero and not fresh:
        if k >= maxrev:
            k = _merge_closest_loop(P, row, k, Q, muN)
            if k >= maxrev:
                return Q, k, True, False
        P[row, k] = Q
        k += 1
    elif fresh:
        k -= 1
    return 2.0 * muN - Q, k, False, not skeleton_zero and not fresh


@njit(**JIT_INNER)
def _z_of_n(Nv, na, z0, c, q, sph=False):
    """Falling N at fixed displacement: ``z - 1/c = (z0 - 1/c) (na/N)**(1-p)`` (exact)."""
    ratio = _pow_q(na / max(Nv, 1e-300), q, sph)
    return clip01(1.0 / c + (z0 - 1.0 / c) * ratio)


@njit(**JIT_INNER)
def _fall_quadrature(ta, tb, na, c, z0, sliding_now, kc):
    """Dissipation of one segment of a fall of ``N`` (:func:`falling_n`), ``na -> tb**3``.

    12-point Gauss–Legendre in ``t = N^(1/3)`` of the rate ``mu N g(y) (-mu dN) / kt0``
    (Thornton & Randall, seed Eq. 3.11 with ``d delta = 0``; ``g`` the slipping fraction
    of the Iwan representation), with ``ta = na^(1/3)``, ``c`` and ``z0`` of the branch at
    ``na``, ``sliding_now`` gross sliding throughout.
    """
    mu, p, m_exp, sph, k8 = kc.mu, kc.p, kc.m_exp, kc.sph, kc.k8
    linear, E, R, Gs, ks_lin = kc.linear, kc.E, kc.R, kc.Gs, kc.ks_lin
    gcoef, glx, glw = kc.gcoef, kc.glx, kc.glw
    q = 1.0 - p
    half = 0.5 * (ta - tb)
    mid = 0.5 * (ta + tb)
    ic = 1.0 / c
    acc = 0.0
    acc_s = 0.0
    for g in range(len(glx)):
        tg = mid + half * glx[g]
        if sph and tg > 1e-100:
            # (na/N)**(2/3) = (ta/tg)**2, y = z**(3/2), theta = y**(1/3) = z**(1/2),
            # kt0 = 8 G* a ~ N**(1/3) = k8 tg: the integrand mu^2 N g / kt0 dN/dt
            # = (3 mu^2 / k8) g tg^4, its constant factor applied once below; with
            # p = 1/3 the slipping fraction g(y) = 1 - y - (theta - y)/(1 - p) is
            # (1 - theta)^2 (1 + theta/2) (no cancellation near y = 1, no series)
            if sliding_now:
                th = 0.0
            else:
                rt = ta / tg
                zg = clip01(ic + (z0 - ic) * (rt * rt))
                th = math.sqrt(zg)
            om = 1.0 - th
            gg = om * om * (1.0 + 0.5 * th)
            tg2 = tg * tg
            acc_s += glw[g] * gg * (tg2 * tg2)
        else:
            Ng = tg * tg * tg
            if sliding_now:
                yg = 0.0
            else:
                yg = _pow_m(_z_of_n(Ng, na, z0, c, q, sph), m_exp, sph)
            gg = _g_of_y(yg, p, m_exp, gcoef, -1.0, sph)
            kt = noslip_stiffness(Ng, linear, E, R, Gs, ks_lin)
            f = mu * mu * Ng * gg / kt if kt > 0.0 else 0.0
            acc += glw[g] * f * 3.0 * tg * tg
    if k8 > 0.0:
        acc += acc_s * (3.0 * mu * mu / k8)
    return half * acc


@njit(**JIT_NO_NRT)
def fall_dissipation(i, fall, kc):
    """The falling-``N`` dissipation :func:`rows` left out of contact ``i`` (``defer``: :func:`law_function`).

    The quadratures of the segments recorded in ``fall[i]`` (``KernelScratch.fall``),
    as :func:`falling_n` computes them otherwise; 0 when none.
    """
    d = 0.0
    for j in range(int(fall[i, 0])):
        b = 1 + FALL_FIELDS * j
        d += _fall_quadrature(fall[i, b], fall[i, b + 1], fall[i, b + 2], fall[i, b + 3], fall[i, b + 4],
                              fall[i, b + 5] != 0.0, kc)
    return d


@njit(**JIT_NO_NRT)
def falling_n(Q, s, k, P, row, N0, N1, cb0, cb1, kc, defer, fall):
    """Exact integration of a fall of ``N`` (``N0 -> N1``) at fixed tangential displacement.

    Thornton & Randall's rate law (seed Eq. 3.11 with ``d delta = 0``,
    ``d tau = s mu dN (1 - theta)``, every ``P_j`` constant; seed Eq. 3.16 for the
    shifted reversal points). Events located exactly within the fall: sliding on the
    virgin branch, erasure of the last reversal, Masing closure (bisection). Dissipation
    by 12-point Gauss–Legendre in ``N^(1/3)``; ``cb0``, ``cb1``: ``N0^(1/3)``, ``N1^(1/3)``
    if the caller knows them (spheres: ``kt0 / k8``, seed Eq. 3.2, 3.11), else negative.
    ``defer``: the quadratures of the first :data:`FALL_SEGMENTS` segments are not
    computed but recorded in ``fall[row]`` (:func:`fall_dissipation`), whose count
    ``fall[row, 0]`` the caller has zeroed. Returns ``(Q, s, k, dissipation, ok)``.
    """
    mu, p, m_exp, maxrev, sph = kc.mu, kc.p, kc.m_exp, kc.maxrev, kc.sph
    diss = 0.0
    Na = N0
    Nb = N1
    q = 1.0 - p
    it = 0
    nrec = 0
    while Na > Nb:
        it += 1
        if it > 2 * max(maxrev, 1) + 6:
            return Q, s, k, diss, False
        c, Pt, Qt = _branch(P, row, k)
        na = Na
        nb = Nb
        muNa = mu * na
        y0 = clip01((Q + Pt) / (c * muNa))
        z0 = _pow_q(y0, q, sph)

        sliding_now = (k == 0) and (z0 <= 0.0)
        n_slide = 0.0
        if k == 0 and z0 < 1.0:
            n_slide = na * _pow_m(clip01(1.0 - z0), m_exp, sph)
        if sliding_now:
            n_slide = na
        n_erase = 0.0
        if k > 0 and z0 > 0.5:
            n_erase = na * _pow_m(clip01(2.0 * z0 - 1.0), m_exp, sph)

        # Masing target reached while N falls (Q decreases monotonically with N)
        n_target = 0.0
        Qb = 0.0
        if k > 0:
            Qb = c * mu * nb * _pow_m(_z_of_n(nb, na, z0, c, q, sph), m_exp, sph) - Pt
            if Qb <= Qt:
                lo = nb
                hi = na
                for _ in range(64):
                    mid = 0.5 * (lo + hi)
                    if c * mu * mid * _pow_m(_z_of_n(mid, na, z0, c, q, sph), m_exp, sph) - Pt <= Qt:
                        lo = mid
                    else:
                        hi = mid
                n_target = hi
        n_event = max(max(n_slide, n_erase), n_target)
        if sliding_now:
            n_event = 0.0
        n_stop = max(n_event, nb)

        # dissipation on [n_stop, na]: rate mu N g(y) w / kt0 with w = -mu dN
        ta = cb0 if (na == N0 and cb0 >= 0.0) else np.cbrt(na)
        tb = cb1 if (n_stop == N1 and cb1 >= 0.0) else np.cbrt(n_stop)
        if defer and nrec < FALL_SEGMENTS:
            # the mixed-control driver: only the accepted iterate needs it (fall_dissipation)
            base = 1 + FALL_FIELDS * nrec
            fall[row, base] = ta
            fall[row, base + 1] = tb
            fall[row, base + 2] = na
            fall[row, base + 3] = c
            fall[row, base + 4] = z0
            fall[row, base + 5] = 1.0 if sliding_now else 0.0
            nrec += 1
            fall[row, 0] = nrec
        else:
            diss += _fall_quadrature(ta, tb, na, c, z0, sliding_now, kc)

        # state at n_stop
        if sliding_now:
            Qi = 0.0
        elif k > 0 and n_stop == nb:
            Qi = Qb  # the same expression at the same N (computed above)
        else:
            z_stop = _z_of_n(n_stop, na, z0, c, q, sph)
            Qi = c * mu * n_stop * _pow_m(z_stop, m_exp, sph) - Pt
        ev = (n_event >= nb) and (n_event > 0.0) and not sliding_now
        is_slide = ev and (k == 0) and (n_slide >= n_event)
        is_target = ev and (k > 0) and (n_target >= n_event) and (n_target > 0.0)
        is_erase = ev and (k > 0) and (not is_target) and (n_erase >= n_event)
        if is_slide:
            Qi = 0.0
        if is_target:
            Qi = Qt
            k = k - 2 if k >= 2 else 0
        if is_erase:
            # back on the previous branch: direction flips
            Qi = Pt
            s = -s
            k = k - 1
        Q = Qi
        Na = n_stop
    return Q, s, k, diss, True


@njit(**_JIT_BRANCH)
def _constant_n_branch(Q, k, u, P, row, N1, muN1, kt1, diss, kc):
    """Displacement ``u >= 0`` along the branch at constant ``N1``, integrated exactly in ``z`` (:func:`md_axis`).

    Seed Eq. 3.11 at constant ``N``: ``z = y**(1-p)`` is linear in the displacement;
    events within the step: Masing closure of the current loop (pop two reversals, one on
    the first loop, seed Eq. 3.14-3.15) and gross sliding on the virgin branch (the rest
    of ``u`` dissipated at ``mu N1``). ``diss`` is the dissipation so far, to which the
    branch's is added. Returns ``(Q, k, diss, ok)``; ``ok`` False when the events do not
    terminate.
    """
    p, m_exp, maxrev, hcoef, sph = kc.p, kc.m_exp, kc.maxrev, kc.hcoef, kc.sph
    q = 1.0 - p
    it = 0
    while u > 0.0 and N1 > 0.0:
        it += 1
        if it > 2 * maxrev + 4:
            return Q, k, diss, False
        c, Pt, Qt = _branch(P, row, k)
        muN = muN1
        y = clip01((Q + Pt) / (c * muN))
        yt = clip01((Qt + Pt) / (c * muN))
        z = _pow_q(y, q, sph)
        zt = _pow_q(yt, q, sph)
        lam = q * kt1 / (c * muN)
        zend = z - lam * u
        hit = not (zend > zt)
        Qend = 0.0
        if not hit:
            Qend = c * muN * _pow_m(zend, m_exp, sph) - Pt
            # Masing's rule at a tie (hysteresis.TIE_TOL): a branch that ends within
            # rounding of the reversal point it heads for has closed its loop
            hit = k > 0 and Qend - Qt <= TIE_TOL * 2.0 * muN
        zstop = zt if hit else zend
        pref = c * muN * muN / (q * kt1)
        if hit:
            used = (z - zt) / lam if math.isfinite(lam) else 0.0
        else:
            used = u
        diss += pref * max(_H(zstop, m_exp, hcoef, sph) - _H(z, m_exp, hcoef, sph), 0.0)
        rem = max(u - used, 0.0)
        Qnew = Qt if hit else Qend  # Qend: the branch at zstop = zend
        if hit and k == 0:
            # gross sliding on the virgin branch
            diss += muN * rem
            rem = 0.0
            Qnew = 0.0
        if hit:
            # Masing's memory rule: the loop closes, pop two reversals (one on the first loop)
            k = k - 2 if k >= 2 else 0
        Q = Qnew
        u = rem if hit else 0.0
    return Q, k, diss, True


@njit(**JIT_NO_NRT)
def md_axis(tau, s, k, P, row, N0, N1, a0, a1, kbar, kt0, kt1, d, rising, falling, kc, defer, fall):
    """Scalar Mindlin–Deresiewicz / Thornton–Randall law along the memory axis.

    Seed Eq. 3.11, ``d tau = 8 G* a theta d delta + s mu dN (1 - theta)``, with theta from
    Eq. 3.13 (virgin) and Eq. 3.14–3.15 (Masing branches); no slip under rising ``N`` when
    ``8 G* a |d delta| <= mu dN`` (Eq. 3.10, 3.16), else ``N`` first along the no-slip
    boundary, then the displacement at constant ``N`` integrated exactly in ``z``.

    Returns ``(tau, s, k, dissipation, elastic, flag, dP, kpush)``; ``P`` (the contact's
    reversal row) is updated in place; ``dP = d P_(kpush-1) / d N1`` for a reversal pushed
    at ``N1`` (``kpush = -1``: none), for the step tangent.
    """
    mu, p, r, maxrev, sph = kc.mu, kc.p, kc.r, kc.maxrev, kc.sph
    diss = 0.0
    dP = 0.0
    kpush = -1
    muN0 = mu * N0
    muN1 = mu * N1
    Q = min(max(muN0 - s * tau, 0.0), 2.0 * muN0)
    if d > 0.0:
        dsign = 1
    elif d < 0.0:
        dsign = -1
    else:
        dsign = 0
    u = 0.0

    # rising N: elastic (Eq. 3.10) or N first on the no-slip boundary
    dalpha = a1 - a0
    bound = mu * r * max(dalpha, 0.0)
    elastic = rising and (abs(d) <= bound)
    if elastic:
        tau_e = tau + kbar * d
        Q = muN1 - s * tau_e
    if rising and not elastic:
        if dsign != s:
            Q, k, full, _pushed = _reverse(Q, k, muN0, P, row, maxrev)
            if full:
                return tau, s, k, diss, False, FLAG_MEMORY_RISING, 0.0, -1
            s = dsign
        u = abs(d) - bound

    # falling N at fixed displacement (exact), then the displacement
    if falling:
        if sph and kc.k8 > 0.0:  # N^(1/3) = kt0(N) / k8 (seed Eq. 3.2, 3.11): no cube roots
            cb0 = kt0 / kc.k8
            cb1 = kt1 / kc.k8
        else:
            cb0 = -1.0
            cb1 = -1.0
        Q, s, k, dd, ok = falling_n(Q, s, k, P, row, N0, N1, cb0, cb1, kc, defer, fall)
        if not ok:
            return tau, s, k, diss, False, FLAG_NO_TERMINATION, 0.0, -1
        diss += dd
    if (not rising) and (d != 0.0) and (N1 > 0.0):
        if dsign != s:
            # the invariant pushed here, P = Q(N1), moves with N1 like Q on the branch
            # before: dP/dN1 = mu theta (Thornton-Randall, see falling_n); for the step tangent
            cpre = 2.0 if k > 0 else 1.0
            ypre = clip01((Q + reversal_at(P, row, k, 1)) / (cpre * muN1))
            th_pre = pow_p(ypre, p, sph)
            Q, k, full, pushed = _reverse(Q, k, muN1, P, row, maxrev)
            if full:
                return tau, s, k, diss, False, FLAG_MEMORY_FLAT, 0.0, -1
            s = dsign
            if pushed:
                dP = mu * th_pre
                kpush = k
        u = abs(d)

    # displacement u >= 0 along s at constant N1: exact branch integration with events
    Q, k, diss, ok = _constant_n_branch(Q, k, u, P, row, N1, muN1, kt1, diss, kc)
    if not ok:
        return tau, s, k, diss, False, FLAG_NO_TERMINATION, 0.0, -1

    tau_new = s * (muN1 - Q)
    if (not rising) and (not falling) and d == 0.0:
        tau_new = tau
    if not N1 > 0.0:
        tau_new = 0.0
    tau_new = min(max(tau_new, -muN1), muN1)
    return tau_new, s, k, diss, elastic and (N1 > 0.0), 0, dP, kpush

r"""Compiled (numba) per-contact kernel of :func:`grainmech.contact.update`.

The NumPy implementation in :mod:`grainmech.contact.law` is the reference; this module
evaluates *the same* algorithm contact by contact in a compiled scalar loop (optionally
parallel over contacts), which removes the per-call overhead of the many small NumPy
operations of the vectorised path. It is selected with ``update(..., backend="auto" |
"numba")`` and covers

* :class:`~grainmech.contact.MindlinDeresiewicz` (Hertz normal law, seed Eq. 3.6–3.7,
  Mindlin–Deresiewicz tangential law with the Thornton–Randall rules, seed Eq. 3.9–3.16),
* :class:`~grainmech.contact.HertzMindlin` and :class:`~grainmech.contact.LinearSpring`
  (no-slip spring, seed Eq. 3.11 with theta = 1, Eq. 3.12, with a Coulomb cap),
* frictionless :class:`~grainmech.contact.Hertz`.

Rods (:class:`~grainmech.contact.Cylinder`, whose normal law needs a Newton inversion of
the integral of seed Eq. 3.8) stay on the NumPy path.

Nothing here is a new model: every branch mirrors a line of the reference, with the
same floating-point evaluation order where that is possible, so the two paths agree to
rounding (the power and cube-root functions of NumPy and of the compiled code may
differ in the last bits; ``tests/test_contact_kernel.py`` checks agreement to 1e-12).
This module imports numba at import time; :mod:`grainmech.contact.law` imports it
lazily and falls back to NumPy when numba is missing.

Agreement with the reference, precisely:

* The closed forms of the normal law (``N``, seed Eq. 3.6; the contact radius, Eq. 3.2,
  hence ``kn`` and ``kt0``) are evaluated by the caller with the reference's vectorised
  NumPy functions and are identical. The elastic–Coulomb laws then agree bit for bit.
* NumPy evaluates ``**`` with its own SIMD routine, which differs from the C library's
  in the last bit for a few per cent of the arguments, so the Mindlin–Deresiewicz
  forces, tangents and dissipation agree to rounding, not bit for bit (measured: 1e-15
  of ``mu N`` on forces, 1e-15 of ``kt0`` on stiffnesses).
* An event that falls *exactly* on the end of a step (a branch that ends, to rounding,
  on the reversal point it started from) may be taken by one path and not by the other.
  The two states are then equivalent (a loop of zero width closed or still remembered;
  the next reversal there erases it) but their ``depth`` differs by two.
* The reference recombines ``T = tau e + T_perp`` for all contacts of a call when any
  contact realigns its memory axis; the kernel always does, so its result for a contact
  never depends on the other contacts of the call (one ulp of ``T`` at most).
* Sphere-only shortcuts in the dissipation integrals (``z^(3/2) = z sqrt(z)`` and, in
  the Gauss–Legendre sum over a fall of ``N``, ``(N_a/N)^(2/3) = (t_a/t)^2``,
  ``kt0(N) = 8 G* (3 R*/(4 E*))^(1/3) N^(1/3)``, hence the integrand
  ``(3 mu^2/k8) g t^4``, and ``g(y) = (1 - theta)^2 (1 + theta/2)`` for ``p = 1/3``)
  are exact identities evaluated with different rounding.
* The copies made by :func:`law_function` for the mixed-control driver (``defer``) add
  the dissipation of a fall of ``N`` only when the caller accepts the iterate, after the
  rest of the step's dissipation (rounding only); everything else they compute equals
  :func:`rows` bit for bit.

Structure: ``_rows`` advances a chunk of contacts; the kernel runs the chunks in a loop
(serial) or a ``prange`` (parallel, from :data:`PARALLEL_THRESHOLD` contacts). The law's
functions allocate nothing and are compiled without numba's reference counting (no atomic
increments of the arrays passed between them), and none is inlined at numba-IR level:
that made the first run compile the law for ~16 s instead of ~5 s, and LLVM inlines the
small helpers anyway. The mixed-control driver calls the law through
:func:`law_function`: a copy of ``rows`` specialised to one law, compiled once and called
through its address rather than linked (and re-optimised) into every caller. So does
:func:`update_kernel` for 3D Mindlin–Deresiewicz contacts (the copy without ``defer``,
specialised to 3D with the axis law inlined: 8–19 % less time per contact than the
generic ``rows``, identical results); other laws and dimensions run the generic ``rows``.

Notation (as in :mod:`grainmech.contact.law`): ``Q = mu N - s tau`` is the distance of
the current state from the friction limit it moves towards; ``P_j = mu N + s_j tau_j``
the invariant of remembered reversal ``j``; ``y`` the argument of theta (seed Eq. 3.13
on the virgin branch, Eq. 3.14–3.15 on a Masing branch), ``theta = y**p``; ``z =
y**(1-p)``, linear in the displacement at constant ``N``; ``c = 1`` on the virgin branch
and ``2`` on a Masing branch.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numba import get_num_threads, njit, prange

from grainmech.contact import law as _law
from grainmech.contact.geometry import hertz_kn, hertz_radius, mindlin_kt0
from grainmech.contact.params import ContactParams, Hertz, LinearSpring, MindlinDeresiewicz

__all__ = ["update_kernel", "rows", "law_function", "fall_dissipation", "FALL_COLUMNS", "law_signature", "law_key",
           "compile_law", "law_compiled",
           "constants", "KernelConstants", "KernelState", "KernelIncrement",
           "KernelOutput", "KernelScratch", "LAW_MD", "LAW_JENKINS", "LAW_FRICTIONLESS",
           "PARALLEL_THRESHOLD"]

#: law codes (``law_kind`` of :mod:`grainmech.contact.law`)
LAW_MD = 0
LAW_JENKINS = 1
LAW_FRICTIONLESS = 2

#: status codes returned by the kernel
OK = 0
BAD_DNORMAL = 1        # d_normal not finite
BAD_DTANGENTIAL = 2    # d_tangential not finite
#: per-contact flags
FLAG_MEMORY_RISING = 1   # reversal memory full in the rising-N reversal (checked first)
FLAG_MEMORY_FLAT = 2     # reversal memory full in the constant/falling-N reversal
FLAG_NO_TERMINATION = 3  # branch integration did not terminate (never observed)

_EPS = 1e-12
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
#: falling-N segments whose quadrature a deferring copy records per contact (more are
#: integrated at once), and the values recorded per segment (KernelScratch.fall)
_FALL_SEGMENTS = 2
_FALL_FIELDS = 6
FALL_COLUMNS = 1 + _FALL_SEGMENTS * _FALL_FIELDS
# the tolerances of the reference law (values, so that the compiled code is self-contained)
_REV_TOL = _law._REV_TOL
_PAR_TOL = _law._PAR_TOL
_TIE_TOL = _law._TIE_TOL
_MERGE_TOL = _law._MERGE_TOL
_CHUNK = 256   # contacts per call of the row loop (and per parallel work item)
_JIT: dict[str, Any] = {"cache": True, "error_model": "numpy", "fastmath": False}
# the per-contact law allocates nothing: compiled without numba's reference counting (the
# atomic increments and decrements of the arrays passed between its functions took ~12 %
# of the mixed-control driver's time)
# Functions only called from compiled code are compiled without the wrappers that make
# them callable from Python and from C (generating and optimising those took ~15 % of the
# first run's compilation: the law's arguments are tuples of many arrays).
_JIT_NO_NRT: dict[str, Any] = {**_JIT, "_nrt": False, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}
_JIT_INNER: dict[str, Any] = {**_JIT, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


# ---------------------------------------------------------------------------------------
# Arguments of the kernel: named tuples (numba passes them by value, fields by name)
# ---------------------------------------------------------------------------------------
class KernelConstants(NamedTuple):
    """Scalar constants and tables of one contact law (:func:`constants`).

    ``law`` is :data:`LAW_MD`, :data:`LAW_JENKINS` or :data:`LAW_FRICTIONLESS`; ``linear``
    a linear normal spring (``kn_lin``, ``ks_lin`` [N/m]) instead of Hertz (``E`` = E*,
    ``R`` = R*, ``Gs`` = G*, seed Eq. 3.12); ``mu`` the friction coefficient
    (``mu_finite``: not infinite); ``r = kn/kt0``; ``p`` the stick exponent of theta
    (seed Eq. 3.13-3.17) and ``m_exp = 1/(1-p)``; ``maxrev`` the reversal memory;
    ``hcoef``, ``gcoef`` the series of the energy functions; ``glx``, ``glw`` a
    Gauss-Legendre rule; ``sph`` spheres (p = 1/3, power shortcuts); ``k8`` with
    ``kt0(N) = k8 N^(1/3)`` (seed Eq. 3.2, 3.11).
    """

    law: int
    linear: bool
    E: float
    R: float
    Gs: float
    kn_lin: float
    ks_lin: float
    mu: float
    mu_finite: bool
    r: float
    p: float
    m_exp: float
    maxrev: int
    hcoef: tuple
    gcoef: tuple
    glx: tuple
    glw: tuple
    sph: bool
    k8: float


class KernelState(NamedTuple):
    """State arrays of ``n`` contacts passed to the compiled kernel.

    State arrays of ``n`` contacts (the fields of :class:`~grainmech.contact.ContactState`
    without ``sliding``): approach (n,), normal_force (n,), tangential_force (n, dim),
    axis (n, dim), direction int8 (n,), depth int32 (n,), reversals (n, max_reversals),
    dissipated_energy (n,).
    """

    approach: np.ndarray
    normal_force: np.ndarray
    tangential_force: np.ndarray
    axis: np.ndarray
    direction: np.ndarray
    depth: np.ndarray
    reversals: np.ndarray
    dissipated_energy: np.ndarray


class KernelIncrement(NamedTuple):
    """One increment of ``n`` contacts passed to the compiled kernel.

    One step: ``d_normal`` (n,), ``d_tangential`` (n, dim), the normal force at its end
    ``N1`` (n,) (seed Eq. 3.6 or ``kn alpha``) and the Hertz contact radii ``rad0``,
    ``rad1`` (n,) at its start and end (seed Eq. 3.2; any values for linear springs).
    """

    d_normal: np.ndarray
    d_tangential: np.ndarray
    N1: np.ndarray
    rad0: np.ndarray
    rad1: np.ndarray


class KernelOutput(NamedTuple):
    """Arrays the compiled kernel writes: the new state and the response.

    Arrays the kernel writes: the new state (as :class:`KernelState`, ``dissipated_energy``
    excepted) and the response (``sliding``, ``dissipation`` of the step, ``ks``,
    ``ks_perp``, ``ktn``, ``kn``, ``open``), all (n,) or (n, dim) / (n, max_reversals);
    ``t_delta`` (n, dim, dim) and ``t_alpha`` (n, dim), the step derivatives ``dT1/d d_t``
    and ``dT1/d alpha`` (:class:`~grainmech.contact.ContactResponse`).
    """

    approach: np.ndarray
    normal_force: np.ndarray
    tangential_force: np.ndarray
    axis: np.ndarray
    direction: np.ndarray
    depth: np.ndarray
    reversals: np.ndarray
    sliding: np.ndarray
    dissipation: np.ndarray
    ks: np.ndarray
    ks_perp: np.ndarray
    ktn: np.ndarray
    kn: np.ndarray
    open: np.ndarray
    t_delta: np.ndarray
    t_alpha: np.ndarray


class KernelScratch(NamedTuple):
    """Work rows and per-contact status flags of the compiled kernel.

    Work rows (n, dim) ``tp``, ``dp`` and per-contact ``flags`` int8 (n,) (0: done;
    1/2 reversal memory full on a rising / constant or falling N; 3 no termination);
    ``fall`` (n, :data:`FALL_COLUMNS`) the falling-N segments whose dissipation a
    deferring law copy left to :func:`fall_dissipation` (any (n, 0) array otherwise).
    """

    tp: np.ndarray
    dp: np.ndarray
    flags: np.ndarray
    fall: np.ndarray


def new_output(n: int, dim: int, max_reversals: int) -> KernelOutput:
    """Uninitialised :class:`KernelOutput` arrays for ``n`` contacts."""
    return KernelOutput(np.empty(n), np.empty(n), np.empty((n, dim)), np.empty((n, dim)),
                        np.empty(n, dtype=np.int8), np.empty(n, dtype=np.int32),
                        np.empty((n, max_reversals)), np.empty(n, dtype=np.bool_), np.empty(n),
                        np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_),
                        np.empty((n, dim, dim)), np.empty((n, dim)))


def new_scratch(n: int, dim: int) -> KernelScratch:
    """:class:`KernelScratch` for ``n`` contacts."""
    return KernelScratch(np.empty((n, dim)), np.empty((n, dim)), np.zeros(n, dtype=np.int8), np.empty((n, 0)))


_CONSTANTS: dict = {}


def constants(params: ContactParams) -> KernelConstants:
    """:class:`KernelConstants` of a contact parameter object (cached per object)."""
    try:
        return _CONSTANTS[params]
    except (KeyError, TypeError):
        pass
    kind = _law.law_kind(params)
    forms = _law.law_forms(params)
    linear = forms.linear
    if isinstance(params, LinearSpring):
        E = R = Gs = 1.0
        kn_lin, ks_lin = float(params.kn), float(params.ks)
    elif isinstance(params, Hertz):
        E = float(params.effective_modulus)
        R = float(params.effective_radius)
        Gs = float(params.effective_shear_modulus)
        kn_lin = ks_lin = 0.0
    else:
        raise TypeError(f"no compiled kernel for {type(params).__name__} (rods use the NumPy law)")
    mu = float(params.friction)
    p = float(params.stick_exponent) if isinstance(params, MindlinDeresiewicz) else 1.0 / 3.0
    m_exp = 1.0 / (1.0 - p)
    kc = KernelConstants(
        {"md": LAW_MD, "jenkins": LAW_JENKINS, "frictionless": LAW_FRICTIONLESS}[kind], linear,
        E, R, Gs, kn_lin, ks_lin, mu, math.isfinite(mu), float(forms.ratio), p, m_exp,
        int(_law.max_reversals(params)),
        # series and quadrature tables as tuples: values, not arrays (no reference counting
        # in the compiled per-contact loop)
        tuple(map(float, _law._h_series(m_exp))), tuple(map(float, _law._g_series(p))),
        tuple(map(float, _law._GL_X)), tuple(map(float, _law._GL_W)),
        (not linear) and p == 1.0 / 3.0,
        # kt0(N) = 8 G* a(N) = k8 N^(1/3) (seed Eq. 3.2, 3.11)
        0.0 if linear else float(mindlin_kt0(hertz_radius(1.0, E, R), Gs)))
    try:
        _CONSTANTS[params] = kc
    except TypeError:  # pragma: no cover - unhashable user subclass
        pass
    return kc


# ---------------------------------------------------------------------------------------
# Closed forms of the normal law and of the no-slip tangential stiffness
# ---------------------------------------------------------------------------------------
@njit(**_JIT_INNER)
def _clip01(x):
    return min(max(x, 0.0), 1.0)


@njit(**_JIT_INNER)
def _kn(N, linear, E, R, kn_lin):
    """Tangent normal stiffness: Hertz ``2 E* a`` (seed Eq. 3.7) or ``kn``; 0 when open."""
    if linear:
        return kn_lin if N > 0.0 else 0.0
    return hertz_kn(hertz_radius(N, E, R), E)


@njit(**_JIT_INNER)
def _kt0(N, linear, E, R, Gs, ks_lin):
    """No-slip tangential stiffness ``8 G* a`` (seed Eq. 3.11 with theta = 1, Eq. 3.12) or ``ks``."""
    if linear:
        return ks_lin if N > 0.0 else 0.0
    return mindlin_kt0(hertz_radius(N, E, R), Gs)


@njit(**_JIT_INNER)
def _secant_kt(N0, N1, a0, a1, linear, r, ks_lin, kt1):
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
@njit(**_JIT_INNER)
def _pow_q(y, q, sph):
    """``y**q`` with ``q = 1 - p``."""
    if sph:
        c = np.cbrt(y)
        return c * c
    return y ** q


@njit(**_JIT_INNER)
def _pow_m(z, m, sph):
    """``z**m`` with ``m = 1/(1 - p)``."""
    if sph:
        return z * math.sqrt(z)
    return z ** m


@njit(**_JIT_INNER)
def _pow_p(y, p, sph):
    """``y**p`` (theta, seed Eq. 3.13-3.15)."""
    if sph:
        return np.cbrt(y)
    return y ** p

# ---------------------------------------------------------------------------------------
# Energy functions of the Iwan representation (module notes of grainmech.contact.law)
# ---------------------------------------------------------------------------------------
@njit(**_JIT_INNER)
def _H(z, m, hcoef, sph):
    """``H(z) = int_z^1 g`` of the Mindlin-Deresiewicz branch integral.

    ``H(z) = int_z^1 g`` with ``g(z) = 1 + (m-1) z^m - m z^(m-1)``, ``m = 1/(1-p)``;
    series in ``1 - z`` near 1 (``H ~ (1-z)^3``).

    ``sph`` (spheres, ``p = 1/3``, ``m = 3/2``): ``z^m = z sqrt(z)``, the same value to a
    few ulp as the general power (the law's decisions never depend on ``H``).
    """
    z = _clip01(z)
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


@njit(**_JIT_INNER)
def _g_of_y(y, p, m, gcoef, theta, sph):
    """Fraction of ``mu N`` carried by slipping elements, ``1 - y - (y^p - y)/(1-p)`` (>= 0).

    ``m = 1/(1-p)`` (a product instead of a division: the function serves the dissipation
    quadrature only, which agrees with the reference to rounding); ``theta``: ``y**p`` if
    already known (``< 0``: compute it).
    """
    y = _clip01(y)
    eps = 1.0 - y
    if eps < 0.02:
        ser = 0.0
        for j in range(len(gcoef) - 1, 1, -1):
            ser = ser * eps + gcoef[j]
        v = ser * eps ** 2
    else:
        th = theta if theta >= 0.0 else _pow_p(y, p, sph)
        v = 1.0 - y - (th - y) * m
    return max(v, 0.0)


# ---------------------------------------------------------------------------------------
# Mindlin–Deresiewicz law along the memory axis (one contact)
# ---------------------------------------------------------------------------------------
@njit(**_JIT_NO_NRT)
def _top(P, row, k, back):
    """``P[row, k - back]`` if ``k - back >= 0`` else 0."""
    col = k - back
    if col >= 0:
        return P[row, col]
    return 0.0


@njit(**_JIT_NO_NRT)
def _merge_closest_loop(P, row, k, Q, muN):
    """Full memory: forget the loop that came closest to closing (law._merge_closest_loop)."""
    best = -1
    gmin = _MERGE_TOL * 2.0 * muN
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


@njit(**_JIT_NO_NRT)
def _reverse(Q, k, muN, P, row, maxrev):
    """Start a branch in the opposite direction at force level ``muN``.

    A virgin contact at ``T ~ 0`` only turns; a reversal at the point where the current
    branch started erases it (pop); otherwise the reversal is remembered (push ``P = Q``).
    On the new branch ``Q' = 2 mu N - Q``. Returns ``(Q, k, overflow, pushed)``.
    """
    if k > 0:
        # Masing's rule at a tie: the loop closed within rounding of its target (law.py)
        Qt = _top(P, row, k, 2) if k >= 2 else _top(P, row, k, 1)
        if Q - Qt <= _REV_TOL * 2.0 * muN:
            Q = min(Q, Qt)
            k = max(k - 2, 0)
    Pt = _top(P, row, k, 1)
    skeleton_zero = (k == 0) and (Q >= muN * (1.0 - _REV_TOL))
    fresh = (k > 0) and (Q + Pt >= 2.0 * muN * (1.0 - _REV_TOL))
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


@njit(**_JIT_INNER)
def _z_of_n(Nv, na, z0, c, q, sph=False):
    """Falling N at fixed displacement: ``z - 1/c = (z0 - 1/c) (na/N)**(1-p)`` (exact)."""
    ratio = _pow_q(na / max(Nv, 1e-300), q, sph)
    return _clip01(1.0 / c + (z0 - 1.0 / c) * ratio)


@njit(**_JIT_INNER)
def _fall_quadrature(ta, tb, na, c, z0, sliding_now, kc):
    """Dissipation of one segment of a fall of ``N`` (:func:`_falling_n`), ``na -> tb**3``.

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
                zg = _clip01(ic + (z0 - ic) * (rt * rt))
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
            kt = _kt0(Ng, linear, E, R, Gs, ks_lin)
            f = mu * mu * Ng * gg / kt if kt > 0.0 else 0.0
            acc += glw[g] * f * 3.0 * tg * tg
    if k8 > 0.0:
        acc += acc_s * (3.0 * mu * mu / k8)
    return half * acc


@njit(**_JIT_NO_NRT)
def fall_dissipation(i, fall, kc):
    """The falling-``N`` dissipation :func:`rows` left out of contact ``i`` (``defer``: :func:`law_function`).

    The quadratures of the segments recorded in ``fall[i]`` (``KernelScratch.fall``),
    as :func:`_falling_n` computes them otherwise; 0 when none.
    """
    d = 0.0
    for j in range(int(fall[i, 0])):
        b = 1 + _FALL_FIELDS * j
        d += _fall_quadrature(fall[i, b], fall[i, b + 1], fall[i, b + 2], fall[i, b + 3], fall[i, b + 4],
                              fall[i, b + 5] != 0.0, kc)
    return d


@njit(**_JIT_NO_NRT)
def _falling_n(Q, s, k, P, row, N0, N1, cb0, cb1, kc, defer, fall):
    """Exact integration of a fall of ``N`` (``N0 -> N1``) at fixed tangential displacement.

    Thornton & Randall's rate law (seed Eq. 3.11 with ``d delta = 0``,
    ``d tau = s mu dN (1 - theta)``, every ``P_j`` constant; seed Eq. 3.16 for the
    shifted reversal points). Events located exactly within the fall: sliding on the
    virgin branch, erasure of the last reversal, Masing closure (bisection). Dissipation
    by 12-point Gauss–Legendre in ``N^(1/3)``; ``cb0``, ``cb1``: ``N0^(1/3)``, ``N1^(1/3)``
    if the caller knows them (spheres: ``kt0 / k8``, seed Eq. 3.2, 3.11), else negative.
    ``defer``: the quadratures of the first :data:`_FALL_SEGMENTS` segments are not
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
        c = 2.0 if k > 0 else 1.0
        Pt = _top(P, row, k, 1)
        if k >= 2:
            Qt = _top(P, row, k, 2)
        elif k == 1:
            Qt = Pt
        else:
            Qt = 0.0
        na = Na
        nb = Nb
        muNa = mu * na
        y0 = _clip01((Q + Pt) / (c * muNa))
        z0 = _pow_q(y0, q, sph)

        sliding_now = (k == 0) and (z0 <= 0.0)
        n_slide = 0.0
        if k == 0 and z0 < 1.0:
            n_slide = na * _pow_m(_clip01(1.0 - z0), m_exp, sph)
        if sliding_now:
            n_slide = na
        n_erase = 0.0
        if k > 0 and z0 > 0.5:
            n_erase = na * _pow_m(_clip01(2.0 * z0 - 1.0), m_exp, sph)

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
        if defer and nrec < _FALL_SEGMENTS:
            # the mixed-control driver: only the accepted iterate needs it (fall_dissipation)
            base = 1 + _FALL_FIELDS * nrec
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


@njit(**_JIT_NO_NRT)
def _md_axis(tau, s, k, P, row, N0, N1, a0, a1, kbar, kt0, kt1, d, rising, falling, kc, defer, fall):
    """Scalar Mindlin–Deresiewicz / Thornton–Randall law along the memory axis.

    Seed Eq. 3.11, ``d tau = 8 G* a theta d delta + s mu dN (1 - theta)``, with theta from
    Eq. 3.13 (virgin) and Eq. 3.14–3.15 (Masing branches); no slip under rising ``N`` when
    ``8 G* a |d delta| <= mu dN`` (Eq. 3.10, 3.16), else ``N`` first along the no-slip
    boundary, then the displacement at constant ``N`` integrated exactly in ``z``.

    Returns ``(tau, s, k, dissipation, elastic, flag, dP, kpush)``; ``P`` (the contact's
    reversal row) is updated in place; ``dP = d P_(kpush-1) / d N1`` for a reversal pushed
    at ``N1`` (``kpush = -1``: none), for the step tangent.
    """
    mu, p, m_exp, r, maxrev, hcoef, sph = kc.mu, kc.p, kc.m_exp, kc.r, kc.maxrev, kc.hcoef, kc.sph
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
        Q, s, k, dd, ok = _falling_n(Q, s, k, P, row, N0, N1, cb0, cb1, kc, defer, fall)
        if not ok:
            return tau, s, k, diss, False, FLAG_NO_TERMINATION, 0.0, -1
        diss += dd
    if (not rising) and (d != 0.0) and (N1 > 0.0):
        if dsign != s:
            # the invariant pushed here, P = Q(N1), moves with N1 like Q on the branch
            # before: dP/dN1 = mu theta (Thornton-Randall, see _falling_n); for the step tangent
            cpre = 2.0 if k > 0 else 1.0
            ypre = _clip01((Q + _top(P, row, k, 1)) / (cpre * muN1))
            th_pre = _pow_p(ypre, p, sph)
            Q, k, full, pushed = _reverse(Q, k, muN1, P, row, maxrev)
            if full:
                return tau, s, k, diss, False, FLAG_MEMORY_FLAT, 0.0, -1
            s = dsign
            if pushed:
                dP = mu * th_pre
                kpush = k
        u = abs(d)

    # displacement u >= 0 along s at constant N1: exact branch integration with events
    q = 1.0 - p
    it = 0
    while u > 0.0 and N1 > 0.0:
        it += 1
        if it > 2 * maxrev + 4:
            return tau, s, k, diss, False, FLAG_NO_TERMINATION, 0.0, -1
        c = 2.0 if k > 0 else 1.0
        Pt = _top(P, row, k, 1)
        if k >= 2:
            Qt = _top(P, row, k, 2)
        elif k == 1:
            Qt = Pt
        else:
            Qt = 0.0
        muN = muN1
        y = _clip01((Q + Pt) / (c * muN))
        yt = _clip01((Qt + Pt) / (c * muN))
        z = _pow_q(y, q, sph)
        zt = _pow_q(yt, q, sph)
        lam = q * kt1 / (c * muN)
        zend = z - lam * u
        hit = not (zend > zt)
        Qend = 0.0
        if not hit:
            Qend = c * muN * _pow_m(zend, m_exp, sph) - Pt
            # Masing's rule at a tie (hysteresis._TIE_TOL): a branch that ends within
            # rounding of the reversal point it heads for has closed its loop
            hit = k > 0 and Qend - Qt <= _TIE_TOL * 2.0 * muN
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

    tau_new = s * (muN1 - Q)
    if (not rising) and (not falling) and d == 0.0:
        tau_new = tau
    if not N1 > 0.0:
        tau_new = 0.0
    tau_new = min(max(tau_new, -muN1), muN1)
    return tau_new, s, k, diss, elastic and (N1 > 0.0), 0, dP, kpush


# ---------------------------------------------------------------------------------------
# One contact: 3D treatment, Coulomb cap, tangents
# ---------------------------------------------------------------------------------------
@njit(**_JIT_NO_NRT)
def _dot_rows(A, i, B, j, dim):
    """``A[i, :dim] . B[j, :dim]`` (``dim`` a compile-time constant in a specialised copy of :func:`rows`)."""
    out = A[i, 0] * B[j, 0]
    for c in range(1, dim):
        out = out + A[i, c] * B[j, c]
    return out


@njit(**_JIT_NO_NRT)
def _axis_tangent(i, e, ks, ksp, ktn, tdel, talp, dim):
    """Step tangent of the form ``ks e e + ks_perp (I - e e)``, ``dT/d alpha = ktn e``."""
    for c in range(dim):
        talp[i, c] = ktn * e[i, c]
        for c2 in range(dim):
            tdel[i, c, c2] = (ks - ksp) * e[i, c] * e[i, c2] + (ksp if c == c2 else 0.0)


@njit(**_JIT_NO_NRT)
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


@njit(**_JIT_NO_NRT)
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
    """
    law, linear, E, R, Gs, kn_lin, ks_lin = kc.law, kc.linear, kc.E, kc.R, kc.Gs, kc.kn_lin, kc.ks_lin
    mu, mu_finite, r = kc.mu, kc.mu_finite, kc.r
    alpha0, N0s, T0s, e0s, dir0, depth0, P0, _diss0 = state
    dn, dt, N1s, rad0, rad1 = inc
    (alpha1o, N1o, T1, e1, s1o, k1o, P1, slide_o, diss_o, ks_o, ksp_o, ktn_o, kn_o, open_o,
     tdel, talp) = out
    tp, dp, flags, fall = scratch
    defer = _DEFER == 1
    if defer and lo < 0:
        # the accepted iterate of a deferring copy: its falling-N dissipation
        for i in range(-lo - 1, hi):
            if fall[i, 0] > 0.0:
                diss_o[i] += fall_dissipation(i, fall, kc)
                fall[i, 0] = 0.0
        return
    p = kc.p
    dim = _DIM if _DIM > 0 else T0s.shape[1]
    for i in range(lo, hi):
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
        if _LINEAR == 1 or (_LINEAR < 0 and linear):
            kn = _kn(N1, linear, E, R, kn_lin)
            kt01 = _kt0(N1, linear, E, R, Gs, ks_lin)
        else:
            # contact radius (seed Eq. 3.2, by the caller) for kn = 2 E* a (Eq. 3.7) and
            # kt0 = 8 G* a (Eq. 3.11 with theta = 1)
            a_1 = rad1[i]
            kn = hertz_kn(a_1, E)
            kt01 = mindlin_kt0(a_1, Gs)
        kn_o[i] = kn
        closed1 = N1 > 0.0
        if _LINEAR == 1 or (_LINEAR < 0 and linear):
            kt00 = _kt0(N0, linear, E, R, Gs, ks_lin)
        else:
            kt00 = mindlin_kt0(rad0[i], Gs)
        rising = N1 > N0
        kbar = _secant_kt(N0, N1, a0e, a1, linear, r, ks_lin, kt01) if rising else kt01
        if (kt00 > 0.0) and (kt01 < kt00):
            rho = kt01 / kt00
        else:
            rho = 1.0

        if _LAW == LAW_FRICTIONLESS or (_LAW < 0 and law == LAW_FRICTIONLESS):
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
            continue

        if _LAW == LAW_JENKINS or (_LAW < 0 and law == LAW_JENKINS):
            # elastic spring (seed Eq. 3.11 with theta = 1), rescaled when the area shrinks,
            # Coulomb cap by radial return
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
            continue

        # ---- hysteretic law (seed Eq. 3.9-3.16): memory axis, split along/across it
        s = 1 if virgin else int(dir0[i])
        k = 0 if virgin else int(depth0[i])
        diss = 0.0
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
        if abs(d_par) <= _PAR_TOL * dtn:  # rounding only: at right angles to the axis (law.py)
            d_par = 0.0
        for c in range(dim):
            tp[i, c] = T1[i, c] - tau * e1[i, c]
            dp[i, c] = dp[i, c] - d_par * e1[i, c]
        falling = N1 < N0

        # across the axis: elastic (no-slip) with rescaling when the area shrinks
        tp2 = _dot_rows(tp, i, tp, i, dim)
        if kt00 > 0.0:
            diss += (1.0 - rho) * tp2 / (2.0 * kt00)
        for c in range(dim):
            tp[i, c] = rho * tp[i, c] + kbar * dp[i, c]
        # step derivatives of kbar and rho with respect to the approach a1 (Hertz:
        # kt0 = kn / r ~ a1**(1/2), d kt0 / d a1 = kt0 / (2 a1); linear springs: 0)
        dkt1 = 0.0 if (linear or not (a1 > 0.0)) else kt01 / (2.0 * a1)
        if rising:
            da = a1 - a0e
            if _LINEAR == 1 or (_LINEAR < 0 and linear):
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

        # along the axis: the 1D Mindlin-Deresiewicz / Thornton-Randall law
        elastic = False
        if mu > 0.0:
            tau, s, k, d_diss, elastic, flag, dPn, kpush = _md_axis(
                tau, s, k, P1, i, N0, N1, a0e, a1, kbar, kt00, kt01, d_par, rising, falling, kc, defer, fall)
            if flag != 0:
                flags[i] = flag
                continue
            diss += d_diss
        else:
            tau = 0.0
            k = 0

        muN1 = mu * N1
        # step tangent of the trial force tau e + T_perp (before the Coulomb cap):
        # along e d tau/d d = kbar (no-slip step of rising N) or 8 G* a theta (seed
        # Eq. 3.11 at constant N1, exact for the z-integration), d tau/d a1 = the
        # secant's derivative, or s mu (1 - theta) kn (Thornton-Randall coupling, exact
        # for spheres after a rise or a fall of N); across e kbar (tau/|d| for an axis
        # just taken from the motion), d T_perp/d a1 from kbar(a1) and rho(a1)
        tha_ok = False  # tha is theta of the end state (reused below while tau, s, k hold)
        tha = 0.0
        if mu > 0.0:
            if elastic:
                a_e = kbar
                a_n = d_par * dkbar
            else:
                tha_ok = True
                Qa = muN1 - s * tau
                Pa = _top(P1, i, k, 1)
                ca = 2.0 if k > 0 else 1.0
                ya = _clip01((Qa + Pa) / (ca * muN1)) if muN1 > 0.0 else 0.0
                if (k == 0) and (Qa <= _EPS * muN1):
                    tha = 0.0
                else:
                    tha = _pow_p(ya, p, kc.sph)
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
        # recombine; Coulomb cap on the total force by radial return (wipes the memory)
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

        # tangents at the end of the step: theta = 1 after a no-slip step of rising N
        # (Eq. 3.10), else Eq. 3.11 with theta of the current branch (Eq. 3.13-3.15)
        Ptop = _top(P1, i, k, 1)
        c2 = 2.0 if k > 0 else 1.0
        Q = muN1 - s * tau
        y = (Q + Ptop) / (c2 * muN1) if muN1 > 0.0 else 0.0
        y = _clip01(y)
        slide = closed1 and (((k == 0) and (Q <= _EPS * muN1)) or (mu == 0.0))
        if slide:
            theta = 0.0
        elif elastic:
            theta = 1.0
        elif tha_ok:
            theta = tha
        else:
            theta = _pow_p(y, p, kc.sph)
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


_LAW_FUNCTIONS: dict = {}


def _copy(fn: Any, name: str, extra: dict, **options: Any) -> Any:
    """A copy of the compiled function ``fn`` named ``name`` (its own cache file), globals updated by ``extra``."""
    import types as pytypes

    f = fn.py_func
    g = dict(f.__globals__)
    g.update(extra)
    fc = pytypes.FunctionType(f.__code__, g, name, f.__defaults__, f.__closure__)
    fc.__qualname__ = name
    fc.__module__ = f.__module__
    fc.__doc__ = f.__doc__
    return njit(**options)(fc)


def _inlined_axis_law() -> Any:
    """:func:`_md_axis` (with :func:`_falling_n`) marked for inlining into the law copies (made once).

    Called, they took the constants ``kc`` (~60 values, the series and quadrature tables)
    by value at every contact; inlined, the law of the mixed-control driver took ~15 %
    less time. Only the law copies inline them: in the generic :func:`rows`, compiled for
    the per-call kernel on a first run, they stay calls (~1 s less compilation).
    """
    md = _LAW_FUNCTIONS.get("md_axis")
    if md is None:
        fall = _copy(_falling_n, "_falling_n_inlined", {}, **_JIT_NO_NRT, forceinline=True)
        md = _copy(_md_axis, "_md_axis_inlined", {"_falling_n": fall}, **_JIT_NO_NRT, forceinline=True)
        _LAW_FUNCTIONS["md_axis"] = md
    return md


def _law_dispatcher(key: tuple[int, bool, bool, int]) -> Any:
    """The copy of :func:`rows` specialised to ``key = (law code, linear, defer, dim)`` (made once)."""
    disp = _LAW_FUNCTIONS.get(key)
    if disp is None:
        import types as pytypes

        f = rows.py_func
        g = dict(f.__globals__)
        g.update(_LAW=int(key[0]), _LINEAR=int(key[1]), _DEFER=int(key[2]), _DIM=int(key[3]),
                 _md_axis=_inlined_axis_law())
        name = (f"rows_law{int(key[0])}_linear{int(key[1])}" + ("_defer" if key[2] else "")
                + (f"_dim{int(key[3])}" if key[3] else ""))
        fc = pytypes.FunctionType(f.__code__, g, name, f.__defaults__, f.__closure__)
        fc.__qualname__ = name  # its own name: its own cache file
        fc.__module__ = f.__module__
        fc.__doc__ = f.__doc__
        # with the C-callable wrapper: its address is what the callers call
        disp = njit(**{**_JIT_NO_NRT, "no_cfunc_wrapper": False})(fc)
        _LAW_FUNCTIONS[key] = disp
    return disp


def law_key(kc: KernelConstants, defer: bool = False, dim: int = 0) -> tuple[int, bool, bool, int]:
    """What :func:`law_function` specialises on: the law code and normal law of ``kc``, ``defer``, the dimension."""
    return int(kc.law), bool(kc.linear), bool(defer), int(dim)


def law_signature(kc: KernelConstants, state: KernelState, inc: KernelIncrement, out: KernelOutput,
                  scratch: KernelScratch) -> tuple:
    """The numba argument types of ``rows(lo, hi, kc, state, inc, out, scratch)`` for these arguments."""
    from numba import typeof, types

    return (types.int64, types.int64, typeof(kc), typeof(state), typeof(inc), typeof(out), typeof(scratch))


def compile_law(key: tuple[int, bool, bool, int], sig: tuple) -> None:
    """Compile (or load from numba's cache) the law copy ``key`` for the argument types ``sig``."""
    _law_dispatcher(key).compile(sig)


def law_compiled(key: tuple[int, bool, bool, int], sig: tuple) -> bool:
    """The law copy ``key`` is already compiled or loaded in this process for ``sig``."""
    return sig in _law_dispatcher(key).overloads


def law_function(kc: KernelConstants, state: KernelState, inc: KernelIncrement, out: KernelOutput,
                 scratch: KernelScratch, defer: bool = False) -> Any:
    """:func:`rows` for the law of ``kc``, compiled alone, as a first-class function value.

    A compiled caller that takes it as an argument (``law(lo, hi, kc, state, inc, out,
    scratch)``) calls it through its address instead of linking a copy of the law into
    its own code: numba re-optimises and re-generates the machine code of every callee
    linked into each caller, and the law is the largest function of the mixed-control
    driver (``docs/performance.md``, "First run"). The copy is specialised to the law
    kind and normal law of ``kc`` (the other laws' branches are not compiled) and to the
    dimension of ``state.tangential_force`` (its vector loops unrolled), and is
    cached on disk like the other kernels; one call per chunk of contacts costs nothing
    measurable. Its type is ``numba.types.FunctionType(numba.types.none(*law_signature(...)))``.

    ``defer``: the copy leaves the dissipation of a fall of ``N`` at fixed displacement
    (the 12-point quadrature of :func:`_falling_n`, the only costly part of the
    dissipation) out of ``out.dissipation`` and records its segments in ``scratch.fall``
    (shape (n, :data:`FALL_COLUMNS`)); for the iterate it accepts, the caller calls it
    once more with ``lo = -1`` (:func:`rows`), which adds that dissipation. The
    mixed-control driver evaluates the law ~2.2 times per step and keeps one. Everything
    else equals the copy without ``defer`` bit for bit; the dissipation agrees to
    rounding (the quadrature is added last).
    """
    from numba.core.types.function_type import CompileResultWAP

    key = law_key(kc, defer, state.tangential_force.shape[1])
    sig = law_signature(kc, state, inc, out, scratch)
    compile_law(key, sig)
    return CompileResultWAP(_law_dispatcher(key).overloads[sig])


@njit(**_JIT_INNER)
def _finite(a):
    """All entries finite."""
    for v in a.ravel():
        if not math.isfinite(v):
            return False
    return True


def _make_kernel(parallel, with_law=False):
    """The kernel, serial or parallel (``prange`` over chunks of ``_CHUNK`` contacts).

    Each contact's result depends only on its own inputs, so both give identical bits.
    ``with_law``: the kernel takes the law as its last argument, a first-class function
    (:func:`law_function`: a copy of :func:`rows` specialised to one law and dimension,
    called through its address) instead of linking the generic :func:`rows`.
    """
    rng = prange if parallel else range

    def kernel(kc, state, inc, out, scratch):
        n = state.approach.shape[0]
        if not _finite(inc.d_normal):
            return BAD_DNORMAL
        if not _finite(inc.d_tangential):
            return BAD_DTANGENTIAL
        nch = (n + _CHUNK - 1) // _CHUNK
        # the constants enter the (parallel) loop as plain values: a parfor cannot take a
        # named tuple holding tuples, so it is rebuilt inside
        (law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp, maxrev, hcoef, gcoef,
         glx, glw, sph, k8) = kc
        for ch in rng(nch):
            lo = ch * _CHUNK
            hi = min(n, lo + _CHUNK)
            rows(lo, hi, KernelConstants(law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p,
                                         m_exp, maxrev, hcoef, gcoef, glx, glw, sph, k8),
                 state, inc, out, scratch)
        return OK

    def kernel_law(kc, state, inc, out, scratch, law_fn):
        n = state.approach.shape[0]
        if not _finite(inc.d_normal):
            return BAD_DNORMAL
        if not _finite(inc.d_tangential):
            return BAD_DTANGENTIAL
        nch = (n + _CHUNK - 1) // _CHUNK
        (law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp, maxrev, hcoef, gcoef,
         glx, glw, sph, k8) = kc
        for ch in rng(nch):
            lo = ch * _CHUNK
            hi = min(n, lo + _CHUNK)
            law_fn(lo, hi, KernelConstants(law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p,
                                           m_exp, maxrev, hcoef, gcoef, glx, glw, sph, k8),
                   state, inc, out, scratch)
        return OK

    fn = kernel_law if with_law else kernel
    fn.__doc__ = """Advance ``n`` contacts by one increment (see :func:`update_kernel`)."""
    return njit(parallel=parallel, no_cfunc_wrapper=True, **_JIT)(fn)  # called from Python only


_kernel_serial = _make_kernel(False)
_kernel_parallel = _make_kernel(True)
_kernel_law_serial = _make_kernel(False, True)
_kernel_law_parallel = _make_kernel(True, True)

#: number of contacts from which the parallel kernel is used (when numba has more than
#: one thread; ``numba.set_num_threads`` / ``NUMBA_NUM_THREADS`` control it). Set it to a
#: huge value to always run serially, e.g. on a machine shared with other jobs, where
#: threads waiting for a busy core make the parallel kernel slower than the serial one.
PARALLEL_THRESHOLD = 2048


_PER_CALL_LAWS: dict = {}


def _arg_key(args: tuple) -> tuple:
    """A key that determines the numba types of ``args`` (named tuples of scalars, tuples, arrays).

    Cheaper than :func:`law_signature` (numba's ``typeof`` of the named tuples took ~0.4
    ms, 40 ns per contact of an 11 000-contact call).
    """
    key: list = []
    for t in args:
        key.append(type(t))
        for v in t:
            if isinstance(v, np.ndarray):
                f = v.flags
                key.append((v.dtype, v.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned))
            elif isinstance(v, tuple):
                key.append(tuple(type(x) for x in v))
            else:
                key.append(type(v))
    return tuple(key)


def _per_call_law(kc: KernelConstants, state: KernelState, inc: KernelIncrement, out: KernelOutput,
                  scratch: KernelScratch) -> Any:
    """:func:`law_function` (no ``defer``) for these arguments, looked up once per law and argument types."""
    key = (law_key(kc, False, state.tangential_force.shape[1]), _arg_key((kc, state, inc, out, scratch)))
    fn = _PER_CALL_LAWS.get(key)
    if fn is None:
        fn = _PER_CALL_LAWS[key] = law_function(kc, state, inc, out, scratch)
    return fn


def update_kernel(kc: KernelConstants, state: KernelState, inc: KernelIncrement
                  ) -> tuple[int, KernelOutput, np.ndarray]:
    """Run the compiled update on contiguous arrays (the caller validates shapes).

    Parameters
    ----------
    kc : KernelConstants
        From :func:`constants`.
    state : KernelState
        ``tangential_force`` and ``axis`` already re-projected if the normals turned.
    inc : KernelIncrement
        Increments and the closed forms of the normal law at the step ends, evaluated by
        the caller with the vectorised functions of :mod:`grainmech.contact.geometry`,
        i.e. exactly as the reference does.

    3D Mindlin–Deresiewicz contacts are advanced by the law copy of :func:`law_function`
    (specialised to the law and to 3D, bit for bit equal to the generic :func:`rows`,
    which advances the others).

    Returns
    -------
    status : int
        0; 1/2 for non-finite ``d_normal``/``d_tangential`` (nothing computed).
    out : KernelOutput
        New state and response (``dissipation`` of this step).
    flags : ndarray of int8, shape (n,)
        Per contact: 1 reversal memory full on a rising-N reversal, 2 on a constant or
        falling-N one, 3 no termination.
    """
    n, dim = state.tangential_force.shape
    out = new_output(n, dim, state.reversals.shape[1])
    scratch = new_scratch(n, dim)
    parallel = n >= PARALLEL_THRESHOLD and get_num_threads() > 1
    if kc.law == LAW_MD and dim == 3:
        # the law copy specialised to 3D with its axis law inlined (law_function), called
        # through its address: ~25 % less time per contact than the generic rows
        fn = _kernel_law_parallel if parallel else _kernel_law_serial
        status = fn(kc, state, inc, out, scratch, _per_call_law(kc, state, inc, out, scratch))
    else:
        fn = _kernel_parallel if parallel else _kernel_serial
        status = fn(kc, state, inc, out, scratch)
    return int(status), out, scratch.flags

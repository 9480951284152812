"""Arguments, codes and constants of the compiled contact kernel (:mod:`grainmech.contact.kernel`).

The named tuples the compiled functions take (:class:`KernelConstants`, :class:`KernelState`,
:class:`KernelIncrement`, :class:`KernelOutput`, :class:`KernelScratch`), the law, status
and flag codes, numba's compile options and :func:`constants`, which turns a contact
parameter object into the constants of one law. Nothing here is compiled; the values come
from the NumPy reference (:mod:`grainmech.contact.hysteresis`, :mod:`grainmech.contact.state`,
:mod:`grainmech.contact.forms`), so that the compiled code is self-contained.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple, cast

import numpy as np

from grainmech.contact.forms import law_forms
from grainmech.contact.geometry import hertz_radius, mindlin_kt0
from grainmech.contact.hysteresis import GL_W, GL_X, g_series, h_series
from grainmech.contact.params import ContactParams, Hertz, LinearSpring, MindlinDeresiewicz
from grainmech.contact.state import law_kind, max_reversals

__all__ = ["constants", "new_output", "new_scratch", "KernelConstants", "KernelState", "KernelIncrement",
           "KernelOutput", "KernelScratch", "LAW_MD", "LAW_JENKINS", "LAW_FRICTIONLESS", "OK", "BAD_DNORMAL",
           "BAD_DTANGENTIAL", "FLAG_MEMORY_RISING", "FLAG_MEMORY_FLAT", "FLAG_NO_TERMINATION", "FALL_COLUMNS"]

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

#: relative size (of ``mu N``) below which a distance from the friction limit counts as
#: zero (the reference law's value, :mod:`grainmech.contact.hysteresis`)
EPS = 1e-12
#: falling-N segments whose quadrature a deferring copy records per contact (more are
#: integrated at once), and the values recorded per segment (KernelScratch.fall)
FALL_SEGMENTS = 2
FALL_FIELDS = 6
FALL_COLUMNS = 1 + FALL_SEGMENTS * FALL_FIELDS
#: contacts per call of the row loop (and per parallel work item)
CHUNK = 256
#: numba's options for every compiled function of the kernel (cached, NumPy's error model)
JIT: dict[str, Any] = {"cache": True, "error_model": "numpy", "fastmath": False}
# the per-contact law allocates nothing: compiled without numba's reference counting (the
# atomic increments and decrements of the arrays passed between its functions took ~12 %
# of the mixed-control driver's time)
# Functions only called from compiled code are compiled without the wrappers that make
# them callable from Python and from C (generating and optimising those took ~15 % of the
# first run's compilation: the law's arguments are tuples of many arrays).
#: options of the law's functions (no reference counting, callable from compiled code only)
JIT_NO_NRT: dict[str, Any] = {**JIT, "_nrt": False, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}
#: options of the small helpers called from compiled code only (with reference counting)
JIT_INNER: dict[str, Any] = {**JIT, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


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
    kind = law_kind(params)
    forms = law_forms(params)
    linear = forms.linear
    if linear:
        spring = cast(LinearSpring, params)
        E = R = Gs = 1.0
        kn_lin, ks_lin = float(spring.kn), float(spring.ks)
    elif forms.spheres:
        hz = cast(Hertz, params)
        E = float(hz.effective_modulus)
        R = float(hz.effective_radius)
        Gs = float(hz.effective_shear_modulus)
        kn_lin = ks_lin = 0.0
    else:
        raise TypeError(f"no compiled kernel for {type(params).__name__} (rods use the NumPy law)")
    mu = float(params.friction)
    # the stick exponent of a Mindlin-Deresiewicz sphere law (the only spheres of kind "md")
    p = float(cast(MindlinDeresiewicz, params).stick_exponent) if kind == "md" else 1.0 / 3.0
    m_exp = 1.0 / (1.0 - p)
    kc = KernelConstants(
        {"md": LAW_MD, "jenkins": LAW_JENKINS, "frictionless": LAW_FRICTIONLESS}[kind], linear,
        E, R, Gs, kn_lin, ks_lin, mu, math.isfinite(mu), float(forms.ratio), p, m_exp,
        int(max_reversals(params)),
        # series and quadrature tables as tuples: values, not arrays (no reference counting
        # in the compiled per-contact loop)
        tuple(map(float, h_series(m_exp))), tuple(map(float, g_series(p))),
        tuple(map(float, GL_X)), tuple(map(float, GL_W)),
        (not linear) and p == 1.0 / 3.0,
        # kt0(N) = 8 G* a(N) = k8 N^(1/3) (seed Eq. 3.2, 3.11)
        0.0 if linear else float(mindlin_kt0(hertz_radius(1.0, E, R), Gs)))
    try:
        _CONSTANTS[params] = kc
    except TypeError:  # pragma: no cover - unhashable user subclass
        pass
    return kc

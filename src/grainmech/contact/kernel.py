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
differ in the last bits; ``tests/contact/test_kernel.py`` checks agreement to 1e-12).
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

Structure: the arguments, codes and :func:`constants` are in
:mod:`grainmech.contact._kernel_types`, the law along the memory axis in
:mod:`grainmech.contact._kernel_axis`, the per-contact loop :func:`rows` in
:mod:`grainmech.contact._kernel_rows` (all re-exported here); this module compiles the
law copies and the kernel. ``rows`` advances a chunk of contacts; the kernel runs the chunks in a loop
(serial) or a ``prange`` (parallel, from :data:`PARALLEL_THRESHOLD` contacts). The law's
functions allocate nothing and are compiled without numba's reference counting (no atomic
increments of the arrays passed between them), and none is inlined at numba-IR level:
that made the first run compile the law for ~16 s instead of ~5 s, and LLVM inlines the
small helpers anyway. The phases of ``rows`` (one contact's step) and the branch
integration of ``md_axis`` are separate functions marked for LLVM inlining
(``forceinline``), so that the code compiled is the one function they were written as.
The mixed-control driver calls the law through :func:`law_function`: a copy of ``rows``
specialised to one law, compiled once and called through its address rather than linked
(and re-optimised) into every caller. So does
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
import types as pytypes
from typing import Any

import numpy as np
from numba import get_num_threads, njit, prange, typeof, types
from numba.core.types.function_type import CompileResultWAP

from grainmech.contact._kernel_axis import fall_dissipation, falling_n, md_axis
from grainmech.contact._kernel_rows import rows
from grainmech.contact._kernel_types import (  # noqa: F401 (the kernel's argument types, codes and constants)
    BAD_DNORMAL,
    BAD_DTANGENTIAL,
    CHUNK,
    FALL_COLUMNS,
    FLAG_MEMORY_FLAT,
    FLAG_MEMORY_RISING,
    FLAG_NO_TERMINATION,
    JIT,
    JIT_INNER,
    JIT_NO_NRT,
    LAW_FRICTIONLESS,
    LAW_JENKINS,
    LAW_MD,
    OK,
    KernelConstants,
    KernelIncrement,
    KernelOutput,
    KernelScratch,
    KernelState,
    constants,
    new_output,
    new_scratch,
)

__all__ = ["update_kernel", "rows", "law_function", "fall_dissipation", "FALL_COLUMNS", "law_signature", "law_key",
           "compile_law", "law_compiled",
           "constants", "KernelConstants", "KernelState", "KernelIncrement",
           "KernelOutput", "KernelScratch", "LAW_MD", "LAW_JENKINS", "LAW_FRICTIONLESS",
           "PARALLEL_THRESHOLD"]


_LAW_FUNCTIONS: dict = {}


def _copy(fn: Any, name: str, extra: dict, **options: Any) -> Any:
    """A copy of the compiled function ``fn`` named ``name`` (its own cache file), globals updated by ``extra``."""
    f = fn.py_func
    g = dict(f.__globals__)
    g.update(extra)
    fc = pytypes.FunctionType(f.__code__, g, name, f.__defaults__, f.__closure__)
    fc.__qualname__ = name
    fc.__module__ = f.__module__
    fc.__doc__ = f.__doc__
    return njit(**options)(fc)


def _inlined_axis_law() -> Any:
    """:func:`md_axis` (with :func:`falling_n`) marked for inlining into the law copies (made once).

    Called, they took the constants ``kc`` (~60 values, the series and quadrature tables)
    by value at every contact; inlined, the law of the mixed-control driver took ~15 %
    less time. Only the law copies inline them: in the generic :func:`rows`, compiled for
    the per-call kernel on a first run, they stay calls (~1 s less compilation).
    """
    md = _LAW_FUNCTIONS.get("md_axis")
    if md is None:
        fall = _copy(falling_n, "_falling_n_inlined", {}, **JIT_NO_NRT, forceinline=True)
        md = _copy(md_axis, "_md_axis_inlined", {"falling_n": fall}, **JIT_NO_NRT, forceinline=True)
        _LAW_FUNCTIONS["md_axis"] = md
    return md


def _law_dispatcher(key: tuple[int, bool, bool, int]) -> Any:
    """The copy of :func:`rows` specialised to ``key = (law code, linear, defer, dim)`` (made once)."""
    disp = _LAW_FUNCTIONS.get(key)
    if disp is None:
        f = rows.py_func
        g = dict(f.__globals__)
        g.update(_LAW=int(key[0]), _LINEAR=int(key[1]), _DEFER=int(key[2]), _DIM=int(key[3]),
                 md_axis=_inlined_axis_law())
        name = (f"rows_law{int(key[0])}_linear{int(key[1])}" + ("_defer" if key[2] else "")
                + (f"_dim{int(key[3])}" if key[3] else ""))
        fc = pytypes.FunctionType(f.__code__, g, name, f.__defaults__, f.__closure__)
        fc.__qualname__ = name  # its own name: its own cache file
        fc.__module__ = f.__module__
        fc.__doc__ = f.__doc__
        # with the C-callable wrapper: its address is what the callers call
        disp = njit(**{**JIT_NO_NRT, "no_cfunc_wrapper": False})(fc)
        _LAW_FUNCTIONS[key] = disp
    return disp


def law_key(kc: KernelConstants, defer: bool = False, dim: int = 0) -> tuple[int, bool, bool, int]:
    """What :func:`law_function` specialises on: the law code and normal law of ``kc``, ``defer``, the dimension."""
    return int(kc.law), bool(kc.linear), bool(defer), int(dim)


def law_signature(kc: KernelConstants, state: KernelState, inc: KernelIncrement, out: KernelOutput,
                  scratch: KernelScratch) -> tuple:
    """The numba argument types of ``rows(lo, hi, kc, state, inc, out, scratch)`` for these arguments."""
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
    (the 12-point quadrature of :func:`falling_n`, the only costly part of the
    dissipation) out of ``out.dissipation`` and records its segments in ``scratch.fall``
    (shape (n, :data:`FALL_COLUMNS`)); for the iterate it accepts, the caller calls it
    once more with ``lo = -1`` (:func:`rows`), which adds that dissipation. The
    mixed-control driver evaluates the law ~2.2 times per step and keeps one. Everything
    else equals the copy without ``defer`` bit for bit; the dissipation agrees to
    rounding (the quadrature is added last).
    """
    key = law_key(kc, defer, state.tangential_force.shape[1])
    sig = law_signature(kc, state, inc, out, scratch)
    compile_law(key, sig)
    return CompileResultWAP(_law_dispatcher(key).overloads[sig])


@njit(**JIT_INNER)
def _finite(a):
    """All entries finite."""
    for v in a.ravel():
        if not math.isfinite(v):
            return False
    return True


def _make_kernel(parallel, with_law=False):
    """The kernel, serial or parallel (``prange`` over chunks of ``CHUNK`` contacts).

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
        nch = (n + CHUNK - 1) // CHUNK
        # the constants enter the (parallel) loop as plain values: a parfor cannot take a
        # named tuple holding tuples, so it is rebuilt inside
        (law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp, maxrev, hcoef, gcoef,
         glx, glw, sph, k8) = kc
        for ch in rng(nch):
            lo = ch * CHUNK
            hi = min(n, lo + CHUNK)
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
        nch = (n + CHUNK - 1) // CHUNK
        (law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p, m_exp, maxrev, hcoef, gcoef,
         glx, glw, sph, k8) = kc
        for ch in rng(nch):
            lo = ch * CHUNK
            hi = min(n, lo + CHUNK)
            law_fn(lo, hi, KernelConstants(law, linear, E, R, Gs, kn_lin, ks_lin, mu, mu_finite, r, p,
                                           m_exp, maxrev, hcoef, gcoef, glx, glw, sph, k8),
                   state, inc, out, scratch)
        return OK

    fn = kernel_law if with_law else kernel
    fn.__doc__ = """Advance ``n`` contacts by one increment (see :func:`update_kernel`)."""
    return njit(parallel=parallel, no_cfunc_wrapper=True, **JIT)(fn)  # called from Python only


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

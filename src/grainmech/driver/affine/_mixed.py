r"""Compiled step/Newton loop of a mixed-control path segment (one compiled call).

:func:`grainmech.driver.affine.solver.run` solves each step of a path with stress-controlled
components by Newton iterations on those components (``solver._solve``), halving a step
that does not converge (``solver._subdivided``). This module runs *the same* loop --
same predictor, same acceptance rules (``rtol``; ``rtol_accept`` on a two-cycle or
after ``max_iter``), same subdivision, same failure causes -- for every step of a
segment of constant control mask inside one compiled function, so that no Python runs
between law evaluations. Per evaluation, one pass over the contacts (chunks of
``CHUNK``, a ``prange`` from :data:`PARALLEL_ROWS` rows):

* kinematics, seed Eq. 2.13 (``delta = d eps . l``) and the normal law at the step's
  end (seed Eq. 3.6, 3.2), exactly as :mod:`grainmech.driver.affine._fused`;
* the compiled law update :func:`grainmech.contact.kernel.rows` from the last converged
  state (trial increment, no drift), passed in as a first-class function
  (:func:`grainmech.contact.kernel.law_function`: compiled once for the law at hand, not
  linked into the pass and the loop);
* the Love-Weber stress (seed Eq. 2.6, symmetric part), the weighted sliding and open
  fractions and the dissipation;
* the Newton Jacobian rows and columns of the stress-controlled components,
  ``sum_c w_c B_c^T K_c B_c`` with the law's step tangent
  ``K = (kn n + t_alpha) n^T + t_delta (I - n n)`` (consistent with the update,
  normal-tangential coupling ``mu dN (1 - theta)`` of seed Eq. 3.11 included;
  :func:`grainmech.driver.affine.point.consistent_tangent` is the NumPy form).

After a converged (sub)step one more pass (the same function with ``commit``, chunk by
chunk, threaded like the evaluations) commits the state and assembles the reported
tangent (seed Eq. 2.26 with the laws' ``kn``, ``ks``, full tangential projector) and the
stored energy. The loop takes the pass (serial or parallel) and the law as first-class functions, so
the three compile separately, and on an empty cache in two processes at once
(:func:`_compile`). The NumPy step loop stays the reference (``SolverOptions(compiled=False)``);
``tests/driver/test_affine_mixed.py`` holds the two to the same success, stresses and Newton
iterations.

Modules: the per-contact pieces, compile options and failure codes are in
:mod:`grainmech.driver.affine._mixed_rows`, the evaluation pass in
:mod:`grainmech.driver.affine._mixed_pass`; this module holds the segment loop (``_segment``),
its compilation and :func:`mixed_segment`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import get_num_threads, njit, typeof, types
from numba.core.types.function_type import CompileResultWAP

from grainmech import _workers
from grainmech.contact import kernel
from grainmech.contact.kernel import (
    KernelIncrement,
    KernelOutput,
    KernelScratch,
    KernelState,
)
from grainmech.contact.law import ContactResponse, ContactState
from grainmech.driver.affine._fold import fold, path_mirrors, unfold
from grainmech.driver.affine._mixed_pass import commit_sums, evaluate_parallel, evaluate_serial
from grainmech.driver.affine._mixed_rows import (
    CHUNK,
    CHUNK_GROUP,
    FAIL_LAW,
    FAIL_NO_CONVERGENCE,
    FAIL_NOT_FINITE,
    FAIL_SINGULAR,
    INNER,
    PARALLEL_ROWS,
    PARTIAL_SUMS,
    PY_ONLY,
    cond2,
    copy_state,
    reduce_chunks,
    solve_small,
    start_radii,
)

__all__ = ["mixed_segment", "FAIL_SINGULAR", "FAIL_NOT_FINITE", "FAIL_NO_CONVERGENCE", "FAIL_LAW"]


@njit(**INNER)
def _split_mask(sc):
    """The stress-controlled components ``idx`` and the strain-controlled ones ``jdx`` of the mask ``sc`` (6,)."""
    ns = 0
    for q in range(6):
        if sc[q]:
            ns += 1
    idx = np.empty(ns, dtype=np.int64)
    jdx = np.empty(6 - ns, dtype=np.int64)
    a = 0
    b = 0
    for q in range(6):
        if sc[q]:
            idx[a] = q
            a += 1
        else:
            jdx[b] = q
            b += 1
    return idx, jdx


@njit(**INNER)
def _start_step(k, sc, incs, t_stress, t_strain, stress, strain, sk_d, sk_t0, sk_t1, sk_dep):
    """Step ``k``'s targets (``solver.run``: no drift) and the substep stack holding the whole step.

    Returns ``(new_ts, new_te)``, the running stress and strain targets at the step's end;
    writes the stack's first entry (strain increment, stress targets at start and end, depth 0).
    """
    new_ts = np.empty(6)
    new_te = np.empty(6)
    for q in range(6):
        new_ts[q] = t_stress[q] + incs[k, q] if sc[q] else stress[q]
        new_te[q] = strain[q] if sc[q] else t_strain[q] + incs[k, q]
    for q in range(6):
        sk_d[0, q] = 0.0 if sc[q] else new_te[q] - strain[q]
        sk_t0[0, q] = stress[q] if sc[q] else 0.0
        sk_t1[0, q] = new_ts[q] if sc[q] else 0.0
    sk_dep[0] = 0
    return new_ts, new_te


@njit(**INNER)
def _predictor(de, d_strain, sc, stress, target, C, idx, jdx, rtol, rtol_accept):
    """``solver._solve``'s tolerances and predictor of a (sub)step: ``de`` from the tangent ``C``.

    The stress scale (largest stress or target; else ``|C| |de|``; else 1) gives the
    tolerances ``(tol, loose) = (rtol, rtol_accept) * scale``, returned. ``de`` (6,) gets the
    prescribed strains and, for the stress-controlled components, the solution of
    ``C[idx, idx] de_idx = target - stress - C[idx, jdx] de_jdx`` (zero if singular or not finite).
    """
    ns = idx.shape[0]
    for q in range(6):
        de[q] = 0.0 if sc[q] else d_strain[q]
    scale = 0.0
    for q in range(6):
        scale = max(scale, abs(stress[q]))
    ts = 0.0
    for a in range(ns):
        ts = max(ts, abs(target[idx[a]]))
    scale = max(scale, ts)
    if scale == 0.0:
        cm = 0.0
        dm = 0.0
        for q in range(36):
            cm = max(cm, abs(C[q // 6, q % 6]))
        for q in range(6):
            dm = max(dm, abs(de[q]))
        scale = cm * dm
        if scale == 0.0:
            scale = 1.0
    tol = rtol * scale
    loose = rtol_accept * scale
    if ns > 0:
        A = np.empty((ns, ns))
        rhs = np.empty(ns)
        for a in range(ns):
            acc = target[idx[a]] - stress[idx[a]]
            for b in range(6 - ns):
                acc -= C[idx[a], jdx[b]] * de[jdx[b]]
            rhs[a] = acc
            for b in range(ns):
                A[a, b] = C[idx[a], idx[b]]
        x, ok = solve_small(A, rhs)  # singular predictor: start from zero
        for a in range(ns):
            de[idx[a]] = x[a] if ok else 0.0
        fin = True
        for q in range(6):
            if not math.isfinite(de[q]):
                fin = False
        if not fin:
            for a in range(ns):
                de[idx[a]] = 0.0
    return tol, loose


@njit(**INNER)
def _newton_update(jac, sig, target, idx, de, finfo):
    """One Newton update of the stress-controlled strains: ``de_idx -= J^-1 (sig - target)_idx``.

    Returns 0, or :data:`FAIL_SINGULAR` (condition number above 1e13 or not finite, in
    ``finfo[0]``) or :data:`FAIL_NOT_FINITE` (the update).
    """
    ns = idx.shape[0]
    J = np.empty((ns, ns))
    r = np.empty(ns)
    for a in range(ns):
        r[a] = sig[idx[a]] - target[idx[a]]
        for b in range(ns):
            J[a, b] = jac[idx[a], idx[b]]
    jfin = True
    for a in range(ns):
        for b in range(ns):
            if not math.isfinite(J[a, b]):
                jfin = False
    cond = cond2(J) if jfin else np.nan
    if not math.isfinite(cond) or cond > 1e13:
        finfo[0] = cond
        return FAIL_SINGULAR
    x, _ = solve_small(J, r)  # not singular (condition checked)
    fin = True
    for a in range(ns):
        de[idx[a]] = de[idx[a]] - x[a]
    for q in range(6):
        if not math.isfinite(de[q]):
            fin = False
    if not fin:
        return FAIL_NOT_FINITE
    return 0


@njit(**INNER)
def _newton(eval_fn, law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, sig, jac,
            sym, idx, target, tol, loose, max_iter, hist, best_de, info, finfo):
    """``solver._solve``'s Newton iterations of a (sub)step from the predictor ``de``, and their acceptance.

    Per iteration one evaluation pass (``eval_fn``, the law ``law_fn``), the residual of
    the stress-controlled components; converged within ``tol``; within ``loose`` the best
    iterate is kept and a two-cycle at a tie accepts it; else :func:`_newton_update`.
    After ``max_iter`` iterations the best iterate within ``loose`` is accepted (evaluated
    again if it is not the last one), or the step fails. Returns ``(cause, iterations,
    loose_accepted, sliding, open)``: ``cause`` 0 or a ``FAIL_*`` code (law failures:
    contact and flag in ``info[3:5]``; residual and tolerance in ``finfo[:2]``), the
    weighted sliding and open sums of the last evaluation; ``sig``, ``jac``, ``de`` hold
    the accepted iterate's stress, Jacobian and strain increment.
    """
    ns = idx.shape[0]
    cause = 0
    s_sl = 0.0
    s_op = 0.0
    have_best = False
    best_r = 0.0
    nh = 0
    it_done = 0
    loose_acc = False
    rmax = 0.0
    for it in range(1, max_iter + 1):
        bad = eval_fn(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, False)
        if bad >= 0:
            cause = FAIL_LAW
            info[3] = bad
            info[4] = scratch.flags[bad]
            break
        s_sl, s_op, _s_di = reduce_chunks(part, sig, jac, sym)
        rmax = 0.0
        for a in range(ns):
            rmax = max(rmax, abs(sig[idx[a]] - target[idx[a]]))
        if rmax <= loose:
            if rmax <= tol:
                it_done = it
                break
            if (not have_best) or rmax < best_r:
                have_best = True
                best_r = rmax
                for q in range(6):
                    best_de[q] = de[q]
            if nh >= 2 and abs(rmax - hist[nh - 2]) <= 1e-6 * rmax:  # two-cycle at a tie
                it_done = it
                loose_acc = True
                break
        hist[nh] = rmax
        nh += 1
        cause = _newton_update(jac, sig, target, idx, de, finfo)
        if cause != 0:
            break
    if cause == 0 and it_done == 0:  # max_iter iterations
        if have_best:
            it_done = max_iter
            loose_acc = True
        else:
            cause = FAIL_NO_CONVERGENCE
            finfo[0] = rmax
            finfo[1] = tol
    if cause == 0 and loose_acc and best_r < rmax:
        # the best iterate is not the last one: evaluate it again (same state)
        for q in range(6):
            de[q] = best_de[q]
        eval_fn(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, False)
        s_sl, s_op, _s_di = reduce_chunks(part, sig, jac, sym)
    return cause, it_done, loose_acc, s_sl, s_op


@njit(**INNER)
def _subdivide(nsk, dep, d_strain, t0, target, sk_d, sk_t0, sk_t1, sk_dep):
    """``solver._subdivided``: the failed (sub)step's two halves onto the stack, the first on top; the new size."""
    for q in range(6):
        tm = 0.5 * (t0[q] + target[q])
        hd = 0.5 * d_strain[q]
        sk_d[nsk, q] = hd
        sk_t0[nsk, q] = tm
        sk_t1[nsk, q] = target[q]
        sk_d[nsk + 1, q] = hd
        sk_t0[nsk + 1, q] = t0[q]
        sk_t1[nsk + 1, q] = tm
    sk_dep[nsk] = dep + 1
    sk_dep[nsk + 1] = dep + 1
    return nsk + 2


@njit(**INNER)
def _record_step(k, sc, new_ts, new_te, t_stress, t_strain, strain, stress, C, rec_strain, rec_stress, rec_tan,
                 rec_scal, rec_int, wsl, wop, diss, work, wst, n_sub, n_it):
    """Record step ``k`` (strain, stress, tangent, fractions, energies, counters) and advance the running targets."""
    for q in range(6):
        t_stress[q] = new_ts[q] if sc[q] else stress[q]
        t_strain[q] = strain[q] if sc[q] else new_te[q]
        rec_strain[k, q] = strain[q]
        rec_stress[k, q] = stress[q]
    for q in range(36):
        rec_tan[k, q // 6, q % 6] = C[q // 6, q % 6]
    rec_scal[k, 0] = wsl
    rec_scal[k, 1] = wop
    rec_scal[k, 2] = diss
    rec_scal[k, 3] = work
    rec_scal[k, 4] = wst
    rec_int[k, 0] = n_sub
    rec_int[k, 1] = n_it


def _segment(eval_fn, law_fn, kc, normals, branch, weights, sc, incs, stress0, strain0, C0, t_stress0, t_strain0,
             rtol, rtol_accept, max_iter, max_depth, st, out, scratch, inc, part, resp, bk_st, bk_resp,
             rec_strain, rec_stress, rec_tan, rec_scal, rec_int, info, finfo, sym):
    # the step/Newton loop of a segment; eval_fn is the serial or the parallel evaluation
    # pass and law_fn the law (first-class functions: pass_function, kernel.law_function)
    # rec_scal[k] = (sliding, open, dissipation, work, stored); rec_int[k] = (substeps,
    # iterations); info = (steps done, cause, depth reached, contact, flag, loose count);
    # finfo = (condition or residual, tolerance, sliding, open); sym: Folding.sym (42,).
    # Phases per (sub)step: predictor (_predictor), Newton and acceptance (_newton),
    # subdivision on failure (_subdivide) or commit; per step: _start_step, _record_step.
    m = incs.shape[0]
    idx, jdx = _split_mask(sc)
    stress = stress0.copy()
    strain = strain0.copy()
    C = C0.copy()
    t_stress = t_stress0  # advanced in place (the caller continues from them)
    t_strain = t_strain0
    Cflat = np.empty(36)
    jac = np.zeros((6, 6))
    sig = np.zeros(6)
    hist = np.zeros(max_iter + 1)
    best_de = np.zeros(6)
    de = np.zeros(6)
    # substep stack (depth first): strain increment, stress targets at start/end, depth
    sk_d = np.zeros((max_depth + 2, 6))
    sk_t0 = np.zeros((max_depth + 2, 6))
    sk_t1 = np.zeros((max_depth + 2, 6))
    sk_dep = np.zeros(max_depth + 2, dtype=np.int64)
    n_loose = 0
    start_radii(kc.linear, kc.E, kc.R, st.approach, st.normal_force, inc.rad0)
    for k in range(m):
        new_ts, new_te = _start_step(k, sc, incs, t_stress, t_strain, stress, strain, sk_d, sk_t0, sk_t1, sk_dep)
        nsk = 1
        n_sub = 0
        n_it = 0
        diss = 0.0
        work = 0.0
        wsl = 0.0
        wop = 0.0
        wst = 0.0
        backed = False
        while nsk > 0:
            nsk -= 1
            dep = sk_dep[nsk]
            d_strain = sk_d[nsk].copy()
            t0 = sk_t0[nsk].copy()
            target = sk_t1[nsk].copy()
            # ---- solver._solve: one (sub)step of Newton iterations
            tol, loose = _predictor(de, d_strain, sc, stress, target, C, idx, jdx, rtol, rtol_accept)
            cause, it_done, loose_acc, s_sl, s_op = _newton(
                eval_fn, law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, sig, jac,
                sym, idx, target, tol, loose, max_iter, hist, best_de, info, finfo)
            if cause != 0:
                wtot = 0.0
                for i in range(weights.shape[0]):
                    wtot += weights[i]
                finfo[2] = s_sl / wtot if (wtot > 0.0 and cause != FAIL_LAW) else 0.0
                finfo[3] = s_op / wtot if (wtot > 0.0 and cause != FAIL_LAW) else 0.0
                if dep >= max_depth:
                    if backed:  # substeps of this step were committed: back to its start
                        copy_state(bk_st, bk_resp, st, resp)
                    info[0] = k
                    info[1] = cause
                    info[2] = dep
                    info[5] = n_loose
                    return k
                if not backed and n_sub == 0:  # nothing committed in this step yet
                    copy_state(st, resp, bk_st, bk_resp)
                    backed = True
                # ---- solver._subdivided: two halves, the first on top of the stack
                nsk = _subdivide(nsk, dep, d_strain, t0, target, sk_d, sk_t0, sk_t1, sk_dep)
                continue
            # ---- accepted: commit the state, counters as solver._subdivided
            new_strain = np.empty(6)  # strain + de (an element loop: no array expression to compile)
            for q in range(6):
                new_strain[q] = strain[q] + de[q]
            eval_fn(law_fn, kc, normals, branch, weights, de, sc, st, out, scratch, inc, part, resp, True)
            wst, wdi = commit_sums(part, Cflat)
            for q in range(36):
                Cflat[q] *= sym[6 + q]
            n_sub += 1
            n_it += it_done
            if loose_acc:
                n_loose += 1
            diss += wdi  # (s_di of the pass without the deferred falling-N part)
            dw = 0.0
            for q in range(6):
                dw += 0.5 * (stress[q] + sig[q]) * (new_strain[q] - strain[q])
            work += dw
            strain = new_strain
            stress = sig.copy()
            for q in range(36):
                C[q // 6, q % 6] = Cflat[q]
            wsl = s_sl
            wop = s_op
        # ---- record the step
        _record_step(k, sc, new_ts, new_te, t_stress, t_strain, strain, stress, C, rec_strain, rec_stress, rec_tan,
                     rec_scal, rec_int, wsl, wop, diss, work, wst, n_sub, n_it)
    info[0] = m
    info[1] = 0
    info[5] = n_loose
    return m


# the pass and the law are arguments (first-class functions), not linked into the loop:
# one compiled loop serves the serial and the parallel pass
_segment_compiled = njit(**PY_ONLY)(_segment)


def chunk_count(n: int) -> int:
    """Chunks of the evaluation pass over ``n`` rows: a multiple of 8, each of at most 128 rows.

    A multiple of the thread count keeps the threads' shares equal: on 2 cores an odd
    number of chunks made the threaded pass up to 1.5x *slower* than the serial one (the
    thread done first falls asleep after its short spin and is woken again for the next
    evaluation, ~0.1 ms), an even number 1.5-1.6x faster (``docs/performance.md``). The
    chunking does not depend on the thread count, so the serial and the threaded pass
    sum in the same order (the same bits).
    """
    return CHUNK_GROUP * max(1, -(-int(n) // (CHUNK_GROUP * CHUNK)))


def pass_signature(law_sig: tuple, args: tuple) -> tuple:
    """The numba argument types of the evaluation pass called by the loop with ``args`` (those after the law)."""
    # positions in the argument tuple built by mixed_segment
    kc, normals, branch, weights, sc = args[0], args[1], args[2], args[3], args[4]
    st, out, scratch, inc, part, resp = args[15], args[16], args[17], args[18], args[19], args[20]
    return (types.FunctionType(types.none(*law_sig)), typeof(kc), typeof(normals), typeof(branch), typeof(weights),
            typeof(np.zeros(6)), typeof(sc), typeof(st), typeof(out), typeof(scratch), typeof(inc), typeof(part),
            typeof(resp), types.boolean)


def compile_pass(parallel: bool, sig: tuple) -> None:
    """Compile (or load from numba's cache) the serial or parallel evaluation pass for ``sig``."""
    (evaluate_parallel if parallel else evaluate_serial).compile(sig)


def pass_function(parallel: bool, sig: tuple) -> Any:
    """The evaluation pass as a first-class function value (compiled or loaded first)."""
    fn = evaluate_parallel if parallel else evaluate_serial
    fn.compile(sig)
    return CompileResultWAP(fn.overloads[sig])


#: the worker process that compiles the law while this one compiles the segment loop
#: (``GRAINMECH_COMPILE_WORKER=0`` switches it off: :mod:`grainmech._workers`)
_WORKER = ("import pickle, sys\n"
           "path, (key, law_sig, parallel, pass_sig) = pickle.load(sys.stdin.buffer)\n"
           "sys.path[:] = path  # import the same grainmech as the parent\n"
           "from grainmech.contact import kernel\n"
           "from grainmech.driver.affine import _mixed\n"
           "kernel.compile_law(key, law_sig)\n"
           "_mixed.compile_pass(parallel, pass_sig)\n")


def _start_worker(job: tuple) -> Any:
    """A Python process that compiles the law and the evaluation pass of ``job`` into numba's cache (or None)."""
    return _workers.start_worker(_WORKER, job)


def _compile(args: tuple, key: tuple, law_sig: tuple, parallel: bool, pass_sig: tuple) -> None:
    """Compile (or load) the segment loop for ``args``; the law and the pass at the same time elsewhere.

    The loop takes the pass and the law as first-class functions, so compiling it needs
    only their types, not their code. When the loop has to be compiled (numba starts a
    compilation: an empty or stale cache), the law and the pass are compiled in a second
    Python process meanwhile, into numba's on-disk cache, from which
    :func:`kernel.law_function` and :func:`pass_function` then load them: with a free
    second core the first run waits for the longer of the two compilations instead of
    their sum (``docs/performance.md``, "First run"). If the worker fails, they are
    compiled here as before.
    """
    sig = ((types.FunctionType(types.intp(*pass_sig)), types.FunctionType(types.none(*law_sig)))
           + tuple(typeof(a) for a in args))
    if sig in _segment_compiled.overloads:
        return

    def start() -> Any:
        done = kernel.law_compiled(key, law_sig) and pass_sig in (
            evaluate_parallel if parallel else evaluate_serial).overloads
        return None if done else _start_worker((key, law_sig, parallel, pass_sig))

    with _workers.on_first_compile(start):
        _segment_compiled.compile(sig)


def mixed_segment(point, sc: np.ndarray, increments: np.ndarray, t_stress: np.ndarray, t_strain: np.ndarray,
                  options) -> dict:
    """Run the steps ``increments`` (m, 6) of constant control mask ``sc`` (6,) from ``point``.

    Parameters
    ----------
    point : MaterialPoint
        Converged start, with a :class:`~grainmech.contact.interface.ContactLaw` whose
        parameters the compiled kernel supports (the caller checks), no finite-deformation
        correction.
    sc : (6,) bool, stress-controlled components
    increments : (m, 6) increments of the controlled components (stress or strain)
    t_stress, t_strain : (6,) running targets at the segment's start (``solver.run``)
    options : SolverOptions

    Returns
    -------
    dict
        ``done`` (steps completed), ``cause`` (0 or a ``FAIL_*`` code), ``depth``,
        ``contact``, ``flag`` (law failure), ``n_loose``, ``finfo`` (condition or residual,
        tolerance, sliding and open fractions of the failing evaluation), per-step records
        ``strain``, ``stress``, ``tangent`` (m, ...), ``sliding``, ``open`` (fractions),
        ``dissipation``, ``work`` (per step), ``stored``, ``substeps``, ``iterations``; the
        final ``state``, ``response``, ``stress``, ``strain``, ``tangent``,
        ``t_stress``, ``t_strain``.
    """
    cs = point.contacts
    params = point.law.params
    kc = kernel.constants(params)
    m = increments.shape[0]
    # one row per orbit of the symmetries of the rows, the state and the segment's path
    # (the antipodal map, mirrors), its weight times the orbit's size (driver/_fold.py)
    folding, normals, branch, weights, st0, r0 = fold(cs, point.state, point.response, options.fold,
                                                      path_mirrors(sc, increments, t_stress))
    sym = folding.sym if folding is not None else np.ones(42)
    n = normals.shape[0]
    nch = chunk_count(n)

    def c(x, dtype=float):
        return np.array(x, dtype=dtype, order="C")

    dtypes = (float, float, float, float, np.int8, np.int32, float, float)
    fields = (st0.approach, st0.normal_force, st0.tangential_force, st0.axis, st0.direction, st0.depth,
              st0.reversals, st0.dissipated_energy)
    st = KernelState(*(c(x, dt) for x, dt in zip(fields, dtypes)))
    bk = KernelState(*(np.empty_like(x) for x in st))
    nrev = st.reversals.shape[1]
    out = KernelOutput(np.empty(n), np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, dtype=np.int8),
                       np.empty(n, dtype=np.int32), np.empty((n, nrev)), np.empty(n, dtype=np.bool_), np.empty(n),
                       np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n, dtype=np.bool_),
                       np.empty((n, 3, 3)), np.empty((n, 3)))
    scratch = KernelScratch(np.empty((n, 3)), np.empty((n, 3)), np.zeros(n, dtype=np.int8),
                            np.zeros((n, kernel.FALL_COLUMNS)))
    inc = KernelIncrement(np.empty(n), np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n))
    resp = tuple(c(x) for x in (r0.kn, r0.ks, r0.ks_perp, r0.ktn, r0.dissipation, r0.sliding, r0.open))
    bk_resp = tuple(np.empty(n) for _ in resp)
    part = np.zeros((nch, PARTIAL_SUMS))
    rec_strain = np.zeros((m, 6))
    rec_stress = np.zeros((m, 6))
    rec_tan = np.zeros((m, 6, 6))
    rec_scal = np.zeros((m, 5))
    rec_int = np.zeros((m, 2), dtype=np.int64)
    info = np.zeros(6, dtype=np.int64)
    finfo = np.zeros(4)
    parallel = n >= PARALLEL_ROWS and get_num_threads() > 1
    # the start's stress and tangent as the folded sums give them: the components the
    # group does not leave invariant (zero to rounding for the symmetric state) set to 0,
    # so that a stress-controlled one stays at its zero target with a zero increment
    C0 = np.ascontiguousarray(point.tangent * sym[6:].reshape(6, 6), dtype=float)
    t_stress = c(t_stress * sym[:6])  # a held component the group maps to minus itself: zero target
    t_strain = c(t_strain)
    args = (kc, c(normals), c(branch), c(weights), c(sc, np.bool_), c(increments),
            c(point.stress * sym[:6]), c(point.strain), C0, t_stress, t_strain,
            float(options.rtol), float(options.rtol_accept), int(options.max_iter), int(options.max_depth),
            st, out, scratch, inc, part, resp, bk, bk_resp,
            rec_strain, rec_stress, rec_tan, rec_scal, rec_int, info, finfo, sym)
    law_sig = kernel.law_signature(kc, st, inc, out, scratch)
    pass_sig = pass_signature(law_sig, args)
    _compile(args, kernel.law_key(kc, True, 3), law_sig, parallel, pass_sig)
    law_fn = kernel.law_function(kc, st, inc, out, scratch, defer=True)  # falling-N dissipation at the commit
    eval_fn = pass_function(parallel, pass_sig)
    done = int(_segment_compiled(eval_fn, law_fn, *args))
    wtot = float(weights.sum())
    if folding is not None:
        st = KernelState(*(unfold(folding, x, name) for name, x in zip(st._fields, st)))
        resp = tuple(unfold(folding, x) for x in resp)
        if info[1] == FAIL_LAW:
            info[3] = folding.rows[info[3]]
    sliding = resp[5] > 0.5
    state = ContactState(st.approach, st.normal_force, st.tangential_force, st.axis, st.direction, st.depth,
                         st.reversals, sliding, st.dissipated_energy)
    response = ContactResponse(st.normal_force, st.tangential_force, resp[0], resp[1], resp[2], resp[3],
                               st.axis, sliding, resp[6] > 0.5, resp[4])
    frac = rec_scal[:, :2] / wtot if wtot > 0 else np.zeros((m, 2))
    last = done - 1
    return {
        "done": done, "cause": int(info[1]), "depth": int(info[2]), "contact": int(info[3]), "flag": int(info[4]),
        "n_loose": int(info[5]), "finfo": finfo,
        "strain": rec_strain[:done], "stress": rec_stress[:done], "tangent": rec_tan[:done],
        "sliding": frac[:done, 0], "open": frac[:done, 1], "dissipation": rec_scal[:done, 2],
        "work": rec_scal[:done, 3], "stored": rec_scal[:done, 4],
        "substeps": rec_int[:done, 0], "iterations": rec_int[:done, 1],
        "state": state, "response": response,
        "stress_end": rec_stress[last].copy() if done else point.stress.copy(),
        "strain_end": rec_strain[last].copy() if done else point.strain.copy(),
        "tangent_end": rec_tan[last].copy() if done else C0.copy(),
        "t_stress": t_stress, "t_strain": t_strain,
    }

"""Step solver of the packing driver (:mod:`grainmech.driver.packing`).

One (sub)step: Newton-Krylov iterations on every grain's fluctuation and the
stress-controlled strains, with the consistent contact tangent, right-preconditioned
GMRES, a per-grain trust limit, a line search, pseudo-transient continuation where Newton
fails, and step halving. The method and its sources are in ``docs/packing-driver.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np

from grainmech.contact import ContactState, HertzMindlin, LinearSpring, MindlinDeresiewicz, update
from grainmech.contact.law import CompiledUpdate, compiled_kernel
from grainmech.driver._packing_ops import (
    Kinematics,
    Preconditioner,
    _cross_rows,
    block_diagonal,
    contact_tangent,
    voigt_of,
)

if TYPE_CHECKING:
    from grainmech.driver.packing import PackingOptions, PackingPoint


def _frictional(params: object) -> bool:
    if isinstance(params, LinearSpring):
        return params.ks > 0 and params.friction > 0
    if isinstance(params, (HertzMindlin, MindlinDeresiewicz)):
        return params.friction > 0
    return False


def _law_kw(backend: str | None) -> dict:
    return {} if backend is None else {"backend": backend}



# --------------------------------------------------------------------------- step solver

class _StepFailure(Exception):
    def __init__(self, cause: str) -> None:
        super().__init__(cause)
        self.cause = cause


@dataclass
class _Context:
    """Per-run solver state: preconditioner and counters."""

    prec: Preconditioner
    opts: PackingOptions
    factorizations: int = 0
    krylov: int = 0
    accepted: int = 0
    last: tuple | None = None  # (v, S, xq, xe) of the last (sub)step: predictor of the next
    mu_max: float = 0.0  # largest pseudo-time shift used
    ptc: int = 0  # Newton iterations that switched to pseudo-transient continuation
    anderson: int = 0  # Anderson iterations
    anderson_ok: int = 0  # (sub)steps the Anderson iterations solved
    relaxed: int = 0  # updates committed by committed relaxation
    relaxations: int = 0  # substeps solved by committed relaxation
    stiff_ok: bool = True  # the last initial-stiffness try contracted well
    newton_ok: bool = True  # the last (sub)step's consistent-tangent updates worked
    energy: bool = False  # line search on the potential energy (frictionless laws only)
    settled: int = 0  # (sub)steps whose Anderson iterations stopped with the stress settled (settle)


def _law_call(point: PackingPoint) -> Callable[[np.ndarray, np.ndarray], tuple]:
    """``update(params, state, dn, dt)`` of the point's law from its state (cached on the point).

    Every trial of a step starts from the same committed state: with the compiled kernel
    its inputs are converted once (:class:`grainmech.contact.law.CompiledUpdate`, the same
    results bit for bit), not at every trial.
    """
    hit = point._cache.get("law")
    if hit is not None and hit[0] is point.state and hit[1] == point.law_backend:
        return hit[2]
    kernel = compiled_kernel(point.params, point.law_backend or "auto")
    params, state, kw = point.params, point.state, _law_kw(point.law_backend)
    fn = (CompiledUpdate(kernel, params, state) if kernel is not None
          else lambda dn, dt: update(params, state, dn, dt, **kw))
    point._cache["law"] = (state, point.law_backend, fn)
    return fn


def _law_step(point: PackingPoint, dn: np.ndarray, dt: np.ndarray) -> tuple:
    """New contact state and response for law-space increments; a law error fails the step."""
    try:
        return _law_call(point)(dn, dt)
    except ValueError as exc:  # GrainmechError (memory, domain) or bad increment
        raise _StepFailure(f"contact law error: {exc}") from None


class _Glue:
    """The compiled counterparts (:mod:`grainmech.driver._packing_kernels`) of one kinematics' iteration glue.

    :meth:`evaluate` is :func:`_evaluate` with ``G^T f`` and ``V sigma``; :meth:`limit`
    is the trust limit of ``_solve`` (:func:`_clip`, :func:`_trust`, :func:`_closing_cap`).
    """

    def __init__(self, kin: Kinematics, mod: Any) -> None:
        from grainmech.driver._packing_kernels import grain_positions

        self.kin, self.k = kin, mod
        self.g = (kin.G.indptr, kin.G.indices, kin.G.data)
        self.gt = (kin.Gt.indptr, kin.Gt.indices, kin.Gt.data)
        self.pos = grain_positions(kin.free, kin.n_grains)
        self.l, self.n = np.ascontiguousarray(kin.l, dtype=float), np.ascontiguousarray(kin.n, dtype=float)

    def evaluate(self, point: PackingPoint, dq: np.ndarray, de: np.ndarray) -> tuple:
        """``(state, response, f, G^T f, V sigma)`` of the trial ``(dq, de)`` from ``point``."""
        C = self.n.shape[0]
        dn, dt = np.empty(C), np.empty((C, 3))
        if not self.k.contact_increments(*self.g, np.ascontiguousarray(dq, dtype=float), self.l, self.n,
                                         np.ascontiguousarray(de, dtype=float), point.scale, dn, dt):
            raise _StepFailure("Newton update not finite")
        st, resp = _law_step(point, dn, dt)
        f, rq, vs = np.empty((C, 3)), np.empty(self.kin.n_free), np.empty(6)
        self.k.forces_balance(resp.normal_force, resp.tangential_force, self.n, self.l, *self.gt, f.reshape(-1), rq,
                              vs)
        return st, resp, f, rq, vs

    def limit(self, dxq: np.ndarray, dxe: np.ndarray, S: np.ndarray, R: np.ndarray, move: float,
              approach: np.ndarray | None, cap: float) -> tuple[np.ndarray, np.ndarray]:
        """The update within the trust limit ``move``, each grain by itself (``approach`` None: no closing cap)."""
        k = self.k
        clipped = np.empty(dxq.size)
        k.clip_moves(np.ascontiguousarray(dxq, dtype=float), self.pos, R, move, clipped)
        d6 = np.zeros(6)
        d6[S] = dxe
        dxe = dxe / max(k.affine_move(self.l, d6) / move, 1.0)
        if approach is not None:
            d6[S] = dxe
            capped = np.empty(dxq.size)
            if k.closing_cap(*self.g, clipped, self.l, self.n, d6, np.ascontiguousarray(approach, dtype=float), cap,
                             self.kin.a, self.kin.b, self.pos, np.ones(self.kin.n_grains), capped):
                return capped, dxe
        return clipped, dxe


#: _Glue per kinematics (weak: dropped with the run's points); None where numba is missing
_GLUE: WeakKeyDictionary = WeakKeyDictionary()


def _compiled_glue(point: PackingPoint) -> _Glue | None:
    """The compiled iteration glue when the point's law runs compiled and numba imports, else None (NumPy)."""
    if point.law_backend == "numpy" or compiled_kernel(point.params, point.law_backend or "auto") is None:
        return None
    kin = point.kinematics
    if kin not in _GLUE:
        try:
            from grainmech.driver import _packing_kernels
        except ImportError:  # pragma: no cover - numba present whenever a compiled law is
            return None
        _GLUE[kin] = _Glue(kin, _packing_kernels)
    return _GLUE[kin]


def _evaluate(point: PackingPoint, dq: np.ndarray, de: np.ndarray):
    """Contact law at the trial increment (from the converged ``point``): state, response, forces."""
    kin, s = point.kinematics, point.scale
    D = kin.delta(dq, de)
    dn = kin.normal_part(D)
    dt = D - dn[:, None] * kin.n
    if not (np.all(np.isfinite(dn)) and np.all(np.isfinite(dt))):
        raise _StepFailure("Newton update not finite")
    st, resp = _law_step(point, dn * s, dt * s[:, None])
    f = resp.normal_force[:, None] * kin.n + resp.tangential_force
    return st, resp, f


def _potential(point: PackingPoint, st: ContactState, resp: Any) -> np.ndarray:
    """Elastic energy (C,) of frictionless contacts [energy].

    Hertz ``(2/5) N alpha`` (seed Eq. 3.6 integrated), linear springs ``N^2 / (2 kn)``.
    """
    N = resp.normal_force
    if isinstance(point.params, LinearSpring):
        return N * N / (2 * point.params.kn)
    return 0.4 * N * np.maximum(st.approach, 0.0) / point.scale


#: pseudo-time shift of the Newton system (Jacobi-scaled: 1 ~ a grain's own elastic
#: stiffness): first value after a failed line search, growth factor, value below which
#: Newton takes over again, ceiling
_MU_FIRST, _MU_GROW, _MU_NEWTON, _MU_MAX = 1e-3, 10.0, 1e-7, 1e3
#: retries with a larger shift when an update grows the residual more than _PTC_GROWTH times
_MU_GROWTHS, _PTC_GROWTH = 6, 3.0
#: an update lowering the residual by less than this factor is a stall
_PTC_STALL = 0.9
#: continuation that has not lowered the residual below _PTC_PROGRESS times its value
#: _PTC_PATIENCE iterations before gives up (the substep is halved or relaxed)
_PTC_PATIENCE, _PTC_PROGRESS = 6, 0.5
#: an update closes an open contact to at most this fraction of the mean approach
_CLOSE_CAP = 0.05
#: committed relaxation: the shift shrinks by at least this factor after each update taken;
#: GMRES tolerance of its updates (each update is committed and the next one corrects it,
#: so a rough direction does; inexact Newton forcing term, Eisenstat & Walker 1996)
_RELAX_MU_CUT, _RELAX_KRYLOV_RTOL = 0.3, 0.1
#: backtracking steps of the elastic operator's update after a failed Newton line search
_STIFF_BACKTRACKS = 4
#: shift of every Newton system: keeps a free grain (no closed contact) where it is
_MU_FLOOR = 1e-9


def _solve(point: PackingPoint, S: np.ndarray, de_E: np.ndarray, target: np.ndarray, ctx: _Context,
           counters: list, step_dsig: float, relax: bool = False) -> PackingPoint:
    """Newton-Krylov iterations of one (sub)step with line search; returns the new point.

    ``step_dsig``: the stress change of the whole step this (sub)step belongs to
    (:func:`_subdivided`), the scale of ``PackingOptions.rtol_step``.

    With ``relax`` the (sub)step is solved by committed relaxation instead: pseudo-transient
    updates from the start, each one committed to the contact laws' history (see the
    loop below).
    """
    opts, prec, kin = ctx.opts, ctx.prec, point.kinematics
    V = point.volume
    nq, ms = kin.n_free, int(S.sum())
    fm = np.linalg.norm(point.forces, axis=1)
    fref = float(fm[fm > 0].mean()) if np.any(fm > 0) else 0.0
    sref = max(float(np.abs(point.stress).max()), float(np.abs(target[S]).max()) if ms else 0.0)
    if fref == 0.0 or sref == 0.0:  # unloaded packing: scale from the stiffness and the step
        est = float(np.abs(prec.A0).max()) / V * max(float(np.abs(de_E).max()), 1e-12)
        sref = sref or est
        fref = fref or est * V / max(kin.n_contacts, 1) / float(np.mean(np.linalg.norm(kin.l, axis=1)))
    Rg = point.radii
    # trust limit of one update: a grain moves (or its surface turns) by at most half the
    # mean approach of the closed contacts (not a fraction of the radius: Hertz overlaps
    # are ~1e-4 R, and a move of 1e-2 R opens or crushes every contact of a grain)
    # or by twice the affine displacement of the step's largest strain increment over a
    # mean branch, whichever is larger (the fluctuations of a step are of that order)
    closed0 = point.state.approach > 0
    abar = float(np.mean(point.state.approach[closed0] / point.scale[closed0])) if closed0.any() else 0.0
    move = 0.5 * abar if closed0.any() else 0.01 * float(Rg.mean())
    lmean = float(np.mean(np.linalg.norm(kin.l, axis=1)))
    de_max = max(float(np.abs(de_E).max()), float(np.abs(np.where(S, target - point.stress, 0.0)).max())
                 * V / max(float(np.abs(prec.A0).max()), 1e-300))
    move = max(move, 2.0 * de_max * lmean)
    tolq = np.repeat(np.stack([np.full(Rg.size, 1.0), Rg], 1), 3, axis=1).reshape(-1)[kin.free] * opts.rtol * fref
    tole = opts.rtol * sref * V
    Dq, De = prec.dq, prec.de[S]

    fast = _compiled_glue(point)

    def residual(xq: np.ndarray, xe: np.ndarray):
        de = de_E.copy()
        de[S] = xe
        if fast is None:
            st, resp, f = _evaluate(point, xq, de)
            rq = kin.balance(f)
            vs = voigt_of(f, kin.l)
        else:
            st, resp, f, rq, vs = fast.evaluate(point, xq, de)
        if point.load is not None:
            rq = rq - _held_load(point, resp)
        re = vs[S] - V * target[S]
        return st, resp, f, rq, re, vs, de

    w0 = _potential(point, point.state, point.response) if ctx.energy else None

    def limit(dxq: np.ndarray, dxe: np.ndarray, st: ContactState) -> tuple[np.ndarray, np.ndarray]:
        """The update within the trust limit ``move``, each grain by itself.

        A grain on a mechanism (free, rolling or sliding away) must not cut the others'
        update; every contact the update closes is stopped near touch (:func:`_closing_cap`).
        """
        if fast is not None:
            return fast.limit(dxq, dxe, S, Rg, move, st.approach / point.scale if abar > 0 else None,
                              _CLOSE_CAP * abar)
        dxq = _clip(kin, dxq, Rg, move)
        dxe = dxe / _trust(kin, None, dxe, S, move)
        if abar > 0:
            dxq = _closing_cap(kin, dxq, dxe, S, st.approach / point.scale, _CLOSE_CAP * abar)
        return dxq, dxe

    def merit(cur: tuple) -> float:
        if ctx.energy:  # potential energy change W - W0 - V t_S . de_S (convex for frictionless laws)
            return float(np.sum(_potential(point, cur[0], cur[1]) - w0)) - V * float(np.dot(target[S], cur[6][S]))
        return rnorm(cur)

    def rnorm(cur: tuple) -> float:
        return float(np.sqrt(np.sum((Dq * cur[3]) ** 2) + np.sum((De * cur[4]) ** 2)))

    def converged(rq: np.ndarray, re: np.ndarray) -> bool:
        return bool(np.all(np.abs(rq) <= tolq) and (ms == 0 or np.all(np.abs(re) <= tole)))

    amb_ok = max(opts.rtol_accept * sref, opts.rtol_step * step_dsig) * V

    def accept(rq: np.ndarray, re: np.ndarray, factor: float = 1.0) -> bool:
        # the out-of-balance forces and moments left make the Love-Weber stress uncertain
        # by at most sum_p (|F_p| R_p + |M_p|) / V (the stress of a grain out of balance
        # depends on the point its moments are taken about); accept when that is below
        # rtol_accept times the stress scale or rtol_step times the step's stress change
        # (the imbalance left is not lost: the next step starts from it and removes it)
        # (the stress-controlled components within the same bound); ``factor`` scales the
        # bound (PackingOptions.settle)
        bound = factor * amb_ok
        return bool(_stress_ambiguity(kin, rq, Rg) <= bound and (ms == 0 or np.all(np.abs(re) <= bound)))

    def unsettled(rq: np.ndarray, re: np.ndarray) -> str:
        """The stress uncertainty left, against what ``accept`` asks, for a failure message."""
        out = f"stress uncertainty {_stress_ambiguity(kin, rq, Rg) / (sref * V):.3g} of the stress scale"
        if ms:
            out += f", stress-control residual {float(np.max(np.abs(re))) / (sref * V):.3g}"
        return out + f", each accepted below {amb_ok / (sref * V):.3g}"

    def done(cur: tuple, it: int, final: bool = True) -> PackingPoint:
        """The point of ``cur`` (at the unknowns ``xq``, ``xe``), counted as a (sub)step if ``final``."""
        ctx.newton_ok = newton_ok
        st, resp, f, rq, re, vs, de = cur
        new = replace(point, state=st, response=resp, forces=f, q=point.q + kin.full(xq),
                      strain=point.strain + de, stress=vs / V, _cache={})
        counters[2] += float(np.sum(resp.dissipation / point.scale) / V)
        counters[3] += float(np.dot(0.5 * (point.stress + new.stress), de))
        if final:
            counters[0] += 1
            counters[1] += it - 1
            ctx.last = None if relax else (v, S.copy(), xq.copy(), xe.copy())
        return new

    # predictor: the last (sub)step's solution scaled to this step's loading (exact for a
    # linear response; a reversal gives factor -1)
    v = np.concatenate([de_E, np.where(S, target - point.stress, 0.0) * V / max(float(np.abs(prec.A0).max()), 1e-300)])
    xq, xe = np.zeros(nq), np.zeros(ms)
    fac = 0.0
    if ctx.last is not None and not ctx.energy and np.array_equal(ctx.last[1], S):
        vl = ctx.last[0]
        vv = float(np.dot(vl, vl))
        if vv > 0:
            fac = float(np.dot(v, vl)) / vv
            xq, xe = fac * ctx.last[2], fac * ctx.last[3]
    # initial-stiffness tries: while they contract well, and after a reversal (elastic unloading)
    stiff_first = not ctx.energy and not relax and (ctx.stiff_ok or fac < 0)
    cur = residual(xq, xe)
    m = merit(cur)
    # committed relaxation: out-of-balance forces of the committed point the update starts from
    base = None
    if relax:
        base = kin.balance(point.forces) - (0.0 if point.load is None else _held_load(point, point.response))
    # pseudo-transient continuation (Kelley & Keyes 1998): each update solves
    # (J + mu I) dx = -r in the Jacobi-scaled unknowns. mu = 0 is Newton; a large mu is an
    # implicit step of overdamped grain dynamics (dx ~ -r / mu), which moves the grains
    # along their out-of-balance forces as a quasi-static DEM relaxation does and stays
    # bounded on a mechanism (a grain rolling or sliding on its neighbours, whose Newton
    # step is singular). mu grows when an update fails to lower the residual (a branch of
    # the contact law switching: a reversal, a contact reaching or leaving the Coulomb
    # limit) and shrinks after each success, so Newton's convergence comes back.
    # Committed relaxation (``relax``): the same updates with mu > 0 from the start, each
    # committed to the contact laws' history as it is taken (the point moves on; the
    # strain of the step goes in with the first update). This is implicit overdamped
    # dynamics of the grains, the relaxation a quasi-static DEM performs: where the
    # step's equilibrium is not reached from the step's start in one increment of the
    # laws (a branch of many contacts switching, an instability that rearranges a few
    # grains), the grains get there along a path whose slips are recorded.
    newton_ok = ctx.newton_ok
    if opts.anderson and not relax and not ctx.energy:
        # Anderson-accelerated elastic iterations first; where they stall (a few grains on
        # a mechanism, all their contacts sliding) Newton-Krylov goes on from their best point
        def settled(rq: np.ndarray, re: np.ndarray, dstress: float) -> bool:
            # the stress is settled: the stress-controlled components within rtol, and both
            # the stress uncertainty of the out-of-balance forces and the estimated stress
            # change still to come (``dstress``, from the contraction of the iterates'
            # stress changes) below ``settle`` times the acceptance bound
            return bool(opts.settle > 0 and dstress <= opts.settle * amb_ok and (ms == 0 or np.all(np.abs(re) <= tole))
                        and accept(rq, re, opts.settle))

        ok, xq, xe, cur, m, it = _anderson(prec, S, np.concatenate([Dq, De]), xq, xe, cur, m, residual, merit,
                                           limit, converged, settled, accept, opts.anderson, 4 * opts.max_iter,
                                           _debug())
        ctx.anderson += it
        if ok:
            ctx.anderson_ok += 1
            if ok == "settled":
                ctx.settled += 1
            elif not converged(cur[3], cur[4]):
                ctx.accepted += 1
            return done(cur, it)
        stiff_first = False
    mu = _MU_FIRST if relax else 0.0
    ptc_from = (0, 0.0)  # iteration and merit where continuation started
    # consistent-tangent updates still worth their Krylov solve (not after they failed in
    # the last (sub)step: the same few mechanism grains make them fail again)
    newton_ok = ctx.newton_ok
    n_iter = opts.relax_iter if relax else opts.max_iter
    dbg = _debug()
    jenkins = isinstance(point.params, (HertzMindlin, LinearSpring)) and _frictional(point.params)
    for it in range(1, n_iter + 1):
        st, resp, f, rq, re, vs, de = cur
        if dbg:
            dbg(f"it {it} merit {m:.3g} force {float(np.max(np.abs(rq) / tolq)) * opts.rtol:.3g} mu {mu:.1e} "
                f"sliding {int(np.sum(resp.sliding))} open {int(np.sum(resp.open))}")
            dbg(_grain_report(kin, rq, tolq, resp)
                + f"; stress ambiguity {_stress_ambiguity(kin, rq, Rg) / (sref * V):.2g}"
                + (f", stress residual {float(np.max(np.abs(re))) / (sref * V):.2g}" if ms else ""))
        if converged(rq, re):
            return done(cur, it)
        if stiff_first:  # initial-stiffness (modified Newton) step: one solve, no Krylov iterations
            dxq, dxe = prec.apply(-rq, -re, S)
            trial = residual(xq + dxq, xe + dxe)
            mt = merit(trial)
            if mt <= 0.1 * m or converged(trial[3], trial[4]):
                xq, xe, cur, m = xq + dxq, xe + dxe, trial, mt
                ctx.stiff_ok = True
                continue
            stiff_first = ctx.stiff_ok = False  # poor contraction: consistent-tangent Newton
        # consistent tangent of the trial state
        r_s = point.scale
        closed = ~np.asarray(resp.open, bool)
        if getattr(resp, "t_delta", None) is not None and not jenkins:
            K = _step_tangent(kin.n, resp, r_s, closed)
        else:
            ksp = np.where(closed, resp.ks_perp, 0.0) * r_s
            if jenkins:
                ksp = ksp * _slip_rotation(point, resp, kin, xq, de)
            K = contact_tangent(kin.n, np.where(closed, resp.kn, 0.0) * r_s, np.where(closed, resp.ks, 0.0) * r_s,
                                ksp, np.where(closed, resp.ktn, 0.0) * r_s, resp.axis)
        Kb = block_diagonal(K)
        if mu == 0.0:  # Newton with a backtracking line search
            if newton_ok:
                dxq, dxe, slope, pred, kr = _direction(kin, Kb, prec, S, rq, re, _MU_FLOOR, m, opts, ctx)
            else:  # Newton failed in this (sub)step: elastic updates (below) until they stall
                dxq, dxe, slope, pred, kr = np.zeros(nq), np.zeros(ms), 0.0, 0.0, 0
            # trust limit (see `move` above) on each grain by itself: a grain on a
            # mechanism (free, rolling or sliding away) must not cut the others' update
            lam = 1.0
            if not ctx.energy:
                dxq, dxe = limit(dxq, dxe, st)
            else:
                lam = 1.0 / _trust(kin, dxq, dxe, S, move)
            ok = False
            # a Krylov solve that lowered the linear model's residual by less than 10 %
            # gives no useful direction (the Jacobian is near singular on a few mechanism
            # grains): no line search along it
            for _nb in range(opts.max_backtracks + 1 if pred > 0.1 * m or ctx.energy else 0):
                trial = residual(xq + lam * dxq, xe + lam * dxe)
                mt = merit(trial)
                if ctx.energy:
                    ok = mt <= m + 1e-4 * lam * slope or (mt <= m and rnorm(trial) <= (1.0 - 1e-4 * lam) * rnorm(cur))
                else:
                    ok = m - mt >= 1e-4 * lam * pred > 0
                ok = ok or converged(trial[3], trial[4])
                if dbg:
                    dbg(f"   newton lam {lam:.3g} decrease {1 - mt / m:.3e} predicted {pred / m:.3e} krylov {kr}")
                if ok:
                    break
                lam *= 0.5
            if not ok and not ctx.energy:
                # the consistent tangent's update fails at a kink of the law (a mechanism
                # grain moved along a sliding contact that then sticks): the elastic
                # operator's update, stiffer than every branch of the laws, with its own
                # backtracking (initial-stiffness iteration), for the rest of the substep
                newton_ok = False
                dxq, dxe = limit(*prec.apply(-rq, -re, S), st)
                lam = 1.0
                for _nb in range(_STIFF_BACKTRACKS):
                    trial = residual(xq + lam * dxq, xe + lam * dxe)
                    mt = merit(trial)
                    if dbg:
                        dbg(f"   elastic lam {lam:.3g} decrease {1 - mt / m:.3e}")
                    if mt <= (1.0 - 1e-4 * lam) * m or converged(trial[3], trial[4]):
                        ok = True
                        break
                    lam *= 0.5
                if ok and mt > _PTC_STALL * m and accept(rq, re):  # crawling, stress settled
                    ctx.accepted += 1
                    return done(cur, it)
                if ok and mt > _PTC_STALL * m:  # crawling: Newton again next time
                    newton_ok = True
            if not ok:
                if accept(rq, re):  # stalled at a kink of the law, already below rtol_accept
                    ctx.accepted += 1
                    return done(cur, it)
                if ctx.energy:
                    sl = float(np.mean(np.asarray(resp.sliding, bool)[closed])) if closed.any() else 0.0
                    raise _StepFailure(f"line search failed at Newton iteration {it} (scaled residual "
                                       f"{rnorm(cur):.3g}; {100 * sl:.0f}% of closed contacts sliding, "
                                       f"{int(closed.sum())} closed)")
                if kr > opts.refactor_after and prec is not point._cache.get("prec"):
                    # the elastic operator is stale: refactor at the (sub)step's converged
                    # start, not at the trial (a trial far from equilibrium, with contacts
                    # opened or crushed, gives a scaling that weights a few grains'
                    # residual by orders of magnitude and a poor preconditioner)
                    ctx.prec = prec = point.preconditioner()
                    ctx.factorizations += 1
                    Dq, De = prec.dq, prec.de[S]
                    m = merit(cur)
                mu = _MU_FIRST  # switch to pseudo-transient continuation
                ctx.ptc += 1
                if ptc_from[0] == 0:
                    ptc_from = (it, m)
        if mu > 0.0:  # pseudo-transient continuation: every update taken, mu by the residual
            for _grow in range(_MU_GROWTHS + 1):
                dxq, dxe, slope, pred, kr = _direction(kin, Kb, prec, S, rq, re, mu, m, opts, ctx,
                                                       _RELAX_KRYLOV_RTOL if relax else None)
                dxq, dxe = limit(dxq, dxe, st)
                lam = 1.0
                try:
                    trial = residual(xq + dxq, xe + dxe)
                except _StepFailure:  # the law refuses the update (e.g. its memory is full): shorter
                    mu *= _MU_GROW
                    continue
                mt = merit(trial)
                # committed relaxation: the update must also release energy, i.e. the
                # out-of-balance forces do positive work on it (trapezoidal rule), as in
                # overdamped dynamics; the residual norm alone is no Lyapunov function there
                work = -0.5 * (float(np.dot(rq + trial[3], dxq)) + float(np.dot(re + trial[4], dxe)))
                if dbg:
                    dbg(f"   ptc mu {mu:.1e} decrease {1 - mt / m:.3e} krylov {kr} work {work:.3g}")
                if mt <= _PTC_GROWTH * m and (not relax or work >= 0.0):
                    break
                if accept(rq, re):
                    ctx.accepted += 1
                    return done(cur, it)
                mu *= _MU_GROW
            else:
                raise _StepFailure(f"pseudo-transient continuation diverged at iteration {it} (scaled residual "
                                   f"{rnorm(cur):.3g}, shift {mu:.3g}; "
                                   f"{int(np.sum(np.asarray(resp.sliding, bool) & closed))} of "
                                   f"{int(closed.sum())} closed contacts sliding; {unsettled(rq, re)})")
            if mt > _PTC_STALL * m and accept(rq, re):  # stalled on a few weak grains, stress settled
                ctx.accepted += 1
                return done(cur, it)
            if not relax and it - ptc_from[0] >= _PTC_PATIENCE:
                if mt > _PTC_PROGRESS * ptc_from[1]:
                    # continuation makes no headway: stop here, so that the substep is
                    # halved or relaxed without spending the rest of max_iter
                    raise _StepFailure(f"pseudo-transient continuation stalled at iteration {it} (scaled "
                                       f"residual {mt:.3g}, {mt / ptc_from[1]:.2f} x that of {_PTC_PATIENCE} "
                                       f"iterations before; {unsettled(trial[3], trial[4])})")
                ptc_from = (it, mt)
            # switched evolution relaxation (Mulder & van Leer 1985): the shift follows the residual
            # (in committed relaxation faster: every update taken released energy, and one
            # that does not is refused and retried with a larger shift)
            mu = mu * (min(mt / m, _RELAX_MU_CUT) if relax else mt / m)
            mu = (_MU_NEWTON if relax else 0.0) if mu < _MU_NEWTON else min(mu, _MU_MAX)
            ctx.mu_max = max(ctx.mu_max, mu)
        xq, xe, cur, m = xq + lam * dxq, xe + lam * dxe, trial, mt
        if relax and base is not None:  # commit the update: the next one starts from it
            # energy the update removed: work of the out-of-balance forces along it
            # (trapezoidal rule, from the committed point), what a DEM's damping dissipates
            # (the stress-controlled strains' work is in the external work, at the actual stress)
            counters[4] -= 0.5 * float(np.dot(base + cur[3], xq)) / V
            point = done(cur, it, final=False)
            ctx.relaxed += 1
            de_E = np.zeros_like(de_E)
            xq, xe = np.zeros(nq), np.zeros(ms)
            # the state again from the committed point: the trial's branch flags (sliding,
            # reversal) belong to the increment just taken; the next one may unload those
            # contacts, and a Newton matrix with them sliding moves grains along contacts
            # that stick
            cur = residual(xq, xe)
            m = merit(cur)
            base = cur[3]
    rq, re = cur[3], cur[4]
    if accept(rq, re):
        ctx.accepted += 1
        return done(cur, n_iter + 1)
    what = "committed relaxation did not converge" if relax else "Newton did not converge"
    raise _StepFailure(f"{what} in {n_iter} iterations (largest force residual "
                       f"{float(np.max(np.abs(rq) / tolq)) * opts.rtol:.3g} x mean contact force; {unsettled(rq, re)})")


def _anderson(prec: Preconditioner, S: np.ndarray, D: np.ndarray, xq: np.ndarray, xe: np.ndarray, cur: tuple,
              m: float, residual: Callable, merit: Callable, limit: Callable, converged: Callable, settled: Callable,
              accept: Callable, mem: int, n_iter: int, dbg: Callable | None) -> tuple:
    """Anderson-accelerated elastic iteration of one (sub)step.

    The fixed-point map is the elastic (initial-stiffness) update ``x + M^-1 (-r(x))``
    with ``M`` the factorised elastic operator (stiffer than every branch of the contact
    laws, so it is a contraction wherever the laws are monotone). Anderson acceleration
    of type II with ``mem`` differences (Anderson 1965; Walker & Ni 2011, SIAM J. Numer.
    Anal. 49, Alg. AA with ``beta = 1``): the update is ``f_k - (dX + dF) gamma`` with
    ``gamma`` minimising ``|D^-1 (f_k - dF gamma)|``, ``f = M^-1 (-r)``, ``D`` the Jacobi
    scaling of the unknowns. It needs no tangent of the laws, so the branch switches of
    a step (contacts reaching the Coulomb limit, reversing, opening) do not mislead it
    as they do a one-sided consistent tangent; it costs one residual and one solve with
    the factor per iteration, where a Newton-Krylov iteration costs one solve per
    Krylov vector. An update that raises the scaled residual more than three times
    restarts the history with a plain elastic update, halved until it does not raise it.
    The iterations stop when every grain is within ``rtol`` (``converged``) or as soon
    as the stress is settled (``settled(rq, re, dstress)``, ``PackingOptions.settle``;
    ``ok = "settled"``), with ``dstress`` the stress change still to come estimated from
    the contraction of the iterates' stress changes ``d_k`` (largest component of
    ``V sigma``): ``d_k rho / (1 - rho)`` with ``rho`` the larger of the last two ratios
    ``d_k / d_(k-1)`` (the a-posteriori bound of a contraction; infinite until two
    ratios below 1 are known). After ``_AA_PATIENCE`` iterations without progress the best point is accepted if
    its stress is settled; otherwise the history restarts from it (at most
    ``_AA_RESTARTS`` times: the differences gathered across a kink of the laws mix two
    branches; on 'dense' at 1e-4 this took 10 steps from 24.6 s to 14.5 s).

    Returns
    -------
    (ok, xq, xe, cur, m, iterations) : ``ok`` True when converged (or accepted after a
    stall), ``"settled"`` when stopped by ``settled``; otherwise (False) the best point
    met, from which the caller's Newton-Krylov goes on.
    """
    nq = xq.size
    X: list = []
    F: list = []
    dXs: list = []  # X[k+1] - X[k]
    dFs: list = []  # (F[k+1] - F[k]) / D
    best = (xq, xe, cur, m)
    ref, stall = m, 0  # merit of the last iteration that made progress, iterations since
    restarts = 0
    it = 0
    vs_last: np.ndarray | None = None  # stress (V sigma) of the last iterate
    dv: list[float] = []  # its changes
    for it in range(1, n_iter + 1):
        st, rq, re = cur[0], cur[3], cur[4]
        if vs_last is not None:
            dv.append(float(np.max(np.abs(cur[5] - vs_last))))
        vs_last = cur[5]
        dstress = np.inf
        if len(dv) >= 3 and dv[-2] > 0 and dv[-3] > 0:
            rho = max(dv[-1] / dv[-2], dv[-2] / dv[-3])
            if rho < 1:
                dstress = dv[-1] * rho / (1 - rho)
        if dbg:
            dbg(f"anderson it {it} merit {m:.3g} history {len(X)} stress change {dv[-1] if dv else 0:.3g} "
                f"to come {dstress:.3g}")
        if converged(rq, re):
            return True, xq, xe, cur, m, it
        if settled(rq, re, dstress):
            return "settled", xq, xe, cur, m, it
        fq, fe = prec.apply(-rq, -re, S)
        x_new, f_new = np.concatenate([xq, xe]), np.concatenate([fq, fe])
        if X:  # differences with the last iterate, scaled as the least-squares problem needs
            dXs.append(x_new - X[-1])
            dFs.append((f_new - F[-1]) / D)
        X.append(x_new)
        F.append(f_new)
        if len(X) > mem + 1:
            X.pop(0)
            F.pop(0)
            dXs.pop(0)
            dFs.pop(0)
        step = f_new
        if dXs:
            dFm = np.array(dFs).T
            gamma = np.linalg.lstsq(dFm, f_new / D, rcond=1e-12)[0]
            step = f_new - np.array(dXs).T @ gamma - (dFm @ gamma) * D
        sq, se = limit(step[:nq], step[nq:], st)
        try:
            trial = residual(xq + sq, xe + se)
            mt = merit(trial)
        except _StepFailure:
            mt = np.inf
        if not mt <= 3.0 * m:  # restart from a plain elastic update, halved until it does not raise r
            if dbg:
                dbg(f"   anderson restart (merit {mt:.3g})")
            X, F, dXs, dFs = [], [], [], []
            sq, se = limit(fq, fe, st)
            for _ in range(_STIFF_BACKTRACKS):
                trial = residual(xq + sq, xe + se)
                mt = merit(trial)
                if mt <= m:
                    break
                sq, se = 0.5 * sq, 0.5 * se
        xq, xe, cur, m = xq + sq, xe + se, trial, mt
        stall += 1
        if m < best[3]:
            best = (xq, xe, cur, m)
        if m < _AA_PROGRESS * ref:
            ref, stall = m, 0
        if stall > _AA_PATIENCE:
            if restarts >= _AA_RESTARTS or accept(best[2][3], best[2][4]):
                break
            # a stall at a kink of the laws: the differences gathered across it mix two
            # branches; start again from the best point with an empty history
            restarts += 1
            if dbg:
                dbg(f"   anderson stalled: restart {restarts} from the best point (merit {best[3]:.3g})")
            xq, xe, cur, m = best
            X, F, dXs, dFs = [], [], [], []
            ref, stall = m, 0
    xq, xe, cur, m = best
    return accept(cur[3], cur[4]), xq, xe, cur, m, it


#: Anderson iterations stop (accepted, or Newton-Krylov takes over) after _AA_PATIENCE
#: iterations that did not lower the best scaled residual below _AA_PROGRESS times itself
_AA_PATIENCE, _AA_PROGRESS = 8, 0.9
#: restarts of the Anderson history from the best point after a stall
_AA_RESTARTS = 2


def _direction(kin: Kinematics, Kb: Any, prec: Preconditioner, S: np.ndarray, rq: np.ndarray, re: np.ndarray,
               shift: float, m: float, opts: PackingOptions, ctx: _Context, rtol: float | None = None) -> tuple:
    """Newton (``shift = 0``) or continuation update: GMRES on ``(J + shift I) y = -r``.

    ``J`` is the Jacobi-scaled consistent tangent (contact tangents ``Kb``, block diagonal)
    and ``r = (rq, re)`` the residual. Right preconditioning by the factorised elastic
    operator: GMRES minimises the true (scaled) residual of the linear model, not the
    preconditioned one, which the near-singular directions of the elastic operator
    (mechanisms: grains that roll or slide freely) would dominate.

    Returns
    -------
    (dxq, dxe, slope, pred, krylov) : the update, ``r . dx``, the decrease of the scaled
    residual norm the linear model predicts (from ``m``), GMRES iterations.
    """
    import scipy.sparse.linalg as spla

    Dq, De = prec.dq, prec.de[S]
    nq, n = Dq.size, Dq.size + De.size
    rhs = -np.concatenate([Dq * rq, De * re])

    def matvec(y: np.ndarray) -> np.ndarray:
        vq = Dq * y[:nq]
        d6 = np.zeros(6)
        d6[S] = De * y[nq:]
        df = Kb @ kin.delta(vq, d6).reshape(-1)
        return np.concatenate([Dq * (kin.Gt @ df), De * voigt_of(df.reshape(-1, 3), kin.l)[S]]) + shift * y

    def psolve(z: np.ndarray) -> np.ndarray:
        yq, ye = prec.apply(z[:nq] / Dq, z[nq:] / De, S)
        return np.concatenate([yq / Dq, ye / De])

    count = [0]

    def cb(_r: Any) -> None:
        count[0] += 1

    z, _info = spla.gmres(spla.LinearOperator((n, n), matvec=lambda v: matvec(psolve(v)), dtype=float),
                          rhs, rtol=rtol or opts.krylov_rtol, atol=0.0, restart=opts.krylov_max, maxiter=1,
                          callback=cb, callback_type="pr_norm")
    y = psolve(z)
    ctx.krylov += count[0]
    if not np.all(np.isfinite(y)):
        raise _StepFailure("linear solve not finite")
    dxq, dxe = Dq * y[:nq], De * y[nq:]
    slope = float(np.dot(rq, dxq) + np.dot(re, dxe))
    if ctx.energy and not slope < 0:  # inexact Krylov step not downhill: preconditioned gradient
        dxq, dxe = prec.apply(-rq, -re, S)
        slope = float(np.dot(rq, dxq) + np.dot(re, dxe))
    pred = m - float(np.linalg.norm(matvec(y) - shift * y - rhs)) if not ctx.energy else 0.0
    return dxq, dxe, slope, pred, count[0]


def _trust(kin: Kinematics, dxq: np.ndarray | None, dxe: np.ndarray, S: np.ndarray, move: float) -> float:
    """Factor (>= 1) by which an update's largest contact displacement exceeds ``move``.

    ``move`` [length] is the trust limit; the update is ``(dxq, dxe)`` (``dxq = None``: the
    strain's part alone).

    Measured on the contacts, not on the grains: a grain rolling on its neighbours (a
    mechanism) may move far without loading any contact, and is bounded by the
    small-strain check of the step instead.
    """
    d6 = np.zeros(6)
    d6[S] = dxe
    d = kin.affine(d6) if dxq is None else kin.delta(dxq, d6)
    return max(float(np.max(np.linalg.norm(d, axis=1), initial=0.0)) / move, 1.0)


def _step_tangent(n: np.ndarray, resp: Any, r_s: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Contact tangent (C, 3, 3) from the law's step tangent [force/length].

    ``K = (kn n + t_alpha) n^T + t_delta (I - n n)`` with ``t_delta = dT/d d_t`` and
    ``t_alpha = dT/d alpha``, the derivatives of the end-of-step force of the step the law
    integrated from the committed state (:class:`grainmech.contact.ContactResponse`; for
    Mindlin-Deresiewicz exact to about 1e-9 against finite differences, including the
    normal-tangential coupling of seed Eq. 3.11 and the radial return at the Coulomb
    limit). ``r_s`` converts law-space displacements (:func:`_law_scale`); open contacts
    carry nothing.
    """
    w = np.where(closed, r_s, 0.0)
    col = resp.kn[:, None] * n + resp.t_alpha
    P = np.eye(3) - n[:, :, None] * n[:, None, :]
    K = col[:, :, None] * n[:, None, :] + np.einsum("cij,cjk->cik", resp.t_delta, P)
    return K * w[:, None, None]


def _slip_rotation(point: PackingPoint, resp: Any, kin: Kinematics, xq: np.ndarray, de: np.ndarray) -> np.ndarray:
    """Factor (C,) of the across-slip stiffness of a Coulomb-capped spring at the trial.

    A sliding contact of a spring with a Coulomb cap (``HertzMindlin``, ``LinearSpring``:
    radial return ``T = mu N T_trial / |T_trial|`` with ``T_trial = T_0 + k_t d_delta``)
    turns its force with the slip direction: across it the consistent stiffness is
    ``k_t mu N / |T_trial|`` (Simo & Hughes 1998, Sect. 2.3 for the radial return), not
    ``k_t``. 1 for a contact that sticks. ``T_trial`` is estimated with the end-of-step
    ``k_t`` (exact when the normal force does not grow); only the Newton matrix uses it.
    """
    sl = np.asarray(resp.sliding, bool) & ~np.asarray(resp.open, bool)
    if not sl.any():
        return np.ones(kin.n_contacts)
    d = kin.delta(xq, de)
    dt = d - np.einsum("ij,ij->i", d, kin.n)[:, None] * kin.n
    trial = point.response.tangential_force + (resp.ks_perp * point.scale)[:, None] * dt
    tn = np.linalg.norm(trial, axis=1)
    cap = np.linalg.norm(resp.tangential_force, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(sl & (tn > cap), cap / np.where(tn > 0, tn, 1.0), 1.0)
    return f


def _held_load(point: PackingPoint, resp: Any) -> np.ndarray:
    """The held input imbalance (``PackingPoint.load``) that the grains' closed contacts can resist.

    A grain's closed contacts resist its motions ``q_p`` that change their relative
    displacements (``W_p q_p != 0``, ``W_p`` the grain's blocks of ``G`` over its closed
    contacts, neighbours held). Along the others, its mechanisms ``W_p phi = 0``, nothing
    can balance a load: a grain whose contacts have all opened (six such motions), a
    grain held by one contact (rotations about the contact point) or by two (rolling
    about the line through its two contact points, in this fixed geometry). A load there
    makes the grain drift without bound in this fixed geometry (and roll or fly off in a
    DEM), so that share of the held load is dropped: the part kept does no work on any
    such motion (it is the load minus its orthogonal projection on them, rotations
    scaled by the grain radius). The first case was the rule before; the second drove a
    grain held by two weak contacts of the 500-grain packing of ``docs/packing-driver.md``
    around its contact axis by 0.17 rad and 4 % of its radius in 68 steps at
    γ = 3e-5, until the small-strain check stopped the run.
    """
    kin = point.kinematics
    if point.load is None:
        return np.zeros(kin.n_free)
    closed = ~np.asarray(resp.open, bool)
    # the same contacts stay closed over most updates and steps: cached per kinematics
    # (shared by every point of a run) and closed set
    memo = _HELD.setdefault(kin, {})
    key = closed.tobytes()
    got = memo.get(key)
    if got is not None and got[0] is point.load:
        return got[1]
    P = kin.n_grains
    R = point.radii
    # only a grain with at most two closed contacts has mechanisms (a rigid motion that
    # moves none of three points of a sphere is zero: no line passes through three of
    # them); the others' loads are kept whole
    ncl = np.bincount(kin.a[closed], minlength=P) + np.bincount(kin.b[closed], minlength=P)
    few = ncl <= 2
    if len(memo) >= 16:
        memo.clear()
    if not few.any():
        memo[key] = (point.load, point.load)
        return point.load
    # blocks of the relative displacement of each closed contact in the motion of its grain
    # A ([I, -[r_A]x]) and of its grain B ([-I, [r_B]x]), rotations scaled by the radius
    closed = closed & (few[kin.a] | few[kin.b])
    a, b, n = kin.a[closed], kin.b[closed], kin.n[closed]
    W = np.zeros((2, a.size, 3, 6))
    W[0, :, :, :3] = np.eye(3)
    W[0, :, :, 3:] = -_cross_rows(R[a][:, None] * n) / R[a][:, None, None]
    W[1, :, :, :3] = -np.eye(3)
    W[1, :, :, 3:] = _cross_rows(-R[b][:, None] * n) / R[b][:, None, None]
    ga = np.einsum("cki,ckj->cij", W[0], W[0]).reshape(-1, 36)
    gb = np.einsum("cki,ckj->cij", W[1], W[1]).reshape(-1, 36)
    gram = np.stack([np.bincount(a, ga[:, k], P) + np.bincount(b, gb[:, k], P) for k in range(36)],
                    axis=1).reshape(P, 6, 6)
    g = np.flatnonzero(few)
    w, U = np.linalg.eigh(gram[g])  # ascending; the grain's mechanisms have w ~ 0 (entries O(1))
    null = w < 1e-9 * np.maximum(w[:, -1:], 1.0)
    scale = np.concatenate([np.ones((g.size, 3)), np.repeat(R[g][:, None], 3, axis=1)], axis=1)
    full = kin.full(point.load)
    ls = full[g] / scale  # (force, moment / R)
    full[g] -= np.einsum("pik,pk,pjk,pj->pi", U, null.astype(float), U, ls) * scale
    kept = full.reshape(-1)[kin.free]
    memo[key] = (point.load, kept)
    return kept


#: _held_load's results per kinematics (weak: dropped with the run's points)
_HELD: WeakKeyDictionary = WeakKeyDictionary()


def _closing_cap(kin: Kinematics, dxq: np.ndarray, dxe: np.ndarray, S: np.ndarray, approach: np.ndarray,
                 cap: float) -> np.ndarray:
    """Grain update with every contact that it closes stopped at an approach of ``cap``.

    An open contact has no stiffness in the Newton matrix (and a Hertz contact none at
    touch), so an update may drive it far into overlap: at a quarter of the mean approach
    it carries a quarter of the mean contact force, and the residual jumps by orders of
    magnitude. Each closing contact's two grains are scaled down together (by the
    smallest factor over their closing contacts) so that it closes to at most ``cap``
    [length]; the next iteration sees it closed, with its stiffness.
    """
    d6 = np.zeros(6)
    d6[S] = dxe
    dn = kin.normal_part(kin.delta(dxq, d6))
    over = (approach <= 0.0) & (approach + dn > cap) & (dn > 0.0)
    if not over.any():
        return dxq
    f = np.ones(kin.n_grains)
    fc = np.clip((cap - approach[over]) / dn[over], 0.0, 1.0)
    np.minimum.at(f, kin.a[over], fc)
    np.minimum.at(f, kin.b[over], fc)
    mv = kin.full(dxq) * f[:, None]
    return mv.reshape(-1)[kin.free]


def _stress_ambiguity(kin: Kinematics, rq: np.ndarray, R: np.ndarray) -> float:
    """``sum_p (|F_p| R_p + |M_p|)`` [force length] of out-of-balance forces and moments ``rq``."""
    g = kin.full(rq)
    return float(np.sum(np.linalg.norm(g[:, :3], axis=1) * R + np.linalg.norm(g[:, 3:], axis=1)))


def _clip(kin: Kinematics, dxq: np.ndarray, R: np.ndarray, move: float) -> np.ndarray:
    """Grain update ``dxq`` (n_free,) with each grain's move clipped to ``move`` [length].

    A grain's translation and surface rotation ``R |theta|`` are scaled down together.
    """
    mv = kin.full(dxq)
    big = np.maximum(np.linalg.norm(mv[:, :3], axis=1), R * np.linalg.norm(mv[:, 3:], axis=1))
    c = move / np.maximum(big, move)
    return (mv * c[:, None]).reshape(-1)[kin.free]


def _grain_report(kin: Kinematics, rq: np.ndarray, tolq: np.ndarray, resp: Any) -> str:
    """Trace line: grains above the force tolerance, the worst ones with their contacts."""
    g = np.max(kin.full(np.abs(rq) / tolq), axis=1)
    closed = ~np.asarray(resp.open, bool)
    sl = np.asarray(resp.sliding, bool) & closed
    nc = np.bincount(kin.a[closed], minlength=g.size) + np.bincount(kin.b[closed], minlength=g.size)
    ns = np.bincount(kin.a[sl], minlength=g.size) + np.bincount(kin.b[sl], minlength=g.size)
    worst = np.argsort(g)[::-1][:5]
    top = " ".join(f"{p}:{g[p]:.2g}({nc[p]}c,{ns[p]}s)" for p in worst)
    return f"   grains over tol {int(np.sum(g > 1))} (>100x {int(np.sum(g > 100))}); worst {top}"


def _debug() -> Callable[[str], None] | None:
    """Trace printer of the step solver when ``GRAINMECH_PACKING_TRACE`` is set."""
    import os
    import sys

    if not os.environ.get("GRAINMECH_PACKING_TRACE"):
        return None
    return lambda msg: print(f"[packing] {msg}", file=sys.stderr)


def _subdivided(point: PackingPoint, S: np.ndarray, de_E: np.ndarray, t0: np.ndarray, t1: np.ndarray,
                depth: int, ctx: _Context, counters: list, step_dsig: float | None = None) -> PackingPoint:
    """Advance by strain ``de_E`` and stress target ``t1`` (from ``t0``), halving on failure.

    ``step_dsig`` (set at ``depth = 0``, kept by the halves): the step's stress change,
    the elastic (affine, an upper bound) response to its strain increment or the change
    of its stress targets; the path's resolution is the user's step, not a substep's.
    """
    if step_dsig is None:
        step_dsig = max(float(np.abs(ctx.prec.A0 @ de_E).max()) / point.volume,
                        float(np.abs(np.where(S, t1 - point.stress, 0.0)).max()))
    try:
        return _solve(point, S, de_E, t1, ctx, counters, step_dsig)
    except _StepFailure as exc:
        err = exc
    if depth == 0 and ctx.prec is not point._cache.get("prec"):  # maybe a stale preconditioner: refactor once
        ctx.prec = point.preconditioner()
        ctx.factorizations += 1
        try:
            return _solve(point, S, de_E, t1, ctx, counters, step_dsig)
        except _StepFailure as exc:
            err = exc
    rd = ctx.opts.relax_depth
    if rd is not None and depth >= min(rd, ctx.opts.max_depth) and not ctx.energy:  # committed relaxation
        ctx.relaxations += 1
        try:
            return _solve(point, S, de_E, t1, ctx, counters, step_dsig, relax=True)
        except _StepFailure as exc:
            err = exc
    if depth >= ctx.opts.max_depth:
        raise _StepFailure(f"{err.cause} (after {ctx.opts.max_depth} halvings)")
    tm = 0.5 * (t0 + t1)
    mid = _subdivided(point, S, 0.5 * de_E, t0, tm, depth + 1, ctx, counters, step_dsig)
    return _subdivided(mid, S, 0.5 * de_E, tm, t1, depth + 1, ctx, counters, step_dsig)

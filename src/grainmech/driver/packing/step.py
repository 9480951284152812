"""Step solver of the packing driver (:mod:`grainmech.driver.packing`).

One (sub)step: Newton-Krylov iterations on every grain's fluctuation and the
stress-controlled strains, with the consistent contact tangent, right-preconditioned
GMRES, a per-grain trust limit, a line search, pseudo-transient continuation where Newton
fails, and step halving. The method and its sources are in ``docs/models/packing.md``.

The (sub)step: :func:`_solve` (predictor, Anderson iterations, Newton-Krylov with line
search, pseudo-transient continuation, committed relaxation, acceptance) and
:func:`subdivided` (step halving). The laws at a trial increment are in
:mod:`grainmech.driver.packing._trial`, the iteration pieces (Anderson, Krylov
direction, trust limits, tangents) in :mod:`grainmech.driver.packing._iterations`, options and
the solver's state in :mod:`grainmech.driver.packing.options`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from grainmech.contact import (
    ContactState,
)
from grainmech.contact.forms import frictional, law_forms
from grainmech.contact.rolling import rolling_update
from grainmech.driver.packing._iterations import (
    STIFF_BACKTRACKS,
    anderson_iterations,
    at_rest,
    clip_grain_moves,
    grain_report,
    held_load,
    hold_mechanisms,
    krylov_direction,
    largest_residual,
    slip_rotation,
    step_tangent,
    stop_closing,
    stress_ambiguity,
    trace_printer,
    trust_ratio,
    unbalanced_ratio,
)
from grainmech.driver.packing._operators import (
    Preconditioner,
    RollingTangent,
    block_diagonal,
    contact_tangent,
    voigt_of,
)
from grainmech.driver.packing._trial import (
    compiled_glue,
    evaluate_trial,
    frictionless_energy,
)
from grainmech.driver.packing.options import (
    ACCEPT_MAX_FORCE,
    OutOfBudget,
    PackingOptions,
    RunContext,
    SubstepFailure,
)

if TYPE_CHECKING:
    from grainmech.driver.packing.point import PackingPoint


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


#: shift of every Newton system: keeps a free grain (no closed contact) where it is
_MU_FLOOR = 1e-9


def _scales(point: PackingPoint, S: np.ndarray, de_E: np.ndarray, target: np.ndarray, prec: Preconditioner,
            opts: PackingOptions) -> tuple:
    """Scales of one (sub)step of :func:`_solve`: ``(V, nq, ms, sref, Rg, abar, move, tolq, tole, fref)``.

    The volume, the numbers of unknowns, the stress scale, the radii, the mean approach of
    the closed contacts, the trust limit ``move`` of one update, the force and stress
    tolerances and the mean contact force.
    """
    kin = point.kinematics
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
    return V, nq, ms, sref, Rg, abar, move, tolq, tole, fref


def _predictor(point: PackingPoint, S: np.ndarray, de_E: np.ndarray, target: np.ndarray, prec: Preconditioner,
               ctx: RunContext, V: float, nq: int, ms: int) -> tuple:
    """Predictor of :func:`_solve`: ``(v, xq, xe, fac)``, the last (sub)step's solution scaled by ``fac``.

    ``v`` is this step's loading (strain increment and scaled stress change), the
    direction the next (sub)step's predictor is scaled along.
    """
    v = np.concatenate([de_E, np.where(S, target - point.stress, 0.0) * V / max(float(np.abs(prec.A0).max()), 1e-300)])
    xq, xe = np.zeros(nq), np.zeros(ms)
    fac = 0.0
    if ctx.last is not None and not ctx.energy and np.array_equal(ctx.last[1], S):
        vl = ctx.last[0]
        vv = float(np.dot(vl, vl))
        if vv > 0:
            fac = float(np.dot(v, vl)) / vv
            xq, xe = fac * ctx.last[2], fac * ctx.last[3]
    return v, xq, xe, fac


def _out_of_budget(kin: Any, rq: np.ndarray, Rg: np.ndarray, fref: float, resp: Any, ctx: RunContext) -> None:
    """Raise :class:`OutOfBudget` with the out-of-balance measures of the iterate ``rq``."""
    g = kin.full(rq)
    worst = float(np.max(np.hypot(np.linalg.norm(g[:, :3], axis=1), np.linalg.norm(g[:, 3:], axis=1) / Rg)))
    closed = ~np.asarray(resp.open, bool)
    sliding = int(np.sum(np.asarray(resp.sliding, bool) & closed))
    raise OutOfBudget(
        f"no equilibrium within max_step_work = {ctx.opts.max_step_work} residual evaluations and GMRES "
        f"iterations (mean unbalanced force ratio {unbalanced_ratio(kin, rq, Rg, fref):.2g}, largest grain "
        f"{worst / max(fref, 1e-300):.2g} of the mean contact force; {sliding} of {int(closed.sum())} closed "
        "contacts sliding): grains that a DEM would let roll and rearrange find no balance in this fixed "
        "geometry")


def _solve(point: PackingPoint, S: np.ndarray, de_E: np.ndarray, target: np.ndarray, ctx: RunContext,
           counters: list, step_dsig: float, relax: bool = False) -> PackingPoint:
    """Newton-Krylov iterations of one (sub)step with line search; returns the new point.

    ``step_dsig``: the stress change of the whole step this (sub)step belongs to
    (:func:`subdivided`), the scale of ``PackingOptions.rtol_step``.

    With ``relax`` the (sub)step is solved by committed relaxation instead: pseudo-transient
    updates from the start, each one committed to the contact laws' history (see
    :meth:`_StepSolve.iterate`). The phases: scales (:func:`_scales`), predictor
    (:func:`_predictor`), Anderson-accelerated elastic iterations
    (:meth:`_StepSolve.anderson`), Newton or continuation iterations
    (:meth:`_StepSolve.iterate`), final acceptance (:meth:`_StepSolve.finish`).
    """
    return _StepSolve(point, S, de_E, target, ctx, counters, step_dsig, relax).run()


class _StepSolve:
    """The state of one (sub)step solved by :func:`_solve` and its phases.

    The attributes that the phases update in turn: ``point`` (moves on in committed
    relaxation), ``de_E`` (the strain of the step, zero once committed), ``prec``, ``Dq``,
    ``De`` (the elastic operator and its Jacobi scaling, refactored when stale), the
    unknowns ``xq`` (grain fluctuations [m, rad]) and ``xe`` (stress-controlled strains),
    the iterate ``cur`` = ``(state, response, forces, rq, re, voigt sum, strain increment)``
    and its merit ``m``, the continuation shift ``mu`` and ``newton_ok``.
    """

    def __init__(self, point: PackingPoint, S: np.ndarray, de_E: np.ndarray, target: np.ndarray, ctx: RunContext,
                 counters: list, step_dsig: float, relax: bool) -> None:
        self.point, self.S, self.de_E, self.target, self.ctx = point, S, de_E, target, ctx
        self.counters, self.relax = counters, relax
        self.opts, self.prec, self.kin = ctx.opts, ctx.prec, point.kinematics
        (self.V, self.nq, self.ms, self.sref, self.Rg, self.abar, self.move, self.tolq, self.tole,
         self.fref) = _scales(point, S, de_E, target, self.prec, self.opts)
        self.Dq, self.De = self.prec.dq, self.prec.de[S]
        self.fast = compiled_glue(point)
        self.w0 = frictionless_energy(point, point.state, point.response) if ctx.energy else None
        self.amb_ok = max(self.opts.rtol_accept * self.sref, self.opts.rtol_step * step_dsig) * self.V
        self.rest_ok = max(self.opts.rtol_accept * self.sref, self.opts.rest_step * step_dsig) * self.V
        self.newton_ok = ctx.newton_ok

    # ------------------------------------------------------------------ residual and tests

    def residual(self, xq: np.ndarray, xe: np.ndarray):
        """The iterate at the unknowns ``(xq, xe)`` (laws evaluated from ``point``)."""
        point, kin, ctx, S = self.point, self.kin, self.ctx, self.S
        de = self.de_E.copy()
        de[S] = xe
        if self.fast is None:
            st, resp, f = evaluate_trial(point, xq, de)
            rq = kin.balance(f)
            vs = voigt_of(f, kin.l)
        else:
            st, resp, f, rq, vs = self.fast.evaluate(point, xq, de)
        roll = None
        if point.rolling is not None:  # contact moments (grain moment balance; not in the stress)
            assert point.moments is not None
            N = np.where(np.asarray(resp.open, bool), 0.0, resp.normal_force)
            roll = rolling_update(point.rolling, kin.n, kin.Rs, N, point.moments, kin.omega(xq))
            rq = rq + kin.moment_balance(roll.moment)
        if point.load is not None:
            rq = rq - held_load(point, resp)
        re = vs[S] - self.V * self.target[S]
        ctx.evals += 1
        if ctx.budget and ctx.work >= ctx.budget:
            _out_of_budget(kin, rq, self.Rg, self.fref, resp, ctx)
        return st, resp, f, rq, re, vs, de, roll

    def limit(self, dxq: np.ndarray, dxe: np.ndarray, st: ContactState) -> tuple[np.ndarray, np.ndarray]:
        """The update within the trust limit ``move``, each grain by itself.

        A grain on a mechanism (free, rolling or sliding away) must not cut the others'
        update; every contact the update closes is stopped near touch (:func:`stop_closing`);
        no grain moves along its mechanisms in the iterate ``st`` (:func:`hold_mechanisms`).
        """
        kin, S, Rg, move, abar = self.kin, self.S, self.Rg, self.move, self.abar
        dxq = hold_mechanisms(kin, dxq, Rg, st.approach > 0.0)
        if self.fast is not None:
            return self.fast.limit(dxq, dxe, S, Rg, move, st.approach / self.point.scale if abar > 0 else None,
                                   _CLOSE_CAP * abar)
        dxq = clip_grain_moves(kin, dxq, Rg, move)
        dxe = dxe / trust_ratio(kin, None, dxe, S, move)
        if abar > 0:
            dxq = stop_closing(kin, dxq, dxe, S, st.approach / self.point.scale, _CLOSE_CAP * abar)
        return dxq, dxe

    def merit(self, cur: tuple) -> float:
        """Scaled residual norm, or with ``ctx.energy`` the potential energy change."""
        if self.ctx.energy:  # potential energy change W - W0 - V t_S . de_S (convex for frictionless laws)
            return (float(np.sum(frictionless_energy(self.point, cur[0], cur[1]) - self.w0))
                    - self.V * float(np.dot(self.target[self.S], cur[6][self.S])))
        return self.rnorm(cur)

    def rnorm(self, cur: tuple) -> float:
        """Jacobi-scaled residual norm of the iterate ``cur``."""
        return float(np.sqrt(np.sum((self.Dq * cur[3]) ** 2) + np.sum((self.De * cur[4]) ** 2)))

    def converged(self, rq: np.ndarray, re: np.ndarray) -> bool:
        """Every force and stress-control residual within ``rtol``."""
        return bool(np.all(np.abs(rq) <= self.tolq) and (self.ms == 0 or np.all(np.abs(re) <= self.tole)))

    def accept(self, rq: np.ndarray, re: np.ndarray, factor: float = 1.0) -> bool:
        """Whether an unconverged iterate is accepted (its stress settled).

        The out-of-balance forces and moments left make the Love-Weber stress uncertain by
        at most ``sum_p (|F_p| R_p + |M_p|) / V`` (the stress of a grain out of balance
        depends on the point its moments are taken about); accept when that is below
        ``rtol_accept`` times the stress scale or ``rtol_step`` times the step's stress
        change (the imbalance left is not lost: the next step starts from it and removes
        it) (the stress-controlled components within the same bound); ``factor`` scales the
        bound (``PackingOptions.settle``). Never with a grain out of balance by more than
        ``ACCEPT_MAX_FORCE`` of the mean contact force: the bar of "every accepted step in
        equilibrium" as reported (``PackingResult.residual``).
        """
        kin, Rg = self.kin, self.Rg
        bound = factor * self.amb_ok
        if ((self.ms and not bool(np.all(np.abs(re) <= bound)))
                or largest_residual(kin, rq, Rg) > ACCEPT_MAX_FORCE * self.fref):
            return False
        amb = stress_ambiguity(kin, rq, Rg)
        if amb <= bound:
            return True
        return bool(factor == 1.0 and self.opts.accept_unbalanced > 0 and amb <= self.rest_ok
                    and at_rest(kin, rq, Rg, self.fref, self.opts.accept_unbalanced))

    def unsettled(self, rq: np.ndarray, re: np.ndarray) -> str:
        """The stress uncertainty left, against what ``accept`` asks, for a failure message."""
        sV = self.sref * self.V
        out = f"stress uncertainty {stress_ambiguity(self.kin, rq, self.Rg) / sV:.3g} of the stress scale"
        if self.ms:
            out += f", stress-control residual {float(np.max(np.abs(re))) / sV:.3g}"
        return out + f", each accepted below {self.amb_ok / sV:.3g}"

    def settled(self, rq: np.ndarray, re: np.ndarray, dstress: float) -> bool:
        """The stress is settled (ends the Anderson phase).

        The stress-controlled components within rtol, and both the stress uncertainty of
        the out-of-balance forces and the estimated stress change still to come
        (``dstress``, from the contraction of the iterates' stress changes) below
        ``settle`` times the acceptance bound.
        """
        opts = self.opts
        return bool(opts.settle > 0 and dstress <= opts.settle * self.amb_ok
                    and (self.ms == 0 or np.all(np.abs(re) <= self.tole)) and self.accept(rq, re, opts.settle))

    def done(self, cur: tuple, it: int, final: bool = True) -> PackingPoint:
        """The point of ``cur`` (at the unknowns ``xq``, ``xe``), counted as a (sub)step if ``final``."""
        point, kin, ctx, counters, V = self.point, self.kin, self.ctx, self.counters, self.V
        ctx.newton_ok = self.newton_ok
        st, resp, f, _rq, _re, vs, de, roll = cur
        new = replace(point, state=st, response=resp, forces=f, q=point.q + kin.full(self.xq),
                      strain=point.strain + de, stress=vs / V, _cache={})
        counters[2] += float(np.sum(resp.dissipation / point.scale) / V)
        if roll is not None:
            new = replace(new, moments=roll.moment, rolling_response=roll)
            counters[2] += float(np.sum(roll.dissipated) / V)
        counters[3] += float(np.dot(0.5 * (point.stress + new.stress), de))
        if final:
            counters[0] += 1
            counters[1] += it - 1
            ctx.last = None if self.relax else (self.v, self.S.copy(), self.xq.copy(), self.xe.copy())
        return new

    def accepted(self, it: int) -> PackingPoint:
        """The current iterate accepted unconverged (counted in ``ctx.accepted``)."""
        self.ctx.accepted += 1
        return self.done(self.cur, it)

    # ------------------------------------------------------------------ phases

    def run(self) -> PackingPoint:
        """Predictor, Anderson phase, Newton or continuation iterations, final acceptance."""
        ctx, relax = self.ctx, self.relax
        # predictor: the last (sub)step's solution scaled to this step's loading (exact for a
        # linear response; a reversal gives factor -1)
        self.v, self.xq, self.xe, fac = _predictor(self.point, self.S, self.de_E, self.target, self.prec, ctx,
                                                   self.V, self.nq, self.ms)
        # initial-stiffness tries: while they contract well, and after a reversal (elastic unloading)
        self.stiff_first = not ctx.energy and not relax and (ctx.stiff_ok or fac < 0)
        self.cur = self.residual(self.xq, self.xe)
        self.m = self.merit(self.cur)
        # committed relaxation: out-of-balance forces of the committed point the update starts from
        self.base = None
        if relax:
            point = self.point
            self.base = point.out_of_balance() - (0.0 if point.load is None
                                                  else held_load(point, point.response))
        self.newton_ok = ctx.newton_ok
        if self.opts.anderson and not relax and not ctx.energy:
            new = self.anderson()
            if new is not None:
                return new
            self.stiff_first = False
        return self.iterate()

    def anderson(self) -> PackingPoint | None:
        """Anderson-accelerated elastic iterations (:func:`anderson_iterations`); None where they stall.

        Where they stall (a few grains on a mechanism, all their contacts sliding)
        Newton-Krylov goes on from their best point.
        """
        ctx, opts = self.ctx, self.opts
        ok, self.xq, self.xe, self.cur, self.m, it = anderson_iterations(
            self.prec, self.S, np.concatenate([self.Dq, self.De]), self.xq, self.xe, self.cur, self.m,
            self.residual, self.merit, self.limit, self.converged, self.settled, self.accept, opts.anderson,
            4 * opts.max_iter, trace_printer())
        ctx.anderson += it
        if not ok:
            return None
        ctx.anderson_ok += 1
        if ok == "settled":
            ctx.settled += 1
        elif not self.converged(self.cur[3], self.cur[4]):
            ctx.accepted += 1
        return self.done(self.cur, it)

    def iterate(self) -> PackingPoint:
        """Newton or pseudo-transient continuation iterations until converged or accepted.

        Pseudo-transient continuation (Kelley & Keyes 1998): each update solves
        ``(J + mu I) dx = -r`` in the Jacobi-scaled unknowns. ``mu = 0`` is Newton; a large
        ``mu`` is an implicit step of overdamped grain dynamics (``dx ~ -r / mu``), which
        moves the grains along their out-of-balance forces as a quasi-static DEM relaxation
        does and stays bounded on a mechanism (a grain rolling or sliding on its
        neighbours, whose Newton step is singular). ``mu`` grows when an update fails to
        lower the residual (a branch of the contact law switching: a reversal, a contact
        reaching or leaving the Coulomb limit) and shrinks after each success, so Newton's
        convergence comes back. Committed relaxation (``relax``): the same updates with
        ``mu > 0`` from the start, each committed to the contact laws' history as it is
        taken (the point moves on; the strain of the step goes in with the first update).
        This is implicit overdamped dynamics of the grains, the relaxation a quasi-static
        DEM performs: where the step's equilibrium is not reached from the step's start in
        one increment of the laws (a branch of many contacts switching, an instability that
        rearranges a few grains), the grains get there along a path whose slips are
        recorded.
        """
        opts, ctx, relax, kin = self.opts, self.ctx, self.relax, self.kin
        self.mu = _MU_FIRST if relax else 0.0
        self.ptc_from = (0, 0.0)  # iteration and merit where continuation started
        # consistent-tangent updates still worth their Krylov solve (not after they failed in
        # the last (sub)step: the same few mechanism grains make them fail again)
        self.newton_ok = ctx.newton_ok
        self.n_iter = opts.relax_iter if relax else opts.max_iter
        self.dbg = dbg = trace_printer()
        self.jenkins = law_forms(self.point.params).kind == "jenkins" and frictional(self.point.params)
        for it in range(1, self.n_iter + 1):
            st, resp, _f, rq, re, _vs, de, _roll = self.cur
            if dbg:
                sV = self.sref * self.V
                dbg(f"it {it} merit {self.m:.3g} force {float(np.max(np.abs(rq) / self.tolq)) * opts.rtol:.3g} "
                    f"mu {self.mu:.1e} sliding {int(np.sum(resp.sliding))} open {int(np.sum(resp.open))}")
                dbg(grain_report(kin, rq, self.tolq, resp)
                    + f"; mean unbalanced {unbalanced_ratio(kin, rq, self.Rg, self.fref):.2g}"
                    + f"; stress ambiguity {stress_ambiguity(kin, rq, self.Rg) / sV:.2g}"
                    + (f", stress residual {float(np.max(np.abs(re))) / sV:.2g}" if self.ms else ""))
            if self.converged(rq, re):
                return self.done(self.cur, it)
            if self.stiff_first:  # initial-stiffness (modified Newton) step: one solve, no Krylov iterations
                dxq, dxe = self.prec.apply(-rq, -re, self.S)
                trial = self.residual(self.xq + dxq, self.xe + dxe)
                mt = self.merit(trial)
                if mt <= 0.1 * self.m or self.converged(trial[3], trial[4]):
                    self.xq, self.xe, self.cur, self.m = self.xq + dxq, self.xe + dxe, trial, mt
                    ctx.stiff_ok = True
                    continue
                self.stiff_first = ctx.stiff_ok = False  # poor contraction: consistent-tangent Newton
            closed = ~np.asarray(resp.open, bool)
            Kb = self.tangent(resp, closed, de)
            out: PackingPoint | tuple | None = None
            if self.mu == 0.0:  # Newton with a backtracking line search
                out = self.newton(it, Kb, st, resp, closed)
                if out is not None and not isinstance(out, tuple):
                    return out
            if self.mu > 0.0:  # pseudo-transient continuation: every update taken, mu by the residual
                out = self.continuation(it, Kb, st, resp, closed)
                if not isinstance(out, tuple):
                    return out
            assert isinstance(out, tuple)  # Newton's update taken, or continuation's
            dxq, dxe, lam, trial, mt = out
            self.xq, self.xe, self.cur, self.m = self.xq + lam * dxq, self.xe + lam * dxe, trial, mt
            if relax and self.base is not None:
                self.commit(it)
        return self.finish()

    def tangent(self, resp: Any, closed: np.ndarray, de: np.ndarray) -> Any:
        """Block-diagonal consistent tangent of the trial state ``resp`` (seed Eq. 3.9-3.17 laws).

        With rolling resistance also the moment springs' part of the iterate ``cur``
        (``self.roll_tan``, :class:`RollingTangent`), which the Newton directions add.
        """
        point, kin = self.point, self.kin
        r_s = point.scale
        roll = self.cur[7]
        self.roll_tan = None if roll is None else RollingTangent(
            kin, roll.tangent, roll.dmoment_dnormal, np.where(closed, resp.kn, 0.0) * r_s)
        if getattr(resp, "t_delta", None) is not None and not self.jenkins:
            K = step_tangent(kin.n, resp, r_s, closed)
        else:
            ksp = np.where(closed, resp.ks_perp, 0.0) * r_s
            if self.jenkins:
                ksp = ksp * slip_rotation(point, resp, kin, self.xq, de)
            K = contact_tangent(kin.n, np.where(closed, resp.kn, 0.0) * r_s, np.where(closed, resp.ks, 0.0) * r_s,
                                ksp, np.where(closed, resp.ktn, 0.0) * r_s, resp.axis)
        return block_diagonal(K)

    def newton(self, it: int, Kb: Any, st: ContactState, resp: Any, closed: np.ndarray) -> PackingPoint | tuple | None:
        """One Newton update with a backtracking line search (elastic updates where it fails).

        Returns the point where the iterate is accepted, the update
        ``(dxq, dxe, lam, trial, merit)`` to take, or None after switching to
        continuation (``mu > 0``).
        """
        opts, ctx, kin, S, dbg = self.opts, self.ctx, self.kin, self.S, self.dbg
        m, cur, xq, xe = self.m, self.cur, self.xq, self.xe
        rq, re = cur[3], cur[4]
        if self.newton_ok:
            dxq, dxe, slope, pred, kr = krylov_direction(kin, Kb, self.prec, S, rq, re, _MU_FLOOR, m, opts, ctx,
                                                   roll=self.roll_tan)
        else:  # Newton failed in this (sub)step: elastic updates (below) until they stall
            dxq, dxe, slope, pred, kr = np.zeros(self.nq), np.zeros(self.ms), 0.0, 0.0, 0
        # trust limit (see `move` in _scales) on each grain by itself: a grain on a
        # mechanism (free, rolling or sliding away) must not cut the others' update
        lam = 1.0
        if not ctx.energy:
            dxq, dxe = self.limit(dxq, dxe, st)
        else:
            lam = 1.0 / trust_ratio(kin, dxq, dxe, S, self.move)
        ok = False
        # a Krylov solve that lowered the linear model's residual by less than 10 %
        # gives no useful direction (the Jacobian is near singular on a few mechanism
        # grains): no line search along it
        for _nb in range(opts.max_backtracks + 1 if pred > 0.1 * m or ctx.energy else 0):
            trial = self.residual(xq + lam * dxq, xe + lam * dxe)
            mt = self.merit(trial)
            if ctx.energy:
                ok = mt <= m + 1e-4 * lam * slope or (mt <= m and self.rnorm(trial) <= (1.0 - 1e-4 * lam)
                                                      * self.rnorm(cur))
            else:
                ok = m - mt >= 1e-4 * lam * pred > 0
            ok = ok or self.converged(trial[3], trial[4])
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
            self.newton_ok = False
            dxq, dxe = self.limit(*self.prec.apply(-rq, -re, S), st)
            lam = 1.0
            for _nb in range(STIFF_BACKTRACKS):
                trial = self.residual(xq + lam * dxq, xe + lam * dxe)
                mt = self.merit(trial)
                if dbg:
                    dbg(f"   elastic lam {lam:.3g} decrease {1 - mt / m:.3e}")
                if mt <= (1.0 - 1e-4 * lam) * m or self.converged(trial[3], trial[4]):
                    ok = True
                    break
                lam *= 0.5
            if ok and mt > _PTC_STALL * m and self.accept(rq, re):  # crawling, stress settled
                return self.accepted(it)
            if ok and mt > _PTC_STALL * m:  # crawling: Newton again next time
                self.newton_ok = True
        if ok:
            return dxq, dxe, lam, trial, mt
        if self.accept(rq, re):  # stalled at a kink of the law, already below rtol_accept
            return self.accepted(it)
        if ctx.energy:
            sl = float(np.mean(np.asarray(resp.sliding, bool)[closed])) if closed.any() else 0.0
            raise SubstepFailure(f"line search failed at Newton iteration {it} (scaled residual "
                               f"{self.rnorm(cur):.3g}; {100 * sl:.0f}% of closed contacts sliding, "
                               f"{int(closed.sum())} closed)")
        if kr > opts.refactor_after and self.prec is not self.point._cache.get("prec"):
            # the elastic operator is stale: refactor at the (sub)step's converged
            # start, not at the trial (a trial far from equilibrium, with contacts
            # opened or crushed, gives a scaling that weights a few grains'
            # residual by orders of magnitude and a poor preconditioner)
            ctx.prec = self.prec = self.point.preconditioner()
            ctx.factorizations += 1
            self.Dq, self.De = self.prec.dq, self.prec.de[S]
            self.m = self.merit(cur)
        self.mu = _MU_FIRST  # switch to pseudo-transient continuation
        ctx.ptc += 1
        if self.ptc_from[0] == 0:
            self.ptc_from = (it, self.m)
        return None

    def continuation(self, it: int, Kb: Any, st: ContactState, resp: Any, closed: np.ndarray) -> PackingPoint | tuple:
        """One pseudo-transient continuation update (every update taken, ``mu`` by the residual).

        Returns the point where the iterate is accepted, else the update
        ``(dxq, dxe, lam, trial, merit)``.
        """
        opts, ctx, kin, S, dbg, relax = self.opts, self.ctx, self.kin, self.S, self.dbg, self.relax
        m, cur, xq, xe = self.m, self.cur, self.xq, self.xe
        rq, re = cur[3], cur[4]
        mu = self.mu
        for _grow in range(_MU_GROWTHS + 1):
            dxq, dxe, _slope, _pred, kr = krylov_direction(kin, Kb, self.prec, S, rq, re, mu, m, opts, ctx,
                                                     _RELAX_KRYLOV_RTOL if relax else None, roll=self.roll_tan)
            dxq, dxe = self.limit(dxq, dxe, st)
            lam = 1.0
            try:
                trial = self.residual(xq + dxq, xe + dxe)
            except SubstepFailure:  # the law refuses the update (e.g. its memory is full): shorter
                mu *= _MU_GROW
                continue
            mt = self.merit(trial)
            # committed relaxation: the update must also release energy, i.e. the
            # out-of-balance forces do positive work on it (trapezoidal rule), as in
            # overdamped dynamics; the residual norm alone is no Lyapunov function there
            work = -0.5 * (float(np.dot(rq + trial[3], dxq)) + float(np.dot(re + trial[4], dxe)))
            if dbg:
                dbg(f"   ptc mu {mu:.1e} decrease {1 - mt / m:.3e} krylov {kr} work {work:.3g}")
            if mt <= _PTC_GROWTH * m and (not relax or work >= 0.0):
                break
            if self.accept(rq, re):
                self.mu = mu
                return self.accepted(it)
            mu *= _MU_GROW
        else:
            raise SubstepFailure(f"pseudo-transient continuation diverged at iteration {it} (scaled residual "
                               f"{self.rnorm(cur):.3g}, shift {mu:.3g}; "
                               f"{int(np.sum(np.asarray(resp.sliding, bool) & closed))} of "
                               f"{int(closed.sum())} closed contacts sliding; {self.unsettled(rq, re)})")
        self.mu = mu
        if mt > _PTC_STALL * m and self.accept(rq, re):  # stalled on a few weak grains, stress settled
            return self.accepted(it)
        if not relax and it - self.ptc_from[0] >= _PTC_PATIENCE:
            if mt > _PTC_PROGRESS * self.ptc_from[1]:
                # continuation makes no headway: stop here, so that the substep is
                # halved or relaxed without spending the rest of max_iter
                raise SubstepFailure(f"pseudo-transient continuation stalled at iteration {it} (scaled "
                                   f"residual {mt:.3g}, {mt / self.ptc_from[1]:.2f} x that of {_PTC_PATIENCE} "
                                   f"iterations before; {self.unsettled(trial[3], trial[4])})")
            self.ptc_from = (it, mt)
        # switched evolution relaxation (Mulder & van Leer 1985): the shift follows the residual
        # (in committed relaxation faster: every update taken released energy, and one
        # that does not is refused and retried with a larger shift)
        mu = mu * (min(mt / m, _RELAX_MU_CUT) if relax else mt / m)
        self.mu = (_MU_NEWTON if relax else 0.0) if mu < _MU_NEWTON else min(mu, _MU_MAX)
        ctx.mu_max = max(ctx.mu_max, self.mu)
        return dxq, dxe, lam, trial, mt

    def commit(self, it: int) -> None:
        """Committed relaxation: commit the update just taken; the next one starts from it."""
        # energy the update removed: work of the out-of-balance forces along it
        # (trapezoidal rule, from the committed point), what a DEM's damping dissipates
        # (the stress-controlled strains' work is in the external work, at the actual stress)
        self.counters[4] -= 0.5 * float(np.dot(self.base + self.cur[3], self.xq)) / self.V
        self.point = self.done(self.cur, it, final=False)
        self.ctx.relaxed += 1
        self.de_E = np.zeros_like(self.de_E)
        self.xq, self.xe = np.zeros(self.nq), np.zeros(self.ms)
        # the state again from the committed point: the trial's branch flags (sliding,
        # reversal) belong to the increment just taken; the next one may unload those
        # contacts, and a Newton matrix with them sliding moves grains along contacts
        # that stick
        self.cur = self.residual(self.xq, self.xe)
        self.m = self.merit(self.cur)
        self.base = self.cur[3]

    def finish(self) -> PackingPoint:
        """Final acceptance after ``n_iter`` iterations, else :class:`SubstepFailure`."""
        rq, re = self.cur[3], self.cur[4]
        if self.accept(rq, re):
            return self.accepted(self.n_iter + 1)
        what = "committed relaxation did not converge" if self.relax else "Newton did not converge"
        raise SubstepFailure(f"{what} in {self.n_iter} iterations (largest force residual "
                           f"{float(np.max(np.abs(rq) / self.tolq)) * self.opts.rtol:.3g} x mean contact force; "
                           f"{self.unsettled(rq, re)})")


def subdivided(point: PackingPoint, S: np.ndarray, de_E: np.ndarray, t0: np.ndarray, t1: np.ndarray,
               depth: int, ctx: RunContext, counters: list, step_dsig: float | None = None) -> PackingPoint:
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
    except SubstepFailure as exc:
        err = exc
    if depth == 0 and ctx.prec is not point._cache.get("prec"):  # maybe a stale preconditioner: refactor once
        ctx.prec = point.preconditioner()
        ctx.factorizations += 1
        try:
            return _solve(point, S, de_E, t1, ctx, counters, step_dsig)
        except SubstepFailure as exc:
            err = exc
    rd = ctx.opts.relax_depth
    if rd is not None and depth >= min(rd, ctx.opts.max_depth) and not ctx.energy:  # committed relaxation
        ctx.relaxations += 1
        try:
            return _solve(point, S, de_E, t1, ctx, counters, step_dsig, relax=True)
        except SubstepFailure as exc:
            err = exc
    if depth >= ctx.opts.max_depth:
        raise SubstepFailure(f"{err.cause} (after {ctx.opts.max_depth} halvings)")
    tm = 0.5 * (t0 + t1)
    mid = subdivided(point, S, 0.5 * de_E, t0, tm, depth + 1, ctx, counters, step_dsig)
    return subdivided(mid, S, 0.5 * de_E, tm, t1, depth + 1, ctx, counters, step_dsig)

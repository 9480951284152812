"""Iteration pieces of the packing step solver (:mod:`grainmech.driver.packing.step`).

Anderson-accelerated elastic iterations (``anderson_iterations``), the Newton-Krylov direction by
right-preconditioned GMRES (``krylov_direction``), the per-grain trust limits (``trust_ratio``,
``clip_grain_moves``, ``stop_closing``), the step tangent of the contact laws (``step_tangent``,
``slip_rotation``), the held input imbalance (``held_load``), the stress uncertainty of
out-of-balance forces (``stress_ambiguity``) and the solver's trace output. The method
and its sources are in ``docs/models/packing.md``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np
import scipy.sparse.linalg as spla

from grainmech.driver.packing._operators import (
    Kinematics,
    Preconditioner,
    cross_rows,
    voigt_of,
)
from grainmech.driver.packing.options import ACCEPT_MAX_FORCE, PackingOptions, RunContext, SubstepFailure

if TYPE_CHECKING:
    from grainmech.driver.packing.point import PackingPoint

#: backtracking steps of the elastic operator's update after a failed Newton line search
STIFF_BACKTRACKS = 4


def anderson_iterations(prec: Preconditioner, S: np.ndarray, D: np.ndarray, xq: np.ndarray, xe: np.ndarray,
                        cur: tuple, m: float, residual: Callable, merit: Callable, limit: Callable,
                        converged: Callable, settled: Callable, accept: Callable, mem: int, n_iter: int,
                        dbg: Callable | None) -> tuple:
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
    ``_AA_RESTARTS`` times, and only from a point better than the one the history
    started from, which would replay the same iterates: the differences gathered across
    a kink of the laws mix two branches; on 'dense' at 1e-4 this took 10 steps from
    24.6 s to 14.5 s).

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
    best = start = (xq, xe, cur, m)
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
        except SubstepFailure:
            mt = np.inf
        if not mt <= 3.0 * m:  # restart from a plain elastic update, halved until it does not raise r
            if dbg:
                dbg(f"   anderson restart (merit {mt:.3g})")
            X, F, dXs, dFs = [], [], [], []
            sq, se = limit(fq, fe, st)
            for _ in range(STIFF_BACKTRACKS):
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
            # a restart from the point this history started from replays the same
            # iterates (the map is deterministic): only a better point is worth one
            if restarts >= _AA_RESTARTS or best is start or accept(best[2][3], best[2][4]):
                break
            # a stall at a kink of the laws: the differences gathered across it mix two
            # branches; start again from the best point with an empty history
            restarts += 1
            if dbg:
                dbg(f"   anderson stalled: restart {restarts} from the best point (merit {best[3]:.3g})")
            xq, xe, cur, m = start = best
            X, F, dXs, dFs = [], [], [], []
            ref, stall = m, 0
    xq, xe, cur, m = best
    return accept(cur[3], cur[4]), xq, xe, cur, m, it


#: Anderson iterations stop (accepted, or Newton-Krylov takes over) after _AA_PATIENCE
#: iterations that did not lower the best scaled residual below _AA_PROGRESS times itself
_AA_PATIENCE, _AA_PROGRESS = 8, 0.9
#: restarts of the Anderson history from the best point after a stall
_AA_RESTARTS = 2


def krylov_direction(kin: Kinematics, Kb: Any, prec: Preconditioner, S: np.ndarray, rq: np.ndarray, re: np.ndarray,
                     shift: float, m: float, opts: PackingOptions, ctx: RunContext, rtol: float | None = None,
                     roll: Any = None) -> tuple:
    """Newton (``shift = 0``) or continuation update: GMRES on ``(J + shift I) y = -r``.

    ``J`` is the Jacobi-scaled consistent tangent (contact tangents ``Kb``, block diagonal)
    and ``r = (rq, re)`` the residual; ``roll``: the contact moments' part
    (:class:`~grainmech.driver.packing._operators.RollingTangent`) or None. Right
    preconditioning by the factorised elastic operator: GMRES minimises the true (scaled)
    residual of the linear model, not the preconditioned one, which the near-singular directions of the elastic operator
    (mechanisms: grains that roll or slide freely) would dominate.

    Returns
    -------
    (dxq, dxe, slope, pred, krylov) : the update, ``r . dx``, the decrease of the scaled
    residual norm the linear model predicts (from ``m``), GMRES iterations.
    """
    Dq, De = prec.dq, prec.de[S]
    nq, n = Dq.size, Dq.size + De.size
    rhs = -np.concatenate([Dq * rq, De * re])

    def matvec(y: np.ndarray) -> np.ndarray:
        vq = Dq * y[:nq]
        d6 = np.zeros(6)
        d6[S] = De * y[nq:]
        d = kin.delta(vq, d6)
        df = Kb @ d.reshape(-1)
        gq = kin.Gt @ df
        if roll is not None:
            gq = gq + roll.apply(vq, d)
        return np.concatenate([Dq * gq, De * voigt_of(df.reshape(-1, 3), kin.l)[S]]) + shift * y

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
        raise SubstepFailure("linear solve not finite")
    dxq, dxe = Dq * y[:nq], De * y[nq:]
    slope = float(np.dot(rq, dxq) + np.dot(re, dxe))
    if ctx.energy and not slope < 0:  # inexact Krylov step not downhill: preconditioned gradient
        dxq, dxe = prec.apply(-rq, -re, S)
        slope = float(np.dot(rq, dxq) + np.dot(re, dxe))
    pred = m - float(np.linalg.norm(matvec(y) - shift * y - rhs)) if not ctx.energy else 0.0
    return dxq, dxe, slope, pred, count[0]


def trust_ratio(kin: Kinematics, dxq: np.ndarray | None, dxe: np.ndarray, S: np.ndarray, move: float) -> float:
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


def step_tangent(n: np.ndarray, resp: Any, r_s: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Contact tangent (C, 3, 3) from the law's step tangent [force/length].

    ``K = (kn n + t_alpha) n^T + t_delta (I - n n)`` with ``t_delta = dT/d d_t`` and
    ``t_alpha = dT/d alpha``, the derivatives of the end-of-step force of the step the law
    integrated from the committed state (:class:`grainmech.contact.ContactResponse`; for
    Mindlin-Deresiewicz exact to about 1e-9 against finite differences, including the
    normal-tangential coupling of seed Eq. 3.11 and the radial return at the Coulomb
    limit). ``r_s`` converts law-space displacements (:func:`law_scale`); open contacts
    carry nothing.
    """
    w = np.where(closed, r_s, 0.0)
    col = resp.kn[:, None] * n + resp.t_alpha
    P = np.eye(3) - n[:, :, None] * n[:, None, :]
    K = col[:, :, None] * n[:, None, :] + np.einsum("cij,cjk->cik", resp.t_delta, P)
    return K * w[:, None, None]


def slip_rotation(point: PackingPoint, resp: Any, kin: Kinematics, xq: np.ndarray, de: np.ndarray) -> np.ndarray:
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


def held_load(point: PackingPoint, resp: Any) -> np.ndarray:
    """The held input imbalance (``PackingPoint.load``) that the grains' closed contacts can resist.

    A grain's closed contacts resist its motions ``q_p`` that change their relative
    displacements (``W_p q_p != 0``, ``W_p`` the grain's blocks of ``G`` over its closed
    contacts, neighbours held). Along the others, its mechanisms ``W_p phi = 0``
    (:func:`_mechanisms`), nothing can balance a load: a grain whose contacts have all
    opened (six such motions), a grain held by one contact (rotations about the contact
    point) or by two (rolling about the line through its two contact points, in this
    fixed geometry). A load there makes the grain drift without bound in this fixed
    geometry (and roll or fly off in a DEM), so that share of the held load is dropped:
    the part kept does no work on any such motion (it is the load minus its orthogonal
    projection on them, rotations scaled by the grain radius). The first case was the
    rule before; the second drove a grain held by two weak contacts of the 500-grain
    packing of ``docs/models/packing.md`` around its contact axis by 0.17 rad and 4 % of
    its radius in 68 steps at γ = 3e-5, until the small-strain check stopped the run.
    """
    kin = point.kinematics
    if point.load is None:
        return np.zeros(kin.n_free)
    closed = ~np.asarray(resp.open, bool)
    memo = _HELD.setdefault(kin, {})
    key = closed.tobytes()
    got = memo.get(key)
    if got is not None and got[0] is point.load:
        return got[1]
    g, proj, scale = _mechanisms(kin, point.radii, closed)
    if len(memo) >= 16:
        memo.clear()
    if not g.size:
        memo[key] = (point.load, point.load)
        return point.load
    full = kin.full(point.load)
    ls = full[g] / scale  # (force, moment / R)
    full[g] -= np.einsum("pij,pj->pi", proj, ls) * scale
    kept = full.reshape(-1)[kin.free]
    memo[key] = (point.load, kept)
    return kept


def _mechanisms(kin: Kinematics, R: np.ndarray, closed: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grains with mechanisms and the projectors onto them: ``(g, proj (k, 6, 6), scale (k, 6))``.

    A grain's closed contacts resist its motions ``q_p`` with ``W_p q_p != 0`` (``W_p``
    its blocks of ``G`` over its closed contacts, neighbours held); its mechanisms are
    ``W_p phi = 0``. Only a grain with at most two closed contacts has any (a rigid motion
    that moves none of three points of a sphere is zero: no line passes through three of
    them): six with none, three rotations about the one contact point, one rolling about
    the line through two. With rolling and twisting resistance (``kin.rolling``) the
    contacts resist the relative rotation as well (its part along ``n`` only with twisting
    resistance), and a grain with one closed contact keeps at most its spin about that
    contact's normal (a cap reached is a sliding of the moment, as Coulomb sliding is for
    forces, and is not a mechanism here either). ``proj`` is the orthogonal projector onto them in the scaled
    coordinates ``(u, R theta)`` (and ``(F, M / R)`` for loads), ``scale`` the grain's
    ``(1, 1, 1, R, R, R)``. Cached per kinematics and closed set (the same contacts stay
    closed over most updates and steps).
    """
    memo = _MECH.setdefault(kin, {})
    key = closed.tobytes()
    got = memo.get(key)
    if got is not None:
        return got
    if len(memo) >= 16:
        memo.clear()
    P = kin.n_grains
    ncl = np.bincount(kin.a[closed], minlength=P) + np.bincount(kin.b[closed], minlength=P)
    few = ncl <= 2
    g = np.flatnonzero(few)
    if not g.size:
        memo[key] = out = (g, np.zeros((0, 6, 6)), np.zeros((0, 6)))
        return out
    # blocks of the relative displacement of each closed contact in the motion of its grain
    # A ([I, -[r_A]x]) and of its grain B ([-I, [r_B]x]), rotations scaled by the radius
    closed = closed & (few[kin.a] | few[kin.b])
    a, b, n = kin.a[closed], kin.b[closed], kin.n[closed]
    W = np.zeros((2, a.size, 3, 6))
    W[0, :, :, :3] = np.eye(3)
    W[0, :, :, 3:] = -cross_rows(R[a][:, None] * n) / R[a][:, None, None]
    W[1, :, :, :3] = -np.eye(3)
    W[1, :, :, 3:] = cross_rows(-R[b][:, None] * n) / R[b][:, None, None]
    ga = np.einsum("cki,ckj->cij", W[0], W[0]).reshape(-1, 36)
    gb = np.einsum("cki,ckj->cij", W[1], W[1]).reshape(-1, 36)
    if kin.rolling:  # moment springs resist the relative rotation too: rolling (and twisting) mechanisms go
        Pr = np.eye(3) - (0.0 if kin.twisting else n[:, :, None] * n[:, None, :])
        Wr = np.zeros((2, a.size, 3, 6))
        Wr[0, :, :, 3:] = Pr / R[a][:, None, None]
        Wr[1, :, :, 3:] = -Pr / R[b][:, None, None]
        ga = ga + np.einsum("cki,ckj->cij", Wr[0], Wr[0]).reshape(-1, 36)
        gb = gb + np.einsum("cki,ckj->cij", Wr[1], Wr[1]).reshape(-1, 36)
    gram = np.stack([np.bincount(a, ga[:, k], P) + np.bincount(b, gb[:, k], P) for k in range(36)],
                    axis=1).reshape(P, 6, 6)
    w, U = np.linalg.eigh(gram[g])  # ascending; the grain's mechanisms have w ~ 0 (entries O(1))
    null = (w < 1e-9 * np.maximum(w[:, -1:], 1.0)).astype(float)
    proj = np.einsum("pik,pk,pjk->pij", U, null, U)
    scale = np.concatenate([np.ones((g.size, 3)), np.repeat(R[g][:, None], 3, axis=1)], axis=1)
    memo[key] = out = (g, proj, scale)
    return out


def hold_mechanisms(kin: Kinematics, dxq: np.ndarray, R: np.ndarray, closed: np.ndarray) -> np.ndarray:
    """Grain update ``dxq`` without its parts along each grain's mechanisms (:func:`_mechanisms`).

    The driver's rule for a grain that loses contacts (``docs/models/packing.md``,
    "Opening and closing"): a motion along a mechanism changes no contact, so no force
    acts along it (the contacts do no work on it and the held load's share there is
    dropped, :func:`held_load`) and equilibrium does not fix it. The grain keeps its
    fluctuation along it, i.e. follows the mean strain there: the least-norm solution, as
    ``H^+`` does in the relaxed tensor (Lemaitre & Maloney 2006, Eq. 12). A grain with no
    closed contact thus leaves the unknowns entirely; a grain with one or two keeps the
    motions they resist. It comes back as soon as a tracked pair closes (``closed`` is
    the iterate's), by the affine motion or by a neighbour's update. Without this rule
    the elastic operator, which holds these motions only by its small shift
    (``regularization``) or by contacts that have opened since it was factorised, turns
    the neighbours' residuals into large moves along them: on 'medium' brought from 100
    to 800 kPa, grains rolled on two contacts and drifted by 5 % of their radius, until
    the small-strain check stopped the run.
    """
    g, proj, scale = _mechanisms(kin, R, closed)
    if not g.size:
        return dxq
    full = kin.full(dxq)
    full[g] -= np.einsum("pij,pj->pi", proj, full[g] * scale) / scale
    return full.reshape(-1)[kin.free]


#: held_load's results per kinematics (weak: dropped with the run's points)
_HELD: WeakKeyDictionary = WeakKeyDictionary()
#: _mechanisms' results per kinematics
_MECH: WeakKeyDictionary = WeakKeyDictionary()


def stop_closing(kin: Kinematics, dxq: np.ndarray, dxe: np.ndarray, S: np.ndarray, approach: np.ndarray,
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


def at_rest(kin: Kinematics, rq: np.ndarray, R: np.ndarray, fref: float, bar: float) -> bool:
    """Whether out-of-balance forces ``rq`` leave the packing at rest by a DEM's measure.

    The mean over grains of ``sqrt(|F_p|^2 + (|M_p|/R_p)^2)`` at most ``bar`` times the
    mean contact force ``fref`` (:func:`unbalanced_force_ratio`, ``kind="mean"``) and the
    largest grain's ``|F_p|``, ``|M_p|/R_p`` at most ``ACCEPT_MAX_FORCE`` times it
    (``PackingOptions.accept_unbalanced``).
    """
    if fref <= 0.0:
        return False
    g = grain_residuals(kin, rq)
    F = np.linalg.norm(g[:, :3], axis=1)
    M = np.linalg.norm(g[:, 3:], axis=1) / R
    return bool(np.mean(np.hypot(F, M)) <= bar * fref and max(F.max(), M.max()) <= ACCEPT_MAX_FORCE * fref)


def grain_residuals(kin: Kinematics, rq: np.ndarray) -> np.ndarray:
    """(P, 6) out-of-balance forces and moments of every grain from ``rq`` (n_free,).

    The translation of grain 0 is pinned (not an unknown, :class:`Kinematics`); its
    out-of-balance force follows from the others', as the contact forces sum to zero:
    ``F_0 = -sum_(p>0) F_p``. Small residuals of many grains in one direction add up
    there, which is why grain 0 is the best-held grain of the packing
    (:func:`grainmech.driver.packing._input.pin_first`).
    """
    g = kin.full(rq)
    g[0, :3] = -g[1:, :3].sum(axis=0)
    return g


def largest_residual(kin: Kinematics, rq: np.ndarray, R: np.ndarray) -> float:
    """The largest grain's ``|F_p|`` or ``|M_p|/R_p`` of out-of-balance forces ``rq`` [force].

    Over the mean contact force this is :func:`unbalanced_force_ratio` with ``kind="max"``,
    the residual :class:`PackingResult` reports.
    """
    g = grain_residuals(kin, rq)
    return float(max(np.linalg.norm(g[:, :3], axis=1).max(initial=0.0),
                     (np.linalg.norm(g[:, 3:], axis=1) / R).max(initial=0.0)))


def unbalanced_ratio(kin: Kinematics, rq: np.ndarray, R: np.ndarray, fref: float) -> float:
    """Mean unbalanced force ratio of out-of-balance forces ``rq`` (trace output)."""
    g = grain_residuals(kin, rq)
    return float(np.mean(np.hypot(np.linalg.norm(g[:, :3], axis=1), np.linalg.norm(g[:, 3:], axis=1) / R))
                 / max(fref, 1e-300))


def stress_ambiguity(kin: Kinematics, rq: np.ndarray, R: np.ndarray) -> float:
    """``sum_p (|F_p| R_p + |M_p|)`` [force length] of out-of-balance forces and moments ``rq``."""
    g = grain_residuals(kin, rq)
    return float(np.sum(np.linalg.norm(g[:, :3], axis=1) * R + np.linalg.norm(g[:, 3:], axis=1)))


def clip_grain_moves(kin: Kinematics, dxq: np.ndarray, R: np.ndarray, move: float) -> np.ndarray:
    """Grain update ``dxq`` (n_free,) with each grain's move clipped to ``move`` [length].

    A grain's translation and surface rotation ``R |theta|`` are scaled down together.
    """
    mv = kin.full(dxq)
    big = np.maximum(np.linalg.norm(mv[:, :3], axis=1), R * np.linalg.norm(mv[:, 3:], axis=1))
    c = move / np.maximum(big, move)
    return (mv * c[:, None]).reshape(-1)[kin.free]


def grain_report(kin: Kinematics, rq: np.ndarray, tolq: np.ndarray, resp: Any) -> str:
    """Trace line: grains above the force tolerance, the worst ones with their contacts."""
    g = np.max(kin.full(np.abs(rq) / tolq), axis=1)
    closed = ~np.asarray(resp.open, bool)
    sl = np.asarray(resp.sliding, bool) & closed
    nc = np.bincount(kin.a[closed], minlength=g.size) + np.bincount(kin.b[closed], minlength=g.size)
    ns = np.bincount(kin.a[sl], minlength=g.size) + np.bincount(kin.b[sl], minlength=g.size)
    worst = np.argsort(g)[::-1][:5]
    top = " ".join(f"{p}:{g[p]:.2g}({nc[p]}c,{ns[p]}s)" for p in worst)
    return f"   grains over tol {int(np.sum(g > 1))} (>100x {int(np.sum(g > 100))}); worst {top}"


def trace_printer() -> Callable[[str], None] | None:
    """Trace printer of the step solver when ``GRAINMECH_PACKING_TRACE`` is set."""
    if not os.environ.get("GRAINMECH_PACKING_TRACE"):
        return None
    return lambda msg: print(f"[packing] {msg}", file=sys.stderr)

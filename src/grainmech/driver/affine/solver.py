"""Drive a material point along a loading path (mixed stress/strain control).

Each step solves for the strain increment whose strain-controlled components are
prescribed and whose stress-controlled components bring the Love-Weber stress to the
target. Newton iterations on the stress-controlled components use the consistent tangent
``C_SS`` (seed Eq. 2.26 from the laws' tangent stiffnesses); every iteration re-evaluates
the laws from the last *converged* state with the total trial increment (no drift of the
history variables). A step that does not converge is split in two halves, recursively up
to ``max_depth`` levels. A failure is never hidden: the result carries ``success``,
``status`` and a ``message`` naming the step and the cause, and everything computed
until then.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike

from grainmech.contact import ReversalMemoryError
from grainmech.contact.interface import ContactLaw
from grainmech.contact.law import max_reversals
from grainmech.driver.affine.response import (
    consistent_tangent,
    evaluate,
    geometric_stiffness,
    sliding_open_fractions,
    tangent,
)
from grainmech.driver.base import DriverResult, PointStepping, StepFailure
from grainmech.driver.loop import (
    ModulusReduction,
    PathCheckpoint,
    copied_rows,
    cyclic_series,
    follow_path,
    path_saves,
    restore_rows,
)
from grainmech.driver.paths import LoadPath
from grainmech.elasticity import condensed_modulus, engineering_constants
from grainmech.errors import ConfigError, GrainmechError

if TYPE_CHECKING:  # the point imports this module (MaterialPoint.at_stress runs a path)
    from grainmech.driver.affine.point import MaterialPoint

__all__ = ["run", "DriverResult", "SolverOptions", "modulus_reduction"]


@dataclass(frozen=True)
class SolverOptions:
    """Options of the increment solver.

    Attributes
    ----------
    rtol : float
        Stress residual tolerance relative to the stress scale of the step
        (``max |sigma|`` at its start and target).
    max_iter : int
        Newton iterations per (sub)step.
    max_depth : int
        Halvings of a step (2**max_depth substeps at most).
    engineering : bool
        Also compute engineering constants of the tangent at each step.
    finite_deformation : bool
        Add the first-order finite-deformation correction of seed Eq. 2.36-2.38
        (errata E-2.34) to the stress increments, ``G(sigma_mid) : d eps`` with the
        mid-step stress (:func:`grainmech.driver.affine.point.geometric_stiffness`). Newton uses
        ``C + G(sigma_start)``; the reported ``tangent`` stays the contact tangent ``C``.
        The contact sums keep the reference geometry (``l``, ``V`` not updated), so the
        option is first order in the total strain.
    rtol_accept : float
        A step whose Newton iterations stall (no longer contract) with every residual at
        most ``rtol_accept`` times the stress scale is accepted, and counted in the
        result's message. The Mindlin-Deresiewicz memory ignores load reversals below
        ``1e-6`` of ``2 mu N`` (round-off ties, :data:`grainmech.contact.hysteresis.REV_TOL`), so
        the stress of a contact set is a continuous function of the strain only to about
        that resolution; below it Newton can cycle between two sides of such a tie.
    compiled : bool
        Integrate a path whose every component is strain controlled in one compiled pass
        (:mod:`grainmech.driver.affine._fused`; no Newton iterations are needed there) when the
        point's law has a compiled kernel. Same results to rounding; ``False`` forces the
        step-by-step loop.
    fold : bool
        In the compiled loops, evaluate one row per orbit of the symmetries that the
        contact set, the state and the path share -- the antipodal map and the mirrors
        through coordinate planes whose odd shear components the path leaves at zero
        (every row's exact image present with the same weight, the state symmetric) --
        with the orbit's weight (:mod:`grainmech.driver.affine._fold`): half the law evaluations
        for a centrosymmetric set, a quarter for simple shear on a Lebedev rule, an eighth
        for a triaxial path; the same results to rounding. ``False`` evaluates every row.
    """

    rtol: float = 1e-9
    rtol_accept: float = 1e-6
    max_iter: int = 30
    max_depth: int = 8
    engineering: bool = False
    finite_deformation: bool = False
    compiled: bool = True
    fold: bool = True

    def __post_init__(self) -> None:
        if not (0 < self.rtol < 1e-2):
            raise ConfigError("rtol", self.rtol, "must lie in (0, 1e-2)")
        if not (self.rtol <= self.rtol_accept < 1e-2):
            raise ConfigError("rtol_accept", self.rtol_accept, "must lie in [rtol, 1e-2)")
        if int(self.max_iter) < 1:
            raise ConfigError("max_iter", self.max_iter, "must be >= 1")
        if not (0 <= int(self.max_depth) <= 30):
            raise ConfigError("max_depth", self.max_depth, "must lie in [0, 30]")


def _solve(point: MaterialPoint, sc: np.ndarray, d_strain: np.ndarray, target: np.ndarray,
           opts: SolverOptions, fused: bool = False) -> tuple[MaterialPoint, int, Any, bool]:
    """Newton iterations for one (sub)step; returns (point, iterations, response).

    ``fused``: evaluate through the compiled pass of :mod:`grainmech.driver.affine._fused`
    (with the consistent Jacobian rows) instead of :func:`evaluate` + :func:`tangent`.
    """
    de = np.where(sc, 0.0, d_strain)
    scale = max(float(np.abs(point.stress).max()), float(np.abs(target[sc]).max()) if sc.any() else 0.0)
    Gm = geometric_stiffness(point.stress) if opts.finite_deformation else np.zeros((6, 6))
    C = point.tangent + Gm
    if scale == 0.0:
        scale = float(np.abs(C).max() * np.abs(de).max()) or 1.0
    tol = opts.rtol * scale
    loose = opts.rtol_accept * scale
    best: tuple | None = None  # (residual, new point, response) of the best iterate within `loose`
    hist: list = []  # residual of every iteration
    if sc.any():
        rhs = target[sc] - point.stress[sc] - C[np.ix_(sc, ~sc)] @ de[~sc]
        try:
            de[sc] = np.linalg.solve(C[np.ix_(sc, sc)], rhs)
        except np.linalg.LinAlgError:
            de[sc] = 0.0
        if not np.all(np.isfinite(de)):
            de[sc] = 0.0
    ev: Any
    for it in range(1, opts.max_iter + 1):
        if fused:
            ev = _fused_evaluate(point, de, sc)
        else:
            ev = evaluate(point, de)
        if opts.finite_deformation:
            # G at the mid-step stress (contact part of the trial): second-order accurate
            mid = point.stress + 0.5 * (ev.stress - (point.stress - point.correction))
            corr = point.correction + geometric_stiffness(mid) @ de
        else:
            corr = point.correction
        sig = ev.stress + corr
        r = sig[sc] - target[sc]
        rmax = float(np.abs(r).max()) if sc.any() else 0.0
        if rmax <= loose:
            new = replace(point, state=ev.state, response=ev.response,
                          strain=point.strain + de, stress=sig, correction=corr)
            if fused:  # the compiled pass assembled it already (cached_property slot)
                object.__setattr__(new, "tangent", ev.tangent)
            if rmax <= tol:
                return new, it, ev.response, False
            if best is None or rmax < best[0]:
                best = (rmax, new, ev.response)
            if len(hist) >= 2 and abs(rmax - hist[-2]) <= 1e-6 * rmax:  # two-cycle at a tie of the law
                return best[1], it, best[2], True
        hist.append(rmax)
        if fused:
            J = ev.jacobian[np.ix_(sc, sc)]
        else:
            C = consistent_tangent(point.contacts, ev.response) + Gm
            J = C[np.ix_(sc, sc)]
        cond = np.linalg.cond(J)
        if not np.isfinite(cond) or cond > 1e13:
            sl, op = sliding_open_fractions(point.contacts, ev.response)
            raise StepFailure(f"tangent singular (condition {cond:.3g}), {100 * sl:.0f}% of contacts "
                               f"sliding, {100 * op:.0f}% open")
        de[sc] = de[sc] - np.linalg.solve(J, r)
        if not np.all(np.isfinite(de)):
            raise StepFailure("Newton update not finite")
    if best is not None:
        return best[1], opts.max_iter, best[2], True
    sl, op = sliding_open_fractions(point.contacts, ev.response)
    raise StepFailure(f"Newton did not converge in {opts.max_iter} iterations (residual "
                       f"{np.abs(r).max():.3g} > {tol:.3g}), {100 * sl:.0f}% of contacts sliding, "
                       f"{100 * op:.0f}% open")


def _subdivided(point, sc, d_strain, t0, t1, depth, opts, counters, fused=False):
    """Advance from ``point`` by strain ``d_strain`` and to stress target ``t1`` (from ``t0``)."""
    try:
        new, it, resp, loose = _solve(point, sc, d_strain, t1, opts, fused)
        counters[0] += 1
        counters[1] += it
        counters[4] += int(loose)
        counters[2] += float(np.dot(point.contacts.weights, resp.dissipation))
        counters[3] += float(np.dot(0.5 * (point.stress + new.stress), new.strain - point.strain))
        return new
    except StepFailure as exc:
        err = exc
    except GrainmechError as exc:  # a law refused the increment (e.g. domain, memory)
        err = StepFailure(f"contact law error: {exc}")
    if depth >= opts.max_depth:
        raise StepFailure(f"{err.cause} (after {opts.max_depth} halvings)")
    tm = 0.5 * (t0 + t1)
    mid = _subdivided(point, sc, 0.5 * d_strain, t0, tm, depth + 1, opts, counters, fused)
    return _subdivided(mid, sc, 0.5 * d_strain, tm, t1, depth + 1, opts, counters, fused)


def run(point: MaterialPoint, path: LoadPath, *, options: SolverOptions | None = None,
        checkpoint: PathCheckpoint | None = None, **kwargs: Any) -> DriverResult:
    """Drive ``point`` along ``path``.

    Parameters
    ----------
    point : MaterialPoint
        Initial converged state (e.g. :meth:`MaterialPoint.isotropic`).
    path : LoadPath
        Steps with control masks and increments (:mod:`grainmech.driver.paths`).
    options : SolverOptions, optional
    checkpoint : PathCheckpoint, optional
        Save the run after the steps it names (the point, the rows so far and the running
        targets; a compiled run is split into calls at those steps) and/or go on from such
        a save (``grainmech run --resume``).
    **kwargs
        Fields of :class:`SolverOptions` (``rtol``, ``max_iter``, ``max_depth``,
        ``engineering``) as a shortcut.

    Returns
    -------
    DriverResult
        ``success`` False if a step failed; the arrays hold the steps done before.
    """
    if options is None:
        options = SolverOptions(**kwargs)
    elif kwargs:
        options = replace(options, **kwargs)
    if not isinstance(path, LoadPath):
        raise ConfigError("path", type(path).__name__, "must be a LoadPath")
    m = len(path)
    # compiled law evaluations (driver/_fused.py): decided once per run
    fused = options.compiled and not options.finite_deformation and _compiled_law(point)
    resume = checkpoint.resume if checkpoint is not None else None
    if fused and not path.stress_control.any() and m > 0 and (resume is None or resume[1]["loop"] == "fused"):
        res = _run_fused(point, path, options, checkpoint)
        if res is not None:
            return res
    if fused and path.stress_control.any():
        return _run_mixed(point, path, options, checkpoint)
    return _run_steps(point, path, options, fused, checkpoint)


@dataclass(frozen=True)
class _Stepping(PointStepping):
    """The affine point as a :class:`~grainmech.driver.base.SteppingPoint` of :func:`follow_path`.

    ``step`` is one step of the Python loop (:func:`_subdivided`: Newton, halvings);
    ``counters`` are the last step's substeps, iterations, dissipation, work and
    (sub)steps accepted at the law's resolution.
    """

    point: MaterialPoint
    options: SolverOptions
    fused: bool
    counters: tuple = (0, 0, 0.0, 0.0, 0)

    def step(self, d_strain: np.ndarray, stress_control: np.ndarray, target: np.ndarray) -> _Stepping:
        """One step from this state (targets ``target`` on the stress-controlled components)."""
        counters: list[Any] = [0, 0, 0.0, 0.0, 0]
        t0 = np.where(stress_control, self.point.stress, 0.0)
        new = _subdivided(self.point, stress_control, d_strain, t0, target, 0, self.options, counters, self.fused)
        return replace(self, point=new, counters=tuple(counters))


def _run_steps(point: MaterialPoint, path: LoadPath, options: SolverOptions, fused: bool,
               checkpoint: PathCheckpoint | None = None) -> DriverResult:
    """:func:`run` step by step through the one path loop (:func:`grainmech.driver.loop.follow_path`)."""
    rows: dict[str, list] = {k: [] for k in ("strain", "stress", "tangent", "sl", "op", "diss", "work", "stored",
                                             "sub", "it")}
    acc = {"diss": 0.0, "work": 0.0, "loose": 0}
    resume: tuple[int, Any] | None = None
    # a saved state of another loop (a compiled run that fell back to this one) is not taken up
    if checkpoint is not None and checkpoint.resume is not None and checkpoint.resume[1]["loop"] == "steps":
        k0, saved = checkpoint.resume
        restore_rows(rows, saved["rows"])
        acc.update(saved["acc"])
        point, resume = saved["point"], (k0, saved["targets"])
    kw = path_saves(checkpoint, lambda st, targets: {"loop": "steps", "point": st.point, "rows": copied_rows(rows),
                                                     "acc": dict(acc), "targets": targets})

    def record(st: _Stepping, k: int) -> None:
        pt = st.point
        sub, it, diss, work, loose = st.counters
        acc["diss"] += diss
        acc["work"] += work
        acc["loose"] += loose
        sl, op = pt.fractions()
        rows["strain"].append(pt.strain.copy())
        rows["stress"].append(pt.stress.copy())
        rows["tangent"].append(pt.tangent)
        rows["sl"].append(sl)
        rows["op"].append(op)
        rows["diss"].append(acc["diss"])
        rows["work"].append(acc["work"])
        rows["stored"].append(pt.stored_energy())
        rows["sub"].append(sub)
        rows["it"].append(it)

    final, success, status, message = follow_path(
        _Stepping(point, options, fused), path, record,
        word_failure=lambda k, exc: f"step {k}: stress target not reachable: {exc.cause}", resume=resume, **kw)
    if acc["loose"]:
        message += (f" ({acc['loose']} (sub)step(s) accepted at the contact law's resolution: stress residual "
                    f"<= {options.rtol_accept:g} x stress scale)")
    arr = {k: np.array(v) for k, v in rows.items()}
    return _result(success, int(status), message, arr, cast(_Stepping, final).point, len(path), options)


def _result(success: bool, status: int, message: str, arr: dict, point: MaterialPoint, m: int,
            options: SolverOptions) -> DriverResult:
    eng: dict = {}
    if options.engineering:
        dicts: list[dict | None] = []
        for C in arr["tangent"]:
            try:
                dicts.append(engineering_constants(C).as_dict())
            except GrainmechError:
                dicts.append(None)
        keys = next((list(d) for d in dicts if d), [])
        for key in keys:
            vals = [d.get(key) if d else None for d in dicts]
            if all(isinstance(v, (int, float)) for v in vals):
                eng[key] = np.array(vals, dtype=float)
    return DriverResult(success, status, message, arr["strain"], arr["stress"], arr["tangent"],
                        arr["sl"], arr["op"], arr["diss"], arr["work"], arr["stored"],
                        arr["sub"].astype(int), arr["it"].astype(int), point, m, eng)


@dataclass(frozen=True)
class _FusedEvaluation:
    state: Any
    response: Any
    stress: np.ndarray
    tangent: np.ndarray
    jacobian: np.ndarray


def _fused_evaluate(point: MaterialPoint, de: np.ndarray, sc: np.ndarray) -> _FusedEvaluation:
    """One trial increment through the compiled pass.

    Kinematics, law, stress, tangent and the consistent Jacobian rows of the
    stress-controlled components.
    """
    # imported here: needs numba (optional)
    from grainmech.driver.affine._fused import strain_path

    out = strain_path(point, de[None, :], sc)
    if out is None:  # reversal memory exhausted somewhere: let the NumPy path say where
        ev = evaluate(point, de)
        return _FusedEvaluation(ev.state, ev.response, ev.stress, tangent(point.contacts, ev.response),
                                consistent_tangent(point.contacts, ev.response))
    return _FusedEvaluation(out["state"], out["response"], out["stress"][0], out["tangent"][0],
                            out["jacobian"][0])


def _compiled_law(point: MaterialPoint) -> bool:
    """Whether the point's law is evaluated by the compiled kernel.

    A :class:`~grainmech.contact.interface.ContactLaw` with numba present, the law
    supported and the backend not ``numpy``.
    """
    return isinstance(point.law, ContactLaw) and point.law.compiled


def _run_fused(point: MaterialPoint, path: LoadPath, options: SolverOptions,
               checkpoint: PathCheckpoint | None = None) -> DriverResult | None:
    """:func:`run` for a fully strain-controlled path through :mod:`grainmech.driver.affine._fused`.

    One compiled call per piece of the path between the steps ``checkpoint.after`` (the
    whole path without a checkpoint), each piece saved at its end.
    """
    # imported here: needs numba (optional)
    from grainmech.driver.affine._fused import strain_path

    m = len(path)
    # the increments exactly as the step loop forms them (targets, no drift)
    de = np.empty((m, 6))
    strain = np.empty((m + 1, 6))
    strain[0] = point.strain
    target = point.strain.copy()
    for k in range(m):
        target = target + path.increment[k]
        de[k] = target - strain[k]
        strain[k + 1] = strain[k] + de[k]
    ends = sorted({int(k) for k in (checkpoint.after if checkpoint is not None else ()) if 0 < k < m} | {m})
    sl0, op0 = point.fractions()
    rows: dict[str, list] = {"stress": [point.stress[None]], "tangent": [point.tangent[None]], "sl": [[sl0]],
                             "op": [[op0]], "diss": [[0.0]], "stored": [[point.stored_energy()]]}
    a = 0
    if checkpoint is not None and checkpoint.resume is not None:
        a, saved = checkpoint.resume
        point, rows = saved["point"], copied_rows(saved["rows"])
    for b in (e for e in ends if e > a):
        out = strain_path(point, de[a:b], fold=options.fold)
        if out is None:
            return None
        for key, name in (("stress", "stress"), ("tangent", "tangent"), ("sl", "sliding"), ("op", "open"),
                          ("stored", "stored")):
            rows[key].append(out[name] + (point.correction if key == "stress" else 0.0))
        rows["diss"].append(rows["diss"][-1][-1] + np.cumsum(out["dissipation"]))
        point = replace(point, state=out["state"], response=out["response"], strain=strain[b].copy(),
                        stress=rows["stress"][-1][-1].copy())
        if b < m and checkpoint is not None and checkpoint.save is not None:
            checkpoint.save(b, {"loop": "fused", "point": point, "rows": copied_rows(rows)})
        a = b
    arr = {key: np.concatenate([np.asarray(v, dtype=float) for v in vals]) for key, vals in rows.items()}
    stress = arr["stress"]
    work = np.zeros(m + 1)
    work[1:] = np.cumsum(np.einsum("ki,ki->k", 0.5 * (stress[:-1] + stress[1:]), de))
    arr.update(strain=strain, work=work, sub=np.r_[0, np.ones(m, dtype=int)], it=np.r_[0, np.ones(m, dtype=int)])
    return _result(True, 0, f"completed {m} steps", arr, point, m, options)


def _mixed_cause(seg: dict, point: MaterialPoint, options: SolverOptions) -> str:
    """The failure cause of a compiled segment, worded as :func:`_solve` words it."""
    # imported here: needs numba (optional)
    from grainmech.driver.affine import _mixed

    code = seg["cause"]
    val, tol, sl, op = seg["finfo"]
    if code == _mixed.FAIL_SINGULAR:
        cause = (f"tangent singular (condition {val:.3g}), {100 * sl:.0f}% of contacts sliding, "
                 f"{100 * op:.0f}% open")
    elif code == _mixed.FAIL_NOT_FINITE:
        cause = "Newton update not finite"
    elif code == _mixed.FAIL_NO_CONVERGENCE:
        cause = (f"Newton did not converge in {options.max_iter} iterations (residual {val:.3g} > {tol:.3g}), "
                 f"{100 * sl:.0f}% of contacts sliding, {100 * op:.0f}% open")
    elif seg["flag"] in (1, 2):
        cause = ("contact law error: "
                 f"{ReversalMemoryError(np.array([seg['contact']]), max_reversals(point.law.params))}")
    else:
        cause = "contact law error: Mindlin-Deresiewicz branch integration did not terminate"
    return f"{cause} (after {options.max_depth} halvings)"


def _run_mixed(point: MaterialPoint, path: LoadPath, options: SolverOptions,
               checkpoint: PathCheckpoint | None = None) -> DriverResult:
    """:func:`run` with each segment of constant control mask in one compiled call.

    :func:`grainmech.driver.affine._mixed.mixed_segment` runs the loop of :func:`run` /
    :func:`_subdivided` / :func:`_solve`, with the same rules and messages. A segment also
    ends at each step of ``checkpoint.after``, where the run is saved.
    """
    # imported here: needs numba (optional)
    from grainmech.driver.affine._mixed import mixed_segment

    m = len(path)
    sc_all = path.stress_control
    sl0, op0 = point.fractions()
    rows: dict[str, list] = {
            "strain": [point.strain[None]], "stress": [point.stress[None]], "tangent": [point.tangent[None]],
            "sl": [[sl0]], "op": [[op0]], "diss": [[0.0]], "work": [[0.0]], "stored": [[point.stored_energy()]],
            "sub": [[0]], "it": [[0]]}
    t_stress = point.stress.copy()
    t_strain = point.strain.copy()
    prev = None
    diss = work = 0.0
    n_loose = 0
    success, status, message = True, 0, f"completed {m} steps"
    a = 0
    after = set(checkpoint.after) if checkpoint is not None else set()
    if checkpoint is not None and checkpoint.resume is not None and checkpoint.resume[1]["loop"] == "mixed":
        a, saved = checkpoint.resume
        rows = copied_rows(saved["rows"])
        point, t_stress, t_strain, prev = saved["point"], saved["t_stress"], saved["t_strain"], saved["prev"]
        diss, work, n_loose = saved["diss"], saved["work"], saved["n_loose"]
    while a < m:
        sc = sc_all[a]
        b = a + 1
        while b < m and np.array_equal(sc_all[b], sc) and b not in after:
            b += 1
        if prev is not None:  # a component switching control restarts from the state
            switched = sc != prev
            t_stress = np.where(switched & sc, point.stress, t_stress)
            t_strain = np.where(switched & ~sc, point.strain, t_strain)
        prev = sc
        seg: dict[str, Any] = mixed_segment(point, sc, path.increment[a:b], t_stress, t_strain, options)
        k = seg["done"]
        t_stress, t_strain = seg["t_stress"], seg["t_strain"]
        n_loose += seg["n_loose"]
        for key, name in (("strain", "strain"), ("stress", "stress"), ("tangent", "tangent"), ("sl", "sliding"),
                          ("op", "open"), ("stored", "stored"), ("sub", "substeps"), ("it", "iterations")):
            rows[key].append(seg[name])
        rows["diss"].append(diss + np.cumsum(seg["dissipation"]))
        rows["work"].append(work + np.cumsum(seg["work"]))
        if k:
            diss = float(rows["diss"][-1][-1])
            work = float(rows["work"][-1][-1])
        point = replace(point, state=seg["state"], response=seg["response"], strain=seg["strain_end"],
                        stress=seg["stress_end"])
        object.__setattr__(point, "tangent", seg["tangent_end"])
        if seg["cause"]:
            success, status = False, 1
            message = f"step {a + k + 1}: stress target not reachable: {_mixed_cause(seg, point, options)}"
            break
        if b in after and b < m and checkpoint is not None and checkpoint.save is not None:
            checkpoint.save(b, {"loop": "mixed", "point": point, "rows": copied_rows(rows),
                                "t_stress": t_stress, "t_strain": t_strain, "prev": prev, "diss": diss,
                                "work": work, "n_loose": n_loose})
        a = b
    if n_loose:
        message += (f" ({n_loose} (sub)step(s) accepted at the contact law's resolution: stress residual "
                    f"<= {options.rtol_accept:g} x stress scale)")
    arr = {key: np.concatenate([np.asarray(v, dtype=float) if key not in ("sub", "it") else np.asarray(v)
                                for v in vals]) for key, vals in rows.items()}
    return _result(success, status, message, arr, point, m, options)


def modulus_reduction(point: Any, amplitudes: ArrayLike, *, n_cycles: int = 2,
                      steps_per_cycle: int = 80, waveform: str = "triangle", constant: str = "stress",
                      progress: Callable[[int, float, Any], None] | None = None,
                      raise_on_failure: bool = True,
                      on_amplitude: Callable[[ModulusReduction], None] | None = None,
                      runner: Callable[..., DriverResult] | None = None,
                      on_stop: Callable[[float, str], None] | None = None,
                      **run_options: Any) -> ModulusReduction:
    """Strain-controlled cyclic simple shear (``gamma_xz``) per amplitude.

    Each amplitude starts from ``point``; the last of ``n_cycles`` cycles is analysed.
    ``G_max`` is the tangent shear modulus of ``point`` condensed with the path's control
    (``sigma_zz`` free at constant normal stress; plain ``C_55`` at constant volume).

    Parameters
    ----------
    constant : {"stress", "volume"}
        Constant normal stress ``sigma_zz`` (default) or constant volume (every other
        strain component held; see :func:`grainmech.driver.cyclic_simple_shear`).
    progress : callable ``(index, amplitude, path)``, optional
        Called before each amplitude is run.
    raise_on_failure : bool
        If False, a failed amplitude is recorded and the others still run (each from
        ``point``); the result has ``success`` False and a ``message`` naming every failed
        amplitude (:func:`grainmech.driver.loop.cyclic_series`).
    on_amplitude : callable ``(ModulusReduction)``, optional
        Called after each completed amplitude with the series so far (what an
        interrupted run can still report).
    runner : callable ``(point, path, **run_options) -> DriverResult``, optional
        What runs each amplitude's path; default :func:`run` (the caller's own reference
        to it: ``grainmech.jobs`` passes the ``grainmech.driver.run`` it imported).
    on_stop : callable ``(amplitude, message)``, optional
        Called when an amplitude fails (with ``raise_on_failure`` False), as it fails.

    Raises
    ------
    GrainmechError
        If a run fails and ``raise_on_failure`` (its message is passed on).
    """
    run_path = run if runner is None else runner
    return cyclic_series(lambda path: run_path(point, path, **run_options), amplitudes,
                         lambda path: condensed_modulus(point.tangent, 4, path.stress_control[0]),
                         n_cycles=n_cycles, steps_per_cycle=steps_per_cycle, waveform=waveform, constant=constant,
                         progress=progress, raise_on_failure=raise_on_failure, on_amplitude=on_amplitude,
                         on_stop=on_stop)

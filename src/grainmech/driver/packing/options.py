"""Options and shared small types of the packing driver (:mod:`grainmech.driver.packing`).

:class:`PackingOptions` and the status codes of a packing run, the law checks and
displacement scale of a contact (``law_scale``), and the step solver's failure and
per-run state (``SubstepFailure``, ``RunContext``): the pieces the point, the runner and the
step solver (:mod:`grainmech.driver.packing.step`) all use, so that none of them imports
another for them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainmech.contact.forms import normal_law
from grainmech.driver.packing._operators import (
    Preconditioner,
)
from grainmech.errors import ParameterError

#: largest grain residual (over the mean contact force) that ``PackingOptions.accept_unbalanced``
#: accepts: the bar of "every accepted step in equilibrium" of the packing driver's checks
ACCEPT_MAX_FORCE = 0.05

#: status codes of :class:`PackingResult`
STATUS_DONE, STATUS_FAILED, STATUS_SMALL_STRAIN = 0, 1, 2


# --------------------------------------------------------------------------- options

@dataclass(frozen=True)
class PackingOptions:
    """Options of the packing driver.

    Attributes
    ----------
    rtol : float
        Equilibrium tolerance: every grain's out-of-balance force ``|F_p|`` and moment
        ``|M_p|/R_p`` at most ``rtol`` times the mean contact force, and every
        stress-controlled component within ``rtol`` times the stress scale of the step.
    rtol_accept, rtol_step : float
        A (sub)step whose iterations stall (at a kink of the contact laws, a few weak
        grains on a mechanism) is accepted when the uncertainty its out-of-balance
        forces and moments leave in the Love-Weber stress, ``sum_p (|F_p| R_p + |M_p|) / V``,
        is below ``rtol_accept`` times the stress scale (the largest stress component)
        or below ``rtol_step`` times the step's stress change (the affine elastic
        response to its strain increment, or the change of its stress targets), and
        every stress-controlled component is within the same bound.
        The imbalance left is not lost: the next step starts from it. ``rtol_step = 0``:
        the stress scale alone (on a 500-grain DEM packing at γ = 3e-4 that stopped the
        run at a contact at touch whose uncertainty was ~3 Pa against a 40 kPa shear
        amplitude, see ``docs/models/packing.md``).
    accept_unbalanced : float
        A (sub)step whose iterations stall is also accepted when the packing is at rest by
        a DEM's measure: the mean unbalanced force ratio (:func:`unbalanced_force_ratio`,
        mean over grains of the out-of-balance force and moment over the mean contact
        force) is at most this, the largest grain's at most ``ACCEPT_MAX_FORCE = 0.05`` of
        the mean contact force, and every stress-controlled component within the stress
        bound above. The default ``1e-4`` is the DEM model's own criterion
        (:class:`grainmech.driver.dem.DemSettings` ``tol``; a DEM packing is taken as
        static below 1e-4 … 1e-5, the shipped ones were made to 2e-5), so a step the
        packing model accepts is at least as balanced as one the DEM model records.
        ``0``: off (only the stress-uncertainty tests above). On the shipped 'medium'
        packing at 1e-4 and constant volume, steps stalled at a mean ratio of 2e-5 … 1e-4
        with a few contacts sliding on each of many grains (a fixed geometry cannot
        rearrange them); with ``0`` the run was still halving a step after 34 min, with
        ``1e-4`` it completed (``docs/models/packing.md``).
    rest_step : float
        Acceptance at rest (``accept_unbalanced``) also asks that the stress uncertainty
        the out-of-balance forces leave is at most this fraction of the step's stress
        change (the affine elastic response to its strain increment, or the change of its
        stress targets): at rest by the DEM's measure is not at rest against a step of a
        small-amplitude loop. ``inf``: no such bound.
    max_iter : int
        Newton iterations per (sub)step.
    max_depth : int
        Halvings of a step that does not converge (2**max_depth substeps at most).
    max_backtracks : int
        Halvings of the Newton update in the line search.
    krylov_rtol : float
        Relative tolerance of GMRES on the Newton system (inexact Newton).
    krylov_max : int
        GMRES iterations per Newton iteration.
    refactor_after : int
        Refactor the elastic preconditioner at the next step when GMRES needed more
        iterations than this.
    relax_depth : int or None
        A substep that still does not converge after this many halvings (at most
        ``max_depth``) is solved by
        committed relaxation (overdamped pseudo-time stepping whose every update is
        committed to the contact laws' history, as a quasi-static DEM relaxes; see
        ``docs/models/packing.md``); ``None``: never, the step fails after ``max_depth``
        halvings.
    relax_iter : int
        Updates of one committed relaxation.
    max_fluctuation : float
        Small-strain bound: stop (status 2) when a grain's displacement fluctuation
        (rigid translation removed) exceeds this fraction of its radius.
    max_strain : float
        Small-strain bound: stop (status 2) when a strain component exceeds this.
    tangent : {"none", "start", "ends", "every"}
        Steps whose relaxed 6x6 tangent is computed (``DriverResult.tangent``; ``"start"``
        is the initial state, ``"ends"`` also the last); rows not computed are NaN.
        Each costs six GMRES solves (about a second for 2000 grains).
    factorization : {"auto", "pardiso", "cholespy", "superlu"}
        Factorisation of the elastic operator: Intel MKL PARDISO (``pypardiso``, optional),
        sparse Cholesky (``cholespy``, optional) or SciPy's SuperLU; ``auto`` takes the
        first installed in that order (PARDISO: 0.2-0.5 s to factor the 11 673-unknown
        operator of ``benchmarks/bench_packing_driver.py`` and 10.3 ms per solve on one
        thread, 6.6 ms on two (see ``reproducible``), cholespy 3.5-4.5 s and 11-13 ms,
        SuperLU 7.4 s and 37 ms; measured on different days, the machine's speed varies).
    law_backend : str or None
        ``backend`` passed to :func:`grainmech.contact.update` (``None``: its default).
    regularization : float
        Shift of the factorised elastic operator, relative to its diagonal:
        ``M = H0 + regularization diag(H0)``. It bounds the update of a grain on a
        near-floppy mode (a grain held by two or three weak contacts: ``dx ~ r / (reg
        diag)``, an implicit step of damped dynamics on that mode, as the shift of
        pseudo-transient continuation) and leaves the stiff modes alone; it changes how
        the iterations get to equilibrium, not the equilibrium (the residual is always the
        laws'). The elastic tangent (``G_max``) is solved to 1e-10 with the unshifted
        operator whatever this is. On the shipped 'medium' packing at γ = 1e-5 the
        default 1e-4 let 80 steps finish where 1e-10 stopped at step 21
        (``docs/models/packing.md``).
    reproducible : bool
        PARDISO factorises (and then solves) on one thread, so that the same input gives
        the same run (default). ``False``: on every core, ~1.5x faster solves, but its
        round-off then depends on the thread schedule, and a path through many kinks of
        the contact laws (sliding, reversals) can take a different course (other
        accepted residuals, times of 51 s or 126 s for the same 500-grain run). Other
        factorisations are reproducible either way. PARDISO's factor is in single
        precision (a preconditioner, refined by CG where it must be exact): 3.2 ms per
        solve of the benchmark operator on one thread instead of 6.0 ms.
    anderson : int
        Every (sub)step of a frictional law is first solved by Anderson-accelerated
        elastic iterations with this many stored differences (one residual and one
        solve with the factor per iteration, no tangent of the laws, so the branch
        switches of the laws do not mislead them); where they stall, Newton-Krylov (with
        continuation, step halving and committed relaxation) goes on from their best
        point. ``0``: Newton-Krylov from the start. On the
        shipped 'dense' packing at γ = 1e-4 the first 20 steps took 10.3 s instead of
        47.0 s, with the same loop (``docs/models/packing.md``).
    settle : float
        The Anderson iterations of a (sub)step stop as soon as the stress uncertainty
        their out-of-balance forces leave (as for ``rtol_accept``/``rtol_step``) is below
        ``settle`` times that acceptance bound, and so is the stress change still to
        come, estimated from the contraction of the iterates' stress changes, even
        before every grain is within ``rtol`` (the stress-controlled components still
        within ``rtol``): most iterations polished forces that no longer moved the
        stress. ``0``: iterate to ``rtol``.
        On the built-in default run ('dense', 2 x 40 steps at 1e-6, 1e-5, 1e-4) the
        default 0.1 took 19.8 s instead of 45.4 s, with G/Gmax within 2.6e-5 and damping
        within 0.0016 % (absolute) of iterating to ``rtol`` (``docs/models/packing.md``).
        On looser packings at 1e-4 (shipped 'medium'), where the fixed geometry is near
        its limit, whether a run completes can depend on round-off with either setting;
        if a run on a loose packing stops, try ``settle=0``.
    max_step_work : int
        Budget of one step of the path (all its substeps together), in residual
        evaluations plus GMRES iterations (about one contact-law update or one solve with
        the factorised operator each; ``PackingResult.cost`` reports what each step
        used). A step that spends it stops the run (status 1) with the step, the
        out-of-balance measures reached and the results so far: where a fixed geometry has
        no equilibrium (grains that would roll off and rearrange in a DEM), halving and
        committed relaxation otherwise crawl on for tens of minutes. The default is set
        from the measurements in ``docs/models/packing.md`` ("Step budget").
    """

    rtol: float = 1e-8
    rtol_accept: float = 1e-5
    rtol_step: float = 1e-3
    accept_unbalanced: float = 1e-4
    rest_step: float = 0.01
    max_iter: int = 25
    max_depth: int = 6
    max_backtracks: int = 8
    krylov_rtol: float = 1e-3
    krylov_max: int = 60
    refactor_after: int = 25
    relax_depth: int | None = 0
    relax_iter: int = 100
    max_fluctuation: float = 0.05
    max_strain: float = 0.02
    tangent: str = "ends"
    factorization: str = "auto"
    law_backend: str | None = "numpy"
    regularization: float = 1e-4
    reproducible: bool = True
    anderson: int = 10
    settle: float = 0.1
    max_step_work: int = 50000

    def __post_init__(self) -> None:
        if not (0 < self.rtol < 1e-2):
            raise ParameterError("rtol", self.rtol, "must lie in (0, 1e-2)")
        if not (self.rtol <= self.rtol_accept < 1e-2):
            raise ParameterError("rtol_accept", self.rtol_accept, "must lie in [rtol, 1e-2)")
        if not (isinstance(self.accept_unbalanced, (int, float)) and 0 <= self.accept_unbalanced <= 1e-2):
            raise ParameterError("accept_unbalanced", self.accept_unbalanced, "must lie in [0, 0.01]")
        if isinstance(self.rest_step, bool) or not (isinstance(self.rest_step, (int, float)) and self.rest_step > 0):
            raise ParameterError("rest_step", self.rest_step, "must be a positive number (inf: no bound)")
        if not (isinstance(self.rtol_step, (int, float)) and 0 <= self.rtol_step < 0.1):
            raise ParameterError("rtol_step", self.rtol_step, "must lie in [0, 0.1)")
        for name in ("max_iter", "krylov_max", "refactor_after", "relax_iter"):
            if int(getattr(self, name)) < 1:
                raise ParameterError(name, getattr(self, name), "must be >= 1")
        for name in ("max_depth", "max_backtracks"):
            if not (0 <= int(getattr(self, name)) <= 30):
                raise ParameterError(name, getattr(self, name), "must lie in [0, 30]")
        if self.relax_depth is not None and not (0 <= int(self.relax_depth) <= 30):
            raise ParameterError("relax_depth", self.relax_depth, "must be None or lie in [0, 30]")
        if not (0 < self.krylov_rtol < 1):
            raise ParameterError("krylov_rtol", self.krylov_rtol, "must lie in (0, 1)")
        if not (self.max_fluctuation > 0 and self.max_strain > 0):
            raise ParameterError("max_fluctuation/max_strain", (self.max_fluctuation, self.max_strain),
                              "must be positive")
        if self.tangent not in ("none", "start", "ends", "every"):
            raise ParameterError("tangent", self.tangent, "must be 'none', 'start', 'ends' or 'every'")
        if self.factorization not in ("auto", "pardiso", "cholespy", "superlu"):
            raise ParameterError("factorization", self.factorization,
                                 "must be 'auto', 'pardiso', 'cholespy' or 'superlu'")
        if not (isinstance(self.regularization, (int, float)) and 1e-12 <= self.regularization <= 1e-2):
            raise ParameterError("regularization", self.regularization, "must lie in [1e-12, 1e-2]")
        if not isinstance(self.reproducible, bool):
            raise ParameterError("reproducible", self.reproducible, "must be True or False")
        if isinstance(self.anderson, bool) or not isinstance(self.anderson, int) or not 0 <= self.anderson <= 50:
            raise ParameterError("anderson", self.anderson, "must be an integer in [0, 50]")
        if isinstance(self.settle, bool) or not isinstance(self.settle, (int, float)) or not 0 <= self.settle <= 1:
            raise ParameterError("settle", self.settle, "must be a number in [0, 1]")
        if isinstance(self.max_step_work, bool) or not isinstance(self.max_step_work, int) or self.max_step_work < 100:
            raise ParameterError("max_step_work", self.max_step_work, "must be an integer >= 100")


def law_scale(params: object, Rs: np.ndarray) -> np.ndarray:
    """Displacement scale ``s_c = (R*_c / R*_law)^(1/3)`` of a Hertz-type law (1 for springs).

    Hertz (seed Eq. 3.6) ``N = (4/3) E* R*^(1/2) alpha^(3/2)`` and Mindlin's
    ``dT = 8 G* a d delta`` with ``a = (R* alpha)^(1/2)`` (seed Eq. 3.5, 3.11) give the same
    forces for a contact of radius ``R*`` at displacements ``(alpha, delta)`` as for the
    law's radius ``R*_law`` at ``(s alpha, s delta)``; the stiffnesses are ``s`` times the
    law's and the dissipated energy ``1/s`` times. So one parameter object serves every
    contact of a polydisperse packing.
    """
    if normal_law(params) == "linear":
        return np.ones_like(Rs)
    return np.cbrt(Rs / params.effective_radius)  # type: ignore[attr-defined]


def check_law_params(params: object) -> None:
    """Raise :class:`~grainmech.errors.ParameterError` unless ``params`` is a sphere law (Hertz-type or linear)."""
    if normal_law(params) not in ("hertz", "linear"):
        raise ParameterError("params", type(params).__name__,
                             "the packing driver needs a sphere law: Hertz, HertzMindlin, MindlinDeresiewicz "
                             "or LinearSpring")


def law_options(backend: str | None) -> dict:
    """Keyword arguments of :func:`grainmech.contact.update` for the law backend ``backend`` (None: its default)."""
    return {} if backend is None else {"backend": backend}


# --------------------------------------------------------------------------- step solver

class SubstepFailure(Exception):
    """A (sub)step that did not converge, with its ``cause``: step halving retries it (``step.subdivided``)."""

    def __init__(self, cause: str) -> None:
        super().__init__(cause)
        self.cause = cause


class OutOfBudget(Exception):
    """A step spent ``PackingOptions.max_step_work`` (not a :class:`SubstepFailure`: no halving retries it)."""

    def __init__(self, cause: str) -> None:
        super().__init__(cause)
        self.cause = cause


@dataclass
class RunContext:
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
    evals: int = 0  # residual evaluations
    budget: int = 0  # evals + krylov at which the current step is out of budget (0: none)
    worst: str = ""  # out-of-balance measures of the last residual evaluated, for the budget message

    @property
    def work(self) -> int:
        """Residual evaluations plus GMRES iterations so far (``PackingOptions.max_step_work``)."""
        return self.evals + self.krylov

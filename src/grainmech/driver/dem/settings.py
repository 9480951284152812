"""Settings of the DEM model and the LAMMPS grain material of a contact law.

:class:`DemSettings` (what makes the DEM model quasi-static: ramp, relaxation damping and
criteria, servo, liquefaction, MPI ranks) and :func:`dem_material` (the grains LAMMPS'
granular model runs for a grainmech contact law). Both are exported by
:mod:`grainmech.driver.dem`, where the model is described.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from grainmech.contact.forms import law_forms
from grainmech.errors import GrainmechError, ParameterError
from grainmech.lammps.granular import GrainMaterial

__all__ = ["AUTO_CONTINUOUS_STRAIN", "DAMPINGS", "DEFAULT_DENSITY", "PROTOCOLS", "DemSettings", "dem_material"]

#: grain density used when the contact law gives none [kg/m^3] (quartz); a quasi-static
#: run's equilibria do not depend on it (it sets the time step and the drags only)
DEFAULT_DENSITY = 2650.0
#: the relaxation's dampings (:attr:`DemSettings.damping`)
DAMPINGS = ("viscous", "kinetic", "cundall")
#: how a path is loaded (:attr:`DemSettings.protocol`)
PROTOCOLS = ("relax", "continuous", "auto")
#: ``protocol = "auto"``: a path is sheared continuously when it is monotonic and reaches
#: this strain (a drained triaxial test to failure, where every relaxation of a flowing
#: packing costs ~1e5 time steps), by step and relax otherwise (every cyclic amplitude:
#: continuous shearing at 1e-3 and 1e-2 gave secant moduli 6 % and 15 % above step and
#: relax on 'dense', beyond the 2 % the choice must hold; ``docs/models/dem.md``)
AUTO_CONTINUOUS_STRAIN = 1e-2


#: least pore-pressure ratio :attr:`DemSettings.liquefaction` may name
LIQUEFACTION_MIN = 0.5


def _cores() -> tuple[int, str]:
    n = os.cpu_count() or 1
    return n, f"the {n} cores of this machine; pair_style granular has no threaded variant"


#: largest value of each count of :class:`DemSettings` and why: the time a run may take
#: (LAMMPS does some 1e4-1e5 time steps a second on a few thousand grains) and the machine
_COUNT_BOUNDS: dict = {
    "ramp_steps": (1_000_000, "time steps per increment: beyond, one cycle takes hours"),
    "chunk": (1_000_000, "time steps between two checks of a relaxation"),
    "max_relax_steps": (100_000_000, "time steps of one relaxation: beyond, one step takes days"),
    "max_corrections": (1000, "servo corrections of one step"),
    "max_substeps": (10_000, "substeps of one step"),
    "threads": _cores,
    "ranks": (65_536, "MPI ranks of one path"),
    "servo_interval": (1_000_000, "time steps between two servo corrections of a continuous path"),
    "min_flow_steps": (10_000_000, "time steps of one increment of a continuous path"),
}
#: range of each ratio of :class:`DemSettings` and why
_RATIO_BOUNDS: dict = {
    # the drag's damping ratio is viscous / 2: above critical damping it only slows the relaxation,
    # and far above it the explicit integration of the drag is unstable (lost atoms)
    "viscous": (1e-6, 2.0, "a fraction of the contact frequency; 2 is critical damping"),
    # below ~1e-10 the round-off of the force sums keeps the ratio from ever getting there
    "tol": (1e-10, 1.0, "an unbalanced force ratio; below 1e-10 round-off keeps a packing from reaching it"),
    "settle": (1e-10, 1.0, "a ratio of stress changes"),
    # velocity Verlet is stable for dt < 2 / omega_max; a grain pressed by ~6 contacts whose
    # tangential springs also turn it has omega_max ~ 6 sqrt(kn / m), so dt < ~0.3 sqrt(m / kn)
    "safety": (1e-3, 0.3, "a fraction of sqrt(m / kn): above 0.3 the integration of a grain held by several "
                          "contacts is unstable (lost atoms)"),
    "stress_tol": (1e-6, 1.0, "relative to the step's stress change"),
    "max_ramp_strain": (1e-9, 1e-3, "strain per time step: below 1e-9 an increment of 2.5e-4 (1e-3 in "
                                    "16 steps per cycle) is ramped over more than 2.5e5 time steps"),
    "max_stress_step": (1e-4, 1.0, "a fraction of the mean stress"),
    "wave_crossings": (1e-3, 1e3, "shear-wave crossing times of the cell per increment"),
    # GDR MiDi (2004): I < ~1e-3 is quasi-static; 1e-6 makes a 1e-2 cycle take ~1e8 time steps
    "inertial_number": (1e-6, 0.1, "the inertial number I = rate d sqrt(rho / p) of continuous shearing; "
                                   "quasi-static below ~1e-3 (GDR MiDi 2004), days of LAMMPS below 1e-6"),
}


@dataclass(frozen=True)
class DemSettings:
    """Numerical settings of the DEM model (what makes it quasi-static).

    Parameters
    ----------
    ramp_steps : int
        Time steps over which each strain increment is applied (affine velocity field).
    viscous : float
        Drag on grain velocities and spins, as a fraction of the contact frequency at the
        packing's stress (``fix viscous`` / ``viscous/sphere``), during relaxation with
        ``damping = "viscous"`` only.
    tol : float
        Unbalanced force ratio (mean out-of-balance force and moment over the mean contact
        force) every recorded state must reach.
    settle : float
        Stress criterion of a relaxation: the Love-Weber stress changes over one chunk by
        less than ``settle`` times its change since the step began.
    chunk : int
        Time steps between two checks of the criteria.
    max_relax_steps : int
        Budget of one relaxation; a step that does not reach equilibrium within it fails.
    safety : float
        Time step as a fraction of the critical one (:func:`grainmech.lammps.granular.critical_time_step`).
    stress_tol : float
        Servo tolerance of the stress-controlled components, relative to the step's
        stress change (at least ``1e-3`` of the mean stress).
    max_corrections : int
        Servo corrections per step before it fails.
    max_stress_step : float
        Largest stress change a substep is predicted to make, as a fraction of the mean
        stress; a step predicted to change more is split (large-strain paths).
    max_substeps : int
        Most substeps of one step.
    max_ramp_strain : float
        Largest strain per time step during a ramp: a larger increment is ramped over
        more than ``ramp_steps`` steps (large-strain paths, amplitudes of 1e-2).
    threads : int
        OpenMP threads of LAMMPS (``pair_style granular`` has no threaded variant; 1 leaves
        the other cores to the rest of the run).
    damping : {"viscous", "kinetic", "cundall"}
        How the grains relax between recorded states: ``"viscous"`` drags (``viscous``,
        ``fix viscous`` / ``viscous/sphere``), ``"kinetic"`` damping (no damping force; all
        velocities and spins are set to zero whenever the power of the forces turns
        negative, :meth:`grainmech.lammps.session.Session.advance`) or Cundall's local
        damping (``cundall``, LAMMPS ``fix damping/cundall``). On 'dense' the drags and
        kinetic damping record the same cycles to 0.2 % at 1e-4 and 1e-3; kinetic damping
        comes to rest where the drags leave a loose packing's stress creeping and takes
        fewer time steps at large strain; at 1e-2 one run of a 2000-grain packing scatters
        by about 2.5 % in G (a 1e-9 R perturbation of the start suffices), and the settings
        move the mean of 6 perturbed runs by at most 1.4 % (``docs/models/dem.md``).
    cundall : float
        Cundall's local damping coefficient in (0, 1), used with ``damping = "cundall"``.
    fallback : bool
        With ``damping = "viscous"`` or ``"cundall"``: a relaxation that has not reached
        equilibrium after ``max_relax_steps`` goes on under kinetic damping for up to
        ``max_relax_steps`` more time steps before the step fails; the next ramp has the
        drags again. Where the drags hold a loose packing's soft modes creeping (1e-2 on
        'medium', 1e-3 at constant volume on 'loose'), kinetic damping brings it to rest;
        where the drags come to rest the run is unchanged. The run's notes count these
        relaxations.
    liquefaction : float
        Pore-pressure ratio ``r_u = 1 - p / p0`` at which the path ends as liquefied
        (:attr:`~grainmech.driver.base.Status.LIQUEFIED`): a recorded state whose mean stress
        is at most ``(1 - liquefaction) p0``, or a relaxation that runs out of its budget with
        the mean stress that low (the grains hold no load-bearing network at that volume, so
        there is no equilibrium with contacts to reach). 0.95, the usual criterion of initial
        liquefaction in cyclic undrained tests (e.g. Ishihara 1993).
    ranks : int
        MPI ranks of each DEM path: above 1, the path runs as an ``mpiexec -n ranks`` job
        with LAMMPS' domain decomposition (:mod:`grainmech.driver.dem.mpi`), for packings
        too large for one core.
    protocol : {"relax", "continuous", "auto"}
        How a path is loaded: ``"relax"`` (step and relax: every recorded state an
        equilibrium, the settings above), ``"continuous"`` (the cell sheared without
        stopping at the rate of ``inertial_number``, the stress-controlled components held
        by a servo every ``servo_interval`` time steps; every recorded state a state of the
        flow with its unbalanced force ratio and inertial number;
        :mod:`grainmech.driver.dem.flow`) or ``"auto"`` (per path: continuous for a
        monotonic path reaching :data:`AUTO_CONTINUOUS_STRAIN`, step and relax otherwise;
        the run's notes say which ran and why).
    inertial_number : float
        Target inertial number ``I = rate d sqrt(rho_s / p)`` of the continuous protocol
        (GDR MiDi 2004): the largest strain rate of a path at the mean stress of each
        increment's start.
    servo_interval : int
        Time steps between two servo corrections of the continuous protocol.
    min_flow_steps : int
        Fewest time steps of an increment of the continuous protocol.
    wave_crossings : float
        Shortest duration of an increment of the continuous protocol, in shear-wave crossing
        times of the cell (``L_max / v_s``, ``v_s = sqrt(G_max / rho)`` of the start
        state): an increment applied faster than the packing can transmit it is not
        quasi-static however small the inertial number (a cycle of 1e-5 on 'dense' in
        increments of 50 time steps, 0.07 crossing times, gave a secant G 6 % below
        G_max). Small amplitudes are then set by this bound, large ones by the inertial
        number.
    """

    ramp_steps: int = 400
    viscous: float = 0.3
    tol: float = 1e-4
    settle: float = 1e-3
    chunk: int = 250
    max_relax_steps: int = 200_000
    safety: float = 0.1
    stress_tol: float = 0.05
    max_corrections: int = 20
    max_ramp_strain: float = 1e-6
    max_stress_step: float = 0.25
    max_substeps: int = 50
    threads: int = 1
    damping: str = "viscous"
    cundall: float = 0.7
    fallback: bool = True
    liquefaction: float = 0.95
    ranks: int = 1
    protocol: str = "relax"
    inertial_number: float = 1e-3
    servo_interval: int = 50
    min_flow_steps: int = 50
    wave_crossings: float = 2.0

    def __post_init__(self) -> None:
        for k in ("ramp_steps", "chunk", "max_relax_steps", "max_corrections", "threads", "max_substeps", "ranks",
                  "servo_interval", "min_flow_steps"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ParameterError(k, v, "must be an integer >= 1")
            hi, why = _COUNT_BOUNDS[k]() if k == "threads" else _COUNT_BOUNDS[k]
            if v > hi:
                raise ParameterError(k, v, f"must be <= {hi:.0f} ({why})")
        for k in ("viscous", "tol", "settle", "safety", "stress_tol", "max_ramp_strain", "max_stress_step",
                  "inertial_number", "wave_crossings"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(k, v, "must be a finite number > 0")
            lo, hi, why = _RATIO_BOUNDS[k]
            if not lo <= v <= hi:
                raise ParameterError(k, v, f"must lie in [{lo:g}, {hi:g}] ({why})")
        if self.chunk > self.max_relax_steps:
            raise ParameterError("chunk", self.chunk, f"must be <= max_relax_steps = {self.max_relax_steps} (the "
                                 "criteria are checked every chunk time steps of a relaxation)")
        if self.protocol not in PROTOCOLS:
            raise ParameterError("protocol", self.protocol, f"must be one of {', '.join(PROTOCOLS)}")
        if self.damping not in DAMPINGS:
            raise ParameterError("damping", self.damping, f"must be one of {', '.join(DAMPINGS)}")
        if not isinstance(self.fallback, (bool, np.bool_)):
            raise ParameterError("fallback", self.fallback, "must be true or false")
        if not (isinstance(self.cundall, (int, float)) and 0 < self.cundall < 1):
            raise ParameterError("cundall", self.cundall, "must be a number in (0, 1)")
        if not (isinstance(self.liquefaction, (int, float)) and LIQUEFACTION_MIN <= self.liquefaction <= 1):
            raise ParameterError("liquefaction", self.liquefaction, f"must be a pore-pressure ratio r_u in "
                                 f"[{LIQUEFACTION_MIN:g}, 1]: the ratio at which the test counts as liquefied "
                                 "(0.95 usual); below 0.5 the grains still carry more than half the mean stress")

    def for_path(self, path: Any) -> tuple[DemSettings, str | None]:
        """The settings a path runs with (``protocol = "auto"`` resolved) and the note saying why.

        ``path`` is a :class:`~grainmech.driver.paths.LoadPath`; its strain excursion is the
        largest cumulative strain component of its strain-controlled increments, and it is
        monotonic when no strain-controlled component reverses.
        """
        if self.protocol != "auto":
            return self, None
        inc = np.where(np.asarray(path.stress_control, bool), 0.0, np.asarray(path.increment, float))
        total = np.cumsum(inc, axis=0)
        reach = float(np.abs(total).max(initial=0.0))
        monotonic = bool(np.all((inc >= 0).all(axis=0) | (inc <= 0).all(axis=0)))
        if monotonic and reach >= AUTO_CONTINUOUS_STRAIN:
            return replace(self, protocol="continuous"), (
                f"protocol auto: continuous shearing (a monotonic path to a strain of {reach:.3g}, at least "
                f"{AUTO_CONTINUOUS_STRAIN:g})")
        return replace(self, protocol="relax"), (
            f"protocol auto: step and relax ({'a cyclic path' if not monotonic else 'a path'} reaching a strain of "
            f"{reach:.3g}; continuous shearing is chosen for monotonic paths from {AUTO_CONTINUOUS_STRAIN:g})")

    def as_dict(self) -> dict:
        """The settings as a JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def dem_material(law: Any) -> tuple[GrainMaterial, list[str]]:
    """The LAMMPS grain material of a grainmech contact law, and notes on what runs.

    Hertz-Mindlin and Mindlin-Deresiewicz laws give the grain shear modulus, Poisson's
    ratio and friction; LAMMPS runs Hertz normal + Mindlin no-slip tangential spring with a
    Coulomb cap for both (it has no Mindlin-Deresiewicz micro-slip law: said in the notes).

    Raises
    ------
    GrainmechError
        For a law LAMMPS' granular model cannot stand for (linear springs, cylinders) or
        a frictionless one.
    """
    try:
        forms = law_forms(law)
    except TypeError:
        forms = None
    name = type(law).__name__
    if forms is None or not forms.spheres:
        raise GrainmechError(f"contacts.law = {name}: the DEM model runs LAMMPS' granular model (Hertz spheres); "
                             "use 'hertz-mindlin' or 'mindlin-deresiewicz'")
    mu = float(getattr(law, "friction", 0.0) or 0.0)
    if not (forms.kind in ("md", "jenkins") and 0 < mu < math.inf):
        raise GrainmechError(f"contacts.law = {name} (friction {mu:g}): the DEM model needs a frictional "
                             "Hertz-Mindlin law (contacts.law = 'hertz-mindlin' or 'mindlin-deresiewicz' with "
                             "contacts.friction > 0)")
    mat = GrainMaterial("grains", float(law.shear_modulus), float(law.poisson), DEFAULT_DENSITY, mu)
    notes = ["LAMMPS pair_style granular: Hertz normal force, Mindlin no-slip tangential spring k_t = 8 G* a "
             f"with a Coulomb cap (friction {mu:g}), grain shear modulus {mat.shear_modulus:.4g} Pa, Poisson "
             f"{mat.poisson:g}"]
    if forms.kind == "md":
        notes.append("the config asks for Mindlin-Deresiewicz contacts; LAMMPS has no counterpart (no micro-slip "
                     "below the Coulomb limit), so the DEM model ran the Hertz-Mindlin law above: its damping at "
                     "small strains comes from full sliding only")
    return mat, notes

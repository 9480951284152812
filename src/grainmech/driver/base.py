"""The contract every kinematic model of grainmech keeps (affine, packing, dem).

A *material point* of any model has a state — ``stress`` and ``strain`` (Voigt order
``xx yy zz yz xz xy``, compression positive, engineering shear strains; see
``docs/conventions.md``) — and answers the tangent, the sliding/open fractions and the
stored energy. It advances by ``step(d_strain, stress_control, target)``: the
strain-controlled components (``stress_control`` False) change by ``d_strain``, the
stress-controlled ones reach ``target``. A step that cannot be solved raises
:class:`StepFailure` with a :class:`Status` code and a cause; the path loop
(:func:`grainmech.driver.loop.follow_path`) turns it into a :class:`DriverResult` with
``success`` False and every state before it kept.

The affine model (:class:`grainmech.driver.MaterialPoint`) and the packing model
(:class:`grainmech.driver.packing.PackingPoint`) are immutable values; the affine model
has compiled whole-path loops (its fast path in :func:`grainmech.driver.run`), and its
step-by-step run, the packing model's (:func:`grainmech.driver.packing.run_packing`)
and the DEM model's (:class:`grainmech.driver.dem.DemPoint`, a live LAMMPS simulation
that moves forward only) go through :func:`grainmech.driver.loop.follow_path`. All three return a
:class:`DriverResult` (the packing and DEM models a subclass with their own per-step
columns), and :func:`grainmech.driver.loop.cyclic_series` analyses any of them.

Above the point, a model is a :class:`KinematicModel`: its name, what it needs from a
config, its series and its path, the details it reports and whether it hands amplitudes
over to another model (:class:`HandOver`). One entry per model is registered in
:mod:`grainmech.driver.registry`; the jobs dispatch through it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Protocol, runtime_checkable

import numpy as np

from grainmech.errors import GrainmechError

__all__ = ["Status", "StepFailure", "Point", "SteppingPoint", "PointStepping", "DriverResult", "KinematicModel",
           "HandOver"]


class Status(IntEnum):
    """Status codes of a :class:`DriverResult` (one set for every model)."""

    DONE = 0
    #: a step found no state that meets its targets (no equilibrium, stress target unreachable)
    FAILED = 1
    #: the model left the range it is valid in (small strain, fixed geometry)
    OUT_OF_RANGE = 2
    #: the user or the system stopped the run (Ctrl-C, SIGTERM)
    INTERRUPTED = 3
    #: the packing lost its mean stress (DEM model, constant volume): the grains hold no
    #: load-bearing network at that volume, the test's answer rather than a numerical failure
    LIQUEFIED = 4


class StepFailure(GrainmechError):
    """A step of a path could not be solved.

    Parameters
    ----------
    cause : str
        What went wrong, in words a user reads (the path loop prefixes the step).
    status : Status
        :attr:`Status.FAILED` (default), :attr:`Status.OUT_OF_RANGE` or :attr:`Status.LIQUEFIED`.
    """

    def __init__(self, cause: str, status: Status = Status.FAILED) -> None:
        super().__init__(cause)
        self.cause = cause
        self.status = Status(status)


@runtime_checkable
class Point(Protocol):
    """What every model's state answers (read-only part of the contract)."""

    @property
    def stress(self) -> np.ndarray:
        """Stress (6,) [Pa], Voigt, compression positive."""

    @property
    def strain(self) -> np.ndarray:
        """Strain (6,) [-], Voigt, compression positive, engineering shears."""

    def fractions(self) -> tuple[float, float]:
        """Sliding and open fractions of the contacts."""

    def stored_energy(self) -> float:
        """Elastic energy per unit volume held by the contacts [Pa]."""


@runtime_checkable
class SteppingPoint(Point, Protocol):
    """A point that advances one mixed-control step at a time (the DEM model)."""

    def step(self, d_strain: np.ndarray, stress_control: np.ndarray, target: np.ndarray) -> SteppingPoint:
        """Advance one step; raise :class:`StepFailure` when it cannot."""


class PointStepping:
    """Mixin of a :class:`SteppingPoint` that wraps a model's point (attribute ``point``) with its run's state.

    The read-only part of the contract (``stress``, ``strain``, ``fractions``,
    ``stored_energy``) is the wrapped point's; the subclass adds ``step`` (the affine and
    packing models' steppers of :func:`grainmech.driver.loop.follow_path`).
    """

    point: Any

    @property
    def stress(self) -> np.ndarray:
        """The wrapped point's stress (6,) [Pa]."""
        return self.point.stress

    @property
    def strain(self) -> np.ndarray:
        """The wrapped point's strain (6,) [-]."""
        return self.point.strain

    def fractions(self) -> tuple[float, float]:
        """The wrapped point's sliding and open fractions."""
        return self.point.fractions()

    def stored_energy(self) -> float:
        """The wrapped point's stored elastic energy per unit volume [Pa]."""
        return self.point.stored_energy()


@dataclass(frozen=True)
class DriverResult:
    """Everything computed along a path; row 0 is the initial state.

    Attributes
    ----------
    success : bool
    status : int
        A :class:`Status` code: 0 done, 1 a step failed, 2 the model's range left,
        3 interrupted.
    message : str
    strain : (k+1, 6) total strain, engineering shear, compression positive
    stress : (k+1, 6) stress [force/length^2]
    tangent : (k+1, 6, 6) Voigt tangent stiffness
    sliding_fraction, open_fraction : (k+1,) weighted fractions of contacts
    dissipation : (k+1,) cumulative dissipated energy per unit volume
    work : (k+1,) cumulative work ``int sigma . d eps`` per unit volume (trapezoidal)
    stored : (k+1,) elastic energy per unit volume held by the contacts (law's estimate)
    substeps, iterations : (k+1,) int, per step
    engineering : dict of name -> (k+1,) arrays, if requested
    final : Point
        Last converged state (restart from it; the DEM model's is a summary, not a live engine).
    n_steps : int
        Steps requested.
    """

    success: bool
    status: int
    message: str
    strain: np.ndarray
    stress: np.ndarray
    tangent: np.ndarray
    sliding_fraction: np.ndarray
    open_fraction: np.ndarray
    dissipation: np.ndarray
    work: np.ndarray
    stored: np.ndarray
    substeps: np.ndarray
    iterations: np.ndarray
    final: Any = field(repr=False)
    n_steps: int = 0
    engineering: dict = field(default_factory=dict, repr=False)


@runtime_checkable
class KinematicModel(Protocol):
    """What the jobs know of a kinematic model (one registered instance per model).

    Attributes
    ----------
    name : str
        The model's name in a config (``[model] method``) and in every output.
    title : str
        The model in a sentence (``"packing model"``).
    needs_grains : bool
        True: it runs on a packing of grains (``[model] packing`` or ``network``) with the
        grain law (the run's law for spheres); False: on the analytical microstructure
        (``[microstructure]``, ``[fabric]``), whose input warnings are then its own.
    settings_section : str or None
        Its own table ``[model.<settings_section>]``, if any.
    amplitudes_key, steps_per_cycle_key : str or None
        Its own ``[model]`` keys for the amplitudes and the steps per cycle of a cyclic
        test, if any (otherwise those of ``[test]``); the same names on the run's spec.
    max_amplitude : float
        Largest strain amplitude it takes.
    upper_bound : bool
        Every contact follows the mean strain: stiffer than the grains, it cannot fail; its
        states beyond the envelope of sands are not predictions, and it is a reference only
        beside models that are not.
    fixed_geometry : bool
        Every grain in equilibrium in a fixed reference geometry: where the grains would
        rearrange, or where it stops, its range ends and it hands the amplitudes over
        (:class:`HandOver`) to a model that ``takes_over``.
    takes_over : bool
        Contacts form and break, grains rearrange: it runs what a fixed-geometry model hands over.
    engine : str or None
        The external code its grains run in (``"LAMMPS"``), None when grainmech solves it.
    envelope_note : str
        How to read its states beyond the envelope of sands.
    """

    name: str
    title: str
    needs_grains: bool
    settings_section: str | None
    amplitudes_key: str | None
    steps_per_cycle_key: str | None
    max_amplitude: float
    upper_bound: bool
    fixed_geometry: bool
    takes_over: bool
    engine: str | None
    envelope_note: str

    def series(self, start: Any, amplitudes: Sequence[float], **options: Any) -> Any:
        """Cyclic simple shear at every amplitude from ``start`` (a :class:`~grainmech.analysis.ModulusReduction`)."""

    def path(self, start: Any, load_path: Any, **options: Any) -> DriverResult:
        """The run along a mixed-control path from ``start``."""

    def details(self, start: Any) -> dict:
        """What an outcome reports about the model's start state (grains, contacts, notes)."""


@dataclass(frozen=True)
class HandOver:
    """The amplitudes one model of a job leaves to the next, and why.

    Attributes
    ----------
    source : str
        The model that hands them over.
    amplitudes : tuple of float
        The amplitudes, in the source model's order.
    why : str
        The reason, in words a user reads.
    """

    source: str
    amplitudes: tuple[float, ...]
    why: str

    @property
    def note(self) -> str:
        """The sentence the receiving model's outcome carries."""
        listed = [float(f"{a:.3g}") for a in self.amplitudes]
        return f"amplitudes {listed} were handed over from the {self.source} model: {self.why}"

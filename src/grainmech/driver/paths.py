"""Loading paths for the material-point driver: control masks, segments, cycles, presets.

A path is a :class:`LoadPath`: one row per step, each with a per-component control mask
(True = stress controlled, False = strain controlled) and the *increment* of every
controlled component over that step. Components are in the library order
``(xx, yy, zz, yz, xz, xy)``; strains are engineering (``gamma = 2 eps``) shear strains,
compression positive (``docs/conventions.md``).

Targets do not drift: while a component keeps the same kind of control, the driver adds
the increments to an exact running target (not to the converged value); when the kind of
control switches, the running target restarts from the current value.

Readable masks such as ``"EESEEE"`` (E = strain, S = stress) are parsed only by
:func:`parse_mask`, at the edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from grainmech.errors import ParameterError

__all__ = [
    "Control",
    "parse_mask",
    "LoadPath",
    "segment",
    "cycles",
    "concatenate",
    "isotropic_compression",
    "triaxial",
    "constant_mean_stress",
    "fig610_path",
    "fig610_stress",
    "simple_shear",
    "cyclic_simple_shear",
    "cyclic_triaxial",
    "COMPONENTS",
    "PathTargets",
]

COMPONENTS = ("xx", "yy", "zz", "yz", "xz", "xy")


@dataclass(frozen=True)
class Control:
    """Per-component control kind (True = stress controlled), library order.

    Parameters
    ----------
    stress : tuple of 6 bool
    """

    stress: tuple[bool, ...]  # six entries, checked in __post_init__

    def __post_init__(self) -> None:
        s = tuple(bool(x) for x in self.stress)
        if len(s) != 6:
            raise ParameterError("control", self.stress, "must have 6 entries (xx, yy, zz, yz, xz, xy)")
        object.__setattr__(self, "stress", s)

    @property
    def array(self) -> np.ndarray:
        """The mask as a bool array, shape (6,) (True: stress-controlled)."""
        return np.array(self.stress, dtype=bool)

    @classmethod
    def all_strain(cls) -> Control:
        """Every component strain-controlled."""
        return cls((False,) * 6)

    @classmethod
    def all_stress(cls) -> Control:
        """Every component stress-controlled."""
        return cls((True,) * 6)

    def __str__(self) -> str:
        return "".join("S" if s else "E" for s in self.stress)


def parse_mask(text: str) -> Control:
    """Parse a readable mask, e.g. ``"EESEEE"`` (E strain, S stress; order xx..xy)."""
    t = str(text).strip().upper()
    if len(t) != 6 or any(c not in "ES" for c in t):
        raise ParameterError("control", text, "must be 6 letters E (strain) or S (stress) in order xx,yy,zz,yz,xz,xy")
    return Control(tuple(c == "S" for c in t))


@dataclass(frozen=True)
class LoadPath:
    """A sequence of steps.

    Attributes
    ----------
    stress_control : bool array (m, 6)
        Control kind per step and component.
    increment : float array (m, 6)
        Increment of each controlled component over the step (stress units for stress
        controlled, strain for strain controlled).
    """

    stress_control: np.ndarray
    increment: np.ndarray

    def __post_init__(self) -> None:
        sc = np.asarray(self.stress_control, dtype=bool)
        inc = np.asarray(self.increment, dtype=float)
        if sc.ndim != 2 or sc.shape[1] != 6 or inc.shape != sc.shape:
            raise ParameterError("path", (sc.shape, inc.shape), "stress_control and increment must both be (m, 6)")
        if not np.all(np.isfinite(inc)):
            raise ParameterError("path.increment", "non-finite", "increments must be finite")
        sc.setflags(write=False)
        inc.setflags(write=False)
        object.__setattr__(self, "stress_control", sc)
        object.__setattr__(self, "increment", inc)

    def __len__(self) -> int:
        return int(self.increment.shape[0])

    def __add__(self, other: LoadPath) -> LoadPath:
        return concatenate([self, other])


def _control(c: Control | str) -> Control:
    return parse_mask(c) if isinstance(c, str) else c


def _nsteps(n: int, name: str = "n_steps") -> int:
    if int(n) != n or int(n) < 1:
        raise ParameterError(name, n, "must be a positive integer")
    return int(n)


def segment(control: Control | str, change: ArrayLike, n_steps: int) -> LoadPath:
    """Linear segment: the controlled components change by ``change`` (6,) in ``n_steps`` equal steps."""
    c = _control(control)
    n = _nsteps(n_steps)
    ch = np.asarray(change, dtype=float)
    if ch.shape != (6,):
        raise ParameterError("change", ch.shape, "must have 6 components")
    return LoadPath(np.tile(c.array, (n, 1)), np.tile(ch / n, (n, 1)))


def _wave(n_cycles: int, steps_per_cycle: int, waveform: str) -> np.ndarray:
    """Values of a unit-amplitude wave at the end of each step, shape (n_cycles*steps,)."""
    if waveform not in ("triangle", "sine"):
        raise ParameterError("waveform", waveform, "must be 'triangle' or 'sine'")
    spc = _nsteps(steps_per_cycle, "steps_per_cycle")
    if waveform == "triangle" and spc % 4:
        raise ParameterError("steps_per_cycle", steps_per_cycle, "must be a multiple of 4 for a triangle wave")
    t = np.arange(1, _nsteps(n_cycles, "n_cycles") * spc + 1) / spc
    if waveform == "sine":
        return np.sin(2 * np.pi * t)
    ph = t % 1.0
    return np.where(ph <= 0.25, 4 * ph, np.where(ph <= 0.75, 2 - 4 * ph, 4 * ph - 4))


def cycles(control: Control | str, direction: ArrayLike, amplitude: float, n_cycles: int,
           steps_per_cycle: int, waveform: str = "triangle") -> LoadPath:
    """Symmetric cycles ``x(t) = x0 + amplitude * wave(t) * direction`` starting at the current value.

    Parameters
    ----------
    control : Control or str
    direction : (6,)
        Components cycled (e.g. ``e_xz``); other controlled components are held.
    amplitude : float
        Amplitude (strain or stress units).
    n_cycles, steps_per_cycle : int
    waveform : {"triangle", "sine"}
        Each cycle is 0 -> +A -> 0 -> -A -> 0.
    """
    c = _control(control)
    d = np.asarray(direction, dtype=float)
    if d.shape != (6,):
        raise ParameterError("direction", d.shape, "must have 6 components")
    if not np.isfinite(amplitude):
        raise ParameterError("amplitude", amplitude, "must be finite")
    v = amplitude * _wave(n_cycles, steps_per_cycle, waveform)
    dv = np.diff(np.concatenate([[0.0], v]))
    dv[-1] -= v[-1]  # end exactly at the start value (wave returns to 0)
    return LoadPath(np.tile(c.array, (dv.size, 1)), dv[:, None] * d[None, :])


def concatenate(paths: Sequence[LoadPath]) -> LoadPath:
    """Join paths step after step."""
    if not paths:
        raise ParameterError("paths", paths, "must not be empty")
    return LoadPath(np.concatenate([p.stress_control for p in paths]),
                    np.concatenate([p.increment for p in paths]))


_E = np.eye(6)


def isotropic_compression(dp: float, n_steps: int) -> LoadPath:
    """Stress-controlled isotropic compression by ``dp`` (shear stresses held)."""
    return segment(Control.all_stress(), dp * np.array([1, 1, 1, 0, 0, 0.0]), n_steps)


def triaxial(axial_strain: float, n_steps: int) -> LoadPath:
    """Drained triaxial test, axis z: ``eps_zz`` controlled, lateral and shear stresses held.

    ``axial_strain > 0``: compression; ``< 0``: extension.
    """
    return segment(parse_mask("SSESSS"), axial_strain * _E[2], n_steps)


def constant_mean_stress(dq: float, n_steps: int) -> LoadPath:
    """Stress-controlled: ``q = sigma_zz - sigma_xx`` changes by ``dq`` at constant mean stress."""
    return segment(Control.all_stress(), dq * np.array([-1 / 3, -1 / 3, 2 / 3, 0, 0, 0]), n_steps)


def fig610_path(kind: str, p0: float, ratio: float, n_steps: int) -> LoadPath:
    """The three stress paths of seed Fig. 6.10 from ``sigma = p0 I`` to ``sigma1/sigma3 = ratio``.

    sigma1 is along z, sigma2 = sigma3 along x, y (all stress controlled).

    kind : {"compression", "constant-mean", "reduced-compression"}
        compression: sigma1 up, sigma3 = p0; constant-mean: sigma1 + 2 sigma3 = 3 p0;
        reduced-compression: sigma3 down, sigma1 = p0.
    """
    s1, s3 = fig610_stress(kind, p0, ratio)
    return segment(Control.all_stress(), [s3 - p0, s3 - p0, s1 - p0, 0, 0, 0], n_steps)


def fig610_stress(kind: str, p0: float, ratio: float) -> tuple[float, float]:
    """(sigma1, sigma3) on a Fig. 6.10 path at stress ratio ``ratio`` (see :func:`fig610_path`)."""
    if not ratio >= 1:
        raise ParameterError("ratio", ratio, "sigma1/sigma3 must be >= 1")
    if kind == "compression":
        return ratio * p0, p0
    if kind == "constant-mean":
        s3 = 3 * p0 / (ratio + 2)
        return ratio * s3, s3
    if kind == "reduced-compression":
        return p0, p0 / ratio
    raise ParameterError("kind", kind, "must be 'compression', 'constant-mean' or 'reduced-compression'")


def simple_shear(gamma: float, n_steps: int) -> LoadPath:
    """Simple shear ``gamma_xz`` at constant normal stress ``sigma_zz`` (other strains held)."""
    return segment(parse_mask("EESEEE"), gamma * _E[4], n_steps)


def cyclic_simple_shear(amplitude: float, n_cycles: int, steps_per_cycle: int,
                        waveform: str = "triangle", *, constant: str = "stress") -> LoadPath:
    """Strain-controlled cyclic simple shear ``gamma_xz``.

    constant : {"stress", "volume"}
        ``"stress"``: constant normal stress ``sigma_zz`` (drained simple shear, mask
        ``EESEEE``); ``"volume"``: every other strain component held, i.e. constant-volume
        simple shear (the usual laboratory stand-in for undrained cyclic simple shear;
        mask ``EEEEEE``, integrated in one compiled pass by the driver).
    """
    if constant == "stress":
        mask = parse_mask("EESEEE")
    elif constant == "volume":
        mask = parse_mask("EEEEEE")
    else:
        raise ParameterError("constant", constant, "must be 'stress' or 'volume'")
    return cycles(mask, _E[4], amplitude, n_cycles, steps_per_cycle, waveform)


def cyclic_triaxial(amplitude: float, n_cycles: int, steps_per_cycle: int, *,
                    control: str = "strain", waveform: str = "triangle") -> LoadPath:
    """Cyclic triaxial about the current state, axis z, lateral stresses held.

    control : {"strain", "stress"}
        cycle ``eps_zz`` (amplitude is a strain) or ``sigma_zz`` (a stress).
    """
    if control == "strain":
        return cycles(parse_mask("SSESSS"), _E[2], amplitude, n_cycles, steps_per_cycle, waveform)
    if control == "stress":
        return cycles(Control.all_stress(), _E[2], amplitude, n_cycles, steps_per_cycle, waveform)
    raise ParameterError("control", control, "must be 'strain' or 'stress'")


class PathTargets:
    """Running targets of a mixed-control path (the semantics every driver follows).

    While a component keeps its kind of control, its increments are added to an exact
    running target (not to the value reached: targets do not drift); when the kind of
    control switches, the running target restarts from the current value. Used by the
    affine, packing and DEM path loops.

    Parameters
    ----------
    stress, strain : array (6,)
        The start state.
    """

    def __init__(self, stress: np.ndarray, strain: np.ndarray) -> None:
        self.stress = np.array(stress, dtype=float)
        self.strain = np.array(strain, dtype=float)
        self._prev: np.ndarray | None = None

    def step(self, sc: np.ndarray, inc: np.ndarray, stress: np.ndarray,
             strain: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Targets ``(stress, strain)`` of the next step from the state ``stress``, ``strain``.

        ``sc`` (6,) bool: stress-controlled components; ``inc`` (6,) their increments.
        Components not controlled by a kind keep the state's value in that target.
        """
        if self._prev is not None:  # a component switching control restarts from the state
            switched = sc != self._prev
            self.stress = np.where(switched & sc, stress, self.stress)
            self.strain = np.where(switched & ~sc, strain, self.strain)
        self._prev = sc
        return np.where(sc, self.stress + inc, stress), np.where(~sc, self.strain + inc, strain)

    def reached(self, sc: np.ndarray, t_stress: np.ndarray, t_strain: np.ndarray, stress: np.ndarray,
                strain: np.ndarray) -> None:
        """Record a completed step: the controlled targets and the state's other components."""
        self.stress = np.where(sc, t_stress, stress)
        self.strain = np.where(~sc, t_strain, strain)

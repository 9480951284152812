"""Secant modulus and damping from strain-controlled cycles.

For one closed stress-strain loop ``(gamma, tau)`` (engineering shear strain):

* amplitude ``gamma_a = (max gamma - min gamma)/2``, ``tau_a`` half the stress range
  between the two strain extremes;
* secant modulus ``G = tau_a / gamma_a``;
* dissipated energy ``dW = |oint tau d gamma|`` (trapezoidal loop area);
* damping ratio ``D = dW / (4 pi W)`` with ``W = tau_a gamma_a / 2`` (Kramer 1996, Sec. 6.4.2;
  Darendeli 2001, Ch. 2).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from grainmech.errors import ParameterError

__all__ = ["LoopProperties", "loop_properties", "ModulusReduction", "modulus_reduction",
           "condensed_modulus"]


@dataclass(frozen=True)
class LoopProperties:
    """Properties of one loop (units: strain dimensionless, stress and energy per volume)."""

    gamma_a: float
    tau_a: float
    secant_modulus: float
    dissipated: float
    stored: float
    damping: float


def loop_properties(gamma: Any, tau: Any) -> LoopProperties:
    """Secant modulus and damping ratio of one closed loop.

    Parameters
    ----------
    gamma, tau : arrays (k,)
        Engineering shear strain and shear stress along one full cycle (first and last
        points at the same strain).
    """
    g = np.asarray(gamma, dtype=float)
    t = np.asarray(tau, dtype=float)
    if g.ndim != 1 or g.shape != t.shape or g.size < 4:
        raise ParameterError("gamma/tau", (g.shape, t.shape), "must be 1-D arrays of equal length >= 4")
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(t))):
        raise ParameterError("gamma/tau", "non-finite", "must be finite")
    imax, imin = int(np.argmax(g)), int(np.argmin(g))
    ga = 0.5 * (g[imax] - g[imin])
    if ga <= 0:
        raise ParameterError("gamma", "constant", "the loop has zero strain amplitude")
    ta = 0.5 * (t[imax] - t[imin])
    dW = abs(float(np.sum(0.5 * (t[1:] + t[:-1]) * np.diff(g))))
    W = 0.5 * ta * ga
    D = dW / (4 * np.pi * W) if W > 0 else 0.0
    return LoopProperties(float(ga), float(ta), float(ta / ga), dW, float(W), float(D))


def condensed_modulus(C: np.ndarray, component: int, stress_control: Sequence[bool]) -> float:
    """Small-strain modulus ``d sigma_k / d eps_k`` with the other components controlled.

    Strain-controlled components are held (zero increment), stress-controlled ones free
    (zero stress increment): ``C_kk - C_kS C_SS^-1 C_Sk``.
    """
    sc = np.asarray(stress_control, dtype=bool)
    C = np.asarray(C, dtype=float)
    k = int(component)
    if sc[k]:
        raise ParameterError("component", k, "must be strain controlled")
    if not sc.any():
        return float(C[k, k])
    return float(C[k, k] - C[k, sc] @ np.linalg.solve(C[np.ix_(sc, sc)], C[sc, k]))


@dataclass(frozen=True)
class ModulusReduction:
    """Modulus reduction and damping against amplitude.

    Attributes
    ----------
    amplitude : (k,) engineering shear strain amplitudes
    G : (k,) secant moduli of the last cycle
    damping : (k,) damping ratios of the last cycle
    G_max : float
        Small-strain modulus from the initial tangent (:func:`condensed_modulus`).
    results : list of DriverResult
    """

    amplitude: np.ndarray
    G: np.ndarray
    damping: np.ndarray
    G_max: float
    results: list
    success: bool = True
    message: str = "done"

    @property
    def G_ratio(self) -> np.ndarray:
        """Secant modulus ratio ``G / G_max`` [-] per amplitude, shape (n_amplitudes,)."""
        return self.G / self.G_max


def modulus_reduction(point: Any, amplitudes: ArrayLike, *, n_cycles: int = 2,
                      steps_per_cycle: int = 80, waveform: str = "triangle", constant: str = "stress",
                      progress: Callable[[int, float, Any], None] | None = None,
                      raise_on_failure: bool = True,
                      on_amplitude: Callable[[ModulusReduction], None] | None = None,
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
        If False, a failed run stops the series and the result (``success`` False,
        ``message`` naming the amplitude) holds the amplitudes done plus the failed run.
    on_amplitude : callable ``(ModulusReduction)``, optional
        Called after each completed amplitude with the series so far (what an
        interrupted run can still report).

    Raises
    ------
    GrainmechError
        If a run fails and ``raise_on_failure`` (its message is passed on).
    """
    from grainmech.driver import run
    from grainmech.driver.loop import cyclic_series

    return cyclic_series(lambda path: run(point, path, **run_options), amplitudes,
                         lambda path: condensed_modulus(point.tangent, 4, path.stress_control[0]),
                         n_cycles=n_cycles, steps_per_cycle=steps_per_cycle, waveform=waveform, constant=constant,
                         progress=progress, raise_on_failure=raise_on_failure, on_amplitude=on_amplitude)

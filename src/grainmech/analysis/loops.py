"""Secant modulus and damping from strain-controlled cycles.

For one closed stress-strain loop ``(gamma, tau)`` (engineering shear strain):

* amplitude ``gamma_a = (max gamma - min gamma)/2``, ``tau_a`` half the stress range
  between the two strain extremes;
* secant modulus ``G = tau_a / gamma_a``;
* dissipated energy ``dW = |oint tau d gamma|`` (trapezoidal loop area);
* damping ratio ``D = dW / (4 pi W)`` with ``W = tau_a gamma_a / 2`` (Kramer 1996, Sec. 6.4.2;
  Darendeli 2001, Ch. 2).

These are the properties of a *closed, stationary* loop. :func:`loop_quality` says how
far an analysed cycle is from one: the stress and strain mismatch between its start and
its end and the asymmetry of its two peaks (tolerances :data:`LOOP_CLOSURE_TOLERANCE`,
:data:`LOOP_ASYMMETRY_TOLERANCE`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.errors import ParameterError

__all__ = ["LoopProperties", "loop_properties", "LoopQuality", "loop_quality", "LOOP_CLOSURE_TOLERANCE",
           "LOOP_ASYMMETRY_TOLERANCE", "ModulusReduction", "condensed_modulus"]

#: largest closure (stress mismatch / tau_a or strain mismatch / gamma_a between the start
#: and the end of the analysed cycle) of a loop taken as closed
LOOP_CLOSURE_TOLERANCE = 0.05
#: largest peak asymmetry ``| |tau_+ - tau_0| - |tau_- - tau_0| | / tau_a`` of a loop taken
#: as symmetric
LOOP_ASYMMETRY_TOLERANCE = 0.10


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


@dataclass(frozen=True)
class LoopQuality:
    """How close one analysed cycle is to a closed, symmetric loop (:func:`loop_quality`).

    Attributes
    ----------
    gamma_a, tau_a : float
        Half the strain range and half the stress range between the two strain extremes
        (as :func:`loop_properties`) [-], [Pa].
    tau_plus, tau_minus : float
        Shear stress at the largest and at the smallest strain (``+gamma_a``, ``-gamma_a``)
        [Pa].
    tau_0 : float
        Reference shear stress the peaks are measured from (the test's initial shear
        stress) [Pa].
    stress_closure : float
        ``|tau_end - tau_start| / tau_a`` [-].
    strain_closure : float
        ``|gamma_end - gamma_start| / gamma_a`` [-].
    asymmetry : float
        ``| |tau_plus - tau_0| - |tau_minus - tau_0| | / tau_a`` [-].
    closure_tolerance, asymmetry_tolerance : float
        The tolerances the loop was judged by [-].
    """

    gamma_a: float
    tau_a: float
    tau_plus: float
    tau_minus: float
    tau_0: float
    stress_closure: float
    strain_closure: float
    asymmetry: float
    closure_tolerance: float = LOOP_CLOSURE_TOLERANCE
    asymmetry_tolerance: float = LOOP_ASYMMETRY_TOLERANCE

    @property
    def closure(self) -> float:
        """The larger of :attr:`stress_closure` and :attr:`strain_closure` [-]."""
        return max(self.stress_closure, self.strain_closure)

    @property
    def closed(self) -> bool:
        """Whether :attr:`closure` is within :attr:`closure_tolerance`."""
        return bool(self.closure <= self.closure_tolerance)

    @property
    def symmetric(self) -> bool:
        """Whether :attr:`asymmetry` is within :attr:`asymmetry_tolerance`."""
        return bool(self.asymmetry <= self.asymmetry_tolerance)

    @property
    def ok(self) -> bool:
        """Closed and symmetric."""
        return self.closed and self.symmetric

    @property
    def problems(self) -> list[str]:
        """One sentence per tolerance exceeded (empty when :attr:`ok`)."""
        out = []
        if not self.tau_a > 0:
            return ["no positive stress amplitude (tau_a <= 0): the stress does not follow the strain"]
        if not self.closed:
            out.append(f"loop not closed: the analysed cycle ends {100 * self.stress_closure:.3g} % of tau_a "
                       f"and {100 * self.strain_closure:.3g} % of gamma_a away from its start "
                       f"(tolerance {100 * self.closure_tolerance:g} %)")
        if not self.symmetric:
            out.append(f"loop not symmetric: |tau(+gamma_a)| = {abs(self.tau_plus - self.tau_0):.4g} Pa, "
                       f"|tau(-gamma_a)| = {abs(self.tau_minus - self.tau_0):.4g} Pa, asymmetry "
                       f"{100 * self.asymmetry:.3g} % of tau_a (tolerance {100 * self.asymmetry_tolerance:g} %)")
        return out

    def as_dict(self) -> dict:
        """JSON-ready: every attribute, ``closed``, ``symmetric``, ``ok`` and ``problems``."""
        return {"gamma_a": self.gamma_a, "tau_a_Pa": self.tau_a, "tau_plus_Pa": self.tau_plus,
                "tau_minus_Pa": self.tau_minus, "tau_0_Pa": self.tau_0, "stress_closure": self.stress_closure,
                "strain_closure": self.strain_closure, "asymmetry": self.asymmetry,
                "closure_tolerance": self.closure_tolerance, "asymmetry_tolerance": self.asymmetry_tolerance,
                "closed": self.closed, "symmetric": self.symmetric, "ok": self.ok, "problems": self.problems}


def loop_quality(gamma: Any, tau: Any, tau_0: float = 0.0, *,
                 closure_tolerance: float = LOOP_CLOSURE_TOLERANCE,
                 asymmetry_tolerance: float = LOOP_ASYMMETRY_TOLERANCE) -> LoopQuality:
    """Closure and peak symmetry of one analysed cycle.

    A secant modulus and a damping ratio (:func:`loop_properties`) describe a stationary
    loop: one that ends where it began and whose two peaks mirror each other. With
    ``gamma_+`` / ``gamma_-`` the largest / smallest strain of the cycle, ``tau_+`` /
    ``tau_-`` the stresses there, ``gamma_a = (gamma_+ - gamma_-)/2`` and ``tau_a =
    (tau_+ - tau_-)/2``:

    * stress closure ``|tau[-1] - tau[0]| / tau_a`` and strain closure
      ``|gamma[-1] - gamma[0]| / gamma_a``: how far the cycle ends from its start (a
      strain-controlled cycle closes in strain by construction; the stress closure shows
      a loop still drifting: ratcheting, a mean stress still changing, a first cycle
      from virgin loading);
    * asymmetry ``| |tau_+ - tau_0| - |tau_- - tau_0| | / tau_a``: how differently the two
      peaks stand from the test's initial shear stress ``tau_0`` (0 for simple shear from
      an isotropic state); a loop whose centre has drifted away from ``tau_0``, or a
      material stiffer one way than the other, shows here.

    The loop is taken as closed if both closures are within ``closure_tolerance`` (5 %
    by default, :data:`LOOP_CLOSURE_TOLERANCE`) and as symmetric if the asymmetry is
    within ``asymmetry_tolerance`` (10 %, :data:`LOOP_ASYMMETRY_TOLERANCE`). A closed
    Masing loop (Masing 1926) has both 0.

    Parameters
    ----------
    gamma, tau : arrays (k,)
        Engineering shear strain [-] and shear stress [Pa] along the analysed cycle,
        from its first state to its last (``k >= 4``).
    tau_0 : float
        Reference shear stress [Pa] the peaks are measured from (the stress at the start
        of the test).
    closure_tolerance, asymmetry_tolerance : float
        Tolerances [-] (fractions, > 0).

    Returns
    -------
    LoopQuality
        Closures and asymmetry are ``inf`` when ``tau_a <= 0``.

    Raises
    ------
    ParameterError
        On arrays of unequal length, shorter than 4, not finite, or of zero strain range.
    """
    g = np.asarray(gamma, dtype=float)
    t = np.asarray(tau, dtype=float)
    if g.ndim != 1 or g.shape != t.shape or g.size < 4:
        raise ParameterError("gamma/tau", (g.shape, t.shape), "must be 1-D arrays of equal length >= 4")
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(t)) and np.isfinite(tau_0)):
        raise ParameterError("gamma/tau/tau_0", "non-finite", "must be finite")
    for name, tol in (("closure_tolerance", closure_tolerance), ("asymmetry_tolerance", asymmetry_tolerance)):
        if not (np.isfinite(tol) and tol > 0):
            raise ParameterError(name, tol, "must be a positive fraction")
    imax, imin = int(np.argmax(g)), int(np.argmin(g))
    ga = 0.5 * (g[imax] - g[imin])
    if ga <= 0:
        raise ParameterError("gamma", "constant", "the loop has zero strain amplitude")
    tp, tm = float(t[imax]), float(t[imin])
    ta = 0.5 * (tp - tm)
    if ta > 0:
        sc = abs(float(t[-1] - t[0])) / ta
        asym = abs(abs(tp - tau_0) - abs(tm - tau_0)) / ta
    else:
        sc = asym = float("inf")
    return LoopQuality(float(ga), float(ta), tp, tm, float(tau_0), float(sc), float(abs(g[-1] - g[0]) / ga),
                       float(asym), float(closure_tolerance), float(asymmetry_tolerance))


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
    success, message
        Whether every amplitude completed or liquefied, and what stopped the others.
    run_amplitudes : (len(results),) or None
        The amplitude of every run in ``results``.
    liquefied : tuple of str
        ``"amplitude a: <message>"`` of every amplitude whose run liquefied (the DEM model
        at constant volume: the test's answer, not a failure; no G or damping).
    """

    amplitude: np.ndarray
    G: np.ndarray
    damping: np.ndarray
    G_max: float
    results: list
    success: bool = True
    message: str = "done"
    run_amplitudes: np.ndarray | None = None
    liquefied: tuple = ()

    @property
    def completed(self) -> list:
        """The results of the completed amplitudes (aligned with ``amplitude``, ``G``, ``damping``)."""
        return [r for r in self.results if r.success][:len(self.G)]

    @property
    def G_ratio(self) -> np.ndarray:
        """Secant modulus ratio ``G / G_max`` [-] per amplitude, shape (n_amplitudes,)."""
        return self.G / self.G_max


def __getattr__(name: str) -> Any:
    """``modulus_reduction``, the affine model's series, where it was defined before: found on first use.

    It lives with the affine driver now (:func:`grainmech.driver.modulus_reduction`); the
    driver imports this module, so this module does not import the driver at its top.
    """
    if name == "modulus_reduction":
        from grainmech.driver import modulus_reduction  # noqa: PLC0415 (see the docstring)

        return modulus_reduction
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

"""How far an analysed cycle is from a closed, stationary loop.

The secant modulus and the damping ratio of a loop (:func:`grainmech.driver.loop.loop_properties`,
which every model's cyclic series applies to its last cycle) are the properties of a
*closed, stationary* loop. :func:`loop_quality` says how far an analysed cycle is from
one: the stress and strain mismatch between its start and its end and the asymmetry of
its two peaks (tolerances :data:`LOOP_CLOSURE_TOLERANCE`, :data:`LOOP_ASYMMETRY_TOLERANCE`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.errors import ParameterError

__all__ = ["LoopQuality", "loop_quality", "LOOP_CLOSURE_TOLERANCE", "LOOP_ASYMMETRY_TOLERANCE"]

#: largest closure (stress mismatch / tau_a or strain mismatch / gamma_a between the start
#: and the end of the analysed cycle) of a loop taken as closed
LOOP_CLOSURE_TOLERANCE = 0.05
#: largest peak asymmetry ``| |tau_+ - tau_0| - |tau_- - tau_0| | / tau_a`` of a loop taken
#: as symmetric
LOOP_ASYMMETRY_TOLERANCE = 0.10


@dataclass(frozen=True)
class LoopQuality:
    """How close one analysed cycle is to a closed, symmetric loop (:func:`loop_quality`).

    Attributes
    ----------
    gamma_a, tau_a : float
        Half the strain range and half the stress range between the two strain extremes
        (as :func:`~grainmech.driver.loop.loop_properties`) [-], [Pa].
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

    A secant modulus and a damping ratio (:func:`~grainmech.driver.loop.loop_properties`) describe a stationary
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

"""Continuous quasi-static shearing of a LAMMPS packing at a target inertial number.

The step-and-relax protocol of the DEM model (:mod:`grainmech.driver.dem.point`) brings the
packing to equilibrium at every recorded state; on a flowing packing every relaxation
then costs as much as the flow itself. The continuous protocol shears without stopping:
the cell deforms at a constant rate set from a target inertial number

``I = gamma_dot d sqrt(rho_s / p)``  (GDR MiDi 2004, Eur. Phys. J. E 14, 341; da Cruz et
al. 2005, Phys. Rev. E 72, 021309),

with ``d`` the mean grain diameter, ``rho_s`` the grain density and ``p`` the mean stress
at the start of the increment; ``I <~ 1e-3`` is the quasi-static regime of steady
shearing. The grains carry the affine velocity field of the cell's rate (LAMMPS ``fix
deform ... remap v``), so that a contact's tangential spring sees the affine part of the
motion from the first time step, and the field follows every change of rate (a reversal
of a cyclic path, the servo's corrections). The stress-controlled components (the lateral
stresses of a drained triaxial test, ``sigma_zz`` of simple shear at constant normal
stress) are held by a servo on the cell, corrected every ``servo_interval`` time steps
from LAMMPS' virial stress with a stiffness estimate, towards the stress the path reaches
at the end of the interval, the correction capped so that the cell's rate stays within
the target inertial number. The estimate starts from the point's (the relaxed elastic
tensor) and learns the flowing packing's response by Broyden's rank-one update after
every interval (its stress-controlled diagonal kept between 1e-3 and 1 times the elastic
one): a packing in plastic flow answers a lateral strain far more softly than its
elastic tensor, and a servo on the elastic tensor lags behind the path. No damping fix acts while flowing (the contact
dashpots of the granular model do); the recorded states are states of the flow, each with
its unbalanced force ratio and inertial number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grainmech.lammps.session import VOIGT_DEFORM, add_affine_velocity

__all__ = ["FlowState", "flow_increment", "inertial_number", "shear_rate", "virial_stress"]

#: LAMMPS ``compute pressure`` order (pxx pyy pzz pxy pxz pyz) -> grainmech Voigt (xx yy zz yz xz xy)
_PRESS_TO_VOIGT = (0, 1, 2, 5, 4, 3)


def virial_stress(lmp) -> np.ndarray:
    """LAMMPS' virial stress of the cell (6,), grainmech order, compression positive [Pa]."""
    p = np.asarray(lmp.vector("press")[:6], float)
    return p[list(_PRESS_TO_VOIGT)]


def shear_rate(inertial_number: float, diameter: float, density: float, pressure: float) -> float:
    """``gamma_dot = I / (d sqrt(rho_s / p))`` [1/s] (GDR MiDi 2004)."""
    return inertial_number / (diameter * math.sqrt(density / pressure))


def inertial_number(rate: float, diameter: float, density: float, pressure: float) -> float:
    """``I = gamma_dot d sqrt(rho_s / p)`` of a strain rate [1/s] at mean stress ``pressure`` [Pa]."""
    if not pressure > 0:
        return math.inf
    return abs(rate) * diameter * math.sqrt(density / pressure)


@dataclass
class FlowState:
    """The cell's current strain rate (grainmech Voigt, engineering, compression positive) [1/s]."""

    rate: np.ndarray
    K: np.ndarray | None = None
    K0: np.ndarray | None = None

    @classmethod
    def at_rest(cls, K: np.ndarray | None = None) -> FlowState:
        """A cell at rest with the servo's stiffness estimate ``K`` (6, 6) [Pa] (None: no servo)."""
        return cls(np.zeros(6), None if K is None else K.copy(), None if K is None else K.copy())

    def learn(self, sc: np.ndarray, s_vec: np.ndarray, y_vec: np.ndarray) -> None:
        """Broyden's update ``K += (y - K s) s^T / (s^T s)`` within the module's bounds."""
        ss = float(s_vec @ s_vec)
        if self.K is None or self.K0 is None or ss <= 0:
            return
        new = self.K + np.outer(y_vec - self.K @ s_vec, s_vec) / ss
        d_new, d0 = np.diag(new)[sc], np.diag(self.K0)[sc]
        if np.all(np.isfinite(new)) and np.all(d_new >= 1e-3 * d0) and np.all(d_new <= d0):
            self.K = new

    @property
    def flowing(self) -> bool:
        """Whether the cell deforms (a rate is set)."""
        return bool(np.any(self.rate != 0.0))


def deform_command(rate: np.ndarray) -> str | None:
    """LAMMPS' ``fix flow`` of the cell rate ``rate`` (grainmech convention; None: at rest)."""
    parts = [f"{key} erate {-r:.12g}" for (key, _), r in zip(VOIGT_DEFORM, rate) if r != 0.0]
    return "fix flow all deform 1 " + " ".join(parts) + " remap v" if parts else None


def _set_rate(s, flow: FlowState, rate: np.ndarray) -> None:
    """Change the cell's rate to ``rate`` (grainmech convention) and the grains' affine velocity with it."""
    if np.array_equal(rate, flow.rate):
        return
    lmp = s.lmp
    if flow.flowing:
        lmp.command("unfix flow")
    add_affine_velocity(s, -(rate - flow.rate), 1.0)  # LAMMPS: tension positive
    cmd = deform_command(rate)
    if cmd is not None:
        lmp.command(cmd)
    flow.rate = np.asarray(rate, float).copy()


def flow_increment(s, flow: FlowState, d_e: np.ndarray, sc: np.ndarray, start: np.ndarray, target: np.ndarray,
                   rate: float, interval: int, min_steps: int, gain: float = 0.8) -> dict:
    """Shear the cell through one recorded increment without stopping (module notes).

    Parameters
    ----------
    s : the LAMMPS session (:class:`grainmech.lammps.session.Session`)
    flow : FlowState
        The cell's rate and the servo's stiffness estimate; updated.
    d_e : array (6,)
        Strain increment of the strain-controlled components (zero where ``sc``).
    sc : bool array (6,)
        Stress-controlled components.
    start, target : arrays (6,)
        Stress at the start of the increment and the stress-controlled targets at its end [Pa].
    rate : float
        Largest strain rate [1/s] (from the target inertial number).
    interval : int
        Time steps between two servo corrections.
    min_steps : int
        Fewest time steps of an increment.
    gain : float
        Fraction of the estimated correction applied per interval.

    Returns
    -------
    dict with ``steps`` (time steps run), ``strain`` (6,) the cell strain applied, ``rate``
    (largest rate of the increment [1/s]).
    """
    dt = s.dt
    big = float(np.abs(d_e).max(initial=0.0))
    n_total = max(int(min_steps), int(math.ceil(big / (rate * dt))) if big > 0 else int(min_steps))
    n_chunks = max(1, int(math.ceil(n_total / interval))) if sc.any() else 1
    chunk = int(math.ceil(n_total / n_chunks))
    applied = np.zeros(6)
    done = 0
    top = 0.0
    K = flow.K
    last: tuple[np.ndarray, np.ndarray] | None = None
    for k in range(n_chunks):
        steps = min(chunk, n_total - done) if k < n_chunks - 1 else n_total - done
        if steps <= 0:
            break
        de_chunk = d_e * (steps / n_total)
        r = np.where(sc, 0.0, de_chunk / (steps * dt))
        if sc.any():
            assert K is not None
            now = virial_stress(s.lmp)
            if last is not None:  # the response to the last interval's strain
                flow.learn(sc, last[1], now - last[0])
                K = flow.K
                assert K is not None
            frac = (done + steps) / n_total
            goal = start + (target - start) * frac
            err = goal[sc] - now[sc] - K[np.ix_(sc, ~sc)] @ de_chunk[~sc]
            de_sc = gain * np.linalg.solve(K[np.ix_(sc, sc)], err)
            r_sc = de_sc / (steps * dt)
            r[sc] = np.clip(r_sc, -rate, rate)
        _set_rate(s, flow, r)
        s.lmp.command(f"run {steps} post no")
        s.steps += steps
        applied += r * steps * dt
        if sc.any():
            last = (now, r * steps * dt)
        done += steps
        top = max(top, float(np.abs(r).max(initial=0.0)))
    return {"steps": done, "strain": applied, "rate": top}

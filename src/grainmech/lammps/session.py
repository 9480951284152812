"""The one LAMMPS session of a packing: load a network, ramp a strain, relax, measure.

:func:`load_network` puts a periodic packing into LAMMPS with the granular model of
:mod:`grainmech.lammps.granular` and the grain friction, and returns a :class:`Session`
(the LAMMPS instance, the time step, the drags). :func:`ramp` applies a strain increment
with the affine velocity field (the cell follows with ``fix deform ... remap v``);
:func:`relax` holds the cell until the unbalanced force ratio is below a tolerance (and
the stress has settled), and returns the network read back from LAMMPS. The DEM model
(:mod:`grainmech.driver.dem`) and the strain probes (:mod:`grainmech.lammps.probes`) are
built on them.

LAMMPS keeps no tangential spring history in a network file, so the tangential forces
restart from zero: the reference state of a run is the re-equilibrated packing.

Sign convention: compression positive (grainmech), engineering shear strains, Voigt
order ``xx yy zz yz xz xy``; a LAMMPS tensile cell strain ``+e`` is a grainmech strain ``-e``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.contact.geometry import hertz_kn, hertz_radius_from_approach
from grainmech.contact.rolling import RollingConstants
from grainmech.errors import GrainmechError
from grainmech.lammps.granular import GrainMaterial, critical_time_step, setup_lammps
from grainmech.lammps.network import network_from_lammps, unbalanced_ratio
from grainmech.lammps.rolling import rolling_pair_suffix
from grainmech.network import ContactNetwork, network_stress

__all__ = ["Session", "load_network", "relax", "RelaxationTimeout", "ramp", "add_affine_velocity", "voigt",
           "VOIGT_DEFORM", "KINETIC_INTERVAL"]


#: LAMMPS ``fix deform`` keyword of each Voigt component (xx yy zz yz xz xy) and the cell
#: length that converts its engineering strain into a length change
VOIGT_DEFORM = (("x", 0), ("y", 1), ("z", 2), ("yz", 2), ("xz", 2), ("xy", 1))
_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def voigt(s: np.ndarray) -> np.ndarray:
    """The Voigt 6-vector ``xx yy zz yz xz xy`` of a symmetric (3, 3) tensor."""
    return np.array([s[i, j] for i, j in _VOIGT])


#: time steps between two checks of the power under kinetic damping (:meth:`Session.advance`)
KINETIC_INTERVAL = 10


@dataclass
class Session:
    """A packing loaded into LAMMPS (:func:`load_network`): the instance, time step, drags and counters."""

    lmp: Any
    mat: GrainMaterial
    dt: float
    tmean: float
    rbar: float
    m_bar: float
    omega: float
    gamma: float
    steps: int = 0
    cundall: float = 0.0
    kinetic: bool = False
    #: relaxations the DEM model finished under kinetic damping after the drags ran out of
    #: budget (counted by :func:`grainmech.driver.dem.point.relax_point`, switched by :meth:`set_kinetic`)
    fallbacks: int = 0
    _power: bool = False

    def drags(self) -> None:
        """Switch the relaxation's damping on (fixes ``drag`` and ``spin``).

        Viscous drags ``gamma`` on velocities and ``gamma rbar^2`` on spins, or, with
        ``cundall`` > 0, Cundall's local non-viscous damping (LAMMPS ``fix damping/cundall``:
        each force and torque component reduced by ``cundall`` times its magnitude against
        the motion; Cundall & Strack 1979), which does not slow the packing's soft modes.
        With ``kinetic`` there are no damping fixes: :meth:`advance` quenches the motion.
        """
        if self.kinetic:
            return
        if self.cundall > 0:
            self.lmp.commands([f"fix drag all damping/cundall {self.cundall:.10g} {self.cundall:.10g}",
                               "fix spin all viscous/sphere 0"])
        else:
            self.lmp.commands([f"fix drag all viscous {self.gamma:.10g}",
                               f"fix spin all viscous/sphere {self.gamma * self.rbar ** 2:.10g}"])

    def undrag(self) -> None:
        """Switch the relaxation's damping off (for a ramp)."""
        if not self.kinetic:
            self.lmp.commands(["unfix drag", "unfix spin"])

    def define_power(self) -> None:
        """Define LAMMPS' ``kpow``: the power of the forces and torques, ``sum f.v + tau.omega`` (once)."""
        if self._power:
            return
        self.lmp.commands(["compute kspin all property/atom omegax omegay omegaz tqx tqy tqz",
                           "variable kpow atom fx*vx+fy*vy+fz*vz+c_kspin[1]*c_kspin[4]+c_kspin[2]*c_kspin[5]"
                           "+c_kspin[3]*c_kspin[6]",
                           "compute kpow all reduce sum v_kpow"])
        self._power = True

    def set_kinetic(self, on: bool) -> None:
        """Switch from the drags (or Cundall's damping) to kinetic damping, or back, during a relaxation."""
        if on == self.kinetic:
            return
        if on:
            self.undrag()
            self.define_power()
            self.kinetic = True
        else:
            self.kinetic = False
            self.drags()

    def advance(self, steps: int) -> None:
        """Run ``steps`` time steps with the relaxation's damping (the cell held).

        With ``kinetic`` (kinetic damping, the quench of dynamic relaxation: Cundall 1987;
        the velocity rule of FIRE, Bitzek et al. 2006, without its mixing and adaptive time
        step) the grains move undamped and every :data:`KINETIC_INTERVAL` time steps the
        power of the forces and torques, ``sum f.v + tau.omega`` over all grains (a LAMMPS
        reduction, so every MPI rank sees the same number), is checked: when it is negative
        the packing has passed a minimum of its potential energy along its motion, and every
        velocity and spin is set to zero. Soft modes are not slowed as by a viscous drag.
        The first run of each call sets LAMMPS up (``pre yes``): fixes may have changed.
        """
        if not self.kinetic:
            self.lmp.command(f"run {steps} post no")
            self.steps += steps
            return
        done = 0
        while done < steps:
            n = min(KINETIC_INTERVAL, steps - done)
            self.lmp.command(f"run {n} {'pre no ' if done else ''}post no")
            done += n
            if self.lmp.scalar("kpow") < 0.0:
                self.lmp.commands(["velocity all set 0.0 0.0 0.0", "set group all omega 0.0 0.0 0.0"])
        self.steps += steps


def load_network(lmp: Any, net: ContactNetwork, mat: GrainMaterial, *, viscous: float = 0.01,
                 safety: float = 0.07, cundall: float = 0.0, kinetic: bool = False,
                 rolling: RollingConstants | None = None) -> Session:
    """Put a periodic network into LAMMPS with grainmech's granular model.

    Put a periodic network into LAMMPS with the granular model of
    :mod:`grainmech.lammps.granular` and the grain friction; set the time step
    (:func:`critical_time_step` times ``safety``) and the drags (``viscous`` times the contact
    frequency at the packing's stress; with ``cundall`` > 0 Cundall's local damping
    instead, :meth:`Session.drags`; with ``kinetic``, kinetic damping,
    :meth:`Session.advance`). ``rolling``: rolling and twisting resistance (LAMMPS
    ``rolling sds`` / ``twisting sds`` with the dashpots of
    :func:`grainmech.lammps.rolling.rolling_damping`); the springs start from zero
    moment, as the tangential ones start from zero force.
    """
    if net.radii is None or not bool(np.all(net.box.periodic)):
        raise GrainmechError("a DEM reference run needs a periodic 3D packing with radii")
    c = net.box.cell
    if abs(c[0, 1]) + abs(c[0, 2]) + abs(c[1, 2]) > 1e-12 * abs(c).max():
        raise GrainmechError("the cell must be in LAMMPS form a = (lx,0,0), b = (xy,ly,0), c = (xz,yz,lz)")
    frac = (net.positions - net.box.origin) @ np.linalg.inv(c)
    frac -= np.floor(frac)
    pos = frac @ c
    p = float(np.trace(np.asarray(network_stress(net).stress)) / 3.0)
    if not p > 0:
        raise GrainmechError("the packing carries no compressive stress")
    rbar = float(np.mean(net.radii))
    setup_lammps(lmp, pos, net.radii, c, mat, mat.friction, p, ids=net.ids,
                 rolling=rolling_pair_suffix(rolling, rbar, mat.density))
    dt = critical_time_step(net.radii, mat, p, safety)
    m_bar = mat.density * 4.0 / 3.0 * math.pi * rbar ** 3
    # Hertz stiffness of a mean contact: approach 2 rbar (p / E*)^(2/3), R* = rbar / 2 (seed Eq. 3.5, 3.7)
    kn = float(hertz_kn(hertz_radius_from_approach(2.0 * rbar * (p / mat.e_star) ** (2.0 / 3.0), 0.5 * rbar),
                        mat.e_star))
    omega = math.sqrt(kn / m_bar)
    g = viscous * omega * m_bar
    lmp.commands([f"timestep {dt:.10g}", "thermo 100"])
    if kinetic and cundall > 0:
        raise GrainmechError("kinetic damping and Cundall's local damping exclude each other")
    s = Session(lmp, mat, dt, p, rbar, m_bar, omega, g, cundall=float(cundall), kinetic=bool(kinetic))
    if kinetic:
        s.define_power()
    s.drags()
    return s


class RelaxationTimeout(GrainmechError):
    """:func:`relax` ran out of time steps.

    ``reached`` is the last unbalanced force ratio, ``mean_stress`` the Love-Weber mean
    stress of the last check [Pa] (compression positive) and ``network`` its network (not
    an equilibrium).
    """

    def __init__(self, message: str, reached: float, mean_stress: float = float("nan"),
                 network: ContactNetwork | None = None) -> None:
        super().__init__(message)
        self.reached = reached
        self.mean_stress = mean_stress
        self.network = network


def relax(s: Session, tol: float, max_steps: int, chunk: int = 500, *,
          settle: tuple[np.ndarray, float] | None = None) -> tuple[ContactNetwork, float, int]:
    """Hold the cell and run LAMMPS until the packing is in equilibrium.

    Hold the cell and run until the unbalanced force ratio is below ``tol`` (and, with
    ``settle = (base, rtol)``, until the Voigt stress changes over a chunk by less than
    ``rtol`` times its distance ``max |sigma - base|`` from ``base``).

    Returns the network, its unbalanced force ratio and the steps used; raises
    GrainmechError when ``max_steps`` pass without reaching ``tol``.
    """
    used = 0
    prev = None
    while True:
        s.advance(chunk)
        used += chunk
        net = network_from_lammps(s.lmp)
        ub = unbalanced_ratio(net)
        ok = ub < tol
        if settle is not None:
            sig = voigt(np.asarray(network_stress(net).stress))
            scale = float(np.abs(sig - settle[0]).max())
            ok = ok and prev is not None and float(np.abs(sig - prev).max()) <= settle[1] * scale
            prev = sig
        if ok:
            return net, ub, used
        if used >= max_steps:
            p_now = float(np.trace(np.asarray(network_stress(net).stress)) / 3.0)
            raise RelaxationTimeout(f"relaxation did not reach an unbalanced force ratio of {tol:g} in "
                                    f"{max_steps} time steps (reached {ub:.3g})", ub, p_now, net)


def add_affine_velocity(s: Session, rate: np.ndarray, sign: float) -> None:
    """Add ``sign`` times the affine velocity field of a cell strain rate to every grain.

    Add ``sign`` times the affine velocity field of the cell strain rate ``rate``
    (Voigt, LAMMPS tension positive, engineering shears) to every grain.
    """
    x = s.lmp.atom("x")
    lo = s.lmp.box()[0]
    r = x - lo
    v = s.lmp.atom_view("v")
    exx, eyy, ezz, gyz, gxz, gxy = rate
    v[:, 0] += sign * (exx * r[:, 0] + gxy * r[:, 1] + gxz * r[:, 2])
    v[:, 1] += sign * (eyy * r[:, 1] + gyz * r[:, 2])
    v[:, 2] += sign * (ezz * r[:, 2])


def ramp(s: Session, de: np.ndarray, steps: int) -> None:
    """Apply the grainmech strain increment ``de`` (Voigt, engineering, compression positive) over ``steps`` time steps.

    The grains get the affine velocity field of the strain rate and the cell follows with
    ``fix deform ... remap v`` (grains crossing a periodic face take the face's velocity):
    the contacts' tangential springs of ``pair_style granular`` integrate the relative
    velocity, so an affine move of positions alone (``remap x``) would never load them.
    The drags are off during the ramp (they would resist the affine motion); the affine
    field is removed at the end.
    """
    rate = -np.asarray(de, float) / (steps * s.dt)  # LAMMPS: tension positive
    parts = [f"{key} erate {r:.12g}" for (key, _), r in zip(VOIGT_DEFORM, rate) if r != 0]
    if not parts:
        return
    s.undrag()
    add_affine_velocity(s, rate, 1.0)
    s.lmp.command("fix probe all deform 1 " + " ".join(parts) + " remap v")
    s.lmp.command(f"run {steps} post no")
    s.lmp.command("unfix probe")
    # the box is now fixed: remove the affine field (at the final positions)
    rate_now = rate.copy()
    add_affine_velocity(s, rate_now, -1.0)
    s.drags()
    s.steps += steps

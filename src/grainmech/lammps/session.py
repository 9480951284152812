"""DEM reference runs with LAMMPS on a packing.

DEM reference runs with LAMMPS on a packing: strain probes (the measured tangent
tensor) and quasi-static cyclic simple shear (secant G and damping).

Both start by loading the packing into LAMMPS (:func:`load_network`) and relaxing it at
fixed cell until the unbalanced force ratio is below ``tol``. LAMMPS keeps no tangential
spring history in a network file, so the tangential forces restart from zero: the
reference state is this re-equilibrated packing (its stress, void ratio and coordination
are returned, and the network too, so a comparison can use the very same state).

**Quasi-static by construction.** Strain is applied in increments: each increment is a
ramp of ``ramp_steps`` time steps (``fix deform ... remap x``, affine), after which the cell
is held and the grains relax until the unbalanced force ratio is below ``tol``. The
stress is the Love-Weber average of the contact forces at that equilibrium (seed Eq. 2.6),
so the numerical damping (``fix viscous``, ``viscous/sphere``, contact damping) changes
the path between equilibria, not the equilibria; :func:`cyclic_simple_shear` checks this
by rerunning with the ramp rate halved or the damping changed.

Sign convention: compression positive (grainmech), engineering shear strains, Voigt
order ``xx yy zz yz xz xy``; a LAMMPS tensile cell strain ``+e`` is a grainmech strain ``-e``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.analysis.loops import loop_properties
from grainmech.contact.geometry import hertz_kn, hertz_radius_from_approach
from grainmech.contact.rolling import RollingConstants
from grainmech.errors import GrainmechError
from grainmech.network import ContactNetwork, network_stress
from grainmech.packing.engine import Lammps
from grainmech.packing.prepare import (
    GrainMaterial,
    critical_time_step,
    network_from_lammps,
    setup_lammps,
    unbalanced_ratio,
)
from grainmech.packing.rolling import rolling_pair_suffix

__all__ = ["ProbeResult", "CyclicResult", "load_network", "relax", "strain_probes", "cyclic_simple_shear",
           "VOIGT_DEFORM"]

Progress = Callable[[str], None]

#: LAMMPS ``fix deform`` keyword of each Voigt component (xx yy zz yz xz xy) and the cell
#: length that converts its engineering strain into a length change
VOIGT_DEFORM = (("x", 0), ("y", 1), ("z", 2), ("yz", 2), ("xz", 2), ("xy", 1))
_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def _voigt(s: np.ndarray) -> np.ndarray:
    return np.array([s[i, j] for i, j in _VOIGT])


#: time steps between two checks of the power under kinetic damping (:meth:`_Session.advance`)
KINETIC_INTERVAL = 10


@dataclass
class _Session:
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
    #: budget (counted by :func:`grainmech.driver.dem._relax`, switched by :meth:`set_kinetic`)
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
                 rolling: RollingConstants | None = None) -> _Session:
    """Put a periodic network into LAMMPS with grainmech's granular model.

    Put a periodic network into LAMMPS with the granular model of
    :mod:`grainmech.packing.prepare` and the grain friction; set the time step
    (:func:`critical_time_step` times ``safety``) and the drags (``viscous`` times the contact
    frequency at the packing's stress; with ``cundall`` > 0 Cundall's local damping
    instead, :meth:`_Session.drags`; with ``kinetic``, kinetic damping,
    :meth:`_Session.advance`). ``rolling``: rolling and twisting resistance (LAMMPS
    ``rolling sds`` / ``twisting sds`` with the dashpots of
    :func:`grainmech.packing.rolling.rolling_damping`); the springs start from zero
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
    s = _Session(lmp, mat, dt, p, rbar, m_bar, omega, g, cundall=float(cundall), kinetic=bool(kinetic))
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


def relax(s: _Session, tol: float, max_steps: int, chunk: int = 500, *,
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
            sig = _voigt(np.asarray(network_stress(net).stress))
            scale = float(np.abs(sig - settle[0]).max())
            ok = ok and prev is not None and float(np.abs(sig - prev).max()) <= settle[1] * scale
            prev = sig
        if ok:
            return net, ub, used
        if used >= max_steps:
            p_now = float(np.trace(np.asarray(network_stress(net).stress)) / 3.0)
            raise RelaxationTimeout(f"relaxation did not reach an unbalanced force ratio of {tol:g} in "
                                    f"{max_steps} time steps (reached {ub:.3g})", ub, p_now, net)


def _add_affine_velocity(s: _Session, rate: np.ndarray, sign: float) -> None:
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


def _ramp(s: _Session, de: np.ndarray, steps: int) -> None:
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
    _add_affine_velocity(s, rate, 1.0)
    s.lmp.command("fix probe all deform 1 " + " ".join(parts) + " remap v")
    s.lmp.command(f"run {steps} post no")
    s.lmp.command("unfix probe")
    # the box is now fixed: remove the affine field (at the final positions)
    rate_now = rate.copy()
    _add_affine_velocity(s, rate_now, -1.0)
    s.drags()
    s.steps += steps


@dataclass
class ProbeResult:
    """Strain probes: the measured tangent tensor (Voigt, compression positive) [Pa]."""

    C: np.ndarray
    strain: float
    network: ContactNetwork
    stress0: np.ndarray
    unbalanced: np.ndarray
    settings: dict
    seconds: float


def strain_probes(net: ContactNetwork, mat: GrainMaterial, *, strain: float = 1e-6, tol: float = 1e-5,
                  ramp_steps: int = 2000, max_relax_steps: int = 200_000, viscous: float = 0.01,
                  settle: float = 1e-3, threads: int | None = None,
                  progress: Progress | None = None, components: Sequence[int] = range(6),
                  rolling: RollingConstants | None = None) -> ProbeResult:
    """Small-strain probes of the six strain components on a packing (module notes).

    ``components``: the strain components probed (Voigt indices; the other columns of
    ``C`` stay NaN); ``rolling``: rolling and twisting resistance (:func:`load_network`).

    Each component ``k``: from the relaxed reference state apply ``+strain`` (ramp, relax
    until the unbalanced force ratio is below ``tol`` and the stress changes over a chunk
    of 500 steps by less than ``settle`` times the probe's stress change),
    read the stress, return to the reference strain (ramp, relax). Column ``k`` of ``C`` is
    the stress change over the strain; the reference stress for each probe is the one
    measured just before it.

    Returns
    -------
    ProbeResult
        ``C`` (6, 6) [Pa] (rows: stress components; columns: strain components), the
        re-equilibrated reference network, the stress before the probes (6,) [Pa], the
        unbalanced force ratio at every equilibrium, the settings and the wall time.
    """
    say = progress or (lambda m: None)
    t0 = time.perf_counter()
    C = np.full((6, 6), np.nan)
    ubs = []
    with Lammps(threads) as lmp:
        s = load_network(lmp, net, mat, viscous=viscous, rolling=rolling)
        ref, ub, n = relax(s, tol, max_relax_steps)
        ubs.append(ub)
        say(f"  reference state relaxed in {n} steps (unbalanced {ub:.2e})")
        sig0 = _voigt(np.asarray(network_stress(ref).stress))
        base = sig0
        for k in components:
            de = np.zeros(6)
            de[k] = strain
            _ramp(s, de, ramp_steps)
            nk, ub, n = relax(s, tol, max_relax_steps, settle=(base, settle))
            ubs.append(ub)
            sk = _voigt(np.asarray(network_stress(nk).stress))
            C[:, k] = (sk - base) / strain
            _ramp(s, -de, ramp_steps)
            nb, ub, n2 = relax(s, tol, max_relax_steps, settle=(sk, settle))
            ubs.append(ub)
            base = _voigt(np.asarray(network_stress(nb).stress))
            say(f"  probe {k + 1}/6: C[{k},{k}] = {C[k, k]:.4g} Pa ({n} + {n2} relaxation steps, "
                f"{time.perf_counter() - t0:.0f} s)")
    settings = {"strain": strain, "tol": tol, "settle": settle, "ramp_steps": ramp_steps, "viscous": viscous,
                "time_step_s": s.dt, "restitution": mat.restitution,
                "rolling": None if rolling is None else rolling.source}
    return ProbeResult(C, strain, ref, sig0, np.array(ubs), settings, time.perf_counter() - t0)


@dataclass
class CyclicResult:
    """Quasi-static cyclic simple shear (``xy``) at constant volume."""

    amplitudes: np.ndarray
    G: np.ndarray
    damping: np.ndarray
    loops: list = field(default_factory=list)
    network: ContactNetwork | None = None
    settings: dict = field(default_factory=dict)
    seconds: float = 0.0


def cyclic_simple_shear(net: ContactNetwork, mat: GrainMaterial, amplitudes: Sequence[float], *,
                        n_cycles: int = 1, points_per_cycle: int = 16, tol: float = 1e-5,
                        settle: float = 1e-3, ramp_steps: int = 1000, max_relax_steps: int = 200_000,
                        viscous: float = 0.01, constant: str = "volume", normal_tol: float = 0.05,
                        threads: int | None = None, progress: Progress | None = None) -> CyclicResult:
    """Quasi-static cyclic simple shear of a packing with LAMMPS.

    Quasi-static cyclic simple shear ``gamma_xy`` at constant volume (``constant =
    "volume"``: cell lengths held) or constant normal stress (``"stress"``: ``sigma_yy``
    held at its initial value by changing the cell length ``ly`` after each increment,
    until its error is below ``normal_tol`` times the increment's shear-stress change; the
    normal stiffness for these corrections is measured once with a ``1e-6`` probe; ``lx``
    and ``lz`` held).

    For each amplitude (in increasing order, on the same packing, as in a laboratory
    staged test): ``n_cycles`` cycles ``0 -> +a -> -a -> +a`` of ``points_per_cycle``
    equal increments, each ramped over ``ramp_steps`` and relaxed to ``tol`` (and until the
    stress settles, as in :func:`strain_probes`, to ``settle`` times the increment's stress
    change). The last
    cycle gives the secant modulus and the damping ratio (:func:`grainmech.analysis.loop_properties`,
    seed/Kramer definitions) from the equilibrium shear stresses ``tau_xy`` (compression
    positive convention: ``tau = sigma_xy`` for ``gamma = gamma_xy``).
    """
    say = progress or (lambda m: None)
    t0 = time.perf_counter()
    amps = np.asarray(amplitudes, float)
    if amps.ndim != 1 or amps.size == 0 or np.any(amps <= 0):
        raise GrainmechError(f"amplitudes = {amplitudes!r}: positive values expected")
    if points_per_cycle % 4:
        raise GrainmechError(f"points_per_cycle = {points_per_cycle}: must be a multiple of 4")
    if constant not in ("volume", "stress"):
        raise GrainmechError(f"constant = {constant!r}: must be 'volume' or 'stress'")
    G, D, loops, vol = [], [], [], []
    with Lammps(threads) as lmp:
        s = load_network(lmp, net, mat, viscous=viscous)
        ref, ub, n = relax(s, tol, max_relax_steps)
        say(f"  reference state relaxed in {n} steps (unbalanced {ub:.2e})")
        tau0 = float(np.asarray(network_stress(ref).stress)[0, 1])
        syy0 = float(np.asarray(network_stress(ref).stress)[1, 1])
        V0 = ref.volume
        M = 0.0
        if constant == "stress":  # normal stiffness d sigma_yy / d eps_yy, measured
            de = np.zeros(6)
            de[1] = 1e-6
            _ramp(s, de, ramp_steps)
            n1, _, _ = relax(s, tol, max_relax_steps, settle=(_voigt(np.asarray(network_stress(ref).stress)), settle))
            M = (float(np.asarray(network_stress(n1).stress)[1, 1]) - syy0) / 1e-6
            _ramp(s, -de, ramp_steps)
            relax(s, tol, max_relax_steps)
        g_now = 0.0
        for a in amps:
            q = points_per_cycle // 4
            path = list(np.linspace(0, a, q + 1)[1:])
            for _ in range(n_cycles):
                path += list(np.linspace(a, -a, 2 * q + 1)[1:]) + list(np.linspace(-a, a, 2 * q + 1)[1:])
            gam, tau = [], []
            base = _voigt(np.asarray(network_stress(ref).stress))
            for g in path:
                de = np.zeros(6)
                de[5] = g - g_now
                _ramp(s, de, ramp_steps)
                g_now = g
                nk, ub, n = relax(s, tol, max_relax_steps, settle=(base, settle))
                if constant == "stress":
                    scale = abs(float(np.asarray(network_stress(nk).stress)[0, 1]) - base[5])
                    for _ in range(20):
                        err = float(np.asarray(network_stress(nk).stress)[1, 1]) - syy0
                        if abs(err) <= normal_tol * max(scale, 1e-12 * syy0):
                            break
                        dn = np.zeros(6)
                        dn[1] = -err / M
                        _ramp(s, dn, ramp_steps)
                        nk, ub, n = relax(s, tol, max_relax_steps, settle=(base, settle))
                    else:
                        raise GrainmechError(f"constant normal stress: sigma_yy not held at gamma = {g:.3g} "
                                             f"(error {err:.3g} Pa after 20 corrections)")
                base = _voigt(np.asarray(network_stress(nk).stress))
                vol.append(nk.volume / V0 - 1.0)
                gam.append(g)
                tau.append(float(np.asarray(network_stress(nk).stress)[0, 1]) - tau0)
            last = slice(len(path) - 4 * q - 1, len(path))
            lp = loop_properties(np.array(gam[last]), np.array(tau[last]))
            G.append(lp.secant_modulus)
            D.append(lp.damping)
            loops.append((np.array(gam), np.array(tau)))
            say(f"  amplitude {a:.3g}: G = {lp.secant_modulus:.5g} Pa, damping {lp.damping:.4f} "
                f"({time.perf_counter() - t0:.0f} s)")
    settings = {"n_cycles": n_cycles, "points_per_cycle": points_per_cycle, "tol": tol, "settle": settle,
                "ramp_steps": ramp_steps, "constant": constant, "normal_stiffness_Pa": M,
                "volume_change_max": float(np.abs(vol).max()) if vol else 0.0,
                "viscous": viscous, "time_step_s": s.dt, "restitution": mat.restitution}
    return CyclicResult(amps, np.array(G), np.array(D), loops, ref, settings, time.perf_counter() - t0)

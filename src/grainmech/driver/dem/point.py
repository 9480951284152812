"""The DEM model's material point: a packing in LAMMPS at an equilibrium state (:mod:`grainmech.driver.dem`).

:class:`DemPoint` takes one mixed-control step at a time: step and relax (ramp, relax,
servo corrections with a Broyden-learned stiffness) or, with ``protocol = "continuous"``,
one increment of continuous shearing (:mod:`grainmech.driver.dem.flow`).
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.contact.rolling import RollingConstants, RollingResistance, moment_energy, rolling_constants
from grainmech.driver.base import Status, StepFailure
from grainmech.driver.dem.flow import FlowState, deform_command, flow_increment, inertial_number, shear_rate
from grainmech.driver.dem.mpi import Tick
from grainmech.driver.dem.settings import DemSettings, dem_material
from grainmech.errors import GrainmechError, ParameterError
from grainmech.lammps.engine import Lammps
from grainmech.lammps.granular import GrainMaterial, resume_lammps
from grainmech.lammps.network import network_from_lammps, unbalanced_ratio
from grainmech.lammps.rolling import ROLLING_DAMPING, rolling_pair_suffix
from grainmech.lammps.session import RelaxationTimeout, Session, load_network, ramp, relax, voigt
from grainmech.network import ContactNetwork, network_stress
from grainmech.network.measures import contact_stiffnesses, coordination
from grainmech.network.relaxed import relaxed_stiffness

__all__ = ["DemPoint", "PRESSURE_TOLERANCE", "dem_rolling", "rolling_note", "rolling_energy"]

#: relative difference between a packing's mean stress and the run's pressure below which
#: the packing is used as it is (as the packing model's ``PACKING_STRESS_TOLERANCE``)
PRESSURE_TOLERANCE = 5e-3
def _sliding(net: ContactNetwork, mu: float) -> float:
    """Fraction of contacts at the Coulomb limit ``|T| >= (1 - 1e-6) mu N``."""
    if net.n_contacts == 0:
        return 0.0
    N = np.asarray(net.normal_force, float)
    T = np.linalg.norm(np.asarray(net.force, float) - N[:, None] * np.asarray(net.normals, float), axis=1)
    return float(np.mean(T >= (1.0 - 1e-6) * mu * np.maximum(N, 0.0)))


def _pairs(net: ContactNetwork) -> set:
    ids = np.asarray(net.ids, np.int64)
    a, b = ids[net.i], ids[net.j]
    return set(zip(np.minimum(a, b).tolist(), np.maximum(a, b).tolist()))


class DemPoint:
    """A packing in LAMMPS at an equilibrium state (a live simulation: it moves forward only).

    Open with :meth:`start` (or as a context manager); :meth:`step` advances it one
    mixed-control step (the :class:`~grainmech.driver.base.SteppingPoint` contract) and
    returns itself; :meth:`close` ends the LAMMPS instance.
    """

    def __init__(self, lmp: Lammps, session: Session, net: ContactNetwork, unbalanced: float,
                 settings: DemSettings, material: GrainMaterial, tick: Tick | None,
                 rolling: RollingConstants | None = None) -> None:
        self._lmp = lmp
        self._s = session
        self.settings = settings
        self.material = material
        #: the rolling and twisting resistance LAMMPS runs (None: none)
        self.rolling = rolling
        self._tick = tick
        self.reference = net
        self.strain = np.zeros(6)
        self.notes: list[str] = []
        self._vol_start = 0.0
        self.corrections = 0
        self._set(net, unbalanced)
        self.p0 = float(np.mean(self.stress[:3]))
        if not self.p0 > 0:
            raise GrainmechError("the DEM packing carries no compressive stress after relaxation")
        self._pairs0 = _pairs(net)
        self.n_contacts0 = net.n_contacts
        self.elastic_tangent = self._relaxed(net)
        self._K = self.elastic_tangent.copy()
        self.mean_radius = float(np.mean(net.require_radii("the DEM model")))
        self._flow: FlowState | None = None  # the continuous protocol's cell rate and servo estimate
        self.inertial = 0.0  # inertial number of the last increment (continuous protocol)

    # -- construction -------------------------------------------------------------------
    @classmethod
    def start(cls, net: ContactNetwork, law: Any, settings: DemSettings | None = None, *,
              pressure: float | None = None, tick: Tick | None = None,
              rolling: RollingResistance | None = None) -> DemPoint:
        """Load ``net`` into LAMMPS with the grains of ``law`` and relax it to equilibrium.

        LAMMPS keeps no tangential spring history from a network file: the tangential
        forces restart from zero and the packing re-settles at fixed cell. With
        ``pressure`` [Pa], the packing is then brought to that isotropic stress (the
        normal stresses servo-controlled, the shear strains held; a packing's stress
        changes when the law's grain moduli differ from those it was made with) if its
        mean stress differs by more than :data:`PRESSURE_TOLERANCE`. The start state, strain
        zero, is that equilibrium (its stress, contacts and unbalanced force ratio are the
        first recorded row). ``rolling``: rolling and twisting resistance, resolved on
        ``net``'s contacts (:func:`dem_rolling`; :mod:`grainmech.driver.dem`).
        """
        st = settings or DemSettings()
        mat, _ = dem_material(law)
        if pressure is not None and not (math.isfinite(pressure) and pressure > 0):
            raise ParameterError("pressure", pressure, "must be a finite stress > 0")
        consts = dem_rolling(rolling, law, net)
        lmp = Lammps(st.threads)
        try:
            s = load_network(lmp, net, mat, viscous=st.viscous, safety=st.safety,
                             cundall=st.cundall if st.damping == "cundall" else 0.0,
                             kinetic=st.damping == "kinetic", rolling=consts)
            ref, ub = _relax(s, st, None, tick)
            pt = cls(lmp, s, ref, ub, st, mat, tick, consts)
            if consts is not None:
                pt.notes.append(rolling_note(consts))
            springs = "tangential spring history" if consts is None else "tangential or moment spring history"
            pt.notes.append(f"LAMMPS keeps no {springs} from a network file: the packing "
                            f"re-settled at fixed cell (unbalanced force ratio {pt.unbalanced:.2g}, "
                            f"{pt.network.n_contacts} contacts, mean stress {pt.p0:.5g} Pa)")
            if lmp.ranks > 1:
                pt.notes.append(f"LAMMPS ran on {lmp.ranks} MPI ranks (domain decomposition)")
            if pressure is not None and abs(pt.p0 / pressure - 1.0) > PRESSURE_TOLERANCE:
                p_before = pt.p0
                sc = np.array([True, True, True, False, False, False])
                target = np.where(sc, float(pressure), 0.0)
                try:
                    pt.step(np.zeros(6), sc, target)
                except StepFailure as exc:
                    raise GrainmechError(f"bringing the DEM packing from p = {p_before:.5g} Pa to {pressure:.5g} Pa "
                                         f"failed: {exc.cause}") from None
                pt._restart_here()
                pt.notes.append(f"brought from p = {p_before:.5g} Pa to {pt.p0:.5g} Pa (isotropic, normal stresses "
                                f"servo-controlled; volumetric strain {pt._vol_start:.3g})")
            return pt
        except BaseException:
            lmp.close()
            raise

    # -- saved and taken up (grainmech run --resume) ---------------------------------------
    def saved_state(self) -> dict:
        """A picklable copy of this state: LAMMPS' restart file and the point's own state.

        The restart file keeps the cell, the grains and the contacts' spring history;
        the point keeps its reference network, strain, servo stiffness, flow state and
        counters, the session its time step, drags and counters. :meth:`resumed` takes it
        up in a new LAMMPS instance. On several MPI ranks every rank calls it (LAMMPS' rank 0
        writes the file: only its state holds it, :mod:`grainmech.driver.dem.mpi`).
        """
        with tempfile.TemporaryDirectory(prefix="grainmech-dem-") as d:
            f = Path(d) / "state.restart"
            self._lmp.command(f"write_restart {f.as_posix()}")
            data = f.read_bytes() if f.exists() else b""  # on several MPI ranks rank 0 writes the file
        s = self._s
        return {"restart": data, "point": {k: v for k, v in vars(self).items() if k not in ("_lmp", "_s", "_tick")},
                "session": {f.name: getattr(s, f.name) for f in fields(s) if f.name != "lmp"},
                "drags": self._lmp.has_id("fix", "drag"), "flowing": self._lmp.has_id("fix", "flow")}

    @classmethod
    def resumed(cls, state: dict, settings: DemSettings, tick: Tick | None = None) -> DemPoint:
        """The point of :meth:`saved_state` in a new LAMMPS instance, going on as the saved one would."""
        lmp = Lammps(settings.threads)
        try:
            sess = dict(state["session"])
            pt = cls.__new__(cls)
            vars(pt).update(state["point"])
            mat = sess["mat"]
            with tempfile.TemporaryDirectory(prefix="grainmech-dem-") as d:
                f = Path(d) / "state.restart"
                f.write_bytes(state["restart"])
                resume_lammps(lmp, f.as_posix(), mat, mat.friction, sess["dt"],
                              rolling_pair_suffix(pt.rolling, sess["rbar"], mat.density))
            lmp.command("thermo 100")
            power = sess.pop("_power", False)
            s = Session(lmp, **sess)
            if power:
                s.define_power()
            if state["drags"]:
                s.drags()
            if state["flowing"] and pt._flow is not None:
                cmd = deform_command(pt._flow.rate)
                if cmd is not None:
                    lmp.command(cmd)
            lmp.command("run 0 post no")  # forces and virial of the restored state (read before the next run)
            pt._lmp, pt._s, pt._tick = lmp, s, tick
            return pt
        except BaseException:
            lmp.close()
            raise

    def _restart_here(self) -> None:
        """Make the current state the start state (strain zero, contact bookkeeping, tangent)."""
        self._vol_start = float(np.sum(self.strain[:3]))
        self.strain = np.zeros(6)
        self.reference = self.network
        self.p0 = float(np.mean(self.stress[:3]))
        self._pairs0 = _pairs(self.network)
        self.n_contacts0 = self.network.n_contacts
        self.elastic_tangent = self._relaxed(self.network)
        self._K = self.elastic_tangent.copy()

    def close(self) -> None:
        """End the LAMMPS instance (idempotent)."""
        self._lmp.close()

    def __enter__(self) -> DemPoint:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- state --------------------------------------------------------------------------
    def _set(self, net: ContactNetwork, unbalanced: float) -> None:
        self.network = net
        self.stress = voigt(np.asarray(network_stress(net).stress))
        self.unbalanced = float(unbalanced)
        self.coordination = float(coordination(net).z)

    def _relaxed(self, net: ContactNetwork) -> np.ndarray:
        """Relaxed small-strain tensor of ``net`` with the Hertz-Mindlin no-slip stiffnesses (Voigt) [Pa].

        With rolling resistance, its elastic moment springs too (``relaxed_stiffness(rolling=)``).
        """
        kn, ks, _ = contact_stiffnesses(net, shear_modulus=self.material.shear_modulus,
                                        poisson=self.material.poisson, source="overlap")
        try:
            return np.asarray(relaxed_stiffness(net, kn, ks, rolling=self.rolling).C_relaxed, float)
        except GrainmechError as exc:
            raise GrainmechError(f"the relaxed DEM packing is not mechanically stable: {exc}") from None

    def fractions(self) -> tuple[float, float]:
        """Sliding fraction of the contacts and fraction of the start state's contacts now open."""
        lost = len(self._pairs0 - _pairs(self.network))
        return _sliding(self.network, self.material.friction), lost / max(self.n_contacts0, 1)

    def stored_energy(self) -> float:
        """Elastic energy per unit volume in the contacts [Pa].

        Hertz normal ``(2/5) N alpha`` (seed Eq. 3.2) plus the tangential spring's
        ``|T|^2 / (2 k_t)`` with ``k_t = 8 G* a`` (Mindlin 1949, seed Eq. 3.11-3.12), plus,
        with rolling resistance, the moment springs' ``|M_r|^2 / (2 k_roll R*^2) +
        M_t^2 / (2 k_twist)`` (:mod:`grainmech.contact.rolling`).
        """
        net = self.network
        if net.n_contacts == 0:
            return 0.0
        f = np.asarray(net.force, float)
        N = np.maximum(np.asarray(net.normal_force, float), 0.0)
        T2 = np.einsum("ij,ij->i", f, f) - N ** 2
        alpha = np.maximum(np.asarray(net.overlap, float), 0.0) if net.overlap is not None else np.zeros(len(N))
        _, ks, _ = contact_stiffnesses(net, shear_modulus=self.material.shear_modulus,
                                       poisson=self.material.poisson, source="overlap")
        e = 0.4 * N * alpha + np.where(ks > 0, np.maximum(T2, 0.0) / (2.0 * np.where(ks > 0, ks, 1.0)), 0.0)
        if self.rolling is not None and net.moment is not None:
            e = e + rolling_energy(self.rolling, net)
        return float(np.sum(e) / net.volume)

    # -- one step -----------------------------------------------------------------------
    def _apply(self, de: np.ndarray, base: np.ndarray, sc: np.ndarray) -> None:
        """Ramp the strain increment ``de`` and relax until equilibrium (:func:`_relax`).

        The ramp takes ``ramp_steps`` time steps, or more so that no time step takes more
        than ``max_ramp_strain``; the relaxation's stress criterion is relative to the
        change since ``base`` (the stress where the step began). In a step whose normal
        stresses are all strain-controlled (``sc``, the step's stress-control mask) a mean
        stress at ``r_u >= liquefaction`` ends the path (liquefaction); when the servo holds
        a normal stress, a collapsed state (the servo expanded too far) is handed back to
        the servo, which compresses it again.
        """
        n = max(self.settings.ramp_steps, int(math.ceil(float(np.abs(de).max()) / self.settings.max_ramp_strain)))
        ramp(self._s, de, n)
        self.strain = self.strain + de
        servo = bool(sc[:3].any())
        net, ub = _relax(self._s, self.settings, base, self._tick, self.p0, servo)
        self._set(net, ub)
        p = float(np.mean(self.stress[:3]))
        if not servo and p <= (1.0 - self.settings.liquefaction) * self.p0:
            raise StepFailure(_liquefied(p, self.p0, "in equilibrium"), Status.LIQUEFIED)

    @property
    def session(self) -> Session:
        """The LAMMPS session this point runs in (:mod:`grainmech.lammps.session`)."""
        return self._s

    @property
    def fallbacks(self) -> int:
        """Relaxations finished under kinetic damping after the drags ran out of budget (``fallback``)."""
        return int(self._s.fallbacks)

    @property
    def relax_steps(self) -> int:
        """LAMMPS time steps run so far (ramps and relaxations)."""
        return int(self._s.steps)

    def step(self, d_strain: np.ndarray, stress_control: np.ndarray, target: np.ndarray) -> DemPoint:
        """Apply one mixed-control step (:mod:`grainmech.driver.dem`); returns ``self``.

        Raises
        ------
        StepFailure
            When a relaxation exceeds ``max_relax_steps`` or the servo does not bring the
            stress-controlled components to ``target`` within ``max_corrections``.
        """
        sc = np.asarray(stress_control, bool)
        d_e = np.where(sc, 0.0, np.asarray(d_strain, float))
        target = np.asarray(target, float)
        start = self.stress.copy()
        st = self.settings
        if st.protocol == "continuous":
            try:
                self._flow_step(d_e, sc, target)
            except GrainmechError as exc:
                raise exc if isinstance(exc, StepFailure) else StepFailure(str(exc)) from None
            p = float(np.mean(self.stress[:3]))
            if not sc[:3].any() and p <= (1.0 - st.liquefaction) * self.p0:
                raise StepFailure(_liquefied(p, self.p0, "while shearing continuously"), Status.LIQUEFIED)
            return self
        try:
            n_sub = self._substeps(d_e, sc, target, start)
            for i in range(1, n_sub):
                # intermediate substeps: the predictor only (the next one corrects what is left)
                self._predict(d_e / n_sub, sc, start + (target - start) * i / n_sub, start)
            self._predict(d_e / n_sub, sc, target, start)
            if not sc.any():
                return self
            for _ in range(st.max_corrections):
                err = target[sc] - self.stress[sc]
                change = float(np.abs(self.stress[~sc] - start[~sc]).max(initial=0.0))
                p = float(np.mean(self.stress[:3]))
                scale = max(change, 1e-3 * abs(p))
                if float(np.abs(err).max()) <= st.stress_tol * scale and self.unbalanced < st.tol:
                    return self
                dx = np.zeros(6)
                dx[sc] = np.linalg.solve(self._K[np.ix_(sc, sc)], err)
                before = self.stress.copy()
                self.corrections += 1
                self._apply(dx, start, sc)
                self._broyden(sc, dx, self.stress - before)
            raise StepFailure(f"the stress-controlled components were not held within {st.stress_tol:g} "
                              f"of the step's stress change after {st.max_corrections} servo corrections "
                              f"(error {float(np.abs(target[sc] - self.stress[sc]).max()):.3g} Pa)")
        except GrainmechError as exc:
            if isinstance(exc, StepFailure):
                raise
            raise StepFailure(str(exc)) from None

    def _flow_step(self, d_e: np.ndarray, sc: np.ndarray, target: np.ndarray) -> None:
        """One recorded increment by the continuous protocol (:mod:`grainmech.driver.dem.flow`).

        The cell is sheared through ``d_e`` (strain-controlled components) at the rate of the
        settings' inertial number at the mean stress of the increment's start, the
        stress-controlled components ``sc`` servo-held on their path from the last recorded
        stress to ``target``; the state reached is read from LAMMPS (contacts, unbalanced
        force ratio, the increment's largest inertial number in :attr:`inertial`).
        """
        st = self.settings
        s = self._s
        if self._flow is None:
            self._flow = FlowState.at_rest(self._K)
        start = self.stress.copy()
        p = float(np.mean(start[:3]))
        if not p > 0:
            raise StepFailure(f"the packing carries no compressive stress (p = {p:.3g} Pa): no inertial number",
                              Status.FAILED)
        d = 2.0 * self.mean_radius
        rho = self.material.density
        out = flow_increment(s, self._flow, d_e, sc, start, target, shear_rate(st.inertial_number, d, rho, p),
                             st.servo_interval, max(st.min_flow_steps, self._wave_steps()))
        self.strain = self.strain + out["strain"]
        net = network_from_lammps(s.lmp)
        self._set(net, unbalanced_ratio(net))
        p_now = float(np.mean(self.stress[:3]))
        self.inertial = inertial_number(out["rate"], d, rho, max(min(p, p_now), 1e-300))
        if self._tick is not None:
            self._tick(s.steps, self.unbalanced)

    def _wave_steps(self) -> int:
        """Time steps of ``wave_crossings`` shear-wave crossings of the cell (:class:`DemSettings`).

        ``v_s = sqrt(G / rho)`` with the start state's small-strain shear modulus (the mean
        of the relaxed tensor's shear diagonal) and the packing's bulk density
        ``rho_s V_s / V``; the crossing length is the longest cell edge.
        """
        net = self.reference
        C = self.elastic_tangent
        G = float(np.mean(np.diag(C)[3:]))
        R = net.require_radii("the DEM model")
        rho = self.material.density * float(np.sum(4.0 / 3.0 * np.pi * R ** 3)) / net.volume
        L = float(np.max(np.linalg.norm(np.asarray(net.box.cell, float), axis=1)))
        if not (G > 0 and rho > 0):
            return 0
        return int(math.ceil(self.settings.wave_crossings * L / math.sqrt(G / rho) / self._s.dt))

    def _substeps(self, d_e: np.ndarray, sc: np.ndarray, target: np.ndarray, start: np.ndarray) -> int:
        """Substeps of a step: the stress change the estimate predicts, over ``max_stress_step`` of p.

        A mixed-control step that would change the stress by more than ``max_stress_step``
        times the mean stress (a large plastic increment, or a stress target far away) is
        applied in that many substeps, so that the servo follows the path instead of
        overshooting it and unloading the packing. Strain-controlled steps are not split.
        """
        if not sc.any():  # strain control: nothing to overshoot
            return 1
        de = self._prediction(d_e, sc, target, start)
        p = abs(float(np.mean(start[:3])))
        size = float(np.abs(self._K @ de).max()) / (self.settings.max_stress_step * p) if p > 0 else 1.0
        return int(min(max(1, math.ceil(size)), self.settings.max_substeps))

    def _prediction(self, d_e: np.ndarray, sc: np.ndarray, target: np.ndarray, now: np.ndarray) -> np.ndarray:
        """Strain increment whose stress-controlled part the estimate says reaches ``target``."""
        de = d_e.copy()
        if sc.any():
            K = self._K
            de[sc] = np.linalg.solve(K[np.ix_(sc, sc)], target[sc] - now[sc] - K[np.ix_(sc, ~sc)] @ d_e[~sc])
        return de

    def _predict(self, d_e: np.ndarray, sc: np.ndarray, target: np.ndarray, start: np.ndarray) -> None:
        """Apply the predicted increment towards ``target`` and learn from the response.

        The relaxation's stress criterion is relative to the change since the step began
        at ``start`` (as for the corrections: :attr:`DemSettings.settle`).
        """
        before = self.stress.copy()
        de = self._prediction(d_e, sc, target, before)
        self._apply(de, start, sc)
        if sc.any():
            self._broyden(sc, de, self.stress - before)

    def _broyden(self, sc: np.ndarray, s_vec: np.ndarray, y_vec: np.ndarray) -> None:
        """Broyden's rank-one update of the stiffness estimate from an observed response.

        ``K += (y - K s) s^T / (s^T s)`` with the applied strain ``s`` (6,) and the observed
        stress change ``y`` (6,): the estimate then reproduces the last response exactly,
        couplings included (a packing in plastic flow answers an axial step with far less
        lateral stress than its elastic tensor). The update is skipped when the response is
        not an equilibrium (a collapsed relaxation handed back to the servo says nothing of
        the stiffness) and when it would make a diagonal term of the stress-controlled block
        small or negative (the servo would be sent away).
        """
        ss = float(s_vec @ s_vec)
        if ss <= 0 or not self.unbalanced < self.settings.tol:
            return
        new = self._K + np.outer(y_vec - self._K @ s_vec, s_vec) / ss
        d_new, d_old = np.diag(new)[sc], np.diag(self._K)[sc]
        if np.all(d_new > 1e-3 * d_old) and np.all(np.isfinite(new)):
            self._K = new


def dem_rolling(rolling: RollingResistance | None, law: Any, net: ContactNetwork) -> RollingConstants | None:
    """The rolling constants LAMMPS runs on ``net`` (None without rolling resistance).

    :func:`~grainmech.contact.rolling.rolling_constants` on the packing's contacts: their
    normal forces and effective radii ``R* = R_A R_B / (R_A + R_B)``.
    """
    if rolling is None or not rolling.active:
        return None
    return rolling_constants(rolling, law, net.normal_force, net.effective_radii("rolling resistance"))


def rolling_note(consts: RollingConstants) -> str:
    """The run note of the rolling resistance LAMMPS ran: its constants and where ``k_roll`` came from."""
    twist = (f"twisting sds k_twist = {consts.k_twist:.4g} N m/rad, cap {consts.twist_cap:.4g} m x N"
             if consts.twist_cap > 0 else "no twisting resistance")
    roll = f"mu_r = {consts.mu_roll:g}" if consts.mu_roll > 0 else "no rolling resistance (mu_r = 0)"
    return (f"rolling resistance (LAMMPS rolling sds / twisting sds): {roll}, {consts.source}; {twist}; "
            f"dashpots at {ROLLING_DAMPING:g} of critical damping (they act on spins only, not on the "
            "recorded equilibria); the moment springs start from zero")


def rolling_energy(consts: RollingConstants, net: ContactNetwork) -> np.ndarray:
    """Elastic energy in the contacts' moment springs of ``net`` (C,) [energy].

    :func:`~grainmech.contact.rolling.moment_energy` with the network's moments, normals and
    effective radii.
    """
    if net.moment is None:
        raise GrainmechError(f"{net.source or 'network'}: rolling energy needs the contact moments")
    return moment_energy(consts, net.moment, net.normals, net.effective_radii("rolling energy"))


def _liquefied(p: float, p0: float, how: str) -> str:
    """The message of a liquefied path: the mean stress reached and the pore-pressure ratio."""
    return (f"liquefied: the mean stress fell to {p:.4g} Pa ({100 * p / p0:.2g} % of p0 = {p0:.5g} Pa, pore-pressure "
            f"ratio r_u = {1 - p / p0:.3f}; {how}): at this volume the grains hold no load-bearing network, "
            "the test's answer rather than a numerical failure")


def _relax(s: Session, st: DemSettings, base: np.ndarray | None, tick: Tick | None,
           p0: float | None = None, servo: bool = False) -> tuple[ContactNetwork, float]:
    """:func:`grainmech.lammps.session.relax` with the settings, progress ticks and one error type.

    The relaxation is checked every ``20 chunk`` time steps: one that has not reached
    equilibrium by then with its mean stress at most ``(1 - liquefaction) p0`` ends the path
    as liquefied (:attr:`~grainmech.driver.base.Status.LIQUEFIED`,
    ``DemSettings.liquefaction``) instead of spending the rest of ``max_relax_steps``
    looking for an equilibrium with contacts that the volume does not allow. With ``servo``
    (a normal stress is servo-controlled) that state is returned instead, out of balance,
    for the servo to correct (it never becomes a recorded state: the servo accepts only
    equilibria).
    """
    used, limit, fell_back = 0, st.max_relax_steps, False
    try:
        while True:
            budget = min(limit - used, 20 * st.chunk)
            try:
                net, ub, n = relax(s, st.tol, budget, st.chunk,
                                   settle=None if base is None else (base, st.settle))
                used += n
                if tick is not None:
                    tick(s.steps, ub)
                return net, ub
            except RelaxationTimeout as exc:
                used += budget
                if tick is not None:  # still relaxing: the ratio reached so far
                    tick(s.steps, float(exc.reached))
                if p0 is not None and exc.mean_stress <= (1.0 - st.liquefaction) * p0:
                    if servo and exc.network is not None:
                        return exc.network, exc.reached
                    raise StepFailure(_liquefied(exc.mean_stress, p0, f"no equilibrium with contacts after {used} "
                                                 f"time steps of relaxation, unbalanced force ratio "
                                                 f"{exc.reached:.3g}"), Status.LIQUEFIED) from None
                if used < limit:
                    continue
                if st.fallback and not s.kinetic:
                    # the drags' budget is spent: kinetic damping goes on for as many time steps
                    s.set_kinetic(True)
                    s.fallbacks += 1
                    fell_back, limit = True, limit + st.max_relax_steps
                    continue
                more = (f" under the {st.damping} damping and as many more under kinetic damping (fallback)"
                        if fell_back else "")
                raise StepFailure(f"no equilibrium within max_relax_steps = {st.max_relax_steps} time "
                                  f"steps{more}: the unbalanced force ratio was {exc.reached:.3g} at the end, "
                                  f"tol = {st.tol:g}") from None
    finally:
        if fell_back:  # the next ramp and relaxation have the drags again
            s.set_kinetic(False)

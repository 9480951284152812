"""The DEM model: the run's test done by LAMMPS on the same grains, quasi-statically.

Where the packing model keeps the reference geometry fixed, the DEM model lets LAMMPS
(``pair_style granular``: Hertz normal force, Mindlin no-slip tangential spring
``k_t = 8 G* a`` capped by Coulomb friction, Mindlin 1949) move the grains: contacts form
and break, grains rearrange, the packing can dilate, contract, fail and liquefy.

**Quasi-static by construction** (as the DEM reference runs of
:mod:`grainmech.packing.reference`, whose functions it uses). A step of a path is a strain
increment applied as a ramp of ``ramp_steps`` time steps with the affine velocity field
(the cell follows with ``fix deform ... remap v``, so the tangential springs see the
affine part of the motion), after which the cell is held and the grains relax (viscous
drags by default, ``DemSettings.damping``) until (a) the unbalanced force ratio is below
``tol`` and (b) the Love-Weber stress (seed Eq. 2.6) changes over a chunk of ``chunk``
steps by less than ``settle`` times its change over the step. Only these equilibrium
states are recorded; on a dense packing the damping and the ramp rate change the path
between them, not the states, while on a loose one the equilibrium a step ends in depends
on the dynamics that lead to it (``docs/dem-model.md`` measures both). At constant volume
a path that loses its mean stress ends as liquefied (``DemSettings.liquefaction``).

**Mixed control.** Stress-controlled components (``sigma_zz`` at constant normal stress,
the lateral stresses of a drained triaxial test) are held by a servo on the cell: the
strain of those components is predicted with a stiffness estimate (the relaxed tensor of
the start state, :func:`grainmech.network.relaxed_stiffness`), applied with the step's
strain increment, then corrected (ramp + relax again, the estimate updated by Broyden's
rule from each observed response) until the stress error is below ``stress_tol`` times
the step's stress change (at least ``1e-3`` of the mean stress). A step whose servo or
relaxation does not converge within its budget raises
:class:`~grainmech.driver.base.StepFailure`; the path keeps what was done.

**Rolling and twisting resistance** (``rolling``, :mod:`grainmech.contact.rolling`): the
constants are resolved once on the start packing's contacts
(:func:`~grainmech.contact.rolling.rolling_constants`: ``k_roll`` tied to the Mindlin
stiffness at their mean normal force and mean effective radius unless given) and LAMMPS
runs them as ``rolling sds`` / ``twisting sds`` in the ``pair_coeff``, with dashpots of half
the critical damping of a grain rocking on one contact
(:func:`grainmech.packing.rolling.rolling_damping`; they act on spins only, so the recorded
equilibria do not depend on them). The moment springs start from zero, as the tangential
ones do; every recorded state carries the contact moments read from LAMMPS
(:func:`~grainmech.packing.prepare.network_from_lammps`), which enter the unbalanced force
ratio, the stored energy and the relaxed tensor of the start state.

Strains are the sum of the increments (for large strains the natural strain of the cell);
compression positive, engineering shears, Voigt order ``xx yy zz yz xz xy``.
"""

from __future__ import annotations

import ctypes
import math
import multiprocessing as mp
import os
import queue
import signal
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.analysis.loops import ModulusReduction, condensed_modulus
from grainmech.contact.rolling import RollingConstants, RollingResistance, rolling_constants
from grainmech.driver._dem_flow import flow_step
from grainmech.driver.base import DriverResult, Status, StepFailure
from grainmech.driver.dem_mpi import Tick, run_dem_ranks
from grainmech.driver.dem_settings import DAMPINGS, DEFAULT_DENSITY, PROTOCOLS, DemSettings, dem_material
from grainmech.driver.loop import cyclic_series, follow_path
from grainmech.driver.paths import LoadPath, cyclic_simple_shear
from grainmech.errors import GrainmechError, ParameterError
from grainmech.network import ContactNetwork, network_stress
from grainmech.network.measures import contact_stiffnesses, coordination
from grainmech.network.relaxed import relaxed_stiffness
from grainmech.packing.engine import Lammps, mpi_world_size
from grainmech.packing.prepare import GrainMaterial
from grainmech.packing.reference import RelaxationTimeout, _ramp, _Session, _voigt, load_network, relax
from grainmech.packing.rolling import ROLLING_DAMPING

__all__ = ["DemSettings", "DemPoint", "DemResult", "DemSeries", "dem_material", "run_dem", "dem_modulus_reduction",
           "DEM_MAX_AMPLITUDE", "DAMPINGS", "DEFAULT_DENSITY", "PROTOCOLS"]

#: largest cyclic amplitude the DEM model accepts (cells tilt; beyond it a simple-shear
#: cell of a 2000-grain packing is too thin for the shear band)
DEM_MAX_AMPLITUDE = 0.05
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

    def __init__(self, lmp: Lammps, session: _Session, net: ContactNetwork, unbalanced: float,
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
        self._flow = None  # the continuous protocol's cell rate and servo estimate
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
        ``net``'s contacts (:func:`dem_rolling`; module notes).
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
        self.stress = _voigt(np.asarray(network_stress(net).stress))
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
        _ramp(self._s, de, n)
        self.strain = self.strain + de
        servo = bool(sc[:3].any())
        net, ub = _relax(self._s, self.settings, base, self._tick, self.p0, servo)
        self._set(net, ub)
        p = float(np.mean(self.stress[:3]))
        if not servo and p <= (1.0 - self.settings.liquefaction) * self.p0:
            raise StepFailure(_liquefied(p, self.p0, "in equilibrium"), Status.LIQUEFIED)

    @property
    def relax_steps(self) -> int:
        """LAMMPS time steps run so far (ramps and relaxations)."""
        return int(self._s.steps)

    def step(self, d_strain: np.ndarray, stress_control: np.ndarray, target: np.ndarray) -> DemPoint:
        """Apply one mixed-control step (module notes); returns ``self``.

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
                flow_step(self, d_e, sc, target)
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
    R = net.require_radii("rolling resistance")
    Rs = R[net.i] * R[net.j] / (R[net.i] + R[net.j])
    return rolling_constants(rolling, law, net.normal_force, Rs)


def rolling_note(consts: RollingConstants) -> str:
    """The run note of the rolling resistance LAMMPS ran: its constants and where ``k_roll`` came from."""
    twist = (f"twisting sds k_twist = {consts.k_twist:.4g} N m/rad, cap {consts.twist_cap:.4g} m x N"
             if consts.twist_cap > 0 else "no twisting resistance")
    roll = f"mu_r = {consts.mu_roll:g}" if consts.mu_roll > 0 else "no rolling resistance (mu_r = 0)"
    return (f"rolling resistance (LAMMPS rolling sds / twisting sds): {roll}, {consts.source}; {twist}; "
            f"dashpots at {ROLLING_DAMPING:g} of critical damping (they act on spins only, not on the "
            "recorded equilibria); the moment springs start from zero")


def rolling_energy(consts: RollingConstants, net: ContactNetwork) -> np.ndarray:
    """Elastic energy in the contacts' moment springs (C,) [energy].

    ``|M_r|^2 / (2 k_roll R*^2) + M_t^2 / (2 k_twist)`` with ``M_t = M . n`` and
    ``M_r = M - M_t n`` (the springs of :func:`~grainmech.contact.rolling.rolling_update`).
    """
    M = np.asarray(net.moment, float)
    n = np.asarray(net.normals, float)
    R = net.require_radii("rolling energy")
    Rs = R[net.i] * R[net.j] / (R[net.i] + R[net.j])
    mt = np.einsum("ci,ci->c", M, n)
    mr2 = np.maximum(np.einsum("ci,ci->c", M, M) - mt * mt, 0.0)
    e = np.zeros(len(mt))
    if consts.mu_roll > 0:
        e += mr2 / (2.0 * consts.k_roll * Rs * Rs)
    if consts.twist_cap > 0:
        e += mt * mt / (2.0 * consts.k_twist)
    return e


def _liquefied(p: float, p0: float, how: str) -> str:
    """The message of a liquefied path: the mean stress reached and the pore-pressure ratio."""
    return (f"liquefied: the mean stress fell to {p:.4g} Pa ({100 * p / p0:.2g} % of p0 = {p0:.5g} Pa, pore-pressure "
            f"ratio r_u = {1 - p / p0:.3f}; {how}): at this volume the grains hold no load-bearing network, "
            "the test's answer rather than a numerical failure")


def _relax(s: _Session, st: DemSettings, base: np.ndarray | None, tick: Tick | None,
           p0: float | None = None, servo: bool = False) -> tuple[ContactNetwork, float]:
    """:func:`grainmech.packing.reference.relax` with the settings, progress ticks and one error type.

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


@dataclass(frozen=True)
class DemResult(DriverResult):
    """:class:`~grainmech.driver.base.DriverResult` of the DEM model, plus per-state data.

    Attributes
    ----------
    unbalanced : (k+1,) unbalanced force ratio of every recorded state (an equilibrium,
        or a state of the flow with ``protocol = "continuous"``)
    inertial : (k+1,) largest inertial number of the increment that led to each state
        (0 for step and relax)
    coordination : (k+1,) coordination number ``2 C / P`` (all grains) of every state
    n_contacts : (k+1,) int, contacts of every state
    notes : tuple of str (contact law that ran, re-settling of the start state, ...)
    settings : dict, the :class:`DemSettings`
    G_max : float, small-strain shear modulus of the start state [Pa] (set by the series)
    elastic_tangent : (6, 6) relaxed small-strain tensor of the start state [Pa]

    ``tangent`` is not measured (NaN); ``iterations`` holds the LAMMPS time steps of each
    step and ``substeps`` its servo corrections.
    """

    unbalanced: np.ndarray = field(default_factory=lambda: np.zeros(0))
    coordination: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_contacts: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    notes: tuple = ()
    settings: dict = field(default_factory=dict)
    elastic_tangent: np.ndarray = field(default_factory=lambda: np.full((6, 6), np.nan))
    inertial: np.ndarray = field(default_factory=lambda: np.zeros(0))


def run_dem(net: ContactNetwork, law: Any, path: LoadPath, settings: DemSettings | None = None, *,
            pressure: float | None = None, on_step: Callable[[int, int], None] | None = None,
            tick: Tick | None = None, rolling: RollingResistance | None = None) -> DemResult:
    """Run ``path`` with LAMMPS on the packing ``net`` (module notes).

    Parameters
    ----------
    net : ContactNetwork
        3D periodic packing with radii (e.g. :func:`grainmech.packing.load_packing`).
    law : contact law
        Hertz-Mindlin or Mindlin-Deresiewicz (:func:`dem_material`).
    path : LoadPath
    settings : DemSettings, optional
    pressure : float, optional
        Isotropic stress [Pa] the packing is brought to before the path (:meth:`DemPoint.start`).
    on_step : callable ``(k, n)``, optional
        After each step.
    tick : callable ``(time_steps, unbalanced)``, optional
        After each relaxation (progress during long steps).
    rolling : RollingResistance, optional
        Rolling and twisting resistance of the contacts (module notes); the notes state
        the constants LAMMPS ran.

    Returns
    -------
    DemResult
        ``success`` False keeps every state before the failed step, the message names it.

    With ``settings.ranks`` > 1 the path runs as an MPI job
    (:func:`grainmech.driver.dem_mpi.run_dem_ranks`); its ranks call this function.
    """
    st = settings or DemSettings()
    if st.ranks > 1 and mpi_world_size() == 1:
        return run_dem_ranks(net, law, path, st, pressure=pressure, on_step=on_step, tick=tick, rolling=rolling)
    _, notes = dem_material(law)
    rows: dict[str, list] = {k: [] for k in ("strain", "stress", "sl", "op", "work", "stored", "sub", "it", "ub",
                                             "z", "nc", "I")}
    state = {"corr": 0, "steps": 0}

    def record(pt: DemPoint, k: int) -> None:
        sl, op = pt.fractions()
        if k > 0:
            mid = 0.5 * (rows["stress"][-1] + pt.stress)
            rows["work"].append(rows["work"][-1] + float(mid @ (pt.strain - rows["strain"][-1])))
        else:
            rows["work"].append(0.0)
        rows["strain"].append(pt.strain.copy())
        rows["stress"].append(pt.stress.copy())
        rows["sl"].append(sl)
        rows["op"].append(op)
        rows["stored"].append(pt.stored_energy())
        rows["sub"].append(pt.corrections - state["corr"])
        rows["it"].append(pt.relax_steps - state["steps"])
        state["corr"], state["steps"] = pt.corrections, pt.relax_steps
        rows["ub"].append(pt.unbalanced)
        rows["z"].append(pt.coordination)
        rows["nc"].append(pt.network.n_contacts)
        rows["I"].append(pt.inertial)

    with DemPoint.start(net, law, st, pressure=pressure, tick=tick, rolling=rolling) as point:
        notes += point.notes
        state["steps"] = point.relax_steps
        final, success, status, message = follow_path(point, path, record, on_step=on_step)
        tangent0 = point.elastic_tangent
        if point._s.fallbacks:
            notes.append(f"{point._s.fallbacks} relaxation(s) did not reach equilibrium under the {st.damping} "
                         f"damping within max_relax_steps = {st.max_relax_steps} time steps and were finished "
                         "under kinetic damping ([model.dem] fallback)")
    arr = {k: np.array(v) for k, v in rows.items()}
    if st.protocol == "continuous" and len(arr["I"]) > 1:
        notes.append(f"continuous shearing at inertial number {st.inertial_number:g} (largest of the path "
                     f"{float(arr['I'].max()):.3g}); the recorded states are states of the flow (unbalanced force "
                     f"ratio up to {float(arr['ub'][1:].max()):.3g})")
    n = len(arr["strain"])
    work = arr["work"]
    diss = work - (arr["stored"] - arr["stored"][0])
    return DemResult(success, int(status), message, arr["strain"], arr["stress"], np.full((n, 6, 6), np.nan),
                     arr["sl"], arr["op"], diss, work, arr["stored"], arr["sub"].astype(int), arr["it"].astype(int),
                     None, len(path), {}, arr["ub"], arr["z"], arr["nc"].astype(int), tuple(notes), st.as_dict(),
                     tangent0, arr["I"])


def _worker_init() -> None:
    """A DEM worker process leaves Ctrl-C and SIGTERM to the parent (which ends the pool).

    On Linux it also asks for SIGTERM when its parent ends (``prctl(PR_SET_PDEATHSIG)``),
    so that a parent killed without cleaning up (a script ended by ``kill``) leaves no
    LAMMPS running.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = os.getppid()
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        return
    if os.getppid() != parent:  # the parent ended before the request took effect
        os._exit(143)


#: niceness of a worker that runs an amplitude other than the largest of its batch (``_Pool``)
_BACKGROUND_NICE = 10


def _worker_run(net: ContactNetwork, law: Any, path: LoadPath, settings: DemSettings | None,
                pressure: float | None, rolling: RollingResistance | None, background: bool, index: int,
                q: Any) -> DemResult:
    """One amplitude in a worker process; progress goes to the parent through ``q``.

    ``background``: the worker lowers its own priority to niceness ``_BACKGROUND_NICE``
    first (``os.nice``; a process cannot raise it again, so it keeps it for later tasks).
    """
    if background and hasattr(os, "nice"):
        try:
            os.nice(max(0, _BACKGROUND_NICE - os.nice(0)))
        except OSError:  # pragma: no cover - a system that refuses it: run at the same priority
            pass

    def on_step(k: int, n: int) -> None:
        q.put((index, "step", k, n))

    def tick(steps: int, ub: float) -> None:
        q.put((index, "tick", steps, ub))

    return run_dem(net, law, path, settings, pressure=pressure, on_step=on_step, tick=tick, rolling=rolling)


class _Pool:
    """Amplitudes run side by side in worker processes (each a LAMMPS on one core).

    The largest amplitude of each batch submitted together (:meth:`DemSeries.add`) is the
    longest run (more time steps per step, more servo corrections): its worker keeps the
    normal priority and the others run at niceness ``_BACKGROUND_NICE``, so that when the
    caller also computes (another model in the main process) the run that decides the
    wall time keeps its core and the shorter ones take what is left. The results do not
    depend on it (each LAMMPS is deterministic on one thread).
    """

    def __init__(self, workers: int) -> None:
        ctx = mp.get_context("spawn")
        self.manager = ctx.Manager()
        self.queue = self.manager.Queue()
        self.ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
        self.futures: list[Future] = []

    def submit(self, *args: Any, background: bool = False, rolling: RollingResistance | None = None) -> None:
        call = (*args, rolling, background, len(self.futures), self.queue)
        self.futures.append(self.ex.submit(_worker_run, *call))

    def result(self, index: int, on_step: Callable[[int, int], None] | None, tick: Tick | None) -> DemResult:
        """Wait for amplitude ``index``, passing on its progress meanwhile."""
        fut = self.futures[index]
        while True:
            try:
                i, kind, a, b = self.queue.get(timeout=0.5)
                if i == index and kind == "step" and on_step is not None:
                    on_step(int(a), int(b))
                elif i == index and kind == "tick" and tick is not None:
                    tick(int(a), float(b))
            except queue.Empty:
                pass
            if fut.done():
                return fut.result()

    def close(self) -> None:
        """End the pool; workers still running are stopped (interrupted run, failed amplitude)."""
        for f in self.futures:
            f.cancel()
        procs = list(getattr(self.ex, "_processes", {}).values())
        self.ex.shutdown(wait=False, cancel_futures=True)
        for pr in procs:
            if pr.is_alive():
                pr.terminate()
        self.manager.shutdown()


class DemSeries:
    """A DEM modulus-reduction series whose amplitudes may start before they are collected.

    ``DemSeries(...)`` checks the inputs and, with ``workers`` > 1, submits every
    amplitude to worker processes at once (each LAMMPS on one core); :meth:`add` submits
    more; :meth:`run` collects them in amplitude order through
    :func:`grainmech.driver.loop.cyclic_series` (with one worker, it runs them there);
    :meth:`close` ends the workers. A job that runs other models first starts the series
    before them, so the DEM amplitudes use the cores those models leave idle.
    """

    def __init__(self, net: ContactNetwork, law: Any, amplitudes: Sequence[float], *, n_cycles: int = 2,
                 steps_per_cycle: int = 16, waveform: str = "triangle", constant: str = "stress",
                 settings: DemSettings | None = None, pressure: float | None = None, workers: int = 1,
                 rolling: RollingResistance | None = None) -> None:
        dem_material(law)  # refuse a law LAMMPS cannot run before anything starts
        amps = np.asarray(amplitudes, dtype=float)
        if amps.ndim != 1 or amps.size == 0 or not np.all(np.isfinite(amps)) or np.any(amps <= 0):
            raise ParameterError("amplitudes", list(np.atleast_1d(amplitudes)), "must be a non-empty list of "
                                 "positive strains")
        if float(amps.max()) > DEM_MAX_AMPLITUDE:
            raise ParameterError("amplitudes", list(amps), f"the DEM model takes amplitudes up to "
                                 f"{DEM_MAX_AMPLITUDE:g}")
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
            raise ParameterError("workers", workers, "must be an integer >= 1")
        self.net, self.law, self.settings, self.pressure = net, law, settings, pressure
        self.rolling = rolling
        self.n_cycles, self.steps_per_cycle = n_cycles, steps_per_cycle
        self.waveform, self.constant = waveform, constant
        self.amplitudes: list[float] = []
        self.index: dict[float, int] = {}
        self.pool = _Pool(min(int(workers), amps.size)) if workers > 1 and amps.size > 1 else None
        self.add(amps)

    def _path(self, a: float) -> LoadPath:
        return cyclic_simple_shear(a, self.n_cycles, self.steps_per_cycle, self.waveform, constant=self.constant)

    def add(self, amplitudes: Sequence[float] | np.ndarray) -> None:
        """Add amplitudes to the series.

        With workers they are submitted at once, the largest first; ``_Pool`` runs all but
        the largest at a lower priority.
        """
        new = sorted({float(a) for a in np.asarray(amplitudes, dtype=float).ravel()} - set(self.index),
                     reverse=True)
        for k, a in enumerate(new):
            self.index[a] = len(self.index)
            self.amplitudes.append(a)
            if self.pool is not None:  # new[0], the largest, keeps the normal priority
                self.pool.submit(self.net, self.law, self._path(a), self.settings, self.pressure,
                                 background=k > 0, rolling=self.rolling)

    def run(self, *, progress: Callable[[int, float, Any], None] | None = None,
            on_step: Callable[[int, int], None] | None = None, tick: Tick | None = None,
            raise_on_failure: bool = True,
            on_amplitude: Callable[[ModulusReduction], None] | None = None) -> ModulusReduction:
        """Collect the series in increasing amplitude (:func:`dem_modulus_reduction`)."""
        tangents: list[np.ndarray] = []
        amps = np.array(sorted(self.amplitudes))

        def one(path: LoadPath) -> DriverResult:
            a = float(amps[len(tangents)])
            if self.pool is not None:
                r = self.pool.result(self.index[a], on_step, tick)
            else:
                r = run_dem(self.net, self.law, path, self.settings, pressure=self.pressure, on_step=on_step,
                            tick=tick, rolling=self.rolling)
            tangents.append(r.elastic_tangent)
            return r

        def gmax(path: LoadPath) -> float:
            if not tangents:
                return float("nan")
            return condensed_modulus(tangents[0], 4, path.stress_control[0])

        return cyclic_series(one, amps, gmax, n_cycles=self.n_cycles, steps_per_cycle=self.steps_per_cycle,
                             waveform=self.waveform, constant=self.constant, progress=progress,
                             raise_on_failure=raise_on_failure, on_amplitude=on_amplitude)

    def close(self) -> None:
        """End the worker processes (idempotent)."""
        if self.pool is not None:
            self.pool.close()
            self.pool = None


def dem_modulus_reduction(net: ContactNetwork, law: Any, amplitudes: Sequence[float], *, n_cycles: int = 2,
                          steps_per_cycle: int = 16, waveform: str = "triangle", constant: str = "stress",
                          settings: DemSettings | None = None, pressure: float | None = None,
                          workers: int = 1,
                          progress: Callable[[int, float, Any], None] | None = None,
                          on_step: Callable[[int, int], None] | None = None, tick: Tick | None = None,
                          raise_on_failure: bool = True,
                          on_amplitude: Callable[[ModulusReduction], None] | None = None,
                          rolling: RollingResistance | None = None) -> ModulusReduction:
    """G/Gmax and damping of a packing by DEM: cyclic simple shear ``gamma_xz`` per amplitude.

    Each amplitude starts from the same state (the packing loaded and relaxed anew; LAMMPS
    is deterministic on one thread), as the other models' series do
    (:func:`grainmech.driver.loop.cyclic_series`: the last of ``n_cycles`` cycles
    analysed). ``G_max`` is ``C_55`` of the relaxed small-strain tensor of that start state
    (:func:`grainmech.network.relaxed_stiffness` with the no-slip Hertz-Mindlin
    stiffnesses LAMMPS uses, condensed with the path's control: ``sigma_zz`` free at
    constant stress): the small-strain limit of the same DEM state, which LAMMPS' own
    strain probes reproduce to 0.13 % on 'dense' (``docs/packing.md``).

    ``workers`` > 1 runs the amplitudes side by side in that many processes (each
    LAMMPS runs on one core; the amplitudes are independent): the same results, in the
    time of the slowest amplitude per worker. Progress is passed on for the amplitude the
    series is waiting for. ``rolling``: rolling and twisting resistance (module notes);
    ``G_max`` then comes from the relaxed tensor with the moment springs.
    """
    series = DemSeries(net, law, amplitudes, n_cycles=n_cycles, steps_per_cycle=steps_per_cycle,
                       waveform=waveform, constant=constant, settings=settings, pressure=pressure, workers=workers,
                       rolling=rolling)
    try:
        return series.run(progress=progress, on_step=on_step, tick=tick, raise_on_failure=raise_on_failure,
                          on_amplitude=on_amplitude)
    finally:
        series.close()

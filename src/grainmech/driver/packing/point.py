"""The packing driver's material point and run (:mod:`grainmech.driver.packing`).

:class:`PackingPoint` (a converged state of a packing of grains: ``from_network``,
``at_stress``, tangents, energies), :func:`unbalanced_force_ratio`, the relaxed tangent by
GMRES per column (``relaxed_tangent``), and the run: :func:`run_packing` ->
:class:`PackingResult`, whose steps the step solver :mod:`grainmech.driver.packing.step`
takes. The point's constructors run the driver (to settle the input, to reach a stress),
so the two live together. The derivation is in ``docs/models/packing.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, cast

import numpy as np

from grainmech.contact import (
    ContactState,
    update,
)
from grainmech.contact.forms import frictional as is_frictional
from grainmech.contact.forms import normal_law
from grainmech.contact.rolling import (
    RollingConstants,
    RollingResistance,
    RollingResponse,
    moment_energy,
    rolling_elastic_stiffness,
    rolling_update,
)
from grainmech.driver import DriverResult, LoadPath
from grainmech.driver.base import PointStepping, Status, StepFailure
from grainmech.driver.loop import PathCheckpoint, follow_path, path_saves
from grainmech.driver.packing._input import (
    check_network,
    gap_pairs,
    initial_contact_state,
    input_forces,
    input_rolling,
    pin_first,
    tensile_note,
)
from grainmech.driver.packing._operators import (
    Kinematics,
    Preconditioner,
    RollingTangent,
    contact_tangent,
    openblas_one_thread,
    voigt_of,
)
from grainmech.driver.packing.consolidate import ENGINES, dem_consolidated, isotropic_pressure
from grainmech.driver.packing.options import (
    OutOfBudget,
    PackingOptions,
    RunContext,
    SubstepFailure,
    check_law_params,
    law_options,
    law_scale,
)
from grainmech.driver.packing.resume import resumed, saved_state
from grainmech.driver.packing.step import subdivided
from grainmech.driver.packing.tangent import relaxed_tangent, unbalanced_force_ratio
from grainmech.errors import GrainmechError, ParameterError
from grainmech.lammps.engine import lammps_available
from grainmech.network import ContactNetwork, rattlers

#: ``PackingOptions.accept_unbalanced`` of :meth:`PackingPoint.at_stress` (a DEM packing's "at rest")
AT_STRESS_UNBALANCED = 1e-4

__all__ = ["PackingPoint", "PackingResult", "run_packing", "unbalanced_force_ratio"]


@dataclass(frozen=True, eq=False)
class PackingPoint:
    """Converged state of a packing (see module notes and ``docs/models/packing.md``).

    Attributes
    ----------
    network : ContactNetwork
        The input packing (reference geometry).
    params : contact law parameters (material constants and friction; the radius of each
        contact comes from its grains, see :func:`law_scale`).
    kinematics : private geometry of the tracked contacts (non-rattler grains).
    grains : int array (P,)
        Rows of ``network`` of the grains kept (rattlers excluded).
    radii : array (P,) [length]
    contact_rows : int array (C,)
        Row of ``network`` of each tracked contact, ``-1`` for a pair tracked because of
        its small initial gap.
    scale : array (C,)
        Law displacement scale ``s_c``.
    state : ContactState
        Contact law state (law space: displacements times ``s_c``).
    response : ContactResponse
        Law response at ``state`` (law space).
    forces : array (C, 3)
        Contact forces (by A on B, compression positive) [force].
    q : array (P, 6)
        Grain fluctuations (translation [length], rotation [rad]); grain 0's translation
        is pinned (global translation).
    strain, stress : arrays (6,)
        Total strain since the input state (engineering shear, compression positive) and
        Love-Weber stress (seed Eq. 2.6), library order ``xx, yy, zz, yz, xz, xy``.
    volume : float
    n_rattlers : int
    initially_closed : bool array (C,)
        Contacts carrying force in the input state.
    notes : tuple of str
    load : array (n_free,) or None
        Constant external grain loads (force, moment) that balance the input's
        out-of-balance forces (``imbalance="hold"`` of :meth:`from_network`); ``None``: none.
    rolling : RollingConstants or None
        The contacts' rolling and twisting resistance (:mod:`grainmech.contact.rolling`);
        ``None``: smooth spheres (no contact moments).
    moments : array (C, 3) or None
        Contact moments (rolling normal to ``n``, twisting along it) [force x length],
        work-conjugate to the relative rotation ``theta_A - theta_B``.
    rolling_response : RollingResponse or None
        The moment springs' response at this state (tangents, caps reached).
    """

    network: ContactNetwork
    params: Any
    kinematics: Kinematics
    grains: np.ndarray
    radii: np.ndarray
    contact_rows: np.ndarray
    scale: np.ndarray
    state: ContactState
    response: Any
    forces: np.ndarray
    q: np.ndarray
    strain: np.ndarray
    stress: np.ndarray
    volume: float
    n_rattlers: int
    initially_closed: np.ndarray
    notes: tuple = ()
    law_backend: str | None = "numpy"
    factorization: str = "auto"
    load: np.ndarray | None = None
    regularization: float = 1e-4
    reproducible: bool = True
    rolling: RollingConstants | None = None
    moments: np.ndarray | None = None
    rolling_response: RollingResponse | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------------ constructor
    @classmethod
    def from_network(cls, net: ContactNetwork, params: Any, *, forces: str = "auto", gap: float = 0.05,
                     max_unbalanced: float = 1e-2, imbalance: str = "hold",
                     options: PackingOptions | None = None,
                     rolling: RollingResistance | RollingConstants | None = None) -> PackingPoint:
        """Packing point from a contact network and a contact law.

        Parameters
        ----------
        net : ContactNetwork
            3D, periodic packing with radii (spheres).
        params : Hertz, HertzMindlin, MindlinDeresiewicz or LinearSpring
            Material constants and friction; each contact uses the effective radius
            ``R_A R_B / (R_A + R_B)`` of its grains.
        forces : {"auto", "stored", "overlap"}
            ``stored``: the network's contact forces (normal part from ``f . n``,
            tangential part placed on the virgin Mindlin-Deresiewicz branch,
            :func:`grainmech.contact.state_from_forces`); ``overlap``: normal forces from
            the overlaps by the law (Hertz, seed Eq. 3.6), no tangential force; ``auto``:
            stored if any force is non-zero, else overlap.
        gap : float
            Pairs of grains not in contact whose gap is below ``gap`` times their mean
            radius are tracked (open) so that they can close.
        max_unbalanced : float
            Largest accepted :func:`unbalanced_force_ratio` of the input (mean-based);
            above it the packing is not mechanically stable and a
            :class:`~grainmech.errors.GrainmechError` says so.
        imbalance : {"hold", "relax", "none"}
            What to do with the input's remaining out-of-balance forces and moments (a DEM
            packing at rest keeps a small imbalance, its unbalanced force ratio).
            ``"hold"``: the input is the equilibrium state, its out-of-balance forces are
            held as constant external loads on the grains (:attr:`load`), so the stress and
            the contact states are exactly the input's; ``"relax"``: remove them with one
            strain-controlled step of zero increment (the grains move; contacts at the
            Coulomb limit may slide; the stress change is in ``notes``); ``"none"``: keep
            them in the residual (the first step removes them).
        rolling : RollingResistance or RollingConstants, optional
            Rolling and twisting resistance of the contacts (:mod:`grainmech.contact.rolling`):
            moment springs and caps in every grain's moment balance and in the tangents. A
            :class:`RollingResistance` is resolved on this packing's contacts
            (:func:`~grainmech.contact.rolling.rolling_constants`); constants already
            resolved (e.g. those the DEM model used) are taken as they are. The contact
            moments are the network's (``ContactNetwork.moment``, a DEM state read from
            LAMMPS), else zero (the imbalance that leaves is held as for any input).
            ``None`` or a zero coefficient: smooth spheres, today's results.

        Raises
        ------
        GrainmechError (a ValueError)
            Bad input, naming the field and the value.
        """
        check_law_params(params)
        opts = options or PackingOptions()
        check_network(net, forces, gap, imbalance)
        assert net.radii is not None  # checked by check_network
        notes: list[str] = []
        frictional = is_frictional(params)
        N, T = input_forces(net, params, forces, frictional, notes)
        carrying = N > 0
        min_c = 2 if frictional else 4
        ratt = rattlers(net, min_c, carrying)
        alive = ~ratt
        if not alive.any():
            raise GrainmechError(f"{net.source or 'network'}: every grain is a rattler (fewer than {min_c} "
                                 f"force-carrying contacts, removed iteratively; {int(carrying.sum())} of "
                                 f"{net.n_contacts} contacts carry force): nothing is left to load")
        notes.append(f"rattlers: {int(ratt.sum())} of {net.n_particles} grains excluded (fewer than {min_c} "
                     f"force-carrying contacts, {'frictional' if frictional else 'frictionless'} rule, "
                     "removed iteratively)")
        keep_c = alive[net.i] & alive[net.j]
        tensile_note(net, keep_c, N, notes)
        gi, gj, gbr = gap_pairs(net, gap, alive)
        if gi.size:
            notes.append(f"{gi.size} pairs with a gap below {gap:g} x mean radius tracked (open)")
        rows = np.concatenate([np.flatnonzero(keep_c), -np.ones(gi.size, dtype=int)])
        I = np.concatenate([net.i[keep_c], gi])
        J = np.concatenate([net.j[keep_c], gj])
        br = np.concatenate([net.branch[keep_c], gbr])
        Lc = np.linalg.norm(br, axis=1)
        nc = br / Lc[:, None]
        Ra, Rb = net.radii[I], net.radii[J]
        Rs = Ra * Rb / (Ra + Rb)
        s = law_scale(params, Rs)
        Nk, Tk = N[keep_c], T[keep_c]
        # contact law state (law space): listed contacts at their forces, gap pairs open
        state = initial_contact_state(params, Nk, Tk, rows, frictional, Lc, Ra, Rb, s)
        grains = pin_first(np.flatnonzero(alive), net, keep_c & carrying, N)
        newidx = -np.ones(net.n_particles, dtype=int)
        newidx[grains] = np.arange(grains.size)
        consts = input_rolling(rolling, params, Nk, Rs[:Nk.size])
        kin = Kinematics.build(newidx[I], newidx[J], nc, br, Ra, Rb, grains.size, rolling=consts is not None,
                               twisting=consts is not None and consts.twist_cap > 0)
        V = net.volume
        st0, resp0 = update(params, state, np.zeros(state.n_contacts), np.zeros((state.n_contacts, 3)),
                            **law_options(opts.law_backend))
        f = resp0.normal_force[:, None] * nc + resp0.tangential_force
        roll: dict = {}
        if consts is not None:
            m0 = np.zeros((I.size, 3))
            if net.moment is not None:  # the moments of the input (by A on B, as the forces)
                m0[:Nk.size] = np.asarray(net.moment, float)[keep_c]
            notes.append(f"rolling resistance mu_r = {consts.mu_roll:g}, twisting cap {consts.twist_cap:.4g} m x N; "
                         f"{consts.source}; contact moments "
                         + ("from the input" if net.moment is not None else "start at zero"))
            Nopen = np.where(np.asarray(resp0.open, bool), 0.0, resp0.normal_force)
            roll = {"rolling": consts, "moments": m0,
                    "rolling_response": rolling_update(consts, nc, kin.Rs, Nopen, m0, np.zeros_like(m0))}
        pt = cls(net, params, kin, grains, net.radii[grains], rows, s, st0, resp0, f,
                 np.zeros((grains.size, 6)), np.zeros(6), voigt_of(f, br) / V, V, int(ratt.sum()),
                 np.concatenate([Nk > 0, np.zeros(gi.size, bool)]), tuple(notes), opts.law_backend,
                 opts.factorization, regularization=opts.regularization, reproducible=opts.reproducible,
                 **roll)
        ufr = unbalanced_force_ratio(pt)
        if not ufr <= max_unbalanced:
            raise GrainmechError(
                f"{net.source or 'network'} is not mechanically stable: unbalanced force ratio {ufr:.3g} "
                f"> max_unbalanced = {max_unbalanced:g} (mean out-of-balance force and moment/radius per "
                "grain over the mean contact force). Equilibrate it first (DEM, or "
                "grainmech.driver.packing.equilibrate_network)")
        pt = replace(pt, notes=pt.notes + (f"input unbalanced force ratio {ufr:.3g}",))
        return _treat_imbalance(pt, imbalance, opts)

    @classmethod
    def at_stress(cls, net: ContactNetwork, params: Any, sigma: float | Sequence[float], *,
                  n_steps: int | None = None, options: PackingOptions | None = None,
                  engine: str = "auto", dem_settings: Any | None = None,
                  **from_network: Any) -> PackingPoint:
        """Packing point brought to a confining stress by a stress-controlled straight path.

        :meth:`from_network`, then ``n_steps`` all-stress-controlled steps of
        :func:`run_packing` from the packing's stress ``s0`` to ``sigma`` (a pressure ``p``
        means ``p I``), with the contact laws' history. The strain of the path is kept.
        The steps are geometric in the mean stress: step ``k`` of ``n`` reaches
        ``s0 + (sigma - s0) (r^k - 1) / (r^n - 1)``, ``r = (p / p0)^(1/n)`` (equal ratios
        of the pressure, so equal relative changes of the Hertz contact stiffnesses,
        ``k ∝ p^(1/3)``; linear when the mean stress does not change). ``n_steps=None``:
        one step per 25 % of pressure change, ``ceil(|ln(p / p0)| / ln 1.25)``, at least 1.
        The steps accept a stalled iteration when the packing is at rest by a DEM's
        measure (``PackingOptions.accept_unbalanced``, ``1e-4`` unless set), and the
        imbalance the last step leaves is held as constant grain loads, as the input's
        is (``imbalance="hold"``), so that paths from the returned point start in
        equilibrium.

        ``engine``: ``"packing"`` (the path above), ``"dem"`` (the DEM model brings the
        packing to the isotropic pressure with LAMMPS, and the point starts from the
        resulting network: :func:`grainmech.driver.packing.consolidate.dem_consolidated`,
        for pressures where the grains rearrange) or ``"auto"`` (the default: the path
        above, and where it stops, the DEM model when LAMMPS is installed and ``sigma`` is
        isotropic; the notes say which ran and why). ``dem_settings``: the DEM model's
        :class:`~grainmech.driver.dem.DemSettings`.

        Raises
        ------
        GrainmechError
            If the path fails or leaves the small-strain range (the message says where),
            or the DEM model cannot run or reach the pressure.
        """
        if engine not in ENGINES:
            raise ParameterError("engine", engine, f"must be one of {', '.join(ENGINES)}")
        p = isotropic_pressure(sigma)
        if engine == "dem":
            return cls._at_stress_dem(net, params, sigma, p, options, dem_settings, (), **from_network)
        try:
            return cls._at_stress_path(net, params, sigma, n_steps, options, **from_network)
        except GrainmechError as exc:
            if engine == "packing" or isinstance(exc, ParameterError) or p is None or not lammps_available():
                raise
            why = (f"the packing model could not bring the packing to p = {p:.5g} Pa ({exc}); the DEM model did",)
            try:
                return cls._at_stress_dem(net, params, sigma, p, options, dem_settings, why, **from_network)
            except GrainmechError as dem_exc:
                raise GrainmechError(f"{exc}; the DEM model (engine='auto') could not either: {dem_exc}") from None

    @classmethod
    def _at_stress_dem(cls, net: ContactNetwork, params: Any, sigma: float | Sequence[float], p: float | None,
                       options: PackingOptions | None, dem_settings: Any, why: tuple,
                       **from_network: Any) -> PackingPoint:
        """:meth:`at_stress` with ``engine="dem"``: the point on the DEM model's network at pressure ``p``.

        ``p`` is the pressure of ``sigma`` (``None``: ``sigma`` is not isotropic, an error).
        """
        if p is None:
            raise ParameterError("sigma", np.asarray(sigma).tolist(),
                                 "the DEM model brings a packing to an isotropic pressure only (a number or p I)")
        rolling = from_network.get("rolling")
        new, notes = dem_consolidated(net, params, p, dem_settings,
                                      rolling if isinstance(rolling, RollingResistance) else None)
        pt = cls.from_network(new, params, options=options or PackingOptions(), **from_network)
        return replace(pt, notes=pt.notes + why + tuple(notes))

    @classmethod
    def _at_stress_path(cls, net: ContactNetwork, params: Any, sigma: float | Sequence[float],
                        n_steps: int | None, options: PackingOptions | None, **from_network: Any) -> PackingPoint:
        """:meth:`at_stress` with ``engine="packing"``: the packing model's own stress path."""
        sig = np.asarray(sigma, dtype=float)
        if sig.ndim == 0:
            if not (math.isfinite(float(sig)) and float(sig) > 0):
                raise ParameterError("sigma", float(sig),
                                     "a confining pressure must be positive (compression positive)")
            sig = float(sig) * np.array([1.0, 1, 1, 0, 0, 0])
        if sig.shape != (6,) or not np.all(np.isfinite(sig)):
            raise ParameterError("sigma", np.shape(sigma), "must be a pressure or a finite (6,) stress vector")
        opts = options or PackingOptions()
        pt = cls.from_network(net, params, options=opts, **from_network)
        run_opts = replace(opts, tangent="none", accept_unbalanced=opts.accept_unbalanced or AT_STRESS_UNBALANCED)
        res = run_packing(pt, _stress_path(pt.stress, sig, n_steps), run_opts)
        if not res.success:
            raise GrainmechError(f"{net.source or 'network'}: bringing the packing to the stress "
                                 f"{np.round(sig, 6).tolist()} failed: {res.message}")
        fin = cast(PackingPoint, res.final)
        ufr = unbalanced_force_ratio(fin)
        # the prepared state is the equilibrium state, as the input is (imbalance="hold"):
        # its out-of-balance forces are held as constant grain loads from here on
        return replace(fin, load=fin.out_of_balance(), notes=fin.notes + (
            f"brought from the input stress to {np.round(sig, 6).tolist()} in {len(res.strain) - 1} stress-controlled "
            "steps "
            f"(volumetric strain {float(res.final.strain[:3].sum()):.3g}); its unbalanced force ratio "
            f"{ufr:.3g} (largest grain {unbalanced_force_ratio(fin, kind='max'):.3g}) is held as constant grain "
            "loads",), _cache={})

    # ------------------------------------------------------------------ derived
    @property
    def n_grains(self) -> int:
        """Number of grains kept (rattlers excluded)."""
        return int(self.grains.size)

    @property
    def n_contacts(self) -> int:
        """Number of tracked contacts (listed ones and gap pairs)."""
        return self.kinematics.n_contacts

    @property
    def frictional(self) -> bool:
        """Whether the contact law has a finite, non-zero friction coefficient."""
        return is_frictional(self.params)

    def contact_stiffness(self) -> tuple[np.ndarray, np.ndarray]:
        """Consistent and elastic contact tangents (C, 3, 3) of the current state [force/length]."""
        r, s, kin = self.response, self.scale, self.kinematics
        closed = ~np.asarray(r.open, bool)
        kn = np.where(closed, r.kn, 0.0) * s
        ksp = np.where(closed, r.ks_perp, 0.0) * s
        K = contact_tangent(kin.n, kn, np.where(closed, r.ks, 0.0) * s, ksp,
                            np.where(closed, r.ktn, 0.0) * s, r.axis)
        K0 = contact_tangent(kin.n, kn, ksp, ksp, np.zeros_like(kn), r.axis)
        return K, K0

    def moment_stiffness(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Consistent and elastic moment-spring tangents (C, 3, 3) of the current state, or None without rolling."""
        if self.rolling is None or self.rolling_response is None:
            return None
        closed = ~np.asarray(self.response.open, bool)
        return (self.rolling_response.tangent,
                rolling_elastic_stiffness(self.rolling, self.kinematics.n, self.kinematics.Rs, closed))

    def rolling_tangent(self, elastic: bool = False) -> RollingTangent | None:
        """The moment springs' part of the consistent (or elastic) tangent, or None without rolling."""
        km = self.moment_stiffness()
        if km is None:
            return None
        assert self.rolling_response is not None
        closed = ~np.asarray(self.response.open, bool)
        kn = np.where(closed, self.response.kn, 0.0) * self.scale
        dmdN = self.rolling_response.dmoment_dnormal
        if elastic:
            dmdN = np.zeros_like(dmdN)
        return RollingTangent(self.kinematics, km[1 if elastic else 0], dmdN, kn)

    def out_of_balance(self) -> np.ndarray:
        """Out-of-balance forces and moments (n_free,) of the contact forces and moments (no held load)."""
        b = self.kinematics.balance(self.forces)
        if self.moments is not None:
            b = b + self.kinematics.moment_balance(self.moments)
        return b

    def preconditioner(self) -> Preconditioner:
        """Factorised elastic operator of this state (cached)."""
        if "prec" not in self._cache:
            km = self.moment_stiffness()
            self._cache["prec"] = Preconditioner(self.kinematics, self.contact_stiffness()[1], self.factorization,
                                                 self.regularization, self.reproducible,
                                                 None if km is None else km[1])
        return self._cache["prec"]

    @cached_property
    def tangent(self) -> np.ndarray:
        """Relaxed tangent (6, 6), Voigt, library order [stress]: ``(1/V)(A - B^T H^-1 B)``.

        ``H = G^T K G``, ``B = G^T K E``, ``A = E^T K E`` with the consistent contact tangent
        ``K`` of the current state (Lemaitre & Maloney 2006, Eq. 12; with ``K = kn n n +
        ks (I - n n)`` this is :func:`grainmech.network.relaxed_stiffness`).
        """
        return relaxed_tangent(self, self.preconditioner(), PackingOptions().krylov_max)

    @cached_property
    def elastic_tangent(self) -> np.ndarray:
        """Relaxed tangent (6, 6) with the elastic (no-slip) contact stiffness [stress].

        ``K0 = kn n n + ks_perp (I - n n)`` of the current state.

        The stiffness of a small strain reversal from this state: at the reversal every
        Mindlin-Deresiewicz contact unloads with its no-slip stiffness ``8 G* a``
        (seed Eq. 3.11; Mindlin & Deresiewicz 1953), whatever its tangential force. This is
        the small-strain modulus a small cycle or a shear wave measures (``G_max``); it
        equals :attr:`tangent` when no contact carries a tangential force.

        The elastic operator ``H0`` is the one the point's preconditioner factorised
        (shifted by ``PackingOptions.regularization``), and the factorisation already
        holds ``(H0 + S)^-1 B0`` (its Schur complement), refined to ``Y = H0^-1 B0`` by CG
        with the factor (``Preconditioner.exact_Y``): the tangent is ``(A0 - B0^T Y) / V``
        (the condensation of :func:`relaxed_tangent`) with no further factorisation,
        when the residual ``|H0 Y - B0|`` of every column is below ``1e-8 |B0|``;
        otherwise GMRES per column as for :attr:`tangent`. On the shipped packings the two agree to 6e-8 (medium),
        2e-10 (dense), 6e-9 (loose); GMRES needed 0.4-4 s there (one iteration per
        near-floppy mode: grains held by two contacts), the direct form 2 ms.
        """
        return relaxed_tangent(self, self.preconditioner(), PackingOptions().krylov_max, elastic=True)

    def fluctuation(self) -> float:
        """Largest displacement fluctuation over its radius (mean translation removed) of a force-carrying grain.

        Over the grains with at least one closed contact: the small-strain check
        (``PackingOptions.max_fluctuation``) is on the geometry of the force network. A
        grain without a closed contact carries nothing, whatever its position (a rattler
        in its cage; it does not move while free, ``docs/models/packing.md``, "Opening and
        closing"); bringing 'medium' from 100 to 800 kPa, such grains had been pushed by
        their closing neighbours by up to 5 % of their radius.
        """
        if not self.n_grains:
            return 0.0
        u = self.q[:, :3] - self.q[:, :3].mean(axis=0)
        kin = self.kinematics
        closed = ~np.asarray(self.response.open, bool)
        carrying = (np.bincount(kin.a[closed], minlength=self.n_grains)
                    + np.bincount(kin.b[closed], minlength=self.n_grains)) > 0
        return float(np.max(np.linalg.norm(u, axis=1) / self.radii, where=carrying, initial=0.0))

    def dissipated(self) -> float:
        """Cumulative frictional dissipation per unit volume since the input state.

        Sliding at the contacts; with rolling resistance the rolling and twisting caps'
        work is in the run's dissipation counter (``PackingResult.dissipation``).
        """
        return float(np.sum(self.state.dissipated_energy / self.scale) / self.volume)

    def stored_energy(self) -> float:
        """Elastic energy per unit volume held by the contacts (estimate).

        Hertz: ``(2/5) N alpha`` (seed Eq. 3.6 integrated) plus ``|T|^2 / (2 k_t0)`` with the
        no-slip stiffness ``k_t0 = 8 G* a``; linear springs ``N^2/(2 kn) + |T|^2/(2 ks)``.
        The tangential term is exact for a spring and an estimate for Mindlin-Deresiewicz.
        """
        r, st = self.response, self.state
        closed = ~np.asarray(r.open, bool)
        T2 = np.einsum("ij,ij->i", r.tangential_force, r.tangential_force)
        kt = r.ks_perp * self.scale
        et = np.where(closed & (kt > 0), T2 / (2 * np.where(kt > 0, kt, 1.0)), 0.0)
        if normal_law(self.params) == "linear":
            en = r.normal_force ** 2 / (2 * self.params.kn)
        else:
            en = 0.4 * r.normal_force * np.maximum(st.approach, 0.0) / self.scale
        em = 0.0
        if self.moments is not None and self.rolling is not None:  # the moment springs
            em = float(np.sum(np.where(closed, moment_energy(self.rolling, self.moments, self.kinematics.n,
                                                             self.kinematics.Rs), 0.0)))
        return float((np.sum(np.where(closed, en, 0.0) + et) + em) / self.volume)

    def fractions(self) -> tuple[float, float]:
        """(sliding fraction of the closed contacts, fraction of the initially closed contacts now open)."""
        r = self.response
        closed = ~np.asarray(r.open, bool)
        sl = float(np.sum(np.asarray(r.sliding, bool) & closed) / max(int(closed.sum()), 1))
        ic = self.initially_closed
        op = float(np.sum(ic & ~closed) / max(int(ic.sum()), 1))
        return sl, op


def _stress_path(s0: np.ndarray, s1: np.ndarray, n_steps: int | None) -> LoadPath:
    """All-stress-controlled path from ``s0`` to ``s1``, geometric in the mean stress (``at_stress``)."""
    p0, p1 = float(np.mean(s0[:3])), float(np.mean(s1[:3]))
    ratio = p1 / p0 if p0 > 0 and p1 > 0 else 1.0
    if n_steps is None:
        n_steps = max(1, math.ceil(abs(math.log(ratio)) / math.log(1.25) - 1e-9))
    if int(n_steps) < 1:
        raise ParameterError("n_steps", n_steps, "must be >= 1")
    n = int(n_steps)
    k = np.arange(n + 1)
    w = k / n if abs(ratio - 1.0) < 1e-12 else (ratio ** (k / n) - 1.0) / (ratio - 1.0)
    targets = s0 + w[:, None] * (s1 - s0)
    return LoadPath(np.ones((n, 6), bool), np.diff(targets, axis=0))


# --------------------------------------------------------------------------- results and run

@dataclass(frozen=True)
class PackingResult(DriverResult):
    """:class:`grainmech.driver.DriverResult` of the packing driver, plus per-step data.

    Attributes
    ----------
    residual : (k+1,) unbalanced force ratio at the end of each step (``kind="max"`` of
        :func:`unbalanced_force_ratio`)
    fluctuation : (k+1,) largest grain displacement fluctuation / radius
    closed : (k+1,) int, number of closed contacts
    krylov : (k+1,) int, GMRES iterations of the step
    relaxation_loss : (k+1,) cumulative energy per unit volume [stress] removed by committed
        relaxation (``PackingOptions.relax_depth``): the work of the out-of-balance forces
        on its updates, which a quasi-static DEM dissipates by its numerical damping. The
        energy balance of a path is ``work = dissipation + stored change + relaxation_loss``.
    cost : (k+1,) int, residual evaluations plus GMRES iterations each step used
        (``PackingOptions.max_step_work`` is the budget of one step)
    factorizations : int, factorisations of the elastic operator in the run
    notes : tuple of str (rattlers, gap pairs, ...)

    ``status``: 0 done, 1 a step failed, 2 the path left the small-strain range.
    ``tangent`` rows that were not computed (see :attr:`PackingOptions.tangent`) are NaN.
    ``sliding_fraction`` is over the closed contacts; ``open_fraction`` the fraction of
    the initially closed contacts that are open.
    """

    residual: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fluctuation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    closed: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    krylov: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    factorizations: int = 0
    notes: tuple = ()
    relaxation_loss: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cost: np.ndarray = field(default_factory=lambda: np.zeros(0, int))



# --------------------------------------------------------------------------- from_network's imbalance rule

def _treat_imbalance(pt: PackingPoint, imbalance: str, opts: PackingOptions) -> PackingPoint:
    """Apply :meth:`PackingPoint.from_network`'s ``imbalance`` rule to a fresh point.

    ``"hold"``: the out-of-balance grain forces and moments become constant external
    loads; ``"relax"``: :func:`run_packing` at fixed strain to equilibrium (fluctuations
    reset to zero); ``"none"``: unchanged.
    """
    net = pt.network
    if imbalance == "hold":
        pt = replace(pt, load=pt.out_of_balance(), notes=pt.notes + (
            "the input's out-of-balance forces and moments are held as constant external grain loads "
            "(the input is the equilibrium state)",))
    elif imbalance == "relax":
        res = run_packing(pt, LoadPath(np.zeros((1, 6), bool), np.zeros((1, 6))),
                          options=replace(opts, tangent="none"))
        if not res.success:
            raise GrainmechError(f"{net.source or 'network'}: equilibrating the input failed: {res.message}")
        eq = cast(PackingPoint, res.final)
        ds = float(np.abs(eq.stress - pt.stress).max() / max(np.abs(pt.stress).max(), 1e-300))
        pt = replace(eq, strain=np.zeros(6), q=np.zeros_like(eq.q),
                     notes=eq.notes + (f"equilibrated at fixed strain: stress changed by {ds:.3g} "
                                       "(relative); residual fluctuations reset to zero",),
                     _cache={"prec": pt.preconditioner()})  # same contacts, same elastic operator to ~ufr
    return pt


def run_packing(point: PackingPoint, path: LoadPath, options: PackingOptions | None = None, *,
                on_step: Callable[[int, int], None] | None = None, checkpoint: PathCheckpoint | None = None,
                **kwargs: Any) -> PackingResult:
    """Drive a packing along a loading path (mixed strain/stress control).

    Same path semantics as :func:`grainmech.driver.run`: per step and component a control
    kind (strain or stress) and an increment; targets do not drift; a component switching
    control restarts from the current value. Each step is solved by Newton iterations on
    all grain fluctuations and the stress-controlled strain components together (consistent
    tangent, GMRES preconditioned by the factorised elastic operator, line search), halved
    up to ``max_depth`` times when it does not converge.

    Parameters
    ----------
    point : PackingPoint
    path : LoadPath
    options : PackingOptions, optional
    on_step : callable, optional
        Called as ``on_step(k, n)`` after step ``k`` of ``n`` is done (progress reports).
    checkpoint : PathCheckpoint, optional
        Save the run at its steps, go on from a saved state (:mod:`grainmech.driver.packing.resume`).
    **kwargs : fields of :class:`PackingOptions` as a shortcut.

    Returns
    -------
    PackingResult
        ``success`` False (status 1: a step failed, 2: small-strain range left) keeps
        every step done before, with the message naming the step and the cause.
    """
    opts = options or PackingOptions(law_backend=point.law_backend, factorization=point.factorization,
                                     regularization=point.regularization, reproducible=point.reproducible)
    if kwargs:
        opts = replace(opts, **kwargs)
    with openblas_one_thread():
        return run_resolved(point, path, opts, on_step=on_step, checkpoint=checkpoint)


@dataclass(frozen=True)
class _Stepping(PointStepping):
    """A packing point with its run's solver context: what :func:`run_resolved` drives through ``follow_path``.

    ``step`` is one step of the step solver (:func:`grainmech.driver.packing.step.subdivided`:
    Newton-Krylov or Anderson, halvings, committed relaxation), within the step's work
    budget, between the range checks of the small-strain model; ``counters`` are the last
    step's substeps, iterations, dissipation, work and relaxation loss, ``krylov`` and
    ``spent`` its GMRES iterations and work (``PackingResult.krylov``, ``cost``).
    """

    point: PackingPoint
    ctx: RunContext
    counters: tuple = (0, 0, 0.0, 0.0, 0.0)
    krylov: int = 0
    spent: int = 0

    def check_targets(self, k: int, sc: np.ndarray, t_strain: np.ndarray) -> None:
        """Stop before step ``k`` when a strain target leaves the small-strain range (``max_strain``)."""
        opts = self.ctx.opts
        if np.abs(t_strain[~sc]).max(initial=0.0) > opts.max_strain:
            j = int(np.argmax(np.where(~sc, np.abs(t_strain), -1.0)))
            raise StepFailure(f"strain component {j} would reach {t_strain[j]:.3g}, beyond max_strain = "
                              f"{opts.max_strain:g} (small-strain, fixed-geometry model)", Status.OUT_OF_RANGE)

    def step(self, d_strain: np.ndarray, stress_control: np.ndarray, target: np.ndarray) -> _Stepping:
        """One step from this state; :class:`StepFailure` when no equilibrium is found or the range is left."""
        ctx, opts, point = self.ctx, self.ctx.opts, self.point
        counters: list[Any] = [0, 0, 0.0, 0.0, 0.0]
        kr0, w0 = ctx.krylov, ctx.work
        ctx.budget = w0 + opts.max_step_work
        try:
            new = subdivided(point, stress_control, d_strain, np.where(stress_control, point.stress, 0.0), target, 0,
                              ctx, counters)
        except (SubstepFailure, OutOfBudget) as exc:
            raise StepFailure(f"no equilibrium found: {exc.cause}") from exc
        finally:
            ctx.budget = 0
        fl = new.fluctuation()
        big = float(np.abs(new.strain).max())
        if fl > opts.max_fluctuation or big > opts.max_strain:
            what = (f"a grain's displacement fluctuation reached {fl:.3g} of its radius (max_fluctuation = "
                    f"{opts.max_fluctuation:g})" if fl > opts.max_fluctuation else
                    f"a strain component reached {big:.3g} (max_strain = {opts.max_strain:g})")
            raise StepFailure(f"left the small-strain range: {what}; the fixed-geometry model no longer applies "
                              "(a run's [model.packing_options] sets both bounds)", Status.OUT_OF_RANGE)
        return replace(self, point=new, counters=tuple(counters), krylov=ctx.krylov - kr0, spent=ctx.work - w0)


def _resolved(point: PackingPoint, path: LoadPath, opts: PackingOptions) -> PackingPoint:
    """:func:`run_resolved`'s input checked, with the options' law backend, factorisation and factor settings."""
    if not isinstance(path, LoadPath):
        raise ParameterError("path", type(path).__name__, "must be a LoadPath")
    if not isinstance(point, PackingPoint):
        raise ParameterError("point", type(point).__name__, "must be a PackingPoint")
    if (opts.regularization, opts.reproducible) != (point.regularization, point.reproducible):
        # the cached factor has another shift or threading
        point = replace(point, regularization=opts.regularization, reproducible=opts.reproducible,
                        _cache={k: v for k, v in point._cache.items() if k != "prec"})
    return replace(point, law_backend=opts.law_backend, factorization=opts.factorization, _cache=point._cache) \
        if (opts.law_backend, opts.factorization) != (point.law_backend, point.factorization) else point


def run_resolved(point: PackingPoint, path: LoadPath, opts: PackingOptions, energy: bool = False,
                 on_step: Callable[[int, int], None] | None = None,
                 checkpoint: PathCheckpoint | None = None) -> PackingResult:
    """:func:`run_packing` with its options resolved (``energy``: potential-energy line search).

    The path loop is :func:`grainmech.driver.loop.follow_path` (the semantics every model
    shares) over :class:`_Stepping`; this records each state (start: the point's tangent
    unless ``tangent="none"``; steps: the relaxed tangent as ``opts.tangent`` asks) and
    words the result. ``checkpoint``: :func:`run_packing`'s.
    """
    rows: dict[str, list] = {k: [] for k in ("strain", "stress", "tangent", "sl", "op", "diss", "work", "loss",
                                             "stored", "sub", "it", "res", "fl", "cl", "kr", "spent")}
    acc = {"diss": 0.0, "work": 0.0, "loss": 0.0}
    point = _resolved(point, path, opts)
    m = len(path)
    fresh = "prec" not in point._cache
    ctx = RunContext(point.preconditioner(), opts, factorizations=int(fresh), energy=energy)
    # resumed: the saved state, with the start's preconditioner as the uninterrupted run has it
    later, resume, counters = resumed(checkpoint, point, rows, acc)
    point = _resolved(later, path, opts) if resume is not None else point
    for name, value in counters.items():  # the factorisation made again is counted
        setattr(ctx, name, value + int(fresh) if name == "factorizations" else value)
    nan66 = np.full((6, 6), np.nan)

    def record(st: _Stepping, k: int) -> None:
        pt = st.point
        sub, it, diss, work, loss = st.counters
        acc["diss"] += diss
        acc["work"] += work
        acc["loss"] += loss
        if k == 0:
            tangent = nan66 if opts.tangent == "none" else pt.tangent
        elif opts.tangent == "every" or (opts.tangent == "ends" and k == m):
            tangent = relaxed_tangent(pt, ctx.prec, opts.krylov_max)
        else:
            tangent = nan66
        sl, op = pt.fractions()
        for key, v in (("strain", pt.strain.copy()), ("stress", pt.stress.copy()), ("tangent", tangent),
                       ("sl", sl), ("op", op), ("diss", acc["diss"]), ("work", acc["work"]), ("loss", acc["loss"]),
                       ("stored", pt.stored_energy()), ("sub", sub), ("it", it),
                       ("res", unbalanced_force_ratio(pt, kind="max")), ("fl", pt.fluctuation()),
                       ("cl", int(np.sum(~np.asarray(pt.response.open, bool)))), ("kr", st.krylov),
                       ("spent", st.spent)):
            rows[key].append(v)

    start = _Stepping(point, ctx)
    final, success, status, message = follow_path(start, path, record, on_step=on_step,
                                                  check_targets=start.check_targets, resume=resume,
                                                  **path_saves(checkpoint, lambda st, targets: saved_state(
                                                      st.point, rows, acc, ctx, targets)))
    point = cast(_Stepping, final).point
    arr = {k: np.array(v) for k, v in rows.items()}
    if opts.tangent == "ends" and not success and len(rows["strain"]) > 1:
        arr["tangent"][-1] = relaxed_tangent(point, ctx.prec, opts.krylov_max)
    return PackingResult(success, int(status), message, arr["strain"], arr["stress"], arr["tangent"], arr["sl"],
                         arr["op"], arr["diss"], arr["work"], arr["stored"], arr["sub"].astype(int),
                         arr["it"].astype(int), cast(Any, point), m, {}, arr["res"], arr["fl"], arr["cl"].astype(int),
                         arr["kr"].astype(int), ctx.factorizations, point.notes + _run_notes(ctx, opts),
                         relaxation_loss=arr["loss"], cost=arr["spent"].astype(int))


def _run_notes(ctx: RunContext, opts: PackingOptions) -> tuple[str, ...]:
    """The run's notes on how its steps were solved (the counters of ``ctx``)."""
    return (((f"{ctx.accepted} (sub)steps accepted with their stress settled (uncertainty "
              f"below rtol_accept = {opts.rtol_accept:g} of the stress scale or rtol_step "
              f"= {opts.rtol_step:g} of the step's stress change) before every grain "
              f"reached rtol = {opts.rtol:g} (the iterations stalled at a kink of the "
              "contact laws)",) if ctx.accepted else ())
            + ((f"{ctx.settled} (sub)steps stopped once the stress uncertainty left and the "
                f"estimated stress change still to come were below settle = {opts.settle:g} times "
                f"the acceptance bound (rtol_accept = {opts.rtol_accept:g} of the stress scale or "
                f"rtol_step = {opts.rtol_step:g} of the step's stress change), before every grain "
                f"reached rtol = {opts.rtol:g}",)
               if ctx.settled else ())
            + ((f"{ctx.anderson_ok} (sub)steps solved by Anderson-accelerated elastic iterations "
                f"({ctx.anderson} iterations), the others by Newton-Krylov",)
               if ctx.anderson else ())
            + ((f"{ctx.relaxations} substeps solved by committed relaxation ({ctx.relaxed} "
                "committed pseudo-time updates: the grains relaxed along a recorded path, as in a "
                "quasi-static DEM)",) if ctx.relaxations else ()))


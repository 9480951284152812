"""A path run by the DEM model: :func:`run_dem` and its :class:`DemResult` (:mod:`grainmech.driver.dem`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.contact.rolling import RollingResistance
from grainmech.driver.base import DriverResult, Status
from grainmech.driver.dem.mpi import JobDied, Tick, run_dem_ranks
from grainmech.driver.dem.point import DemPoint
from grainmech.driver.dem.settings import DemSettings, dem_material
from grainmech.driver.loop import PathCheckpoint, copied_rows, follow_path, path_saves, restore_rows
from grainmech.driver.paths import LoadPath
from grainmech.lammps.engine import mpi_world_size
from grainmech.network import ContactNetwork

__all__ = ["DemResult", "run_dem"]


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

    @classmethod
    def failed(cls, message: str) -> DemResult:
        """The result of a run that ended without one (its process or an MPI rank died): no state, the cause."""
        z, zi = np.zeros(0), np.zeros(0, int)
        return cls(success=False, status=int(Status.FAILED), message=message, strain=np.zeros((0, 6)),
                   stress=np.zeros((0, 6)), tangent=np.zeros((0, 6, 6)), sliding_fraction=z, open_fraction=z,
                   dissipation=z, work=z, stored=z, substeps=zi, iterations=zi, final=None, unbalanced=z,
                   coordination=z, n_contacts=zi)


def run_dem(net: ContactNetwork, law: Any, path: LoadPath, settings: DemSettings | None = None, *,
            pressure: float | None = None, on_step: Callable[[int, int], None] | None = None,
            tick: Tick | None = None, rolling: RollingResistance | None = None,
            checkpoint: PathCheckpoint | None = None) -> DemResult:
    """Run ``path`` with LAMMPS on the packing ``net`` (:mod:`grainmech.driver.dem`).

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
        Rolling and twisting resistance of the contacts (:mod:`grainmech.driver.dem`); the notes state
        the constants LAMMPS ran.
    checkpoint : PathCheckpoint, optional
        Save the run after the steps it names (LAMMPS' restart file and the point's state,
        :meth:`DemPoint.saved_state`) and/or go on from such a save (``grainmech run
        --resume``); on several MPI ranks too (:func:`run_dem_ranks`).

    Returns
    -------
    DemResult
        ``success`` False keeps every state before the failed step, the message names it;
        a job on several MPI ranks one of which died has no state and names the cause.

    With ``settings.ranks`` > 1 the path runs as an MPI job
    (:func:`grainmech.driver.dem.mpi.run_dem_ranks`); its ranks call this function.
    """
    st, why = (settings or DemSettings()).for_path(path)
    if st.ranks > 1 and mpi_world_size() == 1:
        try:
            return run_dem_ranks(net, law, path, st, pressure=pressure, on_step=on_step, tick=tick, rolling=rolling,
                                 checkpoint=checkpoint)
        except JobDied as exc:  # a rank died: this run fails, the caller's other runs go on
            return DemResult.failed(str(exc))
    _, notes = dem_material(law)
    if why:
        notes.append(why)
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

    resume: tuple[int, Any] | None = None
    if checkpoint is not None and checkpoint.resume is not None:
        k0, saved = checkpoint.resume
        restore_rows(rows, saved["rows"])
        state.update(saved["counts"])
        notes = list(saved["notes"])  # the run's notes up to the save
        opened = DemPoint.resumed(saved["point"], st, tick)
        resume = (k0, saved["targets"])
    else:
        opened = DemPoint.start(net, law, st, pressure=pressure, tick=tick, rolling=rolling)
    kw = path_saves(checkpoint, lambda pt, targets: {"point": pt.saved_state(), "rows": copied_rows(rows),
                                                     "counts": dict(state), "targets": targets, "notes": list(notes)})
    with opened as point:
        if resume is None:
            notes += point.notes
            state["steps"] = point.relax_steps
        final, success, status, message = follow_path(point, path, record, on_step=on_step, resume=resume, **kw)
        tangent0 = point.elastic_tangent
        if point.fallbacks:
            notes.append(f"{point.fallbacks} relaxation(s) did not reach equilibrium under the {st.damping} "
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

"""Preparing a periodic, mechanically stable sphere packing with LAMMPS.

Procedure (``docs/packings.md``):

1. **Gas.** ``n`` spheres with radii from a grading (:mod:`grainmech.packing.grading`)
   placed at random without overlap (random sequential addition) in a periodic
   triclinic cell at solid fraction ``initial_solid_fraction`` (0.2).
2. **Compression with the preparation friction.** LAMMPS integrates the grains
   (``fix nve/sphere``) with ``pair_style granular``: ``hertz/material`` normal force
   ``N = (4/3) E* R*^(1/2) delta^(3/2)`` (Hertz 1882; seed Eq. 3.6), ``mindlin``
   tangential force with stiffness ``k_t = 8 G* a``, ``a = (R* delta)^(1/2)`` and the
   Coulomb cap ``|T| <= mu N`` (Mindlin 1949; seed Eq. 3.11), viscous normal and
   tangential damping set by a coefficient of restitution. The cell is deformed
   affinely (``fix deform ... remap x``) by a stress servo in Python: every chunk of
   steps each cell length changes by a strain increment proportional to the error of
   its principal stress (compression positive), capped so that the inertial number
   stays small. Friction ``mu_prep`` during this stage controls the density: 0 gives
   the densest random packing, the grain friction a loose one.
3. **Relaxation with the grain friction.** The tangential model is switched to the
   material's ``mu`` (tangential springs start from zero), the servo continues with a
   smaller gain, and when the stress is within tolerance the cell is held and the
   grains relax, until the unbalanced force ratio is below ``unbalanced_tol`` (1e-5)
   and every principal stress is within ``stress_tol`` (0.5 %) of its target.

**Rolling resistance** (:mod:`grainmech.contact.rolling`, LAMMPS ``rolling sds`` /
``twisting sds``): the grains' own (``GrainMaterial.rolling``) acts in stage 3 with the
grain friction, its constants resolved on the packing's contacts at the switch; a
preparation rolling friction (``PackSettings.prep_rolling``) acts in stage 2 with the
preparation friction, its stiffness tied to the Mindlin stiffness at the target stress
(:func:`grainmech.lammps.rolling.rolling_for_stress`). Preparation friction and rolling
friction both equal to the grains' give the loosest packing of those grains. The dashpots
(:func:`grainmech.lammps.rolling.rolling_damping`) act on spins only.

Quasi-static tricks (they change the path, not the equilibrium reached): a global
viscous drag ``fix viscous`` proportional to the grain mass times a fraction of the
contact frequency (and in the relaxation a rotational drag ``fix viscous/sphere``, which
stops rattlers spinning from the frictionless stage that would otherwise drive their
neighbours through friction), strong contact damping (restitution 0.1 by default), and the capped
servo. The time step is 0.2 over the highest contact frequency expected at the target
stress (:func:`critical_time_step`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from grainmech._deprecated import moved_attribute
from grainmech.contact.rolling import RollingResistance
from grainmech.errors import GrainmechError
from grainmech.lammps.engine import Lammps
from grainmech.lammps.granular import GrainMaterial, critical_time_step, measure_moments, pair_coeff, setup_lammps
from grainmech.lammps.network import lammps_cell, network_from_lammps, unbalanced_ratio
from grainmech.lammps.rolling import rolling_for_stress, rolling_of_network, rolling_pair_suffix
from grainmech.network import ContactNetwork, coordination, network_fabric, network_stress
from grainmech.network.data import solid_volume, void_ratio

__all__ = ["PreparationError", "QUARTZ", "GLASS", "MATERIALS", "PackSettings", "PackResult",
           "prepare_packing", "place_gas", "packing_summary"]

Progress = Callable[[str], None]


def __getattr__(name: str) -> Any:
    return moved_attribute(__name__, name)


class PreparationError(GrainmechError):
    """The preparation ran but did not reach its target (servo or relaxation).

    ``network`` holds the state reached (a :class:`ContactNetwork`), for inspection.
    """

    def __init__(self, message: str, network: ContactNetwork | None = None) -> None:
        super().__init__(message)
        self.network = network


#: quartz: G = 29 GPa, nu = 0.15 (Mavko et al. 2009, The Rock Physics Handbook, Table 7.1:
#: K = 37 GPa, G = 44 GPa for single crystals; 29 GPa, 0.15 is the value used for sand grains
#: in Hertz-Mindlin effective-medium work, Makse et al. 2004), density 2650 kg/m^3, mu = 0.5
QUARTZ = GrainMaterial("quartz", 29e9, 0.15, 2650.0, 0.5)
#: soda-lime glass beads: E = 70 GPa, nu = 0.22 (G = 28.7 GPa), 2500 kg/m^3, mu = 0.2
GLASS = GrainMaterial("glass", 70e9 / (2 * 1.22), 0.22, 2500.0, 0.2)
MATERIALS = {"quartz": QUARTZ, "glass": GLASS}


#: when the grains' own rolling resistance acts in a preparation (:class:`PackSettings`)
GRAIN_ROLLING = ("relaxation", "after")


@dataclass(frozen=True)
class PackSettings:
    """Preparation settings.

    Parameters
    ----------
    stress : (3,) floats
        Target principal stresses along x, y, z, compression positive [Pa].
    prep_friction : float
        Friction during compression (0: densest; the grain friction: loosest).
    seed : int
        Random seed of the radii and the gas.
    unbalanced_tol, stress_tol : float
        Stop criteria of the relaxation (unbalanced force ratio; relative stress error).
    switch_tol : float
        Relative error of the mean stress at which the compression stage ends and the
        grain friction is switched on (near the target a packing compressed with low friction
        creeps, its stress fluctuating by a few percent).
    initial_solid_fraction : float
        Solid fraction of the gas.
    max_steps : int
        Time steps allowed in all; beyond them the preparation stops with an error.
    chunk : int
        Time steps between servo updates.
    inertial_number : float
        Cap of the servo's strain rate as an inertial number ``I = rate d sqrt(rho/p)``
        during compression (a tenth of it during relaxation).
    gain : float
        Servo strain per chunk per unit relative stress error, in units of the contact
        strain ``(p/E*)^(2/3)`` at the target.
    viscous : float
        Global damping rate as a fraction of the contact frequency ``sqrt(kn/m)`` at the
        target stress.
    viscous_relax : float
        The same during the relaxation with the grain friction.
    relax_safety : float
        Time step of the relaxation as a fraction of :func:`critical_time_step` (0.2 during
        the compression).
    threads : int or None
        OpenMP threads (default: all cores).
    prep_rolling : float
        Rolling friction ``mu_r`` during compression (with ``prep_friction``; twisting
        friction the same; stiffness the material's ``rolling_stiffness`` if given, else
        :func:`grainmech.lammps.rolling.rolling_for_stress`); 0: none.
    grain_rolling : {"relaxation", "after"}
        When the grains' own rolling resistance acts: ``"relaxation"`` (default) in stage 3
        with the grain friction; ``"after"``: not in the preparation at all — the packing is
        relaxed with the grain friction only and the grains' rolling springs start unloaded
        at the prepared state (its contact moments are zero, which is an equilibrium of the
        grains with rolling resistance too). A packing compressed with low friction and no
        preparation rolling loses part of its support when rolling and twisting are added
        to its contacts at the switch (2000 Nevada-sand grains compressed with friction
        0.25: mean stress 89 → 48 kPa within 4000 steps) and creeps denser under the servo
        without settling; with ``"after"`` the switch changes the friction only, as for
        grains without rolling resistance. It is how the dense sand packing is made.
    """

    stress: tuple[float, float, float]
    prep_friction: float = 0.0
    seed: int = 1
    unbalanced_tol: float = 1e-5
    stress_tol: float = 5e-3
    switch_tol: float = 0.05
    initial_solid_fraction: float = 0.2
    max_steps: int = 2_000_000
    chunk: int = 200
    viscous: float = 0.05
    viscous_relax: float = 0.01
    relax_safety: float = 0.07
    inertial_number: float = 1e-2
    gain: float = 0.3
    threads: int | None = None
    prep_rolling: float = 0.0
    grain_rolling: str = "relaxation"

    def __post_init__(self) -> None:
        s = np.asarray(self.stress, float)
        if s.shape != (3,) or not np.all(np.isfinite(s)) or not np.all(s > 0):
            raise ValueError(f"stress = {self.stress!r}: three positive principal stresses expected")
        if not (math.isfinite(self.prep_friction) and self.prep_friction >= 0):
            raise ValueError(f"prep_friction = {self.prep_friction!r}: must be >= 0")
        if not (math.isfinite(self.prep_rolling) and self.prep_rolling >= 0):
            raise ValueError(f"prep_rolling = {self.prep_rolling!r}: must be finite and >= 0")
        if self.grain_rolling not in GRAIN_ROLLING:
            raise ValueError(f"grain_rolling = {self.grain_rolling!r}: must be one of {', '.join(GRAIN_ROLLING)}")
        if not 0 < self.unbalanced_tol < 1:
            raise ValueError(f"unbalanced_tol = {self.unbalanced_tol!r}: must lie in (0, 1)")
        if not 0 < self.stress_tol < 1:
            raise ValueError(f"stress_tol = {self.stress_tol!r}: must lie in (0, 1)")
        if not 0.01 <= self.initial_solid_fraction <= 0.3:
            raise ValueError(f"initial_solid_fraction = {self.initial_solid_fraction!r}: must lie in "
                             "[0.01, 0.3] (random addition cannot place denser gases)")
        object.__setattr__(self, "stress", tuple(float(v) for v in s))


@dataclass
class PackResult:
    """A prepared packing: the network and its summary."""

    network: ContactNetwork
    summary: dict
    history: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 6)))
    #: the grading the radii were drawn from (set by ``grainmech.jobs.pack_job``)
    grading: Any = None
    #: columns of ``history``
    history_columns: tuple[str, ...] = ("step", "time_s", "mean_stress_Pa", "void_ratio",
                                        "unbalanced", "stage")


# --------------------------------------------------------------------------- gas

def place_gas(radii: np.ndarray, solid_fraction: float, rng: np.random.Generator,
              max_tries: int = 2000) -> tuple[np.ndarray, float]:
    """Random sequential addition of spheres (largest first) in a periodic cube.

    Returns
    -------
    positions : array (n, 3) [m]
    length : float
        Cube edge [m] with ``sum (4/3) pi R^3 / L^3 = solid_fraction``.
    """
    r = np.asarray(radii, float)
    n = r.size
    L = float((solid_volume(r) / solid_fraction) ** (1.0 / 3.0))
    if L < 4.0 * r.max():
        raise GrainmechError(f"too few grains: the periodic cell ({L:.3g} m) would be less than two of the "
                             f"largest diameters ({2 * r.max():.3g} m) across; use more grains")
    order = np.argsort(-r)
    pos = np.empty((n, 3))
    rmax = r.max()
    placed = 0
    tree = None
    tree_pts, tree_r = np.zeros((0, 3)), np.zeros(0)  # grains in the tree (inside [0, L)^3)
    pending: list[int] = []
    for k, idx in enumerate(order):
        for _ in range(max_tries):
            p = rng.uniform(0.0, L, 3)
            ok = True
            if tree is not None:
                near = tree.query_ball_point(p, r[idx] + rmax)
                if near:
                    q = tree_pts[near]
                    d = q - p
                    d -= L * np.round(d / L)
                    ok = bool(np.all(np.linalg.norm(d, axis=1) > tree_r[near] + r[idx]))
            if ok:
                for pi in pending:
                    d = pos[pi] - p
                    d -= L * np.round(d / L)
                    if np.linalg.norm(d) <= r[pi] + r[idx]:
                        ok = False
                        break
            if ok:
                break
        else:
            raise GrainmechError(f"could not place grain {k + 1} of {n} at solid fraction {solid_fraction:g}")
        pos[idx] = p
        pending.append(idx)
        placed += 1
        if len(pending) >= 64:  # rebuild the periodic tree now and then
            done = order[:placed]
            tree_pts, tree_r = np.mod(pos[done], L), r[done]
            tree = cKDTree(tree_pts, boxsize=L)
            pending = []
    return np.mod(pos, L), L


# --------------------------------------------------------------------------- summary

def packing_summary(net: ContactNetwork, mat: GrainMaterial, *, frictional: bool = True) -> dict:
    """Void ratio, coordination (with and without rattlers), fabric, Love-Weber stress."""
    R = net.require_radii("the packing summary")
    vs = solid_volume(R)
    V = net.volume
    st = network_stress(net)
    s = np.asarray(st.stress)
    co = coordination(net, 2 if frictional else 4)
    fab = network_fabric(net, force_carrying=True) if net.n_contacts else None
    N = net.normal_force
    return {
        "n_grains": net.n_particles, "n_contacts": net.n_contacts,
        "volume_m3": V, "void_ratio": void_ratio(V, vs), "solid_fraction": vs / V,
        "radius_min_m": float(R.min()), "radius_max_m": float(R.max()),
        "radius_mean_m": float(R.mean()),
        "stress_Pa": s.tolist(), "mean_stress_Pa": float(np.trace(s) / 3.0),
        "coordination": {"z": co.z, "z_force": co.z_force, "z_mechanical": co.z_mechanical,
                         "n_rattlers": co.n_rattlers, "rattler_fraction": co.rattler_fraction,
                         "min_contacts": co.min_contacts},
        "fabric_normal2": None if fab is None else np.asarray(fab.normal2).tolist(),
        "mean_normal_force_N": float(N[N > 0].mean()) if np.any(N > 0) else 0.0,
        "mean_overlap_over_radius": float(np.mean(net.overlap / R[net.i]))
        if net.n_contacts and net.overlap is not None else 0.0,
        "material": {"name": mat.name, "shear_modulus_Pa": mat.shear_modulus, "poisson": mat.poisson,
                     "density_kg_m3": mat.density, "friction": mat.friction,
                     **({} if mat.rolling is None else {
                         "rolling_friction": mat.rolling.friction, "rolling_stiffness_N_m": mat.rolling.stiffness,
                         "twisting_friction": mat.rolling.mu_twist})},
    }


# --------------------------------------------------------------------------- preparation

def _stress6(lmp: Any) -> np.ndarray:
    """LAMMPS virial pressure tensor ``pxx pyy pzz pxy pxz pyz``: the stress, compression positive."""
    return lmp.vector("press")[:6]


#: fix deform keywords in the order of :func:`_stress6`
_DEFORM_KEYS = ("x", "y", "z", "xy", "xz", "yz")


def _not_converged(lmp: Any, max_steps: int, stage: int, tmean: float, vs: float) -> PreparationError:
    """The error of a preparation that reached ``max_steps``, naming the stage and the numbers reached."""
    p = _stress6(lmp)
    last_net = network_from_lammps(lmp)
    return PreparationError(
        f"preparation did not converge in max_steps = {max_steps} time steps "
        f"(stage {'compression' if stage == 1 else 'relaxation'}: mean stress {p[:3].mean():.4g} Pa "
        f"for target {tmean:.4g} Pa, void ratio "
        f"{void_ratio(lammps_cell(lmp)[0].diagonal().prod(), vs):.3f})", last_net)


def _servo_increment(settings: PackSettings, stage: int, pm: float, tmean: float, err: np.ndarray, eps_t: float,
                     rbar: float, density: float, chunk: int, dt: float) -> np.ndarray:
    """Servo strain increment (6,) of the cell for one chunk of ``chunk`` time steps ``dt`` [s] (module notes).

    Proportional to the stress error, capped by the inertial number
    ``I = rate d sqrt(rho / p)`` (GDR MiDi 2004) at the current stress; a gas (no stress
    yet) is compressed at ``I = 10 inertial_number`` at the target stress.
    """
    p_ref = max(pm, 0.01 * tmean)
    i_max = settings.inertial_number * (1.0 if stage == 1 else 0.1)
    cap = i_max / (2.0 * rbar * math.sqrt(density / p_ref)) * chunk * dt
    if pm < 1e-3 * tmean:
        de = np.zeros(6)
        de[:3] = -(10 * settings.inertial_number / (2.0 * rbar * math.sqrt(density / tmean)) * chunk * dt)
        return de
    return np.clip(settings.gain * eps_t * err, -cap, cap)


def _start_relaxation(lmp: Any, radii: np.ndarray, mat: GrainMaterial, settings: PackSettings, tmean: float,
                      g_rel: float, rbar: float) -> float:
    """Stage 2 of the preparation: grains at rest, a lighter drag ``g_rel`` and a smaller time step (returned).

    Frictionless grains spin freely: they are stopped before friction acts; a lighter drag
    lets grains that slide find their place instead of creeping. The smaller time step: a
    grain held by several stiff contacts with its rotations vibrates faster than one
    contact (integration noise would keep the unbalanced force near 1e-2).
    """
    dt = critical_time_step(radii, mat, tmean, settings.relax_safety)
    lmp.commands(["velocity all set 0 0 0", "set group all omega 0 0 0", "unfix drag",
                  f"timestep {dt:.10g}",
                  f"fix drag all viscous {g_rel:.10g}",
                  f"fix spin all viscous/sphere {g_rel * rbar ** 2:.10g}"])
    return dt


def _run_chunk(lmp: Any, de: np.ndarray, chunk: int, dt: float) -> None:
    """Run ``chunk`` time steps of ``dt``, deforming the cell by ``de`` (6,) over them (none: held)."""
    rate = de / (chunk * dt)
    if np.any(de != 0):
        lmp.command("fix servo all deform 1 " + " ".join(
            f"{ax} erate {rt:.10g}" for ax, rt in zip(_DEFORM_KEYS, rate)) + " remap x")
        lmp.command(f"run {chunk} post no")
        lmp.command("unfix servo")
    else:
        lmp.command(f"run {chunk} post no")


#: seconds between two progress lines of a preparation (at most, between two chunks of time steps)
PROGRESS_EVERY = 5.0


def decay_time_left(t: np.ndarray, y: np.ndarray, goal: float) -> float | None:
    """Seconds until a quantity that decays exponentially falls to ``goal``, from its samples.

    A proportional servo's relative stress error and a damped relaxation's unbalanced
    force ratio approach their targets roughly as ``y = y0 exp(-k t)``: the least-squares
    line ``ln y = a - k t`` through the samples gives ``k``, and from the last sample the
    time left is ``ln(y_last / goal) / k`` (0 once ``y_last <= goal``).

    Parameters
    ----------
    t : (m,) times [s], increasing
    y : (m,) positive values
    goal : float, > 0

    Returns
    -------
    float or None
        None with fewer than 3 samples, a non-positive or non-finite value, or no decay
        (``k <= 0``): no estimate.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    if t.size < 3 or not np.all(np.isfinite(y)) or np.any(y <= 0) or np.ptp(t) <= 0:
        return None
    k = -float(np.polyfit(t, np.log(y), 1)[0])
    if not k > 0:
        return None
    return max(0.0, math.log(float(y[-1]) / goal) / k)


class _Watch:
    """The progress lines of a preparation (:func:`prepare_packing`): read-only, they change nothing it does.

    Every :data:`PROGRESS_EVERY` seconds (and after the first chunk) a line with the
    stage, the mean stress against the target, the void ratio, the unbalanced force ratio
    (measured in stage 2 once the stress is within ``stress_tol``) and, once the samples
    show a decay, the time left in the stage (:func:`decay_time_left`: in stage 1 from the
    mean stress's relative error approaching ``switch_tol``, in stage 2 from the
    unbalanced force ratio approaching ``unbalanced_tol``; the samples of the later half
    of the stage so far, at least the last 5 s).
    """

    def __init__(self, say: Progress, settings: PackSettings, tmean: float, t0: float) -> None:
        self.say, self.settings, self.tmean, self.t0 = say, settings, tmean, t0
        self.last = -math.inf
        self.start = t0
        self.samples: list[tuple[float, float]] = []
        self.ub = math.nan

    def switch(self, now: float) -> None:
        """Stage 2 begins: its own samples."""
        self.start, self.samples, self.ub = now, [], math.nan

    def left(self, now: float, goal: float) -> float | None:
        keep = now - max(5.0, 0.5 * (now - self.start))
        pts = np.array([p for p in self.samples if p[0] >= keep]).reshape(-1, 2)
        return decay_time_left(pts[:, 0], pts[:, 1], goal)

    def chunk(self, now: float, steps: int, stage: int, pm: float, e_now: float, ub: float, off: float) -> None:
        """After a chunk: record the stage's sample, say a line when one is due.

        ``off``: the largest relative error of a stress component (stage 2 holds the cell
        once it is below ``stress_tol``).
        """
        st = self.settings
        if stage == 1 and 1e-3 * self.tmean < pm:
            self.samples.append((now, abs(pm - self.tmean) / self.tmean))
        elif stage == 2 and not math.isnan(ub):
            self.ub = ub
            self.samples.append((now, ub))
        if now - self.last < PROGRESS_EVERY:
            return
        self.last = now
        if stage == 1:
            what, goal = f"compression, friction {st.prep_friction:g}", st.switch_tol
            ratio = "unbalanced force ratio measured in stage 2"
        else:
            what, goal = "relaxation with the grain friction", st.unbalanced_tol
            ratio = (f"unbalanced force ratio {self.ub:.2e} (stops below {st.unbalanced_tol:g})"
                     if not math.isnan(self.ub) else "unbalanced force ratio not measured yet")
            if off >= st.stress_tol:
                ratio += f", stress off its target by up to {100 * off:.2g} % (to be within {100 * st.stress_tol:g} %)"
        eta = self.left(now, goal)
        self.say(f"  stage {stage} of 2 ({what}): step {steps}, {now - self.t0:.1f} s, mean stress {pm:.4g} Pa "
                 f"(target {self.tmean:.4g} Pa), void ratio {e_now:.4f}, {ratio}"
                 + ("" if eta is None else f", about {eta:.0f} s left in stage {stage}"))


def prepare_packing(radii: np.ndarray, mat: GrainMaterial, settings: PackSettings,
                    progress: Progress | None = None) -> PackResult:
    """Prepare a packing (module notes) and return it with its summary.

    Parameters
    ----------
    radii : array (n,)
        Grain radii [m] (from a grading's ``sample``).
    mat : GrainMaterial
    settings : PackSettings
    progress : callable(str), optional
        Called with a progress line after the first chunk of time steps and then every
        :data:`PROGRESS_EVERY` seconds (stage, mean stress and target, void ratio,
        unbalanced force ratio, time left in the stage once it can be estimated), and at
        the switch to stage 2.

    Raises
    ------
    GrainmechError
        LAMMPS missing or failing (naming the command), the servo not reaching the target
        or the relaxation not converging within ``max_steps`` (naming the stage and the
        numbers reached), too few grains for the cell.
    """
    radii = np.asarray(radii, float)
    n = radii.size
    if n < 50:
        raise GrainmechError(f"n_grains = {n}: at least 50 grains are needed for a periodic packing")
    rng = np.random.default_rng(settings.seed)
    pos, L = place_gas(radii, settings.initial_solid_fraction, rng)
    target = np.concatenate([settings.stress, np.zeros(3)])
    tmean = float(np.mean(settings.stress))
    vs = solid_volume(radii)
    # strain scale of the contacts at the target: delta/(2R) ~ (p/E*)^(2/3) (Hertz, seed Eq. 3.6)
    eps_t = float((tmean / mat.e_star) ** (2.0 / 3.0))
    # contact frequency at the target for the mean grain (kn = 2 E* a, a = sqrt(R* delta))
    rbar = float(np.mean(radii))
    m_bar = mat.density * 4.0 / 3.0 * np.pi * rbar ** 3
    a_t = math.sqrt(0.5 * rbar * 2 * rbar * eps_t)
    kn_t = 2.0 * mat.e_star * a_t
    omega = math.sqrt(kn_t / m_bar)
    say = progress or (lambda s: None)
    hist: list[tuple] = []
    t0 = time.perf_counter()
    watch = _Watch(say, settings, tmean, t0)
    prep_roll = None
    if settings.prep_rolling > 0:
        grain = mat.rolling
        prep_roll = rolling_for_stress(RollingResistance(settings.prep_rolling, None if grain is None else
                                                         grain.stiffness), mat, radii, tmean)
    roll_notes: dict[str, str] = {}
    if prep_roll is not None:
        roll_notes["preparation"] = f"mu_r = {prep_roll.mu_roll:g}, {prep_roll.source} (estimated at the target stress)"
    with Lammps(settings.threads) as lmp:
        consts = setup_lammps(lmp, pos, radii, np.diag([L, L, L]), mat, settings.prep_friction, tmean,
                              rolling=rolling_pair_suffix(prep_roll, rbar, mat.density))
        dt = consts["dt"]
        gamma = settings.viscous * omega * m_bar
        lmp.commands([f"fix drag all viscous {gamma:.10g}", f"thermo {settings.chunk}"])
        lmp.command("run 0 post no")
        chunk = settings.chunk
        steps = 0
        stage = 1
        mu_now = settings.prep_friction
        while True:
            if steps >= settings.max_steps:
                raise _not_converged(lmp, settings.max_steps, stage, tmean, vs)
            p = _stress6(lmp)
            # > 0: too much compression (or too much shear stress) -> expand (or shear back)
            err = (p - target) / tmean
            cell = lammps_cell(lmp)[0]
            e_now = void_ratio(float(np.prod(np.diag(cell))), vs)
            pm = float(p[:3].mean())
            de = _servo_increment(settings, stage, pm, tmean, err, eps_t, rbar, mat.density, chunk, dt)
            within = bool(np.all(np.abs(err) < settings.stress_tol))
            check_ub = stage == 2 and within
            ub = math.nan
            if check_ub:
                net = network_from_lammps(lmp)
                ub = unbalanced_ratio(net)
                if ub < settings.unbalanced_tol:
                    break
            if stage == 1 and abs(pm - tmean) < settings.switch_tol * tmean:
                stage = 2
                grain_roll = None
                if mat.rolling is not None and mat.rolling.active and settings.grain_rolling == "relaxation":
                    grain_roll = rolling_of_network(mat.rolling, mat, network_from_lammps(lmp))
                    roll_notes["grains"] = (f"mu_r = {grain_roll.mu_roll:g}, {grain_roll.source} (at the switch to "
                                            "the grain friction)")
                if mat.friction != mu_now or grain_roll is not None or prep_roll is not None:
                    lmp.command(pair_coeff(mat, mat.friction, rolling_pair_suffix(grain_roll, rbar, mat.density)))
                    mu_now = mat.friction
                    if grain_roll is not None:
                        measure_moments(lmp)
                    elif lmp.has_id("compute", "croll"):
                        lmp.command("uncompute croll")
                dt = _start_relaxation(lmp, radii, mat, settings, tmean, settings.viscous_relax * omega * m_bar, rbar)
                say(f"  stage 2 (grain friction {mat.friction:g}) at step {steps}, void ratio {e_now:.4f}")
                watch.switch(time.perf_counter())
            if stage == 2 and within:
                de = np.zeros(6)  # hold the cell: relax
            _run_chunk(lmp, de, chunk, dt)
            steps += chunk
            now = time.perf_counter()
            hist.append((steps, now - t0, pm, e_now, ub, stage))
            watch.chunk(now, steps, stage, pm, e_now, ub, float(np.max(np.abs(err))))
        net = network_from_lammps(lmp)
        ub = unbalanced_ratio(net)
        p_l = lmp.vector("press")
    summary = packing_summary(net, mat, frictional=mat.friction > 0)
    summary.update({
        "unbalanced_force_ratio": ub,
        "unbalanced_force_ratio_lever_radius": unbalanced_ratio(net, lever="radius"), "target_stress_Pa": list(target),
        "lammps_stress_Pa": {k: float(v) for k, v in zip(("xx", "yy", "zz", "xy", "xz", "yz"), p_l[:6])},
        "prep_friction": settings.prep_friction, "seed": settings.seed, "time_steps": steps,
        "time_step_s": dt, "wall_time_s": time.perf_counter() - t0,
        "model": "LAMMPS pair_style granular hertz/material + tangential mindlin (no-slip "
                 "Mindlin stiffness, Coulomb cap), damping coeff_restitution"
                 + (" + rolling sds / twisting sds" if roll_notes else ""),
    })
    if mat.rolling is not None and mat.rolling.active and settings.grain_rolling == "after":
        roll_notes["grains"] = (f"mu_r = {mat.rolling.friction:g}, not in the preparation (grain_rolling = "
                                "\"after\"): the packing is relaxed with the grain friction only, the grains' "
                                "rolling springs start unloaded at the prepared state (contact moments zero)")
    if roll_notes:
        summary["rolling"] = roll_notes
        summary["prep_rolling_friction"] = settings.prep_rolling
    return PackResult(net, summary, np.array(hist, float).reshape(-1, 6))

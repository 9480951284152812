"""Reading a ``grainmech run`` config into a :class:`~grainmech.jobs.spec.RunSpec` (strict keys).

Tables ``[model]``, ``[microstructure]`` (``[packing]`` in older configs), ``[fabric]``,
``[contacts]``, ``[initial]``, ``[quadrature]``, ``[test]`` (with ``[[test.segments]]`` of a
path), ``[reference]``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from grainmech.analysis import MENQ_D50_MAX
from grainmech.contact.forms import normal_law
from grainmech.driver import concatenate, cycles, parse_mask, segment
from grainmech.driver.base import KinematicModel
from grainmech.driver.registry import MODELS, own_keys
from grainmech.driver.registry import model as registered
from grainmech.errors import ConfigError, GrainmechError
from grainmech.fabric import LEBEDEV_ORDERS
from grainmech.io.config import Section
from grainmech.io.dem import read_network
from grainmech.io.schema import (
    GRAINS_PRESSURE_RANGE,
    build_fabric,
    build_law,
    build_microstructure,
    build_pressure,
    build_rolling,
    microstructure_key,
)
from grainmech.io.units import to_float
from grainmech.jobs.checks import input_warnings
from grainmech.jobs.dem import _check_dem, _check_dem_states, _read_dem_keys, _read_dem_path_keys
from grainmech.jobs.spec import (
    CYCLIC_SIMPLE_SHEAR,
    MAX_STATES,
    RUN_METHODS,
    RUN_TEST_KINDS,
    PackingSource,
    RunSpec,
    _read_amplitudes,
    check_states,
)
from grainmech.packing import load_packing, measured_grading
from grainmech.packing.shipped import describe_packing

__all__ = ["prepare_run"]


#: the grading Menq's (2003) curve takes when the run has no grains and ``[reference]``
#: gives none: coefficient of uniformity and D50 [m] of the shipped packings' sand
#: (``grainmech.packing.shipped``: drawn from ``D50 = 0.3 mm``, ``Cu = 1.3``), a uniform
#: clean quartz sand like those the default run's analytical microstructure describes
DEFAULT_MENQ_GRADING = (1.3, 3e-4)


def _menq_grading(ref: Any, spec: RunSpec) -> dict:
    """``uniformity_coefficient``, ``d50`` [m] and their ``grading_source`` for Menq's curve.

    A key of ``[reference]`` wins; else the grains the run used (``spec.grains``, or the
    ``gmax_packing`` of an affine run) measured by mass (:func:`measured_grading`); else
    :data:`DEFAULT_MENQ_GRADING`.
    """
    cu = ref.number("uniformity_coefficient", None, None, min=1)
    d50 = ref.number("d50", "m", None, min=0, min_inclusive=False, max=MENQ_D50_MAX)
    grains = spec.grains if spec.grains is not None else spec.gmax_grains
    sources = {}
    no_grains = "default (the shipped packings' sand; this run has no grains)"
    measured, on_grains = None, ""
    if grains is not None and grains.network.radii is not None:
        measured = measured_grading(grains.network.radii)
        on_grains = f"measured by mass on the {measured.n_grains} grains of {grains.label}"
    elif grains is not None:
        no_grains = f"default (the shipped packings' sand; the grains of {grains.label} have no radii)"
    if cu is not None:
        sources["uniformity_coefficient"] = "[reference] uniformity_coefficient"
    elif measured is not None:
        cu = measured.cu
        sources["uniformity_coefficient"] = on_grains
    else:
        cu = DEFAULT_MENQ_GRADING[0]
        sources["uniformity_coefficient"] = no_grains
    if d50 is not None:
        sources["d50"] = "[reference] d50"
    elif measured is not None:
        d50 = measured.d50
        sources["d50"] = on_grains
    else:
        d50 = DEFAULT_MENQ_GRADING[1]
        sources["d50"] = no_grains
    if sources["uniformity_coefficient"] == sources["d50"]:
        text = sources["d50"]
    else:
        text = f"Cu: {sources['uniformity_coefficient']}; D50: {sources['d50']}"
    return {"uniformity_coefficient": float(cu), "d50": float(d50), "grading_source": text}


#: keys of ``[model.packing_options]``: the packing model's small-strain bounds
#: (:class:`grainmech.driver.packing.PackingOptions`)
PACKING_OPTION_KEYS = ("max_fluctuation", "max_strain")


def _refuse_unused_model_keys(model: Any, methods: tuple) -> None:
    """A model's own ``[model]`` keys or table in a config that does not run it: named, not "unknown key".

    Each registered model's :func:`~grainmech.driver.registry.own_keys`.
    """
    for m in MODELS.values():
        if m.name in methods:
            continue
        for k in own_keys(m):
            if model.has(k):
                raise ConfigError(model.key(k), model.raw(k), f"is for method = {m.name!r}, which this config does "
                                  f"not use (method = {list(methods)})")


def _read_packing_options(model: Any) -> dict:
    """``[model.packing_options]``: ``max_fluctuation`` and ``max_strain`` of the packing model.

    Both are the bounds of its fixed reference geometry (a grain's displacement
    fluctuation as a fraction of its radius; a strain component); a step past either stops
    the amplitude (``docs/models/packing.md``, "Small-strain range").
    """
    if not model.has("packing_options"):
        return {}
    sec = model.section("packing_options", {})
    out = {k: sec.number(k, None, min=0, min_inclusive=False) for k in PACKING_OPTION_KEYS if sec.has(k)}
    if "max_fluctuation" in out and out["max_fluctuation"] > 1.0:
        raise ConfigError(sec.key("max_fluctuation"), out["max_fluctuation"], "must be <= 1 (a fraction of the "
                          "grain radius; beyond it the fixed reference geometry means nothing)")
    if "max_strain" in out and out["max_strain"] > 0.1:
        raise ConfigError(sec.key("max_strain"), out["max_strain"], "must be <= 0.1 (the packing model is a "
                          "small-strain model)")
    sec.finish()
    return out


def affine_rolling_note(rolling: Any) -> str:
    """What the affine model says of rolling resistance: it is inert there (warning and note)."""
    what = f"contacts.rolling_friction = {rolling.friction:g}"
    if rolling.twisting_friction is not None:
        what += f", contacts.twisting_friction = {rolling.twisting_friction:g}"
    return (f"{what}: rolling and twisting resistance is inert in the affine model (every contact follows the "
            "mean strain, so no grain rotates and no contact moment arises); the packing and DEM models "
            "carry it")


def _read_methods(model: Any) -> tuple:
    """``[model] method``: one of :data:`RUN_METHODS` or a list of them (default ``"affine"``)."""
    raw = model.raw("method", "affine")
    items = [raw] if isinstance(raw, str) else raw
    if not isinstance(items, list) or not items or not all(isinstance(m, str) for m in items):
        raise ConfigError(model.key("method"), raw, f"must be one of {list(RUN_METHODS)} or a list of them")
    bad = [m for m in items if m not in MODELS]
    if bad or len(set(items)) != len(items):
        raise ConfigError(model.key("method"), raw, f"must be one of {list(RUN_METHODS)} or a list of them "
                          "(each at most once)")
    return tuple(items)


class _GmaxKey:
    """``[model]`` seen by :func:`_read_grains` with ``gmax_packing`` in place of ``packing``."""

    #: the key :func:`_read_grains` asks for -> the key of ``[model]`` it reads
    _KEYS = {"packing": "gmax_packing"}

    def __init__(self, model: Any) -> None:
        self._m = model

    def has(self, k: str) -> bool:
        return k in self._KEYS and self._m.has(self._KEYS[k])

    def raw(self, k: str, default: Any = None) -> Any:
        return self._m.raw(self._KEYS[k], default) if k in self._KEYS else default

    def key(self, k: str) -> str:
        return self._m.key(self._KEYS.get(k, k))


def _read_grains(model: Any, base_dir: str | Path | None, who: str = "method = 'packing'") -> PackingSource:
    """The packing of ``method = "packing"`` or ``"dem"`` from the ``[model]`` table.

    ``packing = "<name>"`` (a shipped packing, :func:`grainmech.packing.load_packing`) or
    ``network = "<file>"`` (a contact network :func:`grainmech.io.dem.read_network` reads;
    ``particles`` and ``format`` as in the ``[network]`` table of ``grainmech dem``).
    """
    has_name, has_file = model.has("packing"), model.has("network")
    if has_name == has_file:
        raise ConfigError(model.key("packing"), model.raw("packing", None),
                          f"{who} needs exactly one of model.packing (a shipped packing by name) "
                          "or model.network (a contact-network file)")
    if has_name:
        name = model.raw("packing")
        if not isinstance(name, str):
            raise ConfigError(model.key("packing"), name, "must be the name of a shipped packing")

        try:
            net = load_packing(name)
        except GrainmechError as exc:
            raise ConfigError(model.key("packing"), name, str(exc)) from None
        label = f"shipped packing {name!r}"
        description = describe_packing(name)
    else:
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
        label = str(model.raw("network"))
        description = ""
        try:  # a missing, empty or truncated file: named by the key that names it
            net = read_network(contacts, particles, format=fmt)
        except (GrainmechError, OSError) as exc:
            k = "particles" if particles is not None and _names(exc, particles) else "network"
            why = str(exc) if isinstance(exc, GrainmechError) else f"{exc.strerror}: {exc.filename}"
            raise ConfigError(model.key(k), model.raw(k), why) from None
    if net.dim != 3 or net.radii is None or not net.box.periodic.all():
        raise ConfigError(model.key("packing" if has_name else "network"), label,
                          "the packing driver needs a 3D periodic packing of spheres with radii")
    return PackingSource(label, net, description)


def _names(exc: BaseException, path: Path) -> bool:
    """Whether the error ``exc`` is about the file ``path`` (its message or filename names it)."""
    return str(path) in str(exc) or str(getattr(exc, "filename", "")) == str(path)


def _segments(sec: Any) -> tuple[Any, tuple[int, ...]]:
    """``[[test.segments]]`` -> (LoadPath, the step count at each segment's end).

    Each segment: ``control``, and ``change`` and ``steps`` or ``direction``, ``amplitude``,
    ``n_cycles`` and ``steps_per_cycle``.
    """
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
            parts.append(segment(ctrl, change, s.integer("steps", min=1, max=MAX_STATES)))
        else:
            d = s.raw("direction")
            if not isinstance(d, list) or len(d) != 6:
                raise ConfigError(s.key("direction"), d, "must list 6 values")
            direction = [float(to_float(v, None, s.key("direction"))) for v in d]
            k = int(np.argmax(np.abs(direction)))
            amp = s.number("amplitude", units[k], min=0, min_inclusive=False)
            n, per = s.integer("n_cycles", min=1, max=MAX_STATES), s.integer("steps_per_cycle", min=4, max=MAX_STATES)
            check_states(s, ("n_cycles", "steps_per_cycle"), n, per, what="steps in this segment")
            parts.append(cycles(ctrl, direction, amp, n, per, s.choice("waveform", ("triangle", "sine"), "triangle")))
        total = sum(len(p) for p in parts)
        if total > MAX_STATES:
            raise ConfigError(sec.key("segments"), f"{total} steps", f"the path has more than {MAX_STATES:.0e} "
                              "steps in all (memory and time)")
        s.finish()
    return concatenate(parts), tuple(int(n) for n in np.cumsum([len(p) for p in parts]))


def prepare_run(cfg: dict, base_dir: str | Path | None = None) -> RunSpec:
    """Read a driver config (strict keys).

    Tables ``[model]``, ``[microstructure]`` (``[packing]`` in older configs, read with a
    warning), ``[fabric]``, ``[contacts]``, ``[initial]``, ``[quadrature]``, ``[test]``,
    ``[reference]``.
    """
    root = Section(cfg, "")
    model = root.section("model", {})
    methods = _read_methods(model)
    models: tuple[KinematicModel, ...] = tuple(registered(m) for m in methods)
    _refuse_unused_model_keys(model, methods)
    grain_methods = [m.name for m in models if m.needs_grains]
    # the analytical microstructure ([microstructure], [fabric]) of the models that need no grains
    microstructure = any(not m.needs_grains for m in models)
    ms_key = microstructure_key(root)
    grains = (_read_grains(model, base_dir, " and ".join(f"method = {m!r}" for m in grain_methods))
              if grain_methods else None)
    gmax_grains = None
    if model.has("gmax_packing"):
        if grain_methods:
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
    lo, hi = GRAINS_PRESSURE_RANGE
    if grains is not None and not lo <= pressure <= hi:
        raise ConfigError("initial.pressure", ini.raw("pressure"), f"is {pressure:.4g} Pa, outside the range a packing "
                          f"of grains is brought to ({lo:g} Pa to {hi:g} Pa) by method 'packing' or 'dem'")
    contacts = root.section("contacts")
    if microstructure:
        ms = build_microstructure(root.section(ms_key), density, pressure)
        law = build_law(contacts, ms.radius, rolling=True)
    else:
        if root.has(ms_key):
            raise ConfigError(ms_key, None, f"[{ms_key}] describes the affine model's analytical microstructure "
                              "(void ratio, coordination, radius); with method = 'packing' or 'dem' the "
                              "grains come from model.packing or model.network: remove the table or add "
                              "'affine' to model.method")
        ms = None
        if grains is None:  # _read_grains gives the packing whenever 'packing' is a method
            raise ConfigError("model.method", list(methods), "the packing model needs model.packing or model.network")
        law = build_law(contacts, float(np.median(grains.network.require_radii("the packing model"))), rolling=True)
    rolling = build_rolling(contacts, law)
    grain_law = None
    if grains is not None or gmax_grains is not None:
        if normal_law(law) not in ("hertz", "linear"):
            who = "method = 'packing'" if grains is not None else "model.gmax_packing"
            raise ConfigError("contacts.law", type(law).__name__, f"{who} needs a law for spheres "
                              "(linear, hertz, hertz-mindlin, mindlin-deresiewicz)")
    if any(m.engine is not None for m in models):
        _check_dem(law)  # the engine is LAMMPS: installed, and a law it runs
    if grains is not None:
        # the packing driver evaluates every contact at its own radius R_A R_B / (R_A + R_B)
        # (exact for Hertz-Mindlin forces, grainmech.driver.packing._law_scale): the law's
        # own radius is only a reference
        grain_law = law
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
    if gmax_grains is not None and kind != CYCLIC_SIMPLE_SHEAR:
        raise ConfigError(model.key("gmax_packing"), model.raw("gmax_packing"),
                          f"is reported beside the G/Gmax curves of a cyclic test, not with test.kind = {kind!r}")
    ref = root.section("reference", {})
    packing_options = _read_packing_options(model)
    spec = RunSpec(kind=kind, microstructure=ms, law=law, pressure=pressure, degree=degree,
                   methods=methods, grains=grains, grain_law=grain_law, gmax_grains=gmax_grains,
                   packing_options=packing_options, rolling=rolling)
    pk = cfg.get(ms_key, {})
    if isinstance(pk, dict) and "void_ratio" in pk:
        spec.void_ratio = float(pk["void_ratio"])  # validated by build_microstructure
    spec.friction = float(getattr(law, "friction", float("inf")))
    spec.warnings = input_warnings(cfg)
    if rolling is not None and microstructure:
        spec.warnings.append(affine_rolling_note(rolling))
    if fit and ((fit["p_value"] is not None and fit["p_value"] < 0.01) or fit["shrink_factor"] < 1):
        spec.warnings.append(fit["summary"] + ": the fitted order does not describe the measured normals "
                             "well (raise fabric.fit_order, or check the file)")
    if kind == CYCLIC_SIMPLE_SHEAR:
        spec.amplitudes = _read_amplitudes(test, "amplitudes")
        for m in models:  # a model's own amplitude list (the spec's field of the same name)
            if m.amplitudes_key is not None and model.has(m.amplitudes_key):
                setattr(spec, m.amplitudes_key, _read_amplitudes(model, m.amplitudes_key))
        _read_dem_keys(spec, model)
        spec.keep_beyond_envelope = model.boolean("keep_beyond_envelope", False)
        spec.n_cycles = test.integer("n_cycles", 2, min=2, max=MAX_STATES)
        spec.steps_per_cycle = test.integer("steps_per_cycle", 40, min=8, max=MAX_STATES)
        check_states(test, ("n_cycles", "steps_per_cycle"), spec.n_cycles, spec.steps_per_cycle)
        _check_dem_states(spec, test)
        spec.waveform = test.choice("waveform", ("triangle", "sine"), "triangle")
        spec.constant = test.choice("constant", ("stress", "volume"), "stress")
        mu = float(getattr(grain_law, "friction", 0.0) or 0.0)
        if grain_law is not None and not (0 < mu < float("inf")):
            raise ConfigError("contacts.friction", getattr(grain_law, "friction", None),
                              "damping needs friction: the packing model's loops have no area without a finite "
                              "Coulomb limit (give contacts.friction or contacts.friction_angle)")
        spec.reference = dict(
            pi=ref.number("plasticity_index", None, 0.0, min=0),
            ocr=ref.number("ocr", None, 1.0, min=0, min_inclusive=False),
            n_cycles=ref.number("n_cycles", None, 10.0, min=0, min_inclusive=False),
            frequency=ref.number("frequency", "Hz", 1.0, min=0, min_inclusive=False),
            phi=ref.angle("friction_angle", float(np.radians(33.0)), max_deg=90.0))
        spec.reference.update(_menq_grading(ref, spec))
        root.finish()
        return spec
    for k in ("packing_amplitudes", "dem_amplitudes", "dem_steps_per_cycle", "keep_beyond_envelope"):
        if model.has(k):
            raise ConfigError(model.key(k), model.raw(k), f"is for test.kind = 'cyclic-simple-shear', not {kind!r}")
    _read_dem_path_keys(spec, model)
    spec.path, spec.segment_ends = _segments(test)
    root.finish()
    return spec

"""A soil profile read from ``PROFILE.toml``: layers, water table, stresses at mid-depth.

``grainmech site`` (``docs/site-profile.md``) reads a profile of horizontal layers over a
half-space, works out every layer's effective stresses at mid-depth and turns each layer
into the config of one ``grainmech run`` (cyclic simple shear at the layer's mean
effective stress). This module reads and checks the profile (strict keys, units at the
edge, every error one line naming the layer and the key) and computes the stresses; it
runs nothing.

Stresses (compression positive, Pa) at the mid-depth ``z`` of a layer, with the water
table at depth ``z_w`` below the surface (Terzaghi's effective stress):

* total vertical stress ``sigma_v = sum gamma_i h_i`` over the soil above ``z``;
* pore pressure ``u = gamma_w max(0, z - z_w)`` (hydrostatic);
* ``sigma'_v = sigma_v - u``, ``sigma'_h = K0 sigma'_v``,
  mean effective stress ``p' = (sigma'_v + 2 sigma'_h) / 3``.

``K0`` is a number or Jaky's (1944) rule ``K0 = 1 - sin(phi')`` with each layer's
friction angle (normally consolidated sand).
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grainmech.errors import ConfigError
from grainmech.io.config import Section
from grainmech.io.motion import MOTION_UNITS
from grainmech.io.schema import MICROSTRUCTURE, RENAMED_TABLES, microstructure_key
from grainmech.jobs import RUN_TEST_KINDS
from grainmech.site.density import choose_packing, named_packing

__all__ = ["SiteProfile", "Layer", "Bedrock", "MotionSpec", "read_profile", "jaky_k0", "layer_stresses",
           "GRAVITY", "GAMMA_WATER", "GRAIN_MODULUS_RANGE", "GRAIN_MODULUS_PLAUSIBLE", "SITE_METHODS",
           "DEFAULT_AMPLITUDES"]

#: standard gravity [m/s^2] (mass density = unit weight / g)
GRAVITY = 9.80665
#: unit weight of water [N/m^3] (default of ``[site] unit_weight_water``)
GAMMA_WATER = 9.81e3
#: grain shear moduli [Pa] a ``vs`` anchoring may ask for (1-1000 GPa)
GRAIN_MODULUS_RANGE = (1e9, 1e12)
#: grain shear moduli [Pa] of real minerals (quartz 29-44 GPa, feldspars ~25-40, calcite ~32):
#: an anchoring outside it is run, with a warning that the packing does not match the site's stiffness
GRAIN_MODULUS_PLAUSIBLE = (10e9, 100e9)
#: strain amplitudes of every layer when the profile gives no ``[test] amplitudes``:
#: 1e-6 ... 1e-2, three per decade (1, 2, 5)
DEFAULT_AMPLITUDES = [m * 10.0 ** k for k in range(-6, -2) for m in (1.0, 2.0, 5.0)] + [1e-2]
#: tables of a run config that a layer may override (copied into the layer's run config)
#: (``[packing]``, the old name of ``[microstructure]``, too: the run reads it with a warning)
RUN_TABLES = ("model", "contacts", "fabric", MICROSTRUCTURE, *RENAMED_TABLES, "quadrature", "test", "reference")
#: layer keys naming its grains, and where they go in the layer's run config
#: (``MICROSTRUCTURE``: the analytical microstructure's table under the profile's name for it)
GRAIN_KEYS = {"packing": ("model", "packing"), "network": ("model", "network"),
              "particles": ("model", "particles"), "format": ("model", "format"),
              "void_ratio": (MICROSTRUCTURE, "void_ratio"), "coordination": (MICROSTRUCTURE, "coordination"),
              "radius": (MICROSTRUCTURE, "radius")}
#: the kinematic models a profile can run (``[model] method``): one model, or the packing
#: model over its range and the DEM model beyond it (the default)
SITE_METHODS = (("packing", "dem"), ("packing",), ("dem",), ("affine",))
#: the models that run on a packing of grains
_GRAIN_MODELS = ("packing", "dem")


@dataclass(frozen=True)
class Layer:
    """One layer of the profile, with its stresses at mid-depth.

    Attributes
    ----------
    index : int
        Position from the top (0 first).
    name : str
    thickness, top, mid : float
        Thickness, depth of its top and of its middle [m].
    unit_weight : float
        Total unit weight [N/m^3] (``density * g`` if the layer gives ``density``).
    vs : float or None
        Measured shear-wave velocity [m/s] the model is anchored to, if given.
    k0 : float
        Coefficient of earth pressure at rest used.
    sigma_v, u, sigma_v_eff, sigma_h_eff, p_eff : float
        Total vertical stress, pore pressure, effective vertical and horizontal stress and
        mean effective stress at mid-depth [Pa].
    run_config : dict
        The ``grainmech run`` config of the layer (before ``[initial] pressure``).
    key_map : dict
        Run-config key -> profile key, to name the profile's key in an error.
    packing_choice : dict or None
        The packing chosen by the layer's ``relative_density`` or ``void_ratio``
        (:func:`grainmech.site.density.choose_packing`), or the named one against them.
    """

    index: int
    name: str
    thickness: float
    top: float
    unit_weight: float
    vs: float | None
    k0: float
    sigma_v: float
    u: float
    sigma_v_eff: float
    sigma_h_eff: float
    p_eff: float
    run_config: dict = field(default_factory=dict)
    key_map: dict = field(default_factory=dict)
    packing_choice: dict | None = None

    @property
    def mid(self) -> float:
        """Depth of the middle of the layer [m]."""
        return self.top + 0.5 * self.thickness

    @property
    def bottom(self) -> float:
        """Depth of the bottom of the layer [m]."""
        return self.top + self.thickness

    @property
    def density(self) -> float:
        """Total mass density ``rho = gamma / g`` [kg/m^3]."""
        return self.unit_weight / GRAVITY

    @property
    def label(self) -> str:
        """``layers[i] 'name'`` for messages."""
        return f"layers[{self.index}] {self.name!r}"

    @property
    def slug(self) -> str:
        """File-name form ``NN-name`` of the layer."""
        s = re.sub(r"[^A-Za-z0-9]+", "-", self.name).strip("-").lower()[:SLUG_LENGTH].strip("-") or "layer"
        return f"{self.index + 1:02d}-{s}"


#: longest name part of a layer's file names (a file name of 255 bytes is the usual limit;
#: the layer's number keeps two long names apart)
SLUG_LENGTH = 60
#: shear-wave velocities of soils and rocks [m/s] (soft clays ~50, hard rock ~3500)
VS_RANGE = (10.0, 10_000.0)
#: unit weights of soils and rocks [N/m^3] (no mineral is denser than ~5 t/m^3)
UNIT_WEIGHT_MAX = 50e3
#: largest damping ratio of the bedrock (rock: 0.5-5 %)
BEDROCK_DAMPING_MAX = 0.2


@dataclass(frozen=True)
class Bedrock:
    """The elastic half-space below the profile (for the site-response run).

    ``vs`` [m/s], ``unit_weight`` [N/m^3], ``damping`` (decimal).
    """

    vs: float
    unit_weight: float
    damping: float


@dataclass(frozen=True)
class MotionSpec:
    """``[motion]``: the input motion file (read by :func:`grainmech.io.motion.read_motion`).

    ``path`` the file, ``format`` ``"peer"`` (AT2) or ``"two-column"`` (time [s],
    acceleration), ``units`` of the acceleration (``"g"``, ``"m/s^2"``, ``"cm/s^2"``;
    ``None``: from the AT2 header), ``location`` ``"outcrop"`` or ``"within"`` (where the
    motion was recorded: on rock outcrop or at the base inside the profile).
    """

    path: Path
    format: str
    units: str | None
    location: str = "outcrop"


@dataclass(frozen=True)
class SiteProfile:
    """A profile read by :func:`read_profile`.

    Attributes
    ----------
    source : str
        File name (for reports).
    base_dir : Path
        Folder of the profile file (relative file paths are read from there).
    water_table : float
        Depth of the water table [m] (``inf``: none).
    gamma_w : float
        Unit weight of water [N/m^3].
    k0_rule : str
        ``"given"`` or ``"jaky"``.
    method : str
        The kinematic model(s) of every layer, ``"packing+dem"`` for the two
        (:data:`SITE_METHODS`; :attr:`methods` as a tuple).
    layers : list of Layer
    bedrock : Bedrock or None
    motion : MotionSpec or None
    raw : dict
        The profile as read (for ``summary.json``).
    """

    source: str
    base_dir: Path
    water_table: float
    gamma_w: float
    k0_rule: str
    method: str
    layers: list
    bedrock: Bedrock | None
    motion: MotionSpec | None
    raw: dict

    @property
    def methods(self) -> tuple[str, ...]:
        """The kinematic models of every layer, in the order they run."""
        return tuple(self.method.split("+"))

    @property
    def depth(self) -> float:
        """Depth of the bottom of the profile [m]."""
        return self.layers[-1].bottom if self.layers else 0.0


def jaky_k0(friction_angle: float) -> float:
    """Jaky's (1944) coefficient of earth pressure at rest ``K0 = 1 - sin(phi')`` (phi' in rad)."""
    return 1.0 - math.sin(friction_angle)


def layer_stresses(top: float, thickness: float, gamma: float, sigma_above: float, water_table: float,
                   gamma_w: float, k0: float) -> tuple[float, float, float, float, float]:
    """Stresses at the mid-depth of a layer (Terzaghi's effective stress, hydrostatic water).

    Parameters
    ----------
    top, thickness : float
        Depth of the layer's top and its thickness [m].
    gamma : float
        Total unit weight of the layer [N/m^3].
    sigma_above : float
        Total vertical stress at the layer's top [Pa].
    water_table : float
        Depth of the water table [m] (``inf``: dry profile).
    gamma_w : float
        Unit weight of water [N/m^3].
    k0 : float
        ``sigma'_h / sigma'_v``.

    Returns
    -------
    sigma_v, u, sigma_v_eff, sigma_h_eff, p_eff : float
        [Pa], ``p' = (sigma'_v + 2 sigma'_h) / 3``.
    """
    z = top + 0.5 * thickness
    sigma_v = sigma_above + gamma * 0.5 * thickness
    u = gamma_w * max(0.0, z - water_table)
    sv = sigma_v - u
    sh = k0 * sv
    return sigma_v, u, sv, sh, (sv + 2.0 * sh) / 3.0


def _density(item: Section, run: dict, key_map: dict, label: str, grain_models: bool) -> dict | None:
    """The packing a layer's ``relative_density`` / ``void_ratio`` chooses (module :mod:`grainmech.site.density`).

    ``relative_density`` always chooses a shipped sand packing (or is compared with the
    one the layer names); ``void_ratio`` does so where the layer runs on grains (the
    packing or DEM model), and is the analytical ``[microstructure] void_ratio`` of the affine
    model otherwise.
    """
    if item.has("relative_density") and item.has("void_ratio"):
        raise ConfigError(item.key("void_ratio"), item.raw("void_ratio"),
                          f"{label}: give relative_density or void_ratio, not both")
    key = "relative_density" if item.has("relative_density") else "void_ratio" if item.has("void_ratio") else None
    if key is None or (key == "void_ratio" and not grain_models):
        return None
    value = item.number(key, None)
    where = item.key(key)
    own = item.raw("packing") if item.has("packing") else None
    if own is not None:
        return named_packing(str(own), key, value, where, label)
    if any(item.has(k) for k in ("network", "particles")):
        raise ConfigError(where, value, f"{label}: a layer's density chooses a shipped sand packing; this layer "
                          "gives its own network file")
    choice = choose_packing(key, value, where, label)
    for k in ("packing", "network", "particles", "format"):  # the chosen packing replaces the profile's grains
        run.get("model", {}).pop(k, None)
    run.setdefault("model", {})["packing"] = choice["packing"]
    run.get(microstructure_key(Section(run, "")), {}).pop("void_ratio", None)
    key_map["model.packing"] = where
    return choice


def _grains(item: Section, run: dict, key_map: dict, label: str, grain_models: bool) -> dict | None:
    """The layer's grain keys (:data:`GRAIN_KEYS`) and override tables into its run config.

    Returns the packing chosen by the layer's density (:func:`_density`), if any.
    """
    if any(item.has(k) for k in ("packing", "network", "particles", "format")):
        for k in ("packing", "network", "particles", "format"):  # the layer's grains replace the profile's
            run.get("model", {}).pop(k, None)
    density = _density(item, run, key_map, label, grain_models)
    ms = microstructure_key(Section(run, ""))
    for k, (table, key) in GRAIN_KEYS.items():
        if k == "void_ratio" and grain_models:
            continue
        table = ms if table == MICROSTRUCTURE else table
        if item.has(k):
            run.setdefault(table, {})[key] = item.raw(k)
            key_map[f"{table}.{key}"] = item.key(k)
    for t in ("contacts", "fabric"):
        if item.has(t):
            tab = item.raw(t)
            if not isinstance(tab, dict):
                raise ConfigError(item.key(t), tab, f"{label}: must be a table (replaces the profile's [{t}])")
            run[t] = copy.deepcopy(tab)
            for k in tab:
                key_map[f"{t}.{k}"] = f"{item.key(t)}.{k}"
    return density


def _read_layers(root: Section, run_base: dict, water_table: float, gamma_w: float,
                 k0_given: float | None, grain_models: bool) -> list[Layer]:
    raw = root.raw("layers")
    if not isinstance(raw, list) or not raw or not all(isinstance(x, dict) for x in raw):
        raise ConfigError("layers", raw, "must be a non-empty array of tables [[layers]]")
    layers: list[Layer] = []
    names: set[str] = set()
    top = sigma = 0.0
    for i, d in enumerate(raw):
        item = Section(d, f"layers[{i}]")
        name = item.raw("name", f"layer {i + 1}")
        if not isinstance(name, str) or not name.strip() or name in names:
            raise ConfigError(item.key("name"), name, "must be a non-empty text, different for every layer")
        names.add(name)
        label = f"layers[{i}] {name!r}"
        h = item.number("thickness", "m")
        if not h > 0:
            raise ConfigError(item.key("thickness"), item.raw("thickness"), f"{label}: must be > 0 m")
        if item.has("unit_weight") == item.has("density"):
            raise ConfigError(item.key("unit_weight"), None, f"{label}: give exactly one of unit_weight or density")
        if item.has("unit_weight"):
            gamma, key = item.number("unit_weight", "N/m^3", max=UNIT_WEIGHT_MAX), "unit_weight"
        else:
            gamma, key = item.number("density", "kg/m^3", max=UNIT_WEIGHT_MAX / GRAVITY) * GRAVITY, "density"
        if not gamma > gamma_w:
            raise ConfigError(item.key(key), item.raw(key), f"{label}: the unit weight {gamma / 1e3:.4g} kN/m^3 must "
                              f"exceed water's ({gamma_w / 1e3:.4g} kN/m^3): below the water table the effective "
                              "stress would not grow with depth")
        vs = item.number("vs", "m/s", None, min=VS_RANGE[0], max=VS_RANGE[1]) if item.has("vs") else None
        if k0_given is not None:
            k0 = k0_given
            if item.has("friction_angle"):
                item.angle("friction_angle", max_deg=90.0)
        else:
            if not item.has("friction_angle"):
                raise ConfigError(item.key("friction_angle"), None,
                                  f"{label}: site.k0 = 'jaky' needs the layer's friction angle (K0 = 1 - sin phi')")
            k0 = jaky_k0(item.angle("friction_angle", max_deg=90.0, max_inclusive=False))
        run = copy.deepcopy(run_base)
        # the layer's mean effective stress at mid-depth is the run's initial.pressure, which a
        # profile does not have: a stress out of range is the layer's depth and thickness
        key_map: dict[str, str] = {"initial.pressure": f"{item.key('thickness')} (the mean effective stress at "
                                                       "mid-depth)"}
        density = _grains(item, run, key_map, label, grain_models)
        item.finish()
        sv, u, sve, she, p = layer_stresses(top, h, gamma, sigma, water_table, gamma_w, k0)
        layers.append(Layer(index=i, name=name, thickness=h, top=top, unit_weight=gamma, vs=vs, k0=k0,
                            sigma_v=sv, u=u, sigma_v_eff=sve, sigma_h_eff=she, p_eff=p,
                            run_config=run, key_map=key_map, packing_choice=density))
        top += h
        sigma += gamma * h
    return layers


def _read_bedrock(root: Section) -> Bedrock | None:
    if not root.has("bedrock"):
        return None
    b = root.section("bedrock")
    return Bedrock(vs=b.number("vs", "m/s", min=VS_RANGE[0], max=VS_RANGE[1]),
                   unit_weight=b.number("unit_weight", "N/m^3", min=GAMMA_WATER, max=UNIT_WEIGHT_MAX),
                   damping=b.number("damping", None, 0.01, min=0, max=BEDROCK_DAMPING_MAX))


def _read_motion(root: Section, base: Path) -> MotionSpec | None:
    if not root.has("motion"):
        return None
    m = root.section("motion")
    f = m.raw("file")
    if not isinstance(f, str) or not f.strip():
        raise ConfigError(m.key("file"), f, "must be the path of a motion file")
    path = Path(f) if Path(f).is_absolute() else base / f
    fmt = m.choice("format", ("peer", "two-column"), "peer" if path.suffix.lower() == ".at2" else "two-column")
    units = m.raw("units", None)
    if units is not None and units not in MOTION_UNITS:
        raise ConfigError(m.key("units"), units, f"unknown acceleration units: must be one of {list(MOTION_UNITS)}")
    if units is None and fmt == "two-column":
        raise ConfigError(m.key("units"), None, f"a two-column motion needs its units, one of {list(MOTION_UNITS)}")
    loc = m.choice("location", ("outcrop", "within"), "outcrop")
    return MotionSpec(path=path, format=fmt, units=units, location=loc)


def read_profile(cfg: dict, base_dir: str | Path | None = None, source: str = "profile") -> SiteProfile:
    """Read a profile config (the dict of ``PROFILE.toml``; strict keys).

    Tables: ``[site]`` (``water_table`` depth [m], omitted: no water table;
    ``k0`` a number or ``"jaky"``; ``unit_weight_water``), ``[[layers]]`` (``name``,
    ``thickness``, ``unit_weight`` or ``density``, optional ``vs``, ``friction_angle``,
    the grains: ``packing``/``network``/``particles``/``format`` or
    ``void_ratio``/``coordination``/``radius``, optional ``contacts`` and ``fabric``
    tables replacing the profile's), ``[model]``, ``[contacts]``, ``[fabric]``,
    ``[microstructure]``, ``[quadrature]``, ``[test]``, ``[reference]`` as in ``grainmech run``
    (the defaults of every layer), ``[bedrock]`` and ``[motion]`` for the site-response
    run.

    Raises
    ------
    ConfigError
        One line naming the layer and the key.
    """
    base = Path(base_dir) if base_dir is not None else Path(".")
    root = Section(cfg, "")
    site = root.section("site", {})
    gamma_w = site.number("unit_weight_water", "N/m^3", GAMMA_WATER, min=0, min_inclusive=False)
    wt = site.number("water_table", "m", math.inf, min=0) if site.has("water_table") else math.inf
    k0_raw = site.raw("k0", 0.5)
    k0_given: float | None
    if isinstance(k0_raw, str) and k0_raw.strip().lower() == "jaky":
        k0_given, rule = None, "jaky"
    else:
        k0_given, rule = site.number("k0", None, min=0, min_inclusive=False, max=3.0), "given"
    run_base: dict[str, Any] = {}
    for t in RUN_TABLES:
        if root.has(t):
            tab = root.raw(t)
            if not isinstance(tab, dict):
                raise ConfigError(t, tab, "must be a table")
            run_base[t] = copy.deepcopy(tab)
    model = run_base.setdefault("model", {})
    raw_method = model.get("method", list(SITE_METHODS[0]))
    methods = tuple(raw_method) if isinstance(raw_method, list) else (raw_method,)
    if methods not in SITE_METHODS:
        raise ConfigError("model.method", raw_method, "a profile runs the packing model and the DEM model beyond "
                          "its range (['packing', 'dem'], the default) or one model: 'packing', 'dem' or 'affine'")
    model["method"] = list(methods) if len(methods) > 1 else methods[0]
    method = "+".join(methods)
    test = run_base.setdefault("test", {})
    test.setdefault("amplitudes", list(DEFAULT_AMPLITUDES))
    cyclic = RUN_TEST_KINDS[0]  # cyclic simple shear, the test of every layer
    if test.get("kind", cyclic) != cyclic:
        raise ConfigError("test.kind", test.get("kind"), f"a profile runs {cyclic!r}")
    test["kind"] = cyclic
    layers = _read_layers(root, run_base, wt, gamma_w, k0_given, any(m in _GRAIN_MODELS for m in methods))
    bottom = layers[-1].bottom
    if wt > bottom and math.isfinite(wt):
        raise ConfigError("site.water_table", site.raw("water_table"),
                          f"the water table ({wt:g} m) is below the profile (bottom at {bottom:g} m)")
    bedrock = _read_bedrock(root)
    motion = _read_motion(root, base)
    if motion is not None and bedrock is None:
        raise ConfigError("bedrock", None, "[motion] needs the half-space below the profile: [bedrock] vs, unit_weight")
    root.finish()
    return SiteProfile(source=source, base_dir=base, water_table=wt, gamma_w=gamma_w, k0_rule=rule,
                       method=method, layers=layers, bedrock=bedrock, motion=motion, raw=copy.deepcopy(cfg))

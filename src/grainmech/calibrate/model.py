"""Model predictions for calibration: parameters -> predicted data columns, per data kind.

A calibration holds a *model config* (the tables of a ``grainmech stiffness`` or
``grainmech run`` config: ``microstructure``, ``fabric``, ``contacts``...) and a list of
parameters, each a dotted path into it (``contacts.shear_modulus``,
``fabric.a20``, ``microstructure.coordination.n``; ``[packing]``, the microstructure's old
name, is still read). :func:`set_path` writes a trial value
(SI) into a copy of the config; the data kind's ``predict`` builds the library objects
through :mod:`grainmech.io.schema` and returns the predicted columns.

Data kinds (``docs/calibrate.md``)
----------------------------------
``modulus-pressure``
    Engineering constants of a packing under isotropic pressure (seed Eq. 2.41 via
    :func:`grainmech.material.microstructure_stiffness`), one row per pressure (and optionally
    void ratio). Columns: ``pressure``, ``void_ratio`` (optional), and any of ``G``
    (= ``G_xz``; ``G_xy`` in 2D), ``E`` (= ``E_zz``; ``E_xx`` in 2D), ``K`` (bulk), ``nu``
    (= ``nu_xy``) or the named constants ``E_xx``, ``G_yz``, ``nu_zx``...
``directional``
    Apparent modulus and Poisson's ratio against the loading direction ``alpha`` in a
    plane (seed Eq. 6.1 and Eq. 6.2 corrected, :func:`grainmech.analysis.apparent_moduli`;
    2D: :func:`grainmech.tensors.directional_young` / ``directional_poisson``) at the
    stress of ``[model.stress]``. Columns ``alpha [deg]``, ``E``, ``nu``.
``stress-strain``
    A driver path (:func:`grainmech.driver.run`) from the isotropic state
    ``[model.initial] pressure``: row 0 is that state, each next row is reached in
    ``substeps`` linear steps of the controlled columns (``[data] control``, e.g.
    ``"SSEEEE"``: stress control of xx and yy, strain control of the rest). Measured
    (fitted) columns are the uncontrolled ones: ``strain_xx``... where stress is
    controlled, ``stress_xx``... where strain is controlled. Compression positive,
    engineering shear strain, strains from the initial state.
``modulus-reduction``
    Secant G/Gmax and damping from strain-controlled cyclic simple shear
    (:func:`grainmech.analysis.modulus_reduction`). Columns ``strain`` (amplitude,
    decimal), ``G_ratio`` (alias ``G/Gmax``), ``damping`` (decimal), ``G``.
``rod-strains``
    Strains of a rod packing under a stress increment ``increment`` (default 0.5 psi)
    along ``alpha`` (from y towards x) from an isotropic stress ``pressure`` (2.5 psi)
    (seed Sec. 5.3, 6.1.2): :func:`grainmech.rods.random_arrays.strains`, the tangent
    stiffness of rod contacts seed Eq. 3.8 / 3.17. ``[model]`` keys ``packing``
    (``one-size``/``two-size``: :func:`grainmech.rods.random_arrays.random_array` with ``seed``;
    ``square``/``hexagonal``: :func:`grainmech.rods.regular_array` with
    ``[data] diameter``), ``shear_modulus_equiv`` (G~), ``psi``, ``poisson``,
    ``friction_angle``. Columns ``alpha [deg]``, ``eps_xx``, ``eps_yy``, ``eps_xy``
    (tensor shear strain, compression positive).

Coordination as a relation with coefficients
--------------------------------------------
In kinds with a microstructure, ``microstructure.coordination`` may be a table
``{a = 23.0, b = 25.0, n = 0.0, p_ref = "100 kPa"}`` meaning

    m = (a - b e) (p / p_ref)^n

with ``p`` the isotropic (mean) pressure of the state. ``n = 0`` with ``a = 23, b = 25`` is
seed Eq. 6.4 (Chang's line, ``m = 23 - 25 e``); ``n > 0`` is a phenomenological
pressure dependence of the contact number (not in the seed; effective-medium theory
with a fixed ``m`` gives moduli ~ p^(1/3), and measured sands ~ p^(1/2), see
``docs/calibrate.md``). Each of ``a, b, n`` can be fitted.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.analysis import apparent_moduli, modulus_reduction
from grainmech.calibrate.data import Dataset
from grainmech.driver import MaterialPoint, concatenate, parse_mask, run, segment
from grainmech.elasticity import directional_poisson, directional_young, engineering_constants
from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.config import Section
from grainmech.io.schema import (
    RENAMED_TABLES,
    build_fabric,
    build_law,
    build_microstructure,
    build_pressure,
    build_stress,
    check_pressure,
    microstructure_key,
)
from grainmech.material import microstructure_stiffness
from grainmech.rods import regular_array

__all__ = ["DATA_KINDS", "DataKind", "set_path", "get_path", "predict", "parse_settings"]

_COMP = ("xx", "yy", "zz", "yz", "xz", "xy")
_ENG_3D = ("E_xx", "E_yy", "E_zz", "G_yz", "G_xz", "G_xy", "nu_xy", "nu_yx", "nu_xz", "nu_zx",
           "nu_yz", "nu_zy")
_ENG_2D = ("E_xx", "E_yy", "G_xy", "nu_xy", "nu_yx")


@dataclass(frozen=True)
class DataKind:
    """What a data kind reads and predicts.

    ``inputs``: independent columns (not fitted); ``targets``: columns that can be fitted;
    ``required``: columns that must be present; ``model_keys``: allowed top-level tables
    of the model config.
    """

    name: str
    inputs: tuple[str, ...]
    targets: tuple[str, ...]
    required: tuple[str, ...]
    model_keys: tuple[str, ...]
    x: str  # column used as the abscissa of plots
    predict: Callable[..., dict[str, np.ndarray]]
    slow: bool = False  # model evaluations involve a driver run (noisier, slower)


# ----------------------------------------------------------------------- dotted paths

def get_path(cfg: dict, path: str) -> Any:
    """Value at a dotted path of a nested dict (KeyError if absent)."""
    node: Any = cfg
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            raise KeyError(path)
        node = node[part]
    return node


def set_path(cfg: dict, path: str, value: Any, *, key_prefix: str = "model") -> None:
    """Set ``cfg[a][b][c] = value`` for ``path = "a.b.c"`` (in place).

    Intermediate tables must exist (a misspelt table is an error, never created); the
    last key may be new (the model's own key check then rejects an unknown key).
    """
    parts = path.split(".")
    if not path or any(not p for p in parts):
        raise ConfigError(f"{key_prefix}.{path}", path, "is not a dotted key path such as 'contacts.shear_modulus'")
    node = cfg
    for i, part in enumerate(parts[:-1]):
        nxt = node.get(part) if isinstance(node, dict) else None
        if not isinstance(nxt, dict):
            where = ".".join([key_prefix] + parts[:i + 1])
            raise ConfigError(where, nxt, f"parameter {path!r} needs a table [{where}] in the calibration config")
        node = nxt
    old = node.get(parts[-1])
    if isinstance(old, (dict, list)):
        raise ConfigError(f"{key_prefix}.{path}", old, "is a table or array, not a number: fit one of its keys")
    node[parts[-1]] = value


# ----------------------------------------------------------------------- helpers

def _sections(cfg: dict, allowed: tuple[str, ...]):
    root = Section(cfg, "model")
    for k in cfg:
        if k not in allowed and RENAMED_TABLES.get(k) not in allowed:  # an old table name: read, with a warning
            raise ConfigError(f"model.{k}", cfg[k], f"unknown table for this data kind (allowed: {', '.join(allowed)})")
    return root


def _microstructure(root: Any, density: Any, pressure: float) -> Any:
    sec = root.section(microstructure_key(root))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # correlation range warnings: the fit explores
        return build_microstructure(sec, density, pressure)


def _eng_name(name: str, dim: int) -> str:
    if dim == 3:
        return {"G": "G_xz", "E": "E_zz", "nu": "nu_xy"}.get(name, name)
    return {"G": "G_xy", "E": "E_xx", "nu": "nu_xy"}.get(name, name)


# ----------------------------------------------------------------------- kinds

def _predict_modulus_pressure(model: dict, data: Dataset, settings: dict, validate: bool) -> dict:
    """Engineering constants at each row's pressure (seed Eq. 2.41, Hertz-Mindlin Eq. 4.43)."""
    targets = [t for t in DATA_KINDS["modulus-pressure"].targets if data.has(t)]
    out = {t: np.empty(len(data)) for t in targets}
    density = None
    for i in range(len(data)):
        cfg = copy.deepcopy(model)
        if data.has("void_ratio"):
            cfg.setdefault(microstructure_key(Section(cfg, "model")), {})["void_ratio"] = float(data["void_ratio"][i])
        root = _sections(cfg, DATA_KINDS["modulus-pressure"].model_keys)
        if density is None:  # the fabric does not change from row to row
            density = build_fabric(root.section("fabric", {}))
        p = float(data["pressure"][i])
        if p <= 0:
            raise data.error("pressure must be > 0", i, "pressure")
        ms = _microstructure(root, density, p)
        contacts = build_law(root.section("contacts"), ms.radius)
        if validate and i == 0:
            root.finish()
        C = microstructure_stiffness(ms, contacts, p).C
        eng = engineering_constants(C).as_dict()
        for t in targets:
            if t == "K":  # bulk modulus: volumetric strain under p I is sum of the normal block of S
                d = density.dim
                out[t][i] = 1.0 / float(np.sum(np.linalg.inv(C)[:d, :d]))
                continue
            key = _eng_name(t, density.dim)
            if key not in eng:
                raise data.error(f"column {t!r} is not an engineering constant of a {density.dim}D packing "
                                 f"(available: {', '.join(eng)})")
            out[t][i] = float(eng[key])
    return out


def _stiffness_at_stress(model: dict, allowed: tuple[str, ...], validate: bool) -> tuple[np.ndarray, int]:
    cfg = copy.deepcopy(model)
    root = _sections(cfg, allowed)
    density = build_fabric(root.section("fabric", {}))
    stress = build_stress(root.section("stress", {}), density.dim)
    p = float(stress) if np.ndim(stress) == 0 and stress is not None else (
        float(np.trace(stress)) / density.dim if stress is not None else 1.0)
    ms = _microstructure(root, density, p)
    contacts = build_law(root.section("contacts"), ms.radius)
    if validate:
        root.finish()
    return microstructure_stiffness(ms, contacts, stress).C, density.dim


def _predict_directional(model: dict, data: Dataset, settings: dict, validate: bool) -> dict:
    """Apparent modulus (seed Eq. 6.1) and Poisson's ratio (Eq. 6.2 corrected) against alpha."""
    C, dim = _stiffness_at_stress(model, DATA_KINDS["directional"].model_keys, validate)
    alpha = data["alpha"]
    plane = settings["plane"] or ("xz" if dim == 3 else "xy")
    if dim == 3:
        E, nu = apparent_moduli(C, alpha, plane)
    else:
        ax = {"x": 0, "y": 1}
        if len(plane) != 2 or set(plane) != {"x", "y"}:
            raise ConfigError("data.plane", plane, "must be 'xy' or 'yx' for a 2D packing")
        i, j = ax[plane[0]], ax[plane[1]]
        d = np.zeros((alpha.size, 2))
        m = np.zeros((alpha.size, 2))
        d[:, i], d[:, j] = np.cos(alpha), np.sin(alpha)
        m[:, i], m[:, j] = -np.sin(alpha), np.cos(alpha)
        E, nu = directional_young(C, d), directional_poisson(C, d, m)
    out = {}
    if data.has("E"):
        out["E"] = np.asarray(E, dtype=float)
    if data.has("nu"):
        out["nu"] = np.asarray(nu, dtype=float)
    return out


def _point(model: dict, allowed: tuple[str, ...], validate: bool) -> Any:
    """Isotropic material point from a run-like model config."""
    cfg = copy.deepcopy(model)
    root = _sections(cfg, allowed)
    density = build_fabric(root.section("fabric", {}))
    if density.dim != 3:
        raise ConfigError("model.fabric.dim", density.dim, "the driver works in 3D")
    ini = root.section("initial")
    pressure = build_pressure(ini)
    ms = _microstructure(root, density, pressure)
    law = build_law(root.section("contacts"), ms.radius)
    degree = root.section("quadrature", {}).integer("degree", 11, min=4)
    if validate:
        root.finish()
    return MaterialPoint.isotropic(ms, law, pressure, extra_degree=degree)


def _predict_stress_strain(model: dict, data: Dataset, settings: dict, validate: bool) -> dict:
    """Driver path through the rows (seed Ch. 2 kinematics, driver docs/models/affine.md)."""
    point = _point(model, DATA_KINDS["stress-strain"].model_keys, validate)
    mask = settings["control"]
    sub = settings["substeps"]
    ctrl = "".join("S" if m else "E" for m in mask)
    parts = []
    for i in range(1, len(data)):
        change = np.zeros(6)
        for k, c in enumerate(_COMP):
            col = f"stress_{c}" if mask[k] else f"strain_{c}"
            if data.has(col):
                change[k] = data[col][i] - data[col][i - 1]
        parts.append(segment(ctrl, change, sub))
    res = run(point, concatenate(parts))
    if not res.success:
        raise GrainmechError(f"model run failed: {res.message}")
    idx = np.arange(len(data)) * sub
    out = {}
    for k, c in enumerate(_COMP):
        if mask[k] and data.has(f"strain_{c}"):
            out[f"strain_{c}"] = res.strain[idx, k]
        if not mask[k] and data.has(f"stress_{c}"):
            out[f"stress_{c}"] = res.stress[idx, k]
    return out


def _predict_modulus_reduction(model: dict, data: Dataset, settings: dict, validate: bool) -> dict:
    """Secant G/Gmax and damping D = dW/(4 pi W) of the last cycle (analysis.modulus_reduction)."""
    point = _point(model, DATA_KINDS["modulus-reduction"].model_keys, validate)
    mr = modulus_reduction(point, data["strain"], n_cycles=settings["n_cycles"],
                           steps_per_cycle=settings["steps_per_cycle"], waveform=settings["waveform"])
    out = {}
    if data.has("G_ratio"):
        out["G_ratio"] = mr.G_ratio
    if data.has("damping"):
        out["damping"] = mr.damping
    if data.has("G"):
        out["G"] = mr.G
    return out


ROD_PACKINGS = ("one-size", "two-size", "square", "hexagonal")


def _predict_rod_strains(model: dict, data: Dataset, settings: dict, validate: bool) -> dict:
    """Strains of a rod packing under a stress increment along alpha (seed Sec. 5.3, 6.1.2)."""
    root = Section(copy.deepcopy(model), "model")
    kind = root.choice("packing", ROD_PACKINGS)
    seed = root.integer("seed", 0, min=0)
    G = root.number("shear_modulus_equiv", "Pa", min=0, min_inclusive=False)
    psi = root.number("psi", None, min=0, min_inclusive=False)
    nu = root.number("poisson", None, min=-1, max=0.5, min_inclusive=False, max_inclusive=False)
    phi = float(np.degrees(root.angle("friction_angle", max_deg=90.0, max_inclusive=False)))
    if validate:
        root.finish()
    try:
        from grainmech.rods import random_arrays as random_rods
    except ModuleNotFoundError as exc:  # pragma: no cover - depends on the checkout
        raise GrainmechError("data kind 'rod-strains' needs grainmech.reproduce.random_rods") from exc
    if kind in ("square", "hexagonal"):
        cs = regular_array(kind, diameter=settings["diameter"])
    else:
        cs = random_rods.random_array(kind, seed=seed)
    eps = random_rods.strains(cs, np.degrees(data["alpha"]), G=G, psi=psi, nu=nu, phi_mu_deg=phi,
                              pressure=settings["pressure"], increment=settings["increment"])
    return {k: np.asarray(eps[k], dtype=float) for k in ("eps_xx", "eps_yy", "eps_xy") if data.has(k)}


_PACK = ("microstructure", "fabric", "contacts")
_ENG_COLS = ("G", "E", "K", "nu") + tuple(dict.fromkeys(_ENG_3D + _ENG_2D))
DATA_KINDS: dict[str, DataKind] = {
    "modulus-pressure": DataKind("modulus-pressure", ("pressure", "void_ratio"), _ENG_COLS, ("pressure",),
                                 _PACK, "pressure", _predict_modulus_pressure),
    "directional": DataKind("directional", ("alpha",), ("E", "nu"), ("alpha",), _PACK + ("stress",), "alpha",
                            _predict_directional),
    "stress-strain": DataKind("stress-strain", (), tuple(f"strain_{c}" for c in _COMP)
                              + tuple(f"stress_{c}" for c in _COMP), (),
                              _PACK + ("initial", "quadrature"), "", _predict_stress_strain, slow=True),
    "modulus-reduction": DataKind("modulus-reduction", ("strain",), ("G_ratio", "damping", "G"), ("strain",),
                                  _PACK + ("initial", "quadrature"), "strain", _predict_modulus_reduction,
                                  slow=True),
    "rod-strains": DataKind("rod-strains", ("alpha",), ("eps_xx", "eps_yy", "eps_xy"), ("alpha",),
                            ("packing", "seed", "shear_modulus_equiv", "psi", "poisson", "friction_angle"),
                            "alpha", _predict_rod_strains),
}


def parse_settings(kind: str, sec: Any) -> dict:
    """Kind-specific keys of the ``[data]`` table (a :class:`grainmech.io.config.Section`)."""
    s: dict[str, Any] = {}
    if kind == "directional":
        s["plane"] = sec.raw("plane", None)
    elif kind == "stress-strain":
        text = sec.raw("control")
        try:
            parse_mask(str(text))
        except GrainmechError as exc:
            raise ConfigError(sec.key("control"), text, str(exc)) from None
        s["control"] = tuple(c == "S" for c in str(text).upper())
        s["substeps"] = sec.integer("substeps", 4, min=1)
    elif kind == "modulus-reduction":
        s["n_cycles"] = sec.integer("n_cycles", 2, min=2)
        s["steps_per_cycle"] = sec.integer("steps_per_cycle", 40, min=8)
        s["waveform"] = sec.choice("waveform", ("triangle", "sine"), "triangle")
    elif kind == "rod-strains":
        # seed Sec. 5.2-5.3: rods of 0.5 in, 2.5 psi isotropic, then 0.5 psi along alpha
        s["diameter"] = sec.number("diameter", "m", 0.0127, min=0, min_inclusive=False)
        s["pressure"] = check_pressure(sec.number("pressure", "Pa", 2.5 * 6894.757293168361),
                                       sec.key("pressure"), sec.raw("pressure", None))
        s["increment"] = sec.number("increment", "Pa", 0.5 * 6894.757293168361, min=0, min_inclusive=False)
    return s


def targets_of(kind: str, data: Dataset, settings: dict) -> list[str]:
    """The fitted columns present in ``data`` (uncontrolled ones for stress-strain)."""
    k = DATA_KINDS[kind]
    if kind == "stress-strain":
        mask = settings["control"]
        out = [f"strain_{c}" for m, c in zip(mask, _COMP) if m and data.has(f"strain_{c}")]
        out += [f"stress_{c}" for m, c in zip(mask, _COMP) if not m and data.has(f"stress_{c}")]
        return out
    return [t for t in k.targets if data.has(t)]


def validate_data(kind: str, data: Dataset, settings: dict) -> None:
    """Kind-specific checks of a dataset (monotonic amplitudes, strains from zero...)."""
    if kind == "stress-strain":
        if len(data) < 2:
            raise data.error("a stress-strain path needs at least 2 rows (the initial state and one more)")
        for c in _COMP:
            col = f"strain_{c}"
            if data.has(col) and data[col][0] != 0.0:
                raise data.error("strains are measured from the initial state: row 0 must be 0", 0, col)
        if not targets_of(kind, data, settings):
            raise data.error("no uncontrolled column to fit: with control "
                             f"{''.join('S' if m else 'E' for m in settings['control'])} give strain columns of "
                             "stress-controlled components or stress columns of strain-controlled ones")
    if kind == "modulus-reduction":
        s = data["strain"]
        for i in range(len(data)):
            if s[i] <= 0:
                raise data.error("strain amplitudes must be > 0 (decimal, not %)", i, "strain")
    if kind == "modulus-pressure":
        for i in range(len(data)):
            if data["pressure"][i] <= 0:
                raise data.error("pressure must be > 0", i, "pressure")


def predict(kind: str, model: dict, data: Dataset, settings: dict, *, validate: bool = False) -> dict:
    """Predicted target columns (SI) for the model config ``model``."""
    return DATA_KINDS[kind].predict(model, data, settings, validate)

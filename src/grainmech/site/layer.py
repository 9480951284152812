"""One layer of a profile: its run config, the anchoring to a measured Vs, the run, its record.

Every layer is a ``grainmech run`` (cyclic simple shear) at the layer's mean effective
stress, prepared and executed by :func:`grainmech.jobs.prepare_run` and
:func:`grainmech.jobs.execute_run` -- by default the packing model over its range and the
DEM model beyond it, one amplitude list, each amplitude by one model; the packing model
brings its packing to that stress with :meth:`grainmech.driver.packing.PackingPoint.at_stress`,
the DEM model re-settles it there, the affine model takes the pressure directly. Every
finished amplitude is saved at once (:mod:`grainmech.site.amplitudes`); the layer's curve
and its fitted hyperbola come from the saved amplitudes (:mod:`grainmech.site.curve`).
The functions called in worker processes (:func:`anchor_task`, :func:`run_task`) take and
return plain picklable values.

Anchoring to a measured shear-wave velocity. The target is
``G_target = rho vs^2``. For Hertz-type contacts at fixed contact forces the contact
stiffnesses scale as the grains' modulus to the power 2/3: Hertz (seed Eq. 3.1-3.7)
``k_n = 2 E* a`` with ``a^3 = 3 N R / (4 E*)`` gives ``k_n ~ E*^(2/3) N^(1/3)``, and
Mindlin's ``k_t = 8 G* a (1 - T / (mu N))^(1/3)`` gives ``k_t ~ G*^(2/3)`` at fixed
``N``, ``T`` and Poisson's ratio. At a given stress the forces of the affine model are
fixed by the stress alone, so its Gmax scales exactly as ``G_grain^(2/3)``; the grain
shear modulus is therefore multiplied by ``(G_target / G_model)^(3/2)`` once, and the
run at that modulus (its own Gmax) is the check: reported beside the target. The
packing model's forces at the layer's stress come from a stress-controlled path that
also depends on the modulus (``at_stress``), so there the check can differ from the
target by a little; the record says by how much.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from grainmech import jobs
from grainmech.analysis import condensed_modulus, darendeli, menq_curve
from grainmech.contact.forms import normal_law
from grainmech.driver import MaterialPoint
from grainmech.driver.registry import MODELS, own_keys, resolve
from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.records import amp_id
from grainmech.io.site_profile import read_amplitude_entry, write_amplitude_entry
from grainmech.jobs import cyclic_control, packing_gmax, prepare_run
from grainmech.site.amplitudes import Recorder, amplitude_key, plan_runs
from grainmech.site.curve import layer_curve
from grainmech.site.profile import GRAIN_MODULUS_PLAUSIBLE, GRAIN_MODULUS_RANGE, Layer

__all__ = ["layer_config", "prepare_layer", "model_gmax", "anchor_task", "check_anchor", "anchor_warning",
           "run_task", "read_entries", "entry_key", "layer_key", "failed_record", "DARENDELI_STRAINS",
           "MENQ_STRAINS", "ANCHOR_TOLERANCE"]

#: strains [decimal] of the Darendeli (2001) curves written beside the model's
#: (pystrata's default grid of ``DarendeliSoilType``: 1e-6 ... 10^-1.5, 20 points)
DARENDELI_STRAINS = np.logspace(-6, -1.5, num=20)
#: strains [decimal] of the Menq (2003) curves written beside the model's (the same grid)
MENQ_STRAINS = DARENDELI_STRAINS
#: relative difference between the anchored run's Gmax and rho vs^2 above which the
#: record flags the anchoring
ANCHOR_TOLERANCE = 0.01


def layer_config(layer: Layer, grain_modulus: float | None = None, methods: tuple[str, ...] | None = None,
                 amplitudes: list[float] | None = None) -> dict:
    """The ``grainmech run`` config of ``layer``: its tables, ``[initial] pressure = p'``.

    ``grain_modulus`` [Pa] replaces ``contacts.shear_modulus`` (the anchored value);
    ``methods`` and ``amplitudes`` replace ``[model] method`` and ``[test] amplitudes``
    (the models and amplitudes left to run).
    """
    cfg = copy.deepcopy(layer.run_config)
    cfg["initial"] = {"pressure": float(layer.p_eff)}
    if grain_modulus is not None:
        cfg.setdefault("contacts", {})["shear_modulus"] = float(grain_modulus)
    if methods is not None:
        cfg.setdefault("model", {})["method"] = list(methods) if len(methods) > 1 else methods[0]
        for m in MODELS.values():  # the keys of a model not run would be refused
            if m.name not in methods:
                for k in own_keys(m):
                    cfg["model"].pop(k, None)
    if amplitudes is not None:
        cfg.setdefault("test", {})["amplitudes"] = [float(a) for a in amplitudes]
    return cfg


def layer_key(layer: Layer) -> str:
    """A short hash of everything that decides a layer's result (config, stress, vs)."""
    blob = json.dumps({"config": layer_config(layer), "vs": layer.vs, "p": layer.p_eff,
                       "rho": layer.density}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:12]


def _layer_error(layer: Layer, exc: ConfigError) -> ConfigError:
    """``exc`` (naming a run-config key) re-raised naming the profile's key and the layer."""
    mapped = layer.key_map.get(exc.key, exc.key)
    key = f"{mapped} (layer {layer.name!r})" if mapped.startswith("layers[") else f"{layer.label}: {mapped}"
    return ConfigError(key, exc.value, exc.problem)


def prepare_layer(layer: Layer, base_dir: str | Path | None, grain_modulus: float | None = None,
                  methods: tuple[str, ...] | None = None, amplitudes: list[float] | None = None) -> Any:
    """The :class:`grainmech.jobs.RunSpec` of ``layer`` (config errors name the layer and key)."""
    try:
        return prepare_run(layer_config(layer, grain_modulus, methods, amplitudes), base_dir)
    except ConfigError as exc:
        raise _layer_error(layer, exc) from None


def model_gmax(spec: Any) -> float:
    """The small-strain shear modulus [Pa] the layer's run will normalise its curves by.

    The same evaluation as the run's own ``G_max``: the tangent of the initial state
    condensed with the test's control (``sigma_zz`` free at constant stress); for the
    affine model the tangent of :meth:`MaterialPoint.isotropic`
    (:func:`grainmech.analysis.modulus_reduction`), for the packing model
    :func:`grainmech.jobs.packing_gmax` (elastic tangent of the packing brought to the
    layer's stress).
    """
    if not spec.models[0].needs_grains:  # the affine model, on the analytical microstructure
        point = MaterialPoint.isotropic(spec.microstructure, spec.law, spec.pressure, extra_degree=spec.degree)
        return float(condensed_modulus(point.tangent, 4, [bool(b) for b in cyclic_control(spec.constant)]))
    pg = packing_gmax(dataclasses.replace(spec, gmax_grains=spec.grains), lambda msg: None)
    if "error" in pg:
        raise GrainmechError(pg["error"])
    return float(pg["G_max_Pa"])


def anchor_task(task: tuple[Layer, str | None]) -> dict:
    """Worker function: the grain modulus that gives the layer its measured Vs.

    Returns a JSON-ready dict: ``vs_measured_m_s``, ``G_target_Pa`` (``rho vs^2``),
    ``G_model_Pa`` (Gmax at the config's grain modulus), ``grain_modulus_Pa`` (the
    config's), ``scale`` (``(G_target / G_model)^(3/2)``, the factor on the grain
    modulus), ``grain_modulus_anchored_Pa``.
    """
    layer, base_dir = task
    if layer.vs is None:
        raise ValueError(f"{layer.label} has no vs")
    spec = prepare_layer(layer, base_dir)
    law = spec.grain_law if spec.grain_law is not None else spec.law
    if normal_law(law) != "hertz":
        raise ConfigError(f"layers[{layer.index}].vs (layer {layer.name!r})", layer.vs,
                          f"anchoring to a measured Vs rescales the grains' shear modulus by the Hertz 2/3-power "
                          f"rule; the contact law {type(law).__name__} has no grain modulus")
    g0 = model_gmax(spec)
    target = layer.density * layer.vs ** 2
    scale = (target / g0) ** 1.5
    return {"vs_measured_m_s": float(layer.vs), "G_target_Pa": float(target), "G_model_Pa": g0,
            "grain_modulus_Pa": float(law.shear_modulus), "scale": float(scale),
            "grain_modulus_anchored_Pa": float(law.shear_modulus * scale)}


def check_anchor(layer: Layer, anchor: dict) -> None:
    """Refuse an anchoring that needs a grain shear modulus outside 1-1000 GPa (ConfigError)."""
    lo, hi = GRAIN_MODULUS_RANGE
    g = anchor["grain_modulus_anchored_Pa"]
    if not (lo <= g <= hi):
        raise ConfigError(f"layers[{layer.index}].vs (layer {layer.name!r})", layer.vs,
                          f"would need a grain shear modulus of {g / 1e9:.4g} GPa ({anchor['scale']:.4g} x "
                          f"{anchor['grain_modulus_Pa'] / 1e9:.4g} GPa: the model's Gmax "
                          f"{anchor['G_model_Pa'] / 1e6:.4g} MPa against rho vs^2 = {anchor['G_target_Pa'] / 1e6:.4g} "
                          f"MPa), outside {lo / 1e9:g}-{hi / 1e9:g} GPa")


def _darendeli(spec: Any, layer: Layer, amplitudes: np.ndarray) -> dict:
    """Darendeli (2001) at the layer's mean effective stress, on its grid and at the model's amplitudes."""
    ref = spec.reference or {}
    kw = dict(pi=ref.get("pi", 0.0), ocr=ref.get("ocr", 1.0), n_cycles=ref.get("n_cycles", 10.0),
              frequency=ref.get("frequency", 1.0))
    grid = darendeli(DARENDELI_STRAINS, layer.p_eff, **kw)
    out = {"strain": DARENDELI_STRAINS.tolist(), "G_ratio": grid.G_ratio.tolist(), "damping": grid.damping.tolist(),
           "gamma_r": float(grid.gamma_r), "d_min": float(grid.d_min), "inputs": kw,
           "mean_stress_atm": layer.p_eff / 101325.0}
    if len(amplitudes):
        at = darendeli(amplitudes, layer.p_eff, **kw)
        out.update(at_amplitudes_G_ratio=at.G_ratio.tolist(), at_amplitudes_damping=at.damping.tolist())
    return out


def _menq(spec: Any, layer: Layer, amplitudes: np.ndarray) -> dict:
    """Menq (2003) at the layer's mean effective stress, on its grid and at the model's amplitudes.

    Its grading (coefficient of uniformity, D50) is the layer run's: measured on its grains,
    from ``[reference]`` or the default (:func:`grainmech.jobs.prepare_run`).
    """
    ref = spec.reference or {}
    cu, d50, n = float(ref["uniformity_coefficient"]), float(ref["d50"]), float(ref.get("n_cycles", 10.0))
    inputs = {"uniformity_coefficient": cu, "d50_m": d50, "n_cycles": n, "grading_source": str(ref["grading_source"])}
    grid = menq_curve(MENQ_STRAINS, layer.p_eff, cu, d50, n)
    out = {"strain": MENQ_STRAINS.tolist(), "G_ratio": grid.G_ratio.tolist(), "damping": grid.damping.tolist(),
           "gamma_r": float(grid.gamma_r), "curvature": grid.curvature, "d_min": float(grid.d_min),
           "inputs": inputs, "mean_stress_atm": layer.p_eff / 101325.0}
    if len(amplitudes):
        at = menq_curve(amplitudes, layer.p_eff, cu, d50, n)
        out.update(at_amplitudes_G_ratio=at.G_ratio.tolist(), at_amplitudes_damping=at.damping.tolist())
    return out


def layer_facts(layer: Layer) -> dict:
    """The layer's geometry and stresses (JSON-ready; units in the names)."""
    return {"index": layer.index, "name": layer.name, "slug": layer.slug, "top_m": layer.top,
            "bottom_m": layer.bottom, "mid_m": layer.mid, "thickness_m": layer.thickness,
            "unit_weight_N_m3": layer.unit_weight, "density_kg_m3": layer.density, "k0": layer.k0,
            "sigma_v_Pa": layer.sigma_v, "u_Pa": layer.u, "sigma_v_eff_Pa": layer.sigma_v_eff,
            "sigma_h_eff_Pa": layer.sigma_h_eff, "p_eff_Pa": layer.p_eff, "vs_measured_m_s": layer.vs,
            "density_choice": layer.packing_choice}


def anchor_warning(anchor: dict) -> str | None:
    """The warning of an anchoring whose grain shear modulus leaves 10-100 GPa (None inside).

    The grains of a real sand have a shear modulus of 10-100 GPa (quartz 29-44 GPa); a
    Vs-anchored modulus outside it means the packing at the layer's stress is stiffer or
    softer than the site by the factor ``G_target / G_model`` -- its density or fabric do
    not match the site's -- and the rescaled grains make up for it.
    """
    lo, hi = GRAIN_MODULUS_PLAUSIBLE
    g = anchor["grain_modulus_anchored_Pa"]
    if lo <= g <= hi:
        return None
    ratio = anchor["G_target_Pa"] / anchor["G_model_Pa"]
    times = f"{1 / ratio:.3g} times stiffer" if ratio < 1 else f"{ratio:.3g} times softer"
    return (f"anchoring to the measured Vs {anchor['vs_measured_m_s']:g} m/s needs a grain shear modulus of "
            f"{g / 1e9:.3g} GPa, outside the {lo / 1e9:g}-{hi / 1e9:g} GPa of real grains (quartz 29-44 GPa): the "
            f"packing does not match the site's stiffness (its density or fabric): at the grains' own "
            f"{anchor['grain_modulus_Pa'] / 1e9:.3g} GPa its Gmax is {anchor['G_model_Pa'] / 1e6:.4g} MPa against "
            f"rho vs^2 = {anchor['G_target_Pa'] / 1e6:.4g} MPa: {times} than the site (its Vs "
            f"{100 * (np.sqrt(1 / ratio) - 1):+.0f} % from the measured)")


def entry_key(layer: Layer, modulus: float | None) -> Callable[[str, float], str]:
    """``key(method, amplitude)``: :func:`grainmech.site.amplitudes.amplitude_key` of ``layer``."""
    cfg = layer_config(layer, modulus)
    return lambda method, amplitude: amplitude_key(cfg, layer.density, method, amplitude)


def read_entries(layer: Layer, modulus: float | None, folder: Path, methods: tuple[str, ...],
                 amplitudes: list[float]) -> dict[tuple[str, float], dict]:
    """The saved amplitude entries of ``layer`` whose hash matches the present inputs."""
    key = entry_key(layer, modulus)
    found: dict[tuple[str, float], dict] = {}
    for m in methods:
        for a in amplitudes:
            e = read_amplitude_entry(folder, m, a, key(m, a))
            if e is not None:
                found[(m, amp_id(a))] = e
    return found


def run_task(task: tuple, progress: Callable[[str], None] | None = None) -> dict:
    """Worker function: run the amplitudes of one layer not yet saved; return its record (JSON-ready dict).

    ``task`` is ``(layer, base_dir, anchor, folder, resume)``: ``folder`` the layer's
    amplitude folder (``OUTDIR/layers/<NN-name>``, :mod:`grainmech.site.amplitudes`; None:
    nothing saved), ``resume`` whether the amplitudes saved there are skipped (else every
    amplitude runs and is saved again). ``progress(message)`` receives the model's
    progress lines.

    The runs (:func:`grainmech.site.amplitudes.plan_runs`) go through
    :func:`grainmech.jobs.execute_run` with the layer's run config restricted to the
    models and amplitudes left; each amplitude is saved as it finishes. The record holds
    the curve (:func:`grainmech.site.curve.layer_curve`: the models' points, the fitted
    hyperbola and the curve for site response), Darendeli's and Menq's curves at the
    layer's stress, the packing chosen by the layer's density and the anchoring.

    ``status`` is ``"ok"`` when every amplitude has a point, ``"stopped"`` otherwise (the
    message says which and why).
    """
    layer, base_dir, anchor, folder, resume = task
    t0 = time.perf_counter()
    modulus = anchor["grain_modulus_anchored_Pa"] if anchor else None
    spec = prepare_layer(layer, base_dir, modulus)
    methods = tuple(spec.methods)
    amps = sorted(float(a) for a in spec.amplitudes)
    have = read_entries(layer, modulus, Path(folder), methods, amps) if folder is not None and resume else {}
    reused = len(have)

    def write(entry: dict) -> None:
        if folder is not None:
            write_amplitude_entry(Path(folder), entry)

    rec_hook = Recorder(progress, entry_key(layer, modulus), write, have)
    messages: list[str] = []
    tried: set[tuple[tuple[str, ...], float]] = set()
    while True:  # a run, then (rarely) the DEM model alone on what the packing model handed over
        # an amplitude a run was given and left without an entry is not given to the same models again here
        plan = [(m, [a for a in aa if (m, amp_id(a)) not in tried])
                for m, aa in plan_runs(methods, amps, rec_hook.have)]
        plan = [(m, aa) for m, aa in plan if aa]
        if not plan:
            break
        run_methods, run_amps = plan[0]
        tried.update((run_methods, amp_id(a)) for a in run_amps)
        sub = prepare_layer(layer, base_dir, modulus, methods=run_methods, amplitudes=run_amps)
        out = jobs.execute_run(sub, rec_hook)
        for o in getattr(out, "outcomes", [out]):  # each model's final outcome (its stop reasons)
            rec_hook.amplitudes_done(o)
            if not o.success:
                messages.append(f"{o.method}: {o.message}")
        rec_hook.finished(out, run_amps)
    entries = list(rec_hook.have.values())
    curve = layer_curve(methods, entries, float(layer.p_eff), spec.kind, spec.keep_beyond_envelope)
    law = spec.grain_law if spec.grain_law is not None else spec.law
    g_max = curve["G_max_Pa"]
    done = {amp_id(a) for a in curve["amplitudes"]}
    missing = [a for a in amps if amp_id(a) not in done]
    stops = sorted({f"{e['method']} at {e['amplitude']:.3g}: {e.get('message', '')}" for e in entries
                    if e["status"] == "stopped"})
    warnings: list[str] = []
    for e in sorted(entries, key=lambda e: (e["method"], e["amplitude"])):
        for w in e.get("warnings", []):
            if w not in warnings:
                warnings.append(w)
    if curve["fit_error"]:
        warnings.append(f"no fitted curve: {curve['fit_error']}")
    if curve["fit_warning"]:
        warnings.append(f"fitted curve: {curve['fit_warning']}")
    choice = layer.packing_choice
    if choice and choice["flag"]:
        warnings.append(f"the packing {choice['packing']!r} has D_r {choice['packing_relative_density']:.2f}, "
                        f"{abs(choice['difference']):.2f} from the asked {choice['asked_relative_density']:.2f} "
                        f"({choice['asked']} = {choice['asked_value']:g}): no shipped sand packing is nearer")
    pk_entries = [e for e in entries if resolve(e["method"]).fixed_geometry and e.get("empirical_G_max")]
    sample: dict = next((e for e in entries if e.get("details")), {})
    rec: dict[str, Any] = layer_facts(layer)
    rec.update(key=layer_key(layer), method="+".join(methods),
               grains=(spec.grains.label if spec.grains is not None else
                       f"analytical fabric, void ratio {spec.void_ratio}"),
               contact_law=type(law).__name__, grain_shear_modulus_Pa=float(getattr(law, "shear_modulus", np.nan)),
               status="ok" if not missing else "stopped",
               message=("" if not missing else f"no point at {[float(f'{a:.3g}') for a in missing]}"
                        + (f" ({'; '.join(stops or messages)})" if stops or messages else "")),
               G_max_Pa=g_max if np.isfinite(g_max) else None,
               vs_model_m_s=float(np.sqrt(g_max / layer.density)) if np.isfinite(g_max) and g_max > 0 else None,
               darendeli=_darendeli(spec, layer, np.asarray(curve["amplitudes"])),
               menq=_menq(spec, layer, np.asarray(curve["amplitudes"])),
               empirical_G_max=pk_entries[0]["empirical_G_max"] if pk_entries else None,
               details=sample.get("details", {}), warnings=warnings,
               amplitudes_asked=amps, amplitudes_reused=reused, amplitudes_run=len(rec_hook.new),
               config=layer_config(layer, modulus))
    rec.update({k: curve[k] for k in ("amplitudes", "G_ratio", "damping", "models", "flags", "G_max_model",
                                      "G_max_reason", "choices", "by_model", "fit", "fit_error", "site_curve")})
    rec["beyond_envelope"] = ["beyond_envelope" in f for f in curve["flags"]]
    if anchor:
        a = dict(anchor)
        a["G_checked_Pa"] = g_max
        a["mismatch"] = g_max / a["G_target_Pa"] - 1.0 if np.isfinite(g_max) else None
        a["flag"] = bool(a["mismatch"] is None or abs(a["mismatch"]) > ANCHOR_TOLERANCE)
        a["warning"] = anchor_warning(a)
        if a["warning"]:
            rec["warnings"].append(a["warning"])
        rec["anchor"] = a
    rec["seconds"] = time.perf_counter() - t0
    return rec


def failed_record(layer: Layer, error: BaseException) -> dict:
    """The record of a layer whose task raised (``status = "failed"``)."""
    rec = layer_facts(layer)
    rec.update(key=layer_key(layer), status="failed", message=f"{type(error).__name__}: {error}",
               amplitudes=[], G_ratio=[], damping=[], models=[], flags=[], G_max_Pa=None, vs_model_m_s=None,
               warnings=[], fit=None, site_curve={"strain": [], "G_ratio": [], "damping": [], "left_out": [],
                                                   "model_range": []})
    return rec

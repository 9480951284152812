"""Equivalent-linear site response with pystrata (optional extra ``site``).

Three runs of pystrata's ``EquivalentLinearCalculator`` on the same profile (thicknesses,
unit weights, shear-wave velocities, half-space) and the same input motion, differing
only in the layers' nonlinear curves:

* ``"grainmech"``: every layer's G/Gmax and damping from its grains: the modified
  hyperbola fitted to the packing and DEM models' points (:mod:`grainmech.site.curve`),
  on 1e-7 ... 1e-1 (``pystrata.site.SoilType`` with two ``NonlinearProperty`` curves;
  pystrata interpolates them linearly in log strain);
* ``"darendeli"``: pystrata's own ``DarendeliSoilType`` (Darendeli 2001) at the layer's
  mean effective stress (kPa), plasticity index, OCR, frequency and number of cycles;
* ``"menq"``: pystrata's own ``MenqSoilType`` (Menq 2003, clean sands and gravels) at
  the layer's mean effective stress (kPa), coefficient of uniformity, D50 (mm) and
  number of cycles (the grading of the layer's run, :func:`grainmech.jobs.prepare_run`).

The shear-wave velocity of a layer is its measured ``vs`` where given (the model is
anchored to it), else the model's ``sqrt(Gmax / rho)``. Outputs: the 5 %-damped
acceleration response spectrum at the surface (outcrop), the maximum shear strain and
the peak acceleration against depth.

pystrata is imported only here, only when a site response is asked for; without it
:func:`pystrata_missing` says how to install it.
"""

from __future__ import annotations

import contextlib
import io
import math
from importlib.metadata import version
from typing import Any

import numpy as np

__all__ = ["site_response", "pystrata_missing", "build_profile", "run_column", "INSTALL_HINT", "SPECTRUM_FREQS"]

INSTALL_HINT = 'pip install "grainmech[site]"  (pystrata and pandas, which pystrata 0.5 imports without declaring it)'
#: frequencies [Hz] of the response spectra (periods 0.01-10 s)
SPECTRUM_FREQS = np.logspace(-1, 2, num=301)
#: oscillator damping of the response spectra (decimal)
SPECTRUM_DAMPING = 0.05


def pystrata_missing() -> str | None:
    """``None`` if pystrata imports, else the reason and how to install it."""
    try:
        import pystrata  # noqa: F401  (optional dependency, imported lazily)
    except ImportError as exc:
        return f"pystrata is not installed ({exc}); install it with: {INSTALL_HINT}"
    return None


def _soil(rec: dict, curves: str, reference: dict) -> Any:
    import pystrata

    unit_wt = rec["unit_weight_N_m3"] / 1e3  # pystrata: kN/m^3
    if curves == "darendeli":
        ref = reference or {}
        return pystrata.site.DarendeliSoilType(unit_wt=unit_wt, plas_index=ref.get("pi", 0.0),
                                               ocr=ref.get("ocr", 1.0), stress_mean=rec["p_eff_Pa"] / 1e3,
                                               freq=ref.get("frequency", 1.0), num_cycles=ref.get("n_cycles", 10.0))
    if curves == "menq":
        return pystrata.site.MenqSoilType(unit_wt=unit_wt, uniformity_coeff=reference["uniformity_coefficient"],
                                          diam_mean=1e3 * reference["d50_m"], stress_mean=rec["p_eff_Pa"] / 1e3,
                                          num_cycles=reference["n_cycles"])
    name = f"grainmech {rec['name']}"
    c = rec["site_curve"]
    strains = np.asarray(c["strain"], dtype=float)
    return pystrata.site.SoilType(
        name, unit_wt, pystrata.site.NonlinearProperty(name, strains, np.asarray(c["G_ratio"]), "mod_reduc"),
        pystrata.site.NonlinearProperty(name, strains, np.asarray(c["damping"]), "damping"))


def site_vs(rec: dict) -> float:
    """The layer's shear-wave velocity in the site-response run [m/s]: measured, else the model's."""
    return float(rec["vs_measured_m_s"] if rec.get("vs_measured_m_s") else rec["vs_model_m_s"])


def build_profile(records: list[dict], bedrock: Any, water_table: float, curves: str) -> Any:
    """A ``pystrata.site.Profile`` of the layer records over the half-space ``bedrock``.

    ``curves`` is ``"grainmech"``, ``"darendeli"`` or ``"menq"``; thicknesses [m], unit weights
    [kN/m^3], velocities [m/s] as pystrata takes them.
    """
    import pystrata

    layers = [pystrata.site.Layer(_soil(r, curves, (r.get(curves) or {}).get("inputs", {})),
                                  r["thickness_m"], site_vs(r)) for r in records]
    rock = pystrata.site.SoilType("Rock", bedrock.unit_weight / 1e3, None, bedrock.damping)
    layers.append(pystrata.site.Layer(rock, 0, bedrock.vs))
    depth = sum(r["thickness_m"] for r in records)
    return pystrata.site.Profile(layers, wt_depth=water_table if math.isfinite(water_table) else depth)


def run_column(profile: Any, motion: Any, location: str = "outcrop") -> dict:
    """Equivalent-linear calculation (pystrata) of ``profile``, auto-discretised, under ``motion``.

    Returns a dict of lists: ``periods_s``, ``spectrum_g`` (surface, outcrop, 5 %),
    ``input_spectrum_g``, ``strain_depth_m``, ``max_strain`` (decimal), ``pga_depth_m``,
    ``pga_g``. pystrata's own prints go to a buffer, not to stdout.
    """
    import pystrata

    prof = profile.auto_discretize()
    m = pystrata.motion.TimeSeriesMotion(motion.source, motion.description, motion.time_step, motion.accel_g)
    calc = pystrata.propagation.EquivalentLinearCalculator()
    out = pystrata.output
    outputs = out.OutputCollection([
        out.ResponseSpectrumOutput(SPECTRUM_FREQS, out.OutputLocation("outcrop", index=0), SPECTRUM_DAMPING),
        out.ResponseSpectrumOutput(SPECTRUM_FREQS, out.OutputLocation(location, index=-1), SPECTRUM_DAMPING),
        out.MaxStrainProfile(), out.MaxAccelProfile()])
    with contextlib.redirect_stdout(io.StringIO()):
        calc(m, prof, prof.location(location, index=-1))
        outputs(calc)
    spec, inp, strain, acc = list(outputs)
    return {"periods_s": (1.0 / np.asarray(spec.refs)).tolist(), "spectrum_g": np.ravel(spec.values).tolist(),
            "input_spectrum_g": np.ravel(inp.values).tolist(),
            "strain_depth_m": np.asarray(strain.refs).tolist(), "max_strain": np.ravel(strain.values).tolist(),
            "pga_depth_m": np.asarray(acc.refs).tolist(), "pga_g": np.ravel(acc.values).tolist()}


def _strain_warnings(records: list[dict], run: dict) -> list[str]:
    """Layers whose strains in the run left the strains their fitted curve was fitted on."""
    z = np.asarray(run["strain_depth_m"])
    s = np.asarray(run["max_strain"])
    out = []
    for r in records:
        inside = (z >= r["top_m"]) & (z <= r["bottom_m"])
        rng = r["site_curve"].get("model_range") or []
        if not inside.any() or not rng:
            continue
        peak = float(s[inside].max())
        if peak > rng[1]:
            out.append(f"site response with the grains' curves, layer {r['name']!r}: strains up to {peak:.3g}, beyond "
                       f"the largest amplitude its hyperbola was fitted on ({rng[1]:.3g}); there the curve is the "
                       "fitted hyperbola's extrapolation")
    return out


def site_response(records: list[dict], bedrock: Any, water_table: float, motion: Any,
                  location: str = "outcrop") -> dict:
    """The three pystrata runs (module docstring) of the layer records under ``motion``.

    Returns a JSON-ready dict: ``pystrata_version``, ``motion`` (file, time step, points,
    PGA), ``vs_m_s`` (per layer), ``runs`` (``"grainmech"`` when every layer has curves,
    ``"darendeli"``, and ``"menq"`` when every layer record has Menq's inputs:
    :func:`run_column`), ``warnings``.
    """
    res: dict[str, Any] = {"pystrata_version": version("pystrata"),
                           "motion": {"file": motion.source, "description": motion.description,
                                      "time_step_s": motion.time_step, "points": int(len(motion.accel_g)),
                                      "pga_g": motion.pga_g, "location": location},
                           "vs_m_s": [site_vs(r) for r in records], "runs": {}, "warnings": []}
    missing = [r["name"] for r in records if not r["site_curve"]["strain"]]
    if missing:
        res["warnings"].append(f"no site response with the grains' curves: layer(s) {missing} have no fitted "
                               "curve (fewer than two usable points: their models stopped, or the amplitudes "
                               "left the envelope of sands)")
    else:
        run = run_column(build_profile(records, bedrock, water_table, "grainmech"), motion, location)
        run["label"] = "the grains' curves (fitted hyperbolae)"
        res["runs"]["grainmech"] = run
        res["warnings"] += _strain_warnings(records, run)
    run = run_column(build_profile(records, bedrock, water_table, "darendeli"), motion, location)
    run["label"] = "Darendeli (2001), pystrata DarendeliSoilType"
    res["runs"]["darendeli"] = run
    res["input_spectrum_g"] = run["input_spectrum_g"]
    no_menq = [r["name"] for r in records if not r.get("menq")]
    if no_menq:
        res["warnings"].append(f"no site response with Menq's curves: the record(s) of layer(s) {no_menq} were "
                               "written without them (reused from an earlier run; delete their layers/*.json to "
                               "run them again)")
    else:
        run = run_column(build_profile(records, bedrock, water_table, "menq"), motion, location)
        run["label"] = "Menq (2003), pystrata MenqSoilType"
        res["runs"]["menq"] = run
    return res

"""Files of ``grainmech site``: layer records, curve files, layer table, figures, page.

Layout of the output folder (``docs/site-profile.md``)::

    OUTDIR/
      layers/<NN-name>/<model>-<amplitude>-<hash>.json   every finished amplitude (resume)
      layers/<NN-name>/anchor-<hash>.json                the layer's Vs anchoring
      layers/<NN-name>.json            one record per layer, written as the layer finishes
      curves/<NN-name>.csv             the fitted curve for site response (site-response format)
      curves/<NN-name>-points.csv      the models' points: amplitude, model, G/Gmax, damping, flags
      curves/<NN-name>-darendeli.csv   Darendeli (2001) at the layer's mean effective stress
      curves/<NN-name>-menq.csv        Menq (2003) at the layer's mean effective stress and grading
      layers.csv                       one row per layer
      profile.png                      Vs, stresses, Gmax against depth; the curves of every layer
      response.png, response_*.csv     with [motion] and pystrata: the three site-response runs
      summary.json, index.html

Figures are drawn by :mod:`grainmech.site.plotting` and handed in (this module imports
nothing of ``site``).
"""

from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

from grainmech.io.html import PageSection, write_page
from grainmech.io.results import write_csv, write_figure, write_json
from grainmech.io.site_response import write_curves

__all__ = ["write_layer_record", "read_layer_record", "write_layer_curves", "write_layers_table",
           "write_response", "write_site_page", "write_amplitude_entry", "read_amplitude_entry",
           "amplitude_file", "write_anchor", "read_anchor", "models_used", "LAYER_COLUMNS"]

#: columns of ``layers.csv`` (record key, column header)
LAYER_COLUMNS = (("index", "index"), ("name", "name"), ("top_m", "top [m]"), ("bottom_m", "bottom [m]"),
                 ("mid_m", "mid-depth [m]"), ("unit_weight_N_m3", "unit weight [N/m^3]"), ("k0", "K0"),
                 ("sigma_v_Pa", "sigma_v [Pa]"), ("u_Pa", "u [Pa]"), ("sigma_v_eff_Pa", "sigma'_v [Pa]"),
                 ("sigma_h_eff_Pa", "sigma'_h [Pa]"), ("p_eff_Pa", "p' [Pa]"), ("method", "method"),
                 ("grains", "grains"), ("grain_shear_modulus_Pa", "grain shear modulus [Pa]"),
                 ("packing_chosen", "packing"), ("dr_packing", "D_r packing"), ("dr_asked", "D_r asked"),
                 ("dr_flag", "D_r differs > 0.1"),
                 ("G_max_Pa", "Gmax [Pa]"), ("G_max_model", "Gmax model"), ("vs_model_m_s", "Vs model [m/s]"),
                 ("vs_measured_m_s", "Vs measured [m/s]"), ("anchor_scale", "grain modulus scale"),
                 ("anchor_G_target_Pa", "Gmax target rho vs^2 [Pa]"),
                 ("anchor_G_model_Pa", "Gmax before anchoring [Pa]"),
                 ("anchor_mismatch", "Gmax/target - 1"), ("anchor_warning", "anchoring warning"),
                 ("hardin_richart_ratio", "Gmax / Hardin-Richart (round)"),
                 ("models_used", "models (amplitudes)"), ("fit_gamma_r", "fit gamma_r"),
                 ("fit_curvature", "fit curvature a"), ("fit_g_rms", "fit G/Gmax rms residual"),
                 ("fit_g_max", "fit G/Gmax largest residual"), ("fit_b", "fit Masing scaling b"),
                 ("fit_d_min", "fit D_min"), ("fit_d_rms", "fit damping rms residual"),
                 ("fit_range", "fitted strains"),
                 ("n_amplitudes", "amplitudes done"), ("amplitudes_reused", "amplitudes reused"),
                 ("status", "status"), ("message", "message"), ("seconds", "seconds"))


def amplitude_file(folder: str | Path, method: str, amplitude: float, key: str) -> Path:
    """``<folder>/<method>-<amplitude>-<key>.json``: one saved amplitude of a layer."""
    return Path(folder) / f"{method}-{float(amplitude):.6g}-{key}.json"


def write_amplitude_entry(folder: str | Path, entry: dict) -> Path:
    """Save one amplitude entry (atomically) under its method, amplitude and ``entry["key"]``."""
    Path(folder).mkdir(parents=True, exist_ok=True)
    return write_json(amplitude_file(folder, entry["method"], entry["amplitude"], entry["key"]), entry)


def read_amplitude_entry(folder: str | Path, method: str, amplitude: float, key: str) -> dict | None:
    """The saved entry of ``method`` at ``amplitude`` with hash ``key``, or None (absent or unreadable)."""
    try:
        e = json.loads(amplitude_file(folder, method, amplitude, key).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    ok = isinstance(e, dict) and e.get("key") == key and e.get("status") in ("ok", "stopped", "handed")
    return e if ok else None


def write_anchor(folder: str | Path, key: str, anchor: dict) -> Path:
    """Save a layer's anchoring (``anchor-<key>.json``)."""
    Path(folder).mkdir(parents=True, exist_ok=True)
    return write_json(Path(folder) / f"anchor-{key}.json", {"key": key, "anchor": anchor})


def read_anchor(folder: str | Path, key: str) -> dict | None:
    """A saved anchoring with hash ``key``, or None."""
    try:
        d = json.loads((Path(folder) / f"anchor-{key}.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return d["anchor"] if isinstance(d, dict) and d.get("key") == key and isinstance(d.get("anchor"), dict) else None


def write_layer_record(path: str | Path, record: dict) -> Path:
    """One layer's record as JSON (atomically: a killed run never leaves half a record)."""
    return write_json(path, record)


def read_layer_record(path: str | Path, key: str) -> dict | None:
    """A layer record written by a previous run, if it exists, is readable and has ``key``.

    ``None`` otherwise (the layer then runs again). Records of layers that completed or
    stopped are reused; ``"failed"`` ones (an error in the task) are not.
    """
    try:
        rec = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("key") != key or rec.get("status") not in ("ok", "stopped"):
        return None
    return rec


def models_used(rec: dict) -> str:
    """``"packing 1e-06-0.0001; dem 0.0002-0.01"``: which model made which points of the curve."""
    parts: list[str] = []
    amps, models = rec.get("amplitudes") or [], rec.get("models") or []
    for m in dict.fromkeys(models):
        a = [x for x, mm in zip(amps, models) if mm == m]
        parts.append(f"{m} {a[0]:.3g}" + (f"-{a[-1]:.3g}" if len(a) > 1 else "") + f" ({len(a)})")
    return "; ".join(parts)


def _row(rec: dict) -> dict:
    a = rec.get("anchor") or {}
    emp = rec.get("empirical_G_max") or {}
    ch = rec.get("density_choice") or {}
    fit = rec.get("fit") or {}
    row = dict(rec)
    row.update(anchor_scale=a.get("scale"), anchor_G_target_Pa=a.get("G_target_Pa"),
               anchor_G_model_Pa=a.get("G_model_Pa"), anchor_mismatch=a.get("mismatch"),
               anchor_warning=a.get("warning"),
               hardin_richart_ratio=emp.get("ratio_round"), n_amplitudes=len(rec.get("amplitudes", [])),
               packing_chosen=ch.get("packing"), dr_packing=ch.get("packing_relative_density"),
               dr_asked=ch.get("asked_relative_density"), dr_flag=ch.get("flag") if ch else None,
               models_used=models_used(rec), fit_gamma_r=fit.get("gamma_r"), fit_curvature=fit.get("curvature"),
               fit_g_rms=fit.get("g_residual_rms"), fit_g_max=fit.get("g_max_error"),
               fit_b=fit.get("masing_scaling"), fit_d_min=fit.get("d_min"), fit_d_rms=fit.get("damping_residual_rms"),
               fit_range=("{:.3g}-{:.3g}".format(*fit["strain_range"]) if fit.get("strain_range") else None))
    return row


def write_layers_table(path: str | Path, records: list[dict]) -> Path:
    """``layers.csv``: one row per layer (:data:`LAYER_COLUMNS`)."""
    rows = []
    for rec in records:
        r = _row(rec)
        rows.append(["" if r.get(k) is None or (isinstance(r.get(k), float) and not math.isfinite(r[k]))
                     else r.get(k) for k, _ in LAYER_COLUMNS])
    return write_csv(path, [h for _, h in LAYER_COLUMNS], rows)


def write_layer_curves(folder: str | Path, rec: dict, source: str) -> list[str]:
    """The layer's curve files in the site-response format; returns their names (relative to ``folder``).

    ``<slug>.csv``: the modified hyperbola fitted to the models' points, on the strains of
    ``site_curve`` (no file without a fit); ``<slug>-points.csv``: the points themselves
    (amplitude, the model that made it, G/Gmax on the curve's one Gmax, damping, flags);
    ``<slug>-darendeli.csv``: Darendeli (2001) at the layer's mean effective stress;
    ``<slug>-menq.csv``: Menq (2003) at the layer's mean effective stress and grading (a
    record written without it, reused from an earlier run, has none).
    """
    folder = Path(folder)
    out = []
    p = rec["p_eff_Pa"]
    c = rec.get("site_curve") or {}
    fit = rec.get("fit") or {}
    if c.get("strain"):
        left = c.get("left_out") or []
        write_curves(folder / f"{rec['slug']}.csv", c["strain"], c["G_ratio"], c["damping"],
                     g_max=rec["G_max_Pa"], source=f"{source}: layer {rec['name']!r}, {rec['grains']}, mean "
                     f"effective stress {p:.6g} Pa; modified hyperbola G/Gmax = 1/(1 + (gamma/gamma_r)^a) with "
                     f"gamma_r = {fit['gamma_r']:.4g}, a = {fit['curvature']:.4g} (rms residual "
                     f"{fit['g_residual_rms']:.3g}) and damping b (G/Gmax)^0.1 D_Masing + D_min with "
                     f"b = {fit['masing_scaling']:.4g}, D_min = {fit['d_min']:.4g} (rms residual "
                     f"{fit['damping_residual_rms']:.3g}) fitted to the points of {models_used(rec)} from "
                     "{:.3g} to {:.3g}".format(*fit["strain_range"])
                     + (f"; amplitudes left out of the fit: {left}" if left else ""))
        out.append(f"{rec['slug']}.csv")
    if rec.get("amplitudes"):
        write_csv(folder / f"{rec['slug']}-points.csv",
                  ["strain", "model", "G/Gmax", "damping", "flags"],
                  [[a, m, g, d, " ".join(f)] for a, m, g, d, f in
                   zip(rec["amplitudes"], rec["models"], rec["G_ratio"], rec["damping"], rec["flags"])])
        out.append(f"{rec['slug']}-points.csv")
    d = rec.get("darendeli")
    if d:
        write_curves(folder / f"{rec['slug']}-darendeli.csv", d["strain"], d["G_ratio"], d["damping"],
                     source=f"Darendeli (2001) at mean effective stress {p:.6g} Pa ({d['mean_stress_atm']:.4g} atm), "
                     f"layer {rec['name']!r}")
        out.append(f"{rec['slug']}-darendeli.csv")
    mq = rec.get("menq")
    if mq:
        i = mq["inputs"]
        write_curves(folder / f"{rec['slug']}-menq.csv", mq["strain"], mq["G_ratio"], mq["damping"],
                     source=f"Menq (2003) at mean effective stress {p:.6g} Pa ({mq['mean_stress_atm']:.4g} atm), "
                     f"Cu = {i['uniformity_coefficient']:.4g}, D50 = {1e3 * i['d50_m']:.4g} mm "
                     f"({i['grading_source']}), N = {i['n_cycles']:g}, layer {rec['name']!r}")
        out.append(f"{rec['slug']}-menq.csv")
    return out


def write_response(folder: str | Path, response: dict, figure: Any) -> list[str]:
    """``response.png`` (``figure``) and the spectra, strain and PGA profiles of the site-response runs as CSV."""
    folder = Path(folder)
    write_figure(folder / "response.png", figure)
    runs = response["runs"]
    names = list(runs)
    first = runs[names[0]]
    header = ["period [s]"] + [f"Sa {n} [g]" for n in names]
    rows = [[t] + [runs[n]["spectrum_g"][i] for n in names] for i, t in enumerate(first["periods_s"])]
    write_csv(folder / "response_spectra.csv", header, rows)
    header = ["depth [m]"] + [f"max strain {n} [decimal]" for n in names]
    rows = [[z] + [runs[n]["max_strain"][i] for n in names] for i, z in enumerate(first["strain_depth_m"])]
    write_csv(folder / "response_strain_profile.csv", header, rows)
    header = ["depth [m]"] + [f"PGA {n} [g]" for n in names]
    rows = [[z] + [runs[n]["pga_g"][i] for n in names] for i, z in enumerate(first["pga_depth_m"])]
    write_csv(folder / "response_pga_profile.csv", header, rows)
    return ["response.png", "response_spectra.csv", "response_strain_profile.csv", "response_pga_profile.csv"]


def _fmt(v: Any, scale: float = 1.0, digits: int = 4) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return f"{v * scale:.{digits}g}"
    return html.escape(str(v))


def _layer_table_html(records: list[dict]) -> str:
    head = ["layer", "depth [m]", "p' [kPa]", "packing (D_r; asked)", "models (amplitudes)", "Gmax [MPa]",
            "Vs model [m/s]", "Vs measured [m/s]", "grain G scale", "Gmax / target", "fit gamma_r, a (rms)",
            "damping fit b, D_min (rms)", "status"]
    rows = []
    for r in records:
        a = r.get("anchor") or {}
        ratio = "" if not a else _fmt(1.0 + a["mismatch"]) if a.get("mismatch") is not None else ""
        status = html.escape(r["status"] + ("" if r["status"] == "ok" else f": {r['message']}"))
        ch = r.get("density_choice") or {}
        fit = r.get("fit") or {}
        pk = (html.escape(f"{ch['packing']} ({ch['packing_relative_density']:.2f}; {ch['asked_relative_density']:.2f})")
              + (" <b>differs by more than 0.1</b>" if ch.get("flag") else "")) if ch else html.escape(
                  str(r.get("grains", "")))
        gfit = (f"{_fmt(fit.get('gamma_r'))}, {_fmt(fit.get('curvature'), digits=3)} "
                f"({_fmt(fit.get('g_residual_rms'), digits=2)})") if fit else ""
        dfit = (f"{_fmt(fit.get('masing_scaling'), digits=3)}, {_fmt(fit.get('d_min'), digits=3)} "
                f"({_fmt(fit.get('damping_residual_rms'), digits=2)})") if fit else ""
        scale = _fmt(a.get("scale")) + (" <b>grain modulus outside 10-100 GPa</b>" if a.get("warning") else "")
        cells = [html.escape(r["name"]), f"{r['top_m']:g}-{r['bottom_m']:g}", _fmt(r["p_eff_Pa"], 1e-3), pk,
                 html.escape(models_used(r)), _fmt(r.get("G_max_Pa"), 1e-6), _fmt(r.get("vs_model_m_s")),
                 _fmt(r.get("vs_measured_m_s")), scale, ratio, gfit, dfit, status]
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return ("<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr>"
            + "".join(rows) + "</table>")


def write_site_page(folder: str | Path, summary: dict, records: list[dict], response_note: str) -> Path:
    """``index.html``: the layer table, ``profile.png``, the site response (or how to get it), warnings."""
    folder = Path(folder)
    warn = [f"{r['name']}: {w}" for r in records for w in r.get("warnings", [])]
    warn += summary.get("warnings", [])
    intro = (f"<p>Profile <code>{html.escape(summary['source'])}</code>: {len(records)} layers, "
             f"{html.escape(summary['method'])} model, water table "
             f"{html.escape(str(summary['water_table_m']) if summary['water_table_m'] is not None else 'none')}"
             f" m. {summary['succeeded']} layer(s) completed, {summary['stopped']} stopped, "
             f"{summary['failed']} failed; {summary['reused']} reused from a previous run.</p>"
             + _layer_table_html(records))
    sections = [PageSection("profile", "Profile and curves", folder / "profile.png",
                            "Vs, effective stresses and Gmax against depth; G/Gmax and damping of every layer "
                            "(markers: the models' points, circles the packing model's, squares the DEM "
                            "model's; solid: the modified hyperbola fitted to them, the curve the site "
                            "response takes; dashed: Darendeli 2001; dotted: Menq 2003, clean sands and "
                            "gravels, at the coefficient of uniformity and D50 of the layer's grains or its "
                            "[reference]; both at the layer's mean effective stress).",
                            files=["layers.csv"] + [f"curves/{f}" for f in summary.get("curve_files", [])])]
    if (folder / "response.png").exists():
        sections.append(PageSection("response", "Site response (pystrata, equivalent linear)", folder / "response.png",
                                    response_note, files=[f for f in summary["files"] if f.startswith("response")]))
    else:
        sections.append(PageSection("response", "Site response", None, response_note))
    if warn:
        sections.append(PageSection("warnings", "Warnings", None, "",
                                    raw_html="<ul>" + "".join(f"<li>{html.escape(w)}</li>" for w in warn) + "</ul>"))
    return write_page(folder / "index.html", f"grainmech site: {summary['source']}", intro, sections)

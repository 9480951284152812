"""Files of ``grainmech site``: layer records, curve files, layer table, figures, page.

Layout of the output folder (``docs/site-profile.md``)::

    OUTDIR/
      layers/<NN-name>.json            one record per layer, written as the layer finishes (resume)
      curves/<NN-name>.csv             the model's G/Gmax and damping (site-response format)
      curves/<NN-name>-darendeli.csv   Darendeli (2001) at the layer's mean effective stress
      curves/<NN-name>-menq.csv        Menq (2003) at the layer's mean effective stress and grading
      layers.csv                       one row per layer
      profile.png                      Vs, stresses, Gmax against depth; the curves of every layer
      response.png, response.csv       with [motion] and pystrata: both site-response runs
      summary.json, index.html
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
           "write_response", "write_site_page", "write_profile_figure", "LAYER_COLUMNS"]

#: columns of ``layers.csv`` (record key, column header)
LAYER_COLUMNS = (("index", "index"), ("name", "name"), ("top_m", "top [m]"), ("bottom_m", "bottom [m]"),
                 ("mid_m", "mid-depth [m]"), ("unit_weight_N_m3", "unit weight [N/m^3]"), ("k0", "K0"),
                 ("sigma_v_Pa", "sigma_v [Pa]"), ("u_Pa", "u [Pa]"), ("sigma_v_eff_Pa", "sigma'_v [Pa]"),
                 ("sigma_h_eff_Pa", "sigma'_h [Pa]"), ("p_eff_Pa", "p' [Pa]"), ("method", "method"),
                 ("grains", "grains"), ("grain_shear_modulus_Pa", "grain shear modulus [Pa]"),
                 ("G_max_Pa", "Gmax [Pa]"), ("vs_model_m_s", "Vs model [m/s]"),
                 ("vs_measured_m_s", "Vs measured [m/s]"), ("anchor_scale", "grain modulus scale"),
                 ("anchor_G_target_Pa", "Gmax target rho vs^2 [Pa]"),
                 ("anchor_G_model_Pa", "Gmax before anchoring [Pa]"),
                 ("anchor_mismatch", "Gmax/target - 1"), ("hardin_richart_ratio", "Gmax / Hardin-Richart (round)"),
                 ("n_amplitudes", "amplitudes done"), ("status", "status"), ("message", "message"),
                 ("seconds", "seconds"))


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


def _row(rec: dict) -> dict:
    a = rec.get("anchor") or {}
    emp = rec.get("empirical_G_max") or {}
    row = dict(rec)
    row.update(anchor_scale=a.get("scale"), anchor_G_target_Pa=a.get("G_target_Pa"),
               anchor_G_model_Pa=a.get("G_model_Pa"), anchor_mismatch=a.get("mismatch"),
               hardin_richart_ratio=emp.get("ratio_round"), n_amplitudes=len(rec.get("amplitudes", [])))
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

    ``<slug>.csv``: the model's completed amplitudes, those beyond the envelope of sands
    left out (``site_curve`` of the record; no file if none is left);
    ``<slug>-darendeli.csv``: Darendeli (2001) at the layer's mean effective stress;
    ``<slug>-menq.csv``: Menq (2003) at the layer's mean effective stress and grading (a
    record written without it, reused from an earlier run, has none).
    """
    folder = Path(folder)
    out = []
    p = rec["p_eff_Pa"]
    c = rec.get("site_curve") or {}
    if c.get("strain"):
        left = c.get("left_out") or []
        write_curves(folder / f"{rec['slug']}.csv", c["strain"], c["G_ratio"], c["damping"],
                     g_max=rec["G_max_Pa"], source=f"{source}: layer {rec['name']!r}, {rec['method']} model, "
                     f"{rec['grains']}, mean effective stress {p:.6g} Pa"
                     + (f"; amplitudes beyond the envelope of sands left out: {left}" if left else ""))
        out.append(f"{rec['slug']}.csv")
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


def write_profile_figure(path: str | Path, records: list[dict], water_table: float) -> Path:
    """``profile.png`` (:func:`grainmech.site.plotting.profile_figure`)."""
    # imported here: site/ sits above io/ (site.runner imports this module)
    from grainmech.site.plotting import profile_figure

    return write_figure(path, profile_figure(records, water_table))


def write_response(folder: str | Path, response: dict) -> list[str]:
    """``response.png``, ``response_spectra.csv`` and ``response_profiles.csv`` of the site-response runs."""
    # imported here: site/ sits above io/ (site.runner imports this module)
    from grainmech.site.plotting import response_figure

    folder = Path(folder)
    write_figure(folder / "response.png", response_figure(response))
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
    head = ["layer", "depth [m]", "p' [kPa]", "model", "Gmax [MPa]", "Vs model [m/s]", "Vs measured [m/s]",
            "grain G scale", "Gmax / target", "status"]
    rows = []
    for r in records:
        a = r.get("anchor") or {}
        ratio = "" if not a else _fmt(1.0 + a["mismatch"]) if a.get("mismatch") is not None else ""
        status = html.escape(r["status"] + ("" if r["status"] == "ok" else f": {r['message']}"))
        cells = [html.escape(r["name"]), f"{r['top_m']:g}-{r['bottom_m']:g}", _fmt(r["p_eff_Pa"], 1e-3),
                 html.escape(str(r.get("method", ""))), _fmt(r.get("G_max_Pa"), 1e-6), _fmt(r.get("vs_model_m_s")),
                 _fmt(r.get("vs_measured_m_s")), _fmt(a.get("scale")), ratio, status]
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
                            "(solid: the model; dashed: Darendeli 2001; dotted: Menq 2003, clean sands and "
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

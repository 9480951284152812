"""Output folders of the commands: the files of a ``run``, ``contact`` or ``dem`` job.

Each writer takes the typed result of a job (:mod:`grainmech.outcomes`, built by
:mod:`grainmech.jobs`) and an output directory, writes every file atomically
(:mod:`grainmech.io.results`) and returns what it wrote. Figures are drawn by
:mod:`grainmech.plots`; nothing here computes physics.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import numpy as np

from grainmech import __version__, plots
from grainmech.analysis import SAND_PEAK_FRICTION_DEG
from grainmech.analysis.references import SAND_ENVELOPE_RATIO, SAND_ENVELOPE_TAU_RATIO
from grainmech.io.html import PageSection, write_page
from grainmech.io.results import (
    atomic_write,
    driver_table,
    ensure_dir,
    write_csv,
    write_figure,
    write_json,
    write_text,
)
from grainmech.io.site_response import write_curves
from grainmech.outcomes import CyclicOutcome, RunComparison, envelope_and_loop_warnings, model_of, packing_gmax_line
from grainmech.plots import plot_normal_density, plot_rose

__all__ = ["DEFAULT_OUTPUT_ROOT", "default_outdir", "write_run_outputs", "write_contact_outputs",
           "write_dem_outputs", "CONTACT_COLUMNS"]

#: every command writes to ``./grainmech-out/<command>`` unless ``-o OUTDIR`` is given
DEFAULT_OUTPUT_ROOT = "grainmech-out"


def default_outdir(command: str) -> str:
    """The default output folder of a command, ``grainmech-out/<command>``.

    The default output folder of a command: ``grainmech-out/<command>`` (relative to
    the working directory; one rule for every command, listed in ``.gitignore``).
    """
    return f"{DEFAULT_OUTPUT_ROOT}/{command}"


# ----------------------------------------------------------------------------------- run
def amplitude_csv_name(amplitude: float) -> str:
    """File name of one amplitude's step table: ``cycles_gamma_1.0e-04.csv``."""
    return f"cycles_gamma_{amplitude:.1e}.csv"



#: how each kinematic model is drawn and named where the two are compared
MODEL_STYLE = {"affine": ("ko", "affine (seed: every contact follows the mean strain)"),
               "packing": ("bs", "packing (every grain in equilibrium)"),
               "dem": ("g^", "DEM (LAMMPS: grains rearrange)")}


def write_run_outputs(out: Any, outdir: str | Path, cfg: dict, source: str,
                      interrupted: str | None = None, seconds: float | None = None) -> dict:
    """Write the files of ``grainmech run``.

    Files of ``grainmech run``: a CSV per amplitude (``cycles_gamma_<amplitude>.csv``)
    or ``path.csv``, ``modulus_reduction.csv``, ``site_response_curves.csv``, PNG plots,
    ``config_used.json``, ``summary.json`` and ``index.html``. ``out`` is a
    :class:`grainmech.outcomes.CyclicOutcome` or :class:`grainmech.outcomes.PathOutcome` (one
    model), or a :class:`grainmech.outcomes.RunComparison` (several models: each model's files
    carry the prefix ``<method>_``, the curves of all models share
    ``modulus_reduction.png``, and ``summary.json`` has one entry per model under
    ``models``). Returns the summary (``files`` lists the names).

    ``interrupted`` (a message, e.g. "terminated (SIGTERM) after 2 of 3 amplitudes")
    marks a run stopped by a signal whose finished amplitudes ``out`` holds:
    ``summary.json`` then says ``"success": false``, ``"interrupted": true`` and the
    message; every summary has ``"interrupted"``. ``seconds`` (the run's real elapsed time)
    replaces the models' own time in the summary and the page (an interrupted run's models
    only count their finished amplitudes).
    """
    d = ensure_dir(outdir)
    outs = list(out.outcomes) if isinstance(out, RunComparison) else [out]
    compare = len(outs) > 1
    summary: dict[str, Any] = {"source": source, "kind": out.kind,
                               "success": out.success and interrupted is None,
                               "interrupted": interrupted is not None,
                               "message": out.message if interrupted is None else interrupted,
                               "seconds": out.seconds if seconds is None else float(seconds),
                               "initial_pressure_Pa": out.pressure, "files": [],
                               "methods": [o.method for o in outs]}
    models = {}
    for o in outs:
        models[o.method] = _write_model_files(o, d, f"{o.method}_" if compare else "", summary["files"], source)
    if compare:
        summary["models"] = models
    else:
        summary.update(models[outs[0].method])
    if interrupted is not None:  # the run's state, not the last model's
        summary.update(success=False, message=interrupted)
    if seconds is not None:  # the run's real elapsed time, not the one model's finished amplitudes
        summary["seconds"] = float(seconds)
    summary["warnings"] = list(out.warnings)
    cyclic = [(o, models[o.method]) for o in outs if "G_max_Pa" in models[o.method]]
    rec = out.recommended if isinstance(out, RunComparison) else None
    if rec is not None:
        _write_recommended(d, rec, summary)
    if cyclic:
        _write_curves_figure(d, cyclic, compare, summary, rec)
    cfg_text = json.dumps(cfg, indent=2, default=str)
    write_text(d / "config_used.json", cfg_text)
    summary["files"].append("config_used.json")
    write_json(d / "summary.json", summary)
    summary["files"].append("summary.json")
    _write_run_index(d, summary, cfg_text)
    summary["files"].append("index.html")
    return summary


def _write_model_files(o: Any, d: Path, prefix: str, files: list, source: str) -> dict:
    """Per-step CSVs and per-model tables/plots of one model's outcome; returns its summary."""
    cyclic = isinstance(o, CyclicOutcome)
    env = None if cyclic else o.envelope
    m: dict[str, Any] = {"method": o.method, "success": o.success, "message": o.message, "seconds": o.seconds}
    if o.details:
        m["details"] = o.details
    for i, r in enumerate(o.results):
        cols, rows = driver_table(r)
        # a failed amplitude's steps up to the failure are written too (run_amplitudes
        # names every run; amplitudes only the completed ones)
        name = prefix + (amplitude_csv_name(o.run_amplitudes[i]) if cyclic else "path.csv")
        if not cyclic and o.measures is not None:  # p, q, strains along the axis and the strength (jobs)
            pm = o.measures
            cols, rows = cols + pm.columns, np.hstack([rows, pm.rows])
            m["axial_direction"] = pm.axis
            if pm.strength is not None:
                m["strength"] = pm.strength.as_dict()
        if getattr(r, "residual", None) is not None and len(r.residual) == len(rows):
            cols = cols + ["equilibrium_residual [-]"]
            rows = np.hstack([rows, np.asarray(r.residual, dtype=float)[:, None]])
        if getattr(r, "unbalanced", None) is not None and len(r.unbalanced) == len(rows):
            # the DEM model: every recorded state's equilibrium and contact count
            cols = cols + ["unbalanced_force_ratio [-]", "coordination [-]"]
            rows = np.hstack([rows, np.asarray(r.unbalanced, dtype=float)[:, None],
                              np.asarray(r.coordination, dtype=float)[:, None]])
        # every recorded state against the envelope of sands (jobs.envelope_check; cyclic:
        # jobs.cyclic_envelope of each amplitude's run)
        env_i = (o.envelope[i] if i < len(o.envelope) else None) if cyclic else env
        if env_i is not None and len(env_i["ratio"]) == len(rows):
            # sigma1/sigma3 is unbounded where sigma3 <= 0: an empty cell (write_csv) and a flag, never inf
            unbounded = ~np.isfinite(np.asarray(env_i["ratio"], dtype=float))
            cols = cols + ["stress_ratio_sigma1_sigma3 [-]", "stress_ratio_unbounded [0/1]",
                           "beyond_sand_envelope [0/1]"]
            rows = np.hstack([rows, env_i["ratio"][:, None], unbounded[:, None].astype(float),
                              env_i["beyond"][:, None].astype(float)])
        write_csv(d / name, cols, rows)
        files.append(name)
    if cyclic and o.empirical_G_max:
        m["empirical_G_max"] = o.empirical_G_max
    if env is not None:
        first = env["first_step"]
        cannot_fail = (" the affine model (every contact follows the mean strain) cannot fail, so these "
                       "states are not predictions" if o.model.upper_bound else
                       " read them with the sliding fraction and the equilibrium residual of the packing")
        m["envelope"] = {
            "limit_sigma1_over_sigma3": env["limit"], "friction_angle_deg": env["friction_angle_deg"],
            "first_step_beyond": first, "max_ratio": float(np.max(env["ratio"])),
            "note": ((f"the stress ratio sigma1/sigma3 leaves the envelope sands sustain (Mohr-Coulomb, "
                      f"phi = {env['friction_angle_deg']:g} deg: {env['limit']:.2f}) at step {first} and "
                      f"reaches {float(np.max(env['ratio'])):.3g};" + cannot_fail)
                     if first is not None else "stress ratio within the envelope sands sustain")}
        fig, axes = plots.subplots(2, 2, figsize=(10, 8))
        plots.soil_path_views(o.results[0], axes=axes.ravel())
        fig.tight_layout()
        write_figure(d / f"{prefix}path.png", fig)
        files.append(f"{prefix}path.png")
    if cyclic and len(o.G):
        amps, G, Dm, ratio = np.asarray(o.amplitudes), np.asarray(o.G), np.asarray(o.damping), o.G_ratio
        dp = o.mean_stress_change
        checks = _cyclic_checks(o)
        m.update(checks)
        mr_cols = ["shear_strain_amplitude [-]", "G [Pa]", "G_over_Gmax [-]", "damping [-]",
                "mean_stress_change [-]", "max_stress_ratio_sigma1_sigma3 [-]", "max_tau_over_sigma_zz [-]",
                "beyond_envelope [0/1]", "loop_stress_closure [-]", "loop_strain_closure [-]",
                "loop_asymmetry [-]", "loop_warning [0/1]"]
        mr_rows = [list(r) for r in zip(amps, G, ratio, Dm, dp, [e["max_ratio"] for e in o.envelope[:len(G)]],
                                     checks["max_tau_over_sigma_zz"], [int(b) for b in checks["beyond_envelope"]],
                                     [q.stress_closure for q in o.loop_quality],
                                     [q.strain_closure for q in o.loop_quality],
                                     [q.asymmetry for q in o.loop_quality], [int(w) for w in checks["loop_warning"]])]
        menq = o.references.menq_at_amplitudes if o.references is not None else None
        if menq is not None:  # Menq (2003) at the same amplitudes and mean stress, and its grading
            mr_cols += ["menq_G_over_Gmax [-]", "menq_damping [-]", "menq_uniformity_coefficient [-]", "menq_d50 [m]"]
            mr_rows = [r + [float(mg), float(md), menq.uniformity_coefficient, menq.d50]
                    for r, mg, md in zip(mr_rows, menq.G_ratio, menq.damping)]
            m.update(menq_G_over_Gmax=menq.G_ratio, menq_damping=menq.damping)
        # sigma1/sigma3 unbounded (sigma3 <= 0): an empty cell (write_csv) and a flag; G/Gmax above 1 or
        # a NaN: written, flagged and left out of the site-response curves
        problems = o.value_problems
        m["value_problems"] = problems
        mr_cols += ["max_stress_ratio_unbounded [0/1]", "value_flag [0/1]"]
        mr_rows = [r + [int(not np.isfinite(e["max_ratio"])), int(p is not None)]
                   for r, e, p in zip(mr_rows, o.envelope[:len(G)], problems)]
        write_csv(d / f"{prefix}modulus_reduction.csv", mr_cols, mr_rows)
        files.append(f"{prefix}modulus_reduction.csv")
        # the same curves for site-response tools (strain and damping as decimals); an
        # amplitude beyond the envelope of sands only with [model] keep_beyond_envelope, one
        # whose G/Gmax or damping such a tool does not take (value_flag) never
        keep = o.site_response_keep
        odd = [f"{a:.1e} ({p})" for a, p in zip(amps, problems) if p]
        left = o.beyond_envelope & (not o.keep_beyond_envelope)
        order = np.argsort(amps)
        order = order[keep[order]]
        if order.size and np.all(np.diff(amps[order]) > 0):
            write_curves(d / f"{prefix}site_response_curves.csv", amps[order], ratio[order], Dm[order],
                         g_max=o.G_max, source=f"grainmech run ({o.method} model): {source}, "
                                               f"mean stress {o.pressure:.6g} Pa"
                                               + (f"; amplitudes beyond the envelope of sands left out: "
                                                  f"{', '.join(f'{a:.1e}' for a in amps[left])}"
                                                  if left.any() else "")
                                               + ("; kept beyond the envelope of sands (keep_beyond_envelope): "
                                                  f"{', '.join(f'{a:.1e}' for a in amps[o.beyond_envelope])}"
                                                  if o.keep_beyond_envelope and o.beyond_envelope.any() else "")
                                               + (f"; left out, values a site-response program does not take: "
                                                  f"{', '.join(odd)}" if odd else ""))
            files.append(f"{prefix}site_response_curves.csv")
        fig, ax = plots.subplots(figsize=(6.4, 4.8))
        plots.loops(o.completed_results, amps, ax=ax)
        if prefix:
            ax.set_title(MODEL_STYLE[o.method][1], fontsize=9)
        fig.tight_layout()
        write_figure(d / f"{prefix}loops.png", fig)
        files.append(f"{prefix}loops.png")
        m.update(G_max_Pa=o.G_max, amplitudes=amps, G_Pa=G, G_over_Gmax=ratio, damping=Dm,
                 mean_stress_change=dp)
    return m


def _cyclic_checks(o: Any) -> dict:
    """The envelope and loop-quality entries of a cyclic model's summary (per completed amplitude).

    ``beyond_envelope`` (bool per amplitude), ``max_stress_ratio`` (sigma1/sigma3 of any
    recorded state; null where sigma3 <= 0, unbounded), ``max_tau_over_sigma_zz``,
    ``max_mobilised_friction_deg``, ``first_step_beyond`` (or null), ``envelope`` (the
    criterion), ``loop_quality`` (:meth:`grainmech.analysis.LoopQuality.as_dict` per
    amplitude), ``loop_warning`` (bool per amplitude), ``site_response_excluded`` (the
    amplitudes left out of ``site_response_curves.csv``) and ``amplitude_warnings`` (the
    sentences, also in ``warnings``).
    """
    n = len(o.G)
    env = o.envelope[:n]
    beyond = [bool(e["beyond_any"]) for e in env]
    amps = np.asarray(o.amplitudes, dtype=float)
    excluded = [] if o.keep_beyond_envelope else [float(a) for a, b in zip(amps, beyond) if b]
    why = (" The affine model cannot fail (every contact follows the mean strain): states beyond the "
           "envelope are what its equations give, not predictions for a sand." if o.model.upper_bound else "")
    return {
        "beyond_envelope": beyond,
        "max_stress_ratio": [e["max_ratio"] for e in env],
        "max_tau_over_sigma_zz": [e["max_tau_over_sigma_zz"] for e in env],
        "max_mobilised_friction_deg": [e["max_mobilised_friction_deg"] for e in env],
        "first_step_beyond": [e["first_step"] for e in env],
        "envelope": {
            "criterion": "Mohr-Coulomb on the principal stresses of every recorded state of each amplitude's "
                         "run: sigma1/sigma3 <= (1 + sin phi)/(1 - sin phi)",
            "friction_angle_deg": SAND_PEAK_FRICTION_DEG, "limit_sigma1_over_sigma3": SAND_ENVELOPE_RATIO,
            "limit_tau_over_sigma_zz": SAND_ENVELOPE_TAU_RATIO,
            "reason": "phi = 50 deg bounds the peak friction angles of sands (critical state ~33 deg plus the "
                      "largest dilatancy contribution, Bolton 1986)",
            "keep_beyond_envelope": bool(o.keep_beyond_envelope),
            "note": (f"amplitudes beyond the envelope: {', '.join(f'{a:.1e}' for a, b in zip(amps, beyond) if b)}."
                     + why + (" They are left out of site_response_curves.csv (model.keep_beyond_envelope = "
                              "true keeps them)." if excluded else
                              " They are kept in site_response_curves.csv (model.keep_beyond_envelope)."))
                    if any(beyond) else "every amplitude's states within the envelope of sands"},
        "loop_quality": [q.as_dict() for q in o.loop_quality],
        "loop_warning": [not q.ok for q in o.loop_quality],
        "site_response_excluded": excluded,
        "amplitude_warnings": envelope_and_loop_warnings(o.model, amps, env, o.loop_quality),
    }


#: columns of ``recommended_curve.csv``
RECOMMENDED_COLUMNS = ("shear_strain_amplitude [-]", "G [Pa]", "G_over_Gmax [-]", "damping [-]", "model", "flags")


def _write_recommended(d: Path, rec: Any, summary: dict) -> None:
    """``recommended_curve.csv`` and ``summary["recommended_curve"]`` of a run with several models.

    The curve is :func:`grainmech.outcomes.recommended_curve`; ``flags`` holds its per-point
    flags separated by ``;`` (empty where there is none).
    """
    rows = [[float(a), float(g), float(r), float(dd), m, ";".join(f)]
            for a, g, r, dd, m, f in zip(rec.amplitudes, rec.G, rec.G_ratio, rec.damping, rec.models, rec.flags)]
    write_csv(d / "recommended_curve.csv", RECOMMENDED_COLUMNS, rows)
    summary["files"].append("recommended_curve.csv")
    summary["recommended_curve"] = rec.as_dict()


def _write_curves_figure(d: Path, cyclic: list, compare: bool, summary: dict, rec: Any = None) -> None:
    """Write ``modulus_reduction.png``: G/Gmax and damping with empirical references.

    ``modulus_reduction.png``: G/Gmax and damping of every model with Darendeli (2001),
    Hardin-Drnevich (1972) and Menq (2003) at the run's mean stress, the
    :class:`~grainmech.analysis.references.ReferenceCurves` the first model's outcome
    carries (the references are empirical, none depends on the model; none drawn where it
    carries none).
    """
    first, _ = cyclic[0]
    refs = first.references
    ref_g: dict | None = None
    ref_d: dict | None = None
    if refs is not None:
        dar, gam, menq = refs.darendeli, refs.gamma, refs.menq
        ref_g = {"Darendeli (2001)": (gam, dar.G_ratio), "Hardin-Drnevich (1972)": (gam, refs.hd_ratio)}
        ref_d = {"Darendeli (2001)": (gam, dar.damping), "Hardin-Drnevich (1972)": (gam, refs.hd_damping)}
        if menq is not None:
            ref_g["Menq (2003)"] = (gam, menq.G_ratio)
            ref_d["Menq (2003)"] = (gam, menq.damping)
    fig, (a1, a2) = plots.subplots(1, 2, figsize=(10, 4.2))
    for k, (o, m) in enumerate(cyclic):
        style, name = MODEL_STYLE[o.method] if compare else ("ko", "grainmech")
        last = k == len(cyclic) - 1
        hollow = m.get("beyond_envelope")
        plots.modulus_reduction(m["amplitudes"], m["G_over_Gmax"], ax=a1, label=name, style=style, hollow=hollow,
                                references=ref_g if last else None)
        plots.damping(m["amplitudes"], m["damping"], ax=a2, label=name, style=style, hollow=hollow,
                      references=ref_d if last else None)
    if rec is not None and len(rec.amplitudes):
        label = f"recommended ({rec.G_max_model} Gmax {rec.G_max / 1e6:.4g} MPa)"
        plots.recommended_line(rec.amplitudes, rec.G_ratio, ax=a1, label=label)
        plots.recommended_line(rec.amplitudes, 100 * np.asarray(rec.damping), ax=a2, label=label)
    fig.tight_layout()
    write_figure(d / "modulus_reduction.png", fig)
    summary["files"].append("modulus_reduction.png")
    if refs is None:
        return
    hd, menq = refs.hardin_drnevich, refs.menq
    summary.update(darendeli_gamma_r=refs.darendeli.gamma_r, hardin_drnevich_gamma_r=hd.gamma_r,
                   hardin_drnevich_d_max=hd.d_max, hardin_drnevich_G_max_Pa=refs.hd_gmax,
                   hardin_drnevich_G_max_source=refs.hd_gmax_source)
    if menq is not None:
        summary.update(menq_gamma_r=menq.gamma_r, menq_curvature=menq.curvature, menq_d_min=menq.d_min,
                       menq_masing_scaling=menq.masing_scaling, menq_uniformity_coefficient=menq.uniformity_coefficient,
                       menq_d50_m=menq.d50, menq_grading_source=refs.grading_source)


def _ratio_text(r: Any) -> str:
    """A largest principal stress ratio for the page (None: sigma3 <= 0, unbounded)."""
    return "unbounded (sigma3 &lt;= 0)" if r is None or not np.isfinite(r) else f"{r:.3g}"


def _loop_text(q: dict | None) -> str:
    """'0.1 / 0.0' (percent of tau_a) for the page, '<b>...</b> (warning)' out of tolerance."""
    if q is None:
        return ""
    c = max(q["stress_closure"], q["strain_closure"])
    txt = f"{100 * c:.2g} / {100 * q['asymmetry']:.2g}" if np.isfinite(c) and np.isfinite(q["asymmetry"]) else "n/a"
    return txt if q["ok"] else f"<b>{txt} (warning)</b>"


def _write_run_index(d: Path, summary: dict, cfg_text: str) -> None:
    """``index.html``: key numbers, the plots and the exact inputs used.

    Phases: the introduction (:func:`_run_intro`), per model its details
    (:func:`_model_details`), its cyclic table and loops (:func:`_cyclic_part`) or its path
    (:func:`_path_part`), then the curves (:func:`_curves_section`), warnings and inputs.
    """
    compare = "models" in summary
    models = list(summary["models"].values()) if compare else [summary]
    intro = _run_intro(summary, compare, models)
    sections: list = []
    for m in models:
        pre = f"{m['method']}_" if compare else ""
        head = f"<h3>{html.escape(m['method'])} model</h3>" if compare else ""
        if compare and not m["success"]:
            head += f"<p><b>Stopped:</b> {html.escape(str(m['message']))}</p>"
        head += _model_details(m)
        if "G_max_Pa" in m:
            head += _cyclic_part(d, summary, m, compare, pre, sections)
        head += _path_part(d, summary, m, compare, pre, sections)
        intro += head
    if "modulus_reduction.png" in summary["files"]:
        sections.insert(0, _curves_section(d, summary, compare))
    for w in summary.get("warnings", []):
        intro += f"<p><b>Warning:</b> {html.escape(w)}.</p>"
    sections.append(PageSection("inputs", "Inputs used", None, "The configuration exactly as read.",
                            ("config_used.json", "summary.json"),
                            raw_html=f"<pre>{html.escape(cfg_text)}</pre>"))
    write_page(d / "index.html", "grainmech run", intro, sections)


def _run_intro(summary: dict, compare: bool, models: list) -> str:
    """The opening paragraphs of ``index.html``: version, source, test, status, the models compared."""
    status = "completed" if summary["success"] else f"STOPPED: {summary['message']}"
    intro = (f"<p>grainmech {html.escape(__version__)} &mdash; {html.escape(str(summary['source']))}; "
             f"test <b>{html.escape(summary['kind'])}</b>, initial isotropic stress "
             f"{summary['initial_pressure_Pa']:.6g} Pa; {html.escape(status)}"
             + (f" in {summary['seconds']:.1f} s" if summary.get("seconds") else "") + ".</p>")
    if compare:
        words = {"affine": "<b>affine</b>, the seed's kinematic hypothesis (every contact follows the mean "
                           "strain, on the analytical fabric), an upper bound that cannot fail",
                 "packing": "<b>packing</b>, a packing of grains in which every grain moves and turns until it "
                            "is in force and moment equilibrium at every step, in a fixed reference geometry "
                            "(docs/models/packing.md)",
                 "dem": "<b>dem</b>, the same grains in LAMMPS, strained in ramped increments and relaxed to "
                        "equilibrium at every recorded state: contacts form and break, grains rearrange "
                        "(docs/models/dem.md)"}
        intro += (f"<p>{len(models)} kinematic models of the same sand: "
                  + "; ".join(words[m["method"]] for m in models) + ".</p>")
    return intro


def _model_details(m: dict) -> str:
    """A model's input (its grains, notes, amplitudes) and its strength, as paragraphs."""
    head = ""
    det = m.get("details")
    engine = model_of(m["method"]).engine  # an external engine's grains: its unbalanced force ratio, notes here
    if det and "grains" in det and engine:
        head += (f"<p>{html.escape(str(det['packing']))}: {det['grains']} grains in {engine}, void ratio "
                 f"{det['void_ratio']:.3f}; largest unbalanced force ratio of any recorded state "
                 f"{det.get('max_unbalanced', float('nan')):.2g} (column unbalanced_force_ratio).</p>"
                 + "".join(f"<p>Note: {html.escape(str(n))}.</p>" for n in det.get("notes", [])))
    elif det and "grains" in det:
        what = f" ({det['packing_description']})" if det.get("packing_description") else ""
        head += (f"<p>{html.escape(str(det['packing']) + what)}: {det['grains']} grains in equilibrium "
                 f"({det['rattlers']} rattlers left out), {det['contacts_closed']} contacts "
                 f"({det['contacts_tracked']} pairs tracked), void ratio {det['void_ratio']:.3f}; "
                 f"largest out-of-balance force ratio of any step {det.get('max_residual', float('nan')):.2g} "
                 "(column equilibrium_residual).</p>")
    if det and not engine:  # an external engine's notes are above, with its grains
        head += "".join(f"<p>Note: {html.escape(str(n))}.</p>" for n in det.get("notes", []))
    if det and "amplitudes_note" in det:
        head += f"<p>Amplitudes: {html.escape(str(det['amplitudes_note']))}.</p>"
    sg = m.get("strength")
    if sg:
        head += (f"<p>Strength (Mohr-Coulomb, sin phi = (sigma1 - sigma3)/(sigma1 + sigma3)): peak "
                 f"{sg['peak_friction_angle_deg']:.1f} deg (q/p {sg['peak_q_over_p']:.3f} at axial strain "
                 f"{sg['peak_axial_strain']:.3g}); over the end of the path "
                 f"{sg['critical_friction_angle_deg']:.1f} deg (q/p {sg['critical_q_over_p']:.3f}); "
                 f"{html.escape(sg['note'])}.</p>")
    return head


def _cyclic_part(d: Path, summary: dict, m: dict, compare: bool, pre: str, sections: list) -> str:
    """A cyclic model's paragraphs and table (returned) and its loops section (appended to ``sections``)."""
    head = ""
    det = m.get("details")
    n_a = len(m["amplitudes"])
    beyond = m.get("beyond_envelope") or [False] * n_a
    ratios = m.get("max_stress_ratio") or [None] * n_a
    quality = m.get("loop_quality") or [None] * n_a
    rows = "".join(f"<tr><td>{a:.3g}</td><td>{g:.5g}</td><td>{r:.4f}</td><td>{100 * dd:.3f}</td>"
                   f"<td>{100 * c:+.1f}</td><td>{_ratio_text(sr)}</td>"
                   f"<td>{'<b>beyond</b>' if b else 'within'}</td><td>{_loop_text(q)}</td></tr>"
                   for a, g, r, dd, c, sr, b, q in zip(m["amplitudes"], m["G_Pa"], m["G_over_Gmax"],
                                                       m["damping"], m["mean_stress_change"], ratios,
                                                       beyond, quality))
    table = ("<table><tr><th>shear strain amplitude [decimal]</th><th>secant G [Pa]</th><th>G/Gmax</th>"
             "<th>damping [%]</th><th>change of p [%]</th><th>largest sigma1/sigma3</th>"
             "<th>envelope of sands</th><th>last cycle: closure / asymmetry [%]</th></tr>"
             f"{rows}</table>")
    env_c = m.get("envelope")
    if env_c and "criterion" in env_c:
        warn = "<b>Warning:</b> " if any(beyond) else ""
        head += (f"<p>{warn}Envelope of sands: {html.escape(env_c['criterion'])}, phi = "
                 f"{env_c['friction_angle_deg']:g} deg (sigma1/sigma3 &lt;= "
                 f"{env_c['limit_sigma1_over_sigma3']:.2f}; in simple shear also tau_xz/sigma_zz &lt;= "
                 f"{env_c['limit_tau_over_sigma_zz']:.2f}), {html.escape(env_c['reason'])}. "
                 f"{html.escape(env_c['note'])} Beyond-envelope points are drawn hollow in "
                 "modulus_reduction.png; column beyond_envelope of "
                 f"{pre}modulus_reduction.csv, beyond_sand_envelope of each step table.</p>")
    if quality and any(q is not None for q in quality):
        bad = [f"{a:.1e}" for a, q in zip(m["amplitudes"], quality) if q is not None and not q["ok"]]
        q0 = next(q for q in quality if q is not None)
        head += ((f"<p><b>Warning:</b> the analysed cycle of amplitude(s) {', '.join(bad)} is not a closed, "
                  "symmetric loop: its G/Gmax and damping are those of a loop still changing "
                  "(more cycles, test.n_cycles, may settle it).</p>" if bad else "")
                 + "<p>Loop quality of the analysed (last) cycle: closure = how far it ends from its start "
                   "(|tau_end - tau_start| / tau_a and |gamma_end - gamma_start| / gamma_a, the larger), "
                   "asymmetry = | |tau(+gamma_a) - tau_0| - |tau(-gamma_a) - tau_0| | / tau_a with tau_0 the "
                   f"initial shear stress; tolerances {100 * q0['closure_tolerance']:g} % and "
                   f"{100 * q0['asymmetry_tolerance']:g} % (docs/analysis.md).</p>")
    head += (f"<p>Small-strain shear modulus Gmax = {m['G_max_Pa']:.5g} Pa "
             "(condensed tangent at the initial state); every G/Gmax of this model is normalised by "
             "this one Gmax. The last column is the change of the mean stress p over each "
             "amplitude's run (at constant sigma_zz the horizontal stresses are free to change).</p>")
    emp = m.get("empirical_G_max")
    if emp:
        warn = "<b>Warning:</b> " if emp["flag"] else ""
        head += (f"<p>{warn}Hardin &amp; Richart (1963) at the same void ratio and mean stress: "
                 f"Gmax = {emp['G_round_Pa']:.4g} Pa (round grains, ratio model/empirical "
                 f"{emp['ratio_round']:.2f}), {emp['G_angular_Pa']:.4g} Pa (angular grains, ratio "
                 f"{emp['ratio_angular']:.2f}). {html.escape(emp['note'])}.</p>")
    pg = (det or {}).get("packing_gmax")
    if pg:
        head += ("<p>" + html.escape(packing_gmax_line(pg, m["G_max_Pa"]).strip()) + ". The packing's "
                 "Gmax is the small-strain shear modulus with every grain in force and moment "
                 "equilibrium (packing driver, docs/models/packing.md); the affine model makes every "
                 "contact follow the mean strain, an upper bound.</p>")
    head += table
    sections.append(PageSection(f"{pre}loops", "Stress-strain loops" + (f" ({m['method']})" if compare else ""),
                            d / f"{pre}loops.png",
                            "Every amplitude's loops on one scale: shear stress change divided by its "
                            "largest value tau_a against shear strain divided by its amplitude gamma_a "
                            "(legend: gamma_a as a decimal, tau_a in kPa). The step tables, one per "
                            "amplitude, with units in every column header:",
                            (f"{pre}loops.png", f"{pre}modulus_reduction.csv")
                            + ((f"{pre}site_response_curves.csv",)
                               if f"{pre}site_response_curves.csv" in summary["files"] else ())
                            + tuple(f for f in summary["files"] if f.startswith(f"{pre}cycles_gamma_"))))
    return head


def _path_part(d: Path, summary: dict, m: dict, compare: bool, pre: str, sections: list) -> str:
    """A path's envelope paragraph (returned) and its path section (appended to ``sections``)."""
    head = ""
    env = m.get("envelope")
    if env and "first_step_beyond" in env:  # a path's (a cyclic model's is in its table above)
        warn = "<b>Warning:</b> " if env["first_step_beyond"] is not None else ""
        head += f"<p>{warn}{html.escape(env['note'])} (column beyond_sand_envelope of {pre}path.csv).</p>"
    if f"{pre}path.png" in summary["files"]:
        ax_ = m.get("axial_direction", "zz")
        sections.append(PageSection(f"{pre}path", "Stress and strain along the path"
                                + (f" ({m['method']})" if compare else ""), d / f"{pre}path.png",
                                f"Soil-mechanics views (compression positive, strains decimal from the initial "
                                f"state, axial = {ax_}): deviator stress q = sqrt(3 J2) and volumetric strain "
                                "against axial strain, stress ratio q/p, and the p-q stress path. path.csv has "
                                "every tensor component, these quantities and the tangent constants, with "
                                "units in every column header.",
                                (f"{pre}path.png", f"{pre}path.csv")))
    return head


def _curves_section(d: Path, summary: dict, compare: bool) -> Any:
    """The section of the modulus-reduction and damping curves with the empirical references (if any)."""
    text = ("Secant modulus and damping ratio D = dW/(4 pi W) of the last cycle at each "
            "amplitude" + (" for each model" if compare else "") + " (markers; strain as a decimal, 1e-3 = 0.1 %)")
    files = ("modulus_reduction.png",) + (("recommended_curve.csv",) if "recommended_curve" in summary else ())
    if "darendeli_gamma_r" not in summary:  # an outcome without references
        return PageSection("curves", "Modulus reduction and damping", d / "modulus_reduction.png",
                           text + "." + _recommended_text(summary), files)
    menq = "menq_gamma_r" in summary
    menq_text = ("; and Menq (2003), clean sands and gravels, "
                 f"gamma_r = {summary['menq_gamma_r']:.3g} ({100 * summary['menq_gamma_r']:.4f} %), curvature "
                 f"a = {summary['menq_curvature']:.3f}, D_min = {100 * summary['menq_d_min']:.2f} %, for "
                 f"Cu = {summary['menq_uniformity_coefficient']:.3g} and "
                 f"D50 = {1e3 * summary['menq_d50_m']:.3g} mm ({summary['menq_grading_source']}; columns "
                 "menq_* of modulus_reduction.csv give it at the model's amplitudes)") if menq else ""
    n_refs, every = ("three", "All three reference strains") if menq else ("two", "Both reference strains")
    return PageSection("curves", "Modulus reduction and damping", d / "modulus_reduction.png",
                       text + f", with {n_refs} empirical "
                       "reference curves for a sand at the same mean stress over the same strain range. "
                       f"{every} come from correlations, not from the model: Darendeli "
                       f"(2001) gamma_r = {summary['darendeli_gamma_r']:.3g} "
                       f"({100 * summary['darendeli_gamma_r']:.4f} %), "
                       + ("" if menq else "and ")
                       + "Hardin-Drnevich (1972) "
                       f"gamma_r = tau_max/Gmax = {summary['hardin_drnevich_gamma_r']:.3g} "
                       f"({100 * summary['hardin_drnevich_gamma_r']:.4f} %) with tau_max = p sin(phi') and "
                       f"Gmax = {summary['hardin_drnevich_G_max_Pa']:.4g} Pa from "
                       f"{summary['hardin_drnevich_G_max_source']}, "
                       f"D_max = {100 * summary['hardin_drnevich_d_max']:.1f} %{menq_text}. The model's G/Gmax is "
                       "normalised by its own Gmax; a model that is too stiff shows against "
                       f"{'all' if menq else 'both'} references alike." + _recommended_text(summary), files)


def _recommended_text(summary: dict) -> str:
    """The page's sentences on the recommended curve (empty without one)."""
    rec = summary.get("recommended_curve")
    if not rec:
        return ""
    made = ", ".join(f"{a:.3g} {m}" + (f" ({', '.join(f)})" if f else "")
                     for a, m, f in zip(rec["amplitudes"], rec["models"], rec["flags"]))
    ref = rec.get("reference") or {}
    return (f" The red line is the recommended curve (recommended_curve.csv): the physically based models' "
            f"points, the packing model where it ran, the DEM model beyond, all on one Gmax = "
            f"{rec['G_max_Pa']:.5g} Pa, {rec['G_max_reason']}. Points (amplitude, model, flags): {made}."
            + "".join(f" At {c}." for c in rec["choices"])
            + (f" The affine model is {ref['note']}." if ref else ""))


# ------------------------------------------------------------------------------- contact
#: columns of ``contact.csv`` (SI units; tangential quantities along the loading axis x)
CONTACT_COLUMNS = ("step", "segment", "normal_displacement", "tangential_displacement", "normal_force",
                   "tangential_force", "dissipated_energy", "normal_stiffness", "tangential_stiffness",
                   "sliding")


def write_contact_outputs(out: Any, outdir: str | Path, plot: bool = True) -> list[Path]:
    """Write ``contact.csv`` and ``contact.png`` of a contact run.

    ``contact.csv`` (one row per step, :data:`CONTACT_COLUMNS`) and ``contact.png`` of a
    :class:`grainmech.outcomes.ContactOutcome`. Returns the paths written.
    """
    d = ensure_dir(outdir)
    cols = out.columns

    def writer(fh: Any) -> None:
        fh.write(",".join(CONTACT_COLUMNS) + "\n")
        for i in range(len(cols["step"])):
            vals = []
            for c in CONTACT_COLUMNS:
                v = cols[c][i]
                if c in ("step", "segment"):
                    vals.append(str(int(v)))
                elif c == "sliding":
                    vals.append("1" if bool(v) else "0")
                else:
                    vals.append(repr(float(v)))
            fh.write(",".join(vals) + "\n")

    written = [atomic_write(d / "contact.csv", writer)]
    if plot:
        fig, axes = plots.subplots(1, 2, figsize=(10, 4.2))
        plots.contact_loops(cols, axes=axes, force_unit=out.force_unit)
        fig.suptitle(f"{out.law} contact")
        fig.tight_layout()
        written.append(write_figure(d / "contact.png", fig, dpi=110))
    return written


# ----------------------------------------------------------------------------------- dem
def write_dem_outputs(out: Any, outdir: str | Path, plot: bool = True) -> list[Path]:
    """Write the files of ``grainmech dem``.

    ``summary.json``, the stiffness matrices and engineering constants as CSV, and the
    rose / normal-density plots of a :class:`grainmech.outcomes.DemOutcome`.
    """
    d = ensure_dir(outdir)
    rep = out.report
    written = [write_json(d / "summary.json", rep)]
    for key in ("stiffness_affine", "stiffness_relaxed", "stiffness_closed_form"):
        M = rep.get(key)
        if M is not None:
            def wm(fh: Any, M: Any = M) -> None:
                fh.write("component," + ",".join(rep["order"]) + "\n")
                for lab, row in zip(rep["order"], M):
                    fh.write(lab + "," + ",".join(f"{v:.10e}" for v in row) + "\n")
            written.append(atomic_write(d / f"{key}.csv", wm))
    ea, er = rep.get("engineering_affine"), rep.get("engineering_relaxed")
    if ea:
        def we(fh: Any) -> None:
            fh.write("constant,affine,relaxed\n")
            for k, v in ea.items():
                r = (er or {}).get(k)
                fh.write(f"{k},{v:.10e}," + ("" if r is None else f"{r:.10e}") + "\n")
        written.append(atomic_write(d / "engineering.csv", we))
    if plot:
        figs = [("rose.png", plot_rose(out.network))]
        if out.network.dim == 3:
            figs.append(("normal_density.png", plot_normal_density(out.network)))
        for name, fig in figs:
            written.append(write_figure(d / name, fig))
    return written

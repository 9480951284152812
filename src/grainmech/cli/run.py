"""``grainmech run [CONFIG.toml] [-o OUTDIR] [--quiet]``: the material-point driver from a config.

Without CONFIG it runs the built-in default (``grainmech/data/default_run.toml``): cyclic
simple shear of an isotropic Hertz-Mindlin/Mindlin-Deresiewicz quartz sand at several
strain amplitudes, and writes CSV tables, a JSON summary and PNG plots (loops, G/Gmax and
damping with Darendeli 2001 and Hardin-Drnevich 1972 for the same mean stress).
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.jobs import compute_run


def register(sub: Any) -> None:
    p = sub.add_parser("run", help="drive a material point along a loading path (default: cyclic simple shear)",
                       description=__doc__.splitlines()[0])
    p.add_argument("config", nargs="?", help="TOML config (see examples/run_*.toml)")
    p.add_argument("-o", "--outdir", default="grainmech-out", help="output folder (default ./grainmech-out)")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=main)


def _progress(quiet: bool, msg: str) -> None:
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


def write_outputs(out: dict, outdir: Path, cfg: dict, source: str) -> dict:
    """Files: CSV per run, modulus_reduction.csv, summary.json, PNG plots."""
    from grainmech import plots
    from grainmech.io.results import driver_table, ensure_dir, write_csv, write_json, write_text

    d = ensure_dir(outdir)
    summary: dict[str, Any] = {"source": source, "kind": out["kind"], "success": out["success"],
                               "message": out["message"], "seconds": out.get("seconds"),
                               "initial_pressure_Pa": out["pressure"], "files": []}
    env = out.get("envelope")
    for i, r in enumerate(out["results"]):
        cols, rows = driver_table(r)
        name = f"run_{i:02d}.csv" if out["kind"] == "cyclic-simple-shear" else "path.csv"
        if env is not None and out["kind"] != "cyclic-simple-shear":
            cols = cols + ["stress_ratio_sigma1_sigma3", "beyond_sand_envelope"]
            rows = np.hstack([rows, env["ratio"][:, None], env["beyond"][:, None].astype(float)])
        write_csv(d / name, cols, rows)
        summary["files"].append(name)
    if out.get("empirical_G_max"):
        summary["empirical_G_max"] = out["empirical_G_max"]
    summary["warnings"] = list(out.get("warnings", []))
    if env is not None:
        first = env["first_step"]
        summary["envelope"] = {
            "limit_sigma1_over_sigma3": env["limit"], "friction_angle_deg": env["friction_angle_deg"],
            "first_step_beyond": first, "max_ratio": float(np.max(env["ratio"])),
            "note": (("the stress ratio sigma1/sigma3 leaves the envelope sands sustain (Mohr-Coulomb, "
                      f"phi = {env['friction_angle_deg']:g} deg: {env['limit']:.2f}) at step {first} and "
                      f"reaches {float(np.max(env['ratio'])):.3g}; the affine model (every contact follows "
                      "the mean strain) cannot fail, so these states are not predictions")
                     if first is not None else "stress ratio within the envelope sands sustain")}
    if out["kind"] == "cyclic-simple-shear" and out["G"]:
        from grainmech.analysis import darendeli, hardin_drnevich

        amps = np.asarray(out["amplitudes"])
        G = np.asarray(out["G"])
        Dm = np.asarray(out["damping"])
        ref = out["reference"]
        p = out["pressure"]
        gam = np.logspace(np.log10(min(amps.min(), 1e-6)), np.log10(max(amps.max(), 1e-2)), 60)
        dar = darendeli(gam, p, pi=ref["pi"], ocr=ref["ocr"], n_cycles=ref["n_cycles"],
                        frequency=ref["frequency"])
        tau_max = p * np.sin(ref["phi"])
        gamma_r = tau_max / out["G_max"]
        d_max = (33.0 - 1.5 * np.log10(ref["n_cycles"])) / 100.0
        hd_r, hd_d = hardin_drnevich(gam, gamma_r, d_max)
        # mean stress at the end of each amplitude's run relative to the initial p: at
        # constant sigma_zz the horizontal stresses change during cycling (affine model)
        dp = np.array([float(np.mean(r.stress[-1, :3]) / np.mean(r.stress[0, :3]) - 1.0)
                       for r in out["results"][:len(G)]])
        write_csv(d / "modulus_reduction.csv",
                  ["amplitude", "G_Pa", "G_over_Gmax", "damping", "mean_stress_change"],
                  zip(amps, G, G / out["G_max"], Dm, dp))
        summary["mean_stress_change"] = dp
        summary["files"].append("modulus_reduction.csv")
        # the same curves for site-response tools (strain and damping as decimals)
        from grainmech.io.site_response import write_curves

        o = np.argsort(amps)
        if np.all(np.diff(amps[o]) > 0):
            write_curves(d / "site_response_curves.csv", amps[o], (G / out["G_max"])[o], Dm[o],
                         g_max=out["G_max"],
                         source=f"grainmech run: {source}, mean stress {out['pressure']:.6g} Pa")
            summary["files"].append("site_response_curves.csv")
        plots.loops(out["results"][:len(G)], amps, d / "loops.png")
        plots.modulus_reduction(amps, G / out["G_max"], Dm, d / "modulus_reduction.png",
                                {"Darendeli (2001)": (gam, dar.G_ratio, dar.damping),
                                 "Hardin-Drnevich (1972)": (gam, hd_r, hd_d)})
        summary["files"] += ["loops.png", "modulus_reduction.png"]
        summary.update(G_max_Pa=out["G_max"], amplitudes=amps, G_Pa=G, G_over_Gmax=G / out["G_max"], damping=Dm,
                       darendeli_gamma_r=dar.gamma_r, hardin_drnevich_gamma_r=gamma_r,
                       hardin_drnevich_d_max=d_max)
    elif out["kind"] == "path":
        plots.path_plot(out["results"][0], d / "path.png")
        summary["files"].append("path.png")
    import json
    cfg_text = json.dumps(cfg, indent=2, default=str)
    write_text(d / "config_used.json", cfg_text)
    summary["files"].append("config_used.json")
    write_json(d / "summary.json", summary)
    summary["files"].append("summary.json")
    _write_index(d, summary, cfg_text)
    summary["files"].append("index.html")
    return summary


def _write_index(d: Path, summary: dict, cfg_text: str) -> None:
    """``index.html``: key numbers, the plots and the exact inputs used."""
    import html

    from grainmech import __version__
    from grainmech.io.html import Section, write_page

    status = "completed" if summary["success"] else f"STOPPED: {summary['message']}"
    intro = (f"<p>grainmech {html.escape(__version__)} &mdash; {html.escape(str(summary['source']))}; "
             f"test <b>{html.escape(summary['kind'])}</b>, initial isotropic stress "
             f"{summary['initial_pressure_Pa']:.6g} Pa; {html.escape(status)}"
             + (f" in {summary['seconds']:.1f} s" if summary.get("seconds") else "") + ".</p>")
    sections = []
    if "G_max_Pa" in summary:
        rows = "".join(f"<tr><td>{a:.3g}</td><td>{g:.5g}</td><td>{r:.4f}</td><td>{100 * dd:.3f}</td>"
                       f"<td>{100 * c:+.1f}</td></tr>"
                       for a, g, r, dd, c in zip(summary["amplitudes"], summary["G_Pa"], summary["G_over_Gmax"],
                                                 summary["damping"], summary["mean_stress_change"]))
        table = ("<table><tr><th>shear strain amplitude</th><th>secant G [Pa]</th><th>G/Gmax</th>"
                 f"<th>damping [%]</th><th>change of p [%]</th></tr>{rows}</table>")
        intro += (f"<p>Small-strain shear modulus Gmax = {summary['G_max_Pa']:.5g} Pa "
                  "(condensed tangent at the initial state); every G/Gmax below is normalised by "
                  "this one Gmax. The last column is the change of the mean stress p over each "
                  "amplitude's run (at constant sigma_zz the horizontal stresses are free to change).</p>")
        emp = summary.get("empirical_G_max")
        if emp:
            warn = "<b>Warning:</b> " if emp["flag"] else ""
            intro += (f"<p>{warn}Hardin &amp; Richart (1963) at the same void ratio and mean stress: "
                      f"Gmax = {emp['G_round_Pa']:.4g} Pa (round grains, ratio model/empirical "
                      f"{emp['ratio_round']:.2f}), {emp['G_angular_Pa']:.4g} Pa (angular grains, ratio "
                      f"{emp['ratio_angular']:.2f}). {html.escape(emp['note'])}.</p>")
        intro += table
        sections.append(Section("curves", "Modulus reduction and damping", d / "modulus_reduction.png",
                                "Secant modulus and damping ratio D = dW/(4 pi W) of the last cycle at each "
                                "amplitude, with Darendeli (2001) (reference strain "
                                f"{100 * summary['darendeli_gamma_r']:.4f} %) and Hardin-Drnevich (1972) "
                                f"(gamma_r = tau_max/Gmax = {100 * summary['hardin_drnevich_gamma_r']:.4f} %, "
                                f"D_max = {100 * summary['hardin_drnevich_d_max']:.1f} %) at the same mean stress.",
                                ("modulus_reduction.png", "modulus_reduction.csv")
                                + (("site_response_curves.csv",)
                                   if "site_response_curves.csv" in summary["files"] else ())))
        sections.append(Section("loops", "Stress-strain loops", d / "loops.png",
                                "Shear stress against normalised shear strain for every amplitude.",
                                ("loops.png",)))
    for w in summary.get("warnings", []):
        intro += f"<p><b>Warning:</b> {html.escape(w)}.</p>"
    env = summary.get("envelope")
    if env:
        warn = "<b>Warning:</b> " if env["first_step_beyond"] is not None else ""
        intro += f"<p>{warn}{html.escape(env['note'])} (column beyond_sand_envelope of path.csv).</p>"
    if (d / "path.png").exists():
        sections.append(Section("path", "Strain and stress along the path", d / "path.png",
                                "Every component, compression positive, engineering shear strain.",
                                ("path.png", "path.csv")))
    sections.append(Section("inputs", "Inputs used", None, "The configuration exactly as read.",
                            ("config_used.json", "summary.json"),
                            raw_html=f"<pre>{html.escape(cfg_text)}</pre>"))
    write_page(d / "index.html", "grainmech run", intro, sections)


def main(args: argparse.Namespace) -> int:
    from grainmech.io.config import load_toml

    if args.config:
        cfg = load_toml(args.config)
        source = args.config
    else:
        cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
        source = "built-in default (cyclic simple shear, isotropic quartz sand, 100 kPa)"
    _progress(args.quiet, f"grainmech run: {source}")
    out = compute_run(cfg, progress=lambda msg: _progress(args.quiet, msg))
    for w in out.get("warnings", []):
        print(f"grainmech: warning: {w}", file=sys.stderr)
    summary = write_outputs(out, Path(args.outdir), cfg, source)
    if out["kind"] == "cyclic-simple-shear" and out["G"]:
        _progress(args.quiet, f"Gmax = {out['G_max']:.4g} Pa")
        emp = out.get("empirical_G_max")
        if emp:
            _progress(args.quiet, f"  Hardin-Richart (1963): {emp['G_round_Pa']:.4g} Pa round grains, "
                                  f"{emp['G_angular_Pa']:.4g} Pa angular grains")
            _progress(args.quiet, ("  WARNING: " if emp["flag"] else "  ") + emp["note"])
        for a, g, dd, c in zip(summary["amplitudes"], summary["G_over_Gmax"], summary["damping"],
                               summary["mean_stress_change"]):
            _progress(args.quiet, f"  amplitude {a:9.2e}   G/Gmax {g:6.3f}   damping {100 * dd:6.2f} %"
                                  f"   change of p {100 * c:+6.1f} %")
    if "envelope" in summary and summary["envelope"]["first_step_beyond"] is not None:
        _progress(args.quiet, "WARNING: " + summary["envelope"]["note"])
    _progress(args.quiet, f"wrote {len(summary['files'])} files to {args.outdir}")
    if not out["success"]:
        print(f"grainmech: error: {out['message']} (results so far are in {args.outdir})", file=sys.stderr)
        return 1
    return 0

"""``grainmech site PROFILE.toml [-o OUTDIR] [--resume] [--workers N | --scheduler ADDRESS] [--no-response] [--quiet]``.

Curves for every layer of a soil profile: each layer's effective stresses at mid-depth,
cyclic simple shear at its mean effective stress from 1e-6 to 1e-2 by its grains (the
packing model over its range, the DEM model beyond; anchored to a measured Vs where
given), the modified hyperbola fitted to those points, Darendeli's (2001) and Menq's
(2003) curves beside, the layers in parallel on dask.distributed, and with ``[motion]``
and pystrata (``pip install "grainmech[site]"``) the equivalent-linear site response with
each set of curves. Every finished amplitude is saved in OUTDIR: a killed run restarted
with ``--resume`` on the same OUTDIR skips them. See ``docs/site-profile.md``. Exit status
0 if every layer completed, 1 if a layer's model stopped, 2 for a bad profile (nothing
written).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from grainmech.cli._options import add_cluster_options
from grainmech.errors import GrainmechError
from grainmech.io.reports import default_outdir


def register(sub: Any) -> None:
    """Add the ``grainmech site`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("site", help="G/Gmax and damping for every layer of a soil profile, site response",
                       description=__doc__.split("\n\n", 1)[1].replace("\n", " "))
    p.add_argument("profile", help="profile file (see examples/site_sand_column.toml)")
    p.add_argument("-o", "--outdir", default=default_outdir("site"),
                   help="output folder (default ./%(default)s)")
    add_cluster_options(p)
    p.add_argument("--resume", action="store_true",
                   help="skip every amplitude an earlier run with the same inputs saved in OUTDIR")
    p.add_argument("--no-response", action="store_true", help="do not run pystrata even with [motion]")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech site`` with the parsed ``args``; exit status 0, 1 (a layer stopped) or 2 (bad input)."""
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.io.site_profile import models_used
    from grainmech.site import load_profile, run_site

    if args.workers is not None and args.workers < 1:
        raise GrainmechError(f"--workers {args.workers}: must be a positive integer")
    profile = load_profile(args.profile)
    s = run_site(profile, args.outdir, scheduler=args.scheduler, workers=args.workers, quiet=args.quiet,
                 response=not args.no_response, resume=args.resume)
    for r in s["layers"]:
        g = r.get("G_max_Pa")
        line = (f"{r['name']}: {r['top_m']:g}-{r['bottom_m']:g} m, p' = {r['p_eff_Pa'] / 1e3:.4g} kPa, "
                + (f"Gmax = {g / 1e6:.4g} MPa, Vs = {r['vs_model_m_s']:.4g} m/s" if g else "no Gmax"))
        a = r.get("anchor")
        if a:
            line += (f" (anchored to Vs {a['vs_measured_m_s']:g} m/s: grain shear modulus x {a['scale']:.4g} = "
                     f"{a['grain_modulus_anchored_Pa'] / 1e9:.4g} GPa; Gmax before {a['G_model_Pa'] / 1e6:.4g} MPa, "
                     f"target {a['G_target_Pa'] / 1e6:.4g} MPa, checked {a['G_checked_Pa'] / 1e6:.4g} MPa)")
        ch = r.get("density_choice")
        if ch:
            line += (f"; packing {ch['packing']} (D_r {ch['packing_relative_density']:.2f}, asked "
                     f"{ch['asked_relative_density']:.2f}" + (", differs by more than 0.1)" if ch["flag"] else ")"))
        if r.get("models"):
            line += f"; points: {models_used(r)}"
        fit = r.get("fit")
        if fit:
            line += (f"; fitted gamma_r = {fit['gamma_r']:.3g}, a = {fit['curvature']:.3g} (G/Gmax rms "
                     f"{fit['g_residual_rms']:.2g}), damping b = {fit['masing_scaling']:.3g}, D_min = "
                     f"{fit['d_min']:.3g} (rms {fit['damping_residual_rms']:.2g})")
        line += f"; {r['status']}" + ("" if r["status"] == "ok" else f": {r['message']}")
        print(line)
    sr = s["site_response"]
    if sr.get("run") is False:
        print(f"site response: {sr['reason']}")
    for w in [f"layer {r['name']!r}: {w}" for r in s["layers"] for w in r.get("warnings", [])] + s["warnings"]:
        print(f"grainmech: warning: {w}", file=sys.stderr)
    print(f"grainmech site: {s['n_layers']} layers: {s['succeeded']} completed, {s['stopped']} stopped, "
          f"{s['failed']} failed, {s['reused']} reused; {args.outdir}/index.html")
    return 1 if s["stopped"] or s["failed"] else 0

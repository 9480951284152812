"""``grainmech site PROFILE.toml [-o OUTDIR] [--workers N | --scheduler ADDRESS] [--no-response] [--quiet]``.

Curves for every layer of a soil profile: each layer's effective stresses at mid-depth,
one cyclic-simple-shear run of the chosen model at its mean effective stress (anchored to
a measured Vs where given), Darendeli's (2001) and Menq's (2003) curves beside, the layers
in parallel on dask.distributed with every finished layer saved (a killed run restarted on
the same OUTDIR reruns only the unfinished layers), and with ``[motion]`` and pystrata
(``pip install "grainmech[site]"``) the equivalent-linear site response with each set of
curves. See ``docs/site-profile.md``. Exit status 0 if every layer completed, 1 if a
layer's model stopped, 2 for a bad profile (nothing written).
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
                   help="output folder; finished layers in it are reused (default ./%(default)s)")
    add_cluster_options(p)
    p.add_argument("--no-response", action="store_true", help="do not run pystrata even with [motion]")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech site`` with the parsed ``args``; exit status 0, 1 (a layer stopped) or 2 (bad input)."""
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.site import load_profile, run_site

    if args.workers is not None and args.workers < 1:
        raise GrainmechError(f"--workers {args.workers}: must be a positive integer")
    profile = load_profile(args.profile)
    s = run_site(profile, args.outdir, scheduler=args.scheduler, workers=args.workers, quiet=args.quiet,
                 response=not args.no_response)
    for r in s["layers"]:
        g = r.get("G_max_Pa")
        line = (f"{r['name']}: {r['top_m']:g}-{r['bottom_m']:g} m, p' = {r['p_eff_Pa'] / 1e3:.4g} kPa, "
                + (f"Gmax = {g / 1e6:.4g} MPa, Vs = {r['vs_model_m_s']:.4g} m/s" if g else "no Gmax"))
        a = r.get("anchor")
        if a:
            line += (f" (anchored to Vs {a['vs_measured_m_s']:g} m/s: grain shear modulus x {a['scale']:.4g} = "
                     f"{a['grain_modulus_anchored_Pa'] / 1e9:.4g} GPa; Gmax before {a['G_model_Pa'] / 1e6:.4g} MPa, "
                     f"target {a['G_target_Pa'] / 1e6:.4g} MPa, checked {a['G_checked_Pa'] / 1e6:.4g} MPa)")
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

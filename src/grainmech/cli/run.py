"""``grainmech run [CONFIG.toml] [-o OUTDIR] [--quiet]``: the material-point driver from a config.

Without CONFIG it runs the built-in default (``grainmech/data/default_run.toml``): cyclic
simple shear of an isotropic Hertz-Mindlin/Mindlin-Deresiewicz quartz sand at several
strain amplitudes with both kinematic models (the seed's affine model and the shipped
'dense' packing with every grain in equilibrium, ~20 s), and writes CSV tables, a JSON
summary and PNG plots (loops, G/Gmax and damping with Darendeli 2001 and Hardin-Drnevich
1972 for the same mean stress) to OUTDIR (default ``./grainmech-out/run``).
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from importlib import resources
from typing import Any


def register(sub: Any) -> None:
    """Add the ``grainmech run`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    from grainmech.io.reports import default_outdir

    p = sub.add_parser("run", help="drive a material point along a loading path (default: cyclic simple shear)",
                       description=__doc__.splitlines()[0])
    p.add_argument("config", nargs="?", help="TOML config (see examples/run_*.toml)")
    p.add_argument("-o", "--outdir", default=default_outdir("run"), help="output folder (default ./%(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech run`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    from grainmech.io.config import load_toml
    from grainmech.io.outdir import output_folder
    from grainmech.io.reports import write_run_outputs
    from grainmech.jobs import CyclicOutcome, RunComparison, compute_run, packing_gmax_line

    def say(msg: str) -> None:
        if not args.quiet:
            print(msg, file=sys.stderr, flush=True)

    if args.config:
        from pathlib import Path

        from grainmech.io.config import resolve_file_keys

        cfg = resolve_file_keys(load_toml(args.config), Path(args.config).parent)
        source = args.config
    else:
        cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
        source = "built-in default (cyclic simple shear, isotropic quartz sand, 100 kPa)"
    with output_folder(args.outdir, "run") as folder:  # checked and locked before the work
        say(f"grainmech run: {source}")
        out = compute_run(cfg, progress=say)
        for w in out.warnings:
            print(f"grainmech: warning: {w}", file=sys.stderr)
        summary = write_run_outputs(out, folder.staging, cfg, source)
        folder.commit(success=out.success)
    outs = list(out.outcomes) if isinstance(out, RunComparison) else [out]
    for o in outs:
        m = summary["models"][o.method] if "models" in summary else summary
        if len(outs) > 1:
            say(f"{o.method} model ({'completed' if o.success else 'STOPPED: ' + o.message}):")
        det = o.details
        if det and "grains" in det and o.method == "dem":
            say(f"  {det['packing']}: {det['grains']} grains in LAMMPS, void ratio {det['void_ratio']:.3f}; "
                f"largest unbalanced force ratio {det.get('max_unbalanced', float('nan')):.2g}")
            for n in det.get("notes", []):
                say(f"  note: {n}")
        elif det and "grains" in det:
            say(f"  {det['packing']}: {det['grains']} grains ({det['rattlers']} rattlers), void ratio "
                f"{det['void_ratio']:.3f}; largest out-of-balance force ratio "
                f"{det.get('max_residual', float('nan')):.2g}")
        if det and "amplitudes_note" in det:
            say(f"  {det['amplitudes_note']}")
        if isinstance(o, CyclicOutcome) and len(o.G):
            say(f"  Gmax = {o.G_max:.4g} Pa")
            emp = o.empirical_G_max
            if emp:
                say(f"  Hardin-Richart (1963): {emp['G_round_Pa']:.4g} Pa round grains, "
                    f"{emp['G_angular_Pa']:.4g} Pa angular grains")
                say(("  WARNING: " if emp["flag"] else "  ") + emp["note"])
            pg = (det or {}).get("packing_gmax")
            if pg:
                say(packing_gmax_line(pg, o.G_max))
            for a, g, dd, c in zip(o.amplitudes, o.G_ratio, o.damping, o.mean_stress_change):
                say(f"  amplitude {a:9.2e}   G/Gmax {g:6.3f}   damping {100 * dd:6.2f} %"
                    f"   change of p {100 * c:+6.1f} %")
        env = m.get("envelope")
        if env and env["first_step_beyond"] is not None:
            say("WARNING: " + env["note"])
    say(f"wrote {len(summary['files'])} files to {args.outdir}")
    if not out.success:
        print(f"grainmech: error: {out.message} (results so far are in {args.outdir})", file=sys.stderr)
        return 1
    return 0

"""``grainmech sweep SWEEP.toml [-o OUTDIR] [--workers N | --scheduler ADDRESS] [--retry-failed] [--quiet]``.

Runs every point of a parameter sweep (grid, Latin hypercube or Monte Carlo over keys of
a ``stiffness``, ``run`` or ``dem`` config) on dask.distributed, persisting each point as
it finishes; restarted on the same OUTDIR it reuses the finished points. See
``docs/sweep.md``. Exit status 0 if every point succeeded, 1 if some failed, 2 on a bad
sweep file.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from grainmech.cli._options import add_cluster_options
from grainmech.errors import GrainmechError
from grainmech.io.reports import default_outdir


def register(sub: Any) -> None:
    """Add the ``grainmech sweep`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("sweep", help="run a parameter sweep (grid, Latin hypercube, Monte Carlo) on dask",
                       description="Run every point of a parameter sweep (grid, Latin hypercube or Monte "
                                   "Carlo over keys of a stiffness, run or dem config) on dask.distributed, "
                                   "persisting each point as it finishes; rerun on the same OUTDIR to resume "
                                   "(finished points are reused). See docs/sweep.md. Exit status: 0 if every "
                                   "point succeeded, 1 if some failed, 2 for a bad sweep file.")
    p.add_argument("sweep", help="sweep file (see examples/sweep_*.toml)")
    p.add_argument("-o", "--outdir", default=default_outdir("sweep"),
                   help="output folder; finished points in it are reused (default ./%(default)s)")
    add_cluster_options(p)
    p.add_argument("--retry-failed", action="store_true", help="run again the points recorded as failed")
    p.add_argument("--no-plots", action="store_true", help="do not write summary.png")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech sweep`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.io.schema import renamed_table_warnings
    from grainmech.sweep import load_sweep, run_sweep

    if args.workers is not None and args.workers < 1:
        raise GrainmechError(f"--workers {args.workers}: must be a positive integer")
    sweep = load_sweep(args.sweep)
    for warning in renamed_table_warnings(sweep.base):  # tables under an old name (the points read them)
        print(f"grainmech: warning: {sweep.base_source}: {warning}", file=sys.stderr, flush=True)
    s = run_sweep(sweep, args.outdir, scheduler=args.scheduler, workers=args.workers,
                  retry_failed=args.retry_failed, quiet=args.quiet, plots=not args.no_plots)
    line = (f"grainmech sweep: {s['n_points']} points: {s['succeeded']} succeeded, {s['failed']} failed, "
            f"{s['reused']} reused; table {args.outdir}/sweep.csv")
    print(line)
    if s["failed"]:
        print(f"grainmech: {s['failed']} point(s) failed (see the error column; rerun with --retry-failed)",
              file=sys.stderr)
        return 1
    return 0

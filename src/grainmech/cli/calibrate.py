"""``grainmech calibrate CALIB.toml DATA.csv -o OUTDIR [--starts N] [--seed S] [--workers W]``.

Fits parameters of a model config (dotted key paths, bounds, start values with units) to
measured data with bounded least squares and writes the best fit, standard errors,
correlation, identifiability notes, residuals and a plot to OUTDIR (``docs/calibrate.md``).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from grainmech.errors import ConfigError
from grainmech.io.outdir import output_folder
from grainmech.io.reports import default_outdir
from grainmech.jobs import input_warnings


def register(sub: Any) -> None:
    """Add the ``grainmech calibrate`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("calibrate", help="fit model parameters to measured data (least squares)",
                       description=__doc__.splitlines()[0])
    p.add_argument("config", help="calibration TOML (see examples/calibrate_*.toml)")
    p.add_argument("data", help="data CSV (header with units, e.g. 'pressure [psi],G [psi]')")
    p.add_argument("-o", "--outdir", default=default_outdir("calibrate"),
                   help="output folder (default ./%(default)s)")
    p.add_argument("--starts", type=int, default=None,
                   help="number of starts: the given one plus seeded Latin-hypercube starts within the "
                        "bounds, run through Dask (default: [fit] starts, 1 = serial)")
    p.add_argument("--seed", type=int, default=None, help="seed of the Latin-hypercube starts (default [fit] seed)")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address (default: a local cluster)")
    p.add_argument("--workers", type=int, default=None, help="worker processes of the local Dask cluster")
    p.add_argument("--no-plot", action="store_true", help="do not write fit.png")
    p.add_argument("--quiet", action="store_true", help="no progress messages (the results still go to stdout)")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech calibrate`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.calibrate import fit, load_problem
    from grainmech.calibrate.report import write_report

    if args.starts is not None and args.starts < 1:
        raise ConfigError("--starts", args.starts, "must be >= 1")
    if args.workers is not None and args.workers < 1:
        raise ConfigError("--workers", args.workers, "must be >= 1")
    problem = load_problem(args.config, args.data, starts=args.starts, seed=args.seed)
    for warning in input_warnings(problem.model, "model"):
        print(f"grainmech: warning: {warning}", file=sys.stderr, flush=True)
    if not args.quiet:
        print(f"grainmech calibrate: {problem.kind}, {len(problem.data)} rows; fitting {len(problem.parameters)} "
              f"parameter(s) from {problem.starts} start(s)", file=sys.stderr, flush=True)
    with output_folder(args.outdir, "calibrate") as folder:  # checked and locked before the fit
        result = fit(problem, scheduler=args.scheduler, workers=args.workers)
        files = write_report(result, folder.staging, plot=not args.no_plot)
        folder.commit(success=result.success)
    w = sys.stdout.write
    st = result.stats
    w(f"grainmech calibrate: {problem.kind}, {len(problem.data)} rows, columns {', '.join(problem.targets)}; "
      f"{len(result.starts)} start(s), {result.nfev} evaluations; {result.message}\n")
    for j, p in enumerate(problem.parameters):
        se = st["std_error"][j]
        unit = p.unit or p.si_unit
        err = "not identifiable" if not st["identifiable"][j] else (
            "n/a" if se is None else f"+- {se / p.unit_factor:.4g}")
        su = st["std_error_unscaled"][j]
        if problem.known_sd and su is not None:
            err += f"; +- {su / p.unit_factor:.4g} with the sd_ columns as true standard deviations"
        w(f"  {p.path:<32} {result.x[j] / p.unit_factor:.6g} {unit} ({err})"
          + ("  [at bound]" if st["at_bound"][j] else "") + "\n")
    w("  R^2: " + ", ".join(f"{k} {v:.5f}" for k, v in st["r2"].items()) + "\n")
    for note in st["notes"]:
        w(f"  {'WARNING' if note in st['plausibility'] else 'note'}: {note}\n")
    w(f"wrote {len(files)} files to {args.outdir}\n")
    if not result.success:
        print(f"grainmech: error: the fit did not converge: {result.message} (report in {args.outdir})",
              file=sys.stderr)
    return 0 if result.success else 1

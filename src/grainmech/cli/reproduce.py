"""``grainmech reproduce [FIG ...] [-o OUTDIR] [--quiet]``: regenerate the seed's figures.

Writes, per figure, ``figX_Y.png`` and ``figX_Y.csv`` (the plotted numbers) and a
self-contained ``index.html`` with every figure next to its caption (what the seed
reports, the inputs we chose where the seed is silent, how ours compares). Figure ids:
``4.2``, ``fig4.2``, ``6.10`` ...; none: all. See ``docs/reproduce.md``.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from grainmech.io.reports import default_outdir
from grainmech.reproduce import figure_ids, reproduce

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add the ``grainmech reproduce`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser(
        "reproduce", help="regenerate the seed report's figures (PNG + CSV + index.html)",
        description="Regenerate figures of the seed report (Chang 1988, Ch. 4 and 6) as PNG "
                    "plus CSV of the plotted numbers and a self-contained index.html with "
                    "captions. Available: " + ", ".join(figure_ids()) + ".")
    p.add_argument("figures", nargs="*", metavar="FIG",
                   help="figure ids such as 4.2, fig4.3, 6.10 (default: all)")
    p.add_argument("-o", "--outdir", default=default_outdir("reproduce"),
                   help="output folder (default ./%(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress lines (the list of files still goes to stdout)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``grainmech reproduce`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    figs = reproduce(args.figures, args.outdir, log=None if args.quiet else progress)
    # the result: what was written (stdout); the progress lines above went to stderr
    for fig in figs:
        print(f"Fig. {fig.fig_id}: {fig.stem}.png, {fig.stem}.csv")
    print(f"wrote {2 * len(figs) + 1} files to {args.outdir} (index: {args.outdir}/index.html)")
    return 0

"""``grainmech pack``: prepare a periodic sphere packing at a target stress (LAMMPS).

``grainmech pack CONFIG.toml [-o OUTDIR] [--quiet] [--no-plot]``: a periodic, mechanically
stable sphere packing at a target stress, prepared with LAMMPS (extra ``grainmech[dem]``).

Writes ``contacts.npz`` and ``particles.npz`` (read by ``grainmech dem``), ``summary.json``
(void ratio, coordination with and without rattlers, fabric, stress, unbalanced force
ratio), ``history.csv``, ``packing.png`` and a copy of the config to OUTDIR (default
``./grainmech-out/pack``), all after the preparation has succeeded, written aside and moved
in together (:func:`grainmech.io.outdir.output_folder`: a full disk leaves the previous
packing there as it was). Progress lines go to stderr while LAMMPS runs, at least every
10 s: the stage, the mean stress and its target, the void ratio, the unbalanced force
ratio and, once it can be estimated, the time left in the stage. Exit status 2 for bad
input or missing LAMMPS, 1 when the preparation does not reach its target or the disk is
full, 130 on Ctrl-C. See ``docs/packings.md``.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from grainmech.io.config import load_toml, read_text_file
from grainmech.io.outdir import output_folder
from grainmech.io.pack_config import build_pack_config
from grainmech.io.reports import default_outdir


def register(sub: Any) -> None:
    """Add the ``grainmech pack`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("pack", help="prepare a periodic sphere packing at a target stress (LAMMPS)",
                       description=__doc__.splitlines()[0])
    p.add_argument("config", help="TOML config (see examples/pack_*.toml and docs/packings.md)")
    p.add_argument("-o", "--outdir", default=default_outdir("pack"), help="output folder (default ./%(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.add_argument("--no-plot", action="store_true", help="do not write packing.png")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech pack`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.io.packing import write_pack_outputs
    from grainmech.jobs import input_warnings, pack_job
    from grainmech.packing import PreparationError

    def say(msg: str) -> None:
        if not args.quiet:
            print(msg, file=sys.stderr, flush=True)

    cfg = load_toml(args.config)
    text = read_text_file(args.config, "config")
    build_pack_config(cfg)  # a bad config stops here, with one line, before any warning
    for warning in input_warnings(cfg):  # the same plausibility checks as grainmech run
        print(f"grainmech: warning: {warning}", file=sys.stderr, flush=True)
    say(f"grainmech pack: {args.config}")
    try:
        res = pack_job(cfg, progress=say)
    except PreparationError as exc:
        print(f"grainmech: error: {exc} (nothing written)", file=sys.stderr)
        return 1
    with output_folder(args.outdir, "pack") as folder:  # written aside, moved in together
        write_pack_outputs(res, folder.staging, text, plot=not args.no_plot)
    s = res.summary
    c = s["coordination"]
    print(f"void ratio {s['void_ratio']:.4f}, mean stress {s['mean_stress_Pa']:.5g} Pa, "
          f"coordination {c['z']:.3f} (without rattlers {c['z_mechanical']:.3f}, {c['n_rattlers']} rattlers), "
          f"unbalanced force ratio {s['unbalanced_force_ratio']:.2e}, {s['time_steps']} steps in "
          f"{s['wall_time_s']:.1f} s")
    print(f"written to {args.outdir}")
    return 0

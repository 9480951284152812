"""``grainmech dem CONTACTS [--particles FILE] [--format ...] [--material CONFIG.toml] [--json] [-o OUTDIR]``.

Reads a DEM contact network (LIGGGHTS/LAMMPS local dump, generic CSV/NPZ table), and
writes its Love-Weber stress, fabric, coordination, affine and relaxed stiffness tensors,
engineering constants and plots to OUTDIR (default ``./grainmech-out/dem``). See
``docs/networks.md``.

Material config (TOML, all tables optional)::

    [material]             # grain elastic constants (Hertz-Mindlin law)
    shear_modulus = "29 GPa"
    poisson = 0.15
    [stiffness]
    source = "auto"        # auto | overlap | force | columns | constant
    kn = "1e6 N/m"         # for source = "constant"
    ks = "8e5 N/m"
    geometric = false      # add -(N/|l|)(I - nn) to the contact stiffness
    [relaxed]
    enabled = true
    solver = "auto"        # auto | direct | pardiso | cholesky | superlu | amg | cg
    remove_rattlers = true
    min_contacts = 2       # rattler threshold (default: 2 frictional, d + 1 frictionless)
    [fabric]
    fit_order = 2          # even order of the spherical-harmonic fit
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from typing import Any, TextIO

import numpy as np

from grainmech.errors import ConfigError
from grainmech.io.config import load_toml
from grainmech.io.outdir import output_folder
from grainmech.io.reports import default_outdir, write_dem_outputs


def register(sub: Any) -> None:
    """Add the ``grainmech dem`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser(
        "dem", help="stress, fabric, coordination and affine/relaxed stiffness of a DEM contact network",
        description="Measures of a DEM contact network (LIGGGHTS/LAMMPS local dump or generic CSV/NPZ "
                    "table): Love-Weber stress, fabric tensors and harmonic fit, coordination with and "
                    "without rattlers, affine (seed Eq. 2.26) and relaxed (non-affine) stiffness tensors.")
    p.add_argument("contacts", help="contact file (dump local, .csv or .npz)")
    p.add_argument("--particles", help="particle file (dump custom id x y z radius, .csv or .npz)")
    p.add_argument("--format", choices=("auto", "liggghts", "lammps", "csv", "npz"), default="auto",
                   help="contact file format (default: from suffix and first line)")
    p.add_argument("--keywords", help="compute pair/gran/local keywords in output order, e.g. "
                                      "pos,id,force,contactPoint,delta")
    p.add_argument("--columns", help="name every column of a local dump, e.g. id1,id2,fx,fy,fz")
    p.add_argument("--force-on", choices=("id1", "id2"), default=None,
                   help="particle the file's force acts on (default: id1 for dumps, id2 for tables)")
    p.add_argument("--material", help="TOML with [material], [stiffness], [relaxed], [fabric]")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--no-plots", action="store_true", help="do not write the plots")
    p.add_argument("--quiet", action="store_true", help="no progress messages (results still go to stdout)")
    p.add_argument("-o", "--outdir", default=default_outdir("dem"),
                   help="output folder (created if needed; default ./%(default)s)")
    p.set_defaults(func=run)


def _config(args: argparse.Namespace) -> dict:
    """The dem job config built from the command-line arguments.

    The dem job config: the ``--material`` tables plus a ``[network]`` table from the
    command-line arguments (the form a sweep's ``dem`` config has).
    """
    cfg = load_toml(args.material, allow_empty=True) if args.material else {}
    if "network" in cfg:
        raise ConfigError("network", cfg["network"], f"{args.material}: the network files are given on "
                          "the command line, not in --material")
    net: dict[str, Any] = {"contacts": args.contacts, "format": args.format}
    for key, val in (("particles", args.particles), ("force_on", args.force_on),
                     ("keywords", args.keywords), ("columns", args.columns)):
        if val is not None:
            net[key] = val
    return {"network": net, **cfg}


#: contact files at least this large get a progress bar on a terminal [bytes]
PROGRESS_MIN_BYTES = 64 << 20


def _progress_bar(stream: TextIO) -> Callable[[int, int], None] | None:
    """A ``progress(done, total)`` that draws a bar on ``stream`` if it is a terminal.

    Files smaller than :data:`PROGRESS_MIN_BYTES` (read in about a second) draw nothing;
    the bar is redrawn when its percentage changes and ends with a newline.
    """
    if not stream.isatty():
        return None
    last = [-1]

    def show(done: int, total: int) -> None:
        if total < PROGRESS_MIN_BYTES:
            return
        pct = min(100, 100 * done // total)
        if pct == last[0]:
            return
        last[0] = pct
        bar = "#" * (pct // 4) + "-" * (25 - pct // 4)
        stream.write(f"\rreading the contact file [{bar}] {pct:3d} % of {total / 1e6:.0f} MB")
        if pct == 100:
            stream.write("\n")
        stream.flush()
    return show


def run(args: argparse.Namespace) -> int:
    """Run ``grainmech dem`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.jobs import compute_dem

    cfg = _config(args)
    with output_folder(args.outdir, "dem") as folder:  # checked and locked before the work
        out = compute_dem(cfg, progress=None if args.quiet else _progress_bar(sys.stderr))
        rep = out.report
        write_dem_outputs(out, folder.staging, plot=not args.no_plots)
    if args.json:
        json.dump(rep, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    w = sys.stdout.write
    w(f"grainmech dem: {rep['source']}\n")
    w(f"particles {rep['n_particles']}, contacts {rep['n_contacts']}, volume {rep['volume']:.6g}\n")
    s = np.array(rep["stress"]["tensor"])
    w(f"stress (compression +): mean {rep['stress']['mean']:.6g}, skew ratio {rep['stress']['skew_ratio']:.3g}\n")
    for row in s:
        w("  " + " ".join(f"{v:13.5e}" for v in row) + "\n")
    c = rep["coordination"]
    w(f"coordination z = {c['z']:.4g}, force-carrying {c['z_force']:.4g}, mechanical {c['z_mechanical']:.4g} "
      f"({c['n_rattlers']} rattlers)\n")
    for key in ("stiffness_affine", "stiffness_relaxed", "stiffness_closed_form"):
        M = rep.get(key)
        if M is None:
            continue
        w(f"\n{key} (Voigt, order {' '.join(rep['order'])}):\n")
        for lab, row in zip(rep["order"], M):
            w(f"{lab:>4}" + "".join(f"{v:13.5e}" for v in row) + "\n")
    for key in ("engineering_affine", "engineering_relaxed"):
        e = rep.get(key)
        if e:
            w(f"\n{key}: " + ", ".join(f"{k} {e[k]:.4g}" for k in ("E_xx", "E_yy", "E_zz", "G_yz", "G_xz",
                                                                   "G_xy", "nu_xy", "nu_xz", "nu_yz")
                                         if e.get(k) is not None) + "\n")
    for n in rep.get("notes", []):
        w(f"note: {n}\n")
    w(f"\nwritten to {args.outdir}\n")
    return 0

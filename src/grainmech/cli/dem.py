"""``grainmech dem CONTACTS [--particles FILE] [--format ...] [--material CONFIG.toml] [--json] -o OUTDIR``.

Reads a DEM contact network (LIGGGHTS/LAMMPS local dump, generic CSV/NPZ table), and
writes its Love-Weber stress, fabric, coordination, affine and relaxed stiffness tensors,
engineering constants and plots. See ``docs/dem.md``.

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
    solver = "auto"        # auto | direct | cg
    remove_rattlers = true
    min_contacts = 2       # rattler threshold (default: 2 frictional, d + 1 frictionless)
    [fabric]
    fit_order = 2          # even order of the spherical-harmonic fit
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np

from grainmech.errors import GrainmechError


def register(sub: Any) -> None:
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
    p.add_argument("-o", "--outdir", help="directory for the result files (created if needed)")
    p.set_defaults(func=run)


def _options(path: str | None) -> dict:
    from grainmech.io.config import Section, load_toml
    from grainmech.jobs import dem_options

    if path is None:
        return {}
    root = Section(load_toml(path), "")
    opts = dem_options(root)
    root.finish()
    return opts


def _atomic(path: Path, write: Callable[[Any], None], binary: bool = False) -> None:
    from grainmech.io.results import atomic_write

    atomic_write(path, write, binary=binary, newline=None)


def _write_matrix(path: Path, M: Any, order: list[str]) -> None:
    def w(fh):
        fh.write("component," + ",".join(order) + "\n")
        for lab, row in zip(order, M):
            fh.write(lab + "," + ",".join(f"{v:.10e}" for v in row) + "\n")
    _atomic(path, w)


def _plots(net: Any, out: Path) -> None:
    import matplotlib.pyplot as plt

    from grainmech.network import plot_normal_density, plot_rose

    figs = [("rose.png", plot_rose(net))]
    if net.dim == 3:
        figs.append(("normal_density.png", plot_normal_density(net)))
    for name, fig in figs:
        _atomic(out / name, lambda fh, fig=fig: fig.savefig(fh, format="png", dpi=120), binary=True)
        plt.close(fig)


def run(args: argparse.Namespace) -> int:
    from grainmech.io.dem import read_network
    from grainmech.network import network_report

    opts = _options(args.material)
    split = (lambda s: None if s is None else [x.strip() for x in s.split(",") if x.strip()])
    net = read_network(args.contacts, args.particles, format=args.format, keywords=split(args.keywords),
                       columns=split(args.columns), force_on=args.force_on)
    rep = network_report(net, **opts)
    if args.outdir:
        out = Path(args.outdir)
        if out.exists() and not out.is_dir():
            raise GrainmechError(f"--outdir {out} exists and is not a directory")
        out.mkdir(parents=True, exist_ok=True)
        _atomic(out / "summary.json", lambda fh: (json.dump(rep, fh, indent=2), fh.write("\n")))
        for key in ("stiffness_affine", "stiffness_relaxed", "stiffness_closed_form"):
            if rep.get(key) is not None:
                _write_matrix(out / f"{key}.csv", rep[key], rep["order"])
        ea, er = rep.get("engineering_affine"), rep.get("engineering_relaxed")
        if ea:
            def we(fh):
                fh.write("constant,affine,relaxed\n")
                for k, v in ea.items():
                    r = (er or {}).get(k)
                    fh.write(f"{k},{v:.10e}," + ("" if r is None else f"{r:.10e}") + "\n")
            _atomic(out / "engineering.csv", we)
        if not args.no_plots:
            _plots(net, out)
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
    if args.outdir:
        w(f"\nwritten to {args.outdir}\n")
    return 0

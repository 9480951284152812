"""``grainmech stiffness [CONFIG.toml] [--json] [--order voigt|mandel|seed]``."""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.conventions import order_for, reorder, voigt_to_mandel
from grainmech.io.config import load_toml, resolve_file_keys
from grainmech.jobs import compute_stiffness, input_warnings


def register(sub: Any) -> None:
    """Add the ``grainmech stiffness`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("stiffness", help="stiffness tensor, engineering constants and symmetry of a packing",
                       description="Stiffness tensor (seed Eq. 2.41) of a packing given by its fabric, "
                                   "packing density and contact law. Without CONFIG, runs the built-in "
                                   "default (isotropic quartz sand, Hertz-Mindlin, 100 kPa).")
    p.add_argument("config", nargs="?", help="TOML config (see examples/stiffness_*.toml)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.add_argument("--order", choices=("voigt", "mandel", "seed"), default="voigt",
                   help="component order/shear factor of the printed matrix (default voigt)")
    p.add_argument("--quiet", action="store_true", help="no progress messages (results still go to stdout)")
    p.set_defaults(func=run)


def _matrix(C: np.ndarray, order: str, dim: int) -> tuple[np.ndarray, tuple[str, ...]]:
    labels = order_for(dim, order)
    if order == "mandel":
        return voigt_to_mandel(C), labels
    if order == "seed":
        return reorder(C, to=labels), labels
    return C, labels


def run(args: argparse.Namespace) -> int:
    """Run ``grainmech stiffness`` with the parsed ``args``.

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    if args.config:
        cfg = resolve_file_keys(load_toml(args.config), Path(args.config).parent)
        source = args.config
    else:
        text = resources.files("grainmech.data").joinpath("default_stiffness.toml").read_text()
        cfg = tomllib.loads(text)
        source = "built-in default (isotropic quartz sand, Hertz-Mindlin, 100 kPa)"
    out = compute_stiffness(cfg)  # a bad config stops here, with one line
    for warning in input_warnings(cfg):  # the same plausibility checks as grainmech run
        print(f"grainmech: warning: {warning}", file=sys.stderr, flush=True)
    res, eng, sym, dim = out.result, out.engineering, out.symmetry, out.dim
    M, labels = _matrix(res.C, args.order, dim)
    # quadrature round-off (~1e-16 relative) is shown as an exact zero
    M = np.where(np.abs(M) < 1e-12 * np.abs(M).max(), 0.0, M)
    mean_stress = out.mean_stress
    if args.json:
        obj = {
            "stiffness": M.tolist(),
            "order": list(labels),
            "shear": "mandel" if args.order == "mandel" else "engineering (Voigt)",
            "units": "Pa",
            "engineering": {k: float(v) for k, v in eng.as_dict().items()},
            "symmetry": {"name": sym.name, "seed_name": sym.seed_name,
                         "axis": None if sym.axis is None else [float(x) for x in sym.axis],
                         "residual": float(sym.residual)},
            "mean_stress": mean_stress,
            "convention": out.microstructure.convention,
            "source": source,
        }
        if out.fabric_fit:
            obj["fabric_fit"] = {k: v for k, v in out.fabric_fit.items() if k != "summary"}
        json.dump(obj, sys.stdout, indent=2)
        sys.stdout.write("\n")
        return 0
    w = sys.stdout.write
    w(f"grainmech stiffness: {source}\n")
    w(f"counting convention: {out.microstructure.convention}; mean stress {mean_stress:.6g} Pa\n")
    if out.fabric_fit:
        w(out.fabric_fit["summary"] + "\n")
    w("\n")
    w(f"stiffness ({'Mandel' if args.order == 'mandel' else 'Voigt'}, order {args.order}), Pa:\n")
    w("      " + "".join(f"{lab:>13}" for lab in labels) + "\n")
    for lab, row in zip(labels, M):
        w(f"{lab:>6}" + "".join(f"{v:13.5e}" for v in row) + "\n")
    w("\nengineering constants:\n")
    for k, v in eng.as_dict().items():
        w(f"  {k:<10} {v:.6g}{' Pa' if k[0] in 'EG' else ''}\n")
    w(f"\nsymmetry: {sym}" + (f"  (seed Table 1: {sym.seed_name})" if sym.seed_name else "") + "\n")
    return 0

"""DEM against the packing model on every shipped packing (docs/models/dem.md, "Against the packing model").

LAMMPS keeps no tangential spring history from a network: the DEM model restarts the
tangential forces of a packing from zero and lets it re-settle, while the packing model
keeps them. 'dense' was prepared frictionless (no tangential forces to lose); 'medium'
and 'loose' were prepared with friction 0.15 and 0.5 and carry them. This runs both models
through :func:`grainmech.jobs.compute_run` (``method = ["packing", "dem"]``, Hertz-Mindlin
with the packings' own quartz grains, 100 kPa, constant-volume cyclic simple shear, 2
cycles x 16 steps) at 1e-5 and 1e-4 and prints G, damping and Gmax of each and the
differences as a markdown table.

Usage: ``python benchmarks/dem_vs_packing.py [PACKING ...]`` (default dense medium loose;
needs ``grainmech[dem]``; a few minutes per packing).
"""

from __future__ import annotations

import datetime
import sys
import time

from grainmech.jobs import compute_run


def config(name: str) -> dict:
    """The run config of packing ``name``."""
    return {"contacts": {"law": "hertz-mindlin", "shear_modulus": "29 GPa", "poisson": 0.15, "friction": 0.5},
            "initial": {"pressure": "100 kPa"},
            "model": {"method": ["packing", "dem"], "packing": name},
            "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-5, 1e-4], "n_cycles": 2,
                     "steps_per_cycle": 16, "constant": "volume"}}


def main(argv: list[str]) -> int:
    """Run the comparison for the packings named in ``argv``; exit status."""
    names = argv or ["dense", "medium", "loose"]
    print(f"{datetime.date.today()}: packing model against DEM, Hertz-Mindlin quartz (29 GPa, 0.15, mu 0.5), "
          "100 kPa, constant volume, 2 cycles x 16 steps")
    print("| packing | amplitude | G packing [MPa] | G DEM [MPa] | ΔG | D packing | D DEM | ΔD | Gmax packing / DEM "
          "[MPa] | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in names:
        t0 = time.perf_counter()
        out = compute_run(config(name))
        dt = time.perf_counter() - t0
        pk, dem = (next(o for o in out.outcomes if o.method == m) for m in ("packing", "dem"))
        for a in (1e-5, 1e-4):
            row = [name, f"{a:g}"]
            vals = []
            for o in (pk, dem):
                hit = [k for k, x in enumerate(o.amplitudes) if abs(x / a - 1) < 1e-9]
                vals.append((o.G[hit[0]], o.damping[hit[0]]) if hit else None)
            if None in vals:
                why = pk.message if vals[0] is None else dem.message
                print(f"| {name} | {a:g} | " + " | ".join("—" if v is None else f"{v[0] / 1e6:.2f}" for v in vals)
                      + f" | stopped: {why} | | | | | {dt:.0f} |", flush=True)
                continue
            (gp, dp), (gd, dd) = vals
            row += [f"{gp / 1e6:.2f}", f"{gd / 1e6:.2f}", f"{100 * (gd / gp - 1):+.2f} %", f"{100 * dp:.2f} %",
                    f"{100 * dd:.2f} %", f"{dd - dp:+.4f}", f"{pk.G_max / 1e6:.1f} / {dem.G_max / 1e6:.1f}",
                    f"{dt:.0f}"]
            print("| " + " | ".join(row) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Whether the DEM model's numerical settings move the answer (docs/dem-model.md, settings table).

Runs cyclic simple shear with the DEM model on a shipped packing (Hertz-Mindlin, the
packing's own quartz grains, ``n_cycles = 2``, 16 steps per cycle) at each amplitude with
the default settings (or those of ``--set``) and with the ramp length (``ramp_steps`` and
``max_ramp_strain`` together), the drag and the relaxation tolerance
halved and doubled (under ``--set damping=kinetic``: the tolerance halved and doubled, and
the drags in place of the kinetic damping), and prints G and damping of each against the default's as a
markdown table (the change of G in %, of damping in absolute terms).

Usage: ``python benchmarks/dem_settings_table.py [PACKING] [AMPLITUDE ...] [--constant stress|volume] [--set KEY=VALUE]``
(needs ``grainmech[dem]``; each row is one LAMMPS run per amplitude, minutes).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

from _dem_settings_arg import settings_from

from grainmech.contact import HertzMindlin
from grainmech.driver.dem import dem_modulus_reduction
from grainmech.packing import load_packing, packing_info


def main(argv: list[str]) -> int:
    """Run the benchmark with the command-line arguments ``argv``; exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packing", nargs="?", default="dense")
    ap.add_argument("amplitudes", nargs="*", type=float, default=[1e-4, 1e-3, 1e-2])
    ap.add_argument("--constant", default="volume", choices=("stress", "volume"))
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="a DemSettings field other than its default (repeatable), e.g. damping=kinetic")
    a = ap.parse_args(argv)
    net = load_packing(a.packing)
    m = packing_info(a.packing)["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    base = settings_from(a.set)
    variants = [("default" if not a.set else "base (" + ", ".join(a.set) + ")", base)]
    for f, word in ((0.5, "halved"), (2.0, "doubled")):
        # the ramp: its least length and its largest strain per time step together
        variants.append((f"ramp {word} ({int(base.ramp_steps * f)} steps, {base.max_ramp_strain / f:g} per step)",
                         dataclasses.replace(base, ramp_steps=int(base.ramp_steps * f),
                                             max_ramp_strain=base.max_ramp_strain / f)))
    # the damping of the relaxation: the drags halved and doubled, or, under kinetic damping,
    # the drags in its place
    keys = ("viscous", "tol") if base.damping == "viscous" else ("tol",)
    if base.damping != "viscous":
        variants.append((f"viscous drags ({base.viscous:g}) instead of {base.damping} damping",
                         dataclasses.replace(base, damping="viscous")))
    for k in keys:
        v = getattr(base, k)
        for f, word in ((0.5, "halved"), (2.0, "doubled")):
            variants.append((f"{k} {word} ({v * f:g})", dataclasses.replace(base, **{k: v * f})))
    print(f"packing {a.packing}, constant {a.constant}, amplitudes {a.amplitudes}, defaults {base.as_dict()}",
          flush=True)
    rows = []
    for label, st in variants:
        t0 = time.perf_counter()
        mr = dem_modulus_reduction(net, law, a.amplitudes, settings=st, constant=a.constant,
                                   workers=a.workers, raise_on_failure=False)
        dt = time.perf_counter() - t0
        rows.append((label, mr, dt))
        print(f"{label}: G {list(mr.G)} D {list(mr.damping)} ({dt:.0f} s) {'' if mr.success else mr.message}",
              flush=True)
    ref = rows[0][1]
    head = "| settings | " + " | ".join(f"G({g:g}) | D({g:g})" for g in a.amplitudes) + " | time |"
    print(head)
    print("|" + "---|" * (2 * len(a.amplitudes) + 2))
    for label, mr, dt in rows:
        cells = []
        for i in range(len(a.amplitudes)):
            if i >= len(mr.G):
                cells += ["stopped", "stopped"]
                continue
            if mr is ref:
                cells += [f"{mr.G[i] / 1e6:.2f} MPa", f"{100 * mr.damping[i]:.2f} %"]
            else:
                cells += [f"{100 * (mr.G[i] / ref.G[i] - 1):+.2f} %", f"{mr.damping[i] - ref.damping[i]:+.4f}"]
        print(f"| {label} | " + " | ".join(cells) + f" | {dt:.0f} s |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Whether the DEM model's numerical settings move the answer (docs/models/dem.md, settings table).

Runs cyclic simple shear with the DEM model on a shipped packing (Hertz-Mindlin, the
packing's own quartz grains, ``n_cycles = 2``, 16 steps per cycle) at each amplitude with
the default settings (or those of ``--set``) and with the ramp length (``ramp_steps`` and
``max_ramp_strain`` together), the drag and the relaxation tolerance
halved and doubled (under ``--set damping=kinetic``: the tolerance halved and doubled, and
the drags in place of the kinetic damping), and prints G and damping of each against the default's as a
markdown table (the change of G in %, of damping in absolute terms).

``--replicas N`` runs every row on the packing and on ``N - 1`` copies of it with every
centre moved by ``--perturbation`` (default 1e-9) of its radius in a random direction
(seeds 1 … N-1): at 1e-2 one run's G depends on which rearrangements the path goes
through, which any change of the path alters, so a setting's effect is the change of the
mean over the replicas; the table gives it with its standard error, and a line with the
defaults' spread over the replicas.

Usage: ``python benchmarks/dem_settings_table.py [PACKING] [AMPLITUDE ...] [--constant stress|volume] [--set KEY=VALUE]
[--replicas N] [--perturbation EPS]``
(needs ``grainmech[dem]``; each row is one LAMMPS run per amplitude, minutes).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np
from _dem_settings_arg import settings_from
from packing_grid import perturbed

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
    ap.add_argument("--replicas", type=int, default=1,
                    help="run each row on the packing and N-1 perturbed copies; compare the means")
    ap.add_argument("--perturbation", type=float, default=1e-9,
                    help="the copies' displacement of every centre, in radii (default 1e-9)")
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
    if a.replicas < 1:
        raise SystemExit(f"--replicas {a.replicas}: must be at least 1")
    nets = [net] + [perturbed(net, a.perturbation, seed) for seed in range(1, a.replicas)]
    n_amp = len(a.amplitudes)
    rows = []
    for label, st in variants:
        t0 = time.perf_counter()
        g = np.full((len(nets), n_amp), np.nan)
        d = np.full((len(nets), n_amp), np.nan)
        for r, nt in enumerate(nets):
            mr = dem_modulus_reduction(nt, law, a.amplitudes, settings=st, constant=a.constant,
                                       workers=a.workers, raise_on_failure=False)
            g[r, :len(mr.G)], d[r, :len(mr.G)] = mr.G, mr.damping
            print(f"{label}, replica {r}: G {list(mr.G)} D {list(mr.damping)} "
                  f"{'' if mr.success else mr.message}", flush=True)
        dt = time.perf_counter() - t0
        rows.append((label, g, d, dt))
        print(f"{label}: {dt:.0f} s", flush=True)
    _, g0, d0, _ = rows[0]
    m = len(nets)
    if m > 1:
        for i, amp in enumerate(a.amplitudes):
            print(f"{rows[0][0]} at {amp:g} over {m} replicas: G {np.nanmean(g0[:, i]) / 1e6:.2f} MPa, "
                  f"standard deviation {100 * np.nanstd(g0[:, i], ddof=1) / np.nanmean(g0[:, i]):.2f} %; "
                  f"damping {100 * np.nanmean(d0[:, i]):.2f} %, standard deviation "
                  f"{np.nanstd(d0[:, i], ddof=1):.4f}")
    head = "| settings | " + " | ".join(f"G({x:g}) | D({x:g})" for x in a.amplitudes) + " | time |"
    print(head)
    print("|" + "---|" * (2 * n_amp + 2))
    for k, (label, g, d, dt) in enumerate(rows):
        cells = []
        for i in range(n_amp):
            if np.isnan(g[:, i]).any():
                cells += ["stopped", "stopped"]
            elif k == 0:
                cells += [f"{g[:, i].mean() / 1e6:.2f} MPa", f"{100 * d[:, i].mean():.2f} %"]
            else:
                dg = 100 * (g[:, i].mean() / g0[:, i].mean() - 1)
                dd = d[:, i].mean() - d0[:, i].mean()
                if m == 1:
                    cells += [f"{dg:+.2f} %", f"{dd:+.4f}"]
                else:  # standard error of the difference of two means of m independent runs
                    eg = 100 * np.hypot(g[:, i].std(ddof=1), g0[:, i].std(ddof=1)) / np.sqrt(m) / g0[:, i].mean()
                    ed = np.hypot(d[:, i].std(ddof=1), d0[:, i].std(ddof=1)) / np.sqrt(m)
                    cells += [f"{dg:+.2f} ± {eg:.2f} %", f"{dd:+.4f} ± {ed:.4f}"]
        print(f"| {label} | " + " | ".join(cells) + f" | {dt:.0f} s |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

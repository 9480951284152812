"""Whether the DEM model completes every shipped packing at every amplitude (docs/models/dem.md).

For each shipped packing ('dense', 'medium', 'loose'; Hertz-Mindlin with the packing's
own quartz grains), each control (constant stress: ``sigma_zz`` held by the servo;
constant volume) and each amplitude (default 1e-6, 1e-5, 1e-4, 1e-3, 1e-2), runs cyclic
simple shear with the DEM model (``n_cycles = 2``, 16 steps per cycle, default
:class:`grainmech.driver.dem.DemSettings`) and prints one markdown row per amplitude as
it finishes: completed, liquefied (constant volume) or where it stopped, G, G/Gmax,
damping, the change of mean stress over the path (at constant volume the pore-pressure
ratio), the volumetric strain over the path (compression positive: contraction at constant
stress), the largest unbalanced force ratio of the recorded states, the LAMMPS time steps
and the wall time.

Usage: ``python benchmarks/dem_campaign.py [--packings dense,medium,loose]
[--controls stress,volume] [--amplitudes 1e-6,1e-5,1e-4,1e-3,1e-2] [--workers 1] [--set KEY=VALUE]``
(needs ``grainmech[dem]``; about an hour on one core for the whole grid).
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time

import numpy as np

from _dem_settings_arg import settings_from

from grainmech.contact import HertzMindlin
from grainmech.driver.base import Status
from grainmech.driver.dem import dem_modulus_reduction
from grainmech.packing import load_packing, packing_info


def main(argv: list[str]) -> int:
    """Run the campaign with the command-line arguments ``argv``; exit status (1 if a cell stopped)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--packings", default="dense,medium,loose")
    ap.add_argument("--controls", default="stress,volume")
    ap.add_argument("--amplitudes", default="1e-6,1e-5,1e-4,1e-3,1e-2")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="a DemSettings field other than its default (repeatable), e.g. damping=kinetic")
    a = ap.parse_args(argv)
    amps = [float(x) for x in a.amplitudes.split(",")]
    settings = settings_from(a.set)
    print(f"{datetime.date.today()}: DEM campaign, 2 cycles x 16 steps, settings {settings.as_dict()}")
    print("| packing | control | amplitude | result | G [MPa] | G/Gmax | damping | Δp/p0 | Δε_v | max unbalanced "
          "| time steps | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    stopped = 0
    for name in a.packings.split(","):
        net = load_packing(name)
        m = packing_info(name)["material"]
        law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
        for control in a.controls.split(","):
            t0 = time.perf_counter()
            last = [t0]

            def row(mr, name=name, control=control, last=last) -> None:  # noqa: ANN001
                k = len(mr.G) - 1
                r = mr.completed[-1]
                now = time.perf_counter()
                p = np.mean(r.stress[:, :3], axis=1)
                ev = float(np.sum(r.strain[-1, :3] - r.strain[0, :3]))
                print(f"| {name} | {control} | {mr.amplitude[k]:g} | completed | {mr.G[k] / 1e6:.2f} | "
                      f"{mr.G[k] / mr.G_max:.3f} | {mr.damping[k]:.4f} | {p[-1] / p[0] - 1:+.3f} | {ev:+.2e} | "
                      f"{float(np.max(r.unbalanced)):.2g} | {int(r.iterations.sum())} | {now - last[0]:.0f} |",
                      flush=True)
                last[0] = now

            mr = dem_modulus_reduction(net, law, amps, constant=control, settings=settings,
                                       workers=a.workers, raise_on_failure=False, on_amplitude=row)
            for amp, r in zip(mr.run_amplitudes, mr.results):
                if int(r.status) == Status.LIQUEFIED:  # the test's answer (docs/models/dem.md)
                    p = np.mean(r.stress[:, :3], axis=1)
                    print(f"| {name} | {control} | {amp:g} | LIQUEFIED: {r.message} | | | | "
                          f"{p[-1] / p[0] - 1:+.3f} at step {len(p) - 1} | | {float(np.max(r.unbalanced)):.2g} | "
                          f"{int(r.iterations.sum())} to step {len(p) - 1} | {time.perf_counter() - last[0]:.0f} |",
                          flush=True)
            if not mr.success:
                stopped += 1
                print(f"| {name} | {control} | | STOPPED: {mr.message} | | | | | | | | |", flush=True)
    return 1 if stopped else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Benchmark of the DEM model on several MPI ranks (LAMMPS domain decomposition).

Cyclic simple shear at constant volume on the shipped 'dense' packing (2000 grains), or on
copies of it tiled into a larger periodic cell (``--tiles 5x5x2`` = 1e5 grains: a tiling
of a periodic packing in equilibrium is a packing in equilibrium,
:func:`grainmech.network.builders.tile_network`), Hertz-Mindlin quartz grains (the
packing's own), the default :class:`grainmech.driver.dem.DemSettings` except ``ranks``.
For each number of ranks it prints the wall time, the LAMMPS time steps, grain-steps per
second, the ratio to the dgemm yardstick (``benchmarks/_yardstick.py``), G and damping,
and the difference in G from the first number of ranks.

Run: ``python benchmarks/bench_dem_mpi.py [--ranks 1,2] [--tiles 1x1x1] [--amplitude 1e-5]
[--cycles 2] [--steps 16]`` (needs ``grainmech[dem]``).
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time

from _yardstick import dgemm_seconds

from grainmech.contact import HertzMindlin
from grainmech.driver.dem import DemSettings, dem_modulus_reduction
from grainmech.network.builders import tile_network
from grainmech.packing import load_packing, packing_info


def main(argv: list[str]) -> int:
    """Run the benchmark with the command-line arguments ``argv``; exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ranks", default="1,2", help="comma-separated MPI ranks to compare")
    ap.add_argument("--tiles", default="1x1x1", help="copies of 'dense' along x, y, z (5x5x2 = 1e5 grains)")
    ap.add_argument("--amplitude", type=float, default=1e-5)
    ap.add_argument("--cycles", type=int, default=2)
    ap.add_argument("--steps", type=int, default=16, help="steps per cycle (a multiple of 4)")
    a = ap.parse_args(argv)
    net = load_packing("dense")
    reps = [int(x) for x in a.tiles.split("x")]
    if reps != [1, 1, 1]:
        net = tile_network(net, reps)
    m = packing_info("dense")["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    yard = dgemm_seconds()
    print(f"{datetime.date.today()}: dgemm(2048) {yard:.3f} s; 'dense' x {a.tiles} ({net.n_particles} grains, "
          f"{net.n_contacts} contacts), constant volume, amplitude {a.amplitude:g}, {a.cycles} cycles x {a.steps} "
          "steps", flush=True)
    first = None
    for ranks in [int(r) for r in a.ranks.split(",")]:
        t0 = time.perf_counter()
        mr = dem_modulus_reduction(net, law, [a.amplitude], n_cycles=a.cycles, steps_per_cycle=a.steps,
                                   constant="volume", settings=DemSettings(ranks=ranks), raise_on_failure=False)
        dt = time.perf_counter() - t0
        r = mr.results[0]
        steps = int(r.iterations.sum())
        if not len(mr.G):
            print(f"{ranks} ranks: stopped after {dt:.1f} s: {mr.message}", flush=True)
            continue
        g = float(mr.G[0])
        first = g if first is None else first
        print(f"{ranks} ranks: {dt:.1f} s = {dt / yard:.0f} dgemm; {steps} LAMMPS time steps in the path "
              f"({steps * net.n_particles / dt:.3g} grain-steps per s, with start-up); G {g / 1e6:.4f} MPa "
              f"({100 * (g / first - 1):+.4f} %), Gmax {mr.G_max / 1e6:.4f} MPa, damping "
              f"{100 * mr.damping[0]:.3f} %", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

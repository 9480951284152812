"""Benchmark of the DEM model: one cyclic amplitude on the shipped 'dense' packing.

Constant-stress cyclic simple shear (``sigma_zz`` held by the servo), 2 cycles of 16
steps, Hertz-Mindlin quartz grains (the packing's own), the default
:class:`grainmech.driver.dem.DemSettings`, one LAMMPS on one core; each amplitude from
the relaxed start state (:func:`grainmech.driver.dem.dem_modulus_reduction`). Prints the
wall time of each amplitude, the LAMMPS time steps, the time steps per second (2000
grains) and the ratio to the dgemm yardstick (``benchmarks/_yardstick.py``).

Run: ``python benchmarks/bench_dem_cyclic.py [AMPLITUDE ...] [--constant stress|volume]``
(default 1e-4 1e-3; needs ``grainmech[dem]``).
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time

from _yardstick import dgemm_seconds

from grainmech.contact import HertzMindlin
from grainmech.driver.dem import DemSettings, dem_modulus_reduction
from grainmech.packing import load_packing, packing_info


def main(argv: list[str]) -> int:
    """Run the benchmark with the command-line arguments ``argv``; exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("amplitudes", nargs="*", type=float, default=[1e-4, 1e-3])
    ap.add_argument("--constant", default="stress", choices=("stress", "volume"))
    a = ap.parse_args(argv)
    net = load_packing("dense")
    m = packing_info("dense")["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    yard = dgemm_seconds()
    print(f"{datetime.date.today()}: dgemm(2048) {yard:.3f} s; 'dense' (2000 grains), constant {a.constant}, "
          f"2 cycles x 16 steps, settings {DemSettings().as_dict()}")
    for amp in a.amplitudes:
        t0 = time.perf_counter()
        mr = dem_modulus_reduction(net, law, [amp], constant=a.constant, raise_on_failure=False)
        dt = time.perf_counter() - t0
        r = mr.results[0]
        steps = int(r.iterations.sum())
        g = f"G {mr.G[0] / 1e6:.2f} MPa, damping {100 * mr.damping[0]:.2f} %" if len(mr.G) else mr.message
        print(f"amplitude {amp:g}: {dt:.1f} s = {dt / yard:.0f} dgemm; {steps} LAMMPS time steps in the path "
              f"({steps / dt:.0f} per s, with start-up), {int(r.substeps.sum())} servo corrections; {g}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Benchmark of the DEM model's curve: 3e-4, 1e-3, 3e-3, 1e-2 on a shipped packing, 2 workers.

Cyclic simple shear ``gamma_xz`` at 100 kPa (``sigma_zz`` held), 2 cycles x 16 steps per
amplitude, the packing's own grains (Mindlin-Deresiewicz quartz with its friction, and
its rolling and twisting resistance where it has them), the default
:class:`grainmech.driver.dem.DemSettings` (``protocol = "auto"``, which runs cycles by step
and relax; ``--set protocol=continuous`` for the other), amplitudes run side by side in
``--workers`` LAMMPS processes, the largest first (:func:`grainmech.driver.dem.dem_modulus_reduction`).
Prints the wall time of the whole curve in seconds and dgemm units (``benchmarks/_yardstick.py``),
and per amplitude G/Gmax, damping, the LAMMPS time steps and the servo corrections.

Usage: ``python benchmarks/bench_dem_curve.py [PACKING] [--amplitudes 3e-4,1e-3,3e-3,1e-2]
[--workers 2] [--set KEY=VALUE]`` (needs ``grainmech[dem]``; minutes).
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time

import numpy as np
from _dem_settings_arg import settings_from
from _yardstick import dgemm_seconds
from dem_protocol_table import PRESSURE, _law

from grainmech.driver.dem import dem_modulus_reduction


def main(argv: list[str]) -> int:
    """Run the benchmark with the command-line arguments ``argv``; exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packing", nargs="?", default="nevada-medium")
    ap.add_argument("--amplitudes", default="3e-4,1e-3,3e-3,1e-2")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--set", action="append", metavar="KEY=VALUE")
    a = ap.parse_args(argv)
    amps = [float(v) for v in a.amplitudes.split(",") if v]
    st = settings_from(a.set)
    net, law, rolling = _law(a.packing)
    yard = dgemm_seconds()
    print(f"{datetime.date.today()}: dgemm(2048) {yard:.3f} s; load average {os.getloadavg()[0]:.2f}; "
          f"'{a.packing}' ({net.n_particles} grains), 100 kPa, amplitudes {amps}, {a.workers} workers, "
          f"settings {st.as_dict()}", flush=True)
    t0 = time.perf_counter()
    mr = dem_modulus_reduction(net, law, amps, settings=st, pressure=PRESSURE, rolling=rolling,
                               workers=a.workers, raise_on_failure=False)
    wall = time.perf_counter() - t0
    print(f"curve: {wall:.1f} s = {wall / yard:.0f} dgemm ({mr.message}); load average {os.getloadavg()[0]:.2f}")
    done = {float(x): k for k, x in enumerate(mr.amplitude)}
    for amp, r in zip(mr.run_amplitudes if mr.run_amplitudes is not None else amps, mr.results):
        k = done.get(float(amp))
        g = (f"G/Gmax {mr.G[k] / mr.G_max:.3f}, damping {100 * mr.damping[k]:.2f} %" if k is not None
             else f"stopped: {r.message}")
        print(f"  {amp:g}: {int(np.sum(r.iterations))} LAMMPS time steps, {int(np.sum(r.substeps))} servo "
              f"corrections; {g}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

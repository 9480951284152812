"""How the DEM model's relaxation ends one step under each damping (docs/models/dem.md, "Relaxation").

Loads a shipped packing into LAMMPS (Hertz-Mindlin, its own quartz grains) with viscous
drags, Cundall's local damping (0.7) or kinetic damping, relaxes it, applies one shear
step ``gamma_xz += STEP`` (every strain held, the model's ramp) and then keeps relaxing
past the model's criteria, printing every ``--every`` time steps the unbalanced force
ratio, the change of ``tau_xz`` since the step began and the mean stress, and where the
criteria (``tol``, ``settle`` of :class:`grainmech.driver.dem.DemSettings`) first hold.

Usage: ``python benchmarks/dem_relaxation.py [PACKING] [--damping drags|cundall|kinetic]
[--step 2.5e-5] [--steps 100000] [--every 2500]`` (needs ``grainmech[dem]``; 1-2 min per
100 000 time steps on one core for 2000 grains).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from grainmech.contact import HertzMindlin
from grainmech.driver.dem import DemPoint, DemSettings
from grainmech.lammps.network import network_from_lammps, unbalanced_ratio
from grainmech.lammps.session import ramp, voigt
from grainmech.network import network_stress
from grainmech.packing import load_packing, packing_info


def main(argv: list[str]) -> int:
    """Run the benchmark with the command-line arguments ``argv``; exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packing", nargs="?", default="loose")
    ap.add_argument("--damping", default="kinetic", choices=("drags", "cundall", "kinetic"))
    ap.add_argument("--step", type=float, default=2.5e-5)
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--every", type=int, default=2500)
    a = ap.parse_args(argv)
    net = load_packing(a.packing)
    m = packing_info(a.packing)["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    st = DemSettings(damping={"drags": "viscous"}.get(a.damping, a.damping))
    t0 = time.perf_counter()
    with DemPoint.start(net, law, st) as pt:
        s = pt.session
        print(f"{a.packing}, {a.damping}: start p = {pt.p0:.6g} Pa, unbalanced {pt.unbalanced:.2g}, "
              f"gamma_xz += {a.step:g}", flush=True)
        de = np.zeros(6)
        de[4] = a.step
        base = pt.stress.copy()
        ramp(s, de, max(st.ramp_steps, int(math.ceil(a.step / st.max_ramp_strain))))
        used, prev, met = 0, None, None
        while used < a.steps:
            s.advance(st.chunk)
            used += st.chunk
            nt = network_from_lammps(s.lmp)
            ub = unbalanced_ratio(nt)
            sig = voigt(np.asarray(network_stress(nt).stress))
            scale = float(np.abs(sig - base).max())
            if met is None and prev is not None and ub < st.tol and float(np.abs(sig - prev).max()) <= st.settle * scale:
                met = used
                print(f"criteria hold at {used} steps: d tau_xz {sig[4] - base[4]:.6g} Pa, ub {ub:.3g}", flush=True)
            prev = sig
            if used % a.every == 0:
                print(f"{used:7d} ub {ub:.3e} d tau_xz {sig[4] - base[4]:.6g} Pa p {sig[:3].mean():.7g} Pa", flush=True)
    print(f"{time.perf_counter() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Where the DEM model's time goes: cProfile of one amplitude on a shipped packing, per protocol.

Usage: ``python benchmarks/dem_profile.py [--protocol relax|continuous] [--amplitude 3e-4]``
(needs ``grainmech[dem]``). Runs 'nevada-medium' (2000 Nevada-sand grains with rolling
resistance mu_r 0.25) at the amplitude, one cycle of 8 steps, 100 kPa, with the protocol
(step and relax, or continuous shearing at the default inertial number), and prints the
wall time, the LAMMPS time steps, the split of the time between LAMMPS' ``command`` (its
``run`` commands), the gathers of per-contact data (``extract_compute``), the servo's
sparse solves (``block_cg``, ``csr_matvecs``) and the rest, and the 15 functions with the
largest own time.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--protocol", choices=("relax", "continuous"), default="relax")
    ap.add_argument("--amplitude", type=float, default=3e-4)
    a = ap.parse_args(argv)
    from grainmech.contact import HertzMindlin, RollingResistance
    from grainmech.driver import cyclic_simple_shear
    from grainmech.driver.dem import DemSettings, run_dem
    from grainmech.packing import load_packing, packing_info

    net = load_packing("nevada-medium")
    m = packing_info("nevada-medium")["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], float(net.radii.mean()), friction=m["friction"])
    path = cyclic_simple_shear(a.amplitude, 1, 8)
    t0 = time.perf_counter()
    pr = cProfile.Profile()
    pr.enable()
    r = run_dem(net, law, path, DemSettings(protocol=a.protocol), pressure=1e5, rolling=RollingResistance(0.25))
    pr.disable()
    wall = time.perf_counter() - t0
    st = pstats.Stats(pr)
    own: dict[str, float] = {}
    for (_file, _line, name), (_cc, _nc, tt, _ct, _callers) in st.stats.items():  # type: ignore[attr-defined]
        own[name] = own.get(name, 0.0) + tt
    groups = {"LAMMPS command": ("command",), "gathers (extract_compute)": ("extract_compute",),
              "servo solves (block_cg, csr_matvecs)": ("block_cg", "csr_matvecs")}
    print(f"protocol {a.protocol}, amplitude {a.amplitude:g}: wall {wall:.1f} s, "
          f"{int(sum(r.iterations))} LAMMPS time steps, {r.message}")
    total = sum(own.values())
    named = 0.0
    for label, names in groups.items():
        t = sum(v for k, v in own.items() if k in names or any(k.endswith(n) for n in names))
        named += t
        print(f"  {label}: {t:.1f} s ({100 * t / total:.0f} %)")
    print(f"  the rest: {total - named:.1f} s ({100 * (total - named) / total:.0f} %)")
    st.sort_stats("tottime").print_stats(15)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Make the stored DEM reference of the packing model with rolling resistance (tests/data/dem_reference).

Usage: ``python scripts/rolling_reference.py [NAME]`` (default ``nevada-medium``; needs
``grainmech[dem]``). LAMMPS loads the shipped packing with the grains' rolling resistance
and re-settles it (its tangential and moment springs restart from zero); that re-settled
network (forces and contact moments) is stored, ``NAME-rolling-contacts.npz`` /
``-particles.npz``, with the rolling constants LAMMPS ran and the DEM model's constant-volume
cyclic simple shear at 1e-5 and 1e-4 (2 cycles of 16 steps, step and relax) from it, in
``NAME-rolling-cyclic.json``. ``tests/driver/test_packing_rolling_dem.py`` runs the packing
model on the stored network with the same constants and holds it to those loops.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "dem_reference"


def main(name: str = "nevada-medium") -> int:
    from grainmech.contact import HertzMindlin, RollingResistance
    from grainmech.driver.dem import DemPoint, DemSettings, dem_modulus_reduction
    from grainmech.io.dem import write_table
    from grainmech.packing import load_packing, packing_info

    net = load_packing(name)
    mat = packing_info(name)["material"]
    law = HertzMindlin(mat["shear_modulus_Pa"], mat["poisson"], float(net.radii.mean()), friction=mat["friction"])
    rolling = RollingResistance(mat["rolling_friction"])
    st = DemSettings()
    with DemPoint.start(net, law, st, rolling=rolling) as dp:
        settled, consts = dp.network, dp.rolling
    settled = dataclasses.replace(settled, source=f"{name} re-settled by LAMMPS with rolling resistance")
    write_table(settled, OUT / f"{name}-rolling-contacts.npz", OUT / f"{name}-rolling-particles.npz")
    t0 = time.perf_counter()
    mr = dem_modulus_reduction(settled, law, [1e-5, 1e-4], settings=st, constant="volume", n_cycles=2,
                               steps_per_cycle=16, rolling=rolling, workers=2)
    ref = {"packing": name, "material": mat, "settings": st.as_dict(), "constant": "volume", "n_cycles": 2,
           "steps_per_cycle": 16, "rolling_constants": dataclasses.asdict(consts),
           "amplitudes": mr.amplitude.tolist(), "G_Pa": mr.G.tolist(), "damping": mr.damping.tolist(),
           "G_max_Pa": float(mr.G_max), "seconds": time.perf_counter() - t0,
           "notes": list(mr.results[0].notes)}
    (OUT / f"{name}-rolling-cyclic.json").write_text(json.dumps(ref, indent=1) + "\n")
    print(json.dumps({k: ref[k] for k in ("amplitudes", "G_Pa", "damping", "G_max_Pa", "seconds")}))
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))

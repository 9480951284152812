"""Gmax of the shipped packings against the confining pressure (packing model).

Each shipped packing ('dense', 'medium', 'loose'; Mindlin-Deresiewicz with quartz, the
built-in default's law) is brought from its own 100 kPa to each pressure by
:meth:`grainmech.driver.packing.PackingPoint.at_stress`; ``Gmax`` is ``C_55`` of its
:attr:`~grainmech.driver.packing.PackingPoint.elastic_tangent` condensed with sigma_zz
free (drained simple shear, as ``packing_modulus_reduction`` at constant stress). Prints
one row per pressure as it is done, then the exponent ``n`` of ``G ∝ p^n`` fitted by least
squares on log G against log p over the pressures reached, beside Hardin & Richart's
(1963) 0.5. The "engine" column says what brought the packing there: the packing model's
stress path ("packing"), or the DEM model (LAMMPS) where that path stops or where
``--engine dem`` asks for it (``at_stress(engine=...)``, default ``auto``).

Run: ``nice -n 5 python benchmarks/packing_gmax_pressure.py PACKING [p_kPa ...]
[--engine auto|packing|dem]`` (default pressures 25 50 100 200 400 800).
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from grainmech.analysis import condensed_modulus
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver.packing import PackingOptions, PackingPoint, unbalanced_force_ratio
from grainmech.errors import GrainmechError
from grainmech.packing import QUARTZ, load_packing

DRAINED = [False, False, True, False, False, False]


def main() -> None:
    """Rows of one packing's Gmax at each pressure, then the fitted exponent."""
    args = list(sys.argv[1:])
    engine = "auto"
    if "--engine" in args:
        k = args.index("--engine")
        engine = args[k + 1]
        del args[k:k + 2]
    name = args[0] if args else "dense"
    kpa = [float(x) for x in args[1:]] or [25, 50, 100, 200, 400, 800]
    net = load_packing(name)
    law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()),
                             friction=QUARTZ.friction)
    opts = PackingOptions(law_backend="auto", tangent="none")
    p_ok, g_ok = [], []
    print("| packing | p kPa | Gmax MPa | engine | steps | unbalanced force ratio held (mean / largest) | s |")
    for p in kpa:
        t0 = time.perf_counter()
        try:
            pt = PackingPoint.from_network(net, law, options=opts)
            if abs(float(np.mean(pt.stress[:3])) / (1e3 * p) - 1) > 0.005:
                pt = PackingPoint.at_stress(net, law, 1e3 * p, options=opts, engine=engine)
            g = condensed_modulus(pt.elastic_tangent, 4, DRAINED)
        except GrainmechError as exc:
            print(f"| {name} | {p:g} | stops: {exc} | | | | {time.perf_counter() - t0:.0f} |", flush=True)
            continue
        pm = float(np.mean(pt.stress[:3]))
        p_ok.append(pm)
        g_ok.append(g)
        by_dem = any("by the DEM model" in n for n in pt.notes)
        note = next((n for n in pt.notes if n.startswith("brought from the input")), "")
        steps = note.split(" in ")[1].split(" stress")[0] if note else "servo" if by_dem else "0"
        dem_note = next((n for n in pt.notes if "by the DEM model (LAMMPS" in n), "")
        held = (note.split("unbalanced force ratio ")[1].split(" is held")[0] if note
                else dem_note.split("unbalanced force ratio ")[1].split(",")[0] + " (LAMMPS, mean)" if dem_note
                else f"{unbalanced_force_ratio(pt):.3g} / {unbalanced_force_ratio(pt, kind='max'):.3g}")
        what = "DEM" if by_dem else "packing" if note else "(own)"
        print(f"| {name} | {pm / 1e3:.4g} | {g / 1e6:.2f} | {what} | {steps} | {held} | "
              f"{time.perf_counter() - t0:.0f} |", flush=True)
    if len(p_ok) >= 2:
        n, _ = np.polyfit(np.log(p_ok), np.log(g_ok), 1)
        print(f"{name}: G ∝ p^n with n = {n:.3f} over {min(p_ok) / 1e3:.3g}-{max(p_ok) / 1e3:.3g} kPa "
              f"({len(p_ok)} pressures); Hardin & Richart (1963): 0.5")


if __name__ == "__main__":
    main()

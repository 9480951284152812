"""DEM reference runs (LAMMPS) on a shipped packing, stored for the tests that run without
LAMMPS (``tests/data/dem_reference/``).

Usage: ``python scripts/dem_reference.py [probes|cyclic|cyclic-stress] [PACKING]``
(needs ``grainmech[dem]``). ``probes``: strain probes of the six components (strain 1e-6,
:func:`grainmech.lammps.probes.strain_probes`); ``cyclic``: quasi-static cyclic simple
shear ``gamma_xz`` at constant volume by the DEM model
(:func:`grainmech.driver.dem.dem_modulus_reduction`), amplitudes 1e-5 and 1e-4, each from
the relaxed start state, two cycles (the last analysed), run three times (reference
settings, ramp rate halved, drag doubled) to show the answer does not depend on them;
``cyclic-stress``: the same at constant normal stress (reference settings only). See
docs/packings.md.

The stored ``dense-cyclic*.json`` were made by the earlier reference runner (cyclic
simple shear ``gamma_xy``, amplitudes in increasing order on the same packing, one cycle
after the first quarter); a rerun replaces them with the DEM model's series, which the
tests hold to the same tolerances (``G`` of the small amplitude against the probes'
shear modulus of the sheared plane).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from grainmech.contact import HertzMindlin
from grainmech.driver.dem import DemSettings, dem_modulus_reduction
from grainmech.io.results import write_json
from grainmech.lammps.probes import strain_probes
from grainmech.packing import QUARTZ, load_packing, packing_info

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "dem_reference"


def main(argv: list[str]) -> int:
    what = argv[0] if argv else "probes"
    name = argv[1] if len(argv) > 1 else "dense"
    net = load_packing(name)
    info = packing_info(name)
    say = lambda m: print(m, file=sys.stderr, flush=True)  # noqa: E731
    base = {"packing": name, "void_ratio": info["void_ratio"], "material": info["material"],
            "model": "LAMMPS pair_style granular hertz/material + tangential mindlin NULL (k_t = 8 G* a), "
                     "Coulomb cap, damping coeff_restitution 0.1; fix viscous + viscous/sphere drags"}
    if what == "probes":
        r = strain_probes(net, QUARTZ, progress=say)
        write_json(OUT / f"{name}-probes.json", {
            **base, "C_Pa": r.C.tolist(), "order": ["xx", "yy", "zz", "yz", "xz", "xy"],
            "stress0_Pa": r.stress0.tolist(), "unbalanced": r.unbalanced.tolist(), "settings": r.settings,
            "seconds": r.seconds, "note": "C[:, k] = change of the Love-Weber stress (compression positive) over "
                                          "the strain of component k, at equilibrium"})
        from grainmech.io.dem import write_table
        write_table(r.network, OUT / f"{name}-probes-contacts.npz", OUT / f"{name}-probes-particles.npz")
        return 0
    runs = {"reference": {}, "half_rate": {"ramp_steps": 2000}, "double_drag": {"viscous": 0.02}}
    constant, suffix = "volume", "cyclic"
    if what == "cyclic-stress":
        runs = {"reference": {}}
        constant, suffix = "stress", "cyclic-stress"
    amps = [1e-5, 1e-4]
    radius = float(net.require_radii("the reference runs").mean())
    law = HertzMindlin(QUARTZ.shear_modulus, QUARTZ.poisson, radius, friction=QUARTZ.friction)
    out = {**base, "amplitudes": amps, "shear": "xz", "runs": {}}
    for label, kw in runs.items():
        say(f"cyclic simple shear (DEM model), {label} {kw}")
        settings = DemSettings(**{"ramp_steps": 1000, **kw})
        t0 = time.perf_counter()
        mr = dem_modulus_reduction(net, law, amps, n_cycles=2, steps_per_cycle=16, constant=constant,
                                   settings=settings)
        loops = [{"gamma": r.strain[:, 4].tolist(), "tau_Pa": (r.stress[:, 4] - r.stress[0, 4]).tolist()}
                 for r in mr.results]
        out["runs"][label] = {"G_Pa": mr.G.tolist(), "damping": mr.damping.tolist(), "G_max_Pa": mr.G_max,
                              "settings": {**settings.as_dict(), "constant": constant, "n_cycles": 2,
                                           "steps_per_cycle": 16,
                                           "volume_change_max": max(float(abs(r.strain[:, :3].sum(axis=1)).max())
                                                                    for r in mr.results)},
                              "seconds": time.perf_counter() - t0, "loops": loops}
        write_json(OUT / f"{name}-{suffix}.json", out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

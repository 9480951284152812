"""DEM reference runs (LAMMPS) on a shipped packing, stored for the tests that run without
LAMMPS (``tests/data/dem_reference/``).

Usage: ``python scripts/dem_reference.py [probes|cyclic|cyclic-stress] [PACKING]``
(needs ``grainmech[dem]``). ``probes``: strain probes of the six components (strain 1e-6);
``cyclic``: quasi-static cyclic simple shear at constant volume, amplitudes 1e-5 and 1e-4,
one cycle each after the first quarter, run three times (reference settings, ramp rate
halved, drag doubled) to show the answer does not depend on them; ``cyclic-stress``: the
same at constant normal stress (reference settings only). See docs/packing.md.
"""

from __future__ import annotations

import sys
from pathlib import Path

from grainmech.io.results import write_json
from grainmech.packing import QUARTZ, load_packing, packing_info
from grainmech.packing.reference import cyclic_simple_shear, strain_probes

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
    suffix = "cyclic"
    if what == "cyclic-stress":
        runs = {"reference": {"constant": "stress"}}
        suffix = "cyclic-stress"
    amps = [1e-5, 1e-4]
    out = {**base, "amplitudes": amps, "runs": {}}
    for label, kw in runs.items():
        say(f"cyclic simple shear, {label} {kw}")
        r = cyclic_simple_shear(net, QUARTZ, amps, progress=say, **kw)
        out["runs"][label] = {"G_Pa": r.G.tolist(), "damping": r.damping.tolist(), "settings": r.settings,
                              "seconds": r.seconds,
                              "loops": [{"gamma": g.tolist(), "tau_Pa": t.tolist()} for g, t in r.loops]}
        write_json(OUT / f"{name}-{suffix}.json", out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""Plot of the packing driver against LAMMPS on the same packing, for docs/models/packing.md.

The reference is ``tests/data/dem_reference/dense-cyclic.json``: LAMMPS (``pair_style
granular hertz/material`` + ``tangential mindlin``, quasi-static) on the re-settled
'dense' 2000-grain packing of ``dense-probes-*.npz``, constant-volume cyclic simple shear
γ_xy at 1e-5 and 1e-4 (a ramp of four increments to +γ, then one cycle of sixteen). The
packing driver runs the same strain path with ``HertzMindlin`` on the same network; its
loops are stored next to the figure (``.npz``) so that the figure can be redrawn without
running the driver again (``--from``).

    python benchmarks/plot_dem_comparison.py [docs/packing-dem-comparison.png] [--from FILE.npz]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REF = ROOT / "tests" / "data" / "dem_reference"
K_XY = 5  # library order xx yy zz yz xz xy


def run_driver(amplitudes: list[float]) -> dict:
    """Strain path of the DEM run for each amplitude; loops, G, D, wall time."""
    from grainmech.analysis import loop_properties
    from grainmech.contact import HertzMindlin
    from grainmech.driver import concatenate, segment
    from grainmech.driver.packing import PackingOptions, PackingPoint, run_packing
    from grainmech.io.dem import read_network

    m = json.loads((REF / "dense-cyclic.json").read_text())["material"]
    net = read_network(REF / "dense-probes-contacts.npz", REF / "dense-probes-particles.npz")
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    opts = PackingOptions(law_backend="auto", tangent="none")
    pt = PackingPoint.from_network(net, law, options=opts)
    out: dict = {}
    for k, a in enumerate(amplitudes):
        e = np.zeros(6)
        e[K_XY] = a / 4
        path = concatenate([segment("EEEEEE", e, 1)] * 4 + [segment("EEEEEE", -e, 1)] * 8
                           + [segment("EEEEEE", e, 1)] * 8)
        t = time.perf_counter()
        r = run_packing(pt, path, opts)
        wall = time.perf_counter() - t
        n = len(r.strain)
        out[f"gamma{k}"] = r.strain[:, K_XY]
        out[f"tau{k}"] = r.stress[:, K_XY]
        out[f"wall{k}"] = wall
        out[f"success{k}"] = r.success
        if r.success:
            lp = loop_properties(r.strain[4:, K_XY], r.stress[4:, K_XY])
            out[f"G{k}"], out[f"D{k}"] = lp.secant_modulus, lp.damping
        print(f"gamma {a:g}: {r.message} ({n - 1} steps, {wall:.1f} s)")
    out["amplitudes"] = np.array(amplitudes)
    return out


def main(argv: list[str]) -> None:
    """Run the driver (or read ``--from``) and draw both amplitudes' loops against LAMMPS'."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    args = list(argv)
    cache = None
    if "--from" in args:
        i = args.index("--from")
        cache = args[i + 1]
        del args[i:i + 2]
    out = Path(args[0]) if args else ROOT / "docs" / "packing-dem-comparison.png"
    ref = json.loads((REF / "dense-cyclic.json").read_text())
    amps = [float(a) for a in ref["amplitudes"]]
    if cache:
        data = dict(np.load(cache))
    else:
        data = run_driver(amps)
        np.savez(out.with_suffix(".npz"), **data)
    runs = ref["runs"]["reference"]
    fig, axes = plt.subplots(1, len(amps), figsize=(5 * len(amps), 4.2))
    for k, (ax, a) in enumerate(zip(np.atleast_1d(axes), amps, strict=True)):
        loop = runs["loops"][k]
        g_dem, d_dem = runs["G_Pa"][k], runs["damping"][k]
        ax.plot(np.array(loop["gamma"]) * 1e6, np.array(loop["tau_Pa"]) / 1e3, "o-", ms=4, color="k",
                label=f"LAMMPS: G = {g_dem / 1e6:.1f} MPa, D = {100 * d_dem:.2f} %")
        lab = "packing driver"
        if bool(data[f"success{k}"]):
            lab += f": G = {float(data[f'G{k}']) / 1e6:.1f} MPa, D = {100 * float(data[f'D{k}']):.2f} %"
        else:
            lab += ": stopped (see docs)"
        # the packing starts with a shear stress of its own (tau_xy ~ 0.7 kPa); the DEM loops
        # are stored as the change from the start, so the driver's are drawn the same way
        tau = np.asarray(data[f"tau{k}"])
        ax.plot(np.asarray(data[f"gamma{k}"]) * 1e6, (tau - tau[0]) / 1e3, "s--", ms=3, color="C1",
                label=lab)
        ax.set_xlabel(r"$\gamma_{xy}$ [$10^{-6}$]")
        ax.set_ylabel(r"$\tau_{xy} - \tau_{xy}(0)$ [kPa]")
        ax.set_title(f"constant-volume cyclic simple shear, γ = {a:g}")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    fig.suptitle("2000-grain 'dense' packing, Hertz–Mindlin contacts (μ = 0.5): LAMMPS vs packing driver",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1:])

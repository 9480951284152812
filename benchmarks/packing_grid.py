"""The packing model's grid on the shipped packings: which runs complete, in equilibrium.

For each shipped packing ('dense', 'medium', 'loose'; MindlinDeresiewicz or HertzMindlin
with quartz, the built-in default's law), amplitude and control (constant stress or
constant volume), 2 cycles x 40 steps of cyclic simple shear from the packing at its own
100 kPa (:func:`grainmech.driver.packing.run_packing`). Prints one row per run: whether it
completed, where and why it stopped, the largest equilibrium residual of the accepted
steps (max-based unbalanced force ratio, ``PackingResult.residual``; the bar is 0.05),
G/Gmax and damping of the last cycle, the change of mean stress over the two cycles
(``p_end / p_0 - 1``; at constant volume minus the pore-pressure ratio, the column the DEM
campaign ``benchmarks/dem_campaign.py`` prints for the same cells), the volumetric strain
over them (compression positive: contraction at constant stress), the largest grain
displacement fluctuation (``PackingResult.fluctuation``, in radii), the wall time and its
ratio to the dgemm yardstick.

``--perturb`` adds, for each completed run, the same run with the input positions moved by
1e-12 of a radius (random directions) and gives the difference in the loop's G/Gmax and,
in brackets, the largest difference along the loop (the secant modulus at every step of
the last cycle over Gmax; ill-conditioned near the zero crossings of the strain).

Run: ``nice -n 5 python benchmarks/packing_grid.py [--packings dense,medium,loose]
[--amplitudes 1e-6,1e-5,1e-4,3e-4] [--controls stress,volume] [--laws md,hm] [--perturb]
[--threads] [--accept-unbalanced X] [--rest-step X] [--set KEY=VALUE]``. ``--threads`` repeats each completed run with PARDISO on every core
(``PackingOptions.reproducible = False``) and gives the largest difference in G/Gmax.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from _yardstick import dgemm_seconds

from grainmech.analysis import condensed_modulus, loop_properties
from grainmech.contact import HertzMindlin, MindlinDeresiewicz
from grainmech.driver import cyclic_simple_shear
from grainmech.driver.packing import PackingOptions, PackingPoint, run_packing
from grainmech.network import ContactNetwork
from grainmech.outcomes import run_mean_stress_change
from grainmech.packing import QUARTZ, load_packing


def law_of(name: str, radius: float):
    """The quartz contact law ``md`` (Mindlin-Deresiewicz) or ``hm`` (Hertz-Mindlin), friction 0.5."""
    cls = MindlinDeresiewicz if name == "md" else HertzMindlin
    return cls(QUARTZ.shear_modulus, QUARTZ.poisson, radius, friction=QUARTZ.friction)


def perturbed(net: ContactNetwork, eps: float, seed: int = 0) -> ContactNetwork:
    """``net`` with every centre moved by ``eps`` of its radius in a random direction (branches follow)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=net.positions.shape)
    d *= (eps * net.radii / np.linalg.norm(d, axis=1))[:, None]
    pos = net.positions + d
    br = net.branch + d[net.j] - d[net.i]
    return ContactNetwork(net.ids, pos, net.radii, net.box, net.i, net.j, net.force, br, net.overlap,
                          source=f"{net.source}, perturbed {eps:g} R")


def run_one(net: ContactNetwork, law, amp: float, constant: str, reproducible: bool = True, **options):
    """``(result, G/Gmax curve of the last cycle, G/Gmax, damping, seconds)`` of one run (also when it stopped).

    ``reproducible=False``: PARDISO factors and solves on every core (2 threads here)
    instead of one (:class:`PackingOptions`).
    """
    opts = PackingOptions(law_backend="auto", tangent="none", reproducible=reproducible, **options)
    t0 = time.perf_counter()
    pt = PackingPoint.from_network(net, law, options=opts)
    path = cyclic_simple_shear(amp, 2, 40, constant=constant)
    res = run_packing(pt, path, opts)
    sec = time.perf_counter() - t0
    gmax = condensed_modulus(pt.elastic_tangent, 4, path.stress_control[0])
    if not res.success:
        return res, None, np.nan, np.nan, sec
    g, s = res.strain[:, 4], res.stress[:, 4]
    last = slice(len(g) - 41, len(g))
    lp = loop_properties(g[last], s[last])
    with np.errstate(divide="ignore", invalid="ignore"):
        curve = (s[last] - s[0]) / (g[last] - g[0]) / gmax
    return res, curve, lp.secant_modulus / gmax, lp.damping, sec


def main() -> None:
    """Run the grid given on the command line and print its table."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--packings", default="dense,medium,loose")
    ap.add_argument("--amplitudes", default="1e-6,1e-5,1e-4,3e-4")
    ap.add_argument("--controls", default="stress,volume")
    ap.add_argument("--laws", default="md,hm")
    ap.add_argument("--perturb", action="store_true")
    ap.add_argument("--threads", action="store_true", help="also run each completed cell on every core")
    ap.add_argument("--accept-unbalanced", type=float, default=None,
                    help="PackingOptions.accept_unbalanced (default: the option's default)")
    ap.add_argument("--rest-step", type=float, default=None,
                    help="PackingOptions.rest_step (default: the option's default)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="another PackingOptions field (a number), e.g. settle=0 (repeatable)")
    a = ap.parse_args()
    extra = {} if a.accept_unbalanced is None else {"accept_unbalanced": a.accept_unbalanced}
    for kv in a.set:
        k, v = kv.split("=", 1)
        extra[k] = float(v)
    if a.rest_step is not None:
        extra["rest_step"] = a.rest_step
    dg = dgemm_seconds()
    print(f"dgemm yardstick (n = 2048): {dg:.3f} s", flush=True)
    print("| packing | law | control | γ | result | max residual | G/Gmax | D % | Δp/p0 | Δε_v | max fluctuation [R] | s "
          "| dgemm | perturbed 1e-12 R: ΔG/Gmax (along the loop) | all cores: ΔG/Gmax (along the loop) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    for pk in a.packings.split(","):
        net = load_packing(pk)
        for lw in a.laws.split(","):
            law = law_of(lw, float(net.radii.mean()))
            for ctl in a.controls.split(","):
                for amp in (float(x) for x in a.amplitudes.split(",")):
                    res, curve, gr, d, sec = run_one(net, law, amp, ctl, **extra)
                    what = "completed" if res.success else res.message
                    pert = thr = ""
                    if a.perturb and res.success:
                        r2, c2, g2, *_ = run_one(perturbed(net, 1e-12), law, amp, ctl, **extra)
                        pert = (f"{abs(g2 - gr):.1e} ({np.nanmax(np.abs(c2 - curve)):.1e})" if r2.success
                                else f"stops: {r2.message}")
                    if a.threads and res.success:
                        r3, c3, g3, *_ = run_one(net, law, amp, ctl, reproducible=False, **extra)
                        thr = (f"{abs(g3 - gr):.1e} ({np.nanmax(np.abs(c3 - curve)):.1e})" if r3.success
                               else f"stops: {r3.message}")
                    dp = run_mean_stress_change(res)
                    ev = float(np.sum(res.strain[-1, :3] - res.strain[0, :3]))
                    print(f"| {pk} | {lw} | {ctl} | {amp:g} | {what} | {res.residual.max():.3g} | {gr:.4f} | "
                          f"{100 * d:.3f} | {dp:+.4f} | {ev:+.2e} | {res.fluctuation.max():.3g} | {sec:.1f} | {sec / dg:.0f} "
                          f"| {pert} | {thr} |", flush=True)


if __name__ == "__main__":
    main()

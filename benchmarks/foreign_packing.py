"""A packing from another DEM code (LIGGGHTS) through ``grainmech run``, against that code's own cyclic run.

Issues 28 and 29, "How it will be checked": a loose frictional packing made by LIGGGHTS
(``examples/liggghts/pack.in``; 2000 quartz spheres, Hertz-Mindlin with history, friction
0.5, isotropic ~100 kPa), read as a LIGGGHTS dump (``tests/data/liggghts_loose/``), is
cycled at constant volume at 1e-5 and 1e-4 by the packing and DEM models of
:func:`grainmech.jobs.compute_run` (a config with ``[model] network = FILE``, Hertz-Mindlin
quartz 29 GPa / 0.15 / friction 0.5, ``[initial] pressure`` = the packing's own Love-Weber
mean stress, 2 sinusoidal cycles x 16 steps) and compared with LIGGGHTS' own constant-volume
cycles (``examples/liggghts/cyclic.in``; ``liggghts_cyclic.csv``). Targets: secant G within
10 % at 1e-5; within 15 % (packing model, issue 29) and 20 % (DEM model, issue 28) at 1e-4.

The test is the one LIGGGHTS can run: LIGGGHTS 3.8 cannot tilt a periodic granular cell
(no ghost atoms in a triclinic box), so its cycles are pure shear at constant volume,
``eps_xx = -eps_zz = gamma/2`` (tension positive), i.e. simple shear of amplitude gamma in
the axes rotated 45 degrees about y. grainmech runs the same path (``kind = "path"``, one
cycles segment, control ``EEEEEE``, direction ``[-1/2, 0, 1/2, 0, 0, 0]`` compression
positive: x extends first, as in LIGGGHTS), and the loop is ``gamma = eps_zz - eps_xx``,
``tau = (sigma_zz - sigma_xx)/2`` (compression positive; the same numbers as LIGGGHTS'
tension-positive ones), secant G and damping of the last cycle by
:func:`grainmech.analysis.loop_properties`.

Each (model, amplitude) is a separate run, so its wall time is its own. For context it
prints the network's small-strain moduli for the same shear: the affine one (the seed's
hypothesis, an upper bound; ``[model] method = "affine"`` runs the analytical fabric of
``[packing]``, not a network, so it is evaluated on the network directly) and the relaxed
one. Prints a markdown table. Usage: ``python benchmarks/foreign_packing.py [--amplitudes 1e-5 1e-4]
[--methods affine packing dem] [--steps 16] [--data tests/data/liggghts_medium] [--max-fluctuation 0.2]`` (the DEM model
needs ``grainmech[dem]``; on 2 cores the whole table takes tens of minutes, most of it DEM at 1e-4).
"""

from __future__ import annotations

import argparse
import datetime
import time
from pathlib import Path

import numpy as np

from grainmech.analysis import loop_properties
from grainmech.io.dem import read_network
from grainmech.jobs import compute_run
from grainmech.network import affine_stiffness, contact_stiffnesses, network_stress, relaxed_stiffness

DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "liggghts_loose"
TARGET = {("packing", 1e-5): 0.10, ("dem", 1e-5): 0.10, ("packing", 1e-4): 0.15, ("dem", 1e-4): 0.20}


def liggghts_reference(path: Path = DATA / "liggghts_cyclic.csv") -> dict[float, dict[str, float]]:
    """LIGGGHTS' own result per amplitude: the columns of liggghts_cyclic.csv (G, damping of both cycles, p)."""
    d = np.genfromtxt([ln for ln in path.read_text().splitlines() if not ln.startswith("#")], delimiter=",",
                      names=True)
    return {float(row["amplitude"]): {k: float(row[k]) for k in d.dtype.names} for row in np.atleast_1d(d)}


#: the cycled strain direction (xx, yy, zz, yz, xz, xy), compression positive: pure shear
#: eps_zz = -eps_xx = gamma/2, x extending first (as LIGGGHTS' cyclic.in)
DIRECTION = [-0.5, 0.0, 0.5, 0.0, 0.0, 0.0]


def config(method: str, amplitude: float, pressure: float, steps: int, n_cycles: int = 2,
           data: Path = DATA, packing_options: dict | None = None) -> dict:
    """The run config of one model at one amplitude on a shipped LIGGGHTS packing (folder ``data``).

    ``packing_options`` is the packing model's ``[model.packing_options]`` (its small-strain bounds).
    """
    model: dict = {"method": method, "network": str(data / "contacts.dump.gz"),
                   "particles": str(data / "particles.dump.gz"), "format": "liggghts"}
    if method == "dem":
        model["dem"] = {"workers": 1}
    if method == "packing" and packing_options:
        model["packing_options"] = dict(packing_options)
    return {"contacts": {"law": "hertz-mindlin", "shear_modulus": "29 GPa", "poisson": 0.15, "friction": 0.5},
            "initial": {"pressure": f"{pressure:.6g} Pa"},
            "model": model,
            "test": {"kind": "path", "segments": [
                {"control": "EEEEEE", "direction": DIRECTION, "amplitude": amplitude, "n_cycles": n_cycles,
                 "steps_per_cycle": steps, "waveform": "sine"}]}}


def virgin(strain: np.ndarray, stress: np.ndarray, steps: int) -> float:
    """Secant modulus of the virgin quarter, gamma = 0 to the first peak (step ``steps/4``) [Pa]; NaN if not reached."""
    k = steps // 4
    if strain.shape[0] <= k:
        return float("nan")
    gamma = strain[:, 2] - strain[:, 0]
    tau = 0.5 * (stress[:, 2] - stress[:, 0])
    return float((tau[k] - tau[0]) / (gamma[k] - gamma[0]))


def loops(strain: np.ndarray, stress: np.ndarray, steps: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """(secant G [Pa], damping [-]) of the first and of the last cycle of a pure-shear path of ``steps`` per cycle."""
    gamma = strain[:, 2] - strain[:, 0]
    tau = 0.5 * (stress[:, 2] - stress[:, 0])
    out = []
    for s in (slice(0, steps + 1), slice(strain.shape[0] - steps - 1, None)):
        lp = loop_properties(gamma[s], tau[s])
        out.append((lp.secant_modulus, lp.damping))
    return out[0], out[1]


def pure_shear_modulus(C: np.ndarray) -> float:
    """Shear modulus of the pure shear eps_xx = -eps_zz (Voigt C, engineering strains) [Pa].

    ``tau = (sigma_xx - sigma_zz)/2``, ``gamma = eps_xx - eps_zz``: ``G = (C11 - 2 C13 + C33)/4``
    (``C55`` of the tensor rotated 45 degrees about y).
    """
    return float(C[0, 0] - 2 * C[0, 2] + C[2, 2]) / 4


def small_strain_context(net) -> tuple[float, float]:
    """Affine (seed Eq. 2.26) and relaxed (every grain in equilibrium) no-slip Hertz-Mindlin moduli [Pa].

    Contact stiffnesses from each contact's overlap (seed Eq. 3.7, 3.11), quartz 29 GPa / 0.15
    (``docs/networks.md``, "Contact stiffness").
    """
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15, source="overlap")
    return (pure_shear_modulus(affine_stiffness(net, kn, ks)),
            pure_shear_modulus(relaxed_stiffness(net, kn, ks).C_relaxed))


def _g(x: float) -> str:
    """A modulus [Pa] in MPa, with enough digits for a liquefied packing's."""
    return f"{x / 1e6:.2f}" if abs(x) >= 1e5 else f"{x / 1e6:.2g}"


def _d(x: float) -> str:
    """A damping ratio in percent; a loop without strength (liquefied) has none."""
    return f"{100 * x:.2f} %" if abs(x) < 1 else "— (no loop)"


def main() -> int:
    """Run every (model, amplitude) and print the table; exit status 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--amplitudes", type=float, nargs="+", default=[1e-5, 1e-4])
    ap.add_argument("--methods", nargs="+", default=["packing", "dem"])
    ap.add_argument("--steps", type=int, default=16, help="steps per cycle (multiple of 4)")
    ap.add_argument("--data", type=Path, default=DATA,
                    help="folder of the packing's dumps and liggghts_cyclic.csv (default tests/data/liggghts_loose)")
    ap.add_argument("--max-fluctuation", type=float, default=None,
                    help="the packing model's [model.packing_options] max_fluctuation (default: its own, 0.05)")
    a = ap.parse_args()
    popts = {} if a.max_fluctuation is None else {"max_fluctuation": a.max_fluctuation}
    csv = a.data / "liggghts_cyclic.csv"
    ref = liggghts_reference(csv) if csv.exists() else {}  # the grainmech rows can run before LIGGGHTS' cycles
    net = read_network(a.data / "contacts.dump.gz", a.data / "particles.dump.gz")
    p0 = network_stress(net).mean
    g_aff, g_rel = small_strain_context(net)
    print(f"{datetime.date.today()}: LIGGGHTS packing ({net.n_particles} grains, e = {net.void_ratio:.3f}, "
          f"p = {p0 / 1e3:.2f} kPa), constant-volume cyclic pure shear (simple shear in axes at 45 deg), "
          f"2 sine cycles x {a.steps} steps, "
          "Hertz-Mindlin quartz 29 GPa / 0.15 / mu 0.5", flush=True)
    print(f"Small-strain moduli of the network for this pure shear: affine (seed Eq. 2.26) {g_aff / 1e6:.2f} MPa, "
          f"relaxed no-slip (every grain in equilibrium) {g_rel / 1e6:.2f} MPa", flush=True)
    print("| amplitude | model | result | G last cycle [MPa] | vs LIGGGHTS | target | damping last cycle | "
          "G / damping first cycle | G virgin quarter | p end / p0 | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for amp in a.amplitudes:
        r = ref.get(amp)
        if r is not None:
            print(f"| {amp:g} | LIGGGHTS (cyclic.in) | completed | {_g(r['G_secant_Pa'])} | — | — | "
                  f"{_d(r['damping'])} | {_g(r['G_secant_cycle1_Pa'])} / {_d(r['damping_cycle1'])} | "
                  f"{_g(r['G_virgin_Pa'])} | {r['p_end_Pa'] / r['p_start_Pa']:.3g} | — |", flush=True)
        for m in a.methods:
            t0 = time.perf_counter()
            out = compute_run(config(m, amp, p0, a.steps, data=a.data, packing_options=popts))
            wall = time.perf_counter() - t0
            tgt = TARGET.get((m, amp))
            tgt_s = f"{100 * tgt:.0f} %" if tgt else "—"
            res = out.results[0] if out.results else None
            gv = virgin(np.asarray(res.strain), np.asarray(res.stress), a.steps) if res is not None else float("nan")
            if res is not None and res.success:
                (g1, d1), (g, d) = loops(np.asarray(res.strain), np.asarray(res.stress), a.steps)
                pr = float(np.mean(res.stress[-1, :3]) / np.mean(res.stress[0, :3]))
                if r is not None and r["p_end_Pa"] < 0.5 * r["p_start_Pa"]:
                    vs = "— (LIGGGHTS liquefied)"
                elif r is not None:
                    dg = g / r["G_secant_Pa"] - 1
                    vs = f"{100 * dg:+.1f} %" + ("" if tgt is None else (" (met)" if abs(dg) <= tgt else " (not met)"))
                else:
                    vs = "—"
                print(f"| {amp:g} | {m} | completed | {_g(g)} | {vs} | {tgt_s} | {_d(d)} | {_g(g1)} / {_d(d1)} | "
                      f"{_g(gv)} | {pr:.3g} | {wall:.0f} |", flush=True)
            else:
                why = " ".join(str(out.message).split())
                print(f"| {amp:g} | {m} | stopped: {why} | — | — | {tgt_s} | — | — | {_g(gv)} | — | {wall:.0f} |",
                      flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

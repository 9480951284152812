"""Benchmark of LAMMPS' spatial sort of the atoms (``grainmech.packing.prepare.SORT_MIN_GRAINS``).

A packing made from a random gas (``grainmech pack``) or read from another code lists its
grains in an order unrelated to where they are, so the neighbours of a grain lie far apart
in memory. For each tiling of the shipped 'dense' packing (``--tiles 1x1x1,2x2x1,3x3x2,5x5x2``
= 2000, 8000, 36 000, 100 000 grains) this shuffles the grains' rows, loads them into one
LAMMPS on one thread (:func:`grainmech.lammps.session.load_network`, viscous drags, time
step 0.1 of the critical one), and times a run of ``--steps`` time steps unsorted
(``atom_modify sort 0 0``), then sorted at every reneighbouring (``atom_modify sort 1
0.0``), then unsorted again (the order the sort left). Prints time steps per CPU second and
grain-steps per CPU second for each, and the ratio sorted / unsorted. Nothing is written.

Usage: ``python benchmarks/bench_lammps_sort.py [--tiles 1x1x1,5x5x2] [--steps 200]``
(needs ``grainmech[dem]``; 1e5 grains take about a minute).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import sys
import time

import numpy as np

from grainmech.lammps.engine import Lammps
from grainmech.lammps.session import load_network
from grainmech.network.builders import tile_network
from grainmech.packing import QUARTZ, load_packing


def shuffled(net, seed: int = 0):  # noqa: ANN001, ANN201
    """The network with its grains' rows in a random order (contacts renumbered)."""
    perm = np.random.default_rng(seed).permutation(net.n_particles)
    inv = np.empty_like(perm)
    inv[perm] = np.arange(perm.size)
    return dataclasses.replace(net, ids=net.ids[perm], positions=net.positions[perm], radii=net.radii[perm],
                               i=inv[net.i], j=inv[net.j])


def main(argv: list[str]) -> int:
    """Time each tiling unsorted, sorted and unsorted again; print one line each."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tiles", default="1x1x1,2x2x1,3x3x2,5x5x2")
    ap.add_argument("--steps", type=int, default=200)
    a = ap.parse_args(argv)
    print(f"{datetime.date.today()}: LAMMPS atom sort, 'dense' tiled and shuffled, one thread, {a.steps} time steps")
    for spec in a.tiles.split(","):
        tiles = [int(x) for x in spec.split("x")]
        net = load_packing("dense")
        if tiles != [1, 1, 1]:
            net = tile_network(net, tiles)
        net = shuffled(net)
        rates = {}
        with Lammps(threads=1) as lmp:
            load_network(lmp, net, QUARTZ, viscous=0.3, safety=0.1)
            lmp.command("run 10")
            for label, cmd in (("unsorted", "atom_modify sort 0 0.0"), ("sorted", "atom_modify sort 1 0.0"),
                               ("unsorted after a sort", "atom_modify sort 0 0.0")):
                lmp.command(cmd)
                lmp.command("run 1")
                c0 = time.process_time()
                lmp.command(f"run {a.steps}")
                rates[label] = a.steps / (time.process_time() - c0)
        print(f"{net.n_particles:7d} grains: " + "; ".join(
            f"{k} {v:.1f} steps/s ({net.n_particles * v:.3g} grain-steps/s)" for k, v in rates.items())
            + f"; sorted/unsorted {rates['sorted'] / rates['unsorted']:.2f}x", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

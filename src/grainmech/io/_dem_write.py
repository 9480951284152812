"""Writers of contact networks: :func:`write_liggghts`, :func:`write_table` (re-exported by :mod:`grainmech.io.dem`).

The inverse of the readers of :mod:`grainmech.io.dem`, in their sign conventions (the
LIGGGHTS dump holds the force on the first particle, the table the force on ``id2``);
files are written atomically (:func:`grainmech.io.results.atomic_write`), in chunks of
:data:`grainmech.io._dem_blocks.CHUNK_LINES` lines.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.io import _dem_blocks
from grainmech.io._dem_dump import LIGGGHTS_KEYWORD_COLUMNS
from grainmech.io.results import atomic_write, write_npz
from grainmech.network import Box, ContactNetwork


def _atomic_write_text(path: Path, write) -> None:
    atomic_write(Path(path), write, newline="\n")


def _box_header(box: Box) -> list[str]:
    c = box.cell
    flags = " ".join("pp" if p else "ff" for p in box.periodic)
    if np.allclose(c, np.diag(np.diag(c))):
        lo, hi = box.origin, box.origin + np.diag(c)
        return [f"ITEM: BOX BOUNDS {flags}"] + [f"{lo[k]:.17g} {hi[k]:.17g}" for k in range(3)]
    if abs(c[0, 1]) + abs(c[0, 2]) + abs(c[1, 2]) > 0:
        raise GrainmechError("LAMMPS boxes need a = (lx,0,0), b = (xy,ly,0), c = (xz,yz,lz)")
    xlo, ylo, zlo = box.origin
    lx, ly, lz = c[0, 0], c[1, 1], c[2, 2]
    xy, xz, yz = c[1, 0], c[2, 0], c[2, 1]
    xlb = xlo + min(0.0, xy, xz, xy + xz)
    xhb = xlo + lx + max(0.0, xy, xz, xy + xz)
    ylb = ylo + min(0.0, yz)
    yhb = ylo + ly + max(0.0, yz)
    return [f"ITEM: BOX BOUNDS xy xz yz {flags}", f"{xlb:.17g} {xhb:.17g} {xy:.17g}",
            f"{ylb:.17g} {yhb:.17g} {xz:.17g}", f"{zlo:.17g} {zlo + lz:.17g} {yz:.17g}"]


def write_liggghts(net: ContactNetwork, contacts: str | os.PathLike, particles: str | os.PathLike, *,
                   keywords: Sequence[str] = ("pos", "id", "force", "contactPoint", "delta"),
                   timestep: int = 0, compute_id: str = "fc") -> None:
    """Write a network as LIGGGHTS dumps (``dump local`` with ``c_ID[k]`` headers + ``dump custom``).

    The force is written as LIGGGHTS reports it: the force on the first particle
    (``-f``); ``pos`` holds both centres inside the box (as LIGGGHTS remaps them; the
    reader takes the minimum image). Supports the keywords ``pos id force contactPoint delta``,
    written in the compute's fixed order.
    """
    C = net.n_contacts
    blocks = []
    x1 = net.positions[net.i]
    for w in [k for k in LIGGGHTS_KEYWORD_COLUMNS if k in keywords]:
        if w == "pos":  # both centres as stored (LIGGGHTS remaps them into the box)
            blocks.append(np.hstack([x1, net.positions[net.j]]))
        elif w == "id":
            per = (np.abs(net.positions[net.j] - (x1 + net.branch)).max(axis=1) > 1e-12).astype(float)
            blocks.append(np.stack([net.ids[net.i], net.ids[net.j], per], 1).astype(float))
        elif w == "force":
            blocks.append(-net.force)
        elif w == "contactPoint":
            if net.contact_point is not None:
                blocks.append(net.contact_point)
            else:
                # LIGGGHTS for spheres: (x_i r_j + x_j r_i) / (r_i + r_j), x_j the ghost image
                if net.radii is not None:
                    t = net.radii[net.i] / (net.radii[net.i] + net.radii[net.j])
                else:
                    t = np.full(C, 0.5)
                blocks.append(x1 + t[:, None] * net.branch)
        elif w == "delta":
            if net.overlap is not None:
                blocks.append(net.overlap[:, None])
            elif net.radii is not None:
                blocks.append((net.radii[net.i] + net.radii[net.j] - net.branch_length)[:, None])
            else:
                blocks.append(np.zeros((C, 1)))
        else:
            raise GrainmechError(f"write_liggghts: unsupported keyword {w!r}")
    data = np.hstack(blocks) if blocks else np.zeros((C, 0))
    names = " ".join(f"c_{compute_id}[{k + 1}]" for k in range(data.shape[1]))

    def wc(fh):
        fh.write(f"ITEM: TIMESTEP\n{timestep}\nITEM: NUMBER OF ENTRIES\n{C}\n")
        fh.write("\n".join(_box_header(net.box)) + "\n")
        fh.write(f"ITEM: ENTRIES {names}\n")
        for s in range(0, C, _dem_blocks.CHUNK_LINES):
            np.savetxt(fh, data[s:s + _dem_blocks.CHUNK_LINES], fmt="%.17g")

    _atomic_write_text(Path(contacts), wc)
    P = net.n_particles
    r = net.radii if net.radii is not None else np.full(P, np.nan)
    if not np.all(np.isfinite(r)):
        raise GrainmechError("write_liggghts: the network has no radii")

    def wp(fh):
        fh.write(f"ITEM: TIMESTEP\n{timestep}\nITEM: NUMBER OF ATOMS\n{P}\n")
        fh.write("\n".join(_box_header(net.box)) + "\n")
        fh.write("ITEM: ATOMS id type x y z radius\n")
        arr = np.column_stack([net.ids, np.ones(P), net.positions, r])
        np.savetxt(fh, arr, fmt=["%d", "%d", "%.17g", "%.17g", "%.17g", "%.17g"])

    _atomic_write_text(Path(particles), wp)


def write_table(net: ContactNetwork, contacts: str | os.PathLike, particles: str | os.PathLike) -> None:
    """Write the generic contact and particle tables (CSV, or NPZ by suffix); see :func:`read_table`."""
    cp, pp = Path(contacts), Path(particles)
    cols = {"id1": net.ids[net.i], "id2": net.ids[net.j], "fx": net.force[:, 0], "fy": net.force[:, 1],
            "fz": net.force[:, 2]}
    if net.overlap is not None:
        cols["delta"] = net.overlap
    if net.contact_point is not None:
        cols.update(cpx=net.contact_point[:, 0], cpy=net.contact_point[:, 1], cpz=net.contact_point[:, 2])
    if net.kn is not None and net.ks is not None:
        cols.update(kn=net.kn, ks=net.ks)
    if net.moment is not None:  # rolling and twisting resistance: the contact moment by id1 on id2
        cols.update(mx=net.moment[:, 0], my=net.moment[:, 1], mz=net.moment[:, 2])
    pcols = {"id": net.ids, "x": net.positions[:, 0], "y": net.positions[:, 1], "z": net.positions[:, 2]}
    if net.radii is not None:
        pcols["radius"] = net.radii
    box = {"cell": net.box.cell, "origin": net.box.origin, "periodic": net.box.periodic}
    for path, data, extra in ((cp, cols, box), (pp, pcols, {})):
        if path.suffix.lower() == ".npz":
            write_npz(path, **data, **extra)
            continue

        def w(fh, data=data, extra=extra):
            if extra:
                fh.write("# grainmech generic contact table; force exerted by id1 on id2 (compression positive)\n")
                fh.write("# cell: " + " ".join(f"{v:.17g}" for v in net.box.cell.ravel()) + "\n")
                fh.write("# origin: " + " ".join(f"{v:.17g}" for v in net.box.origin) + "\n")
                fh.write("# periodic: " + " ".join(str(int(v)) for v in net.box.periodic) + "\n")
            names = list(data)
            fh.write(",".join(names) + "\n")
            arr = np.column_stack([data[k] for k in names])
            fmt = ["%d" if k in ("id", "id1", "id2") else "%.17g" for k in names]
            for s in range(0, len(arr), _dem_blocks.CHUNK_LINES):
                np.savetxt(fh, arr[s:s + _dem_blocks.CHUNK_LINES], fmt=fmt, delimiter=",")

        _atomic_write_text(path, w)

"""Readers (and writers) of DEM contact networks: LIGGGHTS, LAMMPS, generic CSV/NPZ.

Every reader returns a :class:`grainmech.network.ContactNetwork` in grainmech's
convention (``docs/conventions.md``, ``docs/networks.md``): each contact once, from particle
A = ``id1`` to B = ``id2``, branch ``l = x_B - x_A`` (periodic minimum image), force
``f`` exerted **by A on B**, compression positive.

DEM sign conventions, converted here and nowhere else:

* LIGGGHTS ``compute pair/gran/local`` and LAMMPS ``compute pair/local`` (``fx fy fz``)
  report the force acting **on the first particle** ``i`` (exerted by ``j``). A
  compressive contact pushes ``i`` away from ``j``: that force is ``-f`` in grainmech's
  terms, so the readers negate it (``force_on="id1"``).
* The generic table (and YADE's ``i.phys.normalForce + i.phys.shearForce``, which is the
  force applied on ``id2``) already holds the force on ``id2`` (``force_on="id2"``).

Data blocks are parsed by pyarrow's CSV reader when pyarrow is installed (in pieces of
whole lines on every core, each copied straight into the kept arrays), else -- and for
anything that reader does not take, and for every error message -- by a NumPy line
parser in chunks of lines; both keep only
the needed columns, so memory is bounded by the output arrays, not by the file. A file whose
name ends in ``.gz`` is decompressed on the fly (line parser only). Malformed
lines, missing columns, NaN/inf values, duplicate or unknown particle ids raise
:class:`~grainmech.errors.GrainmechError` naming the file, the line, the column and the
value.

The readers live per format -- :mod:`grainmech.io._dem_dump` (LIGGGHTS, LAMMPS),
:mod:`grainmech.io._dem_table` (CSV, NPZ) --, the shared block parser in
:mod:`grainmech.io._dem_blocks`, the assembly of the columns into a network in
:mod:`grainmech.network.tables`, the writers in :mod:`grainmech.io._dem_write`; this
module dispatches (:func:`detect_format`, :func:`read_network`) and is where their public
names are imported from.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

from grainmech.errors import GrainmechError
from grainmech.io._dem_blocks import open_text
from grainmech.io._dem_dump import LIGGGHTS_KEYWORD_COLUMNS, read_lammps, read_liggghts
from grainmech.io._dem_table import read_table
from grainmech.io._dem_write import write_liggghts, write_table
from grainmech.network import ContactNetwork

__all__ = [
    "read_network",
    "read_liggghts",
    "read_lammps",
    "read_table",
    "write_liggghts",
    "write_table",
    "LIGGGHTS_KEYWORD_COLUMNS",
    "detect_format",
]


# --------------------------------------------------------------------------- dispatch

def detect_format(path: str | os.PathLike) -> str:
    """``"npz"``, ``"csv"``, ``"liggghts"`` (any ``ITEM:`` dump) from suffix and first line."""
    p = Path(path)
    if p.suffix.lower() == ".npz":
        return "npz"
    with open_text(p, errors="replace") as fh:
        head = fh.readline().strip()
    if head.startswith("ITEM:"):
        return "liggghts"
    return "csv"


def read_network(contacts: str | os.PathLike, particles: str | os.PathLike | None = None, *,
                 format: str = "auto", keywords: Sequence[str] | None = None,
                 columns: Sequence[str] | None = None, force_on: str | None = None,
                 progress: Callable[[int, int], None] | None = None) -> ContactNetwork:
    """Read a contact network; ``format`` is ``auto``, ``liggghts``, ``lammps``, ``csv`` or ``npz``.

    ``auto`` picks ``npz`` by suffix, ``liggghts`` for files starting with ``ITEM:``
    (LAMMPS local dumps are read the same way; their columns must be named with
    ``columns``), else ``csv``. ``progress(done, total)`` receives the bytes of the
    contact file read so far and its size, after each piece of a text file.
    """
    fmt = detect_format(contacts) if format == "auto" else format
    if fmt == "liggghts":
        return read_liggghts(contacts, particles, keywords=keywords, columns=columns,
                             force_on=force_on or "id1", progress=progress)
    if fmt == "lammps":
        if particles is None:
            raise GrainmechError("LAMMPS local dumps carry no positions: give the particle dump (--particles)")
        return read_lammps(contacts, particles, columns=columns, force_on=force_on or "id1", progress=progress)
    if fmt in ("csv", "npz"):
        return read_table(contacts, particles, force_on=force_on, progress=progress)
    raise GrainmechError(f"format must be auto, liggghts, lammps, csv or npz, got {format!r}")

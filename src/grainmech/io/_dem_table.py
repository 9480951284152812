"""Generic contact tables (CSV, NPZ): :func:`read_table` (re-exported by :mod:`grainmech.io.dem`).

One contact per row with descriptive column names (aliases accepted), the particles in a
second table, the box and the force convention in ``# key = value`` comment lines (CSV)
or arrays (NPZ); the force is the one on ``id2`` unless the file or the caller says
otherwise. The data blocks are read by :mod:`grainmech.io._dem_blocks`, the NPZ arrays by
:mod:`grainmech.network.tables`.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.io._dem_blocks import CONTACT_ALIASES, LineReader, particle_columns, read_block
from grainmech.network.data import Box, ContactNetwork
from grainmech.network.tables import CONTACT_COLUMNS, network_from_columns, npz_contacts, npz_particles, particle_table


def _table_box(meta: dict[str, str], path: Path) -> Box | None:
    def nums(key: str, n: int) -> np.ndarray:
        try:
            v = np.array([float(x) for x in meta[key].replace(",", " ").split()])
        except ValueError:
            raise GrainmechError(f"{path}: '# {key}:' must list {n} numbers, got {meta[key]!r}") from None
        if v.size != n or not np.all(np.isfinite(v)):
            raise GrainmechError(f"{path}: '# {key}:' must list {n} finite numbers, got {meta[key]!r}")
        return v
    if "box" in meta:
        b = nums("box", 6)
        per = nums("periodic", 3) != 0 if "periodic" in meta else np.ones(3, bool)
        return Box.orthogonal(b[0::2], b[1::2], per)
    if "cell" in meta:
        c = nums("cell", 9).reshape(3, 3)
        o = nums("origin", 3) if "origin" in meta else np.zeros(3)
        per = nums("periodic", 3) != 0 if "periodic" in meta else np.ones(3, bool)
        return Box(o, c, per)
    return None


def _csv_header(rd: LineReader) -> tuple[list[str], dict[str, str], str | None]:
    meta: dict[str, str] = {}
    while True:
        s = rd.readline()
        if not s:
            raise GrainmechError(f"{rd.path}:{rd.line}: no header line with column names")
        st = s.strip()
        if not st:
            continue
        if st.startswith("#"):
            m = re.match(r"#\s*([A-Za-z_]+)\s*:\s*(.*)$", st)
            if m:
                meta[m.group(1).lower()] = m.group(2).strip()
            continue
        delim = "," if "," in st else None
        names = [x.strip() for x in (st.split(",") if delim else st.split())]
        return names, meta, delim


def read_table(contacts: str | os.PathLike, particles: str | os.PathLike | None = None, *,
               force_on: str | None = None,
               progress: Callable[[int, int], None] | None = None) -> ContactNetwork:
    """Read the generic contact table (CSV or NPZ) and particle table; see ``docs/networks.md``.

    Contact columns (CSV header or NPZ array names): ``id1, id2, fx, fy, fz`` required
    (force exerted **by id1 on id2**, i.e. acting on id2; compression gives
    ``f . (x2 - x1) > 0``); optional ``x1 y1 z1 x2 y2 z2``, ``cpx cpy cpz`` (contact
    point), ``delta`` (overlap), ``kn ks`` (contact stiffness), ``mx my mz`` (contact moment
    by id1 on id2: rolling and twisting resistance). Particle columns: ``id, x,
    y, z, radius``. The box comes from comment lines ``# box: xlo xhi ylo yhi zlo zhi`` or
    ``# cell: ax ay az bx by bz cx cy cz`` with ``# origin: x y z``, and
    ``# periodic: 1 1 1`` (NPZ: arrays ``cell``, ``origin``, ``periodic``), in either
    file. ``# force_on: id1`` declares the opposite force convention. ``progress(done,
    total)`` receives the bytes of a CSV contact file read so far and its size.
    """
    cpath = Path(contacts)
    ppath = Path(particles) if particles is not None else None
    parts = None
    box = None
    meta_force = None
    if ppath is not None:
        if ppath.suffix.lower() == ".npz":
            parts = npz_particles(ppath)
        else:
            with LineReader(ppath) as rd:
                names, meta, delim = _csv_header(rd)
                want = particle_columns(names, ppath, rd.line)
                pcols, first = read_block(rd, names, want, None, delimiter=delim, int_cols=("id",))
            pbox = _table_box(meta, ppath)
            parts = particle_table(pcols, pbox, ppath, first)
        box = parts.box
    if cpath.suffix.lower() == ".npz":
        cols, cbox, meta_force = npz_contacts(cpath)
        first = 0
        box = cbox or box
    else:
        with LineReader(cpath) as rd:
            names, meta, delim = _csv_header(rd)
            canon = [CONTACT_ALIASES.get(n.lower(), n.lower()) for n in names]
            want = {c: k for k, c in enumerate(canon) if c in CONTACT_COLUMNS}
            for c in ("id1", "id2", "fx", "fy", "fz"):
                if c not in want:
                    raise GrainmechError(f"{cpath}:{rd.line}: contact table has no {c!r} column "
                                         f"(columns: {', '.join(names)})")
            cols, first = read_block(rd, names, want, None, delimiter=delim, int_cols=("id1", "id2"),
                                      progress=progress)
        box = _table_box(meta, cpath) or box
        meta_force = meta.get("force_on")
    fo = force_on or meta_force or "id2"
    src = f"table {cpath}" + (f" + {ppath}" if ppath else "")
    return network_from_columns(cols, cpath, first, parts, box, fo, src)

"""LIGGGHTS and LAMMPS dumps: :func:`read_liggghts`, :func:`read_lammps` (re-exported by :mod:`grainmech.io.dem`).

``compute pair/gran/local`` (LIGGGHTS) and ``compute pair/local`` (LAMMPS) dumps with the
particles' ``dump custom``: the dump headers and box, the column names of the keywords,
the particle dump; the data blocks are read by :mod:`grainmech.io._dem_blocks`. The force
in these files acts on the first particle and is negated here (``force_on="id1"``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.io._dem_blocks import CONTACT_ALIASES, LineReader, particle_columns, read_block
from grainmech.network.data import Box, ContactNetwork
from grainmech.network.tables import CONTACT_COLUMNS, ParticleTable, network_from_columns, particle_table

#: Output columns of LIGGGHTS ``compute pair/gran/local`` per keyword, in the compute's fixed
#: output order (LIGGGHTS-PUBLIC 3.8 ``ComputePairGranLocal::post_force_pp``; the order in
#: which keywords are given on the command line does not matter). ``history`` has a
#: model-dependent width (``history:N``); ``heatFlux`` is always the last column.
LIGGGHTS_KEYWORD_COLUMNS: dict[str, tuple[str, ...]] = {
    "pos": ("x1", "y1", "z1", "x2", "y2", "z2"),
    "vel": ("vx1", "vy1", "vz1", "vx2", "vy2", "vz2"),
    "id": ("id1", "id2", "periodic"),
    "force": ("fx", "fy", "fz"),
    "force_normal": ("fnx", "fny", "fnz"),
    "force_tangential": ("ftx", "fty", "ftz"),
    "torque": ("tx", "ty", "tz"),
    "torque_normal": ("tnx", "tny", "tnz"),
    "torque_tangential": ("ttx", "tty", "ttz"),
    "history": (),
    "contactArea": ("area",),
    "delta": ("delta",),
    "contactPoint": ("cpx", "cpy", "cpz"),
    "ms_id": ("ms1", "ms2"),
    "heatFlux": ("heat",),
}
_KEYWORD_ORDER = tuple(LIGGGHTS_KEYWORD_COLUMNS)
#: keyword sets recognised from the column count alone (widths are unique)
_AUTO_KEYWORDS = (
    ("pos", "id", "force", "contactPoint", "delta"),  # 16 (the documented default)
    ("pos", "id", "force", "contactPoint"),  # 15
    ("pos", "id", "force", "delta"),  # 13
    ("pos", "id", "force"),  # 12
    ("id", "force"),  # 6
)


# --------------------------------------------------------------------------- dump headers

@dataclass
class _Dump:
    box: Box | None
    count: int | None
    names: list[str]
    timestep: int | None


def _parse_box(rd: LineReader, item: str) -> Box:
    """Box from a ``ITEM: BOX BOUNDS [xy xz yz] bx by bz`` header (LAMMPS dump format)."""
    words = item.split()[3:]
    tilt = words[:3] == ["xy", "xz", "yz"]
    flags = words[3:] if tilt else words
    if len(flags) != 3:
        flags = ["pp", "pp", "pp"]
    rows = []
    for _ in range(3):
        s = rd.readline()
        try:
            vals = [float(v) for v in s.split()]
        except ValueError:
            raise GrainmechError(f"{rd.path}:{rd.line}: bad BOX BOUNDS line {s.strip()!r}") from None
        if len(vals) != (3 if tilt else 2) or not np.all(np.isfinite(vals)):
            raise GrainmechError(f"{rd.path}:{rd.line}: expected {3 if tilt else 2} finite numbers in "
                                 f"BOX BOUNDS, got {s.strip()!r}")
        rows.append(vals)
    periodic = [f[:1] == "p" for f in flags]
    if not tilt:
        lo = [r[0] for r in rows]
        hi = [r[1] for r in rows]
        return Box.orthogonal(lo, hi, periodic)
    (xlb, xhb, xy), (ylb, yhb, xz), (zlb, zhb, yz) = rows
    xlo = xlb - min(0.0, xy, xz, xy + xz)
    xhi = xhb - max(0.0, xy, xz, xy + xz)
    ylo = ylb - min(0.0, yz)
    yhi = yhb - max(0.0, yz)
    cell = np.array([[xhi - xlo, 0.0, 0.0], [xy, yhi - ylo, 0.0], [xz, yz, zhb - zlb]])
    return Box(np.array([xlo, ylo, zlb]), cell, np.array(periodic))


def _read_dump_header(rd: LineReader, data_item: str) -> _Dump:
    """Read ITEM sections up to the data header ``ITEM: <data_item> names...``."""
    box = None
    count = None
    ts = None
    while True:
        s = rd.readline()
        if not s:
            raise GrainmechError(f"{rd.path}:{rd.line}: file ends before 'ITEM: {data_item}'")
        st = s.strip()
        if not st:
            continue
        if not st.startswith("ITEM:"):
            raise GrainmechError(f"{rd.path}:{rd.line}: expected an 'ITEM:' line of a LAMMPS/LIGGGHTS "
                                 f"dump, got {st[:60]!r}")
        if st.startswith("ITEM: TIMESTEP"):
            v = rd.readline().strip()
            try:
                ts = int(v)
            except ValueError:
                raise GrainmechError(f"{rd.path}:{rd.line}: bad TIMESTEP {v!r}") from None
        elif st.startswith("ITEM: NUMBER OF"):
            v = rd.readline().strip()
            try:
                count = int(v)
            except ValueError:
                raise GrainmechError(f"{rd.path}:{rd.line}: bad {st[6:]} value {v!r}") from None
            if count < 0:
                raise GrainmechError(f"{rd.path}:{rd.line}: negative count {count}")
        elif st.startswith("ITEM: BOX BOUNDS"):
            box = _parse_box(rd, st)
        elif st.startswith(f"ITEM: {data_item}"):
            names = st.split()[2:]
            if not names:
                raise GrainmechError(f"{rd.path}:{rd.line}: 'ITEM: {data_item}' line names no columns")
            return _Dump(box, count, names, ts)
        elif st.startswith("ITEM: ENTRIES") or st.startswith("ITEM: ATOMS"):
            raise GrainmechError(f"{rd.path}:{rd.line}: expected 'ITEM: {data_item}', got {st[:40]!r} "
                                 "(wrong kind of dump: contacts need 'dump local', particles 'dump custom')")
        else:
            # unknown item with one value line (e.g. ITEM: TIME)
            rd.readline()


def _liggghts_names(names: list[str], keywords: Sequence[str] | None, columns: Sequence[str] | None,
                    path: Path, line: int, lammps: bool = False) -> list[str]:
    """Map dump column headers to canonical names."""
    if columns is not None:
        cols = [c.strip() for c in columns]
        if len(cols) != len(names):
            raise GrainmechError(f"{path}:{line}: --columns names {len(cols)} columns but the file has "
                                 f"{len(names)} ({' '.join(names)})")
        return [CONTACT_ALIASES.get(c, c) for c in cols]
    low = [n.lower() for n in names]
    if all(n in CONTACT_ALIASES for n in low):
        return [CONTACT_ALIASES[n] for n in low]
    body = [n for n in low if n != "index"]
    prefix = ["index"] * (len(low) - len(body))
    if keywords is not None:
        cand = [tuple(keywords)]
    elif lammps:
        raise GrainmechError(
            f"{path}:{line}: cannot tell what the columns {' '.join(names)} hold; LAMMPS local dumps "
            "name them after the compute (c_ID[k]). Give their meanings with --columns, e.g. "
            "--columns id1,id2,fx,fy,fz (property/local patom1 patom2 + pair/local fx fy fz)")
    else:
        cand = [k for k in _AUTO_KEYWORDS if sum(len(LIGGGHTS_KEYWORD_COLUMNS[w]) for w in k) == len(body)]
        if not cand:
            raise GrainmechError(
                f"{path}:{line}: cannot tell what the {len(body)} columns {' '.join(names)} hold; give the "
                "keywords of 'compute pair/gran/local' in order (e.g. --keywords pos,id,force,"
                "contactPoint,delta) or name every column with --columns")
    kw = cand[0]
    out: list[str] = []
    parsed: dict[str, int] = {}
    for w in kw:
        base, _, num = w.partition(":")
        if base not in LIGGGHTS_KEYWORD_COLUMNS:
            raise GrainmechError(f"unknown compute pair/gran/local keyword {w!r}; known: "
                                 f"{', '.join(k for k in _KEYWORD_ORDER if k != 'history')}, history:N")
        if base == "history":
            try:
                parsed[base] = int(num)
            except ValueError:
                raise GrainmechError(f"keyword 'history' needs its width, e.g. history:3 (got {w!r})") from None
        else:
            parsed[base] = len(LIGGGHTS_KEYWORD_COLUMNS[base])
    for base in _KEYWORD_ORDER:  # the compute writes its columns in a fixed order
        if base == "history" and base in parsed:
            out += [f"hist{q + 1}" for q in range(parsed[base])]
        elif base in parsed:
            out += list(LIGGGHTS_KEYWORD_COLUMNS[base])
    if len(out) != len(body):
        raise GrainmechError(f"{path}:{line}: keywords {','.join(kw)} give {len(out)} columns but the file "
                             f"has {len(body)} data columns ({' '.join(names)})")
    return prefix + out


def _read_particles_dump(path: Path) -> ParticleTable:
    with LineReader(path) as rd:
        hd = _read_dump_header(rd, "ATOMS")
        want = particle_columns(hd.names, path, rd.line)
        cols, first = read_block(rd, hd.names, want, hd.count, stop_prefix="ITEM:", int_cols=("id",))
    return particle_table(cols, hd.box, path, first)


def read_liggghts(contacts: str | os.PathLike, particles: str | os.PathLike | None = None, *,
                  keywords: Sequence[str] | None = None, columns: Sequence[str] | None = None,
                  force_on: str = "id1", lammps: bool = False,
                  progress: Callable[[int, int], None] | None = None) -> ContactNetwork:
    """Read a LIGGGHTS ``dump local`` of ``compute pair/gran/local`` (+ particle ``dump custom``).

    Parameters
    ----------
    contacts : path
        ``dump local`` file (first snapshot is read). Its ``ITEM: ENTRIES`` header names
        the columns: descriptive names (``id1 id2 fx fy fz x1 ... cpx ... delta``) are used
        directly; otherwise (``c_ID[1] c_ID[2] ...``) they are the output of the compute
        keywords in order, given by ``keywords`` or recognised from the column count for
        ``pos,id,force,contactPoint,delta`` (16 columns), ``pos,id,force,contactPoint`` (15),
        ``pos,id,force,delta`` (13), ``pos,id,force`` (12) and ``id,force`` (6). Widths
        per keyword: :data:`LIGGGHTS_KEYWORD_COLUMNS` (``history:N`` for N history values).
    particles : path, optional
        ``dump custom`` with ``id x y z radius`` (also ``xu``, ``xs`` scaled, ``diameter``).
        Required unless the contacts carry positions (``pos``); radii are needed for the
        Hertz law and the rotations of the relaxed solve.
    keywords, columns : sequence of str, optional
        Compute keywords in output order, or a name for every column.
    force_on : {"id1", "id2"}
        Which particle the file's force acts on; LIGGGHTS reports the force on the first
        particle (default ``"id1"``), which the reader negates.
    progress : callable, optional
        ``progress(done, total)``: bytes of the contact file read so far and its size,
        called after each piece of the data block (a progress bar for large files).

    Returns
    -------
    ContactNetwork
        Box from the dumps (orthogonal or triclinic, periodic flags from the boundary
        codes); branch vectors from the particle centres by minimum image.
    """
    cpath = Path(contacts)
    ppath = Path(particles) if particles is not None else None
    parts = _read_particles_dump(ppath) if ppath is not None else None
    with LineReader(cpath) as rd:
        hd = _read_dump_header(rd, "ENTRIES")
        canon = _liggghts_names(hd.names, keywords, columns, cpath, rd.line, lammps=lammps)
        skip = ("x1", "y1", "z1", "x2", "y2", "z2") if parts is not None else ()
        want = {c: k for k, c in enumerate(canon) if c in CONTACT_COLUMNS and c not in skip}
        for c in ("id1", "id2", "fx", "fy", "fz"):
            if c not in want:
                raise GrainmechError(f"{cpath}:{rd.line}: the contact dump has no {c!r} column "
                                     f"(columns: {' '.join(hd.names)} read as {' '.join(canon)})")
        cols, first = read_block(rd, hd.names, want, hd.count, stop_prefix="ITEM:", int_cols=("id1", "id2"),
                                  progress=progress)
    box = hd.box if hd.box is not None else (parts.box if parts else None)
    src = f"{'LAMMPS' if lammps else 'LIGGGHTS'} {cpath}" + (f" + {ppath}" if ppath else "")
    return network_from_columns(cols, cpath, first, parts, box, force_on, src)


def read_lammps(contacts: str | os.PathLike, particles: str | os.PathLike, *,
                columns: Sequence[str] | None = None, force_on: str = "id1",
                progress: Callable[[int, int], None] | None = None) -> ContactNetwork:
    """Read a LAMMPS ``dump local`` of ``compute property/local`` + ``compute pair/local``.

    The dump must hold the two particle ids (``patom1 patom2``) and the force components
    (``fx fy fz`` of ``compute pair/local``, the force on atom I due to atom J, negated
    here); name the columns with ``columns`` (e.g. ``["id1", "id2", "fx", "fy", "fz"]``,
    ``index`` for the index column) unless the header already uses such names. Positions
    and radii come from the particle ``dump custom`` (``id x y z radius``).
    """
    return read_liggghts(contacts, particles, columns=columns, force_on=force_on, lammps=True, progress=progress)

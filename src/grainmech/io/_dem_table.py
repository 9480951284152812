"""Generic contact tables (CSV, NPZ): :func:`read_table` (re-exported by :mod:`grainmech.io.dem`).

One contact per row with descriptive column names (aliases accepted), the particles in a
second table, the box and the force convention in ``# key = value`` comment lines (CSV)
or arrays (NPZ); the force is the one on ``id2`` unless the file or the caller says
otherwise. The data blocks are read by :mod:`grainmech.io._dem_blocks`.
"""

from __future__ import annotations

import os
import re
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.io._dem_blocks import (
    _ALIASES,
    _CONTACT_WANT,
    _build,
    _finish_particles,
    _LineReader,
    _particle_columns,
    _read_block,
)
from grainmech.network import Box, ContactNetwork


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


def _csv_header(rd: _LineReader) -> tuple[list[str], dict[str, str], str | None]:
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


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    if path.is_file() and path.stat().st_size == 0:
        raise GrainmechError(f"{path}: the file is empty (0 bytes), not a .npz file")
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files}
    except FileNotFoundError:
        raise
    # EOFError: a truncated file; zipfile.BadZipFile: not a zip archive
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise GrainmechError(f"{path}: not a readable .npz file ({type(exc).__name__}: {exc})") from None


def _npz_cols(z: dict[str, np.ndarray], path: Path, names: Iterable[str], int_cols: Iterable[str]) -> dict:
    out = {}
    n = None
    for k in names:
        if k not in z:
            continue
        a = z[k]
        if a.ndim != 1:
            raise GrainmechError(f"{path}: array {k!r} must be one-dimensional, got shape {a.shape}")
        if n is not None and a.shape[0] != n:
            raise GrainmechError(f"{path}: array {k!r} has {a.shape[0]} rows, others {n}")
        n = a.shape[0]
        if k in set(int_cols):
            if not np.issubdtype(a.dtype, np.integer):
                af = a.astype(float)
                if not np.all(np.isfinite(af)) or np.any(np.rint(af) != af):
                    bad = int(np.flatnonzero(~np.isfinite(af) | (np.rint(af) != af))[0])
                    raise GrainmechError(f"{path}: array {k!r} row {bad}: {a[bad].item()!r} is not an integer id")
            out[k] = a.astype(np.int64)
        else:
            af = a.astype(float)
            nonfinite = np.flatnonzero(~np.isfinite(af))
            if nonfinite.size:
                raise GrainmechError(f"{path}: array {k!r} row {int(nonfinite[0])}: value "
                                     f"{float(af[nonfinite[0]])!r} is not finite")
            out[k] = af
    return out


def _npz_box(z: dict[str, np.ndarray], path: Path) -> Box | None:
    if "cell" not in z:
        return None
    o = z.get("origin", np.zeros(3))
    per = z.get("periodic", np.ones(3, bool))
    try:
        return Box(np.asarray(o, float).reshape(3), np.asarray(z["cell"], float).reshape(3, 3),
                   np.asarray(per).astype(bool).reshape(3))
    except ValueError:
        raise GrainmechError(f"{path}: 'cell' must be 3x3, 'origin' and 'periodic' 3 values") from None


def read_table(contacts: str | os.PathLike, particles: str | os.PathLike | None = None, *,
               force_on: str | None = None,
               progress: Callable[[int, int], None] | None = None) -> ContactNetwork:
    """Read the generic contact table (CSV or NPZ) and particle table; see ``docs/dem.md``.

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
            z = _read_npz(ppath)
            cols = _npz_cols(z, ppath, ("id", "x", "y", "z", "radius", "diameter"), ("id",))
            for c in ("id", "x", "y", "z"):
                if c not in cols:
                    raise GrainmechError(f"{ppath}: particle table has no {c!r} array (arrays: {', '.join(z)})")
            pbox = _npz_box(z, ppath)
            parts = _finish_particles(cols, pbox, ppath, 0)
        else:
            with _LineReader(ppath) as rd:
                names, meta, delim = _csv_header(rd)
                want = _particle_columns(names, ppath, rd.line)
                pcols, first = _read_block(rd, names, want, None, delimiter=delim, int_cols=("id",))
            pbox = _table_box(meta, ppath)
            parts = _finish_particles(pcols, pbox, ppath, first)
        box = parts.box
    if cpath.suffix.lower() == ".npz":
        z = _read_npz(cpath)
        cols = _npz_cols(z, cpath, _CONTACT_WANT, ("id1", "id2"))
        for c in ("id1", "id2", "fx", "fy", "fz"):
            if c not in cols:
                raise GrainmechError(f"{cpath}: contact table has no {c!r} array (arrays: {', '.join(z)})")
        first = 0
        box = _npz_box(z, cpath) or box
        if "force_on" in z:
            meta_force = str(z["force_on"])
    else:
        with _LineReader(cpath) as rd:
            names, meta, delim = _csv_header(rd)
            canon = [_ALIASES.get(n.lower(), n.lower()) for n in names]
            want = {c: k for k, c in enumerate(canon) if c in _CONTACT_WANT}
            for c in ("id1", "id2", "fx", "fy", "fz"):
                if c not in want:
                    raise GrainmechError(f"{cpath}:{rd.line}: contact table has no {c!r} column "
                                         f"(columns: {', '.join(names)})")
            cols, first = _read_block(rd, names, want, None, delimiter=delim, int_cols=("id1", "id2"),
                                      progress=progress)
        box = _table_box(meta, cpath) or box
        meta_force = meta.get("force_on")
    fo = force_on or meta_force or "id2"
    src = f"table {cpath}" + (f" + {ppath}" if ppath else "")
    return _build(cols, cpath, first, parts, box, fo, src)

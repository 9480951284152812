"""A contact network from columns of ids, positions and forces; the NPZ form of the generic tables.

Every reader of contact files ends here: the readers (:mod:`grainmech.io.dem`) parse a
file's columns, :func:`particle_table` and :func:`network_from_columns` check them and
assemble the :class:`~grainmech.network.ContactNetwork` in grainmech's convention (each
contact once, from A = ``id1`` to B = ``id2``, branch ``x_B - x_A`` as a periodic minimum
image, force by A on B, compression positive; ``docs/conventions.md``). The NPZ form of
grainmech's generic tables (arrays named as the columns; ``cell``, ``origin``,
``periodic``, ``force_on``) is read here too (:func:`read_npz_network`), so the shipped
packings load without the text readers. Errors name the file, the line (or row), the
column and the value.
"""

from __future__ import annotations

import zipfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.network.data import Box, ContactNetwork

__all__ = ["CONTACT_COLUMNS", "ParticleTable", "particle_table", "lookup_rows", "network_from_columns",
           "read_npz", "npz_columns", "npz_box", "npz_particles", "npz_contacts", "read_npz_network"]

#: canonical contact columns a reader keeps: ids, force (by ``id1`` on ``id2``), centres,
#: contact point, overlap, contact stiffnesses, contact moment
CONTACT_COLUMNS = ("id1", "id2", "fx", "fy", "fz", "x1", "y1", "z1", "x2", "y2", "z2", "cpx", "cpy", "cpz",
                   "delta", "kn", "ks", "mx", "my", "mz")


@dataclass
class ParticleTable:
    """The particles of a contact network as read: ids, centres, radii, box, and where they came from.

    Attributes
    ----------
    ids : ndarray, shape (P,), int64
        Particle ids as in the file.
    pos : ndarray, shape (P, 3)
        Centres [m].
    radii : ndarray, shape (P,), or None
        Radii [m] where the table has them.
    box : Box or None
        The box given with the particles.
    path : Path
        The file, for error messages.
    first_line : int
        Line of the first row (0 for arrays), for error messages.
    """

    ids: np.ndarray
    pos: np.ndarray
    radii: np.ndarray | None
    box: Box | None
    path: Path
    first_line: int


def particle_table(cols: dict[str, np.ndarray], box: Box | None, path: Path, first: int) -> ParticleTable:
    """The particles of the columns ``id``, ``x y z`` (or scaled ``xs ys zs`` with a box), ``radius`` or ``diameter``.

    Raises :class:`~grainmech.errors.GrainmechError` naming the file and line of a
    non-positive radius or a repeated id, or scaled coordinates without a box.
    """
    ids = cols["id"]
    if "x" in cols:
        pos = np.stack([cols["x"], cols["y"], cols["z"]], axis=1)
    else:
        if box is None:
            raise GrainmechError(f"{path}: scaled coordinates (xs ys zs) need a box")
        pos = box.origin + np.stack([cols["xs"], cols["ys"], cols["zs"]], axis=1) @ box.cell
    radii = None
    if "radius" in cols:
        radii = cols["radius"]
    elif "diameter" in cols:
        radii = 0.5 * cols["diameter"]
    if radii is not None and radii.size and not np.all(radii > 0):
        k = int(np.flatnonzero(~(radii > 0))[0])
        raise GrainmechError(f"{path}:{first + k}: particle {int(ids[k])}: radius must be > 0, got {float(radii[k])!r}")
    order = np.argsort(ids, kind="stable")
    sid = ids[order]
    dup = np.flatnonzero(sid[1:] == sid[:-1])
    if dup.size:
        k = int(order[dup[0] + 1])
        raise GrainmechError(f"{path}:{first + k}: particle id {ids[k]} appears twice")
    return ParticleTable(ids, pos, radii, box, path, first)


def _vector(cols: dict[str, np.ndarray], group: Sequence[str]) -> np.ndarray:
    """The (n, 3) array of three columns: the array they are views of, else a stack."""
    a = [cols[k] for k in group]
    base = a[0].base
    if (isinstance(base, np.ndarray) and base.ndim == 2 and base.shape[1] == 3 and base.flags.c_contiguous
            and all(x.base is base for x in a) and all(x.shape[0] == base.shape[0] for x in a)
            and [x.__array_interface__["data"][0] - base.__array_interface__["data"][0] for x in a]
            == [0, 8, 16]):
        return base
    return np.stack(a, axis=1)


#: rows per block of the index look-up and branch vectors (bounded temporaries)
_BUILD_BLOCK = 1 << 16


def lookup_rows(ids_sorted: np.ndarray, order: np.ndarray, q: np.ndarray, path: Path, first: int,
            col: str, ppath: Path) -> np.ndarray:
    """Row of each id of ``q`` (column ``col`` of ``path``) in the particle table (blockwise: temporaries stay small).

    Written over ``q`` itself (an int64 array the reader owns: no second array of the
    contacts' size); nothing is overwritten from the first unknown id on, so the message
    names the id as read. Ids spanning at most ``4 P + 65536`` values (DEM codes number
    their particles 1..P) are looked up in a table indexed by id, else by binary search
    (``searchsorted``, ~10x slower).
    """
    out = q if q.dtype == np.int64 and q.flags.writeable else np.empty(len(q), dtype=np.int64)
    P = len(ids_sorted)
    table = None
    if P:
        lo = int(ids_sorted[0])
        span = int(ids_sorted[-1]) - lo + 1
        if span <= 4 * P + 65536:
            table = np.full(span, -1, dtype=np.int64)
            table[ids_sorted - lo] = order
    nbad = 0
    kbad = -1
    for a in range(0, len(q), _BUILD_BLOCK):
        qq = q[a:a + _BUILD_BLOCK]
        if table is not None:
            k = qq - lo
            outside = (k < 0) | (k >= span)
            np.clip(k, 0, span - 1, out=k)
            rows = table[k]
            bad = np.flatnonzero(outside | (rows < 0))
        else:
            pos = np.searchsorted(ids_sorted, qq)
            np.minimum(pos, P - 1, out=pos)
            bad = np.flatnonzero(ids_sorted[pos] != qq) if P else np.arange(len(qq))
            rows = order[pos] if P else pos
        if bad.size:
            nbad += bad.size
            kbad = a + int(bad[0]) if kbad < 0 else kbad
        elif kbad < 0:
            out[a:a + _BUILD_BLOCK] = rows
    if nbad:
        raise GrainmechError(f"{path}:{first + kbad}: particle id {int(q[kbad])} (column {col}) is not listed in "
                             f"{ppath} ({nbad} contact(s) reference unlisted particles)")
    return out


def network_from_columns(cols: dict[str, np.ndarray], path: Path, first: int, parts: ParticleTable | None,
                         box: Box | None, force_on: str, source: str) -> ContactNetwork:
    """The contact network of contact columns (:data:`CONTACT_COLUMNS`) and a particle table.

    ``cols`` holds ``id1 id2 fx fy fz`` and any of the optional columns; its int64 id
    columns become the index columns in place. The force is the one on ``id2`` (exerted by
    ``id1``) for ``force_on="id2"``; for ``"id1"`` force and moment are negated into that
    convention. Without ``parts`` the particles come from the contacts' ``x1 .. z2``
    columns; without a box the particles' bounding box (not periodic) is the volume, and
    ``source`` says so. Branch vectors are periodic minimum images ``x_B - x_A``.
    Errors (missing columns, self contacts, unknown ids, coincident centres) name the file
    and the line.
    """
    for c in ("id1", "id2", "fx", "fy", "fz"):
        if c not in cols:
            raise GrainmechError(f"{path}: contact data has no {c!r} column")
    if force_on not in ("id1", "id2"):
        raise GrainmechError(f"force_on must be 'id1' or 'id2', got {force_on!r}")
    id1, id2 = cols["id1"], cols["id2"]
    same = np.flatnonzero(id1 == id2)
    if same.size:
        k = int(same[0])
        raise GrainmechError(f"{path}:{first + k}: contact of particle {id1[k]} with itself")
    f = _vector(cols, ("fx", "fy", "fz"))
    if force_on == "id1":
        np.negative(f, out=f)  # force on A (by B) -> force by A on B
    has_pos = all(c in cols for c in ("x1", "y1", "z1", "x2", "y2", "z2"))
    if parts is None:
        if not has_pos:
            raise GrainmechError(f"{path}: the contacts carry no positions (pos keyword / x1..z2 columns); "
                                 "give the particle file (--particles)")
        allid = np.concatenate([id1, id2])
        allpos = np.concatenate([_vector(cols, ("x1", "y1", "z1")), _vector(cols, ("x2", "y2", "z2"))])
        uid, idx = np.unique(allid, return_index=True)
        parts = ParticleTable(uid, allpos[idx], None, None, path, first)
        del allid, allpos
    box = box if box is not None else parts.box
    if box is None:
        r = parts.radii if parts.radii is not None else np.zeros(len(parts.ids))
        lo = (parts.pos - r[:, None]).min(axis=0)
        hi = (parts.pos + r[:, None]).max(axis=0)
        box = Box.orthogonal(lo, hi, False)
        source += " (no box in the files: volume of the particles' bounding box, not periodic)"
    order = np.argsort(parts.ids, kind="stable")
    sid = parts.ids[order]
    # the id columns become the index columns in place (the reader's own int64 arrays)
    ia = lookup_rows(sid, order, id1, path, first, "id1", parts.path)
    ib = lookup_rows(sid, order, id2, path, first, "id2", parts.path)
    del id1, id2, cols["id1"], cols["id2"]
    l_ = np.empty((len(ia), parts.pos.shape[1]))
    for a in range(0, len(ia), _BUILD_BLOCK):
        blk = slice(a, a + _BUILD_BLOCK)
        l_[blk] = box.minimum_image(parts.pos[ib[blk]] - parts.pos[ia[blk]])
        zero = np.flatnonzero(np.einsum("ij,ij->i", l_[blk], l_[blk]) <= 0)
        if zero.size:
            k = a + int(zero[0])
            raise GrainmechError(f"{path}:{first + k}: particles {parts.ids[ia[k]]} and {parts.ids[ib[k]]} "
                                 "have the same centre")
    overlap = cols.get("delta")
    cp = _vector(cols, ("cpx", "cpy", "cpz")) if all(c in cols for c in ("cpx", "cpy", "cpz")) else None
    kn = cols.get("kn")
    ks = cols.get("ks")
    m = _vector(cols, ("mx", "my", "mz")) if all(c in cols for c in ("mx", "my", "mz")) else None
    if m is not None and force_on == "id1":
        np.negative(m, out=m)  # the moment on A (by B) -> the moment by A on B, as the force
    return ContactNetwork(parts.ids, parts.pos, parts.radii, box, ia, ib, f, l_, overlap, cp, kn, ks, source,
                          moment=m)


def read_npz(path: Path) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` file ``path``; an empty or unreadable file raises a one-line error."""
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


def npz_columns(z: dict[str, np.ndarray], path: Path, names: Iterable[str], int_cols: Iterable[str]) -> dict:
    """The one-dimensional arrays ``names`` of ``z`` that are present: ``int_cols`` as int64 ids, the rest float.

    All of equal length and finite; ids integral (errors name the array and the row).
    """
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


def npz_box(z: dict[str, np.ndarray], path: Path) -> Box | None:
    """The box of the arrays ``cell`` (3 x 3), ``origin`` and ``periodic`` (3 each), or None without ``cell``."""
    if "cell" not in z:
        return None
    o = z.get("origin", np.zeros(3))
    per = z.get("periodic", np.ones(3, bool))
    try:
        return Box(np.asarray(o, float).reshape(3), np.asarray(z["cell"], float).reshape(3, 3),
                   np.asarray(per).astype(bool).reshape(3))
    except ValueError:
        raise GrainmechError(f"{path}: 'cell' must be 3x3, 'origin' and 'periodic' 3 values") from None


def npz_particles(path: Path) -> ParticleTable:
    """The particle table of an NPZ file (arrays ``id x y z`` and ``radius`` or ``diameter``; its box)."""
    z = read_npz(path)
    cols = npz_columns(z, path, ("id", "x", "y", "z", "radius", "diameter"), ("id",))
    for c in ("id", "x", "y", "z"):
        if c not in cols:
            raise GrainmechError(f"{path}: particle table has no {c!r} array (arrays: {', '.join(z)})")
    return particle_table(cols, npz_box(z, path), path, 0)


def npz_contacts(path: Path) -> tuple[dict[str, np.ndarray], Box | None, str | None]:
    """The contact columns (:data:`CONTACT_COLUMNS`) of an NPZ file, its box and its ``force_on`` (None if absent)."""
    z = read_npz(path)
    cols = npz_columns(z, path, CONTACT_COLUMNS, ("id1", "id2"))
    for c in ("id1", "id2", "fx", "fy", "fz"):
        if c not in cols:
            raise GrainmechError(f"{path}: contact table has no {c!r} array (arrays: {', '.join(z)})")
    return cols, npz_box(z, path), str(z["force_on"]) if "force_on" in z else None


def read_npz_network(contacts: Path, particles: Path | None = None) -> ContactNetwork:
    """The contact network of the NPZ contact and particle tables (the generic table's arrays).

    As :func:`grainmech.io.dem.read_table` reads them: the force is the one on ``id2``
    unless the contact file's ``force_on`` says ``"id1"``; the contact file's box wins over
    the particle file's.
    """
    parts = npz_particles(particles) if particles is not None else None
    cols, box, force_on = npz_contacts(contacts)
    box = box or (parts.box if parts is not None else None)
    source = f"table {contacts}" + (f" + {particles}" if particles is not None else "")
    return network_from_columns(cols, contacts, 0, parts, box, force_on or "id2", source)

"""Readers (and writers) of DEM contact networks: LIGGGHTS, LAMMPS, generic CSV/NPZ.

Every reader returns a :class:`grainmech.network.ContactNetwork` in grainmech's
convention (``docs/conventions.md``, ``docs/dem.md``): each contact once, from particle
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
the needed columns, so memory is bounded by the output arrays, not by the file. Malformed
lines, missing columns, NaN/inf values, duplicate or unknown particle ids raise
:class:`~grainmech.errors.GrainmechError` naming the file, the line, the column and the
value.
"""

from __future__ import annotations

import io
import itertools
import os
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.network import Box, ContactNetwork

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

CHUNK_LINES = 1 << 16

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

# aliases of descriptive column names -> canonical names
_ALIASES = {
    "id1": "id1", "id2": "id2", "i": "id1", "j": "id2", "patom1": "id1", "patom2": "id2",
    "batom1": "id1", "batom2": "id2",
    "fx": "fx", "fy": "fy", "fz": "fz", "force_x": "fx", "force_y": "fy", "force_z": "fz",
    "x1": "x1", "y1": "y1", "z1": "z1", "x2": "x2", "y2": "y2", "z2": "z2",
    "cpx": "cpx", "cpy": "cpy", "cpz": "cpz", "contact_x": "cpx", "contact_y": "cpy", "contact_z": "cpz",
    "delta": "delta", "overlap": "delta", "kn": "kn", "ks": "ks", "periodic": "periodic",
    "index": "index", "dist": "dist", "eng": "eng", "force": "fmag", "area": "area",
    "fnx": "fnx", "fny": "fny", "fnz": "fnz", "ftx": "ftx", "fty": "fty", "ftz": "ftz",
}
_PARTICLE_ALIASES = {
    "id": "id", "x": "x", "y": "y", "z": "z", "xu": "x", "yu": "y", "zu": "z",
    "xs": "xs", "ys": "ys", "zs": "zs", "xsu": "xs", "ysu": "ys", "zsu": "zs",
    "radius": "radius", "diameter": "diameter", "r": "radius",
}


# --------------------------------------------------------------------------- chunked parser

class _LineReader:
    """Text file with line numbers (1-based) for error messages."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self.fh: io.TextIOWrapper = open(path, encoding="utf-8", errors="strict", newline=None)
        except IsADirectoryError:
            raise GrainmechError(f"{path}: is a directory, not a file") from None
        except FileNotFoundError:
            raise GrainmechError(f"{path}: file not found") from None
        self.line = 0
        self._pushed: list[str] = []

    def readline(self) -> str:
        if self._pushed:
            self.line += 1
            return self._pushed.pop()
        try:
            s = self.fh.readline()
        except UnicodeDecodeError as exc:
            raise GrainmechError(f"{self.path}:{self.line + 1}: not a UTF-8 text file ({exc.reason})") from None
        if s:
            self.line += 1
        return s

    def unread(self, s: str) -> None:
        self._pushed.append(s)
        self.line -= 1

    def chunk(self, n: int) -> list[str]:
        try:
            lines = list(itertools.islice(self.fh, n))
        except UnicodeDecodeError as exc:
            raise GrainmechError(f"{self.path}: not a UTF-8 text file ({exc.reason})") from None
        self.line += len(lines)
        return lines

    def close(self) -> None:
        self.fh.close()

    def __enter__(self) -> _LineReader:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _diagnose(lines: Sequence[str], names: Sequence[str], delimiter: str | None, path: Path,
              line0: int) -> None:
    """Raise a precise error for the first bad line of a chunk."""
    ncol = len(names)
    for k, s in enumerate(lines):
        parts = s.strip().split(delimiter) if delimiter else s.split()
        ln = line0 + k
        if not s.strip():
            raise GrainmechError(f"{path}:{ln}: empty line inside the data (expected {ncol} columns)")
        if len(parts) != ncol:
            raise GrainmechError(f"{path}:{ln}: expected {ncol} columns ({' '.join(names)}), found "
                                 f"{len(parts)}: {s.strip()[:80]!r}")
        for name, v in zip(names, parts):
            try:
                float(v)
            except ValueError:
                raise GrainmechError(f"{path}:{ln}: column {name!r}: value {v.strip()!r} is not a number") from None
    raise GrainmechError(f"{path}:{line0}-{line0 + len(lines) - 1}: could not parse the data block")


def _arrow_csv() -> Any:
    """``pyarrow.csv``, or None when pyarrow is not installed."""
    try:
        import pyarrow.csv as pacsv  # noqa: PLC0415 (optional dependency)
    except ImportError:
        return None
    return pacsv


#: block size of the pyarrow CSV reader within one piece [bytes] (a piece is parsed on one
#: thread; the block size changes neither its speed nor, at this size, its memory)
ARROW_BLOCK = 1 << 20

#: largest piece of a data block parsed by one worker thread at a time [bytes]
#: (:func:`_read_block_arrow`): 1e7 16-column rows on 2 cores parsed in 3.8 s with 8 MB
#: pieces, 3.9-4.1 s with 16 MB, 4.2 s with 64 MB; the streaming reader on one core took 6 s
ARROW_WINDOW = 1 << 24

#: smallest piece [bytes]; between the two a piece is 1/64 of the block, so that the pieces
#: in flight (text and parsed table, ~2.5x the piece each) stay a few percent of the arrays
#: kept (text: ~170 B per contact, arrays ~100 B)
ARROW_WINDOW_MIN = 1 << 20


#: columns read into one (n, 3) array (the arrays the network keeps)
_VECTOR_COLUMNS = (("fx", "fy", "fz"), ("cpx", "cpy", "cpz"), ("x1", "y1", "z1"), ("x2", "y2", "z2"))


def _allocate(keys: Sequence[str], ints: set, count: int) -> dict[str, np.ndarray]:
    """Output arrays of a block.

    int64 ids, (n, 3) arrays for vector columns (each column a view, see :func:`_vector`),
    float64 otherwise.
    """
    out: dict[str, np.ndarray] = {}
    for group in _VECTOR_COLUMNS:
        if all(k in keys for k in group):
            V = np.empty((count, 3))
            for q, k in enumerate(group):
                out[k] = V[:, q]
    for k in keys:
        if k not in out:
            out[k] = np.empty(count, dtype=np.int64 if k in ints else float)
    return out


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


def _as_ids(a: np.ndarray, name: str, path: Path, first: int) -> np.ndarray:
    """Float column -> int64 ids, rejecting non-integer values (error names the line)."""
    ai = np.rint(a).astype(np.int64)
    bad = np.flatnonzero(ai != a)
    if bad.size:
        b = int(bad[0])
        raise GrainmechError(f"{path}:{first + b}: column {name!r}: value {float(a[b])!r} is not an integer id")
    return ai


def _windows(fh: io.RawIOBase, size: int, stop: bytes | None) -> Iterator[bytearray]:
    """Consecutive pieces of a data block, each about ``size`` bytes and whole lines.

    Reads ``fh`` from its position to the end of the file or up to (not including) the
    first line that starts with ``stop`` (the next dump snapshot). A line longer than
    ``size`` makes its piece longer.
    """
    tail = b""
    while True:
        buf = bytearray(size + len(tail))
        buf[:len(tail)] = tail
        got = fh.readinto(memoryview(buf)[len(tail):])
        tot = len(tail) + got
        if tot == 0:
            return
        end = tot if got == 0 else buf.rfind(b"\n", 0, tot) + 1
        if end == 0:  # no line end yet: read on with a larger piece
            tail, size = bytes(buf[:tot]), 2 * size
            continue
        if stop:
            hit = buf.find(b"\n" + stop, 0, end)
            cut = 0 if buf.startswith(stop) else (hit + 1 if hit >= 0 else None)
            if cut is not None:  # the block ends before this line
                del buf[cut:]
                if buf:
                    yield buf
                return
        tail = bytes(buf[end:tot])
        del buf[end:]
        yield buf
        if got == 0:
            return


def _reader_threads() -> int:
    """Worker threads of the pyarrow path: at most 8, the cores this process may use, and pyarrow's count.

    ``pyarrow.cpu_count()`` follows ``OMP_NUM_THREADS`` (set to 1 in a sweep's worker
    processes, :mod:`grainmech.parallel`) and ``pyarrow.set_cpu_count``.
    """
    import pyarrow as pa  # noqa: PLC0415 (optional dependency; only called on the pyarrow path)

    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    return max(1, min(n, int(pa.cpu_count()), 8))


def _read_block_arrow(path: Path, skip_lines: int, names: Sequence[str], want: dict[str, int],
                      count: int | None, delimiter: str | None, stop_prefix: str | None,
                      int_cols: Iterable[str] = (),
                      progress: Callable[[int, int], None] | None = None) -> dict[str, np.ndarray] | None:
    """The wanted columns of a data block parsed by pyarrow's CSV reader on every core.

    The block starts after ``skip_lines`` lines and ends at a line starting with
    ``stop_prefix`` or at the end of the file. It is cut into pieces of whole lines (1/64
    of the block, within ``ARROW_WINDOW_MIN`` ... ``ARROW_WINDOW`` bytes) that worker
    threads parse at the same time (pyarrow releases the GIL), each copied at its row
    offset into arrays allocated once (``count`` known) or concatenated in order at the
    end. At most one piece more than there are threads is held, so the peak memory is the
    kept arrays plus a few pieces. ``progress(done, total)`` is called after each piece
    with the bytes of the file parsed so far and the file's size. Returns None whenever
    the block is not in the simple form this path handles (whitespace other than single
    spaces, a wrong number of fields, a value that is not a number, a short block): the
    caller then runs the line parser, which reports the exact line and column.
    """
    pacsv = _arrow_csv()
    if pacsv is None:
        return None
    import pyarrow as pa  # noqa: PLC0415

    first = skip_lines + 1

    with open(path, "rb") as fh:
        for _ in range(skip_lines):
            fh.readline()
        start = fh.tell()
        head = fh.readline().rstrip(b"\r\n")
        if not head or (stop_prefix and head.startswith(stop_prefix.encode())):
            return None
    if delimiter is None:
        if b"\t" in head or b"  " in head or head.startswith(b" "):
            return None
        sep = " "
    else:
        sep = delimiter
    fields = head.split(sep.encode())
    extra = len(fields) - len(names)
    if extra not in (0, 1) or (extra == 1 and fields[-1].strip()):
        return None  # the line parser reports the column count
    colnames = [f"c{k}" for k in range(len(fields))]
    keys = list(want)
    inc = [colnames[want[k]] for k in keys]
    ints = set(int_cols)
    opts = dict(
        read_options=pacsv.ReadOptions(column_names=colnames, block_size=ARROW_BLOCK, use_threads=False),
        parse_options=pacsv.ParseOptions(delimiter=sep, quote_char=False, double_quote=False,
                                         ignore_empty_lines=False),
        # every column is converted (a non-number anywhere is an error, as in the line
        # parser); only the wanted ones are kept
        convert_options=pacsv.ConvertOptions(
            include_columns=colnames[:len(names)],
            column_types={c: pa.float64() for c in colnames[:len(names)]},
            strings_can_be_null=False, quoted_strings_can_be_null=False, null_values=[]))
    out: dict[str, Any] = _allocate(keys, ints, count) if count is not None else {}

    class _Unsuitable(Exception):
        """A piece this path does not take (the line parser reads the block instead)."""

    def piece(buf: bytearray, before: Future | None, rows: Future) -> dict[str, list[np.ndarray]]:
        """Parse one piece, publish the row offset after it, copy it into the arrays."""
        try:
            try:
                tb = pacsv.read_csv(pa.py_buffer(buf), **opts)
            except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError):
                raise _Unsuitable from None
            del buf
            o0 = before.result() if before is not None else 0
            m = tb.num_rows
            rows.set_result(o0 + m)
        except BaseException as exc:
            rows.set_exception(exc)
            raise
        if count is not None and o0 + m > count:
            raise _Unsuitable
        kept: dict[str, list[np.ndarray]] = {k: [] for k in keys}
        for k, c in zip(keys, inc):
            o = o0
            for chunk in tb.column(c).chunks:
                a = chunk.to_numpy(zero_copy_only=False)
                if k in ints:
                    a = _as_ids(a, names[want[k]], path, first + o)
                if count is not None:
                    out[k][o:o + a.shape[0]] = a
                else:
                    kept[k].append(a)
                o += a.shape[0]
        return kept

    total = max(os.path.getsize(path), 1)
    nthreads = _reader_threads()
    parts: list[dict[str, list[np.ndarray]]] = []
    stop = stop_prefix.encode() if stop_prefix else None
    done_bytes, rows_after = start, None
    with ThreadPoolExecutor(nthreads, thread_name_prefix="grainmech-csv") as pool:
        try:
            flight: list[tuple[Future, int]] = []
            with open(path, "rb", buffering=0) as raw:
                raw.seek(start)
                size = min(ARROW_WINDOW, max(ARROW_WINDOW_MIN, (total - start) // 64))
                for buf in _windows(raw, size, stop):
                    rows: Future = Future()
                    flight.append((pool.submit(piece, buf, rows_after, rows), len(buf)))
                    rows_after = rows
                    del buf
                    while len(flight) > nthreads:
                        fut, nb = flight.pop(0)
                        parts.append(fut.result())
                        done_bytes += nb
                        if progress is not None:
                            progress(done_bytes, total)
            for fut, nb in flight:
                parts.append(fut.result())
                done_bytes += nb
                if progress is not None:
                    progress(done_bytes, total)
        except _Unsuitable:
            return None
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    # hand the Arrow pool's freed blocks back to the system (mimalloc keeps them) before
    # the network is built on top
    pa.default_memory_pool().release_unused()
    n = rows_after.result() if rows_after is not None else 0
    if count is not None:
        return out if n == count else None
    return {k: (np.concatenate([a for p in parts for a in p[k]]) if parts else np.zeros(0)) for k in keys}


def _read_block(rd: _LineReader, names: Sequence[str], want: dict[str, int], count: int | None,
                delimiter: str | None = None, stop_prefix: str | None = None,
                int_cols: Iterable[str] = (),
                progress: Callable[[int, int], None] | None = None) -> tuple[dict[str, np.ndarray], int]:
    """Read ``count`` data rows (or to EOF / a line starting with ``stop_prefix``).

    Returns the wanted columns (by canonical name -> column index) and the line number of
    the first data row.  With pyarrow installed the block is parsed by
    :func:`_read_block_arrow` (same arrays, same checks); the chunked line parser below
    is the fallback and the source of the error messages. ``progress(done, total)`` is
    called with the bytes of the file read so far and its size.
    """
    first = rd.line + 1
    total = max(os.path.getsize(rd.path), 1)
    if not rd._pushed:
        fast = _read_block_arrow(rd.path, rd.line, names, want, count, delimiter, stop_prefix, int_cols,
                                 progress)
        if fast is not None:
            if progress is not None:
                progress(total, total)
            _check_block(fast, names, want, rd.path, first)
            return _int_columns(fast, names, want, set(int_cols), rd.path, first), first
    parts: dict[str, list[np.ndarray]] = {k: [] for k in want}
    cols = list(want.values())
    keys = list(want)
    done = 0
    int_set = set(int_cols)
    while count is None or done < count:
        n = CHUNK_LINES if count is None else min(CHUNK_LINES, count - done)
        line0 = rd.line + 1
        lines = rd.chunk(n)
        if stop_prefix is not None or count is None:
            # cut at a new item / trailing blank lines
            cut = len(lines)
            for k, s in enumerate(lines):
                st = s.strip()
                if (stop_prefix and st.startswith(stop_prefix)) or (count is None and not st):
                    cut = k
                    break
            if cut < len(lines):
                rest = lines[cut:]
                lines = lines[:cut]
                rd.line -= len(rest)
                if count is not None:
                    raise GrainmechError(f"{rd.path}:{rd.line + 1}: expected {count} data rows, found "
                                         f"{done + len(lines)} before {rest[0].strip()[:40]!r}")
                tail = [s for s in rest if s.strip() and not s.lstrip().startswith("#")]
                if tail and not (stop_prefix and tail[0].strip().startswith(stop_prefix)):
                    raise GrainmechError(f"{rd.path}:{rd.line + 1 + rest.index(tail[0])}: data after an "
                                         f"empty line: {tail[0].strip()[:60]!r}")
                if lines:
                    _append_chunk(lines, names, cols, keys, parts, delimiter, rd.path, line0)
                    done += len(lines)
                break
        if not lines:
            if count is not None and done < count:
                raise GrainmechError(f"{rd.path}:{rd.line}: file ends after {done} of {count} data rows")
            break
        _append_chunk(lines, names, cols, keys, parts, delimiter, rd.path, line0)
        done += len(lines)
        if progress is not None:
            progress(min(os.lseek(rd.fh.fileno(), 0, os.SEEK_CUR), total), total)  # bytes read ahead
    if progress is not None:
        progress(total, total)
    out = {k: (np.concatenate(parts[k]) if parts[k] else np.zeros(0)) for k in keys}
    return _int_columns(out, names, want, int_set, rd.path, first), first


def _check_block(cols: dict[str, np.ndarray], names: Sequence[str], want: dict[str, int], path: Path,
                 first: int) -> None:
    """Every value finite, else an error naming the first bad line (in line order)."""
    cols = {k: a for k, a in cols.items() if a.dtype.kind == "f"}
    bad_rows = [int(np.flatnonzero(~np.isfinite(a))[0]) for a in cols.values() if not np.isfinite(a).all()]
    if not bad_rows:
        return
    r = min(bad_rows)
    k = min((c for c in cols if not np.isfinite(cols[c][r])), key=lambda c: want[c])
    raise GrainmechError(f"{path}:{first + r}: column {names[want[k]]!r}: value {float(cols[k][r])!r} "
                         "is not finite")


def _int_columns(out: dict[str, np.ndarray], names: Sequence[str], want: dict[str, int], int_set: set,
                 path: Path, first: int) -> dict[str, np.ndarray]:
    """Convert the id columns to int64, rejecting non-integer values."""
    for k in out:
        if k in int_set and not np.issubdtype(out[k].dtype, np.integer):
            out[k] = _as_ids(out[k], names[want[k]], path, first)
    return out


def _append_chunk(lines, names, cols, keys, parts, delimiter, path, line0) -> None:
    try:
        arr = np.loadtxt(lines, delimiter=delimiter, ndmin=2, dtype=float, comments=None)
    except ValueError:
        _diagnose(lines, names, delimiter, path, line0)
        raise  # pragma: no cover
    if arr.shape[1] != len(names):
        _diagnose(lines, names, delimiter, path, line0)
    sub = arr[:, cols]
    fin = np.isfinite(sub)
    if not fin.all():
        r, c = np.argwhere(~fin)[0]
        raise GrainmechError(f"{path}:{line0 + int(r)}: column {names[cols[c]]!r}: value {float(sub[r, c])!r} "
                             "is not finite")
    for k, c in zip(keys, cols):
        parts[k].append(sub[:, list(cols).index(c)].copy())


# --------------------------------------------------------------------------- dump headers

@dataclass
class _Dump:
    box: Box | None
    count: int | None
    names: list[str]
    timestep: int | None


def _parse_box(rd: _LineReader, item: str) -> Box:
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


def _read_dump_header(rd: _LineReader, data_item: str) -> _Dump:
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
        return [_ALIASES.get(c, c) for c in cols]
    low = [n.lower() for n in names]
    if all(n in _ALIASES for n in low):
        return [_ALIASES[n] for n in low]
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


# --------------------------------------------------------------------------- particles

@dataclass
class _Particles:
    ids: np.ndarray
    pos: np.ndarray
    radii: np.ndarray | None
    box: Box | None
    path: Path
    first_line: int


def _particle_columns(names: list[str], path: Path, line: int) -> dict[str, int]:
    canon = [_PARTICLE_ALIASES.get(n.lower(), n.lower()) for n in names]
    want: dict[str, int] = {}
    for k, c in enumerate(canon):
        if c in ("id", "x", "y", "z", "xs", "ys", "zs", "radius", "diameter") and c not in want:
            want[c] = k
    if "id" not in want:
        raise GrainmechError(f"{path}:{line}: particle table has no 'id' column (columns: {' '.join(names)})")
    have_xyz = all(c in want for c in "xyz")
    have_s = all(c in want for c in ("xs", "ys", "zs"))
    if not (have_xyz or have_s):
        raise GrainmechError(f"{path}:{line}: particle table needs columns x y z (or xu yu zu, xs ys zs); "
                             f"found {' '.join(names)}")
    if have_xyz:
        for c in ("xs", "ys", "zs"):
            want.pop(c, None)
    return want


def _finish_particles(cols: dict[str, np.ndarray], box: Box | None, path: Path, first: int) -> _Particles:
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
    return _Particles(ids, pos, radii, box, path, first)


def _read_particles_dump(path: Path) -> _Particles:
    with _LineReader(path) as rd:
        hd = _read_dump_header(rd, "ATOMS")
        want = _particle_columns(hd.names, path, rd.line)
        cols, first = _read_block(rd, hd.names, want, hd.count, stop_prefix="ITEM:", int_cols=("id",))
    return _finish_particles(cols, hd.box, path, first)


# --------------------------------------------------------------------------- assembling

#: rows per block of the index look-up and branch vectors (bounded temporaries)
_BUILD_BLOCK = 1 << 16


def _lookup(ids_sorted: np.ndarray, order: np.ndarray, q: np.ndarray, path: Path, first: int,
            col: str, ppath: Path) -> np.ndarray:
    """Row of each id of ``q`` in the particle table (blockwise: temporaries stay small).

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


def _build(cols: dict[str, np.ndarray], path: Path, first: int, parts: _Particles | None,
           box: Box | None, force_on: str, source: str) -> ContactNetwork:
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
        parts = _Particles(uid, allpos[idx], None, None, path, first)
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
    ia = _lookup(sid, order, id1, path, first, "id1", parts.path)
    ib = _lookup(sid, order, id2, path, first, "id2", parts.path)
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
    return ContactNetwork(parts.ids, parts.pos, parts.radii, box, ia, ib, f, l_, overlap, cp, kn, ks, source)


_CONTACT_WANT = ("id1", "id2", "fx", "fy", "fz", "x1", "y1", "z1", "x2", "y2", "z2", "cpx", "cpy", "cpz",
                 "delta", "kn", "ks")


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
    with _LineReader(cpath) as rd:
        hd = _read_dump_header(rd, "ENTRIES")
        canon = _liggghts_names(hd.names, keywords, columns, cpath, rd.line, lammps=lammps)
        skip = ("x1", "y1", "z1", "x2", "y2", "z2") if parts is not None else ()
        want = {c: k for k, c in enumerate(canon) if c in _CONTACT_WANT and c not in skip}
        for c in ("id1", "id2", "fx", "fy", "fz"):
            if c not in want:
                raise GrainmechError(f"{cpath}:{rd.line}: the contact dump has no {c!r} column "
                                     f"(columns: {' '.join(hd.names)} read as {' '.join(canon)})")
        cols, first = _read_block(rd, hd.names, want, hd.count, stop_prefix="ITEM:", int_cols=("id1", "id2"),
                                  progress=progress)
    box = hd.box if hd.box is not None else (parts.box if parts else None)
    src = f"{'LAMMPS' if lammps else 'LIGGGHTS'} {cpath}" + (f" + {ppath}" if ppath else "")
    return _build(cols, cpath, first, parts, box, force_on, src)


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


# --------------------------------------------------------------------------- generic table

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
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: np.asarray(z[k]) for k in z.files}
    except (OSError, ValueError) as exc:
        raise GrainmechError(f"{path}: not a readable .npz file ({exc})") from None


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
    point), ``delta`` (overlap), ``kn ks`` (contact stiffness). Particle columns: ``id, x,
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


# --------------------------------------------------------------------------- dispatch

def detect_format(path: str | os.PathLike) -> str:
    """``"npz"``, ``"csv"``, ``"liggghts"`` (any ``ITEM:`` dump) from suffix and first line."""
    p = Path(path)
    if p.suffix.lower() == ".npz":
        return "npz"
    try:
        with open(p, encoding="utf-8", errors="replace") as fh:
            head = fh.readline().strip()
    except FileNotFoundError:
        raise GrainmechError(f"{p}: file not found") from None
    except IsADirectoryError:
        raise GrainmechError(f"{p}: is a directory, not a file") from None
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


# --------------------------------------------------------------------------- writers

def _atomic_write_text(path: Path, write) -> None:
    from grainmech.io.results import atomic_write

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
    for w in [k for k in _KEYWORD_ORDER if k in keywords]:
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
        for s in range(0, C, CHUNK_LINES):
            np.savetxt(fh, data[s:s + CHUNK_LINES], fmt="%.17g")

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
    pcols = {"id": net.ids, "x": net.positions[:, 0], "y": net.positions[:, 1], "z": net.positions[:, 2]}
    if net.radii is not None:
        pcols["radius"] = net.radii
    box = {"cell": net.box.cell, "origin": net.box.origin, "periodic": net.box.periodic}
    for path, data, extra in ((cp, cols, box), (pp, pcols, {})):
        if path.suffix.lower() == ".npz":
            from grainmech.io.results import write_npz

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
            for s in range(0, len(arr), CHUNK_LINES):
                np.savetxt(fh, arr[s:s + CHUNK_LINES], fmt=fmt, delimiter=",")

        _atomic_write_text(path, w)

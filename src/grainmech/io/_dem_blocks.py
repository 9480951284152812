"""Data blocks of DEM files to arrays, and arrays to a contact network (:mod:`grainmech.io.dem`).

The parts every reader of :mod:`grainmech.io.dem` shares: the chunked line reader, the
data-block parsers (pyarrow's CSV reader on every core when pyarrow is installed, else a
NumPy line parser in chunks of :data:`CHUNK_LINES` lines; both keep only the needed
columns), the column aliases, the particle table and the assembly of the contact arrays
into a :class:`~grainmech.network.ContactNetwork` (``_build``). Error messages name the
file, the line, the column and the value.
"""

from __future__ import annotations

import gzip
import io
import itertools
import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.network import Box, ContactNetwork

CHUNK_LINES = 1 << 16


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

def is_gzip(path: str | os.PathLike) -> bool:
    """True for a file whose name ends in ``.gz`` (read through :mod:`gzip`, transparently)."""
    return str(path).lower().endswith(".gz")


def open_text(path: str | os.PathLike, errors: str = "strict") -> io.TextIOWrapper:
    """Open a text file for reading, decompressing it on the fly when its name ends in ``.gz``.

    Errors name the file: a missing file, a directory, and (for ``.gz``) a file that is not
    gzip data are :class:`GrainmechError`.
    """
    try:
        if is_gzip(path):
            fh = gzip.open(path, "rt", encoding="utf-8", errors=errors, newline=None)
            try:
                fh.buffer.peek(1)  # type: ignore[attr-defined]
            except (OSError, EOFError) as exc:
                fh.close()
                raise GrainmechError(f"{path}: not a gzip file ({exc})") from None
            return fh
        return open(path, encoding="utf-8", errors=errors, newline=None)
    except IsADirectoryError:
        raise GrainmechError(f"{path}: is a directory, not a file") from None
    except FileNotFoundError:
        raise GrainmechError(f"{path}: file not found") from None


class _LineReader:
    """Text file (plain, or gzip-compressed when its name ends in ``.gz``) with line numbers (1-based)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fh: io.TextIOWrapper = open_text(path)
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


class _ArrowUnsuitable(Exception):
    """A piece the pyarrow path does not take (the line parser reads the block instead)."""


def _arrow_layout(path: Path, skip_lines: int, n_names: int, delimiter: str | None,
                  stop_prefix: str | None) -> tuple[int, str, list[str]] | None:
    """Where the block starts (byte offset), its separator and the pyarrow column names.

    ``None`` when the first line is not in the simple form the pyarrow path handles (no
    line, the stop line, whitespace other than single spaces, a wrong number of fields).
    """
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
    extra = len(fields) - n_names
    if extra not in (0, 1) or (extra == 1 and fields[-1].strip()):
        return None  # the line parser reports the column count
    return start, sep, [f"c{k}" for k in range(len(fields))]


def _arrow_options(pacsv: Any, pa: Any, colnames: list[str], n_names: int, sep: str) -> dict[str, Any]:
    """The read, parse and convert options of pyarrow for a block (every named column read as float64)."""
    return dict(
        read_options=pacsv.ReadOptions(column_names=colnames, block_size=ARROW_BLOCK, use_threads=False),
        parse_options=pacsv.ParseOptions(delimiter=sep, quote_char=False, double_quote=False,
                                         ignore_empty_lines=False),
        # every column is converted (a non-number anywhere is an error, as in the line
        # parser); only the wanted ones are kept
        convert_options=pacsv.ConvertOptions(
            include_columns=colnames[:n_names],
            column_types={c: pa.float64() for c in colnames[:n_names]},
            strings_can_be_null=False, quoted_strings_can_be_null=False, null_values=[]))


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
    layout = _arrow_layout(path, skip_lines, len(names), delimiter, stop_prefix)
    if layout is None:
        return None
    start, sep, colnames = layout
    keys = list(want)
    inc = [colnames[want[k]] for k in keys]
    ints = set(int_cols)
    opts = _arrow_options(pacsv, pa, colnames, len(names), sep)
    out: dict[str, Any] = _allocate(keys, ints, count) if count is not None else {}

    def piece(buf: bytearray, before: Future | None, rows: Future) -> dict[str, list[np.ndarray]]:
        """Parse one piece, publish the row offset after it, copy it into the arrays."""
        try:
            try:
                tb = pacsv.read_csv(pa.py_buffer(buf), **opts)
            except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError):
                raise _ArrowUnsuitable from None
            del buf
            o0 = before.result() if before is not None else 0
            m = tb.num_rows
            rows.set_result(o0 + m)
        except BaseException as exc:
            rows.set_exception(exc)
            raise
        if count is not None and o0 + m > count:
            raise _ArrowUnsuitable
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
        except _ArrowUnsuitable:
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
    if not rd._pushed and not is_gzip(rd.path):  # the pyarrow path reads raw bytes: plain text only
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
    m = _vector(cols, ("mx", "my", "mz")) if all(c in cols for c in ("mx", "my", "mz")) else None
    if m is not None and force_on == "id1":
        np.negative(m, out=m)  # the moment on A (by B) -> the moment by A on B, as the force
    return ContactNetwork(parts.ids, parts.pos, parts.radii, box, ia, ib, f, l_, overlap, cp, kn, ks, source,
                          moment=m)


_CONTACT_WANT = ("id1", "id2", "fx", "fy", "fz", "x1", "y1", "z1", "x2", "y2", "z2", "cpx", "cpy", "cpz",
                 "delta", "kn", "ks", "mx", "my", "mz")

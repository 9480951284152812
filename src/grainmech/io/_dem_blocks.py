"""Data blocks of DEM files to arrays (:mod:`grainmech.io.dem`).

The parts every reader of :mod:`grainmech.io.dem` shares: the chunked line reader
(:class:`LineReader`), the data-block parser (:func:`read_block`: pyarrow's CSV reader on
every core when pyarrow is installed, else a NumPy line parser in chunks of
:data:`CHUNK_LINES` lines; both keep only the needed columns), the column aliases
(:data:`CONTACT_ALIASES`) and the particle table's columns (:func:`particle_columns`).
The columns become a contact network in :mod:`grainmech.network.tables`. Error messages
name the file, the line, the column and the value.
"""

from __future__ import annotations

import gzip
import io
import itertools
import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.errors import GrainmechError

CHUNK_LINES = 1 << 16


#: aliases of descriptive contact column names -> canonical names
CONTACT_ALIASES = {
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


class LineReader:
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

    def __enter__(self) -> LineReader:
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

    int64 ids, (n, 3) arrays for vector columns (each column a view of the (n, 3) array the network keeps),
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


def read_block(rd: LineReader, names: Sequence[str], want: dict[str, int], count: int | None,
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

def particle_columns(names: list[str], path: Path, line: int) -> dict[str, int]:
    """Canonical particle column -> index in ``names`` (``id``, ``x y z`` or scaled ``xs ys zs``, radius or diameter).

    Raises :class:`~grainmech.errors.GrainmechError` naming the file and the header line
    where ``id`` or the coordinates are missing.
    """
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

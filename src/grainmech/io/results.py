"""Result files, written atomically (a crash never leaves a half-written file).

Every writer goes through :func:`atomic_write`: the data are written to a temporary file
in the target directory and moved into place with :func:`os.replace`. A file system that
is full (or a file-size or disk quota limit reached) raises :class:`StorageFullError`,
one line naming the file, and leaves no temporary file behind.
"""

from __future__ import annotations

import csv
import errno
import io
import json
import os
import tempfile
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np

from grainmech.conventions import ORDER_3D
from grainmech.errors import GrainmechError

__all__ = ["atomic_write", "write_text", "write_json", "write_csv", "write_npz", "write_figure",
           "driver_table", "ensure_dir", "StorageFullError", "storage_full"]

#: errors of a file system that has no room for the data: no space left, a file larger than
#: the process may write (``ulimit -f``, ``RLIMIT_FSIZE``), the user's disk quota exceeded
_FULL = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT})


def storage_full(exc: BaseException) -> bool:
    """True if ``exc`` says that the file system had no room (:data:`_FULL`: ENOSPC, EFBIG, EDQUOT)."""
    return isinstance(exc, StorageFullError) or (isinstance(exc, OSError) and exc.errno in _FULL)


class StorageFullError(GrainmechError):
    """A result file could not be written: no space left, or a file-size or quota limit reached.

    Not an input error: the command line exits with status 1 (``exit_status``).

    Attributes
    ----------
    path : Path
        The file that could not be written.
    reason : str
        The system's words (``"No space left on device"``, ``"File too large"``).
    """

    exit_status = 1

    def __init__(self, path: str | Path, reason: str, note: str = "") -> None:
        self.path, self.reason, self.note = Path(path), reason, note
        super().__init__(f"cannot write {self.path}: {reason} (the disk is full or a file-size or quota limit "
                         "was reached)" + (f"; {note}" if note else ""))

    def __reduce__(self) -> tuple[type, tuple[Path, str, str]]:
        return (type(self), (self.path, self.reason, self.note))


def ensure_dir(path: str | Path) -> Path:
    """Create the folder ``path`` (and parents) if needed; an existing non-folder is an error."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise GrainmechError(f"output path exists and is not a directory: {p}")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GrainmechError(f"cannot create output directory {p}: {exc.strerror}") from None
    return p


def _chmod_default(path: str) -> None:
    """Give a mkstemp file (mode 0600) the permissions of a normally created file."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(path, 0o666 & ~mask)


def atomic_write(path: str | Path, writer: Callable[[Any], None], binary: bool = False,
                 newline: str | None = "") -> Path:
    """Call ``writer(fh)`` on a temporary file next to ``path``, then move it into place.

    The file object is binary if ``binary``, else UTF-8 text with the given ``newline``
    translation (``""``: none, as the csv module wants). The final file gets the usual
    permissions (``0666 & ~umask``).
    """
    p = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    except OSError as exc:
        if storage_full(exc):
            raise StorageFullError(p, exc.strerror or str(exc)) from None
        raise
    try:
        fh: IO[Any] = (os.fdopen(fd, "wb") if binary
                       else os.fdopen(fd, "w", newline=newline, encoding="utf-8"))
        with fh:
            writer(fh)
        _chmod_default(tmp)
        os.replace(tmp, p)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError) and storage_full(exc):
            raise StorageFullError(p, exc.strerror or str(exc)) from None
        raise
    return p


def write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically (:func:`atomic_write`)."""
    return atomic_write(path, lambda fh: fh.write(text))


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if np.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def write_json(path: str | Path, obj: Any) -> Path:
    """JSON with NumPy values converted and non-finite numbers written as null."""
    return atomic_write(path, lambda fh: json.dump(_jsonable(obj), fh, indent=2))


def _cell(v: Any) -> Any:
    """A CSV cell: floats to 10 digits; NaN and infinities as an empty cell (a column beside says why)."""
    if isinstance(v, (float, np.floating)):
        return f"{v:.10g}" if np.isfinite(v) else ""
    return v


def write_csv(path: str | Path, header: Sequence[str], rows: Iterable[Sequence[Any]]) -> Path:
    """Write a CSV file (one ``header`` row, then ``rows``) atomically.

    A value that is not finite (NaN, an unbounded ratio) is written as an empty cell,
    never as ``nan`` or ``inf``: where it can occur the table has a flag column saying why.
    """
    def w(fh: Any) -> None:
        wr = csv.writer(fh)
        wr.writerow(header)
        for r in rows:
            wr.writerow([_cell(v) for v in r])
    return atomic_write(path, w)


def write_figure(path: str | Path, fig: Any, dpi: int = 120) -> Path:
    """A matplotlib figure as PNG (atomically); a pyplot figure is closed afterwards."""
    import matplotlib

    def save(fh: Any) -> None:
        # long lines (a million recorded states) in chunks: Agg refuses one path of that size
        with matplotlib.rc_context({"agg.path.chunksize": 10_000}):
            fig.savefig(fh, format="png", dpi=dpi)
    p = atomic_write(path, save, binary=True)
    if getattr(getattr(fig, "canvas", None), "manager", None) is not None:  # made by pyplot
        import matplotlib.pyplot as plt

        plt.close(fig)
    return p


def write_npz(path: str | Path, **arrays: Any) -> Path:
    """Write ``arrays`` to a compressed ``.npz`` file atomically."""
    def w(fh: Any) -> None:
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        fh.write(buf.getvalue())
    return atomic_write(path, w, binary=True)


def driver_table(result: Any) -> tuple[list[str], np.ndarray]:
    """Columns and rows (one per step) of a :class:`grainmech.driver.DriverResult`.

    Every column name carries its unit in brackets (``stress_xx [Pa]``; ``[-]`` for a
    decimal strain or ratio). Strain uses engineering shear (``gamma_yz = 2 e_yz``...),
    compression positive, decimal (not percent); stress in Pa; energies per unit volume
    (J/m^3); tangent engineering constants ``E_..``, ``G_..`` in Pa, ``nu_..`` [-].
    """
    cols = ["step"] + [f"strain_{c} [-]" for c in ORDER_3D] + [f"stress_{c} [Pa]" for c in ORDER_3D]
    cols += ["sliding_fraction [-]", "open_fraction [-]", "dissipated_energy [J/m^3]", "work [J/m^3]",
             "stored_energy [J/m^3]"]
    data = [np.arange(len(result.stress))[:, None], result.strain, result.stress,
            result.sliding_fraction[:, None], result.open_fraction[:, None], result.dissipation[:, None],
            result.work[:, None], result.stored[:, None]]
    for k, v in sorted(result.engineering.items()):
        cols.append(f"{k} [{'-' if k.startswith('nu') else 'Pa'}]")
        data.append(np.asarray(v)[:, None])
    return cols, np.hstack(data)



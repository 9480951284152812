"""Result files, written atomically (a crash never leaves a half-written file).

Every writer goes through :func:`atomic_write`: the data are written to a temporary file
in the target directory and moved into place with :func:`os.replace`.
"""

from __future__ import annotations

import csv
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
           "driver_table", "soil_path_table", "ensure_dir"]


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
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        fh: IO[Any] = (os.fdopen(fd, "wb") if binary
                       else os.fdopen(fd, "w", newline=newline, encoding="utf-8"))
        with fh:
            writer(fh)
        _chmod_default(tmp)
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
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


def soil_path_table(result: Any) -> tuple[list[str], np.ndarray, str]:
    """The soil-mechanics view of a driver path, one row per step.

    Columns: ``p [Pa]`` (mean stress ``tr(sigma)/3``), ``q [Pa]`` (deviator stress
    ``sqrt(3 J2)``, which is ``sigma_1 - sigma_3`` on a triaxial path), ``q_over_p [-]``,
    ``axial_strain [-]`` (the normal strain along the loading axis: the normal component
    whose stress changed most along the path, else whose strain did), ``volumetric_strain
    [-]`` (``tr(eps)``, compression positive) and ``deviatoric_strain [-]``
    (``sqrt(2/3 e:e)`` of the deviatoric tensor strain ``e``, which is ``2/3 (eps_a -
    eps_r)`` on a triaxial path); all from the initial state, decimal. Returns the
    columns, the rows and the axis name (``"xx"``, ``"yy"`` or ``"zz"``).
    """
    s = np.asarray(result.stress, dtype=float)
    e = np.asarray(result.strain, dtype=float)
    p = s[:, :3].mean(axis=1)
    dev = s[:, :3] - p[:, None]
    j2 = 0.5 * np.sum(dev ** 2, axis=1) + np.sum(s[:, 3:] ** 2, axis=1)
    q = np.sqrt(3.0 * j2)
    de = e - e[0]
    ds = s - s[0]
    score = np.abs(ds[-1, :3]) if np.any(np.abs(ds[-1, :3]) > 0) else np.abs(de[-1, :3])
    axis = int(np.argmax(score))
    ev = de[:, :3].sum(axis=1)
    ed = de[:, :3] - ev[:, None] / 3.0
    eq = np.sqrt(2.0 / 3.0 * (np.sum(ed ** 2, axis=1) + 2.0 * np.sum((de[:, 3:] / 2.0) ** 2, axis=1)))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(p > 0, q / np.where(p > 0, p, 1.0), np.nan)
    cols = ["p [Pa]", "q [Pa]", "q_over_p [-]", "axial_strain [-]", "volumetric_strain [-]",
            "deviatoric_strain [-]"]
    return cols, np.column_stack([p, q, ratio, de[:, axis], ev, eq]), ORDER_3D[axis]

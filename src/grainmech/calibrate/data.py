"""Measured data for calibration: a CSV table read and validated with clear errors.

File format (``docs/calibrate.md``):

* UTF-8 text; lines starting with ``#`` and blank lines are ignored;
* the first other line is the header: comma-separated column names, each optionally
  followed by its unit in square brackets, e.g. ``pressure [psi], G [MPa], void_ratio``;
* every further line holds one number per column.

Values are converted to SI (pint, :mod:`grainmech.io.units`) at reading; a column without
a unit is taken as SI (dimensionless quantities need none). Angles (``alpha``) must carry
their unit (``[deg]`` or ``[rad]``) because both are common in data tables. Every error
names the file, the line, the column and the offending value.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.config import read_text_file
from grainmech.io.schema import pressure_problem
from grainmech.io.units import to_float

__all__ = ["Dataset", "COLUMN_UNITS", "read_csv", "column_unit"]

#: SI target unit of each known column (``None``: dimensionless); other columns are refused.
COLUMN_UNITS: dict[str, str | None] = {
    "pressure": "Pa", "void_ratio": None,
    "G": "Pa", "E": "Pa", "K": "Pa", "nu": None,
    "alpha": "rad",
    "eps_xx": None, "eps_yy": None, "eps_xy": None,
    "strain": None, "G_ratio": None, "damping": None,
}
for _c in ("xx", "yy", "zz", "yz", "xz", "xy"):
    COLUMN_UNITS[f"strain_{_c}"] = None
    COLUMN_UNITS[f"stress_{_c}"] = "Pa"
for _c in ("E_xx", "E_yy", "E_zz", "G_yz", "G_xz", "G_xy"):
    COLUMN_UNITS[_c] = "Pa"
for _c in ("nu_xy", "nu_yx", "nu_xz", "nu_zx", "nu_yz", "nu_zy"):
    COLUMN_UNITS[_c] = None
#: columns of elastic moduli: a measured value must be positive
MODULUS_COLUMNS = frozenset({"G", "E", "K", "E_xx", "E_yy", "E_zz", "G_yz", "G_xz", "G_xy"})
#: aliases accepted in headers
ALIASES = {"G/Gmax": "G_ratio", "g_over_gmax": "G_ratio", "G_over_Gmax": "G_ratio", "D": "damping"}
#: columns whose unit must be written in the header
UNIT_REQUIRED = {"alpha"}


def column_unit(name: str) -> str | None:
    """SI unit of a column (the column of a standard deviation ``sd_X`` has X's unit)."""
    base = name[3:] if name.startswith("sd_") else name
    return COLUMN_UNITS[base]


@dataclass
class Dataset:
    """A validated table in SI units.

    Attributes
    ----------
    path : str
        File name (for messages).
    columns : dict name -> float array (m,)
        SI values.
    units : dict name -> str
        The unit written in the header ("" if none).
    lines : int array (m,)
        Line number of each row in the file (1-based).
    """

    path: str
    columns: dict[str, np.ndarray]
    units: dict[str, str]
    lines: np.ndarray
    order: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return int(self.lines.size)

    def has(self, name: str) -> bool:
        """Whether the table has the column ``name``."""
        return name in self.columns

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def error(self, problem: str, row: int | None = None, column: str | None = None) -> GrainmechError:
        """A GrainmechError naming the file (and line/column if given)."""
        where = self.path if row is None else f"{self.path}, line {int(self.lines[row])}"
        if column is not None:
            where += f", column {column!r}"
            if row is not None:
                where += f" = {float(self.columns[column][row])!r}"
        return GrainmechError(f"{where}: {problem}")


def _parse_header(cell: str, path: str, line: int, col: int) -> tuple[str, str]:
    text = cell.strip()
    unit = ""
    if "[" in text:
        if not text.endswith("]") or text.count("[") != 1:
            raise GrainmechError(f"{path}, line {line}, column {col + 1}: header {cell!r} must be "
                                 "'name' or 'name [unit]'")
        text, unit = text[:-1].split("[")
        text, unit = text.strip(), unit.strip()
    name = ALIASES.get(text, text)
    if not name:
        raise GrainmechError(f"{path}, line {line}, column {col + 1}: empty column name")
    base = name[3:] if name.startswith("sd_") else name
    if base not in COLUMN_UNITS:
        known = ", ".join(sorted(COLUMN_UNITS))
        raise GrainmechError(f"{path}, line {line}: unknown column {text!r} (known: {known}; "
                             "prefix sd_ for a standard deviation)")
    return name, unit


def _factor(unit: str, target: str | None, name: str, path: str, line: int) -> float:
    """Multiplier from ``unit`` to the SI ``target`` (1 if no unit)."""
    if not unit:
        return 1.0

    try:
        return to_float(f"1 {unit}", target, name)
    except ConfigError as exc:
        raise GrainmechError(f"{path}, line {line}, column {name!r}: unit [{unit}] {exc.problem}") from None


def read_csv(path: str | Path, *, required: tuple[str, ...] = (), one_of: tuple[str, ...] = (),
             allowed: tuple[str, ...] | None = None) -> Dataset:
    """Read and validate a data table.

    Parameters
    ----------
    path : str or Path
    required : column names that must be present
    one_of : at least one of these must be present (the fitted quantities)
    allowed : if given, the only accepted column names (``sd_`` columns of allowed ones too)

    Raises
    ------
    GrainmechError
        Missing/empty file, malformed header, unknown, duplicate, missing or disallowed
        columns, a cell that is not a finite number, a wrong number of cells, an ``sd_``
        value or a modulus (``G``, ``E``, ``K``, ``E_xx``...) that is not positive, or a
        pressure outside 1 Pa .. 1 GPa (:data:`grainmech.io.schema.PRESSURE_MIN` ..
        ``PRESSURE_MAX``). The message names file, line, column, value.
    """
    name = str(path)
    text = read_text_file(path, "data")
    header: list[str] | None = None
    units: list[str] = []
    factors: list[float] = []
    rows: list[list[float]] = []
    lines: list[int] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        if not raw.strip() or raw.lstrip().startswith("#"):
            continue
        cells = next(csv.reader([raw]))
        if header is None:
            parsed = [_parse_header(c, name, lineno, i) for i, c in enumerate(cells)]
            header = [h for h, _ in parsed]
            units = [u for _, u in parsed]
            dup = sorted({h for h in header if header.count(h) > 1})
            if dup:
                raise GrainmechError(f"{name}, line {lineno}: column {dup[0]!r} appears more than once")
            for h, u in zip(header, units):
                if h in UNIT_REQUIRED and not u:
                    raise GrainmechError(f"{name}, line {lineno}: column {h!r} needs its unit in the header, "
                                         f"e.g. '{h} [deg]'")
            factors = [_factor(u, column_unit(h), h, name, lineno) for h, u in zip(header, units)]
            continue
        if len(cells) != len(header):
            raise GrainmechError(f"{name}, line {lineno}: {len(cells)} values, expected {len(header)} "
                                 f"({', '.join(header)})")
        row = []
        for h, c, f in zip(header, cells, factors):
            try:
                v = float(c)
            except ValueError:
                raise GrainmechError(f"{name}, line {lineno}, column {h!r}: value {c.strip()!r} "
                                     "is not a number") from None
            if not math.isfinite(v):
                raise GrainmechError(f"{name}, line {lineno}, column {h!r}: value {c.strip()!r} is not finite")
            if h.startswith("sd_") and v <= 0:
                raise GrainmechError(f"{name}, line {lineno}, column {h!r}: value {c.strip()!r}: a standard "
                                     "deviation must be > 0")
            if h in MODULUS_COLUMNS and v <= 0:
                raise GrainmechError(f"{name}, line {lineno}, column {h!r}: value {c.strip()!r}: a measured "
                                     "modulus must be > 0 (a negative one is a sign or column slip)")
            if h == "pressure":
                problem = pressure_problem(v * f)
                if problem is not None:
                    raise GrainmechError(f"{name}, line {lineno}, column 'pressure': value {c.strip()!r}: "
                                         f"{problem}")
            row.append(v * f)
        rows.append(row)
        lines.append(lineno)
    if header is None:
        raise GrainmechError(f"{name}: empty data file (no header line)")
    if not rows:
        raise GrainmechError(f"{name}: no data rows after the header")
    if allowed is not None:
        for h in header:
            base = h[3:] if h.startswith("sd_") else h
            if base not in allowed:
                raise GrainmechError(f"{name}: column {h!r} is not used by this kind of data "
                                     f"(allowed: {', '.join(allowed)})")
    for h in header:
        if h.startswith("sd_") and h[3:] not in header:
            raise GrainmechError(f"{name}: column {h!r} given without the column {h[3:]!r}")
    for r in required:
        if r not in header:
            raise GrainmechError(f"{name}: required column {r!r} is missing (columns: {', '.join(header)})")
    if one_of and not any(c in header for c in one_of):
        raise GrainmechError(f"{name}: no measured column to fit: give at least one of {', '.join(one_of)}")
    arr = np.asarray(rows, dtype=float)
    cols = {h: arr[:, i].copy() for i, h in enumerate(header)}
    return Dataset(name, cols, dict(zip(header, units)), np.asarray(lines), list(header))


def from_arrays(columns: dict[str, Any], name: str = "<arrays>") -> Dataset:
    """A Dataset from SI arrays (for the Python API and tests)."""
    cols = {ALIASES.get(k, k): np.atleast_1d(np.asarray(v, dtype=float)) for k, v in columns.items()}
    sizes = {v.size for v in cols.values()}
    if len(sizes) != 1:
        raise GrainmechError(f"{name}: columns have different lengths {sorted(sizes)}")
    for k, v in cols.items():
        base = k[3:] if k.startswith("sd_") else k
        if base not in COLUMN_UNITS:
            raise GrainmechError(f"{name}: unknown column {k!r}")
        if not np.all(np.isfinite(v)):
            raise GrainmechError(f"{name}: column {k!r} has non-finite values")
    n = sizes.pop()
    return Dataset(name, cols, {k: "" for k in cols}, np.arange(1, n + 1), list(cols))

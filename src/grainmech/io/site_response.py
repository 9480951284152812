"""Modulus-reduction and damping curves for site-response programs (CSV).

File layout (``docs/site-response.md``; the first line is one line, wrapped here)::

    # grainmech modulus-reduction and damping curves | strain: shear strain amplitude gamma
      (engineering shear strain, decimal, NOT percent) | G/Gmax: secant modulus ratio [-] |
      damping: damping ratio D = dW/(4 pi W) (decimal, NOT percent) | Gmax = ... Pa | source: ...
    strain,G/Gmax,damping
    1e-06,0.9995,0.0004
    ...

Strains are strictly increasing and > 0; ``0 < G/Gmax <= 1`` (to a round-off
tolerance); ``0 <= damping < 1``. Site-response programs (pystrata, Strata, DEEPSOIL)
expect decimal strains and decimal damping in their Python APIs; percent in some GUIs -
this file is always decimal and says so in its first line.

The curves come from :func:`grainmech.analysis.modulus_reduction` (secant modulus and
damping ``D = dW / (4 pi W)`` of the last cycle of strain-controlled cyclic simple shear,
``docs/analysis.md``) or from arrays.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.io.config import read_text_file
from grainmech.io.results import atomic_write

__all__ = ["SiteResponseCurves", "curves_from_result", "write_curves", "read_curves", "HEADER"]

HEADER = ("strain", "G/Gmax", "damping")
_G_TOL = 1e-6  # G/Gmax may exceed 1 by round-off only


@dataclass(frozen=True)
class SiteResponseCurves:
    """Curves as read back: arrays (n,), decimal strain and damping.

    ``comment`` is the first line of the file (without ``#``), ``g_max`` the small-strain
    modulus [Pa] if the file states it, else None.
    """

    strain: np.ndarray
    g_ratio: np.ndarray
    damping: np.ndarray
    comment: str = ""
    g_max: float | None = None


def _check(strain: Any, g_ratio: Any, damping: Any, where: str,
           lines: list[int] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    def at(name: str, i: int, a: np.ndarray) -> str:
        """'strain[3] = 0.1' for arrays, 'line 7, column 'strain' = 0.1' for a file."""
        if lines is None:
            return f"{name}[{i}] = {float(a[i])!r}"
        return f"line {lines[i]}, column {name!r} = {float(a[i])!r}"

    s = np.asarray(strain, dtype=float).ravel()
    g = np.asarray(g_ratio, dtype=float).ravel()
    d = np.asarray(damping, dtype=float).ravel()
    if not (s.size == g.size == d.size) or s.size == 0:
        raise GrainmechError(f"{where}: strain, G/Gmax and damping must be non-empty and of equal length "
                             f"(got {s.size}, {g.size}, {d.size})")
    for name, a in (("strain", s), ("G/Gmax", g), ("damping", d)):
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise GrainmechError(f"{where}: {at(name, int(bad[0]), a)} is not finite")
    if np.any(s <= 0):
        i = int(np.flatnonzero(s <= 0)[0])
        raise GrainmechError(f"{where}: {at('strain', i, s)} must be > 0 (decimal strain)")
    inc = np.diff(s)
    if np.any(inc <= 0):
        i = int(np.flatnonzero(inc <= 0)[0])
        raise GrainmechError(f"{where}: strains must be strictly increasing, but {at('strain', i + 1, s)} "
                             f"follows {float(s[i])!r}")
    if np.any(g <= 0) or np.any(g > 1 + _G_TOL):
        i = int(np.flatnonzero((g <= 0) | (g > 1 + _G_TOL))[0])
        raise GrainmechError(f"{where}: {at('G/Gmax', i, g)} must lie in (0, 1]")
    if np.any(d < 0) or np.any(d >= 1):
        i = int(np.flatnonzero((d < 0) | (d >= 1))[0])
        raise GrainmechError(f"{where}: {at('damping', i, d)} must lie in [0, 1) (a decimal ratio, not %)")
    return s, g, d


def curves_from_result(result: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(strain, G/Gmax, damping, Gmax) of a :class:`grainmech.analysis.ModulusReduction`.

    The amplitudes are sorted (the driver runs them in the order given).
    """
    a = np.asarray(result.amplitude, dtype=float)
    o = np.argsort(a, kind="stable")
    return a[o], np.asarray(result.G_ratio, dtype=float)[o], np.asarray(result.damping, dtype=float)[o], \
        float(result.G_max)


def write_curves(path: str | Path, strain: Any = None, g_ratio: Any = None, damping: Any = None, *,
                 result: Any = None, g_max: float | None = None, source: str = "") -> Path:
    """Write the curves as CSV (atomically, :func:`grainmech.io.results.atomic_write`).

    Parameters
    ----------
    path : output file
    strain, g_ratio, damping : arrays (n,), optional
        Shear strain amplitude (decimal), G/Gmax, damping ratio (decimal). Strains must
        increase strictly.
    result : grainmech.analysis.ModulusReduction, optional
        Instead of the arrays (sorted by amplitude; Gmax taken from it).
    g_max : float, optional
        Small-strain shear modulus [Pa], written in the header line.
    source : str
        Free text naming where the curves come from (written in the header line).
    """
    if result is not None:
        if strain is not None or g_ratio is not None or damping is not None:
            raise GrainmechError("give either result or the strain, g_ratio and damping arrays, not both")
        strain, g_ratio, damping, gm = curves_from_result(result)
        g_max = gm if g_max is None else g_max
    elif strain is None or g_ratio is None or damping is None:
        raise GrainmechError("give result or all of strain, g_ratio and damping")
    s, g, d = _check(strain, g_ratio, damping, str(path))
    src = " ".join(str(source).split()).replace("|", "/")
    parts = ["grainmech modulus-reduction and damping curves",
             "strain: shear strain amplitude gamma (engineering shear strain, decimal, NOT percent)",
             "G/Gmax: secant shear modulus / small-strain shear modulus [-]",
             "damping: damping ratio D = dW/(4 pi W) (decimal, NOT percent)"]
    if g_max is not None:
        if not (math.isfinite(g_max) and g_max > 0):
            raise GrainmechError(f"g_max = {g_max!r} must be a positive stress in Pa")
        parts.append(f"Gmax = {g_max:.10g} Pa")
    if src:
        parts.append(f"source: {src}")

    def w(fh: Any) -> None:
        fh.write("# " + " | ".join(parts) + "\n")
        wr = csv.writer(fh, lineterminator="\n")
        wr.writerow(HEADER)
        for row in zip(s, g, d):
            wr.writerow([f"{v:.10g}" for v in row])
    return atomic_write(path, w)


def read_curves(path: str | Path) -> SiteResponseCurves:
    """Read a file written by :func:`write_curves` (validated; errors name file and line)."""
    p = Path(path)
    text = read_text_file(p, "curve")
    comment = ""
    header_seen = False
    rows: list[list[float]] = []
    lines: list[int] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        if not raw.strip():
            continue
        if raw.lstrip().startswith("#"):
            if not comment:
                comment = raw.lstrip()[1:].strip()
            continue
        cells = [c.strip() for c in next(csv.reader([raw]))]
        if not header_seen:
            if tuple(cells) != HEADER:
                raise GrainmechError(f"{p}, line {lineno}: header must be {','.join(HEADER)}, got {raw.strip()!r}")
            header_seen = True
            continue
        if len(cells) != 3:
            raise GrainmechError(f"{p}, line {lineno}: {len(cells)} values, expected 3 ({','.join(HEADER)})")
        row = []
        for name, c in zip(HEADER, cells):
            try:
                row.append(float(c))
            except ValueError:
                raise GrainmechError(f"{p}, line {lineno}, column {name!r}: value {c!r} is not a number") from None
        rows.append(row)
        lines.append(lineno)
    if not header_seen:
        raise GrainmechError(f"{p}: no header line {','.join(HEADER)}")
    if not rows:
        raise GrainmechError(f"{p}: no data rows")
    if "NOT percent" not in comment:
        raise GrainmechError(f"{p}: the first comment line does not state the units (decimal strain and damping); "
                             "not a grainmech curve file")
    a = np.asarray(rows)
    s, g, d = _check(a[:, 0], a[:, 1], a[:, 2], str(p), lines)
    g_max = None
    for part in comment.split("|"):
        part = part.strip()
        if part.startswith("Gmax = ") and part.endswith(" Pa"):
            try:
                g_max = float(part[len("Gmax = "):-3])
            except ValueError:
                raise GrainmechError(f"{p}: cannot read {part!r} in the header line") from None
    return SiteResponseCurves(s, g, d, comment, g_max)

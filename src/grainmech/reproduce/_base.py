"""Common data type of the reproduced figures (no plotting here)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["FigureData", "PSI", "INCH", "progress", "reporting"]

_LOG: list[Callable[[str], None]] = []


def progress(message: str) -> None:
    """Report a progress line from inside a long figure computation.

    A progress line from inside a long figure computation (to the logger installed by
    :func:`reporting`; nothing without one).
    """
    if _LOG:
        _LOG[-1](message)


@contextlib.contextmanager
def reporting(log: Callable[[str], None] | None) -> Iterator[None]:
    """Send :func:`progress` lines to ``log`` within the block."""
    if log is None:
        yield
        return
    _LOG.append(log)
    try:
        yield
    finally:
        _LOG.pop()

#: The seed's Chapter 4 and 6 numbers are in psi and inches; the figures are computed in
#: that consistent unit system (lbf, in, psi) and say so in their labels.
PSI = "psi"
INCH = "in"


@dataclass
class FigureData:
    """Numbers of one reproduced seed figure, ready to plot and to write as CSV.

    Attributes
    ----------
    fig_id : str
        Seed figure number, e.g. ``"4.2"``.
    title : str
        One-line title.
    caption : str
        What the seed reports, the inputs we chose for what it leaves unstated, and how
        our result compares (plain text; HTML-escaped when written).
    table : dict of str -> 1-D array
        Columns of equal length, in "long" form: categorical columns (strings) name the
        series, numeric columns hold the plotted numbers. Written as the figure's CSV.
    meta : dict
        Scalars quoted in the caption (e.g. a fitted exponent), for tests and reports.
    """

    fig_id: str
    title: str
    caption: str
    table: dict[str, np.ndarray]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def stem(self) -> str:
        """File stem, e.g. ``fig4_2``."""
        return "fig" + self.fig_id.replace(".", "_")

    def column(self, name: str, **where: str) -> np.ndarray:
        """Column ``name`` restricted to rows whose categorical columns equal ``where``."""
        mask = np.ones(len(next(iter(self.table.values()))), dtype=bool)
        for key, value in where.items():
            mask &= np.asarray(self.table[key]) == value
        return np.asarray(self.table[name])[mask]

    def rows(self) -> tuple[list[str], list[list[Any]]]:
        """Header and rows for :func:`grainmech.io.results.write_csv`."""
        header = list(self.table)
        cols = [np.asarray(self.table[h]) for h in header]
        n = len(cols[0])
        if any(len(c) != n for c in cols):
            raise ValueError(f"figure {self.fig_id}: table columns differ in length")
        out = []
        for i in range(n):
            out.append([c[i].item() if isinstance(c[i], np.generic) else c[i] for c in cols])
        return header, out


def long_table(blocks: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Concatenate blocks (dicts of scalars/arrays of one length) into one long table."""
    keys = list(blocks[0])
    out: dict[str, list] = {k: [] for k in keys}
    for b in blocks:
        n = max(np.size(v) for v in b.values() if not isinstance(v, str))
        for k in keys:
            v = b[k]
            out[k].append(np.full(n, v, dtype=object) if isinstance(v, str)
                          else np.broadcast_to(np.asarray(v, dtype=float), (n,)))
    return {k: (np.concatenate(v).astype(str) if v[0].dtype == object else np.concatenate(v))
            for k, v in out.items()}

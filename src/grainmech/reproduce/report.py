"""The self-contained ``index.html`` of a reproduction (images embedded as base64)."""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

from grainmech import __version__
from grainmech.io.html import PageSection, write_page
from grainmech.reproduce._base import FigureData

__all__ = ["write_index"]

def write_index(figs: Sequence[FigureData], outdir: str | Path, *, elapsed: float | None = None) -> Path:
    """Write ``outdir/index.html``: each figure's PNG (embedded) next to its caption.

    The PNGs and CSVs must already be in ``outdir`` (``figX_Y.png``, ``figX_Y.csv``).
    """
    out = Path(outdir)
    intro = ("<p>Chang (1988), Ch. 4 and 6, recomputed with grainmech "
             f"{html.escape(__version__)}. Each figure: the PNG, the CSV of the plotted "
             "numbers, and a caption saying what the seed reports, which inputs the seed "
             "leaves unstated and what we chose, and how our result compares. "
             "Units: psi, inch, lbf. Details: <code>docs/reproduce.md</code>.</p>")
    if elapsed is not None:
        intro += f"<p>Computed in {elapsed:.1f} s.</p>"
    sections = [PageSection(f.stem, f"Fig. {f.fig_id}: {f.title}", out / f"{f.stem}.png", f.caption,
                        (f"{f.stem}.png", f"{f.stem}.csv")) for f in figs]
    return write_page(out / "index.html", "Reproduction of the seed report's figures", intro, sections)

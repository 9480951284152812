"""The self-contained ``index.html`` of a reproduction (images embedded as base64)."""

from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Sequence

from grainmech import __version__
from grainmech.reproduce._base import FigureData

__all__ = ["write_index"]

_STYLE = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}
figure{margin:2em 0;border-top:1px solid #ccc;padding-top:1em}
img{max-width:100%;height:auto}figcaption{font-size:0.92em;line-height:1.4}
code{background:#f4f4f4}"""


def write_index(figs: Sequence[FigureData], outdir: str | Path, *, elapsed: float | None = None) -> Path:
    """Write ``outdir/index.html``: each figure's PNG (embedded) next to its caption.

    The PNGs and CSVs must already be in ``outdir`` (``figX_Y.png``, ``figX_Y.csv``).
    """
    from grainmech.io.results import write_text

    out = Path(outdir)
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             "<title>grainmech: reproduction of the seed report's figures</title>",
             f"<style>{_STYLE}</style></head><body>",
             "<h1>Reproduction of the seed report's figures</h1>",
             "<p>Chang (1988), Ch. 4 and 6, recomputed with grainmech "
             f"{html.escape(__version__)}. Each figure: the PNG, the CSV of the plotted "
             "numbers, and a caption saying what the seed reports, which inputs the seed "
             "leaves unstated and what we chose, and how our result compares. "
             "Units: psi, inch, lbf. Details: <code>docs/reproduce.md</code>.</p>"]
    if elapsed is not None:
        parts.append(f"<p>Computed in {elapsed:.1f} s.</p>")
    parts.append("<ul>" + "".join(f"<li><a href='#{f.stem}'>Fig. {f.fig_id}: "
                                  f"{html.escape(f.title)}</a></li>" for f in figs) + "</ul>")
    for f in figs:
        png = out / f"{f.stem}.png"
        data = base64.b64encode(png.read_bytes()).decode("ascii")
        parts.append(
            f"<figure id='{f.stem}'><h2>Fig. {html.escape(f.fig_id)}: {html.escape(f.title)}</h2>"
            f"<img src='data:image/png;base64,{data}' alt='{f.stem}.png'>"
            f"<figcaption>{html.escape(f.caption)}<br>Files: <a href='{f.stem}.png'>{f.stem}.png</a>, "
            f"<a href='{f.stem}.csv'>{f.stem}.csv</a></figcaption></figure>")
    parts.append("</body></html>")
    return write_text(out / "index.html", "\n".join(parts) + "\n")

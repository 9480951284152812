"""Self-contained HTML reports (images embedded as base64, no external assets)."""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from grainmech.io.results import write_text

__all__ = ["PageSection", "write_page"]

_STYLE = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}
figure{margin:2em 0;border-top:1px solid #ccc;padding-top:1em}
img{max-width:100%;height:auto}figcaption{font-size:0.92em;line-height:1.4}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}
code,pre{background:#f4f4f4}pre{padding:0.5em;overflow-x:auto}"""


@dataclass(frozen=True)
class PageSection:
    """One block of a page: heading, optional PNG (embedded), caption text and file links."""

    anchor: str
    heading: str
    png: Path | None = None
    caption: str = ""
    files: Sequence[str] = field(default_factory=tuple)
    raw_html: str = ""


def write_page(path: str | Path, title: str, intro: str, sections: Sequence[PageSection], *,
               toc: bool = True) -> Path:
    """Write an HTML page; ``intro`` and ``raw_html`` are HTML, everything else is escaped."""
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             f"<title>{html.escape(title)}</title>", f"<style>{_STYLE}</style></head><body>",
             f"<h1>{html.escape(title)}</h1>", intro]
    if toc and len(sections) > 1:
        parts.append("<ul>" + "".join(f"<li><a href='#{html.escape(s.anchor)}'>{html.escape(s.heading)}</a></li>"
                                      for s in sections) + "</ul>")
    for s in sections:
        img = ""
        if s.png is not None:
            data = base64.b64encode(Path(s.png).read_bytes()).decode("ascii")
            img = f"<img src='data:image/png;base64,{data}' alt='{html.escape(Path(s.png).name)}'>"
        links = ", ".join(f"<a href='{html.escape(f)}'>{html.escape(f)}</a>" for f in s.files)
        cap = html.escape(s.caption) + (f"<br>Files: {links}" if links else "")
        parts.append(f"<figure id='{html.escape(s.anchor)}'><h2>{html.escape(s.heading)}</h2>{img}"
                     f"{s.raw_html}<figcaption>{cap}</figcaption></figure>")
    parts.append("</body></html>")
    return write_text(path, "\n".join(parts) + "\n")

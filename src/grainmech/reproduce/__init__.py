"""Reproduction of the seed report's figures (``grainmech reproduce``).

Each figure group is one module returning :class:`FigureData` (arrays + caption); the
plots are in :mod:`grainmech.reproduce.plotting`; :func:`reproduce` writes a PNG and a
CSV per figure and a self-contained ``index.html``. See ``docs/reproduce.md``.

Figures (seed numbering): 4.2 (:mod:`.fabric_sections`), 4.3-4.7 (:mod:`.linear_moduli`),
5.2 and 6.1-6.2 (:mod:`.rods`, regular packings A-F; C-F reconstructed),
6.3-6.6 (:mod:`.random_rods`, generated random rod packings),
6.7-6.9 (:mod:`.isotropic_moduli`), 6.10-6.12 (:mod:`.stress_paths`).
"""

from __future__ import annotations

import importlib
import re
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from grainmech.errors import GrainmechError
from grainmech.io.outdir import output_folder
from grainmech.io.results import write_csv
from grainmech.reproduce._base import FigureData, reporting

__all__ = ["FIGURES", "FigureData", "figure_ids", "normalize_id", "build", "reproduce"]

#: seed figure id -> (module, function), in report order
FIGURES: dict[str, tuple[str, str]] = {
    "4.2": ("fabric_sections", "fig4_2"),
    "4.3": ("linear_moduli", "fig4_3"),
    "4.4": ("linear_moduli", "fig4_4"),
    "4.5": ("linear_moduli", "fig4_5"),
    "4.6": ("linear_moduli", "fig4_6"),
    "4.7": ("linear_moduli", "fig4_7"),
    "5.2": ("rods", "fig5_2"),
    "6.1": ("rods", "fig6_1"),
    "6.2": ("rods", "fig6_2"),
    "6.3": ("random_rods", "fig6_3"),
    "6.4": ("random_rods", "fig6_4"),
    "6.5": ("random_rods", "fig6_5"),
    "6.6": ("random_rods", "fig6_6"),
    "6.7": ("isotropic_moduli", "fig6_7"),
    "6.8": ("isotropic_moduli", "fig6_8"),
    "6.9": ("isotropic_moduli", "fig6_9"),
    "6.10": ("stress_paths", "fig6_10"),
    "6.11": ("stress_paths", "fig6_11"),
    "6.12": ("stress_paths", "fig6_12"),
}

_ID = re.compile(r"^(?:fig(?:ure)?[ ._-]?)?(\d+)[._](\d+)$", re.IGNORECASE)


def figure_ids() -> list[str]:
    """All reproducible figure ids, in report order."""
    return list(FIGURES)


def normalize_id(text: str) -> str:
    """``"fig4.2"``, ``"Fig_4_2"``, ``"4.2"`` -> ``"4.2"``.

    Raises
    ------
    GrainmechError
        If the id is not one of :data:`FIGURES`.
    """
    m = _ID.match(str(text).strip())
    fid = f"{int(m.group(1))}.{int(m.group(2))}" if m else None
    if fid not in FIGURES:
        raise GrainmechError(f"unknown figure {text!r}; available: {', '.join(FIGURES)}")
    return fid


def build(fig_id: str) -> FigureData:
    """Compute one figure's data (no files)."""
    fid = normalize_id(fig_id)
    mod, fn = FIGURES[fid]
    func: Callable[[], FigureData] = getattr(importlib.import_module(f"grainmech.reproduce.{mod}"), fn)
    return func()


def reproduce(ids: Sequence[str] | None, outdir: str | Path, *,
              log: Callable[[str], None] | None = None) -> list[FigureData]:
    """Write ``figX_Y.png`` and ``figX_Y.csv`` per figure and ``index.html`` in ``outdir``.

    Parameters
    ----------
    ids : sequence of str or None
        Figure ids (any form accepted by :func:`normalize_id`); None or empty: all.
    outdir : path
        Output directory (created).
    log : callable, optional
        Receives the progress lines (when a figure starts and when it is done; the files
        written are the returned figures' ``stem`` + ``.png``/``.csv`` and ``index.html``).

    Returns
    -------
    list of FigureData, in report order.
    """
    # imported on use, like the figure modules of FIGURES: `import grainmech.reproduce`
    # (and so `grainmech --help`) does not import the figures' code
    from grainmech.reproduce.plotting import plot
    from grainmech.reproduce.report import write_index

    wanted = [normalize_id(i) for i in ids] if ids else list(FIGURES)
    wanted = [f for f in FIGURES if f in set(wanted)]
    figs = []
    t_all = time.perf_counter()
    # the folder is checked and locked before the work; files are staged and moved in at the end
    with output_folder(outdir, "reproduce") as folder:
        out = folder.staging
        for k, fid in enumerate(wanted, 1):
            t0 = time.perf_counter()
            if log:
                log(f"Fig. {fid} ({k}/{len(wanted)}): computing ...")
            with reporting(log):
                fig = build(fid)
            header, rows = fig.rows()
            write_csv(out / f"{fig.stem}.csv", header, rows)
            plot(fig, out / f"{fig.stem}.png")
            figs.append(fig)
            if log:
                log(f"Fig. {fid}: done in {time.perf_counter() - t0:.1f} s")
        write_index(figs, out, elapsed=time.perf_counter() - t_all)
    return figs

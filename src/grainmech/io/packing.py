"""Files of ``grainmech pack``.

Files of ``grainmech pack``: the network (grainmech's generic NPZ tables, read by
``grainmech dem`` and :func:`grainmech.io.dem.read_network`), a JSON summary, the
preparation history (CSV) and a PNG.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from grainmech.io.dem import write_table
from grainmech.io.results import ensure_dir, write_csv, write_figure, write_json, write_text
from grainmech.packing.plotting import packing_figure

__all__ = ["PACK_FILES", "write_pack_outputs"]

#: files written into OUTDIR
PACK_FILES = ("contacts.npz", "particles.npz", "summary.json", "history.csv", "packing.png", "config.toml")


def write_pack_outputs(result: Any, outdir: str | Path, cfg_text: str | None = None, plot: bool = True) -> list[Path]:
    """Write a :class:`grainmech.packing.PackResult` to ``outdir``.

    Write a :class:`grainmech.packing.PackResult` to ``outdir`` (each file atomically,
    all after the computation, so a failed or interrupted run leaves nothing half-written).

    ``contacts.npz`` (``id1 id2 fx fy fz delta`` with the force by id1 on id2, and
    ``cell origin periodic``) and ``particles.npz`` (``id x y z radius``):
    ``grainmech dem OUTDIR/contacts.npz --particles OUTDIR/particles.npz``.
    """
    d = ensure_dir(outdir)
    out = []
    write_table(result.network, d / "contacts.npz", d / "particles.npz")
    out += [d / "contacts.npz", d / "particles.npz"]
    out.append(write_json(d / "summary.json", result.summary))
    out.append(write_csv(d / "history.csv", list(result.history_columns), result.history.tolist()))
    if cfg_text is not None:
        out.append(write_text(d / "config.toml", cfg_text))
    if plot:
        out.append(write_figure(d / "packing.png", packing_figure(result)))
    return out

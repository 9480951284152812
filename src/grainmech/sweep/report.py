"""Summary plot of a sweep (matplotlib, imported lazily): headline outputs against inputs."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from grainmech import plots
from grainmech.io import results
from grainmech.sweep.kinds import SWEEP_KINDS

__all__ = ["summary_plot"]


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def summary_plot(sweep: Any, header: list[str], rows: list[list[Any]], path: Path) -> bool:
    """Scatter plots of the headline outputs against the swept inputs.

    Scatter every headline output of the run kind (e.g. ``G_max`` and ``gamma_r`` for
    ``run``) against every numeric swept input, coloured by the next input. Only
    successful points are drawn. Returns False (no file) if there is nothing to draw.
    """
    ok = [r for r in rows if r[header.index("status")] == "ok"]
    inputs = [p for p in sweep.parameters if p.numeric]
    outputs = [c for c in SWEEP_KINDS[sweep.kind].headline
               if c in header and any(_finite(r[header.index(c)]) for r in ok)]
    if not ok or not inputs or not outputs:
        return False
    import matplotlib.colors
    import matplotlib.ticker

    nr, nc = len(outputs), len(inputs)
    fig, axes = plots.subplots(nr, nc, figsize=(3.6 * nc + 0.8, 2.9 * nr + 0.4), squeeze=False)
    for i, out in enumerate(outputs):
        jo = header.index(out)
        for j, par in enumerate(inputs):
            ax = axes[i][j]
            ji = header.index(par.column)
            pts = [(r[ji], r[jo], r) for r in ok if _finite(r[ji]) and _finite(r[jo])]
            if not pts:
                ax.set_visible(False)
                continue
            x = [p[0] for p in pts]
            y = [p[1] for p in pts]
            other = inputs[(j + 1) % nc] if nc > 1 else None
            if other is not None:
                c = [p[2][header.index(other.column)] for p in pts]
                sc = ax.scatter(x, y, c=c, s=14, cmap="viridis",
                                norm=matplotlib.colors.LogNorm() if other.scale == "log" and min(c) > 0 else None)
                fig.colorbar(sc, ax=ax).set_label(other.column, fontsize=7)
            else:
                order = sorted(range(len(x)), key=x.__getitem__)
                ax.plot([x[k] for k in order], [y[k] for k in order], "o-", ms=3)
            if par.scale == "log" or (par.values is not None and min(x) > 0 and max(x) / min(x) > 50):
                ax.set_xscale("log")
                ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            if out == "gamma_r" and min(y) > 0:
                ax.set_yscale("log")
                ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.set_xlabel(par.column, fontsize=8)
            ax.set_ylabel(out, fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
    fig.suptitle(f"grainmech sweep ({sweep.kind}, {sweep.design}, {len(ok)}/{len(rows)} points ok)", fontsize=9)
    fig.tight_layout()
    results.write_figure(path, fig, dpi=110)
    return True

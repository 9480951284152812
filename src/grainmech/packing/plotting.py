"""Figure of a prepared packing (matplotlib, imported when called)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["packing_figure"]


def packing_figure(result: Any) -> Any:
    """Three panels describing a prepared packing.

    Three panels: the preparation history (mean stress and void ratio against time
    step), the grain-size curve of the packing (percent passing by mass), and a slice of
    the packing (grains cut by the plane ``z = mid-cell``, drawn as circles).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    net = result.network
    s = result.summary
    fig = Figure(figsize=(13, 4.2))
    ax1, ax2, ax3 = fig.subplots(1, 3)
    h = result.history
    if h.size:
        ax1.semilogy(h[:, 0], np.maximum(h[:, 2], 1e-3), label="mean stress [Pa]")
        ax1.axhline(float(np.mean(s["target_stress_Pa"])), color="k", lw=0.6, ls="--", label="target")
        ax1.set_xlabel("time step")
        ax1.set_ylabel("mean stress [Pa]")
        ax1b = ax1.twinx()
        ax1b.plot(h[:, 0], h[:, 3], color="C1", label="void ratio")
        ax1b.set_ylabel("void ratio", color="C1")
        ax1b.set_ylim(max(0.3, float(h[:, 3].min()) - 0.05), min(2.0, float(h[:, 3].max())))
        ax1.legend(loc="lower left", fontsize=8)
    ax1.set_title("preparation")
    d = np.sort(2 * net.radii)
    mass = np.cumsum(d ** 3)
    ax2.semilogx(d * 1e3, 100 * mass / mass[-1], label="packing")
    g = getattr(result, "grading", None)
    if g is not None and hasattr(g, "sizes"):
        ax2.semilogx(np.asarray(g.sizes) * 1e3, 100 * np.asarray(g.passing), "o--", label="sieve curve")
    ax2.set_xlabel("diameter [mm]")
    ax2.set_ylabel("percent passing by mass")
    ax2.legend(fontsize=8)
    ax2.set_title("grain sizes")
    c = net.box.cell
    z0 = net.box.origin[2] + 0.5 * c[2, 2]
    x = net.positions
    for k in range(net.n_particles):
        for dz in (-c[2, 2], 0.0, c[2, 2]):
            h_ = x[k, 2] + dz - z0
            r = net.radii[k]
            if abs(h_) < r:
                ax3.add_patch(Circle((x[k, 0] * 1e3, x[k, 1] * 1e3), np.sqrt(r * r - h_ * h_) * 1e3,
                                     fc="0.7", ec="k", lw=0.3))
    o = net.box.origin * 1e3
    ax3.plot([o[0], o[0] + c[0, 0] * 1e3, o[0] + (c[0, 0] + c[1, 0]) * 1e3, o[0] + c[1, 0] * 1e3, o[0]],
             [o[1], o[1], o[1] + c[1, 1] * 1e3, o[1] + c[1, 1] * 1e3, o[1]], "b-", lw=0.8)
    ax3.set_aspect("equal")
    ax3.autoscale_view()
    ax3.set_xlabel("x [mm]")
    ax3.set_ylabel("y [mm]")
    co = s["coordination"]
    ax3.set_title(f"e = {s['void_ratio']:.3f}, z = {co['z']:.2f} (z_m = {co['z_mechanical']:.2f}), "
                  f"UFR {s['unbalanced_force_ratio']:.1e}", fontsize=9)
    fig.tight_layout()
    return fig

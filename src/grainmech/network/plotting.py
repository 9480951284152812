"""Plots of a contact network (matplotlib through :mod:`grainmech.plots`, imported lazily)."""

from __future__ import annotations

from typing import Any

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.network.data import ContactNetwork
from grainmech.plots import subplots

__all__ = ["plot_rose", "plot_normal_density"]


def plot_rose(net: ContactNetwork, bins: int = 36, weights: str = "count") -> Any:
    """Rose diagrams of the contact normals in the xy, xz and yz planes.

    Each normal (and its opposite) is projected on the plane; the histogram of the in-plane
    angle is drawn in polar axes, weighted by contact count or by the normal force
    (``weights="force"``). Returns a matplotlib ``Figure`` detached from pyplot
    (:func:`grainmech.plots.subplots`); the matplotlib backend is not changed.
    """
    if weights not in ("count", "force"):
        raise GrainmechError(f"weights must be 'count' or 'force', got {weights!r}")
    n = net.normals
    w = np.ones(len(n)) if weights == "count" else np.maximum(net.normal_force, 0.0)
    planes = [("xy", 0, 1), ("xz", 0, 2), ("yz", 1, 2)] if net.dim == 3 else [("xy", 0, 1)]
    fig, axes = subplots(1, len(planes), subplot_kw={"projection": "polar"},
                         figsize=(4 * len(planes), 4), squeeze=False)
    edges = np.linspace(0, 2 * np.pi, bins + 1)
    for ax, (name, a, b) in zip(axes[0], planes):
        ang = np.arctan2(n[:, b], n[:, a])
        ang = np.concatenate([np.mod(ang, 2 * np.pi), np.mod(ang + np.pi, 2 * np.pi)])
        wt = np.concatenate([w, w]) * np.concatenate([np.hypot(n[:, a], n[:, b])] * 2)
        h, _ = np.histogram(ang, edges, weights=wt)
        ax.bar(edges[:-1], h / max(h.max(), 1e-300), width=edges[1] - edges[0], align="edge",
               edgecolor="k", linewidth=0.3)
        ax.set_title(f"{name} plane ({weights})")
        ax.set_yticklabels([])
    fig.tight_layout()
    return fig


def plot_normal_density(net: ContactNetwork, bins: int | None = None) -> Any:
    """Equal-area (Lambert azimuthal, upper hemisphere, z up) density of the contact normals.

    ``n`` and ``-n`` are identified (``n_z >= 0``); the point ``(x, y) = sqrt(2/(1+n_z))
    (n_x, n_y)`` preserves area, so the histogram divided by the uniform expectation is
    the normalised density (1 for an isotropic fabric). 3D only. Returns a ``Figure``.
    """
    from matplotlib.patches import Circle

    if net.dim != 3:
        raise GrainmechError("plot_normal_density is for 3D networks")
    n = net.normals * np.where(net.normals[:, 2:3] < 0, -1.0, 1.0)
    if bins is None:  # about 10 normals per cell on average
        bins = int(np.clip(np.sqrt(4.0 / np.pi * len(n) / 10.0), 6, 60))
    k = np.sqrt(2.0 / (1.0 + n[:, 2]))
    x, y = k * n[:, 0], k * n[:, 1]
    R = np.sqrt(2.0)
    h, xe, ye = np.histogram2d(x, y, bins=bins, range=[[-R, R], [-R, R]])
    cell = (xe[1] - xe[0]) * (ye[1] - ye[0])
    # fraction of each cell inside the projection disc (8 x 8 sub-samples per cell)
    sub = (np.arange(8) + 0.5) / 8
    sx = (xe[:-1, None] + sub[None] * (xe[1] - xe[0])).ravel()
    sy = (ye[:-1, None] + sub[None] * (ye[1] - ye[0])).ravel()
    inside = (sx[:, None] ** 2 + sy[None, :] ** 2 <= R * R).reshape(bins, 8, bins, 8)
    frac = inside.mean(axis=(1, 3))
    expected = len(n) * cell * frac / (np.pi * R * R)
    dens = np.ma.masked_where(frac < 0.25, h / np.where(frac > 0, expected, 1.0))
    fig, ax = subplots(figsize=(5, 4.5))
    im = ax.pcolormesh(xe, ye, dens.T, shading="flat", cmap="viridis")
    ax.add_patch(Circle((0, 0), R, fill=False, color="k", lw=0.8))
    ax.set_aspect("equal")
    ax.set_xlabel("x (equal-area projection)")
    ax.set_ylabel("y")
    ax.set_title("normal density / isotropic\n(equal-area, upper hemisphere, z up)", fontsize=10)
    fig.colorbar(im, ax=ax)
    return fig

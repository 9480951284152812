"""Plots of grainmech results (matplotlib only here, imported lazily).

Every plot function draws into a matplotlib ``Axes`` and returns it: pass ``ax`` to draw
into your own figure (a notebook, a multi-panel figure), or leave it out to draw into the
current pyplot axes; the figures of a contact network (:func:`plot_rose`,
:func:`plot_normal_density`) return their own detached ``Figure``. Nothing here changes
the matplotlib backend or writes files; the command line makes its figures with
:func:`figure` (a ``matplotlib.figure.Figure`` not attached to pyplot, so no display is
needed) and writes them through ``grainmech.io.results.write_figure``.

Example
-------
>>> import matplotlib.pyplot as plt                      # doctest: +SKIP
>>> fig, ax = plt.subplots()                             # doctest: +SKIP
>>> plots.modulus_reduction(mr.amplitude, mr.G_ratio, ax=ax)   # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from grainmech.analysis.stress_path import soil_path_table
from grainmech.conventions import ORDER_3D
from grainmech.errors import GrainmechError
from grainmech.network.data import ContactNetwork

__all__ = ["figure", "subplots", "loops", "modulus_reduction", "damping", "path_histories",
           "soil_path_views", "contact_loops", "plot_rose", "plot_normal_density"]


def _matplotlib() -> Any:
    try:
        import matplotlib
    except ImportError as exc:  # pragma: no cover - depends on environment
        raise GrainmechError("plots need matplotlib (pip install 'grainmech[plot]')") from exc
    return matplotlib


def figure(**kw: Any) -> Any:
    """A matplotlib Figure detached from pyplot.

    A ``matplotlib.figure.Figure`` detached from pyplot (``figsize``, ``dpi``...): it
    needs no display and is freed when dropped (``fig.savefig`` writes it).
    """
    _matplotlib()
    from matplotlib.figure import Figure

    return Figure(**kw)


def subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] | None = None,
             **kw: Any) -> tuple[Any, Any]:
    """``(fig, axes)`` like ``pyplot.subplots`` on a detached :func:`figure`."""
    fig = figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kw)


def _axes(ax: Any) -> Any:
    if ax is not None:
        return ax
    _matplotlib()
    import matplotlib.pyplot as plt

    return plt.gca()


def loops(results: Sequence[Any], amplitudes: Sequence[float] | np.ndarray, *, ax: Any = None, component: int = 4,
          label: str = "xz") -> Any:
    """Stress-strain loops of cyclic runs, every amplitude on one scale.

    Stress-strain loops of cyclic runs, every amplitude on one scale: ``(tau - tau_0) /
    tau_a`` against ``gamma / gamma_a``.

    ``tau_a`` is the largest ``|tau - tau_0|`` of the amplitude's run, ``gamma_a`` its
    strain amplitude; both are given in the legend (``gamma_a`` decimal, ``tau_a`` in kPa)
    so that loops of amplitudes decades apart are all readable.

    Parameters
    ----------
    results : sequence of grainmech.driver.DriverResult
        One per amplitude.
    amplitudes : sequence of float
        Shear strain amplitudes (decimal), used to normalise the strain.
    ax : matplotlib Axes, optional
    component : int
        Voigt index of the shear component (4: xz, library order).
    label : str
        Name of the component in the labels.

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    for r, a in zip(results, amplitudes):
        g = r.strain[:, component] / a
        t = r.stress[:, component] - r.stress[0, component]
        ta = float(np.max(np.abs(t))) or 1.0
        ax.plot(g, t / ta, lw=1, label=f"{a:.1e}  ({ta / 1e3:.3g} kPa)")
    ax.set_xlabel(f"shear strain / amplitude, gamma_{label} / gamma_a [-]")
    ax.set_ylabel(f"shear stress / its amplitude, (tau_{label} - tau_0) / tau_a [-]")
    ax.set_title("Cyclic simple shear loops (normalised)")
    ax.legend(title="gamma_a (tau_a)", fontsize=7, title_fontsize=7)
    ax.grid(alpha=0.3)
    return ax


def _points(ax: Any, x: Any, y: Any, style: str, label: str, hollow: Any) -> None:
    """Markers ``style`` at (x, y) on a log strain axis; those where ``hollow`` is True unfilled.

    The hollow ones (states beyond the envelope of sands, not predictions) get their own
    legend entry "beyond the envelope of sands (hollow)", in the model's marker.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    h = np.zeros(x.shape, dtype=bool) if hollow is None else np.asarray(hollow, dtype=bool)
    if h.shape != x.shape:
        raise GrainmechError(f"hollow has {h.size} entries for {x.size} points")
    (line,) = ax.semilogx(x[~h], y[~h], style, label=label if (~h).any() else f"_{label}")
    if h.any():
        c = line.get_color()
        ax.semilogx(x[h], y[h], style, markerfacecolor="none", markeredgecolor=c,
                    label="beyond the envelope of sands (hollow)")


def modulus_reduction(amplitude: Any, G_ratio: Any, *, ax: Any = None,
                      references: dict[str, tuple[Any, Any]] | None = None,
                      label: str = "grainmech", style: str = "ko", hollow: Any = None) -> Any:
    """G/Gmax against shear strain amplitude, with reference curves.

    G/Gmax against shear strain amplitude (decimal), with reference curves
    ``name -> (gamma, G/Gmax)``; call again on the same Axes (another ``label`` and
    ``style``, no references) to add a model. ``hollow`` (bool per point, optional) draws
    those points unfilled: amplitudes whose states leave the envelope of sands
    (:func:`grainmech.jobs.cyclic_envelope`), not predictions. Returns the Axes.
    """
    ax = _axes(ax)
    _points(ax, amplitude, G_ratio, style, label, hollow)
    for name, (g, r) in (references or {}).items():
        ax.semilogx(g, r, "--", label=name)
    ax.set_xlabel("shear strain amplitude [decimal]")
    ax.set_ylabel("G / Gmax [-]")
    ax.set_ylim(0, 1.05)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return ax


def damping(amplitude: Any, damping_ratio: Any, *, ax: Any = None,
            references: dict[str, tuple[Any, Any]] | None = None, label: str = "grainmech",
            style: str = "ko", hollow: Any = None) -> Any:
    """Damping ratio [%] against shear strain amplitude, with reference curves.

    Damping ratio [%] against shear strain amplitude (decimal), with reference curves
    ``name -> (gamma, D)`` (D decimal); call again on the same Axes to add a model.
    ``hollow`` as in :func:`modulus_reduction`. Returns the Axes.
    """
    ax = _axes(ax)
    _points(ax, amplitude, 100 * np.asarray(damping_ratio), style, label, hollow)
    for name, (g, d) in (references or {}).items():
        ax.semilogx(g, 100 * np.asarray(d), "--", label=name)
    ax.set_xlabel("shear strain amplitude [decimal]")
    ax.set_ylabel("damping ratio [%]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return ax


def recommended_line(amplitude: Any, values: Any, *, ax: Any = None, label: str = "recommended") -> Any:
    """The recommended curve of a run with several models as one line over the models' points.

    ``values`` are G/Gmax or damping [%] at ``amplitude`` (decimal strain), already on the
    curve's one Gmax (:func:`grainmech.outcomes.recommended_curve`). Returns the Axes.
    """
    ax = _axes(ax)
    ax.semilogx(np.asarray(amplitude, dtype=float), np.asarray(values, dtype=float), "-", color="crimson",
                lw=2.0, alpha=0.8, label=label, zorder=1)
    ax.legend(fontsize=8)
    return ax


def path_histories(result: Any, *, axes: Sequence[Any] | None = None) -> Sequence[Any]:
    """Strain and stress components against step number of a driver run.

    Strain (engineering shear) and stress [Pa] components against step number of a
    driver run, in two Axes (given, or two new ones side by side). Returns the two Axes.
    """
    if axes is None:
        _matplotlib()
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    a1, a2 = axes
    steps = np.arange(len(result.stress))
    for k, c in enumerate(ORDER_3D):
        a1.plot(steps, result.strain[:, k], label=c)
        a2.plot(steps, result.stress[:, k], label=c)
    a1.set_ylabel("strain (engineering shear) [-]")
    a2.set_ylabel("stress, compression positive [Pa]")
    for a in (a1, a2):
        a.set_xlabel("step")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    return a1, a2


def soil_path_views(result: Any, *, axes: Sequence[Any] | None = None) -> Sequence[Any]:
    """Soil-mechanics views of a driver path in four Axes.

    The usual soil-mechanics views of a driver path in four Axes: deviator stress ``q``
    and volumetric strain against axial strain, stress ratio ``q/p`` against axial strain,
    and the ``p``-``q`` stress path (quantities of
    :func:`grainmech.analysis.stress_path.soil_path_table`; strains decimal, compression positive,
    stresses in kPa). Returns the four Axes.
    """
    if axes is None:
        _matplotlib()
        import matplotlib.pyplot as plt

        _, axs = plt.subplots(2, 2, figsize=(10, 8))
        axes = axs.ravel()
    a1, a2, a3, a4 = axes
    cols, t, axis = soil_path_table(result)
    p, q, ratio, ea, ev = t[:, 0] / 1e3, t[:, 1] / 1e3, t[:, 2], t[:, 3], t[:, 4]
    xa = f"axial strain eps_{axis} [decimal]"
    a1.plot(ea, q, "-", lw=1.2)
    a1.set_ylabel("deviator stress q [kPa]")
    a2.plot(ea, ev, "-", lw=1.2, color="C1")
    a2.set_ylabel("volumetric strain eps_v [decimal]\n(compression positive)")
    a3.plot(ea, ratio, "-", lw=1.2, color="C2")
    a3.set_ylabel("stress ratio q/p [-]")
    for a in (a1, a2, a3):
        a.set_xlabel(xa)
    a4.plot(p, q, "-", lw=1.2, color="C3")
    a4.plot(p[:1], q[:1], "ko", ms=4, label="start")
    a4.set_xlabel("mean stress p [kPa]")
    a4.set_ylabel("deviator stress q [kPa]")
    a4.legend(fontsize=7)
    for a in axes:
        a.grid(alpha=0.3)
    return a1, a2, a3, a4


def contact_loops(columns: dict[str, Any], *, axes: Sequence[Any] | None = None,
                  force_unit: str = "N") -> Sequence[Any]:
    """One contact's tangential and normal force-displacement curves.

    One contact's tangential force-displacement loop and normal force-approach curve
    (the columns of :class:`grainmech.jobs.ContactOutcome`). Returns the two Axes.
    """
    if axes is None:
        _matplotlib()
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    ax1, ax2 = axes
    ax1.plot(columns["tangential_displacement"], columns["tangential_force"], "-", lw=1.2)
    ax1.set_xlabel("tangential displacement [m]")
    ax1.set_ylabel(f"tangential force [{force_unit}]")
    ax1.set_title("tangential force-displacement")
    ax1.grid(True, alpha=0.3)
    ax2.plot(columns["normal_displacement"], columns["normal_force"], "-", lw=1.2, color="C1",
             marker=".", ms=3)
    ax2.set_xlabel("approach [m]")
    ax2.set_ylabel(f"normal force [{force_unit}]")
    ax2.set_title("normal force-approach")
    ax2.grid(True, alpha=0.3)
    return ax1, ax2


# --------------------------------------------------------------------------- contact networks

def plot_rose(net: ContactNetwork, bins: int = 36, weights: str = "count") -> Any:
    """Rose diagrams of the contact normals in the xy, xz and yz planes.

    Each normal (and its opposite) is projected on the plane; the histogram of the in-plane
    angle is drawn in polar axes, weighted by contact count or by the normal force
    (``weights="force"``). Returns a matplotlib ``Figure`` detached from pyplot
    (:func:`subplots`); the matplotlib backend is not changed.
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

"""Plots of the reproduced figures (matplotlib through :mod:`grainmech.plots`, imported lazily).

One function per seed figure, ``plot(fig, path)`` dispatching on ``fig.fig_id``. The
data come from the figure modules; nothing is computed here.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from grainmech import plots
from grainmech.io import results
from grainmech.reproduce._base import FigureData
from grainmech.reproduce.isotropic_moduli import MEASURED_EXPONENT

__all__ = ["plot"]

_PATH_COLORS = {"compression": "C0", "constant-mean": "C1", "reduced-compression": "C2"}
_METHOD_STYLE = {"state estimate": "-", "path following": "--"}


def _plt() -> Any:
    """``subplots`` / ``figure`` on figures detached from pyplot (no backend is chosen)."""
    return plots


def _save(fig: Any, path: Path) -> Path:
    fig.tight_layout()
    return results.write_figure(path, fig)


def _fig4_2(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.4), subplot_kw={"projection": "polar"})
    labels = {"x=0": ("z", "y"), "y=0": ("z", "x"), "z=0": ("y", "x")}
    for ax, plane in zip(axes, ("x=0", "y=0", "z=0")):
        for fabric, ls in (("transversely isotropic", "-"), ("orthotropic", "-"),
                           ("monoclinic", ":")):
            ang = np.radians(d.column("angle_deg", fabric=fabric, plane=plane))
            ax.plot(ang, d.column("density_4pi", fabric=fabric, plane=plane), ls, lw=1.6,
                    label=fabric)
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        a, b = labels[plane]
        ax.set_title(f"plane {plane}  (0 deg = {a}, 90 deg = {b})", fontsize=9, pad=16)
        # three radial ticks, small, on a white box: readable over the curves
        from matplotlib.ticker import MaxNLocator

        ax.yaxis.set_major_locator(MaxNLocator(3))
        ax.set_rlabel_position(112.5)
        ax.tick_params(axis="y", labelsize=7)
        for lab in ax.get_yticklabels():
            lab.set_bbox({"facecolor": "white", "edgecolor": "none", "alpha": 0.85, "pad": 1})
    handles, labels_ = axes[0].get_legend_handles_labels()
    fig.legend(handles, ["monoclinic (dotted; = orthotropic in x=0, y=0)" if lab == "monoclinic"
                         else lab for lab in labels_], loc="lower center", ncol=3, fontsize=8)
    fig.suptitle("Seed Fig. 4.2: 4 pi xi(n) in three sections")
    fig.tight_layout(rect=(0, 0.1, 1, 0.93))
    return results.write_figure(path, fig)


def _fig4_3(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    k = d.table["ks_kn"]
    ax.plot(k, d.table["E"], "C0-", label="E")
    ax.set_xlabel("Ks / Kn")
    ax.set_ylabel("Young's modulus E [psi] (seed convention)")
    ax2 = ax.twinx()
    ax2.plot(k, d.table["nu"], "C3--", label="nu")
    ax2.set_ylabel("Poisson's ratio nu")
    ax2.set_ylim(0, 0.3)
    ax.legend(handles=ax.get_lines() + ax2.get_lines(), loc="center right")
    ax.set_title("Seed Fig. 4.3: isotropic packing")
    ax.grid(alpha=0.3)
    return _save(fig, path)


def _ks_kn_panels(d: FigureData, path: Path, keys: tuple[str, ...], ylabel: str, title: str) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for ax, fabric in zip(axes, ("transversely isotropic", "orthotropic")):
        k = d.column("ks_kn", fabric=fabric)
        for i, key in enumerate(keys):
            style = ["-", "--", ":"][i]
            ax.plot(k, d.column(key, fabric=fabric), style, label=key.replace("G_xz", "G_zx")
                    .replace("G_yz", "G_zy"))
        ax.set_title(fabric)
        ax.set_xlabel("Ks / Kn")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel(ylabel)
    fig.suptitle(title)
    return _save(fig, path)


def _fig4_7(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for k, style in zip(np.unique(d.table["ks_kn"])[::-1], ("-", "--")):
        sel = d.table["ks_kn"] == k
        a = d.table["a20"][sel]
        for key, c in (("E_zz_ratio", "C0"), ("E_xx_ratio", "C1")):
            axes[0].plot(a, d.table[key][sel], style, color=c,
                         label=f"{key[:4]}/E_iso, Ks/Kn={k:g}")
        for key, c in (("nu_zx_ratio", "C2"), ("nu_xy_ratio", "C3")):
            axes[1].plot(a, d.table[key][sel], style, color=c,
                         label=f"{key[:5]}/nu_iso, Ks/Kn={k:g}")
    for ax, lab in zip(axes, ("Young's modulus ratio", "Poisson's ratio ratio")):
        ax.set_xlabel("a20")
        ax.set_ylabel(lab)
        ax.axhline(1, color="k", lw=0.5)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Seed Fig. 4.7: transversely isotropic / isotropic")
    return _save(fig, path)


def _fig6_7(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    p = d.table["sigma_c"]
    ax.loglog(p, d.table["G_seed"], "C0-",
              label=f"theory, seed convention (slope {d.meta['exponent_seed']:.4f})")
    ax.loglog(p, d.table["G_physical"], "C1--",
              label=f"theory, physical convention (slope {d.meta['exponent_physical']:.4f})")
    g0 = d.table["G_seed"][0]
    ax.loglog(p, g0 * (p / p[0]) ** MEASURED_EXPONENT, "k:",
              label=f"slope {MEASURED_EXPONENT} (measured, seed; guide only)")
    ax.set_xlabel("confining pressure sigma_c [psi]")
    ax.set_ylabel("shear modulus G [psi]")
    ax.set_title("Seed Fig. 6.7: glass balls, e = 0.6 (assumed)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return _save(fig, path)


def _fig6_8(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    e = d.table["void_ratio"]
    names = {"yanagisawa": "Eq. 4.2 Yanagisawa", "smith": "Eq. 4.3 Smith et al.",
             "filep": "Eq. 4.4 Filep", "field": "Eq. 4.5 Field", "chang": "Eq. 6.4 (seed)"}
    for key, lab in names.items():
        ax.plot(e, d.table[f"m_{key}"], "k-" if key == "chang" else "-", lw=2 if key == "chang" else 1,
                label=lab)
    ax.axhline(12, color="gray", ls=":", lw=1, label="12 (kissing number)")
    ax.set_ylim(0, 14)
    ax.set_xlabel("void ratio e")
    ax.set_ylabel("coordination number m")
    ax.set_title("Seed Fig. 6.8: coordination number vs void ratio")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def _fig6_9(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
    t = d.table
    sel_e = t["panel"] == "void ratio"
    for i, s in enumerate(np.unique(t["sigma"][sel_e])):
        sel = sel_e & (t["sigma"] == s)
        c = f"C{i}"
        axes[0].plot(t["void_ratio"][sel], t["G_seed"][sel], "-", color=c, label=f"theory {s:g} psi")
        axes[0].plot(t["void_ratio"][sel], t["G_physical"][sel], "-.", color=c, lw=0.8,
                     label=f"theory {s:g} psi, physical convention")
        axes[0].plot(t["void_ratio"][sel], t["G_hardin_black"][sel], "--", color=c,
                     label=f"Hardin-Black {s:g} psi")
    axes[0].set_xlabel("void ratio e")
    axes[0].set_yscale("log")
    sel = t["panel"] == "pressure"
    axes[1].loglog(t["sigma"][sel], t["G_seed"][sel], "C0-", label="theory, seed convention")
    axes[1].loglog(t["sigma"][sel], t["G_physical"][sel], "C0-.", label="theory, physical")
    axes[1].loglog(t["sigma"][sel], t["G_hardin_black"][sel], "C3--", label="Hardin-Black Eq. 6.3")
    axes[1].set_xlabel("confining stress sigma [psi] (e = 0.6, m = 8)")
    for ax in axes:
        ax.set_ylabel("shear modulus G [psi]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle("Seed Fig. 6.9: Hertz-Mindlin theory (Eq. 6.4 coordination) vs Hardin-Black")
    return _save(fig, path)


def _fig6_10(d: FigureData, path: Path) -> Path:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.6, 5.2))
    for kind, c in _PATH_COLORS.items():
        ax.plot(d.column("sigma3", path=kind), d.column("sigma1", path=kind), color=c, label=kind)
    s3 = np.linspace(0, 12, 2)
    ax.plot(s3, d.meta["R_star"] * s3, "k:", lw=1, label=f"sigma1 = {d.meta['R_star']:.3f} sigma3")
    ax.plot(10, 10, "ko")
    ax.set_xlim(0, 12)
    ax.set_ylim(0, 42)
    ax.set_xlabel("sigma3 = sigma2 [psi]")
    ax.set_ylabel("sigma1 (z) [psi]")
    ax.set_title("Seed Fig. 6.10: stress paths")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def _ratio_panels(d: FigureData, path: Path, keys: tuple[str, ...], labels: tuple[str, ...],
                  title: str) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(1, len(keys), figsize=(5.2 * len(keys), 4.4))
    for ax, key, lab in zip(axes, keys, labels):
        for kind, c in _PATH_COLORS.items():
            for method, ls in _METHOD_STYLE.items():
                ax.plot(d.column("ratio", method=method, path=kind),
                        d.column(key, method=method, path=kind), ls, color=c,
                        label=f"{kind}, {method}")
        ax.axvline(d.meta["R_star"], color="k", ls=":", lw=1)
        ax.set_xlabel("sigma1 / sigma3")
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title + f"  (dotted: R* = {d.meta['R_star']:.3f})")
    return _save(fig, path)


def _polar(d: FigureData, path: Path, key: str, title: str) -> Path:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 6.0), subplot_kw={"projection": "polar"})
    styles = ["-", "--", "-.", ":", "-", "--"]
    for i, pk in enumerate(dict.fromkeys(d.table["packing"])):
        ax.plot(np.radians(d.column("alpha_deg", packing=pk)), d.column(key, packing=pk),
                styles[i % len(styles)], color=f"C{i}", lw=1.8 if i < 2 else 1.3, label=pk)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_title(title + "\n(alpha from y towards x; C-F reconstructed)", fontsize=10)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.12, -0.2), fontsize=7, ncol=2)
    return _save(fig, path)


def _fig5_2(d: FigureData, path: Path) -> Path:
    plt = _plt()
    from matplotlib.patches import Circle
    packs = list(dict.fromkeys(d.table["packing"]))
    fig, axes = plt.subplots(2, 3, figsize=(11, 7.6))
    for ax, pk in zip(axes.ravel(), packs):
        for x, y, dia in zip(d.column("x", packing=pk, item="rod"), d.column("y", packing=pk, item="rod"),
                             d.column("diameter", packing=pk, item="rod")):
            ax.add_patch(Circle((x, y), dia / 2, fc="0.85", ec="0.2", lw=0.8))
        xs, ys = d.column("x", packing=pk, item="contact"), d.column("y", packing=pk, item="contact")
        x2, y2 = d.column("x2", packing=pk, item="contact"), d.column("y2", packing=pk, item="contact")
        for a, b, c, e in zip(xs, ys, x2, y2):
            ax.plot([a, c], [b, e], "C3-", lw=0.8)
        ax.plot(d.column("x", packing=pk, item="cell"), d.column("y", packing=pk, item="cell"),
                "C0--", lw=1.2)
        ax.set_xlim(0, 2)
        ax.set_ylim(0, 2)
        ax.set_aspect("equal")
        ax.set_title(pk + ("" if pk[0] in "AB" else "  [reconstruction]"), fontsize=9)
        ax.set_xlabel("x [in]", fontsize=8)
        ax.tick_params(labelsize=7)
    fig.suptitle("Seed Fig. 5.2: six regular rod packings (C-F reconstructed; lines: contacts, "
                 "dashed: unit cell)", fontsize=10)
    return _save(fig, path)


def _rose(d: FigureData, path: Path, title: str) -> Path:
    plt = _plt()
    from matplotlib.patches import Circle
    fig = plt.figure(figsize=(11, 5.2))
    ax = fig.add_subplot(1, 2, 1, projection="polar")
    ang = np.radians(d.column("angle_deg", item="rose"))
    frac = d.column("fraction", item="rose")
    width = 2 * np.pi / len(ang)
    ax.bar(ang, frac, width=width, bottom=0, color="C0", alpha=0.6, edgecolor="C0")
    ax.plot(np.linspace(0, 2 * np.pi, 200), np.full(200, 1 / len(ang)), "k:", lw=1,
            label="isotropic")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_title("fraction of branch vectors per 10 deg (from y)", fontsize=9)
    ax.legend(loc="lower left", fontsize=8)
    ax2 = fig.add_subplot(1, 2, 2)
    for x, y, dia in zip(d.column("x", item="rod"), d.column("y", item="rod"),
                         d.column("diameter", item="rod")):
        ax2.add_patch(Circle((x, y), dia / 2, fc="0.8", ec="0.2", lw=0.5))
    box = d.meta["box_in"]
    ax2.plot([0, box, box, 0, 0], [0, 0, box, box, 0], "C0--", lw=1)
    ax2.set_xlim(-0.3, box + 0.3)
    ax2.set_ylim(-0.3, box + 0.3)
    ax2.set_aspect("equal")
    ax2.set_title(f"generated packing (periodic cell {box:.2f} in); "
                  f"m = {d.meta['coordination']:.2f}, e = {d.meta['void_ratio']:.3f}", fontsize=9)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def _strains(d: FigureData, path: Path, title: str) -> Path:
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4), sharex=True)
    sets = list(dict.fromkeys(d.table["constants"]))
    for ax, key in zip(axes, ("eps_xx", "eps_yy", "eps_xy")):
        for i, name in enumerate(sets):
            ax.plot(d.column("alpha_deg", constants=name), 1e4 * d.column(key, constants=name),
                    ["-", "--", ":"][i % 3], color=f"C{i}", label=name)
        ax.set_xlabel("alpha [deg] (major principal stress from y)")
        ax.set_ylabel(f"{key} [1e-4] (compression +)")
        ax.axhline(0, color="k", lw=0.5)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


_PLOTTERS: dict[str, Callable[[FigureData, Path], Path]] = {
    "4.2": _fig4_2,
    "4.3": _fig4_3,
    "4.4": lambda d, p: _ks_kn_panels(d, p, ("E_xx", "E_yy", "E_zz"),
                                      "Young's modulus [psi] (seed convention)", "Seed Fig. 4.4"),
    "4.5": lambda d, p: _ks_kn_panels(d, p, ("nu_zx", "nu_zy", "nu_xy"), "Poisson's ratio",
                                      "Seed Fig. 4.5"),
    "4.6": lambda d, p: _ks_kn_panels(d, p, ("G_xz", "G_yz", "G_xy"),
                                      "shear modulus [psi] (seed convention)", "Seed Fig. 4.6"),
    "4.7": _fig4_7,
    "5.2": _fig5_2,
    "6.1": lambda d, p: _polar(d, p, "E", "Seed Fig. 6.1: apparent modulus [psi]"),
    "6.2": lambda d, p: _polar(d, p, "nu", "Seed Fig. 6.2: apparent Poisson's ratio"),
    "6.3": lambda d, p: _rose(d, p, "Seed Fig. 6.3: branch vectors, one-size random packing (generated)"),
    "6.4": lambda d, p: _rose(d, p, "Seed Fig. 6.4: branch vectors, two-size random packing (generated)"),
    "6.5": lambda d, p: _strains(d, p, "Seed Fig. 6.5: strains vs alpha, one-size random packing "
                                 "(2.5 psi + 0.5 psi along alpha)"),
    "6.6": lambda d, p: _strains(d, p, "Seed Fig. 6.6: strains vs alpha, two-size random packing "
                                 "(2.5 psi + 0.5 psi along alpha)"),
    "6.7": _fig6_7,
    "6.8": _fig6_8,
    "6.9": _fig6_9,
    "6.10": _fig6_10,
    "6.11": lambda d, p: _ratio_panels(d, p, ("E_zz", "E_xx"),
                                       ("E_zz [psi]", "E_xx [psi]"), "Seed Fig. 6.11"),
    "6.12": lambda d, p: _ratio_panels(d, p, ("G_xz", "G_xy", "sliding"),
                                       ("G_zx [psi]", "G_xy [psi]", "fraction of sliding contacts"),
                                       "Seed Fig. 6.12"),
}


def plot(fig: FigureData, path: str | Path) -> Path:
    """Write the PNG of a reproduced figure."""
    try:
        fn = _PLOTTERS[fig.fig_id]
    except KeyError:
        fn = _PLOTTERS[fig.fig_id.split("-")[0]]
    return fn(fig, Path(path))

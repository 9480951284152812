"""Figures of a soil profile (matplotlib, imported lazily): the profile and the site response.

Each function builds a detached figure from the layer records of
:func:`grainmech.site.layer.run_task` and returns it; :mod:`grainmech.io.site_profile`
writes it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainmech import plots

__all__ = ["profile_figure", "response_figure"]


def _steps(records: list[dict], key: str, scale: float = 1.0) -> tuple[list[float], list[float]]:
    """Depth and value of a per-layer quantity as a staircase (constant over each layer)."""
    z: list[float] = []
    v: list[float] = []
    for r in records:
        x = r.get(key)
        x = float("nan") if x is None else float(x) * scale
        z += [r["top_m"], r["bottom_m"]]
        v += [x, x]
    return z, v


def profile_figure(records: list[dict], water_table: float) -> Any:
    """Vs, effective stresses and Gmax against depth; every layer's curves coloured by depth.

    Top row: Vs of the model (and the measured Vs where given) [m/s]; the effective
    vertical and mean stress at mid-depth [kPa]; Gmax of the model [MPa]. Bottom row:
    G/Gmax and damping of every layer (markers: the models' points, circles the packing
    model's, squares the DEM model's, triangles the affine model's; solid: the modified
    hyperbola fitted to them; dashed: Darendeli 2001; dotted: Menq 2003; both at the
    layer's mean effective stress), coloured by the depth of the layer's middle.
    """
    import matplotlib.cm
    import matplotlib.colors

    fig = plots.figure(figsize=(13.0, 9.0))
    top = fig.subplots(1, 3, sharey=True, gridspec_kw={"bottom": 0.55, "top": 0.93})
    bottom = fig.subplots(1, 2, gridspec_kw={"top": 0.45, "bottom": 0.07})
    depth = max(r["bottom_m"] for r in records)
    z, v = _steps(records, "vs_model_m_s")
    top[0].plot(v, z, color="C0", label="model")
    if any(r.get("vs_measured_m_s") for r in records):
        z, v = _steps(records, "vs_measured_m_s")
        top[0].plot(v, z, "k--", label="measured (anchored)")
    top[0].set_xlabel("Vs [m/s]")
    top[0].set_ylabel("depth [m]")
    mid = [r["mid_m"] for r in records]
    top[1].plot([r["sigma_v_eff_Pa"] / 1e3 for r in records], mid, "o-", label="sigma'_v")
    top[1].plot([r["p_eff_Pa"] / 1e3 for r in records], mid, "s-", label="p' (mean)")
    top[1].set_xlabel("effective stress at mid-depth [kPa]")
    z, v = _steps(records, "G_max_Pa", 1e-6)
    top[2].plot(v, z, color="C2")
    top[2].set_xlabel("Gmax [MPa]")
    for ax in top:
        ax.set_ylim(depth, 0)
        ax.grid(alpha=0.3)
        if np.isfinite(water_table) and water_table <= depth:
            ax.axhline(water_table, color="C9", lw=1, ls=":")
    top[0].legend(fontsize=8)
    top[1].legend(fontsize=8, title=("water table: dotted" if np.isfinite(water_table) else None),
                  title_fontsize=8)
    norm = matplotlib.colors.Normalize(0, depth)
    cmap = matplotlib.colormaps["viridis_r"]
    for r in records:
        c = cmap(norm(r["mid_m"]))
        amps = np.asarray(r.get("amplitudes") or [], dtype=float)
        models = np.asarray(r.get("models") or ["?"] * len(amps))
        for m, mk in (("packing", "o"), ("dem", "s"), ("affine", "^")):
            k = models == m
            if k.any():
                bottom[0].semilogx(amps[k], np.asarray(r["G_ratio"])[k], mk, color=c, ms=5)
                bottom[1].semilogx(amps[k], np.asarray(r["damping"])[k] * 100, mk, color=c, ms=5)
        sc = r.get("site_curve") or {}
        if sc.get("strain"):
            bottom[0].semilogx(sc["strain"], sc["G_ratio"], "-", color=c, label=f"{r['name']} ({r['mid_m']:g} m)")
            bottom[1].semilogx(sc["strain"], np.asarray(sc["damping"]) * 100, "-", color=c)
        d = r.get("darendeli")
        if d:
            bottom[0].semilogx(d["strain"], d["G_ratio"], "--", color=c, lw=1)
            bottom[1].semilogx(d["strain"], np.asarray(d["damping"]) * 100, "--", color=c, lw=1)
        mq = r.get("menq")
        if mq:
            bottom[0].semilogx(mq["strain"], mq["G_ratio"], ":", color=c, lw=1.2)
            bottom[1].semilogx(mq["strain"], np.asarray(mq["damping"]) * 100, ":", color=c, lw=1.2)
    bottom[0].set_ylabel("G/Gmax")
    bottom[1].set_ylabel("damping [%]")
    for ax in bottom:
        ax.set_xlabel("shear strain amplitude [decimal]")
        ax.grid(alpha=0.3, which="both")
    for ax in bottom:
        ax.set_xlim(1e-7, 1e-1)
    bottom[0].legend(fontsize=8, title="points: packing o, DEM s; fitted hyperbola (solid);\n"
                     "Darendeli 2001 (dashed); Menq 2003 (dotted)", title_fontsize=8)
    fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=list(bottom), label="depth of layer middle [m]")
    fig.suptitle("Soil profile: stresses, Gmax and curves of every layer")
    return fig


def response_figure(response: dict) -> Any:
    """Site response of both runs on one page.

    Surface response spectra (5 % damping) [g], maximum shear strain [%] and PGA [g]
    against depth, for the grains' curves (the fitted hyperbolae), Darendeli's and Menq's (``response`` from
    :func:`grainmech.site.strata.site_response`).
    """
    fig, ax = plots.subplots(1, 3, figsize=(14.0, 5.0))
    styles = {"grainmech": ("C0", "-"), "darendeli": ("C3", "--"), "menq": ("C2", ":")}
    for name, run in response["runs"].items():
        col, ls = styles.get(name, ("k", "-"))
        lab = run["label"]
        ax[0].semilogx(run["periods_s"], run["spectrum_g"], color=col, ls=ls, label=lab)
        ax[1].plot(np.asarray(run["max_strain"]) * 100, run["strain_depth_m"], color=col, ls=ls, label=lab)
        ax[2].plot(run["pga_g"], run["pga_depth_m"], color=col, ls=ls, label=lab)
    inp = response.get("input_spectrum_g")
    if inp is not None:
        ax[0].semilogx(response["runs"][next(iter(response["runs"]))]["periods_s"], inp, color="0.5", lw=1,
                       label="input (outcrop)")
    ax[0].set_xlabel("period [s]")
    ax[0].set_ylabel("surface spectral acceleration, 5 % damping [g]")
    ax[1].set_xlabel("maximum shear strain [%]")
    ax[2].set_xlabel("PGA [g]")
    for a in ax[1:]:
        a.set_ylabel("depth [m]")
        a.invert_yaxis()
    for a in ax:
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=8)
    fig.suptitle(f"Equivalent-linear site response (pystrata {response.get('pystrata_version', '')}): "
                 "the grains' curves vs Darendeli's and Menq's")
    fig.tight_layout()
    return fig

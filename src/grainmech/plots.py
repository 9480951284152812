"""Plots (matplotlib only here, imported lazily; Agg backend, files only)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from grainmech.errors import GrainmechError


def _plt():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on environment
        raise GrainmechError("plots need matplotlib (pip install 'grainmech[plot]')") from exc
    return plt


def _save(fig: Any, path: str | Path) -> Path:
    from grainmech.io.results import atomic_write

    p = Path(path)
    atomic_write(p, lambda fh: fig.savefig(fh, format="png", dpi=120), binary=True)
    _plt().close(fig)
    return p


def loops(results: Sequence[Any], amplitudes: Sequence[float], path: str | Path, component: int = 4,
          label: str = "xz") -> Path:
    """Stress-strain loops (shear component ``component``) of several cyclic runs."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for r, a in zip(results, amplitudes):
        g = r.strain[:, component] / a
        ax.plot(g, r.stress[:, component] - r.stress[0, component], lw=1, label=f"{a:.1e}")
    ax.set_xlabel(f"gamma_{label} / amplitude")
    ax.set_ylabel(f"tau_{label} - tau_0 [Pa]")
    ax.set_title("Cyclic simple shear loops (normalised strain)")
    ax.legend(title="amplitude", fontsize=7)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def modulus_reduction(amplitude: np.ndarray, G_ratio: np.ndarray, damping: np.ndarray, path: str | Path,
                      references: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None) -> Path:
    """G/Gmax and damping ratio against amplitude, with reference curves ``name -> (gamma, G/Gmax, D)``."""
    plt = _plt()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.2))
    a1.semilogx(amplitude, G_ratio, "ko-", label="grainmech")
    a2.semilogx(amplitude, 100 * damping, "ko-", label="grainmech")
    for name, (g, r, d) in (references or {}).items():
        a1.semilogx(g, r, "--", label=name)
        a2.semilogx(g, 100 * d, "--", label=name)
    a1.set_ylabel("G / Gmax")
    a2.set_ylabel("damping ratio [%]")
    for a in (a1, a2):
        a.set_xlabel("shear strain amplitude")
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=8)
    a1.set_ylim(0, 1.05)
    fig.tight_layout()
    return _save(fig, path)


def path_plot(result: Any, path: str | Path) -> Path:
    """Stress and strain histories of a driver run."""
    from grainmech.conventions import ORDER_3D

    plt = _plt()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.2))
    steps = np.arange(len(result.stress))
    for k, c in enumerate(ORDER_3D):
        a1.plot(steps, result.strain[:, k], label=c)
        a2.plot(steps, result.stress[:, k], label=c)
    a1.set_ylabel("strain (engineering shear)")
    a2.set_ylabel("stress [Pa]")
    for a in (a1, a2):
        a.set_xlabel("step")
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)

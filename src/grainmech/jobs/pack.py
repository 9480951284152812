"""``grainmech pack``: a packing of grains prepared with LAMMPS."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.pack_config import build_pack_config
from grainmech.jobs.progress import PACKING_PROGRESS_EVERY, Heartbeat
from grainmech.packing import prepare_packing

__all__ = ["pack_job"]


class _LastLine:
    """A preparation's progress lines passed on, the last one kept for the heartbeat (:class:`Heartbeat`).

    :func:`grainmech.packing.prepare_packing` says a line between chunks of LAMMPS time
    steps; a chunk of a very large packing can take longer than
    :data:`PACKING_PROGRESS_EVERY` s, and :meth:`repeat` then gives the last line again
    with the seconds since it.
    """

    def __init__(self, say: Callable[[str], None]) -> None:
        self.inner, self.when, self.text = say, time.perf_counter(), ""

    def say(self, msg: str) -> None:
        self.when, self.text = time.perf_counter(), msg
        self.inner(msg)

    def repeat(self) -> str | None:
        quiet = time.perf_counter() - self.when
        if quiet < PACKING_PROGRESS_EVERY or not self.text:
            return None
        return f"  (LAMMPS busy with one chunk of time steps for {quiet:.0f} s; the last line:) {self.text.strip()}"


def pack_job(cfg: dict, progress: Callable[[str], None] | None = None) -> Any:
    """Config dict -> prepared packing (:class:`grainmech.packing.PackResult`) with LAMMPS.

    Reads the config with :func:`grainmech.io.pack_config.build_pack_config`, samples the radii
    from the grading (what was cut is in ``summary["grading"]``), prepares the packing
    (:func:`grainmech.packing.prepare_packing`). Writes nothing. ``progress`` gets the
    preparation's lines, and a line at least every :data:`PACKING_PROGRESS_EVERY` s
    while LAMMPS runs (:class:`_LastLine`).
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
    if progress is None:
        res = prepare_packing(sample.radii, pc.material, pc.settings)
    else:
        last = _LastLine(progress)
        with Heartbeat(progress, last.repeat):
            res = prepare_packing(sample.radii, pc.material, pc.settings, progress=last.say)
    res.summary["grading"] = {"kind": type(pc.grading).__name__, "d_min_m": sample.d_min,
                              "d_max_m": sample.d_max, "cut_fines_mass_fraction": sample.cut_fines,
                              "cut_coarse_mass_fraction": sample.cut_coarse,
                              "max_size_ratio": pc.max_size_ratio}
    res.grading = pc.grading
    return res

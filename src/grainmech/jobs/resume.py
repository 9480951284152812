"""Taking up a run's finished amplitudes and paths (``grainmech run --resume``).

Each amplitude of a model's cyclic series starts from the same initial state, so a
finished one does not depend on the others: :func:`reusable` finds those saved by an
earlier run of the same config (:class:`grainmech.io.records.RunRecords`), the series
runs the rest, and :func:`merged` puts the two together through the series itself
(:func:`grainmech.driver.loop.cyclic_series` with each amplitude's run looked up, not
run): the loops, secant moduli, damping, messages and the end of a series at a hand-over
(``until``) are those of one uninterrupted series, value for value. :func:`saver` saves
each amplitude the moment the series reports it.

A path is one run: a model's finished path is taken up whole. Each model's path is also
saved at the end of each segment (:class:`grainmech.driver.loop.PathCheckpoint`: the
affine point, :mod:`grainmech.driver.packing.resume`, the DEM model's LAMMPS restart file,
:meth:`grainmech.driver.dem.DemPoint.saved_state`, on several MPI ranks too) and goes on
from the last one saved.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.driver.loop import ModulusReduction, cyclic_series
from grainmech.driver.registry import MODELS
from grainmech.io.records import RECORDS_DIR, RunRecords, amp_id, normal_config

__all__ = ["run_records", "reusable", "merged", "saver", "listed"]


def listed(amplitudes: Any) -> str:
    """``"1e-06, 1e-05, 0.0001"``: amplitudes for a message."""
    return ", ".join(f"{float(a):g}" for a in amplitudes)


def reusable(records: RunRecords | None, model: str, amplitudes: list[float],
             until: Callable[[float, Any], str | None] | None = None
             ) -> tuple[dict[float, tuple[Any, float]], list[float]]:
    """The saved amplitudes of ``model`` among ``amplitudes`` and the amplitudes left to run.

    Returns ``kept`` (``amp_id(a) -> (result, G_max)``) and the amplitudes without a saved
    run, in their order. With ``until`` (a series that ends at a hand-over), a saved
    amplitude at which the series ends is the last one: the larger ones are not part of
    the series, saved or not.
    """
    kept: dict[float, tuple[Any, float]] = {}
    todo: list[float] = []
    for i, a in enumerate(amplitudes):
        got = records.get(model, a) if records is not None else None
        if got is None:
            todo.append(a)
            continue
        r, meta = got
        kept[amp_id(a)] = (r, float(meta.get("G_max", float("nan"))))
        if until is not None and i + 1 < len(amplitudes) and until(float(a), r):
            break
    return kept, todo


def saver(records: RunRecords | None, model: str) -> Callable[[Any], None]:
    """``save(series)``: save every finished run of a (partial) series not saved yet, with the series' Gmax."""
    done: set[float] = set()

    def save(mr: Any) -> None:
        if records is None or mr is None:
            return
        for a, r in zip(np.asarray(mr.run_amplitudes, dtype=float), mr.results):
            if amp_id(a) not in done and records.save(model, float(a), r, {"G_max": float(mr.G_max)}) is not None:
                done.add(amp_id(a))

    return save


def merged(amplitudes: list[float], kept: dict[float, tuple[Any, float]], new: Any, *, n_cycles: int,
           steps_per_cycle: int, waveform: str, constant: str,
           until: Callable[[float, Any], str | None] | None = None, complete: bool = True) -> ModulusReduction:
    """One series of ``amplitudes`` from the saved runs ``kept`` and the new series ``new`` (or None).

    The series is made again by :func:`grainmech.driver.loop.cyclic_series` with every
    amplitude's run taken from ``kept`` or ``new``: each loop is analysed as the
    uninterrupted series analyses it. ``complete``: ``new`` is the end of its series (the
    amplitudes of neither are beyond a hand-over); otherwise (a series so far) only the
    amplitudes with a run are in it. Gmax (the same for every amplitude: each starts
    from the same state) is the one of the smallest amplitude's source.
    """
    source: dict[float, tuple[Any, float]] = dict(kept)
    if new is not None:
        for a, r in zip(np.asarray(new.run_amplitudes, dtype=float), new.results):
            source[amp_id(a)] = (r, float(new.G_max))
    amps = [float(a) for a in amplitudes if complete or amp_id(a) in source]
    gmax = next((g for a in amps if amp_id(a) in source and np.isfinite(g := source[amp_id(a)][1])), float("nan"))
    order = iter(amps)

    def one(path: Any) -> Any:
        return source[amp_id(next(order))][0]

    if not amps:
        return ModulusReduction(np.zeros(0), np.zeros(0), np.zeros(0), gmax, [], run_amplitudes=np.zeros(0))
    return cyclic_series(one, amps, lambda path: gmax, n_cycles=n_cycles, steps_per_cycle=steps_per_cycle,
                         waveform=waveform, constant=constant, raise_on_failure=False, until=until)



def run_records(outdir: str | Path, cfg: dict, resume: bool) -> RunRecords:
    """The records of ``grainmech run`` in ``outdir`` (``OUTDIR/resume``) for the config ``cfg``.

    The config is compared without the amplitude lists (``test.amplitudes`` and each
    model's own) and without ``[model] method``: every amplitude of a model starts from the
    same initial state, whatever the others and whichever models share the job.
    """
    leave_out = (("test", "amplitudes"), ("model", "method"),
                 *(("model", m.amplitudes_key) for m in MODELS.values() if m.amplitudes_key))
    return RunRecords(Path(outdir) / RECORDS_DIR, normal_config(cfg, leave_out), resume)

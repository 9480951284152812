"""Every amplitude of a layer saved as it finishes, and which model runs which amplitude next.

A layer's curve is made amplitude by amplitude (``grainmech run``'s series). Each finished
amplitude of each model is one small JSON file in ``OUTDIR/layers/<NN-name>/``
(:func:`grainmech.io.site_profile.write_amplitude_entry`), written the moment the model
reports it (the progress hook ``amplitudes_done`` of :func:`grainmech.jobs.execute_run`),
named by the model, the amplitude and a hash of everything that produced it
(:func:`amplitude_key`: the layer's run config except its amplitude list, its stress and
density, the anchored grain modulus, the model, the amplitude, grainmech's version). A
killed profile restarted on the same folder skips every amplitude whose file is there;
a changed config has other hashes, so nothing of the old one is reused.

Entries (``status``): ``"ok"`` (a completed amplitude: secant G, damping, the model's
Gmax, whether the run left the envelope of sands, whether the packing model's grains
rearranged, whether the analysed loop closed), ``"stopped"`` (the model stopped at it:
not run again) and ``"handed"`` (the packing model handed it to the DEM model).

With the packing and DEM models (one amplitude list, each amplitude by one model,
``README`` "Which model when") :func:`plan_runs` says what is left: before the packing
model's hand-over is known, both models on the amplitudes the packing model has not done
(the packing model from the smallest up to the first it stops on or whose grains
rearrange, the DEM model from there, as ``grainmech run``); once it is known, the DEM
model alone on the hand-over amplitude and the larger ones it has not done.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from grainmech.io.records import amp_id, normal_config, record_key
from grainmech.outcomes import model_of

__all__ = ["amplitude_key", "plan_runs", "entries_of", "Recorder", "ENTRY_STATUSES"]

#: statuses of an amplitude entry
ENTRY_STATUSES = ("ok", "stopped", "handed")


def amplitude_key(config: dict, density: float, method: str, amplitude: float) -> str:
    """A short hash of what produces one amplitude of one model of a layer (:func:`grainmech.io.records.record_key`).

    ``config`` is the layer's run config (with its ``[initial] pressure`` and the anchored
    grain modulus); its amplitude list and ``[model] method`` are left out (an amplitude
    does not depend on the others, nor on which models share the list).
    """
    cfg = normal_config(config, (("test", "amplitudes"), ("model", "method")))
    return record_key({"config": cfg, "rho": density}, method, amplitude)


def entries_of(entries: list[dict]) -> dict[tuple[str, float], dict]:
    """``(method, amplitude) -> entry``."""
    return {(e["method"], amp_id(e["amplitude"])): e for e in entries}


def plan_runs(methods: tuple[str, ...], amplitudes: list[float],
              entries: dict[tuple[str, float], dict]) -> list[tuple[tuple[str, ...], list[float]]]:
    """The runs still to do: ``[(methods, amplitudes), ...]`` (empty when every amplitude is done).

    One model: its amplitudes without an entry. The packing and DEM models: see the
    module docstring (the hand-over amplitude is the smallest the packing model stopped
    on, handed over, or completed with its grains rearranging).
    """
    amps = sorted(amp_id(a) for a in amplitudes)
    if methods != ("packing", "dem"):
        todo = [a for a in amps if (methods[0], a) not in entries]
        return [(methods, todo)] if todo else []
    pk = {a: e for (m, a), e in entries.items() if model_of(m).fixed_geometry}
    ends = [a for a, e in pk.items() if e["status"] in ("stopped", "handed") or e.get("moved")]
    if not ends:
        todo = [a for a in amps if a not in pk]
        return [(methods, todo)] if todo else []
    h = min(ends)
    plan: list[tuple[tuple[str, ...], list[float]]] = []
    before = [a for a in amps if a < h and a not in pk]
    if before:
        plan.append((("packing",), before))
    dem = [a for a in amps if a >= h and ("dem", a) not in entries]
    if dem:
        plan.append((("dem",), dem))
    return plan


def _small(details: dict | None) -> dict:
    """The scalar facts of an outcome's details (JSON-ready, no per-amplitude lists)."""
    out: dict[str, Any] = {}
    for k, v in (details or {}).items():
        if isinstance(v, (bool, int, float, str)) or v is None:
            out[k] = v
        elif isinstance(v, np.generic):
            out[k] = v.item()
    return out


class Recorder:
    """The progress callback of a layer's run that saves every amplitude as it finishes.

    Called with a progress line, it passes it on (``progress``); ``amplitudes_done(outcome)``
    (after each completed amplitude, and with a model's final outcome) and
    ``handed_over(amplitudes, why)`` (when the DEM model starts on amplitudes the packing
    model handed over) are the hooks of :func:`grainmech.jobs.execute_run`. ``key(method,
    amplitude)`` names an entry; ``write(entry)`` saves it.
    """

    def __init__(self, progress: Callable[[str], None] | None, key: Callable[[str, float], str],
                 write: Callable[[dict], None], have: dict[tuple[str, float], dict]):
        self.progress, self.key, self.write = progress, key, write
        self.have = dict(have)
        self.new: list[dict] = []

    def __call__(self, message: str) -> None:
        """Pass a progress line on."""
        if self.progress is not None:
            self.progress(message)

    def _save(self, entry: dict) -> None:
        k = (entry["method"], amp_id(entry["amplitude"]))
        old = self.have.get(k)
        if old is not None and old["status"] in ("ok", entry["status"]):
            return
        entry["key"] = self.key(entry["method"], entry["amplitude"])
        self.write(entry)
        self.have[k] = entry
        self.new.append(entry)

    def amplitudes_done(self, out: Any) -> None:
        """Save the completed amplitudes of ``out`` (a CyclicOutcome) and the one it stopped at."""
        method = out.method
        n = len(out.G)
        beyond = out.beyond_envelope
        moved = list((out.details or {}).get("rearranging", []))[:n] if model_of(method).fixed_geometry else []
        moved += [False] * (n - len(moved))
        loops = list(out.loop_quality[:n])
        common = {"method": method, "G_max_Pa": float(out.G_max), "warnings": list(out.warnings),
                  "empirical_G_max": out.empirical_G_max, "details": _small(out.details)}
        for i, a in enumerate(np.asarray(out.amplitudes, dtype=float)[:n]):
            self._save({**common, "amplitude": float(a), "status": "ok", "G_Pa": float(out.G[i]),
                        "damping": float(out.damping[i]), "beyond": bool(beyond[i]) if i < len(beyond) else False,
                        "moved": bool(moved[i]), "loop_ok": bool(loops[i].ok) if i < len(loops) else True})
        done = {amp_id(a) for a in np.asarray(out.amplitudes, dtype=float)[:n]}
        for r, a in zip(out.results, np.asarray(out.run_amplitudes, dtype=float)):
            if amp_id(a) not in done and not getattr(r, "success", True):
                self._save({**common, "amplitude": float(a), "status": "stopped",
                            "message": str(getattr(r, "message", "") or out.message)})

    def handed_over(self, amplitudes: Any, why: str) -> None:
        """Mark the amplitudes the packing model handed to the DEM model (not run by it again)."""
        for a in amplitudes:
            if ("packing", amp_id(a)) not in self.have:
                self._save({"method": "packing", "amplitude": float(a), "status": "handed", "message": str(why)})

    def finished(self, outcome: Any, amplitudes: list[float]) -> None:
        """After the run: a model that did not start (no result at all) marks the amplitudes it was given."""
        outs = getattr(outcome, "outcomes", [outcome])
        for o in outs:
            if model_of(o.method).fixed_geometry and not o.results and not o.success:
                for a in amplitudes:
                    if ("packing", amp_id(a)) not in self.have:
                        self._save({"method": "packing", "amplitude": float(a), "status": "stopped",
                                    "message": str(o.message)})
                        break  # the first: the DEM model takes it and the larger ones

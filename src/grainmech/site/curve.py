"""A layer's curve from its saved amplitudes: one curve of the models' points, and its fitted hyperbola.

The points: :func:`grainmech.outcomes.recommended_curve`, the rule of ``grainmech run``
with several models (the packing model's points where its fixed geometry holds, the DEM
model's beyond it and where the packing model's grains rearrange; every secant G over
the packing model's Gmax), rebuilt here from the saved amplitude entries
(:mod:`grainmech.site.amplitudes`) so that a resumed layer gives the same curve as one
run at once. With one model: its own points on its own Gmax.

The curve for site response: the modified hyperbola fitted to those points
(:func:`grainmech.analysis.hyperbola.fit_hyperbola`: reference strain and curvature from
G/Gmax, Masing scaling and small-strain damping from the damping), evaluated on
:data:`SITE_STRAINS`, so that a site-response program has the layer's curve at every
strain an earthquake brings and holds nothing at a last measured value. Points beyond the
envelope of sands (unless ``[model] keep_beyond_envelope``) and points whose G/Gmax or
damping a site-response program does not take are left out of the fit, as ``grainmech
run`` leaves them out of ``site_response_curves.csv``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.analysis.hyperbola import fit_hyperbola
from grainmech.errors import GrainmechError
from grainmech.outcomes import CyclicOutcome, RunComparison, curve_value_problems, recommended_curve

__all__ = ["layer_curve", "SITE_STRAINS", "REACH_FOR_GAMMA_R"]

#: strains [decimal] of the fitted curve handed to site response: 1e-7 ... 1e-1, 4 per decade
SITE_STRAINS = np.logspace(-7, -1, num=25)
#: the fitted points must reach G/Gmax below this for the reference strain to be fitted
#: rather than extrapolated (a warning otherwise)
REACH_FOR_GAMMA_R = 0.7


@dataclass(frozen=True)
class _Loop:
    """What :func:`recommended_curve` reads of a loop's quality."""

    ok: bool


def _outcome(method: str, entries: list[dict], pressure: float, kind: str) -> CyclicOutcome:
    """A CyclicOutcome of a model's saved ``"ok"`` entries (its points, flags and Gmax; no runs)."""
    ok = sorted((e for e in entries if e["status"] == "ok"), key=lambda e: e["amplitude"])
    gmax = next((float(e["G_max_Pa"]) for e in entries if e.get("G_max_Pa") is not None), float("nan"))
    return CyclicOutcome(
        kind=kind, pressure=pressure, results=[], success=True, message="", seconds=0.0, point=None, method=method,
        details={"rearranging": [bool(e.get("moved")) for e in ok]},
        amplitudes=np.array([e["amplitude"] for e in ok], dtype=float),
        G=np.array([e["G_Pa"] for e in ok], dtype=float), damping=np.array([e["damping"] for e in ok], dtype=float),
        G_max=gmax, envelope=[{"beyond_any": bool(e.get("beyond"))} for e in ok],
        loop_quality=[_Loop(bool(e.get("loop_ok", True))) for e in ok])


def layer_curve(methods: tuple[str, ...], entries: list[dict], pressure: float, kind: str,
                keep_beyond_envelope: bool = False) -> dict:
    """The layer's points and fitted curve (JSON-ready dict).

    Returns ``amplitudes``, ``G_ratio``, ``damping``, ``models``, ``flags`` (the points),
    ``G_max_Pa``, ``G_max_model``, ``G_max_reason``, ``choices``, ``by_model`` (each
    model's own points and Gmax), ``fit`` (:class:`HyperbolaFit` as a dict, or None with
    ``fit_error``), ``site_curve`` (``strain``, ``G_ratio``, ``damping`` of the fit on
    :data:`SITE_STRAINS`, ``left_out``: the amplitudes not fitted, ``model_range``).
    """
    outs = [_outcome(m, [e for e in entries if e["method"] == m], pressure, kind) for m in methods]
    by_model = {o.method: {"amplitudes": o.amplitudes.tolist(), "G_Pa": o.G.tolist(),
                           "G_ratio_own_Gmax": (o.G / o.G_max).tolist() if np.isfinite(o.G_max) else [],
                           "damping": o.damping.tolist(), "G_max_Pa": o.G_max} for o in outs}
    rec = recommended_curve(RunComparison(outs)) if len(outs) > 1 else None
    if rec is not None:
        amps, ratio, damp = rec.amplitudes, rec.G_ratio, rec.damping
        models, flags = list(rec.models), [list(f) for f in rec.flags]
        gmax, gmax_model, why, choices = rec.G_max, rec.G_max_model, rec.G_max_reason, list(rec.choices)
    else:
        o = next((o for o in outs if len(o.G)), outs[0])
        amps, ratio, damp = o.amplitudes, o.G_ratio, o.damping
        models = [o.method] * len(amps)
        flags = [(["beyond_envelope"] if b else []) + (["value_flag"] if p else [])
                 for b, p in zip(o.beyond_envelope, curve_value_problems(ratio, damp))]
        gmax, gmax_model, choices = o.G_max, o.method, []
        why = f"the {o.method} model's own Gmax"
    use = np.array([("value_flag" not in f) and (keep_beyond_envelope or "beyond_envelope" not in f)
                    for f in flags], dtype=bool)
    out: dict[str, Any] = {
        "amplitudes": [float(a) for a in amps], "G_ratio": [float(r) for r in ratio],
        "damping": [float(d) for d in damp], "models": models, "flags": flags,
        "G_max_Pa": float(gmax), "G_max_model": gmax_model, "G_max_reason": why, "choices": choices,
        "by_model": by_model, "fit": None, "fit_error": None, "fit_warning": None,
        "site_curve": {"strain": [], "G_ratio": [], "damping": [], "left_out": [float(a) for a in amps[~use]]
                       if len(amps) else [], "model_range": []}}
    if use.sum() < 2:
        out["fit_error"] = (f"{int(use.sum())} usable point(s): a modified hyperbola needs at least two "
                            "(no curve for site response)")
        return out
    try:
        fit = fit_hyperbola(amps[use], ratio[use], damp[use])
    except GrainmechError as exc:  # pragma: no cover (the points are checked above)
        out["fit_error"] = str(exc)
        return out
    out["fit"] = fit.as_dict()
    low = float(np.min(ratio[use]))
    if low > REACH_FOR_GAMMA_R:
        out["fit_warning"] = (f"the fitted points reach G/Gmax {low:.3f} only (at {float(amps[use].max()):.3g}): "
                              f"the reference strain {fit.gamma_r:.3g} and the curve beyond are an extrapolation")
    elif fit.at_bound:
        out["fit_warning"] = f"the fit ended on the bound of {', '.join(fit.at_bound)}"
    out["site_curve"].update(strain=SITE_STRAINS.tolist(), G_ratio=fit.g_ratio(SITE_STRAINS).tolist(),
                             damping=fit.damping(SITE_STRAINS).tolist(),
                             model_range=[float(amps[use].min()), float(amps[use].max())])
    return out

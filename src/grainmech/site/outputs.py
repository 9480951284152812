"""The files of a finished profile run (through :mod:`grainmech.io.site_profile`) and its summary."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from grainmech.io.results import ensure_dir, write_figure, write_json
from grainmech.io.site_profile import write_layer_curves, write_layers_table, write_response, write_site_page
from grainmech.site import strata
from grainmech.site.profile import SiteProfile

__all__ = ["write_outputs", "response_note"]


def response_note(profile: SiteProfile, response: dict | None, reason: str | None) -> str:
    """What the site-response part of the page says (the runs, or why there are none and what to do)."""
    if response is not None:
        m = response["motion"]
        return (f"pystrata {response['pystrata_version']} equivalent-linear runs with the same Vs profile "
                f"({', '.join(f'{v:.0f}' for v in response['vs_m_s'])} m/s; measured where given, else the "
                f"model's) and half-space, input motion {m['file']} ({m['points']} points, dt = "
                f"{m['time_step_s']:g} s, PGA {m['pga_g']:.3g} g, {m['location']}): surface response spectra "
                "(5 % damping), maximum shear strain and PGA against depth, with three sets of curves: the "
                "grains' (the modified hyperbola fitted to each layer's packing and DEM points, curves/), "
                "pystrata's DarendeliSoilType and its MenqSoilType (Cu and D50 of each layer's grains or "
                "[reference]). " + " ".join(response["warnings"]))
    if profile.motion is None:
        return ("No [motion] in the profile: the curve files in curves/ are what a site-response program reads "
                "(docs/site-response.md has the pystrata recipe); add [motion] and [bedrock] to run pystrata here.")
    return f"Site response not run: {reason}. The curve files in curves/ are written."


def write_outputs(stage: Path, profile: SiteProfile, records: list[dict], *, reused: int, ran: int,
                  response: bool, say: Callable[[str], None], seconds: float, motion: Any = None) -> dict:
    """Curve files, ``layers.csv``, ``profile.png``, the site response, ``summary.json``, ``index.html``.

    Returns the summary dict (also written as ``summary.json``).
    """
    cdir = ensure_dir(stage / "curves")
    curve_files: list[str] = []
    for rec in records:
        curve_files += write_layer_curves(cdir, rec, f"grainmech site {profile.source}")
    write_layers_table(stage / "layers.csv", records)
    files = ["layers.csv"] + [f"curves/{f}" for f in curve_files]
    try:
        from grainmech.site.plotting import profile_figure  # matplotlib on use

        write_figure(stage / "profile.png", profile_figure(records, profile.water_table))
        files.append("profile.png")
    except ImportError as exc:  # pragma: no cover (matplotlib is in every install with the CLI)
        say(f"grainmech site: profile.png not drawn: {exc}")
    res: dict | None = None
    reason: str | None = None
    warnings: list[str] = []
    if profile.motion is not None:
        reason = strata.pystrata_missing() if response else "switched off (--no-response)"
        no_vs = [r["name"] for r in records if not (r.get("vs_measured_m_s") or r.get("vs_model_m_s"))]
        if reason is None and no_vs:  # a layer whose model stopped before its Gmax, with no measured vs
            reason = (f"not run: layer(s) {no_vs} have no shear-wave velocity (no Gmax: their model stopped "
                      "before the first amplitude; a measured vs in the layer gives one)")
        if reason is None and motion is not None and profile.bedrock is not None:
            say("grainmech site: pystrata equivalent-linear runs (grainmech's curves, Darendeli's, Menq's)")
            from grainmech.site.plotting import response_figure  # matplotlib on use

            res = strata.site_response(records, profile.bedrock, profile.water_table, motion, profile.motion.location)
            files += write_response(stage, res, response_figure(res))
            warnings += res["warnings"]
        elif reason is not None:
            say(f"grainmech site: {reason}")
    stopped = [r["name"] for r in records if r["status"] == "stopped"]
    failed = [r["name"] for r in records if r["status"] == "failed"]
    for r in records:
        a = r.get("anchor")
        if a and a.get("flag"):
            warnings.append(f"layer {r['name']!r}: after anchoring, the run's Gmax is {r['G_max_Pa']:.4g} Pa, "
                            f"{100 * a['mismatch']:+.2f} % from rho vs^2 = {a['G_target_Pa']:.4g} Pa (the packing's "
                            "forces at the layer's stress depend a little on the grain modulus)")
    summary: dict[str, Any] = {
        "command": "site", "source": profile.source, "method": profile.method,
        "water_table_m": profile.water_table if math.isfinite(profile.water_table) else None,
        "k0_rule": profile.k0_rule, "n_layers": len(records),
        "succeeded": len(records) - len(stopped) - len(failed), "stopped": len(stopped), "failed": len(failed),
        "stopped_layers": stopped, "failed_layers": failed, "reused": reused, "ran": ran,
        "amplitudes_reused": sum(int(r.get("amplitudes_reused") or 0) for r in records),
        "amplitudes_run": sum(int(r.get("amplitudes_run") or 0) for r in records),
        "seconds": seconds, "curve_files": curve_files, "warnings": warnings,
        "site_response": res if res is not None else {"run": False, "reason": response_note(profile, None, reason)},
        "layers": [{k: v for k, v in r.items() if k != "config"} for r in records],
        "files": files + ["layers/", "summary.json", "index.html"]}
    write_json(stage / "summary.json", summary)
    write_site_page(stage, summary, records, response_note(profile, res, reason))
    return summary

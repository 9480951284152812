"""Calibration result files (through :mod:`grainmech.io.results`, atomically).

``write_report(result, outdir)`` writes

* ``fit.json`` - everything: parameters (SI and display unit), standard errors,
  correlation, identifiability notes, R^2, iterations, the starts;
* ``parameters.csv`` - one row per parameter;
* ``residuals.csv`` - one row per data point and fitted column;
* ``correlation.csv`` - the correlation matrix (empty cells: not identifiable);
* ``starts.csv`` - every start (with ``--starts N``);
* ``fit.png`` - data and fitted model against the data's abscissa (matplotlib, lazily);
* ``calibrated.toml`` - the model config with the fitted values (in the units of the
  calibration file), completed to a config ``grainmech stiffness`` (kinds
  ``modulus-pressure``, ``directional``) or ``grainmech run`` (``modulus-reduction``,
  ``stress-strain``) runs as it is; see :func:`calibrated_config`.
"""

from __future__ import annotations

import copy
import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from grainmech import plots
from grainmech.calibrate.data import column_unit
from grainmech.calibrate.model import DATA_KINDS, set_path
from grainmech.errors import GrainmechError
from grainmech.io import results
from grainmech.io.results import ensure_dir, write_csv, write_json, write_text
from grainmech.io.units import to_float

__all__ = ["summary", "write_report", "plot_fit", "calibrated_config"]

#: the command a calibrated config of each data kind is made for
CONFIG_COMMAND = {"modulus-pressure": "stiffness", "directional": "stiffness",
                  "modulus-reduction": "run", "stress-strain": "run"}


def _fmt_unit(p: Any) -> str:
    return p.unit or p.si_unit or "1"


def summary(result: Any) -> dict:
    """A JSON-able summary of a :class:`grainmech.calibrate.fit.FitResult`."""
    pr = result.problem
    st = result.stats
    params = []
    for j, p in enumerate(pr.parameters):
        se = st["std_error"][j]
        f = p.unit_factor
        params.append({
            "path": p.path, "unit": _fmt_unit(p), "si_unit": p.si_unit or "1", "log": p.log,
            "start": result.start[j] / f, "given_start": p.start / f, "lower": p.lower / f, "upper": p.upper / f,
            "value": result.x[j] / f, "value_si": result.x[j],
            "std_error": None if se is None else se / f, "std_error_si": se,
            "relative_std_error": st["relative_std_error"][j],
            "std_error_known_sd": (None if st["std_error_unscaled"][j] is None or not pr.known_sd
                                   else st["std_error_unscaled"][j] / f),
            "identifiable": st["identifiable"][j], "at_bound": st["at_bound"][j],
        })
    return {
        "config": pr.source, "data": pr.data_source, "kind": pr.kind, "fitted_columns": pr.targets,
        "error_scale": pr.error, "n_points": len(pr.data), "n_residuals": int(result.residuals.size),
        "success": result.success, "status": result.status, "message": result.message,
        "function_evaluations": result.nfev, "jacobian_evaluations": result.njev,
        "cost": result.cost, "rss": st["rss"], "dof": st["dof"], "s2": st["s2"],
        "rms_weighted_residual": st["rms_weighted_residual"],
        "r2": st["r2"], "r2_weighted": st["r2_weighted"],
        "parameters": params,
        "correlation": [[None if not np.isfinite(v) else float(v) for v in row] for row in st["correlation"]],
        "singular_values": st["singular_values"], "unidentified": st["unidentified"], "notes": st["notes"],
        "plausibility": st.get("plausibility", []),
        "starts": [{"index": s.index, "start": [v / p.unit_factor for v, p in zip(s.start, pr.parameters)],
                    "value": [v / p.unit_factor for v, p in zip(s.x, pr.parameters)],
                    "cost": s.cost if math.isfinite(s.cost) else None, "nfev": s.nfev, "status": s.status,
                    "message": s.message} for s in result.starts],
        "seconds": result.seconds,
    }


def write_report(result: Any, outdir: str | Path, *, plot: bool = True) -> list[str]:
    """Write the result files; returns their names."""
    d = ensure_dir(outdir)
    pr = result.problem
    s = summary(result)
    files = []
    write_json(d / "fit.json", s)
    files.append("fit.json")
    write_csv(d / "parameters.csv", ["path", "unit", "start", "lower", "upper", "value", "std_error",
                                     "relative_std_error", "identifiable", "at_bound"],
              ([q["path"], q["unit"], q["start"], q["lower"], q["upper"], q["value"],
                "" if q["std_error"] is None else q["std_error"],
                "" if q["relative_std_error"] is None else q["relative_std_error"],
                q["identifiable"], q["at_bound"]] for q in s["parameters"]))
    files.append("parameters.csv")
    inputs = [c for c in pr.data.order if c not in pr.targets and not c.startswith("sd_")]
    rows = []
    k = 0
    for t in pr.targets:
        for i in range(len(pr.data)):
            rows.append([int(pr.data.lines[i]), *[float(pr.data[c][i]) for c in inputs], t,
                         float(pr.data[t][i]), float(result.predictions[t][i]),
                         float(result.predictions[t][i] - pr.data[t][i]), float(result.residuals[k])])
            k += 1
    write_csv(d / "residuals.csv", ["line", *[f"{c}_SI" for c in inputs], "column", "observed_SI", "predicted_SI",
                                    "residual_SI", "weighted_residual"], rows)
    files.append("residuals.csv")
    names = [p.path for p in pr.parameters]
    write_csv(d / "correlation.csv", ["parameter", *names],
              ([n, *["" if v is None else v for v in row]] for n, row in zip(names, s["correlation"])))
    files.append("correlation.csv")
    if len(result.starts) > 1:
        write_csv(d / "starts.csv", ["index", *[f"start_{n}" for n in names], *[f"value_{n}" for n in names],
                                     "cost", "nfev", "status"],
                  ([st["index"], *st["start"], *st["value"], "" if st["cost"] is None else st["cost"], st["nfev"],
                    st["status"]] for st in s["starts"]))
        files.append("starts.csv")
    if plot:
        plot_fit(result, d / "fit.png")
        files.append("fit.png")
    text = calibrated_config(result)
    if text is not None:
        write_text(d / "calibrated.toml", text)
        files.append("calibrated.toml")
    return files


def calibrated_config(result: Any) -> str | None:
    """TOML text of the calibrated model, ready to run.

    TOML text of the calibrated model: the calibration's ``[model]`` with every fitted
    parameter set to its best value (in the unit the calibration file gave), completed so
    that ``grainmech stiffness`` or ``grainmech run`` (:data:`CONFIG_COMMAND`) runs it:

    * ``modulus-pressure``: ``[stress] pressure`` = the median pressure of the data (the
      stiffness at any other pressure: edit it); the model's own ``void_ratio`` is kept;
    * ``modulus-reduction``: ``[test]`` cyclic simple shear at the data's strain amplitudes
      with the calibration's cycles and steps;
    * ``stress-strain``: the default cyclic simple shear ``[test]`` of ``grainmech run``.

    ``rod-strains`` has no such command: None (no file). A coordination relation
    ``{a, b, n, p_ref}`` stays a relation (both commands evaluate it at their mean stress).
    Requires ``tomli-w``.
    """
    pr = result.problem
    command = CONFIG_COMMAND.get(pr.kind)
    if command is None:
        return None
    try:
        import tomli_w
    except ImportError:  # pragma: no cover - depends on environment

        raise GrainmechError("writing calibrated.toml needs tomli-w (pip install 'grainmech[cli]')") from None
    cfg = copy.deepcopy(pr.model)
    for p, v in zip(pr.parameters, result.x):
        val = float(v) / p.unit_factor
        set_path(cfg, p.path, f"{val:.10g} {p.unit}" if p.unit else val)
    # the default run's [test] is cyclic simple shear
    default_test = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())["test"]
    if pr.kind == "modulus-pressure":
        cfg["stress"] = {"pressure": f"{float(np.median(pr.data['pressure'])):.6g} Pa"}
    elif pr.kind == "modulus-reduction":
        st = pr.settings
        cfg["test"] = {**default_test, "amplitudes": sorted(float(a) for a in pr.data["strain"]),
                       "n_cycles": int(st["n_cycles"]), "steps_per_cycle": int(st["steps_per_cycle"]),
                       "waveform": st["waveform"]}
    elif pr.kind == "stress-strain":
        cfg["test"] = default_test
    head = (f"# Calibrated by grainmech calibrate ({pr.kind}) from {pr.source} and {pr.data_source}:\n"
            + "".join(f"#   {p.path} = {float(v) / p.unit_factor:.6g} {p.unit or p.si_unit or ''}".rstrip() + "\n"
                      for p, v in zip(pr.parameters, result.x))
            + f"# Run it with: grainmech {command} calibrated.toml\n")
    return head + "\n" + tomli_w.dumps(cfg)


def plot_fit(result: Any, path: str | Path) -> Path:
    """Data (markers) and model (line) for each fitted column against the abscissa."""
    pr = result.problem
    xname = DATA_KINDS[pr.kind].x
    data = pr.data
    if xname and data.has(xname):
        x = data[xname]
        unit = data.units.get(xname, "")
        xlabel = f"{xname} [{unit}]" if unit else xname
        if unit:
            x = x / to_float(f"1 {unit}", "rad" if xname == "alpha" else ("Pa" if xname == "pressure" else None), xname)
    else:
        x = np.arange(len(data), dtype=float)
        xlabel = "row"
    n = len(pr.targets)
    head = 0.13 * (len(pr.parameters) + 1)  # inches for the title lines
    height = 3.8 + head
    fig, axes = plots.subplots(1, n, figsize=(4.8 * n, height), squeeze=False)
    group = data["void_ratio"] if data.has("void_ratio") else np.zeros(len(data))

    for ax, t in zip(axes[0], pr.targets):
        yu = data.units.get(t, "")
        fy = to_float(f"1 {yu}", column_unit(t), t) if yu else 1.0
        for gi, g in enumerate(np.unique(group)):
            sel = group == g
            o = np.argsort(x[sel])
            lab = f" e = {g:g}" if data.has("void_ratio") else ""
            ax.plot(x[sel][o], data[t][sel][o] / fy, "o", color=f"C{gi}", ms=4, label=f"data{lab}")
            ax.plot(x[sel][o], result.predictions[t][sel][o] / fy, "-", color=f"C{gi}", lw=1.2, label=f"fit{lab}")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"{t} [{yu}]" if yu else (f"{t} [SI]" if column_unit(t) else t))
        if xname in ("pressure", "strain") and np.all(x > 0):
            ax.set_xscale("log")
            if np.all(data[t] > 0):
                ax.set_yscale("log")
        ax.set_title(f"{t}: R^2 = {result.stats['r2'][t]:.4f}", fontsize=9)
        ax.legend(fontsize=7)
    fig.suptitle(f"grainmech calibrate ({pr.kind}):\n" + pr.describe(result.x).replace(", ", "\n"), fontsize=7)
    fig.set_layout_engine("constrained")  # makes room for exactly the title lines
    return results.write_figure(Path(path), fig, dpi=110)

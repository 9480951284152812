"""``grainmech dem``: the measures of a contact network read from files (``[network]`` table)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.conventions import stress_to_vector, von_mises
from grainmech.elasticity import bulk_modulus, shear_modulus
from grainmech.errors import ConfigError
from grainmech.io.config import Section
from grainmech.io.dem import read_network
from grainmech.jobs.stiffness import _ENGINEERING_2D, _ENGINEERING_3D
from grainmech.network import _solvers
from grainmech.network import network_report_json as network_report
from grainmech.outcomes import DemOutcome

__all__ = ["DemSpec", "dem_options", "prepare_dem", "execute_dem", "compute_dem", "dem_scalars"]


def dem_options(root: Any) -> dict:
    """Keyword arguments of :func:`grainmech.network.network_report` from a config.

    Tables ``[material]``, ``[stiffness]``, ``[relaxed]``, ``[fabric]`` of a
    :class:`~grainmech.io.config.Section` (the caller calls ``finish``).
    """
    opts: dict[str, Any] = {}
    if root.has("material"):
        m = root.section("material")
        opts["shear_modulus"] = m.number("shear_modulus", "Pa", min=0, min_inclusive=False)
        opts["poisson"] = m.number("poisson", None, min=-1, max=0.5, min_inclusive=False,
                                   max_inclusive=False)
    if root.has("stiffness"):
        s = root.section("stiffness")
        opts["stiffness_source"] = s.choice("source", ("auto", "overlap", "force", "columns", "constant"), "auto")
        if s.has("kn"):
            opts["kn"] = s.number("kn", "N/m", min=0)
        if s.has("ks"):
            opts["ks"] = s.number("ks", "N/m", min=0)
        opts["geometric"] = s.boolean("geometric", False)
    if root.has("relaxed"):
        r = root.section("relaxed")
        opts["relaxed"] = r.boolean("enabled", True)

        solver = r.choice("solver", _solvers.METHODS, "auto")
        if not _solvers.available(solver):
            pkg = _solvers.PACKAGES[solver]
            raise ConfigError(r.key("solver"), solver, f"needs the optional package {pkg} (pip install {pkg}; "
                              f"or solver = \"auto\", which uses what is installed)")
        opts["solver"] = solver
        opts["remove_rattlers"] = r.boolean("remove_rattlers", True)
        if r.has("min_contacts"):
            opts["min_contacts"] = r.integer("min_contacts", min=0)
    if root.has("fabric"):
        f = root.section("fabric")
        opts["fit_order"] = f.integer("fit_order", 2, min=2)
    return opts


@dataclass
class DemSpec:
    """Files and options read from a dem config."""

    contacts: Path
    particles: Path | None
    read: dict
    options: dict


def _names(sec: Any, k: str) -> list[str] | None:
    if not sec.has(k):
        return None
    v = sec.raw(k)
    if isinstance(v, str):
        v = [x.strip() for x in v.split(",") if x.strip()]
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise ConfigError(sec.key(k), v, "must be a list of names (or a comma-separated string)")
    return v


def prepare_dem(cfg: dict, base_dir: str | Path | None = None) -> DemSpec:
    """Read a dem config.

    ``[network]`` (``contacts``, ``particles``, ``format``, ``keywords``, ``columns``,
    ``force_on``; file paths relative to ``base_dir``) and the ``grainmech dem --material``
    tables (see :func:`dem_options`).
    """
    root = Section(cfg, "")
    net = root.section("network")
    base = Path(base_dir) if base_dir is not None else Path(".")

    def path(k: str, required: bool) -> Path | None:
        v = net.raw(k) if required else net.raw(k, None)
        if v is None:
            return None
        if not isinstance(v, str) or not v.strip():
            raise ConfigError(net.key(k), v, "must be a file path")
        return base / v

    contacts = path("contacts", True)
    if contacts is None:
        raise ConfigError(net.key("contacts"), None, "must be a file path")
    particles = path("particles", False)
    force_on = net.choice("force_on", ("id1", "id2"), "id1") if net.has("force_on") else None
    read = dict(format=net.choice("format", ("auto", "liggghts", "lammps", "csv", "npz"), "auto"),
                keywords=_names(net, "keywords"), columns=_names(net, "columns"), force_on=force_on)
    opts = dem_options(root)
    root.finish()
    return DemSpec(contacts, particles, read, opts)


def execute_dem(spec: DemSpec, progress: Callable[[int, int], None] | None = None) -> DemOutcome:
    """Read the network and compute :func:`grainmech.network.network_report`.

    ``progress(done, total)`` receives the bytes of the contact file read so far and its
    size (:func:`grainmech.io.dem.read_network`).
    """
    net = read_network(spec.contacts, spec.particles, **spec.read, progress=progress)
    return DemOutcome(net, network_report(net, **spec.options))


def compute_dem(cfg: dict, base_dir: str | Path | None = None,
                progress: Callable[[int, int], None] | None = None) -> DemOutcome:
    """Config dict -> network report (see :func:`prepare_dem`, :func:`execute_dem`)."""
    return execute_dem(prepare_dem(cfg, base_dir), progress)


def dem_scalars(out: DemOutcome) -> dict[str, Any]:
    """Scalar outputs of a network report.

    Counts, stress invariants, coordination, fabric anisotropy, Hill moduli and engineering
    constants of the affine and relaxed stiffness (empty when not computed).
    """
    rep = out.report
    row: dict[str, Any] = {"n_particles": int(rep["n_particles"]), "n_contacts": int(rep["n_contacts"]),
                           "volume [m^3]": float(rep["volume"])}
    S = np.asarray(rep["stress"]["tensor"], dtype=float)
    d = S.shape[0]
    p = float(np.trace(S) / d)
    sym = (S + S.T) / 2
    row["p [Pa]"] = p
    if d == 3:
        row["q [Pa]"] = float(von_mises(stress_to_vector(sym)))
    else:  # the plane analogue sqrt(3/2 s:s) of the 2D deviator s = sigma - p I
        dev = sym - p * np.eye(d)
        row["q [Pa]"] = float(np.sqrt(1.5 * np.sum(dev * dev)))
    row["skew_ratio"] = float(rep["stress"]["skew_ratio"])
    for k in ("z", "z_force", "z_mechanical", "n_rattlers"):
        if k in rep["coordination"]:
            v = rep["coordination"][k]
            row[k] = int(v) if k.startswith("n_") else float(v)
    row["normal_anisotropy"] = float(rep["fabric"]["normal_anisotropy"]["deviator_norm"])
    for which in ("affine", "relaxed"):
        C = rep.get(f"stiffness_{which}")
        ok = C is not None and np.any(np.asarray(C, dtype=float))
        for name, fn in (("K", bulk_modulus), ("G", shear_modulus)):
            try:
                row[f"{name}_hill_{which} [Pa]"] = float(fn(np.asarray(C, dtype=float), "hill")) if ok else None
            except (ValueError, np.linalg.LinAlgError):
                row[f"{name}_hill_{which} [Pa]"] = None
        eng = rep.get(f"engineering_{which}") or {}
        for k in (_ENGINEERING_3D if d == 3 else _ENGINEERING_2D):
            v = eng.get(k)
            row[f"{k}_{which}" + (" [Pa]" if k[0] in "EG" else "")] = None if v is None else float(v)
    return row

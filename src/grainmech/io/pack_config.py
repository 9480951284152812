"""The ``grainmech pack`` config: ``[grains]``, ``[material]``, ``[preparation]`` (``docs/packings.md``).

:func:`build_pack_config` reads it into a :class:`PackConfig` (strict keys, quantities
with units; a bad value is a :class:`~grainmech.errors.ConfigError` naming the key).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from typing import Any

from grainmech.errors import ConfigError, ParameterError
from grainmech.io.config import Section
from grainmech.io.schema import GRAIN_SHEAR_MODULUS_RANGE, _dimensionless, build_rolling, check_pressure
from grainmech.io.units import to_float

__all__ = ["PackConfig", "build_pack_config", "PACK_MAX_GRAINS", "PACK_MAX_SIZE_RATIO", "GRAIN_SIZE_RANGE"]


@dataclass(frozen=True)
class PackConfig:
    """A ``grainmech pack`` config read by :func:`build_pack_config`.

    Attributes
    ----------
    grading : grainmech.packing.SieveCurve | D50Cu | UniformRadius
    n_grains : int
    max_size_ratio : float
    material : grainmech.packing.GrainMaterial
    settings : grainmech.packing.PackSettings
    """

    grading: Any
    n_grains: int
    max_size_ratio: float
    material: Any
    settings: Any


#: most grains ``grainmech pack`` prepares (LAMMPS on one machine: memory and days beyond)
PACK_MAX_GRAINS = 1_000_000
#: largest ``[grains] max_size_ratio``: LAMMPS' neighbour bins follow the largest grain and the
#: time step the smallest, so a wide ratio multiplies both a small grain's neighbours and the time steps
PACK_MAX_SIZE_RATIO = 10.0
#: grain diameters a config may give [m] (1 micrometre to 1 m)
GRAIN_SIZE_RANGE = (1e-6, 1.0)


def build_pack_config(cfg: dict) -> PackConfig:
    """Read a ``grainmech pack`` config (``docs/packings.md``).

    Read a ``grainmech pack`` config (``docs/packings.md``): tables ``[grains]``,
    ``[material]``, ``[preparation]``; strict keys, quantities with units.

    ``[grains]``: ``count`` (>= 50), ``distribution`` = ``"sieve"`` (``sizes``, list of
    lengths, and ``passing``, percent) | ``"d50-cu"`` (``d50``, ``cu``) | ``"uniform"``
    (``radius``, ``spread`` in [0, 1)), ``max_size_ratio`` (4), ``seed`` (1).
    ``[material]``: ``name`` (``"quartz"`` | ``"glass"``, the defaults of the other keys),
    ``shear_modulus``, ``poisson``, ``density``, ``friction``, ``restitution``, and the
    grains' rolling resistance ``rolling_friction``, ``rolling_stiffness``,
    ``twisting_friction`` (as in ``[contacts]`` of a run, :func:`build_rolling`; it acts
    with the grain friction).
    ``[preparation]``: ``stress`` (one stress or three principal stresses, compression
    positive, required), ``friction`` (preparation friction, default 0), ``rolling_friction``
    (rolling friction during compression, with the preparation friction; default 0),
    ``unbalanced_tol``
    (1e-5), ``stress_tol`` (0.005), ``max_steps``, ``threads`` (0 = all cores).
    """
    # imported on use: keeps grainmech.packing (about 0.1 s) out of `grainmech --help`
    from grainmech.packing import MATERIALS, D50Cu, PackSettings, SieveCurve, UniformRadius
    from grainmech.packing.prepare import GRAIN_ROLLING

    root = Section(cfg, "")
    g = root.section("grains")
    n = g.integer("count", min=50, max=PACK_MAX_GRAINS)
    kind = g.choice("distribution", ("sieve", "d50-cu", "uniform"))
    lo_d, hi_d = GRAIN_SIZE_RANGE
    ratio = g.number("max_size_ratio", None, 4.0, min=1, min_inclusive=False, max=PACK_MAX_SIZE_RATIO)
    if kind == "sieve":
        sizes, passing = g.raw("sizes"), g.raw("passing")
        for k, v in (("sizes", sizes), ("passing", passing)):
            if not isinstance(v, list) or len(v) < 2:
                raise ConfigError(g.key(k), v, "expected a list of at least two values")
        d = [to_float(v, "m", f"{g.key('sizes')}[{i}]") for i, v in enumerate(sizes)]
        p = [to_float(v, None, f"{g.key('passing')}[{i}]") for i, v in enumerate(passing)]
        for i, di in enumerate(d):
            if not lo_d <= di <= hi_d:
                raise ConfigError(f"{g.key('sizes')}[{i}]", sizes[i], f"must lie in [{lo_d:g} m, {hi_d:g} m] "
                                  "(grain sizes)")
        try:
            grading: Any = SieveCurve(d, p, key=g.name)
        except ParameterError as exc:  # the grading names its keys as g.key(...)
            raise ConfigError(exc.name, exc.value, exc.problem) from None
    elif kind == "d50-cu":
        # Cu of soils: 1 (one size) to some tens (well-graded gravels); beyond 100 the top of the
        # distribution a packing keeps (D_max / max_size_ratio ... D_max) holds no mass
        grading = D50Cu(g.number("d50", "m", min=lo_d, max=hi_d), g.number("cu", None, min=1, max=100),
                        key=g.name)
    else:
        # R (1 - spread) ... R (1 + spread): a size ratio (1 + spread) / (1 - spread) <= max_size_ratio
        top = (ratio - 1.0) / (ratio + 1.0)
        spread = g.number("spread", None, 0.0, min=0, max=1, max_inclusive=False)
        if spread > top:
            raise ConfigError(g.key("spread"), g.raw("spread"), f"gives grains {(1 + spread) / (1 - spread):.3g} "
                              f"times as large as the smallest, more than max_size_ratio = {ratio:g}: at most "
                              f"{top:.4g} (or raise grains.max_size_ratio, up to {PACK_MAX_SIZE_RATIO:g})")
        grading = UniformRadius(g.number("radius", "m", min=lo_d / 2, max=hi_d / 2), spread, key=g.name)
    seed = g.integer("seed", 1, min=0)

    m = root.section("material", {})
    mat = MATERIALS[m.choice("name", tuple(MATERIALS), "quartz")]
    fields: dict[str, Any] = {}
    # physical ranges: shear moduli from soft polymer beads (1 MPa) to diamond (~0.5 TPa);
    # densities from foams (10 kg/m^3) to osmium (22 600 kg/m^3); friction coefficients to 10
    # (84 deg: a contact that never slides)
    for k, unit, lo, hi in (("shear_modulus", "Pa", *GRAIN_SHEAR_MODULUS_RANGE), ("poisson", None, -1, 0.5),
                            ("density", "kg/m^3", 10, 30000), ("friction", None, 0, 10),
                            ("restitution", None, 0, 1)):
        if m.has(k):
            fields[k] = m.number(k, unit, min=lo, max=hi, min_inclusive=k not in ("poisson", "restitution"),
                                 max_inclusive=k != "poisson")
    try:
        mat = replace(mat, **fields)
    except ValueError as exc:
        raise ConfigError(m.name, fields, str(exc)) from None
    from grainmech.lammps.rolling import grain_law

    rolling = build_rolling(m, grain_law(mat, 1.0))
    if rolling is not None:
        mat = replace(mat, rolling=rolling)

    pr = root.section("preparation")
    if not pr.has("stress"):  # not "unknown key 'stress_tol' (did you mean 'stress'?)"
        raise ConfigError(pr.key("stress"), None, "required key is missing (the stress the packing is brought to, "
                          "e.g. stress = \"100 kPa\")")
    raw = pr.raw("stress")
    if isinstance(raw, list):
        if len(raw) != 3:
            raise ConfigError(pr.key("stress"), raw, "give one stress or three principal stresses (x, y, z)")
        sx, sy, sz = (to_float(v, "Pa", f"{pr.key('stress')}[{i}]") for i, v in enumerate(raw))
        stress = (sx, sy, sz)
    else:
        s0 = to_float(raw, "Pa", pr.key("stress"))
        stress = (s0, s0, s0)
    if not all(s > 0 for s in stress):
        raise ConfigError(pr.key("stress"), raw, "must be positive (compression positive)")
    for sv in stress:
        check_pressure(sv, pr.key("stress"), raw)
    kw: dict[str, Any] = {}
    kw["prep_friction"] = pr.number("friction", None, 0.0, min=0, max=10)
    if pr.has("rolling_friction"):
        kw["prep_rolling"] = _dimensionless(pr, "rolling_friction")
    if pr.has("grain_rolling"):
        gr = pr.raw("grain_rolling")
        if gr not in GRAIN_ROLLING:
            raise ConfigError(pr.key("grain_rolling"), gr, f"must be one of {', '.join(map(repr, GRAIN_ROLLING))} "
                              "(when the grains' own rolling resistance acts: in the relaxation, or after the "
                              "preparation with the springs unloaded)")
        if mat.rolling is None:
            raise ConfigError(pr.key("grain_rolling"), gr, "needs [material] rolling_friction (the grains have no "
                              "rolling resistance)")
        kw["grain_rolling"] = gr
    if pr.has("unbalanced_tol"):
        kw["unbalanced_tol"] = pr.number("unbalanced_tol", None, min=0, max=1, min_inclusive=False,
                                         max_inclusive=False)
    if pr.has("stress_tol"):
        kw["stress_tol"] = pr.number("stress_tol", None, min=0, max=1, min_inclusive=False, max_inclusive=False)
    if pr.has("max_steps"):
        kw["max_steps"] = pr.integer("max_steps", min=1000, max=1_000_000_000)
    threads = pr.integer("threads", 0, min=0, max=os.cpu_count() or 1)
    settings = PackSettings(stress, seed=seed, threads=threads or None, **kw)
    root.finish()
    return PackConfig(grading, n, ratio, mat, settings)

"""Sweep files: read, validate and expand into points (one resolved run config each).

File format (TOML; see ``docs/sweep.md``)::

    [sweep]
    kind = "stiffness"            # stiffness | run | dem
    base = "my_config.toml"       # base config, relative to this file (or an inline [base] table)
    design = "grid"               # grid | latin-hypercube | monte-carlo
    samples = 50                  # latin-hypercube / monte-carlo: number of points
    seed = 1                      # latin-hypercube / monte-carlo (default 0)

    [parameters."microstructure.void_ratio"]
    values = [0.55, 0.65, 0.75]

    [parameters."stress.pressure"]
    min = "50 kPa"
    max = "800 kPa"
    num = 5                       # grid only
    scale = "log"                 # linear (default) | log

Every point is the base config with the swept keys replaced by SI values; its id is a
stable hash of the run kind and the resolved config (:func:`point_id`).
"""

from __future__ import annotations

import copy
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.config import Section, load_toml
from grainmech.io.schema import MICROSTRUCTURE, RENAMED_TABLES, microstructure_key
from grainmech.io.units import config_value
from grainmech.sweep.design import DESIGNS, SweepParameter, make_design, parse_parameter, parse_path
from grainmech.sweep.kinds import SWEEP_KINDS

__all__ = ["Sweep", "Point", "load_sweep", "sweep_from_dict", "parse_path", "set_path", "point_id"]

#: the largest number of points a sweep may have (a guard against typos such as num = 1e6)
MAX_POINTS = 1_000_000


def set_path(cfg: dict, key: str, value: Any) -> None:
    """Set ``cfg[<dotted key>] = value`` in place, creating missing tables."""
    segs = parse_path(key)
    node: Any = cfg
    for i, s in enumerate(segs[:-1]):
        nxt = segs[i + 1]
        if isinstance(s, int):
            if not isinstance(node, list) or s >= len(node):
                raise ConfigError(f"parameters.{key}", value, "index out of range in the base config")
            node = node[s]
            continue
        if not isinstance(node, dict):
            raise ConfigError(f"parameters.{key}", value, f"{s!r} is inside a value that is not a table")
        if s not in node:
            if isinstance(nxt, int):
                raise ConfigError(f"parameters.{key}", value, f"the base config has no array {s!r}")
            node[s] = {}
        node = node[s]
    last = segs[-1]
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            raise ConfigError(f"parameters.{key}", value, "index out of range in the base config")
        node[last] = value
    elif not isinstance(node, dict):
        raise ConfigError(f"parameters.{key}", value, "the parent of this key is not a table")
    else:
        if isinstance(node.get(last), dict):
            raise ConfigError(f"parameters.{key}", value, "names a table, not a value")
        node[last] = value


def point_id(kind: str, config: dict) -> str:
    """Stable 16-hex-digit id: SHA-256 of the run kind and the canonical JSON of the config."""
    text = json.dumps({"kind": kind, "config": config}, sort_keys=True, separators=(",", ":"),
                      default=str, allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Point:
    """One run of a sweep: its index in the design, swept values (parameter order), config, id."""

    index: int
    values: tuple
    config: dict = field(repr=False)
    id: str = ""


@dataclass
class Sweep:
    """A validated sweep: run kind, base config, parameters and the expanded points."""

    kind: str
    base: dict
    base_dir: Path
    source: str
    base_source: str
    design: str
    parameters: list[SweepParameter]
    points: list[Point]
    samples: int | None = None
    seed: int | None = None

    def describe(self) -> dict:
        """JSON-ready description (written to ``sweep.json``)."""
        return {"source": self.source, "kind": self.kind, "base": self.base_source, "design": self.design,
                "samples": self.samples, "seed": self.seed, "n_points": len(self.points),
                "parameters": [{"key": p.key, "column": p.column, "unit": p.unit,
                                "values": None if p.values is None else list(p.values),
                                "min": None if p.values is not None else p.lo,
                                "max": None if p.values is not None else p.hi,
                                "scale": p.scale, "num": p.num} for p in self.parameters],
                "base_config": self.base}


def load_sweep(path: str | Path, *, check: bool = True) -> Sweep:
    """Read a sweep file (see the module docstring)."""
    p = Path(path)
    return sweep_from_dict(load_toml(p), p.parent, source=str(path), check=check)


def sweep_from_dict(data: dict, sweep_dir: str | Path = ".", *, source: str = "<dict>",
                    check: bool = True) -> Sweep:
    """Validate a sweep given as a dict and expand its points.

    ``sweep_dir`` resolves a relative ``sweep.base`` path (and, for an inline base, the
    relative file paths of a dem config). With ``check`` the base config with the first
    points' values is read by the run kind's parser, so misspelt keys fail here, naming
    the key, instead of failing every point.
    """
    sweep_dir = Path(sweep_dir)
    root = Section(data, "")
    sw = root.section("sweep")
    kind = sw.choice("kind", tuple(SWEEP_KINDS))
    design = sw.choice("design", DESIGNS, "grid")
    if design == "grid":
        for k in ("samples", "seed"):
            if sw.has(k):
                raise ConfigError(sw.key(k), sw.data[k], "only for design = 'latin-hypercube' or 'monte-carlo'")
        samples: int | None = None
        seed: int | None = None
    else:
        samples = sw.integer("samples", min=1)
        seed = sw.integer("seed", 0, min=0)
    if sw.has("base") and root.has("base"):
        raise ConfigError("sweep.base", sw.data["base"], "give either sweep.base (a file) or a [base] table, not both")
    if sw.has("base"):
        ref = sw.raw("base")
        if not isinstance(ref, str) or not ref.strip():
            raise ConfigError("sweep.base", ref, "must be the path of a config file (relative to the sweep file)")
        bpath = sweep_dir / ref
        if not bpath.is_file():
            raise ConfigError("sweep.base", ref, f"config file not found (looked for {bpath})")
        try:
            base = load_toml(bpath)
        except GrainmechError as exc:
            raise ConfigError("sweep.base", ref, str(exc)) from None
        base_dir, base_source = bpath.parent, ref
    elif root.has("base"):
        base = root.raw("base")
        if not isinstance(base, dict):
            raise ConfigError("base", base, "must be a table (the inline base config)")
        base_dir, base_source = sweep_dir, "inline [base] table"
    else:
        raise ConfigError("sweep.base", None, "required: the path of a base config, or an inline [base] table")
    praw = root.raw("parameters")
    if not isinstance(praw, dict) or not praw:
        raise ConfigError("parameters", praw, "must be a table with one sub-table per swept key, "
                                              "e.g. [parameters.\"microstructure.void_ratio\"]")
    psec = root.section("parameters")
    params = [parse_parameter(key, psec.section(key), design) for key in praw]
    root.finish()
    _check_table_names(params, base)

    n_total = 1
    if design == "grid":
        for p in params:
            n_total *= len(p.grid_values())
    elif samples is not None:
        n_total = samples
    if n_total > MAX_POINTS:
        raise ConfigError("parameters", list(praw), f"gives {n_total} points (more than {MAX_POINTS})")
    values = make_design(design, params, samples, seed or 0)
    points: list[Point] = []
    seen: dict[str, int] = {}
    for i, vals in enumerate(values):
        cfg = copy.deepcopy(base)
        for p, v in zip(params, vals):
            set_path(cfg, p.key, config_value(v, p.unit) if isinstance(v, float) else v)
        pid = point_id(kind, cfg)
        if pid in seen:
            raise ConfigError("parameters", list(praw), f"points {seen[pid]} and {i} resolve to the same "
                                                        "config (repeated values?)")
        seen[pid] = i
        points.append(Point(i, tuple(vals), cfg, pid))
    sweep = Sweep(kind, base, base_dir, source, base_source, design, params, points, samples, seed)
    if check:
        check_sweep(sweep)
    return sweep


def _check_table_names(params: list[SweepParameter], base: dict) -> None:
    """Refuse a swept key in the analytical microstructure's table under the name the base does not use.

    ``[packing]`` is the old name of ``[microstructure]`` (both are read): a swept
    ``packing.void_ratio`` on a base with ``[microstructure]`` would add a second table.
    """
    if not any(n in base for n in (MICROSTRUCTURE, *RENAMED_TABLES)):
        return
    ms = microstructure_key(Section(base, ""))
    for p in params:
        head, _, rest = p.key.partition(".")
        if head in (MICROSTRUCTURE, *RENAMED_TABLES) and head != ms:
            raise ConfigError(f"parameters.{p.key}", None, f"the base config calls this table [{ms}] "
                              f"([packing] is the old name of [microstructure]): write '{ms}.{rest}'")


def check_sweep(sweep: Sweep) -> None:
    """Read the points' configs with the run kind's parser (no computation) until one is valid.

    Raises a :class:`ConfigError` for an unknown key, an error in a key that is not swept
    (a broken base config), or when no point at all has a valid config. A bad *value* of
    a swept key in some points is left to those points, which are recorded as failed.
    """
    kind = SWEEP_KINDS[sweep.kind]
    swept = {p.key for p in sweep.parameters}
    first: GrainmechError | None = None
    for pt in sweep.points:
        try:
            kind.prepare(pt.config, sweep.base_dir)
            return
        except ConfigError as exc:
            if exc.problem.startswith("unknown key"):
                raise ConfigError(f"parameters.{exc.key}" if exc.key in swept else exc.key, exc.value,
                                  f"not a key of a {sweep.kind!r} config ({exc.problem})") from None
            if exc.key not in swept:
                raise ConfigError(exc.key, exc.value, f"{exc.problem} (in the base config "
                                                      f"{sweep.base_source})") from None
            first = first or exc
        except GrainmechError as exc:
            first = first or exc
    if first is not None:
        raise GrainmechError(f"no point of the sweep has a valid config; the first: {first}")

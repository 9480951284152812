"""Parameters of a sweep and the designs that sample them: grid, Latin hypercube, Monte Carlo.

A :class:`SweepParameter` is one config key (a dotted path such as ``"microstructure.void_ratio"``)
with either an explicit list of ``values`` or a range ``[lo, hi]`` on a linear or log
scale. Quantities with units (``"50 kPa"``, ``"24 deg"``) are converted to SI at the
edge; the column of the sweep table then names the SI unit (``"stress.pressure [Pa]"``).

The designs map points of the unit cube to parameter values:

* :func:`grid` -- the Cartesian product of every parameter's values (the last parameter
  varies fastest); a range needs ``num`` values (``linspace`` / ``logspace``).
* :func:`latin_hypercube` -- :class:`scipy.stats.qmc.LatinHypercube`, seeded: each of the
  ``n`` equal strata of every parameter (in log space for a log scale) holds exactly
  one sample.
* :func:`monte_carlo` -- independent uniform (log-uniform) samples, seeded.

A parameter given by ``values`` is sampled by LHS / Monte Carlo as a discrete uniform
choice (stratum ``floor(u n)``).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import qmc

from grainmech.errors import ConfigError, ParameterError
from grainmech.io.units import ANGLE_UNITS as _ANGLES
from grainmech.io.units import to_float, unit_registry

__all__ = ["SweepParameter", "parse_parameter", "grid", "latin_hypercube", "monte_carlo", "make_design",
           "DESIGNS", "si_value"]

DESIGNS = ("grid", "latin-hypercube", "monte-carlo")

#: SI units a quantity is reported in, tried in order (first with the right dimension wins)
_SI_UNITS = ("Pa", "m", "N/m", "N", "1/m**3", "1/m**2", "1/m", "Hz", "s", "kg/m**3", "kg", "J",
             "J/m**3", "m**2", "m**3", "K")


_NUMERIC = re.compile(r"\s*[-+]?(\d|\.\d|inf|nan)", re.IGNORECASE)


def _is_quantity_text(v: str) -> bool:
    return bool(_NUMERIC.match(v))


def _check_si_unit(unit: Any, key: str) -> str:
    if not isinstance(unit, str) or not unit.strip():
        raise ConfigError(key, unit, "must be a unit name such as 'Pa'")
    ureg = unit_registry()
    try:
        q = ureg.Quantity(1.0, unit)
        factor = float(q.to_base_units().magnitude) if not q.dimensionless else float(q.to("rad").magnitude)
    except Exception as exc:  # pint raises many kinds
        raise ConfigError(key, unit, f"unknown unit ({exc})") from None
    if not math.isclose(factor, 1.0, rel_tol=1e-12):
        raise ConfigError(key, unit, "must be an SI unit (Pa, m, N/m, rad, ...): sweep tables hold SI "
                                     "values; write quantities like '50 kPa' in the values instead")
    return unit.strip()


def si_value(value: Any, key: str, unit: str | None = None) -> tuple[float, str]:
    """A number or quantity string -> (SI float, SI unit label or ``""``).

    Bare numbers are taken as SI (as everywhere in grainmech configs). With ``unit`` the
    quantity is converted to it; otherwise the unit is inferred from the quantity's
    dimension (``Pa``, ``m``, ``N/m``, ...; angles become ``rad``).
    """
    if unit is not None:
        return to_float(value, unit, key), unit
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ConfigError(key, value, "expected a number or a quantity string")
    if isinstance(value, (int, float)):
        return to_float(value, None, key), ""
    try:
        return float(value.strip()), ""
    except ValueError:
        pass
    ureg = unit_registry()
    try:
        q = ureg.Quantity(value.strip())
    except Exception as exc:  # pint's parser raises many kinds
        raise ConfigError(key, value, f"cannot read this quantity ({str(exc) or type(exc).__name__})") from None
    if not isinstance(q, ureg.Quantity):
        return to_float(value, None, key), ""
    if q.dimensionless:
        label = "rad" if str(q.units) in _ANGLES else ""
        return to_float(value, label or None, key), label
    for u in _SI_UNITS:
        if q.dimensionality == ureg.Quantity(1.0, u).dimensionality:
            return to_float(value, u, key), u
    base = q.to_base_units()
    return to_float(value, f"{base.units:~}", key), f"{base.units:~}"


@dataclass(frozen=True)
class SweepParameter:
    """One swept config key.

    Attributes
    ----------
    key : str
        Dotted config path (``"stress.pressure"``, ``"test.segments[0].amplitude"``).
    unit : str
        SI unit of the values (``""`` for dimensionless or text values).
    values : tuple or None
        Explicit values (SI floats, or strings/booleans for choices).
    lo, hi : float
        Range (SI) when ``values`` is None.
    scale : str
        ``"linear"`` or ``"log"``.
    num : int or None
        Number of grid values for a range.
    """

    key: str
    unit: str = ""
    values: tuple | None = None
    lo: float = math.nan
    hi: float = math.nan
    scale: str = "linear"
    num: int | None = None

    @property
    def column(self) -> str:
        """Column name in the sweep table: the key with its SI unit in brackets."""
        return f"{self.key} [{self.unit}]" if self.unit else self.key

    @property
    def numeric(self) -> bool:
        """Whether every value is a number (a range, or a list of numbers)."""
        return self.values is None or all(isinstance(v, float) for v in self.values)

    def grid_values(self) -> list:
        """The values of a grid: the given list, or ``num`` points from ``min`` to ``max`` (linear or log)."""
        if self.values is not None:
            return list(self.values)
        if self.num is None:
            raise ParameterError("num", None, f"parameter {self.key!r}: a min/max range needs num (points)")
        n = int(self.num)
        if n == 1:
            return [self.lo]
        if self.scale == "log":
            v = np.logspace(math.log10(self.lo), math.log10(self.hi), n)
        else:
            v = np.linspace(self.lo, self.hi, n)
        v[0], v[-1] = self.lo, self.hi  # exact end points
        return [float(x) for x in v]

    def from_unit(self, u: np.ndarray) -> list:
        """Map samples ``u`` in [0, 1) to parameter values.

        Map samples ``u`` in [0, 1) to values (inverse CDF of the uniform / log-uniform
        distribution, or a discrete uniform choice among ``values``).
        """
        u = np.asarray(u, dtype=float)
        if self.values is not None:
            idx = np.minimum((u * len(self.values)).astype(int), len(self.values) - 1)
            return [self.values[i] for i in idx]
        if self.scale == "log":
            a, b = math.log(self.lo), math.log(self.hi)
            return [float(x) for x in np.exp(a + u * (b - a))]
        return [float(x) for x in self.lo + u * (self.hi - self.lo)]


#: one segment of a dotted config path: ``name`` or ``name[i][j]``
_SEGMENT = re.compile(r"^([A-Za-z0-9_\-]+)((?:\[\d+\])*)$")


def parse_path(key: Any, where: str = "parameters") -> list[str | int]:
    """``"test.segments[0].amplitude"`` -> ``["test", "segments", 0, "amplitude"]``."""
    if not isinstance(key, str) or not key.strip():
        raise ConfigError(where, key, "a parameter key must be a dotted config path such as "
                          "'microstructure.void_ratio'")
    out: list[str | int] = []
    for part in key.split("."):
        m = _SEGMENT.match(part)
        if not m:
            raise ConfigError(where, key, f"bad path segment {part!r} (expected name or name[index])")
        out.append(m.group(1))
        out.extend(int(i) for i in re.findall(r"\[(\d+)\]", m.group(2)))
    return out


def parse_parameter(key: str, sec: Any, design: str) -> SweepParameter:
    """A :class:`SweepParameter` from the table ``[parameters."<key>"]`` (a config Section)."""
    parse_path(key, sec.name)
    if str(key).rsplit(".", 1)[-1].endswith("angle") and not sec.has("unit"):
        # one rule for angles in every config (docs/config.md): the unit is required
        for k in ("values", "min", "max"):
            vs = sec.data.get(k)
            for v in (vs if isinstance(vs, list) else [vs]):
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    raise ConfigError(sec.key(k), sec.data[k], "an angle needs its unit: write e.g. "
                                                               f"'{v:g} deg' or '{v:g} rad'")
    unit = _check_si_unit(sec.raw("unit"), sec.key("unit")) if sec.has("unit") else None
    scale = sec.choice("scale", ("linear", "log"), "linear")
    if sec.has("values"):
        for k in ("min", "max", "num"):
            if sec.has(k):
                raise ConfigError(sec.key(k), sec.data[k], "give either values or a min/max range, not both")
        if sec.has("scale"):
            raise ConfigError(sec.key("scale"), sec.data["scale"], "applies to a min/max range, not to values")
        raw = sec.raw("values")
        if not isinstance(raw, list) or not raw:
            raise ConfigError(sec.key("values"), raw, "must be a non-empty list")
        vals: list = []
        labels = set()
        for v in raw:
            if isinstance(v, bool) or (isinstance(v, str) and not _is_quantity_text(v)):
                vals.append(v)  # a choice (e.g. a law name or a correlation), passed as is
                continue
            if not isinstance(v, (int, float, str)):
                raise ConfigError(sec.key("values"), raw, "values must be numbers, quantity strings or names")
            x, lab = si_value(v, sec.key("values"), unit)
            if isinstance(v, str):
                labels.add(lab)
            vals.append(x)
        if len(labels) > 1:
            raise ConfigError(sec.key("values"), raw, f"mixes units of different kinds ({', '.join(sorted(labels))})")
        if any(isinstance(v, float) for v in vals) and not all(isinstance(v, float) for v in vals):
            raise ConfigError(sec.key("values"), raw, "mixes numbers and names")
        seen = set()
        for v in vals:
            if v in seen:
                raise ConfigError(sec.key("values"), raw, f"value {v!r} is repeated")
            seen.add(v)
        lab = unit if unit is not None else (labels.pop() if labels else "")
        return SweepParameter(key, lab, tuple(vals))
    if not (sec.has("min") and sec.has("max")):
        missing = "min" if not sec.has("min") else "max"
        raise ConfigError(sec.key(missing), None, "required: give values = [...] or both min and max")
    lo, lab_lo = si_value(sec.raw("min"), sec.key("min"), unit)
    hi, lab_hi = si_value(sec.raw("max"), sec.key("max"), unit)
    strs = [lab for lab, v in ((lab_lo, sec.data["min"]), (lab_hi, sec.data["max"])) if isinstance(v, str)]
    if len(set(strs)) > 1:
        raise ConfigError(sec.key("max"), sec.data["max"], f"has units of another kind than min = {sec.data['min']!r}")
    if not hi > lo:
        raise ConfigError(sec.key("max"), sec.data["max"], f"must be greater than min = {sec.data['min']!r}")
    if scale == "log" and lo <= 0:
        raise ConfigError(sec.key("min"), sec.data["min"], "must be positive for scale = 'log'")
    num = None
    if design == "grid":
        num = sec.integer("num", min=1)
        if num == 1:
            raise ConfigError(sec.key("num"), num, "must be >= 2 for a range (use values = [x] for one value)")
    elif sec.has("num"):
        raise ConfigError(sec.key("num"), sec.data["num"], f"only for design = 'grid' (this sweep is {design!r}; "
                                                          "the number of points is sweep.samples)")
    lab = unit if unit is not None else (strs[0] if strs else "")
    return SweepParameter(key, lab, None, lo, hi, scale, num)


def grid(params: Sequence[SweepParameter]) -> list[tuple]:
    """Cartesian product of the parameters' values, last parameter fastest."""
    return [tuple(p) for p in itertools.product(*(q.grid_values() for q in params))]


def _from_cube(params: Sequence[SweepParameter], u: np.ndarray) -> list[tuple]:
    cols = [p.from_unit(u[:, j]) for j, p in enumerate(params)]
    return [tuple(c[i] for c in cols) for i in range(u.shape[0])]


def lhs_unit(n: int, d: int, seed: int) -> np.ndarray:
    """``(n, d)`` Latin hypercube sample of the unit cube (scipy.stats.qmc, seeded)."""
    return qmc.LatinHypercube(d, rng=np.random.default_rng(seed)).random(n)


def latin_hypercube(params: Sequence[SweepParameter], n: int, seed: int) -> list[tuple]:
    """``n`` points of a seeded Latin hypercube design."""
    return _from_cube(params, lhs_unit(n, len(params), seed))


def monte_carlo(params: Sequence[SweepParameter], n: int, seed: int) -> list[tuple]:
    """``n`` independent uniform (log-uniform) points, seeded."""
    return _from_cube(params, np.random.default_rng(seed).random((n, len(params))))


def make_design(design: str, params: Sequence[SweepParameter], samples: int | None = None,
                seed: int = 0) -> list[tuple]:
    """Points (one tuple of values per point, in parameter order) of a design."""
    if design not in DESIGNS:
        raise ConfigError("sweep.design", design, f"must be one of {', '.join(map(repr, DESIGNS))}")
    if design == "grid":
        return grid(params)
    if samples is None:
        raise ParameterError("samples", None, f"design {design!r} needs the number of samples")
    if design == "latin-hypercube":
        return latin_hypercube(params, int(samples), seed)
    return monte_carlo(params, int(samples), seed)

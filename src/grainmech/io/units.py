"""Quantities with units, converted at the edge (pint, optional extra ``units``).

Config values may be plain numbers (taken in the unit system of the run, SI in the
examples) or strings such as ``"15000 psi"``, ``"0.5 in"``, ``"24 deg"``.
:func:`to_float` converts them to a float in a requested target unit and raises
:class:`~grainmech.errors.ConfigError` naming the key when that is impossible.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

from grainmech.errors import ConfigError

__all__ = ["to_float", "unit_registry"]


@lru_cache(maxsize=1)
def unit_registry():  # pragma: no cover - trivial
    """The shared pint registry (created lazily)."""
    try:
        import pint
    except ImportError as exc:  # pragma: no cover - depends on environment
        raise ConfigError("units", None, "quantities with units need the 'pint' package "
                          "(pip install 'grainmech[units]')") from exc
    ureg = pint.UnitRegistry()
    ureg.define("lbf_per_in = lbf / inch")
    return ureg


def to_float(value: Any, unit: str | None, key: str) -> float:
    """Convert a config value to a float in ``unit``.

    Parameters
    ----------
    value : float, int or str
        A number (taken as already in ``unit``) or a string with units.
    unit : str or None
        Target unit understood by pint (``"Pa"``, ``"m"``, ``"N/m"``, ``"rad"``...). For a
        dimensionless quantity pass ``None`` or ``""``.
    key : str
        Config key, used in error messages.

    Raises
    ------
    ConfigError
        If the value is not a number, has an unknown unit, the wrong dimension, or is
        not finite.
    """
    if isinstance(value, bool):
        raise ConfigError(key, value, "expected a number or a quantity string, got a boolean")
    if isinstance(value, (int, float)):
        out = float(value)
    elif isinstance(value, str):
        text = value.strip()
        try:
            out = float(text)
        except ValueError:
            ureg = unit_registry()
            import pint
            try:
                q = ureg.Quantity(text)
            except Exception as exc:  # pint's parser raises many kinds (TokenError, ZeroDivisionError...)
                detail = str(exc) or type(exc).__name__
                raise ConfigError(key, value, f"cannot read this quantity ({detail})") from None
            target = unit if unit else "dimensionless"
            if not isinstance(q, ureg.Quantity):  # e.g. "2" parsed as a plain number
                q = ureg.Quantity(float(q), "dimensionless")
            if not unit and q.units != ureg.dimensionless:
                # pint counts angles and percent as dimensionless: "1 deg" would pass as 0.01745
                raise ConfigError(key, value, f"is a dimensionless number: write it without a unit "
                                  f"(got {format(q.units, '~') or str(q.units)!r})") from None
            try:
                out = float(q.to(target).magnitude)
            except pint.errors.DimensionalityError:
                raise ConfigError(key, value, f"has units of {q.dimensionality}, "
                                  f"expected something convertible to {target}") from None
    else:
        raise ConfigError(key, value, "expected a number or a quantity string")
    if not math.isfinite(out):
        raise ConfigError(key, value, "must be finite")
    return out


#: pint names of angle units (dimensionless in pint; configs hold angles in radians)
ANGLE_UNITS = ("degree", "radian", "arcminute", "arcsecond", "turn", "revolution", "gradian")


def config_value(value: float, si_unit: str) -> float | str:
    """A value to write into a config dict, in SI units.

    A value to write into a config dict: angles as ``"<x> rad"`` (a bare angle is an
    error in every config, ``docs/config.md``), everything else as the bare SI number.
    """
    return f"{float(value)!r} rad" if si_unit == "rad" else float(value)

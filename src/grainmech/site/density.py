"""A layer's packing chosen by its density: the nearest shipped sand packing by relative density.

A layer gives ``relative_density`` (``D_r``, 0-1) or ``void_ratio`` (``e``). The table of
candidates is read from the shipped packings themselves (:data:`grainmech.packing.SAND_PACKINGS`,
each one's summary for its void ratio and :func:`grainmech.packing.packing_limits` for the
``e_min`` / ``e_max`` measured for its grains), so a packing added to the shipped set is a
candidate without a change here. Relative density (Kulhawy & Mayne 1990, as
:func:`grainmech.analysis.empirical.relative_density`)::

    D_r = (e_max - e) / (e_max - e_min)

A void ratio is turned into a relative density with the limits of each candidate's own
grains; the candidate whose ``D_r`` is nearest the asked one is taken. A difference above
:data:`DENSITY_FLAG` is flagged in the layer's row (the nearest packing is still used). A
void ratio outside ``[e_min, e_max]`` of every candidate's grains, or a relative density
outside 0-1, is a bad input: no packing of these grains can reach it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

from grainmech.analysis.empirical import relative_density
from grainmech.errors import ConfigError
from grainmech.packing import SAND_PACKINGS, packing_info, packing_limits

__all__ = ["SandPacking", "sand_packings", "choose_packing", "named_packing", "DENSITY_FLAG"]

#: difference of relative density between the packing used and the one asked above which the row is flagged
DENSITY_FLAG = 0.1


@dataclass(frozen=True)
class SandPacking:
    """A shipped sand packing with the limits of its grains."""

    name: str
    void_ratio: float
    e_min: float
    e_max: float

    @property
    def relative_density(self) -> float:
        """``D_r`` of the packing against its grains' limits."""
        return relative_density(self.void_ratio, self.e_min, self.e_max)


@functools.lru_cache(maxsize=1)
def sand_packings() -> tuple[SandPacking, ...]:
    """The shipped sand packings with measured limits (from their summaries), loosest last."""
    out = []
    for name in SAND_PACKINGS:
        lim = packing_limits(name)
        if lim is None:
            continue
        out.append(SandPacking(name, float(packing_info(name)["void_ratio"]), float(lim["e_min"]),
                               float(lim["e_max"])))
    return tuple(sorted(out, key=lambda p: -p.relative_density))


def _choice(pk: SandPacking, asked_key: str, asked_value: float, asked_dr: float, named: bool) -> dict:
    diff = pk.relative_density - asked_dr
    return {"asked": asked_key, "asked_value": float(asked_value), "asked_relative_density": float(asked_dr),
            "packing": pk.name, "packing_void_ratio": pk.void_ratio,
            "packing_relative_density": pk.relative_density, "e_min": pk.e_min, "e_max": pk.e_max,
            "difference": float(diff), "flag": bool(abs(diff) > DENSITY_FLAG), "named": named}


def _asked_dr(pk: SandPacking, key: str, value: float) -> float:
    return float(value) if key == "relative_density" else relative_density(value, pk.e_min, pk.e_max)


def _check(key: str, value: float, where: str, label: str) -> None:
    cands = sand_packings()
    if key == "relative_density" and not 0.0 <= value <= 1.0:
        raise ConfigError(where, value, f"{label}: a relative density lies in 0-1 (D_r = (e_max - e)/(e_max - e_min))")
    if key == "void_ratio" and not any(p.e_min <= value <= p.e_max for p in cands):
        lims = ", ".join(f"{p.name}: {p.e_min:.3f}-{p.e_max:.3f}" for p in cands)
        raise ConfigError(where, value, f"{label}: no shipped sand packing reaches this void ratio (the limits "
                          f"e_min-e_max of their grains: {lims})")


def choose_packing(key: str, value: float, where: str, label: str) -> dict:
    """The nearest shipped sand packing by relative density to ``key = value`` of a layer.

    Parameters
    ----------
    key : {"relative_density", "void_ratio"}
    value : float
    where, label : str
        The config key and the layer, for the error.

    Returns
    -------
    dict
        ``asked``, ``asked_value``, ``asked_relative_density``, ``packing``,
        ``packing_void_ratio``, ``packing_relative_density``, ``e_min``, ``e_max``,
        ``difference`` (packing's D_r - asked), ``flag`` (above :data:`DENSITY_FLAG`).

    Raises
    ------
    ConfigError
        A relative density outside 0-1, a void ratio no candidate's grains reach, or no
        shipped sand packing with measured limits.
    """
    cands = sand_packings()
    if not cands:
        raise ConfigError(where, value, f"{label}: no shipped sand packing with measured void-ratio limits")
    _check(key, value, where, label)
    usable = [p for p in cands if key == "relative_density" or p.e_min <= value <= p.e_max]
    best = min(usable, key=lambda p: abs(p.relative_density - _asked_dr(p, key, value)))
    return _choice(best, key, value, _asked_dr(best, key, value), named=False)


def named_packing(name: str, key: str, value: float, where: str, label: str) -> dict | None:
    """The density of a layer that names its packing too: the named one, against the asked density.

    ``None`` when ``name`` is not a shipped sand packing with measured limits (nothing to
    compare); raises as :func:`choose_packing` for a density no packing reaches.
    """
    _check(key, value, where, label)
    pk = next((p for p in sand_packings() if p.name == name), None)
    if pk is None:
        return None
    return _choice(pk, key, value, _asked_dr(pk, key, value), named=True)

"""``--set KEY=VALUE`` of the DEM benchmarks: a :class:`grainmech.driver.dem.DemSettings` from the command line."""

from __future__ import annotations

import dataclasses

from grainmech.driver.dem import DemSettings


def settings_from(pairs: list[str] | None) -> DemSettings:
    """DemSettings with each ``KEY=VALUE`` of ``pairs`` (typed as the field's default; ``true``/``false``)."""
    base = DemSettings()
    kw = {}
    for pair in pairs or []:
        key, _, text = pair.partition("=")
        if key not in base.__dataclass_fields__ or not text:
            raise SystemExit(f"--set {pair!r}: expected KEY=VALUE with KEY one of {sorted(base.__dataclass_fields__)}")
        default = getattr(base, key)
        if isinstance(default, str):
            kw[key] = text
        elif isinstance(default, bool):
            kw[key] = text.lower() == "true"
        else:
            kw[key] = type(default)(float(text)) if isinstance(default, int) else float(text)
    return dataclasses.replace(base, **kw)

"""The packing model as a :class:`~grainmech.driver.base.KinematicModel` (in :mod:`grainmech.driver.registry`).

Every grain in force and moment equilibrium at every step, in a fixed reference geometry:
where the grains would rearrange, or where it stops, it hands the amplitudes over to a
model whose grains rearrange.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from grainmech.driver.packing import PackingPoint, PackingResult, packing_modulus_reduction, run_packing

__all__ = ["PackingModel", "PACKING"]


class PackingModel:
    """The packing model: its start is a :class:`~grainmech.driver.packing.PackingPoint`."""

    name: str = "packing"
    title: str = "packing model"
    needs_grains: bool = True
    settings_section: str | None = "packing_options"
    amplitudes_key: str | None = "packing_amplitudes"
    steps_per_cycle_key: str | None = None
    max_amplitude: float = float("inf")
    upper_bound: bool = False
    fixed_geometry: bool = True
    takes_over: bool = False
    engine: str | None = None
    envelope_note: str = ("the packing model keeps a fixed reference geometry: read this amplitude with its sliding "
                     "fraction and equilibrium residual")

    def series(self, start: PackingPoint, amplitudes: Sequence[float], **options: Any) -> Any:
        """:func:`~grainmech.driver.packing.packing_modulus_reduction` from ``start``."""
        return packing_modulus_reduction(start, amplitudes, **options)

    def path(self, start: PackingPoint, load_path: Any, **options: Any) -> PackingResult:
        """:func:`~grainmech.driver.packing.run_packing` along ``load_path``."""
        return run_packing(start, load_path, **options)

    def details(self, start: PackingPoint) -> dict:
        """Grains in equilibrium, rattlers left out, contact pairs tracked and closed, the point's notes."""
        return {"grains": int(start.n_grains), "rattlers": int(start.n_rattlers),
                "contacts_tracked": int(start.n_contacts), "contacts_closed": int(np.sum(start.initially_closed)),
                "notes": list(start.notes)}


#: the one packing model
PACKING = PackingModel()

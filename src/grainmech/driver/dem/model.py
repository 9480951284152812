"""The DEM model as a :class:`~grainmech.driver.base.KinematicModel` (in :mod:`grainmech.driver.registry`).

LAMMPS on the same grains, quasi-statically: contacts form and break, grains rearrange;
it runs the amplitudes a fixed-geometry model hands over.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from grainmech.driver.dem.run import DemResult, run_dem
from grainmech.driver.dem.series import DEM_MAX_AMPLITUDE, dem_modulus_reduction
from grainmech.driver.dem.settings import DemSettings, dem_material

__all__ = ["DemStart", "DemModel", "DEM"]


@dataclass(frozen=True)
class DemStart:
    """What every DEM run starts from: the grains, their law and the run's settings.

    Attributes
    ----------
    network : grainmech.network.ContactNetwork
        The packing (3D, periodic, with radii).
    law : object
        The contact law for spheres.
    settings : DemSettings or None
        :class:`~grainmech.driver.dem.settings.DemSettings` (None: the defaults).
    pressure : float or None
        Mean stress [Pa] the packing is brought to before the test.
    rolling : object or None
        Rolling and twisting resistance.
    workers : int
        Processes that run amplitudes side by side.
    """

    network: Any
    law: Any
    settings: DemSettings | None = None
    pressure: float | None = None
    rolling: Any = None
    workers: int = 1


class DemModel:
    """The DEM model: its start is a :class:`DemStart` (the LAMMPS system lives in each run)."""

    name: str = "dem"
    title: str = "DEM model"
    needs_grains: bool = True
    settings_section: str | None = "dem"
    amplitudes_key: str | None = "dem_amplitudes"
    steps_per_cycle_key: str | None = "dem_steps_per_cycle"
    max_amplitude: float = DEM_MAX_AMPLITUDE
    upper_bound: bool = False
    fixed_geometry: bool = False
    takes_over: bool = True
    engine: str | None = "LAMMPS"
    envelope_note: str = "read this amplitude with its unbalanced force ratio"

    def series(self, start: DemStart, amplitudes: Sequence[float], **options: Any) -> Any:
        """:func:`~grainmech.driver.dem.series.dem_modulus_reduction` on ``start``'s grains."""
        return dem_modulus_reduction(start.network, start.law, amplitudes, settings=start.settings,
                                     pressure=start.pressure, workers=start.workers, rolling=start.rolling, **options)

    def path(self, start: DemStart, load_path: Any, **options: Any) -> DemResult:
        """:func:`~grainmech.driver.dem.run.run_dem` along ``load_path`` on ``start``'s grains."""
        return run_dem(start.network, start.law, load_path, start.settings, pressure=start.pressure,
                       rolling=start.rolling, **options)

    def details(self, start: DemStart) -> dict:
        """Grains, settings and the notes of the law LAMMPS runs (:func:`dem_material`)."""
        _, law_notes = dem_material(start.law)
        settings = start.settings if start.settings is not None else DemSettings()
        return {"grains": int(start.network.n_particles), "settings": settings.as_dict(), "notes": list(law_notes)}


#: the one DEM model
DEM = DemModel()

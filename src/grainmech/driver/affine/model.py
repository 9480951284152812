"""The affine model as a :class:`~grainmech.driver.base.KinematicModel` (in :mod:`grainmech.driver.registry`).

The seed's kinematic hypothesis (every contact follows the mean strain, seed Eq. 2.13) on
an analytical microstructure: an upper bound that cannot fail.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from grainmech.driver.affine.point import MaterialPoint
from grainmech.driver.affine.solver import DriverResult, modulus_reduction, run

__all__ = ["AffineModel", "AFFINE"]


class AffineModel:
    """The affine model: its start is a :class:`~grainmech.driver.affine.point.MaterialPoint`."""

    name: str = "affine"
    title: str = "affine model"
    needs_grains: bool = False
    settings_section: str | None = None
    amplitudes_key: str | None = None
    steps_per_cycle_key: str | None = None
    max_amplitude: float = float("inf")
    upper_bound: bool = True
    fixed_geometry: bool = False
    takes_over: bool = False
    engine: str | None = None
    envelope_note: str = ("the affine model cannot fail (every contact follows the mean strain): this amplitude's "
                     "G/Gmax and damping are not predictions for a sand")

    def series(self, start: MaterialPoint, amplitudes: Sequence[float], *,
               runner: Callable[..., DriverResult] = run, **options: Any) -> Any:
        """:func:`~grainmech.driver.affine.solver.modulus_reduction` from ``start``, each amplitude by ``runner``."""
        return modulus_reduction(start, amplitudes, runner=runner, **options)

    def path(self, start: MaterialPoint, load_path: Any, **options: Any) -> DriverResult:
        """:func:`~grainmech.driver.affine.solver.run` along ``load_path``, with the engineering columns."""
        return run(start, load_path, engineering=True, **options)

    def details(self, start: MaterialPoint) -> dict:
        """Nothing beyond the config's microstructure."""
        return {}


#: the one affine model
AFFINE = AffineModel()

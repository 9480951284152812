"""The kinematic models of grainmech, one registered :class:`~grainmech.driver.base.KinematicModel` each.

:data:`MODELS` maps a model's name (``[model] method``) to the model, in the order the
models are listed to a user; :func:`model` looks one up. The jobs and the CLI dispatch
through it: what a model needs and does is read from its attributes, not from its name.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from grainmech.driver.affine.model import AFFINE
from grainmech.driver.base import KinematicModel
from grainmech.driver.dem.model import DEM
from grainmech.driver.packing.model import PACKING
from grainmech.errors import ParameterError

__all__ = ["MODELS", "model", "resolve", "own_keys"]

#: name -> model: the affine model (the seed's kinematic hypothesis), the packing model
#: (every grain in equilibrium in a fixed geometry), the DEM model (LAMMPS on the same grains)
MODELS: Mapping[str, KinematicModel] = MappingProxyType({m.name: m for m in (AFFINE, PACKING, DEM)})


def model(name: str) -> KinematicModel:
    """The registered model called ``name``; :class:`~grainmech.errors.ParameterError` naming the known ones."""
    try:
        return MODELS[name]
    except (KeyError, TypeError):
        raise ParameterError("method", name, f"is not a kinematic model: the known ones are {list(MODELS)}") from None


def resolve(m: str | KinematicModel) -> KinematicModel:
    """A model given by name or as itself."""
    return model(m) if isinstance(m, str) else m


def own_keys(m: KinematicModel) -> tuple[str, ...]:
    """The model's own ``[model]`` keys and table: its settings section, amplitude list, steps per cycle."""
    return tuple(k for k in (m.settings_section, m.amplitudes_key, m.steps_per_cycle_key) if k is not None)

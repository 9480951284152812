"""What a ``grainmech run`` config asks for: the kinematic models, the test kinds and the spec.

:class:`RunSpec` is read by :func:`grainmech.jobs.run_config.prepare_run`; the packing of
grains of the packing and DEM models is a :class:`PackingSource`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.errors import ConfigError

__all__ = ["CYCLIC_SIMPLE_SHEAR", "RUN_TEST_KINDS", "RUN_METHODS", "GRAIN_METHODS", "RunSpec", "PackingSource"]

#: ``test.kind`` of a modulus-reduction series (the one place the name is spelt)
CYCLIC_SIMPLE_SHEAR = "cyclic-simple-shear"
#: test kinds of ``grainmech run`` (``[test] kind``): cyclic simple shear at several
#: amplitudes, or a mixed-control path of ``[[test.segments]]``
RUN_TEST_KINDS = (CYCLIC_SIMPLE_SHEAR, "path")
#: kinematic models of ``grainmech run`` (``[model] method``): ``"affine"``, the seed's
#: kinematic hypothesis (every contact follows the mean strain, seed Eq. 2.13) on an
#: analytical fabric; ``"packing"``, a packing of grains with every grain in equilibrium
#: (:mod:`grainmech.driver.packing`); ``"dem"``, the same test run by LAMMPS on the same
#: grains, quasi-statically: contacts form and break, grains rearrange
#: (:mod:`grainmech.driver.dem`)
RUN_METHODS = ("affine", "packing", "dem")
#: the methods that run on a packing of grains (``[model] packing`` or ``network``)
GRAIN_METHODS = ("packing", "dem")


@dataclass
class RunSpec:
    """Objects read from a ``grainmech run`` config."""

    kind: str
    packing: Any
    law: Any
    pressure: float
    degree: int
    amplitudes: list[float] = field(default_factory=list)
    n_cycles: int = 2
    steps_per_cycle: int = 40
    waveform: str = "triangle"
    constant: str = "stress"
    reference: dict | None = None
    path: Any = None
    void_ratio: float | None = None
    friction: float = float("inf")
    keep_beyond_envelope: bool = False
    warnings: list = field(default_factory=list)
    methods: tuple = ("affine",)
    grains: PackingSource | None = None
    packing_law: Any = None
    gmax_grains: PackingSource | None = None
    packing_amplitudes: list[float] | None = None
    packing_options: dict = field(default_factory=dict)
    dem_amplitudes: list[float] | None = None
    dem_steps_per_cycle: int = 16
    dem_settings: Any = None
    dem_workers: int = 1
    dem_handed: tuple | None = None
    dem_series: Any = None

    def amplitudes_of(self, method: str) -> list[float]:
        """The cyclic amplitudes of ``method`` (``[model] packing_amplitudes`` / ``dem_amplitudes``)."""
        if method == "packing" and self.packing_amplitudes is not None:
            return self.packing_amplitudes
        if method == "dem" and self.dem_amplitudes is not None:
            return self.dem_amplitudes
        return self.amplitudes


@dataclass
class PackingSource:
    """The packing of grains of ``method = "packing"`` (``[model]`` table of a run config).

    Attributes
    ----------
    label : str
        ``"shipped packing 'medium'"`` or the file name, for messages and reports.
    network : grainmech.network.ContactNetwork
        The packing read (3D, periodic, with radii).
    """

    label: str
    network: Any

    @property
    def void_ratio(self) -> float:
        """Void ratio ``e = V / V_s - 1`` of the cell.

        ``V_s`` is the volume of all spheres, rattlers included.
        """
        return float(self.network.void_ratio)


def _read_amplitudes(section: Any, key: str) -> list[float]:
    """A non-empty list of positive strain amplitudes ``section[key]``."""
    amps = section.raw(key)
    if not isinstance(amps, list) or not amps:
        raise ConfigError(section.key(key), amps, "must be a non-empty list of strains")
    try:
        bad = [a for a in amps if isinstance(a, bool) or not np.isfinite(float(a)) or float(a) <= 0]
    except (TypeError, ValueError):
        bad = [amps]
    if bad:
        raise ConfigError(section.key(key), amps, "every amplitude must be a positive strain")
    return [float(a) for a in amps]

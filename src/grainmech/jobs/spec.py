"""What a ``grainmech run`` config asks for: the kinematic models, the test kinds and the spec.

:class:`RunSpec` is read by :func:`grainmech.jobs.run_config.prepare_run`; the packing of
grains of the packing and DEM models is a :class:`PackingSource`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech._deprecated import warn_renamed
from grainmech.driver.base import HandOver, KinematicModel
from grainmech.driver.dem import DEM_MAX_AMPLITUDE
from grainmech.driver.registry import MODELS, resolve
from grainmech.errors import ConfigError

__all__ = ["CYCLIC_SIMPLE_SHEAR", "RUN_TEST_KINDS", "RUN_METHODS", "GRAIN_METHODS", "RunSpec", "PackingSource"]

#: ``test.kind`` of a modulus-reduction series (the one place the name is spelt)
CYCLIC_SIMPLE_SHEAR = "cyclic-simple-shear"
#: test kinds of ``grainmech run`` (``[test] kind``): cyclic simple shear at several
#: amplitudes, or a mixed-control path of ``[[test.segments]]``
RUN_TEST_KINDS = (CYCLIC_SIMPLE_SHEAR, "path")
#: kinematic models of ``grainmech run`` (``[model] method``), the names of
#: :data:`grainmech.driver.registry.MODELS`: ``"affine"``, the seed's kinematic hypothesis
#: (every contact follows the mean strain, seed Eq. 2.13) on an analytical fabric;
#: ``"packing"``, a packing of grains with every grain in equilibrium
#: (:mod:`grainmech.driver.packing`); ``"dem"``, the same test run by LAMMPS on the same
#: grains, quasi-statically: contacts form and break, grains rearrange
#: (:mod:`grainmech.driver.dem`)
RUN_METHODS = tuple(MODELS)
#: the methods that run on a packing of grains (``[model] packing`` or ``network``)
GRAIN_METHODS = tuple(name for name, m in MODELS.items() if m.needs_grains)
#: largest strain amplitude of any model: the DEM model's (:data:`grainmech.driver.dem.DEM_MAX_AMPLITUDE`);
#: the affine and packing models are small-strain models and stop well before it
MAX_AMPLITUDE = DEM_MAX_AMPLITUDE
#: most recorded states of one amplitude's cycles (``n_cycles * steps_per_cycle``) or of a
#: path (the sum of its segments' steps): the step tables of one run stay within a few GB
MAX_STATES = 1_000_000
#: most recorded states of one DEM amplitude or path (each a LAMMPS relaxation of 0.1-1 s:
#: beyond, a day per amplitude)
MAX_DEM_STATES = 100_000


def check_states(sec: Any, keys: tuple[str, str], n: int, steps: int, limit: int = MAX_STATES,
                 what: str = "recorded states per amplitude") -> None:
    """Refuse ``n * steps`` above ``limit``, naming both keys of ``sec`` and their values."""
    if n * steps > limit:
        a, b = keys
        raise ConfigError(sec.key(b), steps, f"with {sec.key(a)} = {n}: {n * steps:.3g} {what}, more than "
                          f"{limit:.0e} (memory and time); lower one of them")


@dataclass
class RunSpec:
    """Objects read from a ``grainmech run`` config.

    ``microstructure`` (:class:`~grainmech.material.Microstructure`, the
    ``[microstructure]`` table and the fabric) and ``law`` are those of the models that run
    on the analytical microstructure (None without one); ``grains`` is the packing of grains
    of the packing and DEM models and ``grain_law`` the contact law both of them apply to
    it (the ``[contacts]`` law, evaluated at every contact's own radii). ``packing``, the
    old name of ``microstructure``, warns.

    ``rolling``: the contacts' rolling and twisting resistance
    (:class:`~grainmech.contact.rolling.RollingResistance`, ``[contacts]``
    ``rolling_friction``, ``rolling_stiffness``, ``twisting_friction``), None when the
    config has none or it resists nothing; the packing and DEM models carry it, the
    affine model has no grain rotation (its run warns).

    ``methods`` are the names the config gives, :attr:`models` the registered models
    (:mod:`grainmech.driver.registry`). ``warnings`` are those of the analytical
    microstructure's input (the models that need no grains report them).
    """

    kind: str
    microstructure: Any
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
    #: a path test: the step count at the end of each of its ``[[test.segments]]``
    segment_ends: tuple = ()
    void_ratio: float | None = None
    friction: float = float("inf")
    keep_beyond_envelope: bool = False
    warnings: list = field(default_factory=list)
    methods: tuple = ("affine",)
    grains: PackingSource | None = None
    grain_law: Any = None
    gmax_grains: PackingSource | None = None
    packing_amplitudes: list[float] | None = None
    packing_options: dict = field(default_factory=dict)
    dem_amplitudes: list[float] | None = None
    dem_steps_per_cycle: int = 16
    dem_settings: Any = None
    dem_workers: int = 1
    #: one amplitude list for a fixed-geometry model and a model after it that takes over:
    #: each amplitude is run by one model (the packing model from the smallest up to the
    #: first it stops on or flags, the DEM model from there; :mod:`grainmech.jobs.handover`)
    one_list: bool = False
    rolling: Any = None

    @property
    def models(self) -> tuple[KinematicModel, ...]:
        """The registered models of :attr:`methods`, in the config's order."""
        return tuple(resolve(m) for m in self.methods)

    def amplitudes_of(self, model: str | KinematicModel, handed: HandOver | None = None) -> list[float]:
        """The cyclic amplitudes of ``model``: its own list (``[model] <amplitudes_key>``) or ``test.amplitudes``.

        With ``handed`` (the amplitudes an earlier model of the job left to it,
        :func:`grainmech.jobs.handover.hand_over`) those join the list, in ascending order.
        """
        own = self.own_amplitudes(model)
        amps = own if own is not None else self.amplitudes
        if handed is not None and handed.amplitudes:
            return sorted(amps + list(handed.amplitudes))
        return amps

    def own_amplitudes(self, model: str | KinematicModel) -> list[float] | None:
        """The amplitude list ``model`` has of its own (``[model] <amplitudes_key>``), None when it has none."""
        key = resolve(model).amplitudes_key
        return getattr(self, key) if key is not None else None

    def steps_per_cycle_of(self, model: str | KinematicModel) -> int:
        """Steps per cycle of ``model``: its own (``[model] <steps_per_cycle_key>``) or ``test.steps_per_cycle``."""
        m = resolve(model)
        return int(getattr(self, m.steps_per_cycle_key)) if m.steps_per_cycle_key is not None else self.steps_per_cycle

    def law_of(self, model: str | KinematicModel) -> Any:
        """The contact law of ``model``: the grains' (``grain_law``) or the microstructure's (``law``)."""
        return self.grain_law if resolve(model).needs_grains else self.law

    @property
    def packing(self) -> Any:
        """The old name of :attr:`microstructure` (warns; removed in the next minor release)."""
        warn_renamed("RunSpec.packing", "RunSpec.microstructure")
        return self.microstructure


@dataclass
class PackingSource:
    """The packing of grains of ``method = "packing"`` (``[model]`` table of a run config).

    Attributes
    ----------
    label : str
        ``"shipped packing 'medium'"`` or the file name, for messages and reports.
    network : grainmech.network.ContactNetwork
        The packing read (3D, periodic, with radii).
    description : str
        What a shipped packing models (its grains, void ratio and relative density,
        :func:`grainmech.packing.shipped.describe_packing`); empty for a file.
    """

    label: str
    network: Any
    description: str = ""

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
    if len({float(a) for a in amps}) != len(amps):
        raise ConfigError(section.key(key), amps, "lists an amplitude twice: give each once")
    big = [float(a) for a in amps if float(a) > MAX_AMPLITUDE]
    if big:
        raise ConfigError(section.key(key), amps, f"amplitude {big[0]:g} is beyond what any test reaches (at most "
                          f"{MAX_AMPLITUDE:g}, the DEM model's): amplitudes are decimal strains, did you mean "
                          f"{big[0]:g} % ({big[0] / 100:g})?")
    return [float(a) for a in amps]

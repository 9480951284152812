"""Modulus reduction and damping of any kinematic model: one entry, the model named.

:func:`modulus_reduction` runs strain-controlled cyclic simple shear at every amplitude
from one start state with the model it is given (a name of
:data:`grainmech.driver.registry.MODELS` or the model itself) and returns its
:class:`~grainmech.analysis.ModulusReduction`: the model's own ``series``, through the
registry, so that a script asks for a model the way a config does (``[model] method``).
The driver is imported on first call (``import grainmech.analysis`` does not import it).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, cast

from numpy.typing import ArrayLike

from grainmech.errors import ParameterError

__all__ = ["modulus_reduction"]


def modulus_reduction(start: Any, amplitudes: ArrayLike, *, model: Any = "affine", **options: Any) -> Any:
    """G/Gmax and damping against strain amplitude: cyclic simple shear of ``start`` by ``model``.

    Each amplitude starts from ``start`` (strain-controlled ``gamma_xz``, constant
    ``sigma_zz`` unless ``constant="volume"``); the last of ``n_cycles`` cycles gives the
    secant modulus ``G = tau_a / gamma_a`` and the damping ``D = dW / (4 pi W)``
    (:func:`grainmech.analysis.loop_properties`), ``G_max`` the model's small-strain
    modulus condensed for the path's control (:func:`grainmech.driver.loop.cyclic_series`).

    Parameters
    ----------
    start : object
        What the model starts from: for ``"affine"`` (the seed's kinematic hypothesis,
        every contact follows the mean strain, seed Eq. 2.13) a
        :class:`~grainmech.driver.MaterialPoint`
        (:func:`grainmech.driver.affine.solver.modulus_reduction`: ``n_cycles=2``,
        ``steps_per_cycle=80``, ``waveform``, ``constant``, ``progress``,
        ``raise_on_failure``, ``on_amplitude``, ``runner`` and the run's options); for
        ``"packing"`` (every grain in equilibrium in a fixed reference geometry) a
        :class:`~grainmech.driver.packing.PackingPoint`
        (:func:`grainmech.driver.packing.packing_modulus_reduction`, ``steps_per_cycle=40``);
        for ``"dem"`` (LAMMPS on the same grains, which rearrange) a
        :class:`~grainmech.driver.dem.model.DemStart`: the grains, their law, settings,
        pressure, rolling resistance and worker processes
        (:func:`grainmech.driver.dem.dem_modulus_reduction`).
    amplitudes : array_like of float
        Shear strain amplitudes (engineering ``gamma``, decimal).
    model : str or KinematicModel
        ``"affine"`` (default), ``"packing"``, ``"dem"``, or a registered model itself.
    **options
        Passed to the model's series (listed above).

    Returns
    -------
    grainmech.analysis.ModulusReduction

    Raises
    ------
    ParameterError
        For a name that is not a kinematic model (naming the known ones).
    """
    from grainmech.driver.registry import resolve  # noqa: PLC0415 (the driver, on first use)

    try:
        m = resolve(model)
    except ParameterError as exc:
        raise ParameterError("model", model, exc.problem) from None
    return m.series(start, cast(Sequence[float], amplitudes), **options)  # an array passes as it is

"""Analysis of driver results: modulus reduction, damping, directional moduli, references.

See ``docs/analysis.md``. The analysis sits above the driver: the names every model's
cyclic series needs live there and are found here on first use --
:func:`loop_properties`, :class:`LoopProperties` and :class:`ModulusReduction`
(:mod:`grainmech.driver.loop`) --; :func:`modulus_reduction` runs any kinematic model's
series (``model="affine"``, ``"packing"`` or ``"dem"``, through
:mod:`grainmech.driver.registry`; :mod:`grainmech.analysis.series`);
:func:`condensed_modulus` is :func:`grainmech.elasticity.condensed_modulus`.
"""

from typing import Any

from grainmech.analysis.directional import apparent_moduli
from grainmech.analysis.empirical import (
    DARENDELI_PHI,
    MENQ_D50_MAX,
    P_ATM,
    SAND_PEAK_FRICTION_DEG,
    DarendeliCurves,
    HardinDrnevichReference,
    HardinRichart,
    MenqCurves,
    darendeli,
    hardin_drnevich,
    hardin_drnevich_reference,
    hardin_richart,
    masing_damping_hyperbolic,
    menq_curve,
    mohr_coulomb_ratio,
)
from grainmech.analysis.loops import LOOP_ASYMMETRY_TOLERANCE, LOOP_CLOSURE_TOLERANCE, LoopQuality, loop_quality
from grainmech.analysis.series import modulus_reduction
from grainmech.elasticity import condensed_modulus

__all__ = ["DARENDELI_PHI", "MENQ_D50_MAX", "MenqCurves", "menq_curve",
           "P_ATM", "SAND_PEAK_FRICTION_DEG", "DarendeliCurves", "HardinDrnevichReference",
           "HardinRichart", "hardin_drnevich_reference", "LOOP_ASYMMETRY_TOLERANCE", "LOOP_CLOSURE_TOLERANCE",
           "LoopQuality", "loop_quality",
           "hardin_richart", "mohr_coulomb_ratio", "LoopProperties", "ModulusReduction",
           "apparent_moduli", "condensed_modulus", "darendeli", "hardin_drnevich", "loop_properties",
           "masing_damping_hyperbolic", "modulus_reduction"]


def __getattr__(name: str) -> Any:
    """The driver's names, on first use (``import grainmech.analysis`` does not import the driver)."""
    if name in ("loop_properties", "LoopProperties", "ModulusReduction"):
        from grainmech.driver import loop  # noqa: PLC0415 (the driver, on first use)

        return getattr(loop, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

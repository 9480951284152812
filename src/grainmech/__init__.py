"""grainmech: micro-structural model of granular materials.

Implements the particulate model of Chang (1988), "Deformation behavior of sands under
cyclic loading - a micro-structural approach" (the *seed* report), and goes beyond it.
Conventions (compression positive, component order) are in :mod:`grainmech.conventions`.

The main objects are available from the package itself and are imported on first use
(``import grainmech`` stays fast and imports neither matplotlib nor numba)::

    import grainmech as gm
    ms = gm.Microstructure.from_grains(gm.isotropic(3), void_ratio=0.65, coordination=8.7, radius=2.5e-4)
    res = gm.microstructure_stiffness(ms, gm.HertzMindlin(44e9, 0.08, 2.5e-4), 1e5)
"""

from __future__ import annotations

import importlib
import os
from typing import Any

from grainmech._deprecated import install_module_aliases, warn_renamed
from grainmech.errors import ConfigError, GrainmechError, ParameterError

install_module_aliases()

# The compiled kernels' parallel loops run on OpenMP (numba's "omp" layer) in regions of
# ~0.3-3 ms. With OpenMP's default active waiting, a thread that finishes its share spins
# on its core; on a machine whose cores are shared with other jobs the spinning thread
# takes the core from the one it waits for, and the threaded mixed-control driver ran 4x
# slower than the serial one (docs/performance.md). Passive waiting, with a short spin
# first (GNU OpenMP's GOMP_SPINCOUNT = 1000, ~25 us here): the mixed-control driver's
# regions follow each other within microseconds and a worker still spinning is woken for
# free (-10 % on an idle machine against no spin), while a core taken by another job loses
# at most that spin per region (as fast as no spin there; 10000 was 40 % slower). Values
# the user set are kept (a GOMP_SPINCOUNT only with our passive policy: it would override
# ACTIVE's); read once by the OpenMP runtime when numba first starts its threads, i.e.
# after this import.
if "OMP_WAIT_POLICY" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
    os.environ.setdefault("GOMP_SPINCOUNT", "1000")

__version__ = "0.1.0"

#: public name -> module that defines it (imported lazily by :func:`__getattr__`)
_LAZY: dict[str, str] = {
    # fabric: contact-normal densities (seed Eq. 4.7-4.9), fitting, coordination
    **dict.fromkeys(("SphericalDensity", "FourierDensity", "isotropic", "density_from_fabric_tensor",
                     "fit_density", "fabric_tensor", "coordination_number"), "grainmech.fabric"),
    # contact laws (seed Ch. 3)
    **dict.fromkeys(("Hertz", "HertzMindlin", "MindlinDeresiewicz", "LinearSpring", "Cylinder"),
                    "grainmech.contact"),
    # the analytical description of a granular material and its stiffness (seed Eq. 2.41);
    # packing_stiffness: its old name (warns when called; Packing: _RENAMED)
    **dict.fromkeys(("Microstructure", "microstructure_stiffness", "StiffnessResult", "packing_stiffness"),
                    "grainmech.material"),
    **dict.fromkeys(("ContactSet", "stiffness", "love_weber_stress"), "grainmech.assembly"),
    **dict.fromkeys(("engineering_constants", "symmetry_class", "bulk_modulus", "shear_modulus"),
                    "grainmech.elasticity"),
    # material-point driver and loading paths
    **dict.fromkeys(("MaterialPoint", "run", "segment", "cycles", "concatenate", "cyclic_simple_shear",
                     "triaxial", "DriverResult"), "grainmech.driver"),
    # analysis and empirical references
    **dict.fromkeys(("modulus_reduction", "ModulusReduction", "darendeli", "menq_curve", "hardin_drnevich",
                     "hardin_drnevich_reference", "hardin_richart", "apparent_moduli"), "grainmech.analysis"),
    # packings of grains (DEM contact networks)
    **dict.fromkeys(("ContactNetwork", "relaxed_stiffness", "affine_stiffness"), "grainmech.network"),
    # config -> result, as the command line does it
    **dict.fromkeys(("compute_stiffness", "compute_run", "compute_contact", "compute_dem"), "grainmech.jobs"),
    "plots": "grainmech.plots",
}

#: old public name -> its new name (each use warns, DeprecationWarning; removed in the next release)
_RENAMED = {"Packing": "Microstructure"}

__all__ = ["ConfigError", "GrainmechError", "ParameterError", "__version__", *sorted([*_LAZY, *_RENAMED])]


def __getattr__(name: str) -> Any:
    if name in _RENAMED:
        warn_renamed(f"grainmech.{name}", f"grainmech.{_RENAMED[name]}")
        return __getattr__(_RENAMED[name])
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'grainmech' has no attribute {name!r}")
    module = importlib.import_module(mod)
    value = module if mod.rsplit(".", 1)[-1] == name else getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | set(_RENAMED))

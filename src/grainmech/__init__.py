"""grainmech: micro-structural model of granular materials.

Implements the particulate model of Chang (1988), "Deformation behavior of sands under
cyclic loading - a micro-structural approach" (the *seed* report), and goes beyond it.
Conventions (compression positive, component order) are in :mod:`grainmech.conventions`.
"""

from grainmech.errors import ConfigError, GrainmechError

__version__ = "0.1.0"
__all__ = ["ConfigError", "GrainmechError", "__version__"]

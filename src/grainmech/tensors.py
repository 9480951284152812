"""Alias of :mod:`grainmech.elasticity`.

Alias of :mod:`grainmech.elasticity` under its former name (``from grainmech.tensors
import ...`` keeps working); new code imports :mod:`grainmech.elasticity`.
"""

from grainmech.elasticity import *  # noqa: F401,F403
from grainmech.elasticity import __all__  # noqa: F401

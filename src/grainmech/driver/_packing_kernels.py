"""Old path of :mod:`grainmech.driver.packing._kernels`: the same module object under this name.

``import grainmech.driver._packing_kernels`` gives :mod:`grainmech.driver.packing._kernels` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import _kernels as _module

sys.modules[__name__] = _module

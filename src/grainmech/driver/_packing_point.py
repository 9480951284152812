"""Old path of :mod:`grainmech.driver.packing.point`: the same module object under this name.

``import grainmech.driver._packing_point`` gives :mod:`grainmech.driver.packing.point` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import point as _module

sys.modules[__name__] = _module

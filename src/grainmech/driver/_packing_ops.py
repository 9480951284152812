"""Old path of :mod:`grainmech.driver.packing._operators`: the same module object under this name.

``import grainmech.driver._packing_ops`` gives :mod:`grainmech.driver.packing._operators` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import _operators as _module

sys.modules[__name__] = _module

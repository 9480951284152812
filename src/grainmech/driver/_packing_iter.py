"""Old path of :mod:`grainmech.driver.packing._iterations`: the same module object under this name.

``import grainmech.driver._packing_iter`` gives :mod:`grainmech.driver.packing._iterations` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import _iterations as _module

sys.modules[__name__] = _module

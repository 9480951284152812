"""Old path of :mod:`grainmech.driver.packing.options`: the same module object under this name.

``import grainmech.driver._packing_options`` gives :mod:`grainmech.driver.packing.options` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import options as _module

sys.modules[__name__] = _module

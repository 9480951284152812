"""Old path of :mod:`grainmech.driver.packing.step`: the same module object under this name.

``import grainmech.driver._packing_step`` gives :mod:`grainmech.driver.packing.step` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import step as _module

sys.modules[__name__] = _module

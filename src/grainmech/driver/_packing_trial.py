"""Old path of :mod:`grainmech.driver.packing._trial`: the same module object under this name.

``import grainmech.driver._packing_trial`` gives :mod:`grainmech.driver.packing._trial` itself,
so that every name, private ones included, is the one the packing model uses.
"""

import sys

from grainmech.driver.packing import _trial as _module

sys.modules[__name__] = _module

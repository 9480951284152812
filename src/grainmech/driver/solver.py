"""Old path of :mod:`grainmech.driver.affine.solver`: the same module object under this name.

``import grainmech.driver.solver`` gives :mod:`grainmech.driver.affine.solver` itself (not a
copy of its names), so that every name, private ones included, is the one the affine
model uses.
"""

import sys

from grainmech.driver.affine import solver as _module

sys.modules[__name__] = _module

"""Old path of :mod:`grainmech.driver.affine.point`: the same module object under this name.

``import grainmech.driver.point`` gives :mod:`grainmech.driver.affine.point` itself (not a
copy of its names), so that every name, private ones included, is the one the affine
model uses.
"""

import sys

from grainmech.driver.affine import point as _module

sys.modules[__name__] = _module

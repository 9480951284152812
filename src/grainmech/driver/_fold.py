"""Old path of :mod:`grainmech.driver.affine._fold`: the same module object under this name.

``import grainmech.driver._fold`` gives :mod:`grainmech.driver.affine._fold` itself (not a
copy of its names), so that every name, private ones included, is the one the affine
model uses.
"""

import sys

from grainmech.driver.affine import _fold as _module

sys.modules[__name__] = _module

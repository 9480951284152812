"""Old path of :mod:`grainmech.driver.affine._fused`: the same module object under this name.

``import grainmech.driver._fused`` gives :mod:`grainmech.driver.affine._fused` itself (not a
copy of its names), so that every name, private ones included, is the one the affine
model uses.
"""

import sys

from grainmech.driver.affine import _fused as _module

sys.modules[__name__] = _module

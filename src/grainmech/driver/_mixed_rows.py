"""Old path of :mod:`grainmech.driver.affine._mixed_rows`: the same module object under this name.

``import grainmech.driver._mixed_rows`` gives :mod:`grainmech.driver.affine._mixed_rows` itself (not a
copy of its names), so that every name, private ones included, is the one the affine
model uses.
"""

import sys

from grainmech.driver.affine import _mixed_rows as _module

sys.modules[__name__] = _module

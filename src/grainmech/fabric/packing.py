"""Deprecated: the packing-density and coordination correlations are :mod:`grainmech.fabric.coordination` now.

Importing this module warns (:class:`DeprecationWarning`); it is removed in the next
release ("packing" names a packing of grains only). Every name is the same.
"""

from __future__ import annotations

from grainmech._deprecated import warn_renamed
from grainmech.fabric.coordination import *  # noqa: F403 - the old module's names, unchanged
from grainmech.fabric.coordination import __all__  # noqa: F401

warn_renamed("grainmech.fabric.packing", "grainmech.fabric.coordination", stacklevel=2)

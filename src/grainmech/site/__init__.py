"""Curves for every layer of a soil profile, anchored to measured Vs, and their site response.

``grainmech site PROFILE.toml`` (``docs/site-profile.md``): a profile of layers over a
half-space (:func:`read_profile`, :func:`load_profile`), every layer's effective stresses
at mid-depth, one ``grainmech run`` per layer at its mean effective stress (optionally
anchored to a measured shear-wave velocity), Darendeli's (2001) and Menq's (2003) curves
beside, all layers on Dask with resume (:func:`run_site`), and with pystrata (extra
``site``) the equivalent-linear site response with each set of curves
(:mod:`grainmech.site.strata`).
"""

from __future__ import annotations

from pathlib import Path

from grainmech.io.config import load_toml
from grainmech.site.profile import Bedrock, Layer, MotionSpec, SiteProfile, jaky_k0, layer_stresses, read_profile
from grainmech.site.runner import run_site

__all__ = ["SiteProfile", "Layer", "Bedrock", "MotionSpec", "read_profile", "load_profile", "run_site",
           "jaky_k0", "layer_stresses"]


def load_profile(path: str | Path) -> SiteProfile:
    """Read ``PROFILE.toml`` (:func:`read_profile`; relative file paths from the file's folder)."""
    p = Path(path)
    return read_profile(load_toml(p), p.parent, source=p.name)

"""Config tables -> library objects (shared by the CLI and the Python API).

Tables understood here (all keys optional unless marked):

``[packing]``
    ``void_ratio``, ``coordination`` (a number or a correlation name: ``"yanagisawa"``,
    ``"smith"``, ``"filep"``, ``"field"``, ``"chang"``), ``radius`` (length), ``convention``
    (``"physical"`` | ``"seed"``); or directly ``contacts_per_volume`` (1/length^d) and
    ``branch_length`` (length).
``[fabric]``
    ``dim`` (3 | 2); seed parameters ``a20, a22, b22`` (3D) or ``a2, b2, a4, b4`` (2D);
    or ``tensor`` (a fabric tensor N_ij, trace 1); default isotropic.
``[contacts]``
    ``law = "linear"`` with ``kn``, ``ks`` (force/length), or ``law = "hertz-mindlin"``
    with ``shear_modulus`` (stress) and ``poisson``.
``[stress]``
    ``pressure`` (stress), or ``tensor`` (3x3 / 2x2, compression positive).

Unit system: quantities with units are converted to SI; bare numbers are taken as SI.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainmech.errors import ConfigError
from grainmech.io.config import Section

__all__ = ["build_fabric", "build_packing", "build_contacts", "build_stress"]

SEED_3D = ("a20", "a22", "b22")
SEED_2D = ("a2", "b2", "a4", "b4")


def build_fabric(sec: Section) -> Any:
    """Density from ``[fabric]`` (seed parameters or a fabric tensor)."""
    from grainmech import fabric

    dim = sec.integer("dim", 3)
    if dim not in (2, 3):
        raise ConfigError(sec.key("dim"), dim, "must be 2 or 3")
    names = SEED_3D if dim == 3 else SEED_2D
    other = SEED_2D if dim == 3 else SEED_3D
    for k in other:
        if sec.has(k):
            raise ConfigError(sec.key(k), sec.data[k], f"is a {'2D' if dim == 3 else '3D'} parameter but dim = {dim}")
    if sec.has("tensor"):
        if any(sec.has(k) for k in names):
            raise ConfigError(sec.key("tensor"), sec.data["tensor"], f"give either tensor or {', '.join(names)}, not both")
        raw = sec.raw("tensor")
        try:
            N = np.asarray(raw, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(sec.key("tensor"), raw, "must be a square array of numbers") from None
        if N.shape != (dim, dim):
            raise ConfigError(sec.key("tensor"), raw, f"must be a {dim}x{dim} array")
        if not np.all(np.isfinite(N)) or abs(np.trace(N) - 1.0) > 1e-6 or not np.allclose(N, N.T):
            raise ConfigError(sec.key("tensor"), raw, "must be symmetric with trace 1 (N_ij = <n_i n_j>)")
        return fabric.density_from_fabric_tensor(N)
    vals = {k: sec.number(k, None, 0.0) for k in names}
    cls = fabric.SphericalDensity if dim == 3 else fabric.FourierDensity
    return cls.from_seed(**vals)


def build_packing(sec: Section, density: Any) -> Any:
    """Packing from ``[packing]`` and a density."""
    from grainmech.fabric import CORRELATIONS, coordination_number
    from grainmech.material import Packing

    convention = sec.choice("convention", ("physical", "seed"), "physical")
    if sec.has("contacts_per_volume") or sec.has("branch_length"):
        nv = sec.number("contacts_per_volume", f"1/m**{density.dim}", min=0, min_inclusive=False)
        bl = sec.number("branch_length", "m", min=0, min_inclusive=False)
        radius = sec.number("radius", "m", None, min=0, min_inclusive=False)
        return Packing(density, nv, bl, convention, radius)
    e = sec.number("void_ratio", None, min=0, min_inclusive=False)
    coord = sec.raw("coordination")
    name = coord.strip().lower() if isinstance(coord, str) else None
    if name is not None and name in CORRELATIONS:
        m = float(coordination_number(e, name))
    else:
        try:
            m = sec.number("coordination", None, min=0, min_inclusive=False)
        except ConfigError:
            if isinstance(coord, str):
                raise ConfigError(sec.key("coordination"), coord, "must be a positive number or one of "
                                  f"{', '.join(map(repr, sorted(CORRELATIONS)))}") from None
            raise
    radius = sec.number("radius", "m", min=0, min_inclusive=False)
    return Packing.from_grains(density, void_ratio=e, coordination=m, radius=radius, convention=convention)


def build_contacts(sec: Section, packing: Any) -> Any:
    """Contact stiffness provider from ``[contacts]``."""
    from grainmech.material import ConstantStiffness

    law = sec.choice("law", ("linear", "hertz-mindlin"))
    if law == "linear":
        return ConstantStiffness(sec.number("kn", "N/m", min=0), sec.number("ks", "N/m", min=0))
    from grainmech.contact import HertzMindlin

    G = sec.number("shear_modulus", "Pa", min=0, min_inclusive=False)
    nu = sec.number("poisson", None, min=-1, max=0.5, min_inclusive=False, max_inclusive=False)
    return HertzMindlin.for_equal_spheres(G, nu, packing.radius)


#: Stresses a config may give [Pa]: 1 uPa to 1 TPa. Far outside every granular material
#: (quartz grains crush near 1 GPa), and the limits keep Hertz forces and moduli (which
#: go as p^(1/3) and p^(2/3)) away from floating-point under- and overflow.
PRESSURE_MIN, PRESSURE_MAX = 1e-6, 1e12


def build_pressure(sec: Section, key: str = "pressure") -> float:
    """A mean stress [Pa] in :data:`PRESSURE_MIN` .. :data:`PRESSURE_MAX`."""
    return sec.number(key, "Pa", min=PRESSURE_MIN, max=PRESSURE_MAX)


def build_stress(sec: Section, dim: int) -> Any:
    """Pressure (float) or stress tensor from ``[stress]``; None if the table is empty."""
    if sec.has("pressure") and sec.has("tensor"):
        raise ConfigError(sec.key("tensor"), sec.data["tensor"], "give either pressure or tensor, not both")
    if sec.has("pressure"):
        return build_pressure(sec)
    if sec.has("tensor"):
        raw = sec.raw("tensor")
        from grainmech.io.units import to_float
        try:
            S = np.array([[to_float(v, "Pa", sec.key("tensor")) for v in row] for row in raw])
        except TypeError:
            raise ConfigError(sec.key("tensor"), raw, f"must be a {dim}x{dim} array") from None
        if S.shape != (dim, dim) or not np.allclose(S, S.T):
            raise ConfigError(sec.key("tensor"), raw, f"must be a symmetric {dim}x{dim} array")
        if np.abs(S).max() > PRESSURE_MAX:
            raise ConfigError(sec.key("tensor"), raw, f"entries must not exceed {PRESSURE_MAX:g} Pa in size")
        return S
    return None


LAWS = ("linear", "hertz-mindlin", "mindlin-deresiewicz")


def build_law(sec: Section, packing: Any) -> Any:
    """Incremental contact law parameters (``grainmech.contact``) from ``[contacts]``.

    ``law``: ``"mindlin-deresiewicz"`` (``shear_modulus``, ``poisson``, ``friction`` or
    ``friction_angle``), ``"hertz-mindlin"`` (same; friction optional, default infinite)
    or ``"linear"`` (``kn``, ``ks``, optional friction).
    """
    from grainmech import contact

    law = sec.choice("law", LAWS)
    if sec.has("friction") and sec.has("friction_angle"):
        raise ConfigError(sec.key("friction_angle"), sec.data["friction_angle"],
                          "give either friction or friction_angle, not both")
    mu = None
    if sec.has("friction"):
        mu = sec.number("friction", None, min=0)
    elif sec.has("friction_angle"):
        phi = sec.angle("friction_angle", max_deg=90.0, max_inclusive=False)
        mu = float(np.tan(phi))
    if law == "linear":
        kn = sec.number("kn", "N/m", min=0, min_inclusive=False)
        ks = sec.number("ks", "N/m", min=0)
        return contact.LinearSpring(kn, ks, friction=np.inf if mu is None else mu)
    G = sec.number("shear_modulus", "Pa", min=0, min_inclusive=False)
    nu = sec.number("poisson", None, min=-1, max=0.5, min_inclusive=False, max_inclusive=False)
    r = packing.radius
    if law == "hertz-mindlin":
        return contact.HertzMindlin(G, nu, r, friction=np.inf if mu is None else mu)
    if mu is None:
        raise ConfigError(sec.key("friction"), None, "is required for law = 'mindlin-deresiewicz' "
                          "(or give friction_angle)")
    return contact.MindlinDeresiewicz(G, nu, r, friction=mu)

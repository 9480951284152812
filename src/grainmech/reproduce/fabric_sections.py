"""Seed Fig. 4.2: sections of the contact-normal density along the x=0, y=0, z=0 planes.

The density is the seed's second-order expansion (Eq. 4.15),
``xi(n) = (1/4 pi)[1 + a20 P2(cos g) + 3 sin^2 g (a22 cos 2b + b22 sin 2b)]`` with the
seed's angles (``n_z = cos g``, ``n_y = sin g cos b``, ``n_x = sin g sin b``;
``docs/conventions.md``), evaluated through :class:`grainmech.fabric.SphericalDensity`.
"""

from __future__ import annotations

import numpy as np

from grainmech.fabric import SphericalDensity
from grainmech.reproduce._base import FigureData, long_table

__all__ = ["FABRICS", "PLANES", "section_normals", "fig4_2"]

#: The seed's three fabrics of Fig. 4.2 (Sec. 4.4): name -> (a20, a22, b22).
FABRICS: dict[str, tuple[float, float, float]] = {
    "transversely isotropic": (0.8, 0.0, 0.0),
    "orthotropic": (0.2, 0.25, 0.0),
    "monoclinic": (0.2, 0.25, 0.1),
}

#: Section planes and the in-plane angle measured from the first axis towards the second.
PLANES: dict[str, tuple[str, str]] = {"x=0": ("z", "y"), "y=0": ("z", "x"), "z=0": ("y", "x")}

_AXIS = {"x": 0, "y": 1, "z": 2}


def section_normals(plane: str, angle: np.ndarray) -> np.ndarray:
    """Unit normals (library components x, y, z) in a section plane.

    Parameters
    ----------
    plane : {"x=0", "y=0", "z=0"}
    angle : array
        In-plane angle [rad] from the first axis of :data:`PLANES` (z for x=0 and y=0, y
        for z=0, i.e. the seed's polar axis and azimuth origin) towards the second.
    """
    a, b = PLANES[plane]
    n = np.zeros((np.size(angle), 3))
    n[:, _AXIS[a]] = np.cos(angle)
    n[:, _AXIS[b]] = np.sin(angle)
    return n


def fig4_2(n_angles: int = 361) -> FigureData:
    """Density sections of seed Fig. 4.2, as ``4 pi xi(n)`` (1 for an isotropic fabric).

    Parameters
    ----------
    n_angles : int
        Points per section over 0..360 degrees.
    """
    ang = np.linspace(0.0, 2 * np.pi, n_angles)
    blocks = []
    extrema = {}
    for name, (a20, a22, b22) in FABRICS.items():
        dens = SphericalDensity.from_seed(a20, a22, b22)
        for plane in PLANES:
            n = section_normals(plane, ang)
            val = 4 * np.pi * dens(n)
            extrema[(name, plane)] = (float(val.min()), float(val.max()))
            blocks.append({"fabric": name, "plane": plane, "angle_deg": np.degrees(ang),
                           "n_x": n[:, 0], "n_y": n[:, 1], "n_z": n[:, 2],
                           "density_4pi": val})
    ti = extrema[("transversely isotropic", "z=0")]
    orth = extrema[("orthotropic", "z=0")]
    caption = (
        "Seed Fig. 4.2: sections of the contact-normal density xi(n) (Eq. 4.15) along the "
        "x=0, y=0 and z=0 planes for the transversely isotropic (a20 = 0.8), orthotropic "
        "(a20 = 0.2, a22 = 0.25) and monoclinic (a20 = 0.2, a22 = 0.25, b22 = 0.1) "
        "fabrics, plotted as 4 pi xi (1 = isotropic) in polar form. Angles: in x=0 and y=0 "
        "from the z axis (the seed's polar axis, gamma) towards y and x; in z=0 from the y "
        "axis (the seed's azimuth origin, beta) towards x. All inputs are the seed's. The "
        "seed's plot itself is not legible in the text we have, so the comparison is with "
        "Eq. 4.15: the sections equal it evaluated directly (tested). Checks: the "
        f"transversely isotropic section in z=0 is the circle 1 - a20/2 = {ti[0]:.3f}; the "
        f"orthotropic one in z=0 ranges from {orth[0]:.3f} (along x) to {orth[1]:.3f} "
        "(along y), i.e. 1 - a20/2 -/+ 3 a22; b22 rotates the z=0 section of the "
        "monoclinic fabric away from the x, y axes and leaves x=0 and y=0 as for the "
        "orthotropic fabric except for the sin 2 beta term, which vanishes there.")
    return FigureData("4.2", "Contact-normal density sections (seed Fig. 4.2)", caption,
                      long_table(blocks), {"extrema": extrema})

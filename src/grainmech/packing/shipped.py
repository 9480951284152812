"""Packings shipped with grainmech (``grainmech/data/packings``), loadable without LAMMPS.

Three packings of 2000 quartz grains (``D50 = 0.3 mm``, ``Cu = 1.3``, sizes cut to a
ratio of 2.5) at an isotropic 100 kPa, made by ``grainmech pack`` with the configs
``NAME.toml`` next to them (``scripts/make_packings.py`` remakes them):

* ``"dense"`` - preparation friction 0;
* ``"medium"`` - preparation friction 0.15;
* ``"loose"`` - preparation friction 0.5 (the grain friction).

Each is stored as grainmech's generic NPZ tables (``NAME-contacts.npz``,
``NAME-particles.npz``) with its summary (``NAME-summary.json``).
"""

from __future__ import annotations

import json
from importlib import resources

from grainmech.errors import GrainmechError
from grainmech.io.dem import read_table
from grainmech.network import ContactNetwork

__all__ = ["PACKINGS", "load_packing", "packing_info"]

#: names of the shipped packings
PACKINGS = ("dense", "medium", "loose")


def _check(name: str) -> None:
    if name not in PACKINGS:
        raise GrainmechError(f"packing = {name!r}: not a shipped packing (choose one of "
                             f"{', '.join(PACKINGS)}, or give a network file)")


def load_packing(name: str) -> ContactNetwork:
    """The shipped packing ``name`` as a contact network.

    The shipped packing ``name`` (``"dense"``, ``"medium"``, ``"loose"``) as a
    :class:`~grainmech.network.ContactNetwork` (SI units, forces by A on B, compression
    positive), e.g. for ``grainmech.driver.packing.PackingPoint.from_network``.
    """
    _check(name)
    base = resources.files("grainmech.data").joinpath("packings")
    with resources.as_file(base.joinpath(f"{name}-contacts.npz")) as c, \
            resources.as_file(base.joinpath(f"{name}-particles.npz")) as p:
        net = read_table(c, p)
    return ContactNetwork(net.ids, net.positions, net.radii, net.box, net.i, net.j, net.force, net.branch,
                          net.overlap, source=f"shipped packing {name!r} (grainmech pack, LAMMPS)",
                          moment=net.moment)


def packing_info(name: str) -> dict:
    """The summary of the shipped packing ``name``.

    The summary of the shipped packing ``name`` (void ratio, coordination, stress,
    unbalanced force ratio, grading, preparation), as written by ``grainmech pack``.
    """
    _check(name)
    f = resources.files("grainmech.data").joinpath("packings").joinpath(f"{name}-summary.json")
    return json.loads(f.read_text())

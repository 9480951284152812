"""Packings shipped with grainmech (``grainmech/data/packings``), loadable without LAMMPS.

Six packings of 2000 quartz grains at an isotropic 100 kPa, made by ``grainmech pack``
with the configs ``NAME.toml`` next to them (``scripts/make_packings.py`` remakes them).

Sand packings: the grading of Nevada sand (``D50 = 0.15 mm``, ``Cu = 1.7``, sizes cut to a
ratio of 4), grains with rolling resistance ``mu_r = 0.25`` (``docs/contact-laws.md``), at
three relative densities against the void-ratio limits ``grainmech pack`` measures for the
same grains (``nevada-limits.json``):

* ``"nevada-medium"`` - preparation friction 0.5, preparation rolling friction 0.01;
* ``"nevada-loose"`` - preparation friction 0.5 and rolling friction 0.25 (the grains');
* ``"nevada-dense"`` - preparation friction 0.09, no preparation rolling friction; the
  grains' rolling resistance starts unloaded at the prepared state (``grain_rolling =
  "after"``, ``docs/packings.md``), so its contact moments are zero.

Smooth-sphere packings (``D50 = 0.3 mm``, ``Cu = 1.3``, sizes cut to a ratio of 2.5, no
rolling resistance: glass-bead-like grains, kept for comparison):

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
from grainmech.network import ContactNetwork
from grainmech.network.tables import read_npz_network

__all__ = ["PACKINGS", "SAND_PACKINGS", "describe_packing", "load_packing", "packing_info", "packing_limits"]

#: names of the shipped packings
PACKINGS = ("dense", "medium", "loose", "nevada-dense", "nevada-medium", "nevada-loose")
#: the sand packings among them (grains with rolling resistance)
SAND_PACKINGS = ("nevada-dense", "nevada-medium", "nevada-loose")


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
        net = read_npz_network(c, p)
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


def packing_limits(name: str) -> dict | None:
    """The void-ratio limits ``e_min``/``e_max`` measured for the grains of the shipped packing ``name``.

    ``grainmech pack`` with the two procedures of ``<set>-emin.toml`` (densest: compression
    without friction) and ``<set>-emax.toml`` (loosest: compression with high friction and
    rolling resistance), written by ``scripts/make_packings.py limits``; None where they
    were not measured.
    """
    _check(name)
    stem = _grain_set(name)
    f = resources.files("grainmech.data").joinpath("packings").joinpath(f"{stem}-limits.json")
    return json.loads(f.read_text()) if f.is_file() else None


#: the grains of each set of shipped packings, as their configs give them (``NAME.toml``)
GRAIN_SETS = {"nevada": "Nevada sand's grading (VELACS: D50 0.15 mm, Cu 1.7), quartz grains with rolling "
                        "resistance mu_r 0.25",
              "smooth": "smooth quartz spheres (D50 0.3 mm, Cu 1.3), no rolling resistance"}


def _grain_set(name: str) -> str:
    return "nevada" if name.startswith("nevada") else "smooth"


def describe_packing(name: str) -> str:
    """What the shipped packing ``name`` models, in one line: its grains, void ratio and relative density.

    The relative density ``D_r = (e_max - e) / (e_max - e_min)`` is against the limits
    measured for the same grains (:func:`packing_limits`).
    """
    info = packing_info(name)
    e = float(info["void_ratio"])
    out = f"{GRAIN_SETS[_grain_set(name)]}; void ratio {e:.3f}"
    lim = packing_limits(name)
    if lim is not None:
        dr = (lim["e_max"] - e) / (lim["e_max"] - lim["e_min"])
        out += (f", relative density {dr:.2f} (against e_min {lim['e_min']:.3f} and e_max {lim['e_max']:.3f} "
                "measured for the same grains)")
    return out

"""Measured contact networks (DEM output): measures, affine and relaxed stiffness.

A :class:`ContactNetwork` holds the particles (ids, centres, radii), the simulation cell
(:class:`Box`, periodic and possibly triclinic) and the contacts in grainmech's counting
convention (``docs/conventions.md``): every physical contact once, from particle ``A``
(``i``) to particle ``B`` (``j``), branch vector ``l = x_B - x_A`` (minimum image across
periodic boundaries), unit normal ``n = l/|l|`` (spheres), and the force ``f`` exerted
**by A on B**, compression positive (``N = f . n >= 0`` for a compressive contact).
Readers in :mod:`grainmech.io.dem` convert DEM files to this form.

Modules
-------
* :mod:`~grainmech.network.data` - :class:`Box`, :class:`ContactNetwork`.
* :mod:`~grainmech.network.measures` - :func:`network_stress` (Love 1927 / Weber 1966,
  seed Eq. 2.6-2.7), :func:`network_fabric` (seed Eq. 4.6), :func:`coordination`,
  :func:`rattlers` and :func:`rattler_threshold`, :func:`contact_stiffnesses` (Hertz-Mindlin,
  seed Eq. 3.2, 3.5, 3.7, 3.11-3.12).
* :mod:`~grainmech.network.stiffness` - :func:`affine_stiffness`, seed Eq. 2.26 through
  :func:`grainmech.assembly.stiffness`.
* :mod:`~grainmech.network.relaxed` - :func:`relaxed_stiffness`, the exact small-strain
  tangent with the particles relaxed to equilibrium,
  ``C_relaxed = C_affine - (1/V) B^T H^+ B`` (Lemaitre & Maloney 2006; Agnolin & Roux
  2007; Kruyt & Rothenburg 1998), solved with a sparse Cholesky factorisation or CG.
* :mod:`~grainmech.network.builders` - synthetic periodic networks
  :func:`lattice_network` (sc, fcc), :func:`random_network` and :func:`tile_network`.
* :mod:`~grainmech.network.report` - :func:`network_report` (a :class:`NetworkReport`
  of arrays; :meth:`NetworkReport.to_json` / :func:`network_report_json` for files) and
  :func:`closed_form_from_fit` (seed Eq. 4.21-4.33 from the fitted fabric).
* :mod:`~grainmech.network.tables` - a network from columns of ids, positions and forces
  (what every reader of :mod:`grainmech.io.dem` ends in), and the NPZ form of the
  generic tables.

The figures of a network (rose diagrams, normal density) are :func:`grainmech.plots.plot_rose`
and :func:`grainmech.plots.plot_normal_density`.

Stiffness terms only: the contact stiffness ``K = kn n n + ks (I - n n)`` is used
unchanged; with ``geometric=True`` the term ``-(N/|l|) (I - n n)`` (the rotation of a
pre-loaded normal force with the branch vector) is added to ``K``, i.e. ``ks`` becomes
``ks - N/|l|``. The change ``f (x) dl`` of the stress under strain and the change of
volume are not included in either tensor. See ``docs/networks.md``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from grainmech._deprecated import moved_attribute
from grainmech.network.builders import lattice_network, random_network, tile_network
from grainmech.network.data import Box, ContactNetwork

if TYPE_CHECKING:
    from grainmech.network.measures import (
        CoordinationResult,
        FabricResult,
        contact_stiffnesses,
        coordination,
        network_fabric,
        network_stress,
        rattler_threshold,
        rattlers,
    )
    from grainmech.network.relaxed import RelaxedResult, relaxed_stiffness
    from grainmech.network.report import NetworkReport, closed_form_from_fit, network_report, network_report_json
    from grainmech.network.stiffness import affine_stiffness, contact_matrix, effective_ks, strain_map

__all__ = [
    "Box",
    "ContactNetwork",
    "network_stress",
    "network_fabric",
    "FabricResult",
    "coordination",
    "CoordinationResult",
    "rattlers",
    "rattler_threshold",
    "contact_stiffnesses",
    "affine_stiffness",
    "contact_matrix",
    "effective_ks",
    "relaxed_stiffness",
    "RelaxedResult",
    "strain_map",
    "lattice_network",
    "random_network",
    "tile_network",
    "network_report",
    "network_report_json",
    "NetworkReport",
    "closed_form_from_fit",
]

#: public name -> module that defines it, imported on first use: the measures pull in
#: grainmech.assembly and with it numba (~66 MB of resident memory, 0.2 s), which a
#: reader of DEM files (``grainmech.io.dem`` needs only Box and ContactNetwork) does not
#: need
_LAZY: dict[str, str] = {
    **dict.fromkeys(("CoordinationResult", "FabricResult", "contact_stiffnesses", "coordination",
                     "network_fabric", "network_stress", "rattler_threshold", "rattlers"),
                    "grainmech.network.measures"),
    **dict.fromkeys(("RelaxedResult", "relaxed_stiffness"), "grainmech.network.relaxed"),
    **dict.fromkeys(("NetworkReport", "closed_form_from_fit", "network_report", "network_report_json"),
                    "grainmech.network.report"),
    **dict.fromkeys(("affine_stiffness", "contact_matrix", "effective_ks", "strain_map"),
                    "grainmech.network.stiffness"),
}


def __getattr__(name: str) -> Any:
    mod = _LAZY.get(name)
    if mod is None:
        return moved_attribute(__name__, name)  # the plots moved to grainmech.plots (a warning)
    value = getattr(importlib.import_module(mod), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

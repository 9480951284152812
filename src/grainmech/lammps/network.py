"""A LAMMPS state read back as a :class:`~grainmech.network.ContactNetwork`, and its unbalanced force ratio."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grainmech.errors import GrainmechError
from grainmech.network import Box, ContactNetwork

__all__ = ["lammps_cell", "network_from_lammps", "unbalanced_ratio"]


def lammps_cell(lmp: Any) -> tuple[np.ndarray, np.ndarray]:
    """The cell's rows ``a = (lx,0,0)``, ``b = (xy,ly,0)``, ``c = (xz,yz,lz)`` (3, 3) [m] and its origin (3,) [m]."""
    lo, hi, xy, yz, xz = lmp.box()
    lx, ly, lz = hi - lo
    return np.array([[lx, 0, 0], [xy, ly, 0], [xz, yz, lz]], float), lo


def network_from_lammps(lmp: Any, source: str = "grainmech pack (LAMMPS)") -> ContactNetwork:
    """The current LAMMPS state as a :class:`ContactNetwork` (grainmech's convention).

    ``compute pair/local force p1 p2 p3 p10 p11 p12`` of ``pair_style granular`` gives per
    pair ``(I, J)`` the normal force magnitude, the tangential force on ``I`` and
    ``x_I - x_J`` (with the periodic image). The force on ``I`` is
    ``F_I = force (x_I - x_J)/r + F_t``; grainmech stores the force by ``A = I`` on
    ``B = J``, ``f = -F_I``, and the branch ``l = x_J - x_I``. Call after a ``run``.
    On several MPI ranks every rank gets the whole network (grains and pairs gathered).

    With rolling resistance (:func:`grainmech.lammps.granular.measure_moments`) the network carries the contact
    moments too: LAMMPS applies to ``I`` the torque ``R* n_IJ x F_r + M_t n_IJ``
    (``n_IJ = (x_I - x_J)/r``, ``R* = R_I R_J / (R_I + R_J)``) and its opposite to ``J``;
    grainmech's moment ``M`` is the one by ``A`` on ``B`` (``A`` receives ``-M``, the
    convention of :mod:`grainmech.contact.rolling`), ``M = -(R* n_IJ x F_r + M_t n_IJ)``.
    """
    lmp.command("run 0 post no")
    cell, lo = lammps_cell(lmp)
    tag = lmp.atom_all("id").astype(np.int64)
    x = lmp.atom_all("x")
    r = lmp.atom_all("radius")
    order = np.argsort(tag)
    ids = tag[order]
    rowof = np.empty(tag.max() + 1, np.int64)
    rowof[ids] = np.arange(ids.size)
    pl = lmp.local_all("cpair")
    pi = lmp.local_all("cids")
    if pl.shape[0] != pi.shape[0]:
        raise GrainmechError(f"LAMMPS pair/local ({pl.shape[0]}) and property/local ({pi.shape[0]}) "
                             "list different pairs")
    box = Box(lo, cell, np.ones(3, bool))
    rolling = lmp.has_id("compute", "croll")
    moment = None
    if pl.shape[0] == 0:
        C = 0
        I = J = np.zeros(0, np.int64)
        f = lbr = np.zeros((0, 3))
        moment = np.zeros((0, 3)) if rolling else None
    else:
        I = rowof[pi[:, 0].astype(np.int64)]
        J = rowof[pi[:, 1].astype(np.int64)]
        dIJ = pl[:, 4:7]
        rr = np.linalg.norm(dIJ, axis=1)
        F_I = pl[:, 0:1] * dIJ / rr[:, None] + pl[:, 1:4]
        f = -F_I
        lbr = -dIJ
        C = len(I)
        if rolling:
            pr = lmp.local_all("croll")
            if pr.shape[0] != C:
                raise GrainmechError(f"LAMMPS pair/local lists {C} pairs with forces and {pr.shape[0]} with "
                                     "moments")
            nIJ = dIJ / rr[:, None]
            rI, rJ = r[order][I], r[order][J]
            Rs = rI * rJ / (rI + rJ)
            moment = -(Rs[:, None] * np.cross(nIJ, pr[:, 0:3]) + pr[:, 3:4] * nIJ)
    pos = x[order]
    rad = r[order]
    ov = rad[I] + rad[J] - np.linalg.norm(lbr, axis=1) if C else np.zeros(0)
    return ContactNetwork(ids, pos, rad, box, I, J, f, lbr, ov, source=source, moment=moment)


def unbalanced_ratio(net: ContactNetwork, *, lever: str = "lammps") -> float:
    """Unbalanced force ratio of a network from its contact forces (and contact moments).

    Mean over grains with contacts of ``sqrt(|F|^2 + (|M|/R)^2)`` (sum of contact forces
    and moments on the grain) over the mean contact force magnitude (the usual DEM measure,
    e.g. Ng 2006, with the moments added as in ``grainmech.driver.packing``). A network
    with contact moments (rolling resistance, ``net.moment``: by ``A`` on ``B``) adds them
    to the grains' moments.

    Parameters
    ----------
    net : ContactNetwork
    lever : {"lammps", "radius"}
        Lever arm of a contact force about a grain centre: ``R - delta/2`` along the normal
        (the contact point of LAMMPS ``pair_style granular``) or ``R`` (grainmech's
        packing driver, ``r_A = R_A n``).
    """
    if net.n_contacts == 0:
        return math.inf
    n = net.normals
    R = net.require_radii("the unbalanced force ratio")
    ov = net.overlap if net.overlap is not None else np.zeros(net.n_contacts)
    half = 0.5 * ov if lever == "lammps" else 0.0 * ov
    rA = (R[net.i] - half)[:, None] * n
    rB = -(R[net.j] - half)[:, None] * n
    P = net.n_particles
    F = np.zeros((P, 3))
    M = np.zeros((P, 3))
    np.add.at(F, net.j, net.force)
    np.add.at(F, net.i, -net.force)
    np.add.at(M, net.i, np.cross(rA, -net.force))
    np.add.at(M, net.j, np.cross(rB, net.force))
    if net.moment is not None:
        np.add.at(M, net.j, net.moment)
        np.add.at(M, net.i, -net.moment)
    has = np.zeros(P, bool)
    has[net.i] = True
    has[net.j] = True
    fc = np.linalg.norm(net.force, axis=1)
    res = np.sqrt(np.einsum("ij,ij->i", F, F) + np.einsum("ij,ij->i", M, M) / R ** 2)[has]
    return float(res.mean() / fc.mean()) if fc.mean() > 0 else math.inf

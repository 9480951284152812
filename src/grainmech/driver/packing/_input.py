"""The input phases of :meth:`grainmech.driver.packing.PackingPoint.from_network`.

Validation of the network, the input contact forces (stored or from the overlaps) and the
contact law state the point starts from.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from grainmech.contact import ContactState, state_from_approach, state_from_forces
from grainmech.contact.rolling import RollingConstants, RollingResistance, rolling_constants
from grainmech.driver.packing.options import law_scale
from grainmech.errors import GrainmechError, ParameterError
from grainmech.network import ContactNetwork


def check_network(net: Any, forces: str, gap: float, imbalance: str) -> None:
    """Validate the input of :meth:`PackingPoint.from_network` (one-line errors naming the field)."""
    if not isinstance(net, ContactNetwork):
        raise ParameterError("network", type(net).__name__, "must be a grainmech.network.ContactNetwork")
    if net.dim != 3:
        raise ParameterError("network.dim", net.dim, "the packing driver works in 3D")
    if net.radii is None:
        raise ParameterError("network.radii", None, "are required (spheres): give the particle radii")
    if not net.box.periodic.all():
        raise ParameterError("network.box.periodic", net.box.periodic.tolist(),
                             "must be periodic in x, y and z (walls are not modelled)")
    if imbalance not in ("hold", "relax", "none"):
        raise ParameterError("imbalance", imbalance, "must be 'hold', 'relax' or 'none'")
    if forces not in ("auto", "stored", "overlap"):
        raise ParameterError("forces", forces, "must be 'auto', 'stored' or 'overlap'")
    if not (gap >= 0 and math.isfinite(gap)):
        raise ParameterError("gap", gap, "must be finite and >= 0")
    if net.n_contacts == 0:
        raise ParameterError("network", net.source, "has no contacts")


def input_forces(net: ContactNetwork, params: Any, forces: str, frictional: bool,
                 notes: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Normal (C,) [N] and tangential (C, 3) [N] forces of the input contacts.

    ``forces="stored"``: the network's forces split along the normal; ``"overlap"``: the
    Hertz (seed Eq. 3.6) or spring force of the overlap (``R_A + R_B - |l|`` when none is
    stored), no tangential force; ``"auto"``: stored when any is non-zero. A frictionless
    law drops tangential forces (a note in ``notes``); non-carrying contacts get ``T = 0``.
    """
    assert net.radii is not None  # checked by check_network
    n, L = net.normals, net.branch_length
    RA, RB = net.radii[net.i], net.radii[net.j]
    if forces == "auto":
        forces = "stored" if np.any(net.force != 0) else "overlap"
    if forces == "stored":
        N = np.einsum("ij,ij->i", net.force, n)
        T = net.force - N[:, None] * n
    else:
        alpha = net.overlap if net.overlap is not None else RA + RB - L
        Rs = RA * RB / (RA + RB)
        N = state_from_approach(params, np.maximum(alpha, 0.0) * law_scale(params, Rs)).normal_force
        T = np.zeros_like(net.force)
    N = _tensile_at_zero(N, net)
    carrying = N > 0
    if frictional:
        T = _cap_small_excess(net, N, T, params.friction, notes)
    if not frictional and np.any(T[carrying] != 0):
        Tm = np.linalg.norm(T, axis=1)
        if Tm.max() > 1e-9 * max(float(N.max()), 1e-300):
            notes.append(f"frictionless law: tangential forces of the input dropped (largest "
                         f"|T|/N = {float(np.max(Tm[carrying] / N[carrying])):.3g})")
        T = np.zeros_like(T)
    T = np.where(carrying[:, None], T, 0.0)
    return N, T


#: largest tensile normal force of an input contact, relative to the mean normal force of
#: the force-carrying contacts, that the input takes at zero force (beyond it the input is
#: an error): a DEM's normal damping at a contact about to open leaves such forces
TENSILE_CAP = 1e-3


def _tensile_at_zero(N: np.ndarray, net: ContactNetwork) -> np.ndarray:
    """Normal forces with small tensile ones (a DEM's damping, round-off) set to zero.

    A cohesionless contact law carries no tension: a stored normal force below zero is
    the normal dashpot of a DEM at a contact about to open (LAMMPS reports, e.g.,
    -5.8e-9 N against a mean of about 1e-2 N on a re-settled sand packing; the shipped
    packings hold 0-20 such contacts, at most 5e-6 of their mean normal force) and is
    taken at zero force when it is within :data:`TENSILE_CAP` of the mean normal force;
    a larger one is an error naming the contact. :func:`tensile_note` says how many of
    them the packing model keeps.
    """
    if not np.any(N < 0):
        return N
    carrying = N > 0
    scale = float(np.mean(N[carrying])) if carrying.any() else 0.0
    k = int(np.argmin(N))
    if not -N[k] <= TENSILE_CAP * scale:
        raise GrainmechError(f"{net.source or 'network'}: contact {k} carries a tensile normal force of "
                             f"{N[k]:.6g} N (mean normal force {scale:.6g} N): a cohesionless contact law carries "
                             "no tension; use forces='overlap'")
    return np.maximum(N, 0.0)


def tensile_note(net: ContactNetwork, kept: np.ndarray, N: np.ndarray, notes: list[str]) -> None:
    """Say how many kept contacts (``kept``: between grains that are not rattlers) came with a tensile force."""
    raw = np.einsum("ij,ij->i", net.force, net.normals)
    used = kept & (raw < 0) & (N == 0)
    if used.any():
        notes.append(f"{int(used.sum())} input contact(s) between load-bearing grains with a tensile normal force "
                     f"(largest {-float(raw[used].min()):.3g} N: a DEM's normal damping at a contact about to open) "
                     "taken at zero force")


#: largest excess ``|T| - mu N`` of a stored tangential force, relative to the mean normal force of
#: the force-carrying contacts, that the input takes by capping ``|T|`` to ``mu N`` (beyond it the
#: input is an error); the same fraction as the driver's equilibrium bound on a step's largest
#: residual (0.05 of the mean contact force)
TANGENTIAL_EXCESS_CAP = 0.05


def _grain_imbalance(net: ContactNetwork, N: np.ndarray, T: np.ndarray) -> float:
    """Mean |sum of contact forces| over the grains with contacts [N] (forces only)."""
    f = N[:, None] * net.normals + T
    F = np.zeros((net.n_particles, 3))
    np.add.at(F, net.j, f)
    np.add.at(F, net.i, -f)
    has = np.bincount(np.concatenate([net.i, net.j]), minlength=net.n_particles) > 0
    return float(np.linalg.norm(F[has], axis=1).mean())


def _cap_small_excess(net: ContactNetwork, N: np.ndarray, T: np.ndarray, friction: float,
                      notes: list[str]) -> np.ndarray:
    """Cap stored tangential forces slightly above the Coulomb limit to ``mu N``; note how many.

    LIGGGHTS' ``compute pair/gran/local`` reports, on a few contacts (most of them about to
    open: overlaps of 1e-12 ... 1e-9 m against ~1e-7 m), a tangential force above ``mu``
    times the normal force, which is not the force that acted: capped to ``mu N``, the
    contact forces of the shipped LIGGGHTS packing balance every grain 60 times better
    (mean out-of-balance force 1.5e-4 -> 2.3e-6 of the mean contact force,
    ``docs/networks.md``, "A packing from LIGGGHTS"). Such forces are capped when (1) every
    excess ``|T| - mu N`` is below :data:`TANGENTIAL_EXCESS_CAP` of the mean normal force
    and (2) capping lowers the grains' mean out-of-balance force; otherwise they are left
    for :func:`initial_contact_state` to reject. The capped forces are the input state (what is
    left unbalanced is held as grain loads, as for any input).
    """
    carrying = N > 0
    if not carrying.any():
        return T
    mag = np.linalg.norm(T, axis=1)
    muN = friction * np.maximum(N, 0.0)
    over = carrying & (mag > muN * (1 + 1e-6))
    if not over.any():
        return T
    excess = float(np.max(mag[over] - muN[over]))
    scale = float(np.mean(N[carrying]))
    if excess > TANGENTIAL_EXCESS_CAP * scale:
        return T
    capped = T.copy()
    capped[over] *= (muN[over] / mag[over])[:, None]
    before, after = _grain_imbalance(net, N, T), _grain_imbalance(net, N, capped)
    if after >= before:
        return T
    notes.append(f"{int(over.sum())} input contacts with |T| > mu N (friction {friction:g}) capped to mu N: the "
                 f"largest excess {excess:.3g} N is {excess / scale:.2%} of the mean normal force (limit "
                 f"{TANGENTIAL_EXCESS_CAP:.0%}); the grains' mean out-of-balance force falls from {before:.3g} N "
                 f"to {after:.3g} N")
    return capped


def initial_contact_state(params: Any, Nk: np.ndarray, Tk: np.ndarray, rows: np.ndarray, frictional: bool,
                          Lc: np.ndarray, Ra: np.ndarray, Rb: np.ndarray, s: np.ndarray) -> ContactState:
    """Contact law state (law space): the listed contacts at their forces, the gap pairs open.

    ``Nk``, ``Tk``: forces [N] of the ``Nk.size`` listed contacts (first rows); ``Lc``
    [m], ``Ra``, ``Rb`` [m], ``s`` (displacement scale, :func:`law_scale`) of every
    tracked pair. A tangential force above ``mu N`` (beyond 1e-6 relative) is an error
    naming the contact; one within it is capped to ``mu N``.
    """
    if frictional:
        mag = np.linalg.norm(Tk, axis=1)
        muN = params.friction * Nk
        over = mag > muN * (1 + 1e-6)
        if np.any(over):
            k = int(np.flatnonzero(over)[0])
            raise GrainmechError(f"contact {int(rows[k])}: |T| = {mag[k]:.6g} exceeds mu N = {muN[k]:.6g} "
                                 f"(friction {params.friction:g}); use forces='overlap' or the packing's "
                                 "friction coefficient")
        cap = np.where(mag > muN, muN / np.where(mag > 0, mag, 1.0), 1.0)
        st_l = state_from_forces(params, Nk, Tk * cap[:, None])
    else:
        st_l = state_from_forces(params, Nk, np.zeros_like(Tk))
    st_g = state_from_approach(params, -(Lc[Nk.size:] - Ra[Nk.size:] - Rb[Nk.size:]) * s[Nk.size:])
    return ContactState(*(np.concatenate([x, y]) for x, y in zip(st_l, st_g)))


def pin_first(grains: np.ndarray, net: ContactNetwork, carrying: np.ndarray, N: np.ndarray) -> np.ndarray:
    """``grains`` (kept rows of ``net``) with the best-held grain first: its translation is pinned.

    The global translation of a periodic packing is a zero mode, removed by pinning the
    translation of the first kept grain (:class:`Kinematics`). That grain's out-of-balance
    force is then minus the sum of all the others' (:func:`grain_residuals`), and moving
    it means moving every other grain against it. Pinned on a grain held by two weak
    contacts (the first row of the shipped 'loose' packing has 2, carrying 0.09 and 0.06 of
    the mean contact force), the coherent part of the other grains' small residuals piles up
    on it step after step (0.014 → 0.050 of the mean contact force over γ = 5e-5 … 9e-5 at
    1e-4 on 'loose', every free grain below 0.002). The grain with the most force-carrying
    contacts (then the largest sum of their normal forces, then the lowest row) is pinned
    instead (``N``: the input normal forces of ``net``'s contacts, ``carrying`` the kept
    force-carrying ones).
    """
    ends = np.concatenate([net.i[carrying], net.j[carrying]])  # each contact counts for both grains
    count = np.bincount(ends, minlength=net.n_particles)
    load = np.bincount(ends, np.tile(N[carrying], 2), net.n_particles)
    best = grains[np.lexsort((grains, -load[grains], -count[grains]))[0]]
    return np.concatenate([[best], grains[grains != best]])


def gap_pairs(net: ContactNetwork, gap: float, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of non-rattler grains not in contact whose gap is below ``gap`` times their mean radius."""
    pos, R, box = net.positions, net.require_radii("tracking gap pairs"), net.box
    idx = np.flatnonzero(alive)
    if idx.size < 2 or gap <= 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros((0, 3))
    cut = 2.0 * float(R[idx].max()) * (1.0 + gap)
    if np.allclose(box.cell, np.diag(np.diag(box.cell))) and box.periodic.all():
        L = np.diag(box.cell)
        tree = cKDTree(np.mod(pos[idx] - box.origin, L), boxsize=L)
        pr = tree.query_pairs(min(cut, 0.4999 * float(L.min())), output_type="ndarray")
        I, J = idx[pr[:, 0]], idx[pr[:, 1]]
    else:
        if idx.size > 4000:
            raise ParameterError("gap", gap, "gap-pair search in a non-orthogonal or non-periodic cell is "
                              "limited to 4000 grains; use gap = 0")
        I, J = np.triu_indices(idx.size, 1)
        I, J = idx[I], idx[J]
    br = box.minimum_image(pos[J] - pos[I])
    d = np.linalg.norm(br, axis=1)
    g = d - R[I] - R[J]
    keep = (g > 0) & (g < gap * 0.5 * (R[I] + R[J]))
    I, J, br = I[keep], J[keep], br[keep]
    # drop pairs already listed as contacts
    P = net.n_particles
    listed = set((np.minimum(net.i, net.j) * P + np.maximum(net.i, net.j)).tolist())
    key = np.minimum(I, J) * P + np.maximum(I, J)
    new = np.array([k not in listed for k in key.tolist()], dtype=bool)
    return I[new], J[new], br[new]


def input_rolling(rolling: RollingResistance | RollingConstants | None, params: Any, N: np.ndarray,
                  Rs: np.ndarray) -> RollingConstants | None:
    """:meth:`PackingPoint.from_network`'s ``rolling``, resolved on the listed contacts (None: off)."""
    if rolling is None:
        return None
    if isinstance(rolling, RollingConstants):
        return rolling if (rolling.mu_roll > 0 or rolling.twist_cap > 0) else None
    if not isinstance(rolling, RollingResistance):
        raise ParameterError("rolling", rolling, "must be a RollingResistance, RollingConstants or None")
    if not rolling.active:
        return None
    return rolling_constants(rolling, params, N, Rs)

"""Synthetic periodic contact networks (lattices, disordered packings) for tests and benchmarks."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from grainmech.contact.geometry import hertz_force
from grainmech.contact.params import Hertz
from grainmech.errors import GrainmechError
from grainmech.network.data import Box, ContactNetwork

__all__ = ["lattice_network", "random_network", "tile_network"]


def _hertz_forces(net_pos: np.ndarray, radii: np.ndarray, I: np.ndarray, J: np.ndarray, br: np.ndarray,
                  shear_modulus: float, poisson: float) -> tuple[np.ndarray, np.ndarray]:
    """Hertz contact forces along the branch vectors ``br`` and the approaches (seed Eq. 3.3-3.6)."""
    Es = Hertz(shear_modulus, poisson, 1.0).effective_modulus
    Ra, Rb = radii[I], radii[J]
    Rs = Ra * Rb / (Ra + Rb)
    L = np.linalg.norm(br, axis=1)
    alpha = np.maximum(Ra + Rb - L, 0.0)
    N = hertz_force(alpha, Es, Rs)  # seed Eq. 3.6
    return N[:, None] * br / L[:, None], alpha


def lattice_network(kind: str, n_cells: int, radius: float, overlap: float, *,
                    shear_modulus: float = 29e9, poisson: float = 0.15) -> ContactNetwork:
    """Periodic simple-cubic or face-centred-cubic packing of equal Hertz spheres.

    Periodic simple-cubic (``"sc"``) or face-centred-cubic (``"fcc"``) packing of equal
    Hertz spheres, every nearest-neighbour pair in contact with the given ``overlap``.

    The nearest-neighbour distance is ``2 radius - overlap``; the cell is
    ``n_cells`` conventional cubes per side (``n_cells >= 3`` so that no pair of particles
    touches twice across the periodic boundaries). Forces follow Hertz (seed Eq. 3.6),
    compression positive.
    """
    if kind not in ("sc", "fcc"):
        raise GrainmechError(f"kind must be 'sc' or 'fcc', got {kind!r}")
    if n_cells < 3:
        raise GrainmechError(f"n_cells must be >= 3, got {n_cells}")
    dnn = 2.0 * radius - overlap
    if kind == "sc":
        a = dnn
        basis = np.zeros((1, 3))
    else:
        a = dnn * np.sqrt(2.0)
        basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    grid = np.stack(np.meshgrid(*[np.arange(n_cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
    pos = ((grid[:, None, :] + basis[None]) * a).reshape(-1, 3)
    L = n_cells * a
    box = Box.orthogonal([0, 0, 0], [L, L, L], True)

    tree = cKDTree(np.mod(pos, L), boxsize=L)
    pairs = tree.query_pairs(dnn * (1 + 1e-6), output_type="ndarray")
    I, J = pairs[:, 0], pairs[:, 1]
    br = box.minimum_image(pos[J] - pos[I])
    radii = np.full(len(pos), float(radius))
    f, alpha = _hertz_forces(pos, radii, I, J, br, shear_modulus, poisson)
    return ContactNetwork(np.arange(1, len(pos) + 1), pos, radii, box, I, J, f, br, alpha,
                          source=f"{kind} lattice {n_cells}^3")


def random_network(n_particles: int, *, coordination: float = 7.0, cell: np.ndarray | None = None,
                   radius_range: tuple[float, float] = (0.8, 1.2), shear_modulus: float = 29e9,
                   poisson: float = 0.15, tangential: float = 0.3,
                   seed: int | np.random.Generator | None = 0) -> ContactNetwork:
    """Disordered periodic network of polydisperse Hertz spheres (for tests and benchmarks).

    Centres are uniform in the cell; the radii are scaled so that the ``coordination *
    n / 2`` closest pairs (by gap relative to the radius sum) overlap. Normal forces follow
    Hertz from the overlap; tangential forces are random with ``|T| <= tangential N``. The
    network is *not* in equilibrium (use it for stiffness and I/O, not for the skew check).

    Parameters
    ----------
    cell : array (3, 3), optional
        Cell vectors (rows); default a cube of side ``(n_particles)^(1/3) * 2``. Orthogonal
        cells use a k-d tree; general (triclinic) cells a direct search (n <= 4000).
    """
    rng = np.random.default_rng(seed)
    n = int(n_particles)
    if n < 2:
        raise GrainmechError("n_particles must be >= 2")
    side = 2.0 * n ** (1.0 / 3.0)
    cellm = np.diag([side] * 3) if cell is None else np.asarray(cell, float)
    box = Box(np.zeros(3), cellm, np.ones(3, bool))
    s = rng.random((n, 3))
    pos = s @ cellm
    r0 = rng.uniform(radius_range[0], radius_range[1], n)
    target = int(round(coordination * n / 2))
    diag = np.allclose(cellm, np.diag(np.diag(cellm)))
    # candidate pairs: generous cutoff from the mean spacing
    spacing = (box.volume / n) ** (1.0 / 3.0)
    cut = 2.2 * spacing * radius_range[1] / np.mean(radius_range)
    if diag:

        Ls = np.diag(cellm)
        tree = cKDTree(np.mod(pos, Ls), boxsize=Ls)
        pairs = tree.query_pairs(cut, output_type="ndarray")
        I, J = pairs[:, 0], pairs[:, 1]
    else:
        if n > 4000:
            raise GrainmechError("random_network: triclinic cells are limited to 4000 particles")
        I, J = np.triu_indices(n, 1)
    br = box.minimum_image(pos[J] - pos[I])
    ratio = np.linalg.norm(br, axis=1) / (r0[I] + r0[J])
    if target > ratio.size:
        raise GrainmechError("random_network: coordination too high for the candidate search")
    k = np.argpartition(ratio, target - 1)[:target]
    scale = ratio[k].max() * (1 + 1e-9)
    radii = r0 * scale * (1 + 1e-3)  # all selected pairs overlap by at least ~0.1 %
    I, J, br = I[k], J[k], br[k]
    fN, alpha = _hertz_forces(pos, radii, I, J, br, shear_modulus, poisson)
    nrm = br / np.linalg.norm(br, axis=1)[:, None]
    t = rng.normal(size=(target, 3))
    t -= np.einsum("ij,ij->i", t, nrm)[:, None] * nrm
    t /= np.linalg.norm(t, axis=1)[:, None]
    Nmag = np.linalg.norm(fN, axis=1)
    f = fN + (tangential * rng.random(target) * Nmag)[:, None] * t
    return ContactNetwork(np.arange(1, n + 1), pos, radii, box, I, J, f, br, alpha,
                          source=f"random network n={n}")


def tile_network(net: ContactNetwork, reps: tuple[int, ...] | list[int]) -> ContactNetwork:
    """Periodic copies of a periodic network: ``reps[k]`` copies along cell vector ``k``.

    Copy ``t`` (multi-index ``(t_0, t_1, t_2)``, C order) of grain ``p`` sits at
    ``x_p + sum_k t_k a_k`` and gets row ``t P + p`` and id ``t (max id + 1) + id_p``. A
    contact of copy ``t`` keeps its branch vector, force and geometry; its second grain
    is the copy the branch vector reaches, ``t + s`` (modulo ``reps``) with ``s`` the
    whole cells between the minimum image and the stored positions. The result is the
    same material: its stress, fabric and affine and relaxed tensors equal the original's
    (a periodic fluctuation of the small cell is one of the large cell), which
    ``tests/network/test_network.py`` checks. Used to make large packings for benchmarks.

    Parameters
    ----------
    net : ContactNetwork
        Periodic along every cell vector.
    reps : sequence of int
        Copies along each cell vector (``net.dim`` positive integers).
    """
    d = net.dim
    r = np.asarray(reps)
    if r.shape != (d,) or not np.issubdtype(r.dtype, np.integer) or np.any(r < 1):
        raise GrainmechError(f"reps must be {d} positive integers, got {reps!r}")
    if not net.box.periodic.all():
        raise GrainmechError("tile_network needs a network periodic along every cell vector")
    cell = net.box.cell
    P, C, T = net.n_particles, net.n_contacts, int(np.prod(r))
    idx = np.array(np.unravel_index(np.arange(T), tuple(r))).T  # (T, d)
    pos = (net.positions[None, :, :] + (idx @ cell)[:, None, :]).reshape(T * P, d)
    # whole cells between the branch vector's end and grain j's stored position
    s = np.rint((net.positions[net.i] + net.branch - net.positions[net.j]) @ np.linalg.inv(cell))
    tj = np.ravel_multi_index(((idx[:, None, :] + s.astype(np.int64)[None, :, :]) % r).reshape(-1, d).T,
                              tuple(r))
    I = np.repeat(np.arange(T), C) * P + np.tile(net.i, T)
    J = tj * P + np.tile(net.j, T)
    step = int(net.ids.max()) + 1

    def rep(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.tile(a, (T,) + (1,) * (a.ndim - 1))

    ids = (np.arange(T)[:, None] * step + net.ids[None, :]).reshape(-1)
    return ContactNetwork(ids, pos, rep(net.radii), Box(net.box.origin, cell * r[:, None], net.box.periodic),
                          I, J, np.tile(net.force, (T, 1)), np.tile(net.branch, (T, 1)), rep(net.overlap),
                          rep(net.contact_point),
                          rep(net.kn), rep(net.ks), f"{net.source} tiled {'x'.join(map(str, r))}")

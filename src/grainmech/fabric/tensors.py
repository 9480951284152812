r"""Fabric tensors ``N`` and coefficient tensors ``phi`` (seed Eq. 4.6, 4.10, 4.11).

Definitions
-----------
Fabric tensor of rank ``r`` (seed Eq. 4.6; Kanatani 1984)::

    N_{i1..ir} = integral n_i1 ... n_ir xi(n) dOmega = < n_i1 ... n_ir >

Coefficient tensors (seed Eq. 4.10; Kanatani 1984, Eq. 3.10)::

    xi(n) = (1/|S|) [1 + phi_ij n_i n_j + phi_ijkl n_i n_j n_k n_l + ...]

with ``|S| = 4 pi`` (sphere, Eq. 4.10a) or ``2 pi`` (circle, Eq. 4.10b), and each
``phi_(k)`` fully symmetric and *traceless* (deviatoric).  With that choice the
representation is unique, ``phi_(k) . n^k`` is exactly the degree-``k`` harmonic part of
``|S| xi``, and (Kanatani 1984, "Distribution of directional data and fabric tensors",
Int. J. Eng. Sci. 22(2), 149-164)::

    phi_(k) = F_k(d) * dev[ N_(k) ]

    F_k(3) = (2k + 1)!! / k!      ->  F_2 = 15/2,  F_4 = 315/8,  F_6 = 3003/16
    F_k(2) = 2^k                  ->  F_2 = 4,     F_4 = 16,     F_6 = 64

``F_2`` reproduces seed Eq. 4.11 (15/2 for spheres, 4 for discs).  Derivation: the degree-k
part ``h_k = phi_(k) . n^k`` of ``|S| xi`` is the only part of ``xi`` that contributes to
the deviatoric part of ``N_(k)``, and ``(1/|S|) integral (phi . n^k) n^(x)k dOmega`` has
deviatoric part ``phi / F_k``; the constants follow from
``<n^(x)2k>`` = sum over pairings of Kronecker deltas / (d (d+2) ... (d+2k-2)).
In 3D ``1/F_k = k!/(2k+1)!!``; in 2D ``(1/2 pi) integral cos^2(k theta) dtheta = 1/2`` and
``cos(k theta) = Re (n_y + i n_x)^k`` give ``1/F_k = 2^-k``.  Both are checked by
quadrature in ``tests/fabric/test_fabric_tensors.py``.

Lower-rank fabric tensors are traces of higher ones (``N_ij = N_ijkk``), so a rank-``L``
fabric tensor determines all ``phi_(k)``, ``k <= L``, and hence a density of order ``L``.

All functions here work for ``d = 2`` and ``d = 3`` and any even rank (memory grows as
``d**rank``; ranks above :data:`MAX_RANK` are refused).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from itertools import permutations
from math import factorial, prod

import numpy as np

from grainmech.conventions import seed_angles, seed_theta
from grainmech.errors import ParameterError
from grainmech.fabric import _checks
from grainmech.fabric._basis import harmonic_basis
from grainmech.fabric.quadrature import unit_rule

__all__ = [
    "MAX_RANK",
    "kanatani_factor",
    "outer_power",
    "contract_normals",
    "symmetrize",
    "trace",
    "deviatoric",
    "isotropic_moment",
    "rotate_tensor",
    "phi_from_fabric",
    "fabric_from_phi",
    "Anisotropy",
    "anisotropy",
]

#: Highest tensor rank handled (3**12 = 531441 components).
MAX_RANK = 12


def _sphere_measure(dim: int) -> float:
    return 4.0 * np.pi if dim == 3 else 2.0 * np.pi


def kanatani_factor(k: int, dim: int) -> float:
    """Factor ``F_k`` in ``phi_(k) = F_k dev N_(k)`` (Kanatani 1984; seed Eq. 4.11 for k=2).

    Parameters
    ----------
    k : int
        Tensor rank (>= 0).
    dim : int
        2 (discs, circle) or 3 (spheres, sphere).

    Returns
    -------
    float
        ``(2k+1)!!/k!`` in 3D (15/2 for k = 2, 315/8 for k = 4), ``2**k`` in 2D (4, 16).
    """
    k = _checks.as_int(k, "k", 0)
    dim = _checks.as_dim(dim)
    if dim == 3:
        return float(prod(range(1, 2 * k + 2, 2))) / factorial(k)
    return float(2 ** k)


def _check_tensor(T: object, name: str, dim: int | None = None) -> np.ndarray:
    A = _checks.as_finite_array(T, name)
    if A.ndim == 0:
        return A
    d = A.shape[0]
    if d not in (2, 3) or any(s != d for s in A.shape) or (dim is not None and d != dim):
        want = f"({dim}, ..., {dim})" if dim else "(d, ..., d) with d = 2 or 3"
        raise ParameterError(name, f"array of shape {A.shape}", f"must have shape {want}")
    if A.ndim > MAX_RANK:
        raise ParameterError(name, f"array of shape {A.shape}", f"rank above {MAX_RANK} not supported")
    return A


def outer_power(n: np.ndarray, k: int) -> np.ndarray:
    """Flattened k-fold outer products ``n^(x)k`` of many vectors.

    Parameters
    ----------
    n : ndarray, shape (p, d)
    k : int

    Returns
    -------
    ndarray, shape (p, d**k)
        Row ``q`` is ``n_q (x) ... (x) n_q`` in C order (ones for ``k = 0``).
    """
    p, d = n.shape
    out = np.ones((p, 1))
    for _ in range(k):
        out = (out[:, :, None] * n[:, None, :]).reshape(p, -1)
    return out


def contract_normals(T: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``T_{i1..ik} n_i1 ... n_ik`` for many normals.

    Parameters
    ----------
    T : ndarray, shape (d,) * k
    n : ndarray, shape (p, d)

    Returns
    -------
    ndarray, shape (p,)
    """
    T = np.asarray(T, dtype=float)
    return outer_power(n, T.ndim) @ T.reshape(-1)


def symmetrize(T: object) -> np.ndarray:
    """Fully symmetric part: average over all permutations of the indices.

    Parameters
    ----------
    T : array_like, shape (d,) * k

    Returns
    -------
    ndarray, shape (d,) * k
    """
    A = _check_tensor(T, "T")
    k = A.ndim
    if k < 2:
        return A.copy()
    perms = set(permutations(range(k)))
    total = np.zeros_like(A)
    for p in perms:
        total = total + np.transpose(A, p)
    return total / len(perms)


def trace(T: object, times: int = 1) -> np.ndarray:
    """Contract the last two indices ``times`` times: ``N_ij = N_ijkk`` (rank drops by 2 each)."""
    A = _check_tensor(T, "T")
    times = _checks.as_int(times, "times", 0)
    if 2 * times > A.ndim:
        raise ParameterError("times", times, f"cannot take {times} traces of a rank-{A.ndim} tensor")
    for _ in range(times):
        A = np.trace(A, axis1=A.ndim - 2, axis2=A.ndim - 1)
    return A


def deviatoric(T: object) -> np.ndarray:
    """Deviatoric (fully symmetric, traceless) part of a tensor of any rank, 2D or 3D.

    Computed exactly as the tensor of the degree-``k`` harmonic part of the polynomial
    ``T . n^k`` (Kanatani 1984): project ``T . n^k`` onto the orthonormal harmonics of
    degree ``k`` with a quadrature rule exact for degree ``2k``, then
    ``dev T = F_k * mean_n[h_k(n) n^(x)k]``.  For rank 2 this is ``T - tr(T) delta/d``; for
    rank 4 it equals ``T - a sum_6 delta T2 + b t sum_3 delta delta`` with
    ``a = 1/(d+4)``, ``b = 1/((d+4)(d+2))`` (tested).

    Parameters
    ----------
    T : array_like, shape (d,) * k

    Returns
    -------
    ndarray, shape (d,) * k
        Only the symmetric part of ``T`` matters.
    """
    A = _check_tensor(T, "T")
    k = A.ndim
    if k < 2:
        return A.copy()
    d = A.shape[0]
    pts, w = unit_rule(d, 2 * k)
    p = contract_normals(A, pts)
    B = harmonic_basis(pts, k)
    coef = _sphere_measure(d) * (w * p) @ B
    h = B @ coef
    D = kanatani_factor(k, d) * ((w * h) @ outer_power(pts, k))
    return D.reshape(A.shape)


def isotropic_moment(rank: int, dim: int) -> np.ndarray:
    """Fabric tensor of the uniform density: ``<n^(x)r>`` over the unit sphere/circle.

    Closed form: zero for odd ``r``; for even ``r`` the sum over all ``(r-1)!!`` pairings of
    Kronecker deltas divided by ``d (d+2) ... (d+r-2)`` (e.g. ``delta_ij / 3``,
    ``(delta_ij delta_kl + delta_ik delta_jl + delta_il delta_jk) / 15`` in 3D).

    Returns
    -------
    ndarray, shape (dim,) * rank
    """
    rank = _checks.as_int(rank, "rank", 0)
    dim = _checks.as_dim(dim)
    if rank > MAX_RANK:
        raise ParameterError("rank", rank, f"rank above {MAX_RANK} not supported")
    shape = (dim,) * rank
    if rank % 2:
        return np.zeros(shape)
    if rank == 0:
        return np.array(1.0)
    delta = np.eye(dim)
    prodd = np.array(1.0)
    for _ in range(rank // 2):
        prodd = np.multiply.outer(prodd, delta)
    npair = prod(range(1, rank, 2))
    denom = prod(dim + 2 * j for j in range(rank // 2))
    return symmetrize(prodd) * npair / denom


def rotate_tensor(T: object, R: object) -> np.ndarray:
    """``T'_{i..} = R_ia R_jb ... T_ab..`` (the fabric tensor of normals ``n' = R n``).

    Parameters
    ----------
    T : array_like, shape (d,) * k
    R : array_like, shape (d, d)
        Orthogonal matrix.
    """
    A = _check_tensor(T, "T")
    if A.ndim == 0:
        return A.copy()
    Rm = _checks.as_rotation(R, A.shape[0])
    for ax in range(A.ndim):
        A = np.moveaxis(np.tensordot(Rm, A, axes=([1], [ax])), 0, ax)
    return A


def _check_symmetric(A: np.ndarray, name: str, tol: float) -> None:
    if A.ndim < 2:
        return
    err = np.abs(symmetrize(A) - A).max()
    scale = max(1.0, np.abs(A).max())
    if err > tol * scale:
        raise ParameterError(name, f"array of shape {A.shape}",
                          f"must be fully symmetric; max |sym(T) - T| = {err:.3g}")


def phi_from_fabric(N: object, tol: float = 1e-8) -> dict[int, np.ndarray]:
    """Coefficient tensors from a fabric tensor (seed Eq. 4.11; Kanatani 1984).

    ``phi_(k) = F_k dev[ N_(k) ]`` for ``k = 2, 4, ..., L``, where ``N_(k)`` is ``N`` traced
    ``(L - k)/2`` times.  ``phi_(2) = 15/2 (N_ij - delta_ij/3)`` (spheres) or
    ``4 (N_ij - delta_ij/2)`` (discs) is the seed's Eq. 4.11.

    Parameters
    ----------
    N : array_like, shape (d,) * L
        Fabric tensor of even rank ``L >= 2`` (fully symmetric, full trace = 1).
    tol : float
        Tolerance of the symmetry and normalisation checks.

    Returns
    -------
    dict
        ``{k: phi_k}`` for ``k = 2, 4, ..., L``; each ``phi_k`` of shape (d,) * k.

    Raises
    ------
    ParameterError
        If ``N`` has odd rank, is not symmetric, or its full trace is not 1.
    """
    A = _check_tensor(N, "N")
    L = A.ndim
    if L < 2 or L % 2:
        raise ParameterError("N", f"array of shape {A.shape}", "rank must be even and >= 2")
    _check_symmetric(A, "N", tol)
    full = float(trace(A, L // 2))
    if abs(full - 1.0) > tol:
        raise ParameterError("N", f"array of shape {A.shape}",
                          f"full trace must be 1 (normalised density, seed Eq. 4.8); got {full:.12g}")
    d = A.shape[0]
    out: dict[int, np.ndarray] = {}
    for k in range(2, L + 1, 2):
        out[k] = kanatani_factor(k, d) * deviatoric(trace(A, (L - k) // 2))
    return out


def _check_phis(phis: Mapping[int, object], dim: int | None, tol: float) -> tuple[dict[int, np.ndarray], int]:
    if not isinstance(phis, Mapping):
        raise ParameterError("phis", type(phis).__name__,
                          "must be a mapping {rank: tensor}, e.g. {2: phi_ij, 4: phi_ijkl}")
    out: dict[int, np.ndarray] = {}
    for k, T in phis.items():
        k = _checks.as_even_order(k, "phis rank")
        if k == 0:
            raise ParameterError("phis rank", k, "rank 0 is fixed to 1 by normalisation (Eq. 4.10)")
        A = _check_tensor(T, f"phis[{k}]", dim)
        if A.ndim != k:
            raise ParameterError(f"phis[{k}]", f"array of shape {A.shape}", f"must have rank {k}")
        dim = A.shape[0]
        _check_symmetric(A, f"phis[{k}]", tol)
        tr = np.abs(trace(A)).max()
        if tr > tol * max(1.0, np.abs(A).max()):
            raise ParameterError(f"phis[{k}]", f"array of shape {A.shape}",
                              f"must be traceless (Kanatani's deviatoric coefficient tensor, seed "
                              f"Eq. 4.10); max |trace| = {tr:.3g}")
        out[k] = A
    if dim is None:
        raise ParameterError("phis", phis, "give at least one tensor or the dimension")
    return out, dim


def fabric_from_phi(phis: Mapping[int, object], rank: int, dim: int | None = None,
                    tol: float = 1e-8) -> np.ndarray:
    """Fabric tensor of rank ``rank`` of the density ``(1/|S|)[1 + sum_k phi_(k) . n^k]``.

    Exact moment (seed Eq. 4.6) by a quadrature rule of degree ``rank + max k``.  Closed
    forms (checked in the tests), 3D::

        N_ij   = delta_ij/3 + (2/15) phi_ij
        N_ijkl = (1/15) sum_3 delta delta + (2/105) sum_6 delta_ij phi_kl + (8/315) phi_ijkl

    and 2D::

        N_ij   = delta_ij/2 + phi_ij/4
        N_ijkl = (1/8) sum_3 delta delta + (1/24) sum_6 delta_ij phi_kl + phi_ijkl/16

    Parameters
    ----------
    phis : mapping {int: array}
        Traceless symmetric coefficient tensors keyed by (even) rank; may be empty if
        ``dim`` is given (isotropic density).
    rank : int
        Rank of the requested fabric tensor.
    dim : int, optional
        Needed only when ``phis`` is empty.

    Returns
    -------
    ndarray, shape (d,) * rank
    """
    rank = _checks.as_int(rank, "rank", 0)
    if rank > MAX_RANK:
        raise ParameterError("rank", rank, f"rank above {MAX_RANK} not supported")
    if dim is not None:
        dim = _checks.as_dim(dim)
    ph, d = _check_phis(phis, dim, tol)
    top = max(ph, default=0)
    pts, w = unit_rule(d, rank + top)
    f = np.ones(len(w))
    for A in ph.values():
        f = f + contract_normals(A, pts)
    N = (w * f) @ outer_power(pts, rank)
    return N.reshape((d,) * rank)


@dataclass(frozen=True)
class Anisotropy:
    """Scalar and directional anisotropy measures of a second-order fabric tensor.

    Attributes
    ----------
    deviator : ndarray, shape (d, d)
        ``N' = N - delta/d``.
    deviator_norm : float
        Frobenius norm ``||N'|| = sqrt(N'_ij N'_ij)``.
    phi : ndarray, shape (d, d)
        ``phi_ij = F_2 N'_ij`` (seed Eq. 4.11; 15/2 in 3D, 4 in 2D).
    amplitude : float
        Equivalent axisymmetric amplitude ``a``: in 3D ``sqrt(2/3 phi_ij phi_ij)``
        ``= (15/2) sqrt(2/3 N'_ij N'_ij)`` (the a_ij = 15/2 N'_ij of Ouadfel and Rothenburg
        2001, scalar chosen so that the seed's density ``(1/4 pi)[1 + a20 P2(cos gamma)]``
        gives ``a = |a20|``); in 2D ``sqrt(phi_ij phi_ij / 2) = 2 (N_1 - N_2)``, the
        ``a`` of ``(1/2 pi)[1 + a cos 2(theta - theta_a)]`` (Rothenburg and Bathurst
        1989), ``= sqrt(a2^2 + b2^2)`` in the seed's Eq. 4.34.  Some authors use
        ``sqrt(3/2 phi:phi)`` instead (1.5 times this value in 3D).
    principal_values : ndarray, shape (d,)
        Eigenvalues of ``N``, descending (they sum to 1).
    principal_axes : ndarray, shape (d, d)
        Columns are the corresponding unit eigenvectors (major axis first); the sign is
        fixed so that the last (z in 3D, y in 2D) component is non-negative (if that is
        zero, the largest component is positive).
    major_axis_seed_angles : tuple of float
        Seed angles of the major axis: ``(gamma, beta)`` in 3D, ``(theta,)`` in 2D,
        radians, with gamma in [0, pi/2] / theta in [0, pi).
    """

    deviator: np.ndarray
    deviator_norm: float
    phi: np.ndarray
    amplitude: float
    principal_values: np.ndarray
    principal_axes: np.ndarray
    major_axis_seed_angles: tuple[float, ...]


def anisotropy(N: object, tol: float = 1e-8) -> Anisotropy:
    """Anisotropy of a second-order fabric tensor (deviatoric norm, amplitude, axes).

    Parameters
    ----------
    N : array_like, shape (d, d)
        Symmetric fabric tensor with unit trace (seed Eq. 4.6, rank 2).

    Returns
    -------
    Anisotropy
    """
    A = _check_tensor(N, "N")
    if A.ndim != 2:
        raise ParameterError("N", f"array of shape {A.shape}", "must be a second-order tensor (d, d)")
    _check_symmetric(A, "N", tol)
    tr = float(np.trace(A))
    if abs(tr - 1.0) > tol:
        raise ParameterError("N", f"array of shape {A.shape}", f"trace must be 1; got {tr:.12g}")
    d = A.shape[0]
    dev = A - np.eye(d) * tr / d
    phi = kanatani_factor(2, d) * dev
    pp = float(np.sum(phi * phi))
    amp = float(np.sqrt(2.0 / 3.0 * pp)) if d == 3 else float(np.sqrt(pp / 2.0))
    vals, vecs = np.linalg.eigh(0.5 * (A + A.T))
    idx = np.argsort(vals)[::-1]
    vals, vecs = vals[idx], vecs[:, idx]
    for j in range(d):
        col = vecs[:, j]
        last = col[-1] if abs(col[-1]) > 1e-12 else col[np.argmax(np.abs(col))]
        if last < 0:
            vecs[:, j] = -col
    major = vecs[:, 0]
    if d == 3:
        g, b = seed_angles(major)
        ang: tuple[float, ...] = (float(g), float(b))
    else:
        th = float(seed_theta(major))
        ang = (th - np.pi if th >= np.pi else th,)
    return Anisotropy(deviator=dev, deviator_norm=float(np.linalg.norm(dev)), phi=phi,
                      amplitude=amp, principal_values=vals, principal_axes=vecs,
                      major_axis_seed_angles=ang)

"""Contact set -> stress and stiffness tensor (the kinematic hypothesis, seed Ch. 2).

A :class:`ContactSet` is the one object every input becomes: a fabric density
discretised by quadrature, a regular packing, or a measured contact network. Each entry
``c`` has a unit normal ``n_c``, a vector ``l_c`` (branch or centre-to-contact vector, see
*Counting convention*), a weight ``w_c`` (entries per unit volume it stands for, so that
for a measured network ``w_c = 1/V``), and tangent contact stiffnesses ``kn_c``, ``ks_c``.

Under the kinematic hypothesis (seed Eq. 2.13) the relative displacement at a contact is
``delta = eps . l`` and the force is ``f = K delta`` with the local stiffness in global
frame ``K = kn n(x)n + ks (I - n(x)n)`` (seed Eq. 2.17-2.23 with the full tangential
projector). The Love-Weber stress (seed Eq. 2.6, 2.27) is ``sigma = sum_c w_c f_c (x) l_c``,
so the stiffness (seed Eq. 2.26, and Eq. 2.41 for a distribution) is::

    C_ijkl = sym_(ij) sym_(kl) sum_c w_c K_ik l_j l_l .

Splitting ``K = (kn - ks) n(x)n + ks I`` gives the form the kernels evaluate::

    C = sum_c w_c (kn - ks) S_c (x) S_c + B(M),   S_c = sym(n_c (x) l_c),
    M = sum_c w_c ks l_c (x) l_c,   B(M)_ijkl = (d_ik M_jl + d_jk M_il + d_il M_jk + d_jl M_ik)/4

which costs 21 + 6 products per contact (3D) whatever the number of contacts.

Counting convention
-------------------
One engine, two ways of feeding it:

* ``physical`` (default, DEM and effective-medium theory): every physical contact once,
  ``l`` = centre-to-centre branch vector, ``w = 1/V`` (or contacts per volume x
  quadrature weight). This reproduces Walton (1987) / Digby (1981) exactly.
* ``seed`` (Chang 1988, Eq. 2.6 and 2.26): every particle and each of its contacts, i.e.
  each physical contact twice, ``l`` = centre-to-contact vector ``r``, and the seed's
  ``N/V`` of Eq. 4.1. The stress is the same as ``physical`` (``f (x) r`` summed over both
  sides equals ``f (x) l``), but the stiffness of equal spheres is exactly **half**: the
  seed applies the full contact stiffness to ``delta^{nm} = r . eps``, which is only the
  part of the relative displacement associated with one particle (Eq. 2.9). See
  ``docs/seed-errata.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from grainmech.conventions import matrix_to_tensor4, tensor4_to_matrix
from grainmech.errors import GrainmechError

__all__ = [
    "ContactSet",
    "stiffness",
    "stiffness_tensor",
    "love_weber_stress",
    "StressResult",
    "numba_available",
    "static_contact_forces",
    "stiffness_from_arrays",
    "love_weber_sum",
    "moments_to_voigt",
]

_CHUNK = 1 << 18  # contacts per NumPy chunk: bounds temporary memory (~30 MB)


def _as_array(name: str, value: Any, shape_desc: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GrainmechError(f"{name} must be a numeric array {shape_desc}: {exc}") from None
    return arr


def _check_finite(name: str, arr: np.ndarray) -> None:
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr).reshape(arr.shape[0], -1).all(axis=1))[0])
        raise GrainmechError(f"{name} has a non-finite value at contact {bad}: {arr[bad]!r}")


@dataclass(frozen=True)
class ContactSet:
    """Contacts (or quadrature directions) with geometry, weights and stiffness.

    Parameters
    ----------
    normals : array, shape (n, d)
        Unit contact normals (d = 2 or 3), pointing from particle A to particle B.
    branch : array, shape (n, d)
        Vector ``l`` carried into the kinematics ``delta = eps . l`` and the stress
        ``f (x) l``: the branch vector A -> B (``physical`` convention) or the
        centre-to-contact vector (``seed`` convention). Units of length.
    weights : array, shape (n,) or scalar
        Entries per unit volume that each row stands for (``1/V`` for a measured
        network). Units 1/length^d.
    kn, ks : array, shape (n,) or scalar
        Tangent normal and tangential contact stiffness, force/length (3D) or
        force/length per unit thickness (2D).
    convention : {"physical", "seed"}
        Recorded for reporting; the engine treats both the same (see module notes).
    """

    normals: np.ndarray
    branch: np.ndarray
    weights: np.ndarray
    kn: np.ndarray
    ks: np.ndarray
    convention: str = "physical"
    unit_tol: float = field(default=1e-6, repr=False)

    def __post_init__(self) -> None:
        n = _as_array("normals", self.normals, "(n, d)")
        if n.ndim != 2 or n.shape[1] not in (2, 3):
            raise GrainmechError(f"normals must have shape (n, 2) or (n, 3), got {n.shape}")
        m = n.shape[0]
        l_ = _as_array("branch", self.branch, "(n, d)")
        if l_.shape != n.shape:
            raise GrainmechError(f"branch must have the shape of normals {n.shape}, got {l_.shape}")
        arrays = {"normals": n, "branch": l_}
        for name in ("weights", "kn", "ks"):
            a = _as_array(name, getattr(self, name), "(n,)")
            if a.ndim == 0:
                a = np.full(m, float(a))
            if a.shape != (m,):
                raise GrainmechError(f"{name} must be a scalar or have shape ({m},), got {a.shape}")
            arrays[name] = a
        for name, a in arrays.items():
            _check_finite(name, a)
        norms = np.linalg.norm(n, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > self.unit_tol)
        if bad.size:
            i = int(bad[0])
            raise GrainmechError(f"normals must be unit vectors; row {i} has length {norms[i]:.6g}")
        for name in ("weights", "kn", "ks"):
            neg = np.flatnonzero(arrays[name] < 0)
            if neg.size:
                i = int(neg[0])
                raise GrainmechError(f"{name} must be >= 0; row {i} is {arrays[name][i]:.6g}")
        if self.convention not in ("physical", "seed"):
            raise GrainmechError(f"convention must be 'physical' or 'seed', got {self.convention!r}")
        for name, a in arrays.items():
            a = np.ascontiguousarray(a)
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def dim(self) -> int:
        """Spatial dimension (2 or 3)."""
        return int(self.normals.shape[1])

    def __len__(self) -> int:
        return int(self.normals.shape[0])

    def with_stiffness(self, kn: Any, ks: Any) -> ContactSet:
        """Same geometry with new contact stiffnesses."""
        return ContactSet(self.normals, self.branch, self.weights, kn, ks, self.convention)

    @classmethod
    def from_density(
        cls,
        density: Any,
        *,
        contacts_per_volume: float,
        branch_length: float,
        kn: float | Callable[[np.ndarray], np.ndarray],
        ks: float | Callable[[np.ndarray], np.ndarray],
        extra_degree: int = 4,
        convention: str = "physical",
    ) -> ContactSet:
        """Discretise a contact-normal density by quadrature (seed Eq. 2.41).

        Parameters
        ----------
        density : object with ``directions(extra_degree) -> (normals, weights)``
            A density from :mod:`grainmech.fabric` (weights sum to 1 and integrate
            ``xi(n) f(n)`` exactly for polynomials ``f`` of degree <= ``extra_degree``).
        contacts_per_volume : float
            ``N/V`` in the chosen convention (physical: contacts per volume; seed: the
            seed's Eq. 4.1 count, each contact twice).
        branch_length : float
            Length of ``l`` (physical: centre-to-centre distance ``2 rho`` for equal
            spheres; seed: particle radius ``rho``).
        kn, ks : float or callable
            Contact stiffnesses, constant or as a function of the normals (k, d) -> (k,).
        extra_degree : int
            Polynomial degree in ``n`` of the rest of the integrand: 4 for constant
            stiffnesses (seed Eq. 4.19); raise it for direction-dependent stiffness.
        """
        if not np.isfinite(contacts_per_volume) or contacts_per_volume <= 0:
            raise GrainmechError(f"contacts_per_volume must be > 0, got {contacts_per_volume!r}")
        if not np.isfinite(branch_length) or branch_length <= 0:
            raise GrainmechError(f"branch_length must be > 0, got {branch_length!r}")
        normals, w = density.directions(extra_degree)
        kn_v = np.asarray(kn(normals) if callable(kn) else kn, dtype=float)
        ks_v = np.asarray(ks(normals) if callable(ks) else ks, dtype=float)
        return cls(normals, branch_length * normals, contacts_per_volume * np.asarray(w),
                   kn_v, ks_v, convention)


# --------------------------------------------------------------------------- kernels

def _sym_mandel_rows(n: np.ndarray, l_: np.ndarray) -> np.ndarray:
    """Mandel vectors of sym(n (x) l) for each row; shape (k, 6) or (k, 3)."""
    r2 = np.sqrt(2.0) / 2.0
    if n.shape[1] == 3:
        return np.stack([
            n[:, 0] * l_[:, 0], n[:, 1] * l_[:, 1], n[:, 2] * l_[:, 2],
            r2 * (n[:, 1] * l_[:, 2] + n[:, 2] * l_[:, 1]),
            r2 * (n[:, 0] * l_[:, 2] + n[:, 2] * l_[:, 0]),
            r2 * (n[:, 0] * l_[:, 1] + n[:, 1] * l_[:, 0]),
        ], axis=1)
    return np.stack([
        n[:, 0] * l_[:, 0], n[:, 1] * l_[:, 1],
        r2 * (n[:, 0] * l_[:, 1] + n[:, 1] * l_[:, 0]),
    ], axis=1)


def _moments_numpy(n, l_, w, kn, ks):
    """Return (A, M): A = sum w (kn-ks) s s^T (Mandel), M = sum w ks l l^T."""
    d = n.shape[1]
    m = 6 if d == 3 else 3
    A = np.zeros((m, m))
    M = np.zeros((d, d))
    for start in range(0, n.shape[0], _CHUNK):
        sl = slice(start, start + _CHUNK)
        s = _sym_mandel_rows(n[sl], l_[sl])
        c = w[sl] * (kn[sl] - ks[sl])
        A += (s * c[:, None]).T @ s
        lw = l_[sl] * (w[sl] * ks[sl])[:, None]
        M += lw.T @ l_[sl]
    return A, M


def _b_operator(d: int) -> np.ndarray:
    """Linear map M (d, d) -> Mandel matrix of B(M), as an array (m, m, d, d)."""
    eye = np.eye(d)
    ops = []
    for a in range(d):
        for b in range(d):
            E = np.zeros((d, d))
            E[a, b] = 1.0
            B = 0.25 * (np.einsum("ik,jl->ijkl", eye, E) + np.einsum("jk,il->ijkl", eye, E)
                        + np.einsum("il,jk->ijkl", eye, E) + np.einsum("jl,ik->ijkl", eye, E))
            ops.append(tensor4_to_matrix(B, mandel=True))
    return np.moveaxis(np.array(ops).reshape(d, d, *ops[0].shape), (0, 1), (2, 3))


_B_OP = {2: _b_operator(2), 3: _b_operator(3)}
#: Mandel -> Voigt scaling of each entry (1 / (s_i s_j), s = 1 or sqrt 2)
_M2V = {d: 1.0 / np.outer(s_, s_) for d, s_ in
        ((3, np.array([1, 1, 1, np.sqrt(2), np.sqrt(2), np.sqrt(2)])), (2, np.array([1, 1, np.sqrt(2)])))}


def _b_mandel(M: np.ndarray) -> np.ndarray:
    """Mandel matrix of B(M)_ijkl = (d_ik M_jl + d_jk M_il + d_il M_jk + d_jl M_ik)/4."""
    return np.einsum("abkl,kl->ab", _B_OP[M.shape[0]], M)


try:  # optional compiled kernel (extra "fast")
    import numba as _nb

    @_nb.njit(inline="always", fastmath=True, cache=True)
    def add_moments3(a, nx, ny, nz, lx, ly, lz, cn, cs, r2):  # pragma: no cover - numba
        """Add one contact's terms to the 27 moments of :func:`_moments_to_matrices` (3D).

        ``cn = w (kn - ks)``, ``cs = w ks``: ``a[:21]`` the upper triangle of
        ``sum cn s s`` with ``s`` the Mandel vector of ``sym(n (x) l)``; ``a[21:27]``
        ``sum cs l (x) l`` as (xx, yy, zz, yz, xz, xy) (seed Eq. 2.26, full projector).
        """
        s0 = nx * lx
        s1 = ny * ly
        s2 = nz * lz
        s3 = r2 * (ny * lz + nz * ly)
        s4 = r2 * (nx * lz + nz * lx)
        s5 = r2 * (nx * ly + ny * lx)
        t0 = cn * s0
        t1 = cn * s1
        t2 = cn * s2
        t3 = cn * s3
        t4 = cn * s4
        a[0] += t0 * s0
        a[1] += t0 * s1
        a[2] += t0 * s2
        a[3] += t0 * s3
        a[4] += t0 * s4
        a[5] += t0 * s5
        a[6] += t1 * s1
        a[7] += t1 * s2
        a[8] += t1 * s3
        a[9] += t1 * s4
        a[10] += t1 * s5
        a[11] += t2 * s2
        a[12] += t2 * s3
        a[13] += t2 * s4
        a[14] += t2 * s5
        a[15] += t3 * s3
        a[16] += t3 * s4
        a[17] += t3 * s5
        a[18] += t4 * s4
        a[19] += t4 * s5
        a[20] += cn * s5 * s5
        a[21] += cs * lx * lx
        a[22] += cs * ly * ly
        a[23] += cs * lz * lz
        a[24] += cs * ly * lz
        a[25] += cs * lx * lz
        a[26] += cs * lx * ly

    @_nb.njit(parallel=True, fastmath=True, cache=True)
    def _moments_numba3(n, l_, w, kn, ks, nchunks):  # pragma: no cover - exercised when numba present
        N = n.shape[0]
        out = np.zeros((nchunks, 27))
        step = (N + nchunks - 1) // nchunks
        r2 = np.sqrt(2.0) / 2.0
        for c in _nb.prange(nchunks):
            a = np.zeros(27)
            lo = c * step
            hi = min(N, lo + step)
            for i in range(lo, hi):
                wi = w[i]
                cs = wi * ks[i]
                add_moments3(a, n[i, 0], n[i, 1], n[i, 2], l_[i, 0], l_[i, 1], l_[i, 2],
                              wi * kn[i] - cs, cs, r2)
            for k in range(27):
                out[c, k] = a[k]
        return out.sum(axis=0)

    @_nb.njit(parallel=True, fastmath=True, cache=True)
    def _moments_numba2(n, l_, w, kn, ks, nchunks):  # pragma: no cover
        N = n.shape[0]
        out = np.zeros((nchunks, 9))
        step = (N + nchunks - 1) // nchunks
        r2 = np.sqrt(2.0) / 2.0
        for c in _nb.prange(nchunks):
            a = np.zeros(9)
            lo = c * step
            hi = min(N, lo + step)
            for i in range(lo, hi):
                nx = n[i, 0]
                ny = n[i, 1]
                lx = l_[i, 0]
                ly = l_[i, 1]
                wi = w[i]
                cs = wi * ks[i]
                cn = wi * kn[i] - cs
                s0 = nx * lx
                s1 = ny * ly
                s2 = r2 * (nx * ly + ny * lx)
                a[0] += cn * s0 * s0
                a[1] += cn * s0 * s1
                a[2] += cn * s0 * s2
                a[3] += cn * s1 * s1
                a[4] += cn * s1 * s2
                a[5] += cn * s2 * s2
                a[6] += cs * lx * lx
                a[7] += cs * ly * ly
                a[8] += cs * lx * ly
            for k in range(9):
                out[c, k] = a[k]
        return out.sum(axis=0)

    _HAVE_NUMBA = True
except ImportError:  # pragma: no cover - depends on environment
    _HAVE_NUMBA = False


def numba_available() -> bool:
    """True if the optional compiled kernel (numba) can be used."""
    return _HAVE_NUMBA


def _moments_to_matrices(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 27 moments of the compiled 3D kernel as ``(A (6, 6) Mandel, M (3, 3))``."""
    A = np.zeros((6, 6))
    A[_TRIU6] = a[:21]
    A = A + np.triu(A, 1).T
    M = np.array([[a[21], a[26], a[25]], [a[26], a[22], a[24]], [a[25], a[24], a[23]]])
    return A, M


def moments_to_voigt(a: np.ndarray) -> np.ndarray:
    """Voigt stiffness (6, 6) [stress] from the 27 moments of ``add_moments3``.

    Voigt stiffness (6, 6) [stress] from the 27 moments accumulated by ``add_moments3``
    (seed Eq. 2.26 with the full tangential projector, symmetrised as :func:`stiffness`).
    """
    A, M = _moments_to_matrices(a)
    Cm = A + _b_mandel(M)
    return 0.5 * (Cm + Cm.T) * _M2V[3]


_TRIU6 = np.triu_indices(6)


def _moments_compiled(n, l_, w, kn, ks):
    nchunks = max(1, min(64, n.shape[0] // 4096))
    if n.shape[1] == 3:
        return _moments_to_matrices(_moments_numba3(n, l_, w, kn, ks, nchunks))
    else:
        a = _moments_numba2(n, l_, w, kn, ks, nchunks)
        A = np.zeros((3, 3))
        A[np.triu_indices(3)] = a[:6]
        A = A + np.triu(A, 1).T
        M = np.array([[a[6], a[8]], [a[8], a[7]]])
    return A, M


def stiffness(contacts: ContactSet, *, mandel: bool = False, backend: str = "auto") -> np.ndarray:
    """Stiffness matrix of a contact set under the kinematic hypothesis (seed Eq. 2.26/2.41).

    Parameters
    ----------
    contacts : ContactSet
    mandel : bool
        Return the Mandel matrix instead of Voigt.
    backend : {"auto", "numpy", "numba"}
        ``auto`` uses the compiled kernel when numba is installed and the set is large.

    Returns
    -------
    array, shape (6, 6) in 3D or (3, 3) in 2D
        Library order ``(xx, yy, zz, yz, xz, xy)`` / ``(xx, yy, xy)``; Voigt matrices act
        on engineering shear strains. Units: stress (force/length^2 in 3D).

    Notes
    -----
    Minor symmetries are imposed by taking the symmetric parts of stress and strain (seed
    Eq. 2.6); major symmetry follows from the symmetric local stiffness ``K``.
    """
    if not isinstance(contacts, ContactSet):
        raise GrainmechError(f"contacts must be a ContactSet, got {type(contacts).__name__}")
    if backend not in ("auto", "numpy", "numba"):
        raise GrainmechError(f"backend must be 'auto', 'numpy' or 'numba', got {backend!r}")
    if backend == "numba" and not _HAVE_NUMBA:
        raise GrainmechError("backend 'numba' requested but numba is not installed "
                             "(pip install 'grainmech[fast]')")
    return stiffness_from_arrays(contacts.normals, contacts.branch, contacts.weights, contacts.kn, contacts.ks,
                             mandel=mandel, backend=backend)


def stiffness_from_arrays(n: np.ndarray, l_: np.ndarray, w: np.ndarray, kn: np.ndarray, ks: np.ndarray, *,
                      mandel: bool = False, backend: str = "auto") -> np.ndarray:
    """:func:`stiffness` (seed Eq. 2.26) on validated contiguous float arrays.

    No checks: for inner loops (the material-point driver) that validated their arrays once.
    Shapes: ``n``, ``l_`` (C, d); ``w``, ``kn``, ``ks`` (C,). Returns (m, m) Voigt (or Mandel).
    """
    use_numba = backend == "numba" or (backend == "auto" and _HAVE_NUMBA and n.shape[0] >= 2000)
    A, M = _moments_compiled(n, l_, w, kn, ks) if use_numba else _moments_numpy(n, l_, w, kn, ks)
    Cm = A + _b_mandel(M)
    Cm = 0.5 * (Cm + Cm.T)
    if mandel:
        return Cm
    return Cm * _M2V[n.shape[1]]


def stiffness_tensor(contacts: ContactSet, backend: str = "auto") -> np.ndarray:
    """4th-order stiffness tensor C_ijkl, shape (d, d, d, d); see :func:`stiffness`."""
    return matrix_to_tensor4(stiffness(contacts, mandel=True, backend=backend), mandel=True)


@dataclass(frozen=True)
class StressResult:
    """Love-Weber average stress (seed Eq. 2.6-2.7), compression positive.

    Attributes
    ----------
    stress : array (d, d)
        Symmetric part, Eq. 2.6.
    skew : array (d, d)
        Skew-symmetric part, Eq. 2.7 (mean torque density; zero at equilibrium).
    skew_ratio : float
        ``|skew| / |stress|`` (Frobenius norms), 0 if the stress vanishes.
    """

    stress: np.ndarray
    skew: np.ndarray
    skew_ratio: float

    @property
    def mean(self) -> float:
        """Mean stress p = tr(sigma)/d."""
        return float(np.trace(self.stress) / self.stress.shape[0])


def love_weber_sum(f: np.ndarray, l_: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``sum_c w_c f_c (x) l_c`` (seed Eq. 2.6 before symmetrisation) on validated arrays.

    No checks (for inner loops): ``f``, ``l_`` (C, d), ``w`` (C,); returns (d, d).
    """
    full = np.zeros((f.shape[1], f.shape[1]))
    for start in range(0, f.shape[0], _CHUNK):
        sl = slice(start, start + _CHUNK)
        full += (f[sl] * w[sl, None]).T @ l_[sl]
    return full


def love_weber_stress(forces: np.ndarray, branch: np.ndarray, weights: np.ndarray | float) -> StressResult:
    """Love-Weber stress ``sigma_ij = sum_c w_c f_i l_j`` (seed Eq. 2.6, 2.7, 2.27).

    Parameters
    ----------
    forces : array, shape (n, d)
        Contact force exerted by particle A on particle B, compression positive (its
        normal component ``f . n`` is the compressive normal force).
    branch : array, shape (n, d)
        Branch vectors A -> B (physical convention) or centre-to-contact vectors (seed
        convention, each contact twice with its own force).
    weights : array (n,) or float
        Entries per unit volume (``1/V`` for a network).

    Returns
    -------
    StressResult
    """
    f = _as_array("forces", forces, "(n, d)")
    l_ = _as_array("branch", branch, "(n, d)")
    if f.ndim != 2 or f.shape[1] not in (2, 3) or f.shape != l_.shape:
        raise GrainmechError(f"forces {f.shape} and branch {l_.shape} must both be (n, d), d = 2 or 3")
    w = np.broadcast_to(_as_array("weights", weights, "(n,)"), (f.shape[0],))
    _check_finite("forces", f)
    _check_finite("branch", l_)
    full = love_weber_sum(f, l_, w)
    sym = 0.5 * (full + full.T)
    skew = 0.5 * (full - full.T)
    ns = np.linalg.norm(sym)
    return StressResult(sym, skew, float(np.linalg.norm(skew) / ns) if ns > 0 else 0.0)


def static_contact_forces(contacts: ContactSet, sigma: np.ndarray) -> np.ndarray:
    """Static estimate of the contact forces carrying a given stress.

    The forces ``f_c = sigma . F^{-1} . l_c`` with the branch fabric
    ``F = sum_c w_c l_c (x) l_c`` reproduce the Love-Weber stress exactly:
    ``sum_c w_c f_c (x) l_c = sigma F^{-1} F = sigma`` (seed Eq. 2.6). For an isotropic
    fabric and ``sigma = P I`` this is the seed's Eq. 4.43, ``f = 3 V P / (N l) n``; for
    an anisotropic fabric or stress the forces have tangential components (the basis of
    the seed's Sec. 6.3.2 state estimate, see the driver docs).

    Parameters
    ----------
    contacts : ContactSet
    sigma : array (d, d)
        Symmetric stress, compression positive.

    Returns
    -------
    array (n, d)
        Force exerted by particle A on particle B at each row.
    """
    s = _as_array("sigma", sigma, "(d, d)")
    d = contacts.dim
    if s.shape != (d, d):
        raise GrainmechError(f"sigma must have shape ({d}, {d}), got {s.shape}")
    if not np.all(np.isfinite(s)) or not np.allclose(s, s.T, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(s).max())):
        raise GrainmechError("sigma must be a finite symmetric tensor")
    F = (contacts.branch * contacts.weights[:, None]).T @ contacts.branch
    if np.linalg.matrix_rank(F) < d:
        raise GrainmechError("the branch vectors do not span space (branch fabric is singular); "
                             "no contact forces can carry a general stress")
    G = s @ np.linalg.inv(F)
    return contacts.branch @ G.T

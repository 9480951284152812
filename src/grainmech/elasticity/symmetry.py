"""Material-symmetry class of a stiffness, its natural frame, and the projection onto a class.

Forte & Vianello 1996; Cowin & Mehrabadi 1987.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache, lru_cache
from types import MappingProxyType

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from grainmech.conventions import mandel_to_voigt, matrix_to_tensor4, voigt_to_mandel
from grainmech.elasticity._mandel import (
    as_given,
    as_voigt,
    check_finite_symmetric,
    check_orthogonal,
    dimension,
    frame_from_axis,
    isotropic_projection,
    isotropic_projectors,
    mandel_rotation,
    unit_vectors,
)
from grainmech.elasticity.conversions import contracted_tensors, rotation_about
from grainmech.errors import GrainmechError

#: Names of the eight elastic symmetry classes (Forte & Vianello 1996), highest first.
SYMMETRY_CLASSES_3D: tuple[str, ...] = (
    "isotropic", "cubic", "transversely isotropic", "tetragonal", "trigonal",
    "orthotropic", "monoclinic", "triclinic",
)
#: Names of the four 2D elastic symmetry classes, highest first.
SYMMETRY_CLASSES_2D: tuple[str, ...] = ("isotropic", "square", "orthotropic", "anisotropic")

#: Number of independent elastic constants in the natural frame of each class.
N_INDEPENDENT: Mapping[str, int] = MappingProxyType({
    "isotropic": 2, "cubic": 3, "transversely isotropic": 5, "tetragonal": 6,
    "trigonal": 6, "orthotropic": 9, "monoclinic": 13, "triclinic": 21,
    "square": 3, "anisotropic": 6,
})

#: The seed's names (Chang 1988, Table 1) for the classes it covers.  The seed's
#: "orthotropic with non-coincident stress axes" is the 13-constant *matrix form* of
#: Table 1 (normal stresses coupled to the xy shear strain), i.e. the monoclinic pattern;
#: an orthotropic tensor whose axes are not the coordinate axes also gets this seed name.
SEED_NAMES: Mapping[str, str] = MappingProxyType({
    "isotropic": "isotropic",
    "transversely isotropic": "transverse isotropic",
    "tetragonal": "tetragonal",
    "orthotropic": "orthotropic",
    "monoclinic": "orthotropic with non-coincident stress axes",
})


def _kron_avg(Ks: np.ndarray) -> np.ndarray:
    """Projection (as a matrix on row-major vec) that averages M over the group {K}."""
    return np.mean([np.kron(K, K) for K in Ks], axis=0)


def _group_mats(cls: str) -> np.ndarray:
    """Rotation matrices generating the averaging group of ``cls`` in its natural frame.

    Axis classes use only the rotations about z: a 4th-order elasticity tensor invariant
    under an n-fold rotation (n = 2, 3, 4) lies in the monoclinic, trigonal, tetragonal
    class or higher (Forte & Vianello 1996), and invariance under 8 equally spaced
    rotations implies invariance under all of them (Hermann's theorem: the components
    of a rotated 4th-order tensor are trigonometric polynomials of degree 4).
    """
    z = np.array([0.0, 0.0, 1.0])
    if cls in ("transversely isotropic", "tetragonal", "trigonal", "monoclinic"):
        n = {"transversely isotropic": 8, "tetragonal": 4, "trigonal": 3, "monoclinic": 2}[cls]
        return np.array([rotation_about(z, 2 * np.pi * k / n) for k in range(n)])
    if cls == "orthotropic":
        return np.array([np.diag(s) for s in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))])
    if cls == "cubic":  # the 24 proper rotations of the cube
        mats = []
        for p in itertools.permutations(range(3)):
            for s in itertools.product((1, -1), repeat=3):
                Q = np.zeros((3, 3))
                Q[range(3), p] = s
                if np.linalg.det(Q) > 0:
                    mats.append(Q)
        return np.array(mats)
    # 2D
    if cls == "square":
        return np.array([[[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]
                         for t in np.arange(4) * np.pi / 2])
    if cls == "orthotropic2d":
        return np.array([np.eye(2), np.diag([1.0, -1.0])])
    raise KeyError(cls)


@cache
def _projector(cls: str, dim: int) -> np.ndarray:
    """(m^2, m^2) matrix of the orthogonal projection onto ``cls``-invariant tensors."""
    if cls == "isotropic":
        J, Kd = isotropic_projectors(dim)
        return np.outer(J.ravel(), J.ravel()) + np.outer(Kd.ravel(), Kd.ravel()) / np.trace(Kd)
    key = "orthotropic2d" if (dim == 2 and cls == "orthotropic") else cls
    P = _kron_avg(mandel_rotation(_group_mats(key)))
    P.setflags(write=False)
    return P


def _natural_residual(Mn: np.ndarray, R: np.ndarray, cls: str) -> np.ndarray:
    """Residual vector (I - P) vec(K M K^T) for frame(s) R; ``Mn`` is normalised."""
    dim = R.shape[-1]
    K = mandel_rotation(R)
    Mp = K @ Mn @ np.swapaxes(K, -1, -2)
    v = Mp.reshape(Mp.shape[:-2] + (-1,))
    P = _projector(cls, dim)
    return v - v @ P.T


_AXIS_CLASSES = ("transversely isotropic", "tetragonal", "trigonal", "monoclinic")
_LEVELS_3D = (("isotropic",), ("cubic", "transversely isotropic"), ("tetragonal", "trigonal"),
              ("orthotropic",), ("monoclinic",), ("triclinic",))


@lru_cache(maxsize=1)
def _sphere_grid(n: int = 1200, k: int = 8) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fibonacci points on the upper hemisphere, their neighbour lists and frames.

    Neighbours with ``n ~ -n``; a frame per point (rows t1, t2, a).
    """
    i = np.arange(n)
    z = (i + 0.5) / n
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(1 - z * z)
    P = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    tree = cKDTree(np.vstack([P, -P]))
    _, idx = tree.query(P, k=k + 1)
    nb = idx[:, 1:] % n
    frames = np.array([frame_from_axis(p) for p in P])
    for arr in (P, nb, frames):
        arr.setflags(write=False)
    return P, nb, frames


def _canon_axis(a: np.ndarray) -> np.ndarray:
    a = a / np.linalg.norm(a)
    for c in (2, 1, 0):
        if abs(a[c]) > 1e-9:
            return a if a[c] > 0 else -a
    return a  # pragma: no cover


def _refine(Mn: np.ndarray, R0: np.ndarray, cls: str, axis_only: bool) -> tuple[float, np.ndarray]:
    """Local least-squares polish of a frame; returns (relative residual, frame)."""
    r0 = float(np.linalg.norm(_natural_residual(Mn, R0, cls)))
    if r0 < 1e-14:
        return r0, R0

    def frame(p: np.ndarray) -> np.ndarray:
        w = np.array([p[0], p[1], 0.0]) if axis_only else p
        return Rotation.from_rotvec(w).as_matrix() @ R0

    def fun(p: np.ndarray) -> np.ndarray:
        return _natural_residual(Mn, frame(p), cls)

    sol = least_squares(fun, np.zeros(2 if axis_only else 3), method="lm",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=400)
    R = frame(sol.x)
    r = float(np.linalg.norm(_natural_residual(Mn, R, cls)))
    if r > r0:
        return r0, R0
    U, _, Vt = np.linalg.svd(R)  # re-orthonormalise
    return r, U @ Vt


def _dedupe_axes(found: list[tuple[float, np.ndarray]], cos_tol: float = np.cos(np.radians(2.0))
                 ) -> list[tuple[float, np.ndarray]]:
    out: list[tuple[float, np.ndarray]] = []
    for r, R in sorted(found, key=lambda t: t[0]):
        if all(abs(np.dot(R[2], Q[2])) < cos_tol for _, Q in out):
            out.append((r, R))
    return out


class _Search3D:
    """Lazy orientation searches for one normalised Mandel matrix."""

    def __init__(self, Mn: np.ndarray) -> None:
        self.Mn = Mn
        # Cowin-Mehrabadi seeds: eigenvectors of the dilatational and Voigt tensors
        d, v = contracted_tensors(matrix_to_tensor4(Mn, mandel=True))
        (ld, Vd), (lv, Vv) = np.linalg.eigh(d), np.linalg.eigh(v)
        self.contracted_eigs = (ld, lv)
        seeds = np.hstack([Vd, Vv]).T
        self.seed_frames = np.array([frame_from_axis(_canon_axis(s)) for s in seeds])
        # the eigenvector frames of d and v (rows, made proper): orthotropic / cubic seeds
        self.eigen_frames = np.array([V.T * (np.sign(np.linalg.det(V)) or 1.0) for V in (Vd, Vv)])
        self._grid: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._axes: dict[str, list[tuple[float, np.ndarray]]] = {}
        self.best: dict[str, tuple[float, np.ndarray | None]] = {}

    def grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Hemisphere grid, neighbours, frames and the rotated matrices (computed once)."""
        if self._grid is None:
            P, nb, frames = _sphere_grid()
            K = mandel_rotation(frames)
            Mgrid = (K @ self.Mn @ np.swapaxes(K, -1, -2)).reshape(len(P), -1)
            self._grid = (P, nb, frames, Mgrid)
        return self._grid

    def lower_bound(self, cls: str) -> float:
        """A lower bound of the class residual from the contracted tensors alone.

        The contractions ``d_ij = C_ijkk`` and ``v_ij = C_ikjk`` commute with rotations,
        so for the group average ``P_G`` (any orientation), ``d(C) - d(P_G C) = d(C - P_G C)``
        and ``||d(X)||_F <= sqrt(3) ||X||_F`` (Cauchy-Schwarz over the contracted index;
        likewise for ``v``).  ``d(P_G C)`` is the group average of ``d(C)``: isotropic for the
        cubic group, transversely isotropic for an n-fold rotation with n >= 3
        (Cowin & Mehrabadi 1987).  Hence the residual of ``cubic`` is at least
        ``||dev d|| / sqrt(3)``, and that of the classes with a 3-, 4- or 8-fold axis at
        least ``min(lambda_2 - lambda_1, lambda_3 - lambda_2) / sqrt(6)`` (the distance to
        the nearest matrix with a double eigenvalue, Hoffman-Wielandt), the larger of the
        ``d`` and ``v`` values.  Other classes: 0.
        """
        bounds = [0.0]
        for lam in self.contracted_eigs:
            if cls == "cubic":
                bounds.append(float(np.linalg.norm(lam - lam.mean())) / np.sqrt(3.0))
            elif cls in ("transversely isotropic", "tetragonal", "trigonal"):
                bounds.append(float(np.min(np.diff(lam))) / np.sqrt(6.0))
        return max(bounds)

    def quick(self, cls: str, tol: float) -> tuple[float, np.ndarray]:
        """Best residual and frame among the Cowin-Mehrabadi seeds (no search).

        Polished when it is already within ``tol``.
        """
        frames = self.seed_frames if cls in _AXIS_CLASSES else self.eigen_frames
        rs = np.linalg.norm(_natural_residual(self.Mn, frames, cls), axis=-1)
        i = int(np.argmin(rs))
        if rs[i] > tol:
            return float(rs[i]), frames[i]
        return _refine(self.Mn, frames[i], cls, axis_only=cls in _AXIS_CLASSES)

    def axes(self, cls: str, nref: int) -> list[tuple[float, np.ndarray]]:
        """Refined candidate axes for an axis class: list of (residual, frame), best first."""
        if cls in self._axes:
            return self._axes[cls]
        P = _projector(cls, 3)
        _, nb, gframes, Mgrid = self.grid()
        r = np.linalg.norm(Mgrid - Mgrid @ P.T, axis=1)
        locmin = np.flatnonzero(r <= r[nb].min(axis=1))
        locmin = locmin[np.argsort(r[locmin])]
        cands = [(float(r[i]), gframes[i]) for i in locmin]
        rs = np.linalg.norm(_natural_residual(self.Mn, self.seed_frames, cls), axis=-1)
        cands += [(float(x), F) for x, F in zip(rs, self.seed_frames)]
        cands = _dedupe_axes(cands)[:nref]
        refined = [_refine(self.Mn, F, cls, axis_only=True) for _, F in cands]
        out = _dedupe_axes(refined, cos_tol=np.cos(np.radians(0.5)))
        self._axes[cls] = out
        return out

    def frame_class(self, cls: str) -> tuple[float, np.ndarray | None]:
        """Best residual and frame for orthotropic (from 2-fold axes) or cubic (4-fold)."""
        src = "monoclinic" if cls == "orthotropic" else "tetragonal"
        ax = [F[2] for _, F in self.axes(src, 8)]
        frames = []
        for a, b in itertools.permutations(ax[:6], 2):
            if abs(np.dot(a, b)) < 0.5:
                t = b - np.dot(b, a) * a
                t /= np.linalg.norm(t)
                frames.append(np.array([t, np.cross(a, t), a]))
        if not frames:
            frames = [np.eye(3)] + [F for _, F in self.axes(src, 8)[:2]]
        frames_arr = np.array(frames)
        rs = np.linalg.norm(_natural_residual(self.Mn, frames_arr, cls), axis=-1)
        order = np.argsort(rs)[:3]
        best = min((_refine(self.Mn, frames_arr[i], cls, axis_only=False) for i in order),
                   key=lambda t: t[0])
        return best

    def residual(self, cls: str) -> tuple[float, np.ndarray | None]:
        if cls in self.best:
            return self.best[cls]
        if cls == "isotropic":
            P = isotropic_projection(self.Mn, 3)
            res: tuple[float, np.ndarray | None] = (float(np.linalg.norm(self.Mn - P)), np.eye(3))
        elif cls == "triclinic":
            res = (0.0, None)
        elif cls in _AXIS_CLASSES:
            res = self.axes(cls, 8 if cls == "monoclinic" else 4)[0]
        else:
            res = self.frame_class(cls)
        self.best[cls] = res
        return res


#: a seed frame whose polished residual is below this fraction of ``tol`` settles its level
_CERTAIN = 1e-3


def _level_results(search: _Search3D, level: tuple[str, ...], tol: float
                   ) -> dict[str, tuple[float, np.ndarray | None]]:
    """Residual and frame of the classes of one level that need to be known.

    A class whose invariant lower bound (:meth:`_Search3D.lower_bound`) exceeds ``tol``
    cannot pass: its bound is recorded and no orientation is searched.  If a
    Cowin-Mehrabadi seed frame already fits a class to ``_CERTAIN * tol``, that class
    passes and the other classes of the level are not searched (a second class within
    ``tol`` with a still smaller residual would put the tensor within ~``tol`` of the
    higher level, which has failed).  Otherwise every remaining class is searched.
    """
    results: dict[str, tuple[float, np.ndarray | None]] = {}
    todo: list[str] = []
    for c in level:
        bound = search.lower_bound(c)
        if bound > tol * (1.0 + 1e-9):
            results[c] = (bound, None)
        else:
            todo.append(c)
    certain = {}
    for c in todo:
        if c not in ("isotropic", "triclinic"):
            r, Fq = search.quick(c, tol)
            if r <= _CERTAIN * tol:
                certain[c] = (r, Fq)
    if certain:
        results.update(certain)
        return results
    for c in todo:
        results[c] = search.residual(c)
    return results


def _nearest_signed_permutation(F: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Among the frames g @ F (g in the symmetry group), the one closest to the identity."""
    cands = np.einsum("gij,jk->gik", group, F)
    return cands[int(np.argmax(np.einsum("gii->g", cands)))]


def _in_plane_twofold(Mn: np.ndarray, F: np.ndarray, n_fold: int) -> np.ndarray:
    """Rotate frame F about its z row so that x' is a 2-fold axis closest to e_x."""
    phis = np.linspace(0.0, np.pi, 181)[:-1]
    Rz = np.array([rotation_about((0, 0, 1), p).T for p in phis])  # rows rotate in-plane
    frames = Rz @ F
    M2 = _projector("monoclinic", 3)
    # 2-fold about x' of the frame: move x' to z and test C2 about z
    to_x = np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0]])  # rows (y', a, x'): x' -> z
    test = to_x @ frames
    K = mandel_rotation(test)
    Mp = (K @ Mn @ np.swapaxes(K, -1, -2)).reshape(len(phis), -1)
    r = np.linalg.norm(Mp - Mp @ M2.T, axis=1)
    i = int(np.argmin(r))

    def fun(p: np.ndarray) -> np.ndarray:
        Fx = rotation_about((0, 0, 1), phis[i] + p[0]).T @ F
        return _natural_residual(Mn, to_x @ Fx, "monoclinic")

    sol = least_squares(fun, [0.0], method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    x = float(sol.x[0])
    # the residual is linear in a small angle error: a few Gauss-Newton steps with a
    # central-difference slope remove what LM leaves when it starts next to the minimum
    for _ in range(3):
        h = 1e-5
        r0 = fun(np.array([x]))
        J = (fun(np.array([x + h])) - fun(np.array([x - h]))) / (2 * h)
        jj = float(J @ J)
        if jj <= 0:
            break
        dx = -float(J @ r0) / jj
        if abs(dx) > 1e-3:
            break
        x += dx
    phi = phis[i] + x
    step = np.pi / n_fold
    opts = [rotation_about((0, 0, 1), phi + k * step).T @ F for k in range(2 * n_fold)]
    return max(opts, key=lambda G: G[0, 0])


@dataclass(frozen=True)
class SymmetryClass:
    """Result of :func:`symmetry_class`.

    Attributes
    ----------
    name : str
        One of :data:`SYMMETRY_CLASSES_3D` (or :data:`SYMMETRY_CLASSES_2D` in 2D).
    seed_name : str or None
        The seed's Table 1 name (``None`` for cubic, trigonal, triclinic and 2D classes).
    axis : array, shape (3,), or None
        Unit symmetry axis (transversely isotropic, tetragonal, trigonal) or the normal of
        the mirror plane (monoclinic); ``None`` otherwise.  Sign: largest-index non-zero
        component positive.
    axes : array, shape (3, 3) / (2, 2), or None
        Proper rotation whose rows are the natural basis vectors, so that
        ``rotate_stiffness(C, axes)`` is in the standard form: symmetry axis / mirror
        normal along z; tetragonal and trigonal x along a 2-fold axis (so ``C16 = 0`` and,
        for trigonal, only ``C14 = -C24 = C56`` couple); orthotropic and cubic axes along
        the symmetry axes, chosen closest to the coordinate axes.  Identity for isotropic,
        ``None`` for triclinic / 2D anisotropic.
    residual : float
        ``||C - P(C)|| / ||C||`` for the reported class in the natural frame, where ``P``
        is the orthogonal projection onto tensors of that symmetry (Frobenius norm of the
        tensor = of its Mandel matrix).  ``<= tol`` by construction (0 for triclinic).
    residuals : mapping str -> float
        The minimised residual of every class that was tested; for a class ruled out by
        the contracted-tensor invariants without a search, that lower bound (``> tol``).
        A class not needed for the answer (the other class of a level settled by a seed
        frame) is absent.
    tol : float
    aligned : bool or None
        Whether the natural axes (the axis alone for transversely isotropic and
        monoclinic) coincide with the coordinate axes to 1e-6.
    n_independent : int
        Number of independent constants of the class.
    kelvin_moduli : array
        Eigenvalues of the Mandel matrix (a frame-free cross-check of the class).
    """

    name: str
    seed_name: str | None
    axis: np.ndarray | None
    axes: np.ndarray | None
    residual: float
    residuals: Mapping[str, float]
    tol: float
    aligned: bool | None
    n_independent: int
    kelvin_moduli: np.ndarray

    def __str__(self) -> str:
        ax = "" if self.axis is None else f", axis {np.array2string(self.axis, precision=4)}"
        return f"{self.name} (residual {self.residual:.2e}{ax})"


def _is_signed_perm(F: np.ndarray, atol: float = 1e-6) -> bool:
    A = np.abs(F)
    return bool(np.all(np.abs(A - np.round(A)) < atol) and np.allclose(np.round(A).sum(0), 1))


def symmetry_class(C: np.ndarray, tol: float = 1e-6) -> SymmetryClass:
    """Frame-independent elastic symmetry class of a stiffness.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Symmetric stiffness in any frame (positive definiteness not required).
    tol : float
        Relative tolerance.  ``C`` belongs to a class if some orientation of the class's
        symmetry group ``G`` gives ``||C - P_G(C)||_F <= tol ||C||_F``, with ``P_G`` the
        group average (the orthogonal projection onto ``G``-invariant tensors) and the
        Frobenius norm of the 4th-order tensor (= of its Mandel matrix).  The minimised
        distance is therefore the relative distance from ``C`` to the nearest tensor of the
        class.

    Returns
    -------
    SymmetryClass

    Notes
    -----
    3D method (numerical, in the spirit of Cowin & Mehrabadi 1987):

    1. Isotropy: distance to the isotropic projection (no orientation needed).
    2. For the axis groups -- 8-fold (transversely isotropic; Hermann's theorem), 4-fold
       (tetragonal), 3-fold (trigonal) and 2-fold (monoclinic) rotations -- the residual
       is evaluated for the axes of a 1200-point hemisphere grid and for the eigenvectors
       of the Cowin-Mehrabadi tensors ``d_ij = C_ijkk``, ``v_ij = C_ikjk``; the best local
       minima are polished by least squares.  Grid sampling makes the search robust when
       ``d`` and ``v`` have repeated eigenvalues (cubic, transversely isotropic).
    3. Orthotropic frames are built from pairs of near-orthogonal 2-fold axes, cubic
       frames from pairs of 4-fold axes, and polished over SO(3).
    4. The classes are tried from the highest symmetry down, by levels
       isotropic | cubic, transversely isotropic | tetragonal, trigonal | orthotropic |
       monoclinic | triclinic; the first level with a residual ``<= tol`` wins, ties inside
       a level going to the smaller residual.

    Two shortcuts avoid searches whose outcome is already known: a class whose lower
    bound from the eigenvalues of ``d`` and ``v`` exceeds ``tol`` (cubic: ``d``, ``v``
    isotropic; 3-, 4-, 8-fold axis: ``d``, ``v`` with a double eigenvalue) is not searched,
    and a level is settled without a search when a seed frame (eigenvectors of ``d`` or
    ``v``) already fits one of its classes to ``1e-3 tol`` -- the usual case for a tensor
    computed from a fabric, which costs well under a millisecond.

    Since an n-fold axis (n = 2, 3, 4) already forces the mirror planes of the class for an
    elasticity tensor (Forte & Vianello 1996), rotations suffice.  The Kelvin moduli are
    returned as an independent check (e.g. isotropic: a five-fold eigenvalue).

    2D: isotropic (projection), square (4-fold rotation, orientation-free), orthotropic
    (mirror line found on a 1-degree grid and polished), anisotropic.
    """
    M, _ = as_voigt(C)
    check_finite_symmetric(M, 1e-10)
    M = 0.5 * (M + M.T)
    Mm = voigt_to_mandel(M)
    peak = float(np.abs(Mm).max())
    if peak == 0.0:
        raise GrainmechError("C is zero: no symmetry class")
    Mn = Mm / peak  # scale first: the Frobenius norm of a tiny/huge matrix under/overflows
    Mn = Mn / np.linalg.norm(Mn)
    kel = peak * np.linalg.eigvalsh(Mm / peak)
    if M.shape[0] == 3:
        return _symmetry_class_2d(Mn, tol, kel)
    search = _Search3D(Mn)
    residuals: dict[str, float] = {}
    name, res, F = "triclinic", 0.0, None
    for level in _LEVELS_3D:
        results = _level_results(search, level, tol)
        for c, (r, _) in results.items():
            residuals[c] = r
        ok = [c for c in results if results[c][0] <= tol]
        if ok:
            name = min(ok, key=lambda c: results[c][0])
            res, F = results[name]
            break
    axis = None
    if F is not None:
        if name in _AXIS_CLASSES:
            axis = _canon_axis(F[2])
            F = frame_from_axis(axis)
            if name == "tetragonal":
                F = _in_plane_twofold(Mn, F, 4)
            elif name == "trigonal":
                F = _in_plane_twofold(Mn, F, 3)
            aligned = _is_signed_perm(F) if name in ("tetragonal", "trigonal") else \
                bool(np.max(np.abs(axis)) > 1 - 1e-6)
        elif name in ("orthotropic", "cubic"):
            group = np.array([np.diag(s) @ np.eye(3)[list(p)]
                              for p in itertools.permutations(range(3))
                              for s in itertools.product((1, -1), repeat=3)])
            group = group[np.linalg.det(group) > 0]
            F = _nearest_signed_permutation(F, group)
            aligned = _is_signed_perm(F)
        else:  # isotropic
            aligned = True
        if aligned and name != "isotropic":
            # snap to the exact coordinate frame when that is as good
            Fs = np.round(F) if name not in ("transversely isotropic", "monoclinic") \
                else frame_from_axis(np.round(np.asarray(axis)))
            rs = float(np.linalg.norm(_natural_residual(Mn, Fs, name)))
            if name in ("tetragonal", "trigonal"):
                # the class residual ignores the in-plane angle: the snapped frame must also
                # keep x' on a 2-fold axis (no spurious C15/C16 in the standard form)
                to_x = np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0]])
                r2 = [float(np.linalg.norm(_natural_residual(Mn, to_x @ G, "monoclinic"))) for G in (F, Fs)]
                rs = max(rs, r2[1] - 2.0 * r2[0])
            if rs <= max(2.0 * res, 1e-13):
                F, res = Fs, rs
                if axis is not None:
                    axis = Fs[2].copy()
    else:
        aligned = None
    seed = SEED_NAMES.get(name)
    if name == "orthotropic" and not aligned:
        seed = SEED_NAMES["monoclinic"]
    return SymmetryClass(name=name, seed_name=seed, axis=axis, axes=F, residual=float(res),
                         residuals=MappingProxyType(residuals), tol=tol, aligned=aligned,
                         n_independent=N_INDEPENDENT[name], kelvin_moduli=kel)


def _rot2(phi: np.ndarray | float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], -2)  # rows = new basis


def _symmetry_class_2d(Mn: np.ndarray, tol: float, kel: np.ndarray) -> SymmetryClass:
    residuals: dict[str, float] = {}
    r_iso = float(np.linalg.norm(Mn - isotropic_projection(Mn, 2)))
    residuals["isotropic"] = r_iso
    if r_iso <= tol:
        return SymmetryClass("isotropic", None, None, np.eye(2), r_iso,
                             MappingProxyType(residuals), tol, True, 2, kel)
    # mirror-line search (needed for the axes of square and orthotropic)
    phis = np.linspace(0.0, np.pi / 2, 91)[:-1]  # mirrors come in orthogonal pairs
    r = np.linalg.norm(_natural_residual(Mn, _rot2(phis), "orthotropic"), axis=-1)
    cands = np.argsort(r)[:3]

    def fun(p: np.ndarray) -> np.ndarray:
        return _natural_residual(Mn, _rot2(p[0]), "orthotropic")

    best = None
    for i in cands:
        sol = least_squares(fun, [phis[i]], method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
        rr = float(np.linalg.norm(fun(sol.x)))
        if best is None or rr < best[0]:
            best = (rr, float(sol.x[0]))
    r_orth, phi = best  # type: ignore[misc]
    r_sq = float(np.linalg.norm(_natural_residual(Mn, np.eye(2), "square")))
    residuals["square"] = r_sq
    if r_sq <= tol:
        name, res, nfold = "square", r_sq, 4
    else:
        residuals["orthotropic"] = r_orth
        if r_orth <= tol:
            name, res, nfold = "orthotropic", r_orth, 2
        else:
            return SymmetryClass("anisotropic", None, None, None, 0.0,
                                 MappingProxyType(residuals), tol, None, 6, kel)
    opts = [_rot2(phi + k * np.pi / nfold) for k in range(2 * nfold)]
    F = max(opts, key=lambda G: np.trace(G))
    aligned = _is_signed_perm(F)
    if aligned:
        rs = float(np.linalg.norm(_natural_residual(Mn, np.round(F), name)))
        if rs <= max(2.0 * res, 1e-13):
            F, res = np.round(F), rs
    return SymmetryClass(name, None, None, F, res, MappingProxyType(residuals), tol, aligned,
                         N_INDEPENDENT[name], kel)


def symmetric_projection(C: np.ndarray, cls: str, axes: np.ndarray | None = None) -> np.ndarray:
    """Nearest tensor of a given symmetry in a given orientation (group average).

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3) or tensor
    cls : str
        A class name from :data:`SYMMETRY_CLASSES_3D` / :data:`SYMMETRY_CLASSES_2D`.
    axes : array, shape (3, 3) / (2, 2), or shape (3,), optional
        Natural frame (rows = natural basis vectors, as :attr:`SymmetryClass.axes`); for
        the axis classes a 3-vector (the axis) is enough.  Default: the coordinate frame.

    Returns
    -------
    array, same form as ``C``
        The orthogonal projection (Frobenius norm) of ``C`` onto the tensors invariant
        under the class's group in that orientation.  For tetragonal and trigonal the
        group is the n-fold rotation about the axis, so the result may keep a ``C16``
        (tetragonal) or ``C15`` (trigonal) term in the given frame; it is still of that
        class (in a frame rotated about the axis the term vanishes).
    """
    M, t4 = as_voigt(C)
    dim = dimension(M)
    valid = SYMMETRY_CLASSES_3D if dim == 3 else SYMMETRY_CLASSES_2D
    if cls not in valid:
        raise GrainmechError(f"cls must be one of {valid} for a {dim}D stiffness; got {cls!r}")
    if cls in ("triclinic", "anisotropic"):
        return as_given(M.copy(), t4)
    if axes is None:
        F = np.eye(dim)
    else:
        A = np.asarray(axes, dtype=float)
        if dim == 3 and A.shape == (3,):
            if cls not in _AXIS_CLASSES:
                raise GrainmechError(f"axes for class {cls!r} must be a 3x3 frame; got a vector")
            F = frame_from_axis(unit_vectors(A, 3, "axes"))
        else:
            F = check_orthogonal(A, dim)
    Mm = voigt_to_mandel(M)
    if cls == "isotropic":
        P = isotropic_projection(Mm, dim)
    else:
        K = mandel_rotation(F)
        Mnat = K @ Mm @ K.T
        Pnat = (_projector(cls, dim) @ Mnat.ravel()).reshape(Mnat.shape)
        P = K.T @ Pnat @ K
    return as_given(mandel_to_voigt(0.5 * (P + P.T)), t4)

"""Folding a symmetric contact set by the symmetries of the path (affine model, compiled driver).

Let ``g = diag(g_x, g_y, g_z)``, ``g_k = ±1``, be a sign map: the antipodal map
``-I`` or a mirror through a coordinate plane (or a product of them). Under the affine
kinematic hypothesis (seed Eq. 2.13) a row with normal ``g n`` and branch ``g l`` gets the
relative displacement ``dε (g l)``. When the strain increment is invariant,
``g dε g = dε``, this is ``g (dε l)``: the same normal approach ``(g n)·(g Δ) = n·Δ``
and the tangential displacement mapped by ``g``. The contact laws are isotropic in the
tangent plane and have no handedness, so a contact started from the mapped state (the
same normal force, approach, reversal invariants ``P_j`` and branch direction ``s``, the
tangential force ``T`` and slip axis ``e`` mapped by ``g``) stays the image of its
partner at every step. In floating point each of these maps only changes signs, exactly,
so the rows of an orbit stay bit-for-bit images of each other
(``tests/driver/test_affine_mixed.py`` checks it on unfolded runs).

* The antipodal map leaves every strain invariant (``(-I) dε (-I) = dε``).
* The mirror ``x_k -> -x_k`` leaves ``dε`` invariant iff the two shear components with
  one index ``k`` vanish (``y``: ``ε_xy``, ``ε_yz``). Cyclic simple shear in ``xz``, for
  instance, has the mirror ``y -> -y``; a triaxial path has all three.

The images contribute ``(g f) ⊗ (g l)`` to the Love–Weber stress (seed Eq. 2.6) and
``D_g B^T K B D_g`` to the stiffness (seed Eq. 2.26), ``D_g`` the signs of the six
components (``g_i g_j`` for component ``ij``). Summed over an orbit ``O`` of a row
``r`` this is ``|O|`` times the projection of ``r``'s own contribution on the components
the group leaves invariant (the others sum to zero). So a quadrature with these
symmetries (Lebedev rules are invariant under all 48 symmetries of the cube) needs one
row per orbit, with ``|O|`` times its weight, and the non-invariant components of the
sums set to zero (:attr:`Folding.sym`). The compiled driver folds a segment by the
largest group the path, the rows (normal, branch vector and weight, exactly) and the
starting state (to :data:`STATE_RTOL`) allow, and unfolds the state at its end; results
equal the unfolded run's to rounding (the sums run over the rows in another order, and
a starting state symmetric to rounding is replaced by its representatives' values).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np

__all__ = ["antipodal_pairs", "is_mirrored", "fold", "unfold", "path_mirrors", "Folding", "ANTIPODE"]

#: state and response fields that are vectors (mapped by ``g``) and 3x3 matrices (``g . g``)
VECTOR_FIELDS = ("tangential_force", "axis", "t_alpha")
MATRIX_FIELDS = ("t_delta",)
#: the antipodal map
ANTIPODE = (-1, -1, -1)
#: relative tolerance (of a field's largest magnitude) of the starting state's symmetry
STATE_RTOL = 1e-12
#: index pairs of the six components, library order xx, yy, zz, yz, xz, xy
_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def component_signs(g: Any) -> np.ndarray:
    """Signs ``g_i g_j`` of the six components (library order) under the sign map ``g``."""
    return np.array([g[i] * g[j] for i, j in _PAIRS], dtype=float)


def path_mirrors(stress_control: np.ndarray, increments: np.ndarray, stress_target: np.ndarray | None = None
                 ) -> tuple[tuple[int, int, int], ...]:
    """Mirrors through coordinate planes that leave every step of a path invariant.

    The mirror ``x_k -> -x_k`` changes the sign of the two shear components with one
    index ``k``. It leaves the path invariant when each of them has zero increments
    throughout and is either strain controlled (its strain then does not change: the
    affine kinematics depend on the increments only) or stress controlled with a target
    of zero (``stress_target``, the running target at the path's start, zero to
    :data:`STATE_RTOL` of its largest component: a stress summed from a state symmetric
    to rounding; the symmetric state meets it with a zero strain increment, and the
    folded driver sets it to zero).

    Parameters
    ----------
    stress_control : (6,) bool
    increments : (m, 6) increments of the controlled components
    stress_target : (6,) running stress targets at the start (needed when a shear
        component is stress controlled; without it such a mirror is not taken)
    """
    sc = np.asarray(stress_control, dtype=bool)
    inc = np.asarray(increments, dtype=float).reshape(-1, 6)
    out: list[tuple[int, int, int]] = []
    for k in range(3):
        g = [1, 1, 1]
        g[k] = -1
        odd = component_signs(g) < 0
        if inc[:, odd].any():
            continue
        held = odd & sc
        if held.any():
            if stress_target is None:
                continue
            t = np.abs(np.asarray(stress_target, dtype=float))
            if not np.all(t[held] <= STATE_RTOL * t.max()):
                continue
        out.append((g[0], g[1], g[2]))
    return tuple(out)


def _closure(gens: tuple) -> np.ndarray:
    """The group of sign maps generated by ``gens`` (identity first), shape (|G|, 3)."""
    group = {(1, 1, 1)}
    frontier = [(1, 1, 1)]
    while frontier:
        a = frontier.pop()
        for b in gens:
            c = (a[0] * b[0], a[1] * b[1], a[2] * b[2])
            if c not in group:
                group.add(c)
                frontier.append(c)
    return np.array(sorted(group, reverse=True), dtype=np.int64)  # (1, 1, 1) first


def images(normals: np.ndarray, branch: np.ndarray, weights: np.ndarray, g: Any) -> np.ndarray | None:
    """The row that the sign map ``g`` takes every row to, or None.

    ``normals[img[i]] = g normals[i]`` and the same for the branch vector, exactly, with
    equal weights; None if some row has no such image.
    """
    s = np.tile(np.asarray(g, float), 2)
    X = np.hstack([normals, branch]) + 0.0   # + 0.0: -0.0 compares as 0.0 in the sort keys
    Y = X * s + 0.0
    o = np.lexsort(X.T[::-1])
    og = np.lexsort(Y.T[::-1])
    if not np.array_equal(X[o], Y[og]):
        return None
    img = np.empty(X.shape[0], dtype=np.int64)
    img[og] = o       # g maps row og[k] onto row o[k]
    if not np.array_equal(weights[img], weights):
        return None
    return img


def _signed(a: np.ndarray, g: np.ndarray, name: str) -> np.ndarray:
    """The field ``name`` of a row mapped by ``g``."""
    if name in VECTOR_FIELDS:
        return a * g.astype(a.dtype)
    if name in MATRIX_FIELDS:
        return a * np.outer(g, g).astype(a.dtype)
    return a


def _equivariant(fields: Any, imgs: list, group: np.ndarray, skip: tuple = ()) -> bool:
    """Every field of every row equals its partner's mapped by ``g``, for every ``g`` of the group.

    Integer and boolean fields exactly, floating-point ones to :data:`STATE_RTOL` of the
    field's largest magnitude: a state built by sums whose order depends on the row
    (matrix products) is symmetric only to rounding. (The folded run starts from the
    representatives' values; from there on the images stay exact.)
    """
    for name, a in zip(fields._fields, fields):
        if a is None or name in skip:
            continue
        floating = a.dtype.kind == "f"
        tol = STATE_RTOL * float(np.abs(a).max()) if (floating and a.size) else 0.0
        for g, img in zip(group[1:], imgs[1:]):
            b = _signed(a, g, name)
            if floating:
                if not np.all(np.abs(a[img] - b) <= tol):
                    return False
            elif not np.array_equal(a[img], b):
                return False
    return True


@dataclass(frozen=True)
class Folding:
    """One row per orbit of a group of sign maps.

    ``group`` (|G|, 3): the sign maps, identity first; ``rows`` (r,): the representative
    of each orbit (the lowest row index); ``image`` (|G|, r): the row of ``g`` applied to
    each representative; ``size`` (r,): the orbit sizes; ``n`` the rows of the whole set.
    """

    group: np.ndarray
    rows: np.ndarray
    image: np.ndarray
    size: np.ndarray
    n: int

    @property
    def sym(self) -> np.ndarray:
        """(42,) factors of the folded sums' components.

        1 for the stress components (6) and the tangent entries (36, row-major) the group
        leaves invariant, 0 for the others (their sum over an orbit vanishes).
        """
        s = np.array([component_signs(g) for g in self.group])       # (|G|, 6)
        s6 = np.all(s > 0, axis=0)
        s36 = np.all(s[:, :, None] * s[:, None, :] > 0, axis=0)
        return np.concatenate([s6, s36.ravel()]).astype(float)

    def unfold(self, half: np.ndarray, name: str = "") -> np.ndarray:
        """The whole set's array from the representatives' rows (field ``name`` mapped by each ``g``)."""
        full = np.empty((self.n,) + half.shape[1:], dtype=half.dtype)
        for g, img in zip(self.group[::-1], self.image[::-1]):  # identity last: a row its own image keeps its bits
            full[img] = _signed(half, g, name)
        return full


def _group_folding(normals: np.ndarray, branch: np.ndarray, weights: np.ndarray, state: Any, response: Any,
                   gens: tuple, cache: dict) -> Folding | None:
    group = _closure(gens)
    imgs = []
    for g in group:
        key = tuple(int(v) for v in g)
        if key not in cache:
            cache[key] = images(normals, branch, weights, g)
        if cache[key] is None:
            return None
        imgs.append(cache[key])
    if not (_equivariant(state, imgs, group) and _equivariant(response, imgs, group, skip=("t_delta", "t_alpha"))):
        return None
    allimg = np.array(imgs)                  # (|G|, n)
    rows = np.unique(allimg.min(axis=0))     # lowest row of each orbit
    image = allimg[:, rows]
    srt = np.sort(image, axis=0)
    size = 1 + np.count_nonzero(np.diff(srt, axis=0), axis=0)
    return Folding(group, rows, image, size, normals.shape[0])


def fold(contacts: Any, state: Any, response: Any, enabled: bool = True, mirrors: tuple = ()) -> tuple:
    """The rows a compiled loop evaluates: one per orbit, or all of them.

    The group is generated by the antipodal map and ``mirrors`` (:func:`path_mirrors` of
    the path to run); the largest subgroup under which the rows are invariant exactly
    and the state to :data:`STATE_RTOL` is taken.

    Returns ``(folding, normals, branch, weights, state, response)``: ``folding`` a
    :class:`Folding` when ``enabled`` and some group of more than one map applies (then the
    arrays are those of the representatives, the weights times the orbit sizes), else
    None and the arrays as they are.
    """
    normals, branch, weights = contacts.normals, contacts.branch, contacts.weights
    none = (None, normals, branch, weights, state, response)
    if not enabled or normals.shape[0] < 2:
        return none
    gens = (ANTIPODE,) + tuple(tuple(int(v) for v in m) for m in mirrors)
    cache: dict = {}
    # the largest group first (subsets of the generators by the size of what they generate)
    subsets = sorted((s for k in range(len(gens), 0, -1) for s in combinations(gens, k)),
                     key=lambda s: -len(_closure(s)))
    for sub in subsets:
        f = _group_folding(normals, branch, weights, state, response, sub, cache)
        if f is not None:
            r = f.rows
            return (f, normals[r], branch[r], weights[r] * f.size, type(state)(*(x[r] for x in state)),
                    type(response)(*(None if x is None else x[r] for x in response)))
    return none


def antipodal_pairs(normals: np.ndarray, branch: np.ndarray, weights: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Rows ``keep`` and their antipodes ``partner`` if every row has exactly one, else None.

    Row ``partner[k]`` has normal ``-normals[keep[k]]`` and branch vector
    ``-branch[keep[k]]`` exactly, and the same weight; ``keep`` is sorted.
    """
    n = normals.shape[0]
    if n < 2 or n % 2:
        return None
    img = images(normals, branch, weights, ANTIPODE)
    if img is None or np.any(img == np.arange(n)):
        return None
    keep = np.flatnonzero(np.arange(n) < img)
    return keep, img[keep]


def is_mirrored(state: Any, response: Any, keep: np.ndarray, partner: np.ndarray) -> bool:
    """Whether ``state`` and ``response`` of every ``partner`` row mirror its ``keep`` row exactly.

    The response's step tangents (``t_delta``, ``t_alpha``) are not compared: a segment
    does not start from them.
    """
    g = np.array(ANTIPODE)

    def ok(fields: Any) -> bool:
        return all(np.array_equal(a[partner], _signed(a[keep], g, name)) for name, a in zip(fields._fields, fields)
                   if a is not None and name not in ("t_delta", "t_alpha"))

    return ok(state) and ok(response)


def unfold(folding: Folding, half: np.ndarray, name: str = "") -> np.ndarray:
    """:meth:`Folding.unfold` (a module function: the drivers call it, tests watch it)."""
    return folding.unfold(half, name)

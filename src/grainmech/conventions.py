"""Conventions used throughout grainmech, fixed in one place.

See ``docs/conventions.md`` for the prose version. In short:

* **Sign**: compression positive (as in the seed report and in soil mechanics).
  Normal contact force and normal contact displacement (approach) are positive in
  compression. Files from DEM codes (tension positive) are converted in ``grainmech.io``.
* **Axes**: the library works in a right-handed Cartesian frame ``(x, y, z)``; tensor
  index 0, 1, 2 means x, y, z.
* **6-vectors**: component order ``(xx, yy, zz, yz, xz, xy)``.  *Voigt* stiffness
  matrices act on engineering shear strains ``(2 e_yz, 2 e_xz, 2 e_xy)``; *Mandel*
  matrices use a factor sqrt(2) on the shear components of both stress and strain.
  In 2D the order is ``(xx, yy, xy)``.
* **Seed labelling**: the seed (Chang 1988) writes a unit normal as
  ``n = (cos g, sin g cos b, sin g sin b)`` with components ``(n_z, n_y, n_x)``
  (polar axis z, azimuth b measured from y towards x), and orders 6-vectors as
  ``(zz, yy, xx, zy, zx, xy)``. In 2D it writes ``n = (n_y, n_x) = (cos t, sin t)``
  (t measured from the y axis) and orders 3-vectors as ``(yy, xx, yx)``. These are
  offered as explicit mappings (:func:`reorder`, :func:`seed_normal`,
  :func:`seed_normal_2d`) so the seed's tables can be compared entry by entry.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "ORDER_3D",
    "ORDER_2D",
    "SEED_ORDER_3D",
    "SEED_ORDER_2D",
    "AXES",
    "index_pairs",
    "order_for",
    "tensor4_to_matrix",
    "matrix_to_tensor4",
    "voigt_to_mandel",
    "mandel_to_voigt",
    "stress_to_vector",
    "strain_to_vector",
    "vector_to_stress",
    "vector_to_strain",
    "von_mises",
    "reorder",
    "seed_normal",
    "seed_angles",
    "seed_normal_2d",
    "seed_theta",
]

#: Library 6-vector component order (3D).
ORDER_3D: tuple[str, ...] = ("xx", "yy", "zz", "yz", "xz", "xy")
#: Library 3-vector component order (2D).
ORDER_2D: tuple[str, ...] = ("xx", "yy", "xy")
#: The seed's Voigt order (Eq. 4.20): (zz, yy, xx, zy, zx, xy).
SEED_ORDER_3D: tuple[str, ...] = ("zz", "yy", "xx", "yz", "xz", "xy")
#: The seed's 2D order (Eq. 4.36): (yy, xx, yx).
SEED_ORDER_2D: tuple[str, ...] = ("yy", "xx", "xy")

AXES = "xyz"


def _canon(label: str) -> str:
    """Canonical (sorted) form of a component label: 'zy' -> 'yz'."""
    if len(label) != 2 or any(c not in AXES for c in label):
        raise ValueError(f"component label {label!r} must be two of the letters x, y, z")
    return "".join(sorted(label))


def index_pairs(order: Sequence[str]) -> list[tuple[int, int]]:
    """Tensor index pairs (i, j) for each label of a component order.

    Parameters
    ----------
    order : sequence of str
        Component labels such as ``("xx", "yy", "zz", "yz", "xz", "xy")``.

    Returns
    -------
    list of (int, int)
        ``[(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]`` for the example.
    """
    return [(AXES.index(lab[0]), AXES.index(lab[1])) for lab in map(_canon, order)]


def order_for(dim: int, name: str = "voigt") -> tuple[str, ...]:
    """Component order for dimension ``dim`` and output style ``name``.

    ``name`` is one of ``"voigt"``, ``"mandel"`` (both use the library order) or
    ``"seed"`` (the seed's order, Eq. 4.20 / 4.36).
    """
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    if name in ("voigt", "mandel"):
        return ORDER_3D if dim == 3 else ORDER_2D
    if name == "seed":
        return SEED_ORDER_3D if dim == 3 else SEED_ORDER_2D
    raise ValueError(f"order must be 'voigt', 'mandel' or 'seed', got {name!r}")


def _shear_mask(order: Sequence[str]) -> np.ndarray:
    return np.array([lab[0] != lab[1] for lab in order])


def tensor4_to_matrix(C: np.ndarray, order: Sequence[str] | None = None,
                      mandel: bool = False) -> np.ndarray:
    """4th-order stiffness tensor -> Voigt (or Mandel) matrix.

    Parameters
    ----------
    C : array, shape (d, d, d, d)
        Stiffness tensor with minor symmetries (d = 2 or 3).
    order : sequence of str, optional
        Component order; library order for ``d`` by default.
    mandel : bool
        If True, scale shear rows and columns by sqrt(2) (Mandel notation).

    Returns
    -------
    array, shape (m, m)
        m = 6 in 3D, 3 in 2D. In Voigt form ``sigma_vec = M @ [e_xx, ..., 2 e_xy]``.
    """
    C = np.asarray(C, dtype=float)
    d = C.shape[0]
    if C.shape != (d, d, d, d) or d not in (2, 3):
        raise ValueError(f"C must have shape (d, d, d, d) with d = 2 or 3, got {C.shape}")
    order = tuple(order) if order is not None else order_for(d)
    pairs = index_pairs(order)
    M = np.array([[C[i, j, k, l] for (k, l) in pairs] for (i, j) in pairs])
    if mandel:
        s = np.where(_shear_mask(order), np.sqrt(2.0), 1.0)
        M = M * s[:, None] * s[None, :]
    return M


def matrix_to_tensor4(M: np.ndarray, order: Sequence[str] | None = None,
                      mandel: bool = False) -> np.ndarray:
    """Voigt (or Mandel) stiffness matrix -> 4th-order tensor with minor symmetries."""
    M = np.asarray(M, dtype=float)
    m = M.shape[0]
    if M.shape != (m, m) or m not in (3, 6):
        raise ValueError(f"M must be 6x6 (3D) or 3x3 (2D), got shape {M.shape}")
    d = 3 if m == 6 else 2
    order = tuple(order) if order is not None else order_for(d)
    pairs = index_pairs(order)
    if mandel:
        s = np.where(_shear_mask(order), np.sqrt(2.0), 1.0)
        M = M / s[:, None] / s[None, :]
    C = np.zeros((d, d, d, d))
    for a, (i, j) in enumerate(pairs):
        for b, (k, l) in enumerate(pairs):
            for (p, q) in {(i, j), (j, i)}:
                for (r, s_) in {(k, l), (l, k)}:
                    C[p, q, r, s_] = M[a, b]
    return C


def voigt_to_mandel(M: np.ndarray) -> np.ndarray:
    """Convert a Voigt stiffness matrix (library order) to Mandel form."""
    M = np.asarray(M, dtype=float)
    return tensor4_to_matrix(matrix_to_tensor4(M), mandel=True)


def mandel_to_voigt(M: np.ndarray) -> np.ndarray:
    """Convert a Mandel stiffness matrix (library order) to Voigt form."""
    M = np.asarray(M, dtype=float)
    return tensor4_to_matrix(matrix_to_tensor4(M, mandel=True))


def _sym_to_vector(T: np.ndarray, factor: float) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    d = T.shape[-1]
    if T.shape[-2:] != (d, d) or d not in (2, 3):
        raise ValueError(f"tensor must have trailing shape (d, d), d = 2 or 3; got {T.shape}")
    pairs = index_pairs(order_for(d))
    return np.stack([T[..., i, j] * (factor if i != j else 1.0) for i, j in pairs], axis=-1)


def _vector_to_sym(v: np.ndarray, factor: float) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    m = v.shape[-1]
    if m not in (3, 6):
        raise ValueError(f"vector must have 6 (3D) or 3 (2D) components, got {m}")
    d = 3 if m == 6 else 2
    T = np.zeros(v.shape[:-1] + (d, d))
    for a, (i, j) in enumerate(index_pairs(order_for(d))):
        val = v[..., a] / (factor if i != j else 1.0)
        T[..., i, j] = val
        T[..., j, i] = val
    return T


def stress_to_vector(sigma: np.ndarray, mandel: bool = False) -> np.ndarray:
    """Symmetric stress tensor(s) (..., d, d) -> vector(s) in library order."""
    return _sym_to_vector(sigma, np.sqrt(2.0) if mandel else 1.0)


def strain_to_vector(eps: np.ndarray, mandel: bool = False) -> np.ndarray:
    """Symmetric strain tensor(s) -> vector(s); Voigt uses engineering shear (factor 2)."""
    return _sym_to_vector(eps, np.sqrt(2.0) if mandel else 2.0)


def vector_to_stress(v: np.ndarray, mandel: bool = False) -> np.ndarray:
    """Inverse of :func:`stress_to_vector`."""
    return _vector_to_sym(v, np.sqrt(2.0) if mandel else 1.0)


def vector_to_strain(v: np.ndarray, mandel: bool = False) -> np.ndarray:
    """Inverse of :func:`strain_to_vector`."""
    return _vector_to_sym(v, np.sqrt(2.0) if mandel else 2.0)


def von_mises(stress: np.ndarray) -> np.ndarray:
    """Deviator stress ``q = sqrt(3 J2) = sqrt(3/2 s:s)`` (von Mises) of stress vector(s) [Pa].

    ``s`` is the deviatoric part of the stress tensor and ``J2 = s:s / 2``; in the library's
    order (``xx yy zz yz xz xy``, tensor shear components)
    ``J2 = (s_xx^2 + s_yy^2 + s_zz^2) / 2 + sigma_yz^2 + sigma_xz^2 + sigma_xy^2``. On a
    triaxial path (``sigma_2 = sigma_3``) ``q = |sigma_1 - sigma_3|``, the soil-mechanics
    deviator stress (Wood 1990, *Soil behaviour and critical state soil mechanics*,
    Sec. 1.3). The same for either sign convention.

    Parameters
    ----------
    stress : array, shape (..., 6)
        Stress vectors in library order [Pa].

    Returns
    -------
    ndarray, shape (...)
    """
    s = np.asarray(stress, dtype=float)
    if s.shape[-1:] != (6,):
        raise ValueError(f"stress must have 6 components (xx yy zz yz xz xy) in its last axis, got shape {s.shape}")
    p = s[..., :3].mean(axis=-1)
    dev = s[..., :3] - p[..., None]
    j2 = 0.5 * np.sum(dev ** 2, axis=-1) + np.sum(s[..., 3:] ** 2, axis=-1)
    return np.sqrt(3.0 * j2)


def reorder(M: np.ndarray, to: Sequence[str], frm: Sequence[str] | None = None) -> np.ndarray:
    """Permute the rows/columns of a stiffness matrix (or a vector) between component orders.

    Parameters
    ----------
    M : array, shape (m,) or (m, m)
        Matrix or vector in order ``frm`` (library order by default).
    to : sequence of str
        Target order, e.g. :data:`SEED_ORDER_3D`.

    Notes
    -----
    Only a permutation: the shear factor (Voigt or Mandel) is unchanged.
    """
    M = np.asarray(M, dtype=float)
    m = M.shape[0]
    frm = tuple(frm) if frm is not None else order_for(3 if m == 6 else 2)
    src = [_canon(x) for x in frm]
    try:
        perm = [src.index(_canon(x)) for x in to]
    except ValueError as exc:
        raise ValueError(f"orders {tuple(frm)} and {tuple(to)} do not hold the same components") from exc
    if len(perm) != m or len(set(perm)) != m:
        raise ValueError(f"orders {tuple(frm)} and {tuple(to)} do not hold the same components")
    if M.ndim == 1:
        return M[perm]
    return M[np.ix_(perm, perm)]


def seed_normal(gamma: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Unit normal in library (x, y, z) components from the seed's angles (Eq. 2.19).

    The seed writes ``n = (cos g, sin g cos b, sin g sin b)`` for ``(n_z, n_y, n_x)``, so
    ``n_x = sin g sin b``, ``n_y = sin g cos b``, ``n_z = cos g``.

    Parameters
    ----------
    gamma, beta : array_like
        Polar angle from z (0..pi) and azimuth from y towards x (0..2 pi), radians.

    Returns
    -------
    array, shape (..., 3)
    """
    g = np.asarray(gamma, dtype=float)
    b = np.asarray(beta, dtype=float)
    return np.stack(np.broadcast_arrays(np.sin(g) * np.sin(b), np.sin(g) * np.cos(b), np.cos(g)), axis=-1)


def seed_angles(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`seed_normal`: (gamma, beta) of unit normals (..., 3)."""
    n = np.asarray(n, dtype=float)
    gamma = np.arctan2(np.hypot(n[..., 0], n[..., 1]), n[..., 2])
    beta = _angle_mod(np.arctan2(n[..., 0], n[..., 1]))
    return gamma, beta


def _angle_mod(a: np.ndarray) -> np.ndarray:
    """Map angles to [0, 2 pi) (np.mod can return exactly 2 pi for tiny negative input)."""
    out = np.mod(a, 2 * np.pi)
    return np.where(out >= 2 * np.pi, 0.0, out)


def seed_normal_2d(theta: np.ndarray) -> np.ndarray:
    """2D unit normal (x, y) from the seed's angle theta (from the y axis; Eq. 4.35).

    The seed writes ``n = (n_y, n_x) = (cos t, sin t)``.
    """
    t = np.asarray(theta, dtype=float)
    return np.stack([np.sin(t), np.cos(t)], axis=-1)


def seed_theta(n: np.ndarray) -> np.ndarray:
    """Inverse of :func:`seed_normal_2d`: theta in [0, 2 pi)."""
    n = np.asarray(n, dtype=float)
    return _angle_mod(np.arctan2(n[..., 0], n[..., 1]))

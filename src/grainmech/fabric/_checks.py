"""Input checks shared by the fabric modules (private).

Every check raises :class:`grainmech.errors.ParameterError` naming the offending field, so
a user never sees a deep NumPy traceback or a silent NaN.
"""

from __future__ import annotations

import numpy as np

from grainmech.errors import ParameterError

#: Tolerance on ``| |n| - 1 |`` accepted for "unit" normals.
UNIT_TOL = 1e-6


def _short(a: np.ndarray) -> str:
    return f"array of shape {a.shape}"


def as_int(value: object, name: str, minimum: int | None = None) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(name, value, "must be an integer")
    if minimum is not None and value < minimum:
        raise ParameterError(name, value, f"must be >= {minimum}")
    return int(value)


def as_even_order(value: object, name: str = "order") -> int:
    """A non-negative even integer (expansion order of a centrosymmetric density)."""
    v = as_int(value, name, 0)
    if v % 2:
        raise ParameterError(name, value, "must be even (a contact-normal density is "
                          "centrosymmetric, so only even harmonics occur; seed Eq. 4.7, 4.9)")
    return v


def as_dim(value: object, name: str = "dim") -> int:
    if isinstance(value, (bool, np.bool_)) or value not in (2, 3):
        raise ParameterError(name, value, "must be 2 or 3")
    return int(value)


def as_finite_array(value: object, name: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(name, value, f"must be numeric ({exc})") from None
    if not np.all(np.isfinite(a)):
        if a.ndim == 0:
            raise ParameterError(name, a.item(), "must be finite (not NaN or inf)")
        bad = np.argwhere(~np.isfinite(a))[0]
        raise ParameterError(name, _short(a),
                          f"contains a non-finite value (NaN or inf) at index {tuple(int(i) for i in bad)}")
    return a


def as_scalar(value: object, name: str) -> float:
    """A finite real scalar."""
    a = as_finite_array(value, name)
    if a.ndim != 0:
        raise ParameterError(name, value, "must be a single number")
    return float(a)


def as_normals(value: object, dim: int | None = None, name: str = "normals",
               normalise: bool = True) -> np.ndarray:
    """Unit vectors of shape (..., dim); checks shape, finiteness and unit length.

    Parameters
    ----------
    value : array_like, shape (..., d)
    dim : int, optional
        Required trailing length (2 or 3); any of the two if None.
    normalise : bool
        Divide by the norm after checking (removes round-off below :data:`UNIT_TOL`).
    """
    n = as_finite_array(value, name)
    if n.ndim == 0 or n.shape[-1] not in ((dim,) if dim else (2, 3)):
        want = f"(..., {dim})" if dim else "(..., 2) or (..., 3)"
        raise ParameterError(name, _short(n), f"must have shape {want}")
    norm = np.linalg.norm(n, axis=-1)
    dev = np.abs(norm - 1.0)
    if dev.size and dev.max() > UNIT_TOL:
        idx = np.unravel_index(int(np.argmax(dev)), dev.shape)
        raise ParameterError(name, _short(n),
                          f"must be unit vectors; entry {tuple(int(i) for i in idx)} has length "
                          f"{norm[idx]:.9g} (tolerance {UNIT_TOL:g})")
    return n / norm[..., None] if normalise else n


def as_weights(value: object, count: int, name: str = "weights") -> np.ndarray:
    """Non-negative finite weights of shape (count,) with a positive sum."""
    w = as_finite_array(value, name)
    if w.shape != (count,):
        raise ParameterError(name, _short(w), f"must have shape ({count},), one weight per normal")
    if np.any(w < 0):
        i = int(np.argmin(w))
        raise ParameterError(name, _short(w), f"must be non-negative; weights[{i}] = {w[i]:g}")
    if not w.sum() > 0:
        raise ParameterError(name, _short(w), "must have a positive sum")
    return w


def as_rotation(value: object, dim: int, name: str = "R", tol: float = 1e-8) -> np.ndarray:
    """An orthogonal (dim, dim) matrix (proper or improper)."""
    R = as_finite_array(value, name)
    if R.shape != (dim, dim):
        raise ParameterError(name, _short(R), f"must have shape ({dim}, {dim})")
    err = np.abs(R @ R.T - np.eye(dim)).max()
    if err > tol:
        raise ParameterError(name, _short(R), f"must be orthogonal; max |R R^T - I| = {err:.3g}")
    return R

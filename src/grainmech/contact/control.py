"""Force-controlled steps: find the displacement increments that give prescribed forces.

The normal law is invertible in closed form (a prescribed normal force fixes the
approach). The tangential force after a step is a non-decreasing function of the
displacement increment along a fixed direction (for every law here), so a prescribed
tangential force is found by a bracketing root search (Illinois regula falsi, which
keeps a bracket and converges superlinearly), vectorised over contacts.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from grainmech.contact.forms import law_forms
from grainmech.contact.law import ContactResponse, ContactState, update
from grainmech.contact.params import ContactParams
from grainmech.errors import GrainmechError

__all__ = ["solve_step"]


def solve_step(params: ContactParams, state: ContactState, *,
               d_normal: ArrayLike | None = None,
               normal_force: ArrayLike | None = None,
               d_tangential: ArrayLike | None = None,
               tangential_force: ArrayLike | None = None,
               direction: ArrayLike | None = None,
               rtol: float = 1e-11,
               max_iter: int = 200,
               ) -> tuple[ContactState, ContactResponse, np.ndarray, np.ndarray]:
    """One step with each of the normal and tangential channels under force or displacement control.

    Parameters
    ----------
    params : contact parameter object
    state : ContactState
        Start of the step (not modified).
    d_normal : array_like, shape (n,), optional
        Prescribed approach increment [m] ...
    normal_force : array_like, shape (n,), optional
        ... or prescribed normal force at the end of the step [N] (exactly one of the two).
    d_tangential : array_like, shape (n, dim), optional
        Prescribed tangential displacement increment [m] ...
    tangential_force : array_like, shape (n,), optional
        ... or prescribed component of the tangential force along ``direction`` at the end
        of the step [N] (the increment is then sought along ``direction``). Giving neither
        holds the tangential displacement.
    direction : array_like, shape (n, dim) or (dim,), optional
        Unit direction for ``tangential_force`` (default: first tangent axis, ``x``).
    rtol : float
        Relative tolerance on the tangential force.
    max_iter : int
        Iteration limit of the root search.

    Returns
    -------
    new_state, response, d_normal, d_tangential

    Raises
    ------
    GrainmechError
        If a prescribed tangential force exceeds ``mu N`` or the search fails.
    """
    n, dim = state.n_contacts, state.dim
    if (d_normal is None) == (normal_force is None):
        raise ValueError("give exactly one of d_normal and normal_force")
    if d_tangential is not None and tangential_force is not None:
        raise ValueError("give at most one of d_tangential and tangential_force")

    dn = _normal_increment(params, state, d_normal, normal_force)

    if tangential_force is None:
        dt = np.zeros((n, dim)) if d_tangential is None else np.asarray(d_tangential, dtype=float)
        new_state, resp = update(params, state, dn, dt)
        return new_state, resp, dn, np.broadcast_to(dt, (n, dim)).copy()

    target = np.broadcast_to(np.asarray(tangential_force, dtype=float), (n,)).copy()
    dvec = _unit_direction(direction, n, dim)

    def F(x: np.ndarray) -> tuple[np.ndarray, ContactState, ContactResponse]:
        st, rp = update(params, state, dn, x[:, None] * dvec)
        return np.einsum("ij,ij->i", rp.tangential_force, dvec) - target, st, rp

    f0, st0, rp0 = F(np.zeros(n))
    N1 = rp0.normal_force
    mu = float(getattr(params, "friction", 0.0))
    cap = mu * N1
    scale = np.maximum.reduce([np.abs(target), cap, np.full(n, 1e-300)])
    tol = rtol * scale
    bad = np.abs(target) > cap * (1.0 + 1e-9) + tol
    if np.any(bad):
        i = int(np.nonzero(bad)[0][0])
        raise GrainmechError(
            f"tangential force {target[i]:.6g} exceeds the friction limit mu N = {cap[i]:.6g} "
            f"at contact {i} (N = {N1[i]:.6g})")
    done = np.abs(f0) <= tol
    if np.all(done):
        return st0, rp0, dn, np.zeros((n, dim))

    # bracket: x = 0 gives f0; step out along -sign(f0) with the no-slip stiffness (an upper
    # bound of the tangent, so the first guess undershoots) and double until the sign changes
    k0 = np.asarray(law_forms(params).kt0(N1), dtype=float)
    stiff = k0 > 0
    if not np.all(done | stiff):
        raise GrainmechError("a prescribed tangential force needs a tangential stiffness: this contact has none "
                             "(linear springs with ks = 0, or no normal force); prescribe a tangential "
                             "displacement instead")
    k0 = np.where(stiff, k0, 1.0)
    lo, flo, hi, fhi = _bracket(F, f0, k0, done, tol)
    x = _illinois(F, lo, flo, hi, fhi, done, tol, max_iter)
    x = np.where(done, 0.0, x)
    st, rp = update(params, state, dn, x[:, None] * dvec)
    return st, rp, dn, x[:, None] * dvec


def _normal_increment(params: ContactParams, state: ContactState, d_normal: ArrayLike | None,
                      normal_force: ArrayLike | None) -> np.ndarray:
    """The approach increment (n,) [m]: given, or the one that reaches ``normal_force`` (inverse normal law)."""
    n = state.n_contacts
    if normal_force is not None:
        Nt = np.broadcast_to(np.asarray(normal_force, dtype=float), (n,)).copy()
        if not np.all(np.isfinite(Nt)) or np.any(Nt < 0):
            raise GrainmechError("prescribed normal force must be finite and >= 0")
        alpha_t = np.where(Nt > 0, law_forms(params).approach_from_force(Nt), np.minimum(state.approach, 0.0))
        return alpha_t - state.approach
    return np.broadcast_to(np.asarray(d_normal, dtype=float), (n,)).copy()


def _unit_direction(direction: ArrayLike | None, n: int, dim: int) -> np.ndarray:
    """Unit directions (n, dim) of a prescribed tangential force (default: the first axis, ``x``)."""
    if direction is None:
        dvec = np.zeros((n, dim))
        dvec[:, 0] = 1.0
        return dvec
    dvec = np.broadcast_to(np.asarray(direction, dtype=float), (n, dim)).copy()
    ln = np.linalg.norm(dvec, axis=1)
    if np.any(ln <= 0):
        raise ValueError("direction must be non-zero")
    return dvec / ln[:, None]


def _bracket(F: Callable, f0: np.ndarray, k0: np.ndarray, done: np.ndarray,
             tol: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(lo, f(lo), hi, f(hi))`` with ``f`` changing sign (or vanishing) on ``[lo, hi]``.

    From ``x = 0`` a step ``|f0| / k0`` along ``-sign(f0)``, doubled until the sign changes.
    """
    n = len(f0)
    lo = np.zeros(n)
    flo = f0.copy()
    sgn = -np.sign(f0)
    h = np.abs(f0) / k0
    hi = sgn * h
    fhi, _, _ = F(hi)
    for _ in range(200):
        need = ~done & (np.sign(fhi) == np.sign(f0)) & (np.abs(fhi) > tol)
        if not np.any(need):
            break
        lo = np.where(need, hi, lo)
        flo = np.where(need, fhi, flo)
        hi = np.where(need, 2.0 * hi, hi)
        fhi_new, _, _ = F(hi)
        fhi = np.where(need, fhi_new, fhi)
    else:  # pragma: no cover
        raise GrainmechError("could not bracket the prescribed tangential force")
    return lo, flo, hi, fhi


def _illinois(F: Callable, lo: np.ndarray, flo: np.ndarray, hi: np.ndarray, fhi: np.ndarray,
              done: np.ndarray, tol: np.ndarray, max_iter: int) -> np.ndarray:
    """Illinois regula falsi on ``[lo, hi]`` (vectorised): the root of ``F`` in each bracket."""
    n = len(lo)
    # f changes sign or vanishes at hi
    x = hi.copy()
    fx = fhi.copy()
    side = np.zeros(n)
    for _ in range(max_iter):
        conv = done | (np.abs(fx) <= tol) | (np.abs(hi - lo) <= 1e-15 * np.maximum(np.abs(hi), 1e-300))
        if np.all(conv):
            break
        denom = fhi - flo
        with np.errstate(divide="ignore", invalid="ignore"):
            xs = np.where(denom != 0, hi - fhi * (hi - lo) / denom, 0.5 * (lo + hi))
        inside = (xs - np.minimum(lo, hi)) * (np.maximum(lo, hi) - xs) > 0
        xs = np.where(inside, xs, 0.5 * (lo + hi))
        fs, _, _ = F(xs)
        fs = np.where(conv, fx, fs)
        xs = np.where(conv, x, xs)
        same_as_hi = np.sign(fs) == np.sign(fhi)
        # replace the end point with the same sign; halve the other one's value if repeated
        lo_new = np.where(same_as_hi, lo, hi)
        flo_new = np.where(same_as_hi, np.where(side == 1, 0.5 * flo, flo), fhi)
        side = np.where(same_as_hi, 1, -1)
        hi = np.where(conv, hi, xs)
        fhi = np.where(conv, fhi, fs)
        lo = np.where(conv, lo, lo_new)
        flo = np.where(conv, flo, flo_new)
        x = np.where(conv, x, xs)
        fx = np.where(conv, fx, fs)
    else:  # pragma: no cover
        raise GrainmechError("prescribed tangential force: root search did not converge")
    return x

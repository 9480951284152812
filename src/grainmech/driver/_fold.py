"""Antipodal folding of a centrosymmetric contact set (affine model, compiled driver).

Under the affine kinematic hypothesis (seed Eq. 2.13) a row with normal ``-n`` and
branch ``-l`` gets the relative displacement ``dε·(-l) = -(dε·l)``: the same normal
approach ``n·Δ`` and the opposite tangential displacement. The contact laws are
isotropic in the tangent plane, so a contact started from the mirrored state (the same
normal force, approach, reversal invariants ``P_j`` and branch direction ``s``, the
opposite tangential force ``T`` and slip axis ``e``) stays the mirror of its partner at
every step, and its force ``-f`` contributes ``(-f) ⊗ (-l) = f ⊗ l`` to the Love–Weber
stress (seed Eq. 2.6) and the same ``B^T K B`` to the stiffness (seed Eq. 2.26). In
floating point every one of these sign changes is exact, so the two rows of a pair stay
bit-for-bit mirrors (``tests/test_driver_mixed.py`` checks it on an unfolded run).

A Lebedev rule (and any quadrature of a centrosymmetric fabric density that pairs its
points exactly) therefore needs half its rows: one of each pair, with twice the weight.
The compiled driver folds a segment when every row has an exact antipode (normal,
branch vector and weight) and the state at the segment's start is exactly mirrored, and
unfolds the state at its end; results equal the unfolded run's to rounding (the sums
run over the rows in another order).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["antipodal_pairs", "is_mirrored", "fold", "unfold", "FLIPPED_STATE"]

#: fields of :class:`~grainmech.contact.state.ContactState` that change sign at the antipode
FLIPPED_STATE = ("tangential_force", "axis")


def antipodal_pairs(normals: np.ndarray, branch: np.ndarray, weights: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray] | None:
    """Rows ``keep`` and their antipodes ``partner`` if every row has exactly one, else None.

    Row ``partner[k]`` has normal ``-normals[keep[k]]`` and branch vector
    ``-branch[keep[k]]`` exactly, and the same weight; ``keep`` is sorted.
    """
    n = normals.shape[0]
    if n < 2 or n % 2:
        return None
    o = np.lexsort(normals.T[::-1])
    o_neg = np.lexsort((-normals).T[::-1])
    if not np.array_equal(normals[o], -normals[o_neg]):
        return None
    # o[i] and o_neg[i] are antipodes; each pair appears twice (once from each side)
    keep_mask = o < o_neg
    keep, partner = o[keep_mask], o_neg[keep_mask]
    if keep.size * 2 != n or np.any(keep == partner):
        return None
    if not (np.array_equal(branch[keep], -branch[partner]) and np.array_equal(weights[keep], weights[partner])):
        return None
    s = np.argsort(keep)
    return keep[s], partner[s]


def _mirrored(a: np.ndarray, keep: np.ndarray, partner: np.ndarray, flip: bool) -> bool:
    return bool(np.array_equal(a[partner], -a[keep] if flip else a[keep]))


def is_mirrored(state: Any, response: Any, keep: np.ndarray, partner: np.ndarray) -> bool:
    """Whether ``state`` and ``response`` of every ``partner`` row mirror its ``keep`` row exactly.

    The response's step tangents (``t_delta``, ``t_alpha``) are not compared: a segment
    does not start from them.
    """
    return (all(_mirrored(a, keep, partner, name in FLIPPED_STATE) for name, a in zip(state._fields, state))
            and all(_mirrored(a, keep, partner, name in FLIPPED_STATE)
                    for name, a in zip(response._fields, response)
                    if a is not None and name not in ("t_delta", "t_alpha")))


def fold(contacts: Any, state: Any, response: Any, enabled: bool = True) -> tuple:
    """The rows a compiled loop evaluates: one of each antipodal pair, or all of them.

    Returns ``(pairs, normals, branch, weights, state, response)``: ``pairs`` the
    ``(keep, partner)`` of :func:`antipodal_pairs` when ``enabled``, the set pairs up
    exactly and the state is mirrored (then the arrays are those of the rows ``keep``,
    the weights doubled), else None and the arrays as they are.
    """
    normals, branch, weights = contacts.normals, contacts.branch, contacts.weights
    pairs = antipodal_pairs(normals, branch, weights) if enabled else None
    if pairs is None or not is_mirrored(state, response, *pairs):
        return None, normals, branch, weights, state, response
    keep = pairs[0]
    return (pairs, normals[keep], branch[keep], 2.0 * weights[keep], type(state)(*(x[keep] for x in state)),
            type(response)(*(None if x is None else x[keep] for x in response)))


def unfold(half: np.ndarray, keep: np.ndarray, partner: np.ndarray, flip: bool) -> np.ndarray:
    """Full array from the rows ``keep``: the ``partner`` rows copied, negated if ``flip``."""
    full = np.empty((2 * half.shape[0],) + half.shape[1:], dtype=half.dtype)
    full[keep] = half
    full[partner] = -half if flip else half
    return full

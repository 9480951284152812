"""Compiled kinematics of the packing driver's iterations (private; needs numba).

Each Anderson or Newton iteration of :mod:`grainmech.driver.packing.step` maps grain
updates to contact displacements, contact forces to out-of-balance forces and stress,
and bounds each update grain by grain. In NumPy each of these is a dozen small array
operations on ~4000 contacts (~10-50 us each, ~1.5 ms per iteration on the shipped
packing, a fifth of the iteration). Here each is one compiled pass. The NumPy functions
of :mod:`grainmech.driver.packing._operators` and :mod:`grainmech.driver.packing.step` stay the
reference: the iterations use these when the contact law runs compiled (``law_backend``
``"auto"`` or ``"numba"``), and ``tests/driver/test_packing_kernels.py`` holds the two to the same
values.

Conventions as :mod:`grainmech.driver.packing._operators`: ``Delta_c = G_c q + E_c e`` with
``E_c e = l_c . eps`` (seed Eq. 2.13), forces ``f_c = N_c n_c + T_c``, out-of-balance
forces and moments ``G^T f``, ``V sigma = sym(sum_c f_c (x) l_c)`` (Love-Weber, seed
Eq. 2.6). Sparse products run over the CSR rows in order, as SciPy's ``csr_matvec``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

__all__: list[str] = []

_JIT: dict[str, Any] = {"cache": True, "error_model": "numpy"}


@njit(**_JIT)
def _affine(l_, de, c):
    """``l_c . eps`` (3 components) of the engineering Voigt strain ``de`` (seed Eq. 2.13)."""
    e00, e11, e22 = de[0], de[1], de[2]
    e12, e02, e01 = 0.5 * de[3], 0.5 * de[4], 0.5 * de[5]
    lx, ly, lz = l_[c, 0], l_[c, 1], l_[c, 2]
    return (lx * e00 + ly * e01 + lz * e02,
            lx * e01 + ly * e11 + lz * e12,
            lx * e02 + ly * e12 + lz * e22)


@njit(**_JIT)
def _g_row(indptr, indices, data, x, row):
    """Row ``row`` of the CSR product ``G x``."""
    acc = 0.0
    for j in range(indptr[row], indptr[row + 1]):
        acc += data[j] * x[indices[j]]
    return acc


@njit(**_JIT)
def _delta(indptr, indices, data, x, l_, de, c):
    """Relative displacement ``G_c x + l_c . eps`` (3 components) of contact ``c`` (seed Eq. 2.13)."""
    a0, a1, a2 = _affine(l_, de, c)
    return (_g_row(indptr, indices, data, x, 3 * c) + a0,
            _g_row(indptr, indices, data, x, 3 * c + 1) + a1,
            _g_row(indptr, indices, data, x, 3 * c + 2) + a2)


@njit(**_JIT)
def contact_increments(indptr, indices, data, dq, l_, n, de, s, dn, dt):
    """Normal and tangential relative displacement of every contact, in law space.

    ``Delta = G dq + l . eps``; ``dn = s (Delta . n)``, ``dt = s (Delta - (Delta . n) n)``
    written into ``dn`` (C,) and ``dt`` (C, 3). Returns False if any value before the
    scaling is not finite (nothing else is promised then).
    """
    ok = True
    for c in range(n.shape[0]):
        d0, d1, d2 = _delta(indptr, indices, data, dq, l_, de, c)
        nx, ny, nz = n[c, 0], n[c, 1], n[c, 2]
        dnc = d0 * nx + d1 * ny + d2 * nz
        t0, t1, t2 = d0 - dnc * nx, d1 - dnc * ny, d2 - dnc * nz
        if not (math.isfinite(dnc) and math.isfinite(t0) and math.isfinite(t1) and math.isfinite(t2)):
            ok = False
        sc = s[c]
        dn[c] = dnc * sc
        dt[c, 0] = t0 * sc
        dt[c, 1] = t1 * sc
        dt[c, 2] = t2 * sc
    return ok


@njit(**_JIT)
def forces_balance(N, T, n, l_, gt_indptr, gt_indices, gt_data, f, rq, vs):
    """Contact forces ``f = N n + T``, out-of-balance ``rq = G^T f`` and ``vs = V sigma`` (6,).

    ``f`` is written as a flat (3C,) array (a view of the caller's (C, 3) array); ``vs``
    in library order xx, yy, zz, yz, xz, xy of ``sym(sum_c f_c (x) l_c)``. Nothing is
    allocated (scalar sums: a smaller function, compiled faster on a first run).
    """
    s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
    for c in range(n.shape[0]):
        f0 = N[c] * n[c, 0] + T[c, 0]
        f1 = N[c] * n[c, 1] + T[c, 1]
        f2 = N[c] * n[c, 2] + T[c, 2]
        f[3 * c] = f0
        f[3 * c + 1] = f1
        f[3 * c + 2] = f2
        lx, ly, lz = l_[c, 0], l_[c, 1], l_[c, 2]
        s00 += f0 * lx
        s01 += f0 * ly
        s02 += f0 * lz
        s10 += f1 * lx
        s11 += f1 * ly
        s12 += f1 * lz
        s20 += f2 * lx
        s21 += f2 * ly
        s22 += f2 * lz
    for row in range(rq.shape[0]):
        rq[row] = _g_row(gt_indptr, gt_indices, gt_data, f, row)
    vs[0] = s00
    vs[1] = s11
    vs[2] = s22
    vs[3] = 0.5 * (s12 + s21)
    vs[4] = 0.5 * (s02 + s20)
    vs[5] = 0.5 * (s01 + s10)


@njit(**_JIT)
def clip_moves(x, pos, R, move, out):
    """Each grain's update (translation and surface rotation ``R |theta|`` together) cut to ``move``.

    ``x`` (n_free,) free unknowns, written cut into ``out``; ``pos`` (P, 6) index of each
    grain's unknown in ``x`` (-1: pinned). As :func:`grainmech.driver.packing._iterations.clip_grain_moves`.
    """
    for p in range(pos.shape[0]):
        t2 = 0.0
        r2 = 0.0
        for k in range(6):
            j = pos[p, k]
            v = x[j] if j >= 0 else 0.0
            if k < 3:
                t2 += v * v
            else:
                r2 += v * v
        big = max(math.sqrt(t2), R[p] * math.sqrt(r2))
        c = move / max(big, move)
        for k in range(6):
            j = pos[p, k]
            if j >= 0:
                out[j] = x[j] * c


@njit(**_JIT)
def affine_move(l_, de):
    """Largest contact displacement ``max_c |l_c . eps|`` of the strain ``de`` alone."""
    big = 0.0
    for c in range(l_.shape[0]):
        a0, a1, a2 = _affine(l_, de, c)
        big = max(big, math.sqrt(a0 * a0 + a1 * a1 + a2 * a2))
    return big


@njit(**_JIT)
def closing_cap(indptr, indices, data, dxq, l_, n, de, approach, cap, a, b, pos, f, out):
    """Grain update with every contact it closes stopped at an approach of ``cap``.

    As :func:`grainmech.driver.packing._iterations.stop_closing`: both grains of a contact
    that is open (``approach <= 0``) and would close beyond ``cap`` are scaled by the
    smallest factor ``(cap - approach)/dn`` (clipped to [0, 1]) over their closing
    contacts. ``f`` (P,) ones on entry (work space). Returns True and the scaled update
    in ``out`` if any contact closes beyond ``cap``; False (``out`` untouched) otherwise.
    """
    changed = False
    for c in range(n.shape[0]):
        ap = approach[c]
        if ap > 0.0:
            continue
        d0, d1, d2 = _delta(indptr, indices, data, dxq, l_, de, c)
        dnc = d0 * n[c, 0] + d1 * n[c, 1] + d2 * n[c, 2]
        if ap + dnc > cap and dnc > 0.0:
            changed = True
            fc = min(max((cap - ap) / dnc, 0.0), 1.0)
            f[a[c]] = min(f[a[c]], fc)
            f[b[c]] = min(f[b[c]], fc)
    if changed:
        for p in range(pos.shape[0]):
            for k in range(6):
                j = pos[p, k]
                if j >= 0:
                    out[j] = dxq[j] * f[p]
    return changed


def grain_positions(free: np.ndarray, n_grains: int) -> np.ndarray:
    """(P, 6) index of each grain's unknown in the free vector, -1 where pinned."""
    pos = np.full(6 * n_grains, -1, dtype=np.int64)
    pos[free] = np.arange(int(free.sum()))
    return pos.reshape(n_grains, 6)

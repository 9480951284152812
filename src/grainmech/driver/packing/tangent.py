"""Tangents and the out-of-balance measure of a packing point (:mod:`grainmech.driver.packing`).

:func:`unbalanced_force_ratio` (a DEM's measure of how far a packing is from
equilibrium, moments included) and the relaxed tangent of a point by GMRES per column or
from its factorised elastic operator (``relaxed_tangent``, the condensation of
Lemaitre & Maloney 2006, Eq. 12, with the contacts' moment springs where the grains have
rolling resistance).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse.linalg as spla

from grainmech.driver.packing._iterations import grain_residuals, held_load
from grainmech.driver.packing._operators import Preconditioner, block_diagonal

if TYPE_CHECKING:
    from grainmech.driver.packing.point import PackingPoint

__all__ = ["unbalanced_force_ratio"]


def unbalanced_force_ratio(point: PackingPoint, *, kind: str = "mean") -> float:
    """Out-of-balance measure of a packing point.

    ``kind="mean"``: mean over grains of ``sqrt(|F_p|^2 + (|M_p|/R_p)^2)`` over the mean
    ``|f_c|`` of the force-carrying contacts (the usual DEM "unbalanced force ratio",
    e.g. YADE's ``unbalancedForce``, with moments added); ``kind="max"``: the largest
    of ``|F_p|``, ``|M_p|/R_p`` over the same mean (the driver's convergence measure).
    Returns 0 for a packing without contact forces.
    """
    b = point.out_of_balance()
    g = grain_residuals(point.kinematics, b if point.load is None else b - held_load(point, point.response))
    fm = np.linalg.norm(point.forces, axis=1)
    fmean = float(fm[fm > 0].mean()) if np.any(fm > 0) else 0.0
    if fmean == 0.0:
        return 0.0
    F = np.linalg.norm(g[:, :3], axis=1)
    M = np.linalg.norm(g[:, 3:], axis=1) / point.radii
    if kind == "max":
        return float(max(F.max(), M.max()) / fmean)
    return float(np.mean(np.hypot(F, M)) / fmean)


def relaxed_tangent(point: PackingPoint, prec: Preconditioner, krylov_max: int, elastic: bool = False,
                    direct: bool = True) -> np.ndarray:
    """Relaxed tangent (6, 6) of ``point`` by GMRES per column.

    With its consistent contact tangent, or with the elastic one (``elastic``); the
    elastic one straight from the preconditioner's ``Y = H0^-1 B0`` when that solves this
    point's operator (``direct``, see :attr:`PackingPoint.elastic_tangent`).
    """
    kin = point.kinematics
    K = point.contact_stiffness()[1 if elastic else 0]
    Kb = block_diagonal(K)
    KE = Kb @ kin.E
    B = kin.Gt @ KE
    A = kin.E.T @ KE
    rt = point.rolling_tangent(elastic)  # contact moments: grain moment balance only, not the stress

    def hop(y: np.ndarray) -> np.ndarray:
        d = kin.G @ y
        out = kin.Gt @ (Kb @ d)
        if rt is not None:
            out = out + (rt.apply(y, d.reshape(-1, 3)) if y.ndim == 1 else
                         np.stack([rt.apply(y[:, k], d[:, k].reshape(-1, 3)) for k in range(y.shape[1])], axis=1))
        return out

    if rt is not None:
        B = B + rt.strain_columns()
    if elastic and direct and prec.Y.shape == B.shape:
        # the preconditioner factorised this operator (shifted) and holds Y = (H0 + S)^-1 B0:
        # refined to H0^-1 B0 by CG with that factor, no further factorisation, when it
        # solves this point's operator (PackingPoint.elastic_tangent)
        Y = prec.exact_Y()[0]
        R = hop(Y) - B
        if np.all(np.linalg.norm(R, axis=0) <= 1e-8 * np.linalg.norm(B, axis=0)):
            return (A - KE.T @ (kin.G @ Y)) / point.volume if rt is not None else (A - B.T @ Y) / point.volume
    D = prec.dq
    nq = kin.n_free
    S0 = np.zeros(6, bool)
    op = spla.LinearOperator((nq, nq), matvec=lambda y: D * hop(D * y), dtype=float)
    pc = spla.LinearOperator((nq, nq), matvec=lambda z: prec.apply(z / D, np.zeros(0), S0)[0] / D, dtype=float)
    X = np.zeros((nq, 6))
    for k in range(6):
        if not np.any(B[:, k]):
            continue
        y, _ = spla.gmres(op, D * B[:, k], rtol=1e-10, atol=0.0, restart=krylov_max, maxiter=3, M=pc)
        X[:, k] = D * y
    C = (A - (kin.E.T @ (Kb @ (kin.G @ X)))) / point.volume
    return C

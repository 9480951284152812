"""The soil-mechanics view of a stress path: mean stress, deviator, strains along the loading axis."""

from __future__ import annotations

from typing import Any

import numpy as np

from grainmech.conventions import ORDER_3D, von_mises

__all__ = ["soil_path_table"]


def soil_path_table(result: Any) -> tuple[list[str], np.ndarray, str]:
    """The soil-mechanics view of a driver path, one row per step.

    Columns: ``p [Pa]`` (mean stress ``tr(sigma)/3``), ``q [Pa]`` (deviator stress
    ``sqrt(3 J2)``, :func:`grainmech.conventions.von_mises`, which is ``sigma_1 - sigma_3``
    on a triaxial path), ``q_over_p [-]``,
    ``axial_strain [-]`` (the normal strain along the loading axis: the normal component
    whose stress changed most along the path, else whose strain did), ``volumetric_strain
    [-]`` (``tr(eps)``, compression positive) and ``deviatoric_strain [-]``
    (``sqrt(2/3 e:e)`` of the deviatoric tensor strain ``e``, which is ``2/3 (eps_a -
    eps_r)`` on a triaxial path); all from the initial state, decimal. Returns the
    columns, the rows and the axis name (``"xx"``, ``"yy"`` or ``"zz"``).
    """
    s = np.asarray(result.stress, dtype=float)
    e = np.asarray(result.strain, dtype=float)
    p = s[:, :3].mean(axis=1)
    q = von_mises(s)
    de = e - e[0]
    ds = s - s[0]
    score = np.abs(ds[-1, :3]) if np.any(np.abs(ds[-1, :3]) > 0) else np.abs(de[-1, :3])
    axis = int(np.argmax(score))
    ev = de[:, :3].sum(axis=1)
    ed = de[:, :3] - ev[:, None] / 3.0
    eq = np.sqrt(2.0 / 3.0 * (np.sum(ed ** 2, axis=1) + 2.0 * np.sum((de[:, 3:] / 2.0) ** 2, axis=1)))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(p > 0, q / np.where(p > 0, p, 1.0), np.nan)
    cols = ["p [Pa]", "q [Pa]", "q_over_p [-]", "axial_strain [-]", "volumetric_strain [-]",
            "deviatoric_strain [-]"]
    return cols, np.column_stack([p, q, ratio, de[:, axis], ev, eq]), ORDER_3D[axis]

"""What a run's outcome carries for its report: the empirical references and a path's strength.

:func:`reference_curves` evaluates the empirical modulus-reduction and damping curves of a
sand at a cyclic run's mean stress (Darendeli 2001, Hardin & Drnevich 1972, Menq 2003);
:func:`path_measures` gives a path's soil-mechanics table and its strength. The run job
calls them once when it makes the outcome (:mod:`grainmech.jobs.model`) and stores the
result on it; the writer (:mod:`grainmech.io.reports`) only formats what it carries.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.analysis.empirical import (
    SAND_PEAK_FRICTION_DEG,
    DarendeliCurves,
    HardinDrnevichReference,
    MenqCurves,
    darendeli,
    hardin_drnevich,
    hardin_drnevich_reference,
    menq_curve,
    mohr_coulomb_ratio,
)
from grainmech.analysis.strength import StrengthResult, path_strength
from grainmech.analysis.stress_path import soil_path_table

__all__ = ["ReferenceCurves", "reference_curves", "PathMeasures", "path_measures", "SAND_ENVELOPE_RATIO",
           "SAND_ENVELOPE_TAU_RATIO"]

#: ``sigma1/sigma3`` on the envelope of sands, Mohr-Coulomb with phi = :data:`SAND_PEAK_FRICTION_DEG`
#: (``(1 + sin phi)/(1 - sin phi)`` = 7.55)
SAND_ENVELOPE_RATIO = mohr_coulomb_ratio(np.radians(SAND_PEAK_FRICTION_DEG))
#: ``tau_xz/sigma_zz`` on the same envelope in simple shear (``tan phi`` = 1.19)
SAND_ENVELOPE_TAU_RATIO = float(np.tan(np.radians(SAND_PEAK_FRICTION_DEG)))
#: points of the reference curves, log-spaced over the run's strain range
N_REFERENCE_POINTS = 60


@dataclass(frozen=True)
class ReferenceCurves:
    """Empirical reference curves of a cyclic run (:func:`reference_curves`).

    Attributes
    ----------
    gamma : ndarray (60,)
        Shear strain (decimal), log-spaced over the run's amplitudes (a decade either side
        of a single one).
    darendeli : DarendeliCurves
        Darendeli (2001) on ``gamma``.
    hardin_drnevich : HardinDrnevichReference
        Hardin & Drnevich (1972) reference strain and largest damping.
    hd_ratio, hd_damping : ndarray (60,)
        Hardin-Drnevich G/Gmax and damping (decimal) on ``gamma``.
    hd_gmax : float
        The Gmax [Pa] of Hardin-Drnevich's ``gamma_r = tau_max / Gmax``.
    hd_gmax_source : str
        Where ``hd_gmax`` comes from.
    menq : MenqCurves or None
        Menq (2003) on ``gamma`` (None without a grading in ``reference``).
    menq_at_amplitudes : MenqCurves or None
        Menq (2003) at the run's amplitudes.
    grading_source : str or None
        Where Menq's Cu and D50 come from (``reference["grading_source"]``).
    """

    gamma: np.ndarray
    darendeli: DarendeliCurves
    hardin_drnevich: HardinDrnevichReference
    hd_ratio: np.ndarray
    hd_damping: np.ndarray
    hd_gmax: float
    hd_gmax_source: str
    menq: MenqCurves | None = None
    menq_at_amplitudes: MenqCurves | None = None
    grading_source: str | None = None


def _menq(gamma: Any, pressure: float, ref: dict) -> MenqCurves | None:
    """Menq (2003) at ``pressure`` and the grading of ``ref`` (None without one)."""
    if "uniformity_coefficient" not in ref or "d50" not in ref:
        return None
    return menq_curve(gamma, pressure, ref["uniformity_coefficient"], ref["d50"], ref.get("n_cycles", 10.0))


def reference_curves(amplitudes: Any, pressure: float, reference: dict, g_max: float,
                     empirical_g_max: dict | None = None) -> ReferenceCurves | None:
    """Empirical reference curves (Darendeli 2001, Hardin-Drnevich 1972, Menq 2003) for a cyclic run.

    Darendeli (2001), Hardin-Drnevich (1972) and Menq (2003) curves at the run's mean
    stress, over the strain range of the model's amplitudes (a decade either side of a
    single one). Menq's takes the coefficient of uniformity and D50 of ``reference`` (the
    grains the run used, ``[reference]`` keys or the default: :func:`grainmech.jobs.prepare_run`),
    and is also given at the amplitudes themselves.

    All are empirical end to end: no reference strain uses the model's Gmax.
    Darendeli's ``gamma_r`` comes from his correlation (mean stress, PI, OCR; Table 8.12);
    Hardin-Drnevich's ``gamma_r = tau_max / Gmax`` takes ``tau_max = p sin(phi')`` and the
    Gmax of Hardin's correlation for angular grains at the run's void ratio and mean stress
    (Hardin & Richart 1963, the form Hardin & Drnevich 1972 use), so a model that is too
    stiff shows as a curve shifted away from both references instead of moving one of
    them. Without a void ratio (packing given by contacts per volume) the model's Gmax is
    the only one available and is used (``hd_gmax_source`` says which).

    Parameters
    ----------
    amplitudes : array_like (k,)
        The shear strain amplitudes the model completed (decimal).
    pressure : float
        Mean stress [Pa].
    reference : dict
        ``pi``, ``ocr``, ``n_cycles``, ``frequency`` [Hz], ``phi`` [rad]; optionally
        ``uniformity_coefficient``, ``d50`` [m] and ``grading_source`` (Menq).
    g_max : float
        The model's Gmax [Pa] (used only without ``empirical_g_max``).
    empirical_g_max : dict or None
        :func:`grainmech.jobs.checks.empirical_gmax_check` (its ``G_angular_Pa``).

    Returns None without an amplitude, without the ``reference`` inputs or without a
    finite, positive Gmax for Hardin-Drnevich.
    """
    amps = np.asarray(amplitudes, dtype=float)
    if amps.size == 0 or not reference:
        return None
    lo, hi = float(amps.min()), float(amps.max())
    if hi <= lo:  # one amplitude (or an interrupted run's first): a decade either side
        lo, hi = lo / 10, hi * 10
    gam = np.logspace(np.log10(lo), np.log10(hi), N_REFERENCE_POINTS)
    dar = darendeli(gam, pressure, pi=reference["pi"], ocr=reference["ocr"], n_cycles=reference["n_cycles"],
                    frequency=reference["frequency"])
    if empirical_g_max:
        g_hd, source = float(empirical_g_max["G_angular_Pa"]), "Hardin-Richart (1963) angular grains"
    else:
        g_hd, source = float(g_max), "the model's Gmax (no void ratio given)"
    if not (np.isfinite(g_hd) and g_hd > 0):  # no Gmax to normalise Hardin-Drnevich's curve by
        return None
    hd = hardin_drnevich_reference(pressure, reference["phi"], g_hd, reference["n_cycles"])
    hd_r, hd_d = hardin_drnevich(gam, hd.gamma_r, hd.d_max)
    return ReferenceCurves(gam, dar, hd, hd_r, hd_d, g_hd, source, _menq(gam, pressure, reference),
                           _menq(amps, pressure, reference), reference.get("grading_source"))


@dataclass(frozen=True)
class PathMeasures:
    """The soil-mechanics view of a path and its strength (:func:`path_measures`).

    Attributes
    ----------
    columns : list of str
        :func:`grainmech.analysis.stress_path.soil_path_table`'s column names.
    rows : ndarray (k+1, 6)
        Its rows, one per recorded state.
    axis : str
        The loading axis (``"xx"``, ``"yy"`` or ``"zz"``).
    strength : StrengthResult or None
        :func:`grainmech.analysis.strength.path_strength` along the axis (None with fewer
        than 3 states).
    """

    columns: list
    rows: np.ndarray
    axis: str
    strength: StrengthResult | None = None


def path_measures(result: Any) -> PathMeasures:
    """p, q, strains along the loading axis and the peak and critical-state strength of a path.

    ``result`` has ``stress`` and ``strain`` (k+1, 6), compression positive; the table is
    :func:`grainmech.analysis.stress_path.soil_path_table`, the strength
    :func:`grainmech.analysis.strength.path_strength` (Mohr-Coulomb, Wood 1990 Sec. 4.2)
    of its axial and volumetric strains.
    """
    cols, rows, axis = soil_path_table(result)
    strength = path_strength(result.stress, rows[:, 3], rows[:, 4]) if len(rows) >= 3 else None
    return PathMeasures(cols, rows, axis, strength)

"""Plausibility checks of inputs and results: warnings (not errors), each with value and reason.

Bare stresses below 1 kPa, amplitudes beyond the small-strain range, implausible
coordination numbers (:func:`input_warnings`); a model Gmax above the grains' own modulus
or far from Hardin & Richart (1963); recorded states beyond the envelope of sands; loops
that are not closed; packing-model loops at constant volume whose mean stress drifts
(grains that rearrange, :func:`rearrangement_warnings`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainmech.analysis import SAND_PEAK_FRICTION_DEG, hardin_richart, loop_quality, mohr_coulomb_ratio
from grainmech.conventions import vector_to_stress
from grainmech.driver.base import KinematicModel
from grainmech.driver.registry import resolve
from grainmech.fabric import CORRELATIONS, coordination_number
from grainmech.io.schema import MICROSTRUCTURE, RENAMED_TABLES, renamed_table_warnings
from grainmech.outcomes import run_mean_stress_change

__all__ = ["SMALL_STRAIN_LIMIT", "SPHERE_COORDINATION_RANGE", "GMAX_FLAG_FACTOR", "input_warnings",
           "grain_modulus_warning", "empirical_gmax_check", "envelope_check", "cyclic_envelope",
           "last_cycle_quality", "REARRANGEMENT_DP", "rearranging", "rearrangement_warnings"]


#: largest shear strain amplitude the material-point model is meant for (small strain,
#: fixed reference geometry; laboratory G/Gmax curves end near 1e-2)
SMALL_STRAIN_LIMIT = 1e-2


#: coordination numbers of sphere packings: ~4 (loose frictional, Thornton 2000's
#: mechanical value) to 12 (face-centred cubic); random close packing ~6
SPHERE_COORDINATION_RANGE = (4.0, 12.0)


def grain_modulus_warning(g_max: float, law: Any) -> list[str]:
    """A warning if the packing's shear modulus exceeds the grains' own (``law.shear_modulus``).

    A packing of grains cannot be stiffer than the solid it is made of (Hashin-Shtrikman
    upper bound of a porous solid).
    """
    grain_g = getattr(law, "shear_modulus", None)
    if grain_g is None or not np.isfinite(g_max) or g_max <= grain_g:
        return []
    return [f"model Gmax = {g_max:.4g} Pa is above the grains' own shear modulus {grain_g:.4g} Pa: "
            "a packing cannot be stiffer than its solid"]


def input_warnings(cfg: dict, prefix: str = "") -> list[str]:
    """Plausibility warnings (not errors) about a config, each with value and reason.

    The same checks for every command that reads these keys (``run``, ``stiffness``,
    ``calibrate``'s model, ``pack``):

    * a bare stress below 1 kPa (``pressure = 100`` is read as 100 Pa) in
      ``initial.pressure``, ``stress.pressure`` or ``preparation.stress``;
    * a cyclic amplitude above :data:`SMALL_STRAIN_LIMIT`;
    * a coordination number outside :data:`SPHERE_COORDINATION_RANGE`;
    * a table under its old name (:data:`grainmech.io.schema.RENAMED_TABLES`: ``[packing]``
      is ``[microstructure]`` now).

    ``prefix`` is the dotted name of ``cfg`` in its file (``"model"`` in a calibration),
    for the names of renamed tables.
    """
    out = renamed_table_warnings(cfg, prefix)
    for table, key in (("initial", "pressure"), ("stress", "pressure"), ("preparation", "stress")):
        sec = cfg.get(table, {}) if isinstance(cfg.get(table), dict) else {}
        p = sec.get(key)
        if isinstance(p, (int, float)) and not isinstance(p, bool) and 0 < p < 1e3:
            out.append(f"{table}.{key} = {p:g}: a bare number is read in Pa ({p:g} Pa, below 1 kPa); "
                       f"write e.g. \"{p:g} kPa\" if that was meant")
    test = cfg.get("test", {}) if isinstance(cfg.get("test"), dict) else {}
    amps = test.get("amplitudes")
    if isinstance(amps, list):
        big = [a for a in amps if isinstance(a, (int, float)) and a > SMALL_STRAIN_LIMIT]
        if big:
            out.append(f"test.amplitudes = {big}: above {SMALL_STRAIN_LIMIT:g}, beyond the small-strain "
                       "range of the model (fixed reference geometry, no grain rearrangement)")
    # the analytical microstructure under the name the config gives it (both: refused by the readers)
    ms = next((old for old in RENAMED_TABLES if isinstance(cfg.get(old), dict)), MICROSTRUCTURE)
    pk = cfg.get(ms, {}) if isinstance(cfg.get(ms), dict) else {}
    coord, e = pk.get("coordination"), pk.get("void_ratio")
    m = None
    if isinstance(coord, (int, float)) and not isinstance(coord, bool):
        m = float(coord)
    elif isinstance(coord, str) and coord.strip().lower() in CORRELATIONS and isinstance(e, (int, float)):
        m = float(coordination_number(float(e), coord.strip().lower()))
    lo, hi = SPHERE_COORDINATION_RANGE
    if m is not None and not (lo <= m <= hi):
        out.append(f"{ms}.coordination = {m:.3g}: outside {lo:g}-{hi:g}, the range sphere packings "
                   "reach (loose frictional ~4, random close ~6, face-centred cubic 12)")
    return out


#: Model Gmax outside [1/2, 2] x Hardin-Richart is flagged (the scatter of the empirical
#: relation about its data is ~+-20 %; a factor 2 is far outside it).
GMAX_FLAG_FACTOR = 2.0


def empirical_gmax_check(g_model: float, void_ratio: float | None, pressure: float,
                         model: str | KinematicModel = "affine") -> dict | None:
    """The model's Gmax beside Hardin & Richart (1963) at the same void ratio and mean stress.

    Returns ``None`` without a void ratio; else a dict with both empirical values [Pa], the
    ratios model/empirical, the validity ranges, a ``flag`` (ratio to the nearer of the two
    outside ``[1/2, 2]``) and a ``note`` saying what it means for the ``model`` (a model or
    its name): an upper bound, or a packing of grains stiffer than sands.
    """
    if void_ratio is None or not (0 < void_ratio < 2.17) or not np.isfinite(g_model):
        return None
    hr = hardin_richart(void_ratio, pressure)
    r_round, r_ang = g_model / hr.G_round, g_model / hr.G_angular
    nearest = min((r_round, r_ang), key=lambda r: abs(np.log(r)))
    flag = not (1 / GMAX_FLAG_FACTOR <= nearest <= GMAX_FLAG_FACTOR)
    note = (f"model Gmax is {nearest:.2f} x Hardin-Richart (1963) for e = {void_ratio:g} and "
            f"p = {pressure / 1e3:.4g} kPa")
    if flag and nearest > 1 and not resolve(model).upper_bound:
        note += (": the packing is stiffer than sands of this void ratio (Hardin-Richart's sands are "
                 "angular and less coordinated than packings of smooth spheres; compare with a packing "
                 "of the sand's own density and coordination)")
    elif flag and nearest > 1:
        note += (": the affine model (seed's kinematic hypothesis: every contact follows the mean "
                 "strain, no grain can move to relieve its contacts) is an upper bound, several "
                 "times too stiff in shear for real sands; the relaxed tensor of a packing "
                 "(grainmech dem) is the small-strain modulus with the grains in equilibrium")
    elif flag:
        note += ": far below the empirical relation; check the contact moduli and coordination"
    return {"G_round_Pa": hr.G_round, "G_angular_Pa": hr.G_angular, "ratio_round": r_round,
            "ratio_angular": r_ang, "void_ratio": void_ratio, "mean_stress_Pa": pressure,
            "in_range_round": hr.in_range_round, "in_range_angular": hr.in_range_angular,
            "flag": bool(flag), "note": note, "citation": hr.citation}


def envelope_check(stress: np.ndarray) -> dict:
    """Steps whose principal stress ratio exceeds what sands sustain.

    Envelope: Mohr-Coulomb with the friction angle
    :data:`~grainmech.analysis.SAND_PEAK_FRICTION_DEG` (50 deg, ``sigma1/sigma3 = 7.55``),
    an upper bound of measured peak friction angles of sands (critical-state ~33 deg plus
    Bolton's 1986 largest dilatancy term). The affine model cannot fail: every contact
    follows the mean strain, so a stress ratio grows without bound under shear; states
    beyond the envelope are artefacts of that hypothesis, not predictions.

    Parameters
    ----------
    stress : (k+1, 6) stresses, compression positive (library order)

    Returns
    -------
    dict with ``ratio`` (k+1,) principal ratio sigma1/sigma3 (inf where sigma3 <= 0),
    ``beyond`` (k+1,) bool, ``limit``, ``friction_angle_deg``, ``first_step`` (or None).
    """
    lim = mohr_coulomb_ratio(np.radians(SAND_PEAK_FRICTION_DEG))
    S = np.asarray(stress, dtype=float)
    ratio = np.empty(len(S))
    for k, sv in enumerate(S):
        ev = np.linalg.eigvalsh(vector_to_stress(sv))
        ratio[k] = ev[-1] / ev[0] if ev[0] > 0 else np.inf
    beyond = ratio > lim
    first = int(np.argmax(beyond)) if beyond.any() else None
    return {"ratio": ratio, "beyond": beyond, "limit": lim, "friction_angle_deg": SAND_PEAK_FRICTION_DEG,
            "first_step": first}


def cyclic_envelope(stress: np.ndarray) -> dict:
    """Every recorded state of a cyclic simple shear run against the envelope of sands.

    The envelope is :func:`envelope_check`'s, the same as for paths: Mohr-Coulomb on the
    principal stresses with the friction angle
    :data:`~grainmech.analysis.SAND_PEAK_FRICTION_DEG` (50 deg, ``sigma1/sigma3 <=
    7.55``), an upper bound of the peak friction angles of sands (critical state ~33 deg
    plus the largest dilatancy term of Bolton 1986). In simple shear the stress ratio
    on the horizontal plane cannot exceed the largest ratio on any plane, so the
    envelope also bounds ``|tau_xz| / sigma_zz <= tan 50 deg = 1.19``; that ratio is
    reported beside it (the mobilised ratio a simple shear test measures).

    Parameters
    ----------
    stress : (k+1, 6) stresses [Pa], compression positive (library order)

    Returns
    -------
    dict
        :func:`envelope_check`'s keys (``ratio``, ``beyond`` per state, ``limit``,
        ``friction_angle_deg``, ``first_step``) and the scalars ``beyond_any``,
        ``max_ratio`` (sigma1/sigma3, inf once sigma3 <= 0), ``max_mobilised_friction_deg``
        (``asin((R - 1)/(R + 1))`` of the largest ratio R; 90 once sigma3 <= 0) and
        ``max_tau_over_sigma_zz`` (inf where sigma_zz <= 0).
    """
    S = np.asarray(stress, dtype=float)
    env = envelope_check(S)
    r = float(np.max(env["ratio"])) if len(S) else 1.0
    phi = 90.0 if not np.isfinite(r) else float(np.degrees(np.arcsin((r - 1.0) / (r + 1.0))))
    szz = S[:, 2] if len(S) else np.ones(1)
    tau = np.abs(S[:, 4]) if len(S) else np.zeros(1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ratio = np.where(szz > 0, tau / np.where(szz > 0, szz, 1.0), np.inf)
    env.update(beyond_any=bool(np.any(env["beyond"])), max_ratio=r, max_mobilised_friction_deg=phi,
               max_tau_over_sigma_zz=float(np.max(t_ratio)))
    return env


def last_cycle_quality(result: Any, steps_per_cycle: int) -> Any:
    """:func:`grainmech.analysis.loop_quality` of the last ``steps_per_cycle`` steps of a cyclic run.

    The cycle analysed by the modulus-reduction series (``gamma_xz``, ``tau_xz``, states
    ``n - steps_per_cycle .. n``), the peaks measured from the run's initial ``tau_xz``.
    """
    n = len(result.strain) - 1
    last = slice(max(n - steps_per_cycle, 0), n + 1)
    return loop_quality(result.strain[last, 4], result.stress[last, 4], tau_0=float(result.stress[0, 4]))


#: change of mean stress over a constant-volume cyclic run of the packing model above which
#: its loop is flagged: against the DEM model on the same grains (``docs/models/packing.md``,
#: "Where the fixed geometry holds"), where the packing model's change stays within 0.3 %,
#: the two agree within 1 % in G on 'dense' and 'medium' and on 'loose' at 1e-5 within the
#: DEM's own spread with its damping (0.4 % and 3.3 %); they differ by 6.9 % and 20 % where
#: it is 2.0 % and 11.8 % (the DEM packing rearranges there); 1 % lies between the two
REARRANGEMENT_DP = 0.01


def rearranging(model: str | KinematicModel, constant: str, results: list) -> list[bool]:
    """Whether each completed run is flagged by :func:`rearrangement_warnings` (aligned with ``results``).

    Only a model with a fixed reference geometry (the packing model) is flagged; ``model``
    is a model or its name.
    """
    if not resolve(model).fixed_geometry or constant != "volume":
        return [False] * len(results)
    return [abs(run_mean_stress_change(r)) > REARRANGEMENT_DP for r in results]


def rearrangement_warnings(model: str | KinematicModel, constant: str, amplitudes: Any,
                           results: list) -> list[str]:
    """One warning per packing-model amplitude whose constant-volume run drifts in mean stress.

    ``results``: the completed runs, aligned with ``amplitudes``. At constant volume a
    packing whose grains rearrange changes its mean stress (an undrained test's pore
    pressure; in sands from the volumetric threshold shear strain, Vucetic 1994); the
    packing model's fixed geometry follows that change in sign and size but not the loop
    (``docs/models/packing.md``). An amplitude whose ``|p_end / p_0 - 1|`` exceeds
    :data:`REARRANGEMENT_DP` is flagged. Models without a fixed geometry and constant
    stress: none.
    """
    out = []
    for a, r, flagged in zip(amplitudes, results, rearranging(model, constant, results)):
        if flagged:
            dp = run_mean_stress_change(r)
            out.append(f"packing model, amplitude {a:.1e}: the mean stress changed by {100 * dp:+.1f} % over the "
                       f"constant-volume cycles (more than {100 * REARRANGEMENT_DP:g} %): the grains rearrange "
                       "here, which the packing model's fixed geometry does not follow; against the DEM model on "
                       "the same grains such loops were 7-20 % off in G (docs/models/packing.md, 'Where the fixed "
                       "geometry holds'): method = \"dem\" is the model for this amplitude")
    return out

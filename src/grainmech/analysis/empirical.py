"""Empirical modulus-reduction and damping curves (references for the driver's output).

* Hardin & Drnevich (1972): hyperbolic ``G/Gmax = 1/(1 + gamma/gamma_r)`` and
  ``D = D_max (1 - G/Gmax)``.
* Darendeli (2001), PhD thesis, Univ. of Texas at Austin, Ch. 8-9: modified hyperbola
  with reference strain from mean effective stress, PI, OCR and Masing damping scaled by
  cycles and frequency. **Mean stress in atmospheres**: the function takes Pa and
  converts explicitly with ``P_ATM = 101325 Pa``.
* Menq (2003), PhD thesis, Univ. of Texas at Austin: modified hyperbola for clean sands
  and gravels with reference strain and curvature from mean effective stress and the
  coefficient of uniformity, minimum damping from ``Cu``, ``D50`` and mean stress, and
  Darendeli's Masing damping scaled by cycles (as pystrata's ``MenqSoilType``).

* Hardin & Richart (1963): small-strain shear modulus of clean sands from void ratio
  and mean effective stress (round and angular grains).
* A stress-ratio envelope for sands (Mohr-Coulomb, Bolton 1986) to flag model states
  that no sand sustains.

Strains are given as plain strains (not percent); Darendeli's formulae in percent are
applied internally.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from grainmech.errors import ParameterError

__all__ = ["P_ATM", "DARENDELI_PHI", "hardin_drnevich", "HardinDrnevichReference",
           "hardin_drnevich_reference", "darendeli", "DarendeliCurves", "menq_curve", "MenqCurves",
           "MENQ_D50_MAX",
           "masing_damping_hyperbolic", "masing_damping_modified", "masing_damping_peak",
           "hardin_richart", "HardinRichart", "mohr_coulomb_ratio",
           "SAND_PEAK_FRICTION_DEG", "bolton", "Bolton", "BOLTON_PHI_CS_DEG", "DOBRY_THRESHOLD_STRAIN",
           "relative_density"]

#: standard atmosphere [Pa] used for the Pa -> atm conversion of Darendeli's mean stress
P_ATM = 101325.0

#: Darendeli (2001) calibrated coefficients phi_1..phi_12 (all soils, Table 8.12)
DARENDELI_PHI = (0.0352, 0.0010, 0.3246, 0.3483, 0.9190, 0.8005,
                 0.0129, -0.1069, -0.2889, 0.2919, 0.6329, -0.0057)


def _strain(gamma: Any) -> np.ndarray:
    g = np.asarray(gamma, dtype=float)
    if not np.all(np.isfinite(g)) or np.any(g <= 0):
        raise ParameterError("gamma", gamma, "strains must be finite and > 0")
    return g


def hardin_drnevich(gamma: Any, gamma_r: float, d_max: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Hardin-Drnevich (1972) hyperbolic curves.

    Parameters
    ----------
    gamma : array, shear strain amplitude (dimensionless)
    gamma_r : float, reference strain ``tau_max / G_max``
    d_max : float, maximum damping ratio (dimensionless)

    Returns
    -------
    G_ratio, damping : arrays like ``gamma``
    """
    g = _strain(gamma)
    if not gamma_r > 0:
        raise ParameterError("gamma_r", gamma_r, "must be > 0")
    if not 0 <= d_max < 1:
        raise ParameterError("d_max", d_max, "must lie in [0, 1)")
    r = 1.0 / (1.0 + g / gamma_r)
    return r, d_max * (1.0 - r)


@dataclass(frozen=True)
class HardinDrnevichReference:
    """Parameters of the Hardin-Drnevich curves for a sand (see :func:`hardin_drnevich_reference`).

    Attributes
    ----------
    tau_max : float
        Shear strength [Pa].
    gamma_r : float
        Reference strain ``tau_max / G_max`` (decimal).
    d_max : float
        Largest damping ratio (decimal).
    """

    tau_max: float
    gamma_r: float
    d_max: float
    citation: str = ("Hardin, B. O. & Drnevich, V. P. (1972). Shear modulus and damping in soils: "
                     "design equations and curves. J. Soil Mech. Found. Div. ASCE 98(SM7), 667-692")


def hardin_drnevich_reference(mean_stress: float, friction_angle: float, g_max: float,
                              n_cycles: float = 10.0) -> HardinDrnevichReference:
    """Reference strain and largest damping of a clean dry sand (Hardin & Drnevich 1972).

    * shear strength ``tau_max = p sin(phi')`` (Mohr-Coulomb without cohesion at mean
      effective stress ``p``), reference strain ``gamma_r = tau_max / G_max``;
    * largest damping of clean dry sands ``D_max = (33 - 1.5 log10 N) %`` after ``N``
      loading cycles (Hardin & Drnevich 1972, Table 2).

    Parameters
    ----------
    mean_stress : float
        Mean effective stress ``p`` [Pa] (> 0).
    friction_angle : float
        Effective friction angle ``phi'`` [rad], in (0, pi/2).
    g_max : float
        Small-strain shear modulus [Pa] (> 0) that normalises the curve.
    n_cycles : float
        Number of loading cycles ``N`` (> 0).

    Returns
    -------
    HardinDrnevichReference
        Use with :func:`hardin_drnevich` (``gamma_r``, ``d_max``).
    """
    for name, v in (("mean_stress", mean_stress), ("g_max", g_max)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} = {v!r}: must be finite and > 0 (Pa)")
    if not (np.isfinite(friction_angle) and 0 < friction_angle < np.pi / 2):
        raise ValueError(f"friction_angle = {friction_angle!r}: must lie in (0, pi/2) rad")
    if not (np.isfinite(n_cycles) and n_cycles > 0):
        raise ValueError(f"n_cycles = {n_cycles!r}: must be > 0")
    tau_max = float(mean_stress * np.sin(friction_angle))
    return HardinDrnevichReference(tau_max, tau_max / float(g_max),
                                   float((33.0 - 1.5 * np.log10(n_cycles)) / 100.0))


def _masing_modified_pct(g_pct: np.ndarray, gr_pct: float, a: float) -> np.ndarray:
    """Masing damping [%] of the modified hyperbola of curvature ``a`` (Darendeli 2001, Eq. 9.4).

    ``D_Masing = c1 D1 + c2 D1^2 + c3 D1^3`` with ``D1`` the Masing damping [%] of the
    hyperbola (a = 1, :func:`masing_damping_hyperbolic`) at ``g_pct / gr_pct`` and
    ``c1 = -1.1143 a^2 + 1.8618 a + 0.2523``, ``c2 = 0.0805 a^2 - 0.0710 a - 0.0095``,
    ``c3 = -0.0005 a^2 + 0.0002 a + 0.0003`` (Darendeli's fit to the Masing loops of the
    modified hyperbola; strains in percent).
    """
    d1 = 100.0 * masing_damping_hyperbolic(g_pct, gr_pct)
    c1 = -1.1143 * a ** 2 + 1.8618 * a + 0.2523
    c2 = 0.0805 * a ** 2 - 0.0710 * a - 0.0095
    c3 = -0.0005 * a ** 2 + 0.0002 * a + 0.0003
    return c1 * d1 + c2 * d1 ** 2 + c3 * d1 ** 3


def masing_damping_hyperbolic(gamma: Any, gamma_r: float) -> np.ndarray:
    """Masing damping ratio of the hyperbola ``tau = G gamma/(1 + gamma/gamma_r)``.

    ``D = (1/pi) [4 (gamma - gamma_r ln(1 + gamma/gamma_r)) (gamma + gamma_r)/gamma^2 - 2]``
    (Darendeli 2001, Eq. 9.4a with a = 1, as a ratio). Returns a ratio.
    """
    g = _strain(gamma)
    return (4.0 * (g - gamma_r * np.log1p(g / gamma_r)) * (g + gamma_r) / g ** 2 - 2.0) / np.pi


def masing_damping_modified(gamma: Any, gamma_r: float, curvature: float) -> np.ndarray:
    """Masing damping ratio of the modified hyperbola ``G/Gmax = 1/(1 + (gamma/gamma_r)^a)``.

    Darendeli's (2001, Eq. 9.4) polynomial in the Masing damping of the hyperbola
    (:func:`masing_damping_hyperbolic`), with ``a = curvature``; strains and the result
    as ratios (not percent).
    """
    g = _strain(gamma)
    return _masing_modified_pct(100.0 * g, 100.0 * float(gamma_r), float(curvature)) / 100.0


def masing_damping_peak(curvature: float) -> float:
    """``gamma / gamma_r`` where ``(G/Gmax)^0.1 D_Masing`` of the modified hyperbola is largest.

    Beyond it Menq's (2003) damping, and pystrata's running maximum, hold the peak value
    (:func:`menq_curve`).
    """
    return _menq_masing_peak(float(curvature))


@dataclass(frozen=True)
class DarendeliCurves:
    """Darendeli (2001) curves; strains and damping as ratios (not percent)."""

    gamma: np.ndarray
    G_ratio: np.ndarray
    damping: np.ndarray
    gamma_r: float
    d_min: float
    curvature: float


def darendeli(gamma: Any, mean_stress: float, *, pi: float = 0.0, ocr: float = 1.0,
              n_cycles: float = 10.0, frequency: float = 1.0) -> DarendeliCurves:
    """Darendeli (2001) modulus reduction and damping.

    Parameters
    ----------
    gamma : array
        Shear strain amplitudes (dimensionless, NOT percent).
    mean_stress : float
        Mean effective stress ``sigma'_0`` **in Pa** (converted to atm with ``P_ATM``).
    pi : float
        Plasticity index [%].
    ocr : float
        Over-consolidation ratio.
    n_cycles : float
        Number of loading cycles ``N``.
    frequency : float
        Loading frequency [Hz].

    Notes
    -----
    With ``phi`` = :data:`DARENDELI_PHI` and ``s = sigma'_0 / P_ATM``:
    ``gamma_r[%] = (phi1 + phi2 PI OCR^phi3) s^phi4``, ``a = phi5``,
    ``G/Gmax = 1 / (1 + (gamma/gamma_r)^a)``,
    ``D_min[%] = (phi6 + phi7 PI OCR^phi8) s^phi9 (1 + phi10 ln f)``,
    ``b = phi11 + phi12 ln N``,
    ``D = b (G/Gmax)^0.1 D_Masing + D_min`` with ``D_Masing = c1 D1 + c2 D1^2 + c3 D1^3``,
    ``D1`` the a = 1 Masing damping [%] and ``c1 = -1.1143 a^2 + 1.8618 a + 0.2523``,
    ``c2 = 0.0805 a^2 - 0.0710 a - 0.0095``, ``c3 = -0.0005 a^2 + 0.0002 a + 0.0003``.
    """
    g = _strain(gamma)
    for name, v, lo in (("mean_stress", mean_stress, 0.0), ("ocr", ocr, 0.0),
                        ("n_cycles", n_cycles, 0.0), ("frequency", frequency, 0.0)):
        if not (np.isfinite(v) and v > lo):
            raise ParameterError(name, v, "must be finite and > 0")
    if not (np.isfinite(pi) and pi >= 0):
        raise ParameterError("pi", pi, "must be finite and >= 0")
    p = DARENDELI_PHI
    s_atm = mean_stress / P_ATM
    gr_pct = (p[0] + p[1] * pi * ocr ** p[2]) * s_atm ** p[3]
    a = p[4]
    g_pct = 100.0 * g
    ratio = 1.0 / (1.0 + (g_pct / gr_pct) ** a)
    dmin_pct = (p[5] + p[6] * pi * ocr ** p[7]) * s_atm ** p[8] * (1.0 + p[9] * np.log(frequency))
    b = p[10] + p[11] * np.log(n_cycles)
    dm = _masing_modified_pct(g_pct, gr_pct, a)
    d_pct = b * ratio ** 0.1 * dm + dmin_pct
    return DarendeliCurves(g, ratio, d_pct / 100.0, gr_pct / 100.0, dmin_pct / 100.0, a)


#: the largest median grain size [m] :func:`menq_curve` takes: Menq's soils are sands and
#: gravels; a D50 above 0.1 m (cobbles and boulders) is most likely a D50 in millimetres
#: given as metres
MENQ_D50_MAX = 0.1


@dataclass(frozen=True)
class MenqCurves:
    """Menq (2003) curves (see :func:`menq_curve`); strains and damping as ratios (not percent).

    Attributes
    ----------
    gamma, G_ratio, damping : arrays
        Shear strain amplitude, ``G/Gmax`` and damping ratio (decimal).
    gamma_r : float
        Reference strain (decimal), where ``G/Gmax = 0.5``.
    curvature : float
        Curvature ``a`` of the modified hyperbola.
    d_min : float
        Small-strain damping ratio (decimal).
    masing_scaling : float
        Scaling ``b`` of the Masing damping.
    peak_strain : float
        Strain (decimal) above which the damping is held at its largest value.
    uniformity_coefficient, d50, mean_stress, n_cycles : float
        Inputs (``d50`` in m, ``mean_stress`` in Pa).
    """

    gamma: np.ndarray
    G_ratio: np.ndarray
    damping: np.ndarray
    gamma_r: float
    curvature: float
    d_min: float
    masing_scaling: float
    peak_strain: float
    uniformity_coefficient: float
    d50: float
    mean_stress: float
    n_cycles: float
    citation: str = ("Menq, F.-Y. (2003). Dynamic properties of sandy and gravelly soils. PhD thesis, "
                     "University of Texas at Austin (as in pystrata's MenqSoilType)")


def _menq_masing_peak(a: float) -> float:
    """``x = gamma / gamma_r`` where ``(G/Gmax)^0.1 D_Masing`` of curvature ``a`` is largest.

    The product rises from 0 and, past a single peak (``x`` about 65 for ``a = 0.86``,
    400 for ``a = 0.5``, 40 for ``a = 1.2``), falls again; found by a bounded search in
    ``ln x`` over ``1 ... 1e7``.
    """
    def neg(u: float) -> float:
        x = np.exp(u)
        return -float((1.0 + x ** a) ** -0.1 * _masing_modified_pct(np.array([x]), 1.0, a)[0])

    res = minimize_scalar(neg, bounds=(0.0, np.log(1e7)), method="bounded", options={"xatol": 1e-10})
    return float(np.exp(res.x))


def menq_curve(gamma: Any, mean_stress: float, uniformity_coefficient: float, d50: float,
               n_cycles: float = 10.0) -> MenqCurves:
    """Menq (2003) modulus reduction and damping of clean sands and gravels.

    Parameters
    ----------
    gamma : array
        Shear strain amplitudes (dimensionless, NOT percent; > 0).
    mean_stress : float
        Mean effective stress ``sigma'_m`` **in Pa** (> 0; divided by ``p_a`` =
        :data:`P_ATM` = 101325 Pa).
    uniformity_coefficient : float
        Coefficient of uniformity ``Cu = D60 / D10`` (>= 1).
    d50 : float
        Median grain size ``D50`` **in m** (> 0, at most :data:`MENQ_D50_MAX`; the
        correlation takes mm and the conversion is done here).
    n_cycles : float
        Number of loading cycles ``N`` (> 0); 10 as in pystrata.

    Returns
    -------
    MenqCurves
        ``G_ratio`` and ``damping`` (decimal) at ``gamma``, and the parameters.

    Notes
    -----
    With ``s = sigma'_m / p_a`` (Menq 2003; the form of pystrata's ``MenqSoilType``):

    * ``gamma_r [%] = 0.12 Cu^-0.6 s^(0.5 Cu^-0.15)``, ``a = 0.86 + 0.1 log10 s``,
      ``G/Gmax = 1 / (1 + (gamma/gamma_r)^a)``;
    * ``D_min [%] = 0.55 Cu^0.1 D50^-0.3 s^-0.08`` with ``D50`` in mm;
    * ``b = 0.6329 - 0.00566 ln N``;
    * ``D = b (G/Gmax)^0.1 D_Masing + D_min`` with ``D_Masing`` Darendeli's (2001,
      Eq. 9.4) Masing damping of the modified hyperbola: the closed-form Masing damping
      of the hyperbola (a = 1, :func:`masing_damping_hyperbolic`) corrected for the
      curvature by his polynomial ``c1 D1 + c2 D1^2 + c3 D1^3``.

    The term ``b (G/Gmax)^0.1 D_Masing`` rises with strain to a peak (at about 65
    ``gamma_r`` for ``a = 0.86``) and then falls; pystrata keeps its damping curve from
    falling with a running maximum over its strain grid, and this function holds the
    damping at the peak value beyond ``peak_strain`` (the running maximum of the
    continuous curve). Below ``peak_strain`` both are the same formula; above it
    pystrata holds the value of its last grid point before the peak, which is at most
    this peak value. Example: 100 kPa, ``Cu = 1.5``: ``G/Gmax`` = 0.872, 0.727,
    0.486, 0.115 at ``gamma`` = 1e-4, 3e-4, 1e-3, 1e-2 (``gamma_r`` = 0.0935 %,
    ``a`` = 0.859).
    """
    g = _strain(gamma)
    if not (np.isfinite(mean_stress) and mean_stress > 0):
        raise ParameterError("mean_stress", mean_stress, "must be finite and > 0 (Pa)")
    if not (np.isfinite(uniformity_coefficient) and uniformity_coefficient >= 1):
        raise ParameterError("uniformity_coefficient", uniformity_coefficient,
                             "the coefficient of uniformity D60/D10 must be finite and >= 1")
    if not (np.isfinite(d50) and 0 < d50 <= MENQ_D50_MAX):
        raise ParameterError("d50", d50, f"must lie in (0, {MENQ_D50_MAX:g}] m (a length in metres: "
                             "0.2 mm is 2e-4)")
    if not (np.isfinite(n_cycles) and n_cycles > 0):
        raise ParameterError("n_cycles", n_cycles, "must be finite and > 0")
    cu, s = float(uniformity_coefficient), float(mean_stress) / P_ATM
    gr_pct = 0.12 * cu ** -0.6 * s ** (0.5 * cu ** -0.15)
    a = 0.86 + 0.1 * np.log10(s)
    ratio = 1.0 / (1.0 + (100.0 * g / gr_pct) ** a)
    dmin_pct = 0.55 * cu ** 0.1 * (1e3 * float(d50)) ** -0.3 * s ** -0.08
    b = 0.6329 - 0.00566 * np.log(n_cycles)
    x_peak = _menq_masing_peak(a)
    g_pct = np.minimum(100.0 * g, x_peak * gr_pct)  # the damping is held at its peak beyond it
    d_pct = b * (1.0 + (g_pct / gr_pct) ** a) ** -0.1 * _masing_modified_pct(g_pct, gr_pct, a) + dmin_pct
    return MenqCurves(g, ratio, d_pct / 100.0, gr_pct / 100.0, float(a), dmin_pct / 100.0, float(b),
                      x_peak * gr_pct / 100.0, cu, float(d50), float(mean_stress), float(n_cycles))


@dataclass(frozen=True)
class HardinRichart:
    """Empirical small-strain shear modulus (see :func:`hardin_richart`).

    Attributes
    ----------
    G_round, G_angular : float
        Gmax [Pa] for round-grained (Ottawa) and angular-grained (crushed quartz) sand.
    void_ratio, mean_stress : float
        Inputs (mean stress in Pa).
    in_range_round, in_range_angular : bool
        Whether the void ratio lies in the range the relation was fitted on.
    citation : str
    """

    G_round: float
    G_angular: float
    void_ratio: float
    mean_stress: float
    in_range_round: bool
    in_range_angular: bool
    citation: str = ("Hardin, B. O. & Richart, F. E. (1963). Elastic wave velocities in granular "
                     "soils. J. Soil Mech. Found. Div. ASCE 89(SM1), 33-65")


def hardin_richart(void_ratio: float, mean_stress: float) -> HardinRichart:
    """Hardin & Richart (1963) small-strain shear modulus of dry clean sand.

    ``G = A (B - e)^2 / (1 + e) * sqrt(sigma'_0)`` with ``G`` and ``sigma'_0`` in kPa:

    * round grains (Ottawa sand, fitted for ``e`` 0.3-0.8): ``A = 6908``, ``B = 2.17``;
    * angular grains (crushed quartz, ``e`` 0.6-1.3): ``A = 3230``, ``B = 2.97``.

    The coefficients are the psi forms ``2630`` and ``1230`` (the round-grain form is seed
    Eq. 6.3, Hardin & Black 1968) times ``sqrt(6.894757)`` for kPa. Example: ``e = 0.65``,
    ``100 kPa`` gives 96.7 MPa (round) and 105.4 MPa (angular).

    Parameters
    ----------
    void_ratio : float
        Void ratio ``e`` (> 0 and below ``B``).
    mean_stress : float
        Mean effective stress [Pa] (> 0).
    """
    if not (np.isfinite(void_ratio) and 0 < void_ratio < 2.17):
        raise ParameterError("void_ratio", void_ratio, "must lie in (0, 2.17) for Hardin-Richart")
    if not (np.isfinite(mean_stress) and mean_stress > 0):
        raise ParameterError("mean_stress", mean_stress, "must be finite and > 0 (Pa)")
    e = float(void_ratio)
    root = np.sqrt(mean_stress / 1e3)  # sqrt(kPa)
    g_round = 6908.0 * (2.17 - e) ** 2 / (1.0 + e) * root * 1e3
    g_ang = 3230.0 * (2.97 - e) ** 2 / (1.0 + e) * root * 1e3
    return HardinRichart(float(g_round), float(g_ang), e, float(mean_stress),
                         bool(0.3 <= e <= 0.8), bool(0.6 <= e <= 1.3))


#: Upper bound of measured peak friction angles of sands [deg]: critical-state angle of
#: quartz sands ~33 deg plus Bolton's (1986) largest dilatancy contribution ~15-20 deg.
SAND_PEAK_FRICTION_DEG = 50.0


def mohr_coulomb_ratio(friction_angle: float) -> float:
    """Largest principal stress ratio on a cohesionless Mohr-Coulomb envelope.

    Largest principal stress ratio ``sigma1/sigma3 = (1 + sin phi)/(1 - sin phi)``
    on a Mohr-Coulomb envelope of friction angle ``phi`` [rad] without cohesion
    (e.g. 7.55 for 50 deg, 2.62 for the contact angle atan 0.5 = 26.6 deg).
    """
    if not (np.isfinite(friction_angle) and 0 <= friction_angle < np.pi / 2):
        raise ParameterError("friction_angle", friction_angle, "must lie in [0, pi/2) rad")
    sn = np.sin(friction_angle)
    return float((1 + sn) / (1 - sn))


#: critical-state friction angle of quartz and feldspar sands [deg] (Bolton 1986: 33 deg,
#: measured 32-34 deg)
BOLTON_PHI_CS_DEG = 33.0
#: threshold cyclic shear strain below which strain-controlled cycles build no appreciable
#: pore pressure in sands, whatever their density (Dobry, Ladd, Yokel, Chung & Powell 1982,
#: NBS Building Science Series 138: about 0.01 %)
DOBRY_THRESHOLD_STRAIN = 1e-4


@dataclass(frozen=True)
class Bolton:
    """Bolton's (1986) strength of a sand at a relative density and mean effective stress.

    Attributes
    ----------
    relative_dilatancy : float
        ``I_R = D_r (Q - ln p') - R`` (``Q = 10``, ``R = 1``, ``p'`` in kPa), clipped to [0, 4].
    phi_cs, phi_peak : float
        Critical-state and peak friction angles [deg]; ``phi_peak = phi_cs + k I_R`` with
        ``k = 3`` (triaxial compression) or 5 (plane strain).
    dilatancy_rate : float
        Peak ``-(d eps_v / d eps_1)`` in triaxial compression, ``0.3 I_R`` (Bolton 1986),
        compression positive.
    """

    relative_dilatancy: float
    phi_cs: float
    phi_peak: float
    dilatancy_rate: float


def bolton(relative_density: float, mean_stress: float, *, test: str = "triaxial",
           phi_cs: float = BOLTON_PHI_CS_DEG) -> Bolton:
    """Bolton (1986), Geotechnique 36(1), "The strength and dilatancy of sands".

    ``I_R = D_r (10 - ln p') - 1`` with ``p'`` in kPa (quartz and feldspar sands),
    clipped to ``0 <= I_R <= 4``; ``phi_peak - phi_cs = 3 I_R`` in triaxial compression
    and ``5 I_R`` in plane strain [deg]; peak dilatancy rate
    ``-(d eps_v/d eps_1)_max = 0.3 I_R`` (triaxial). The relations as
    the project's reference sheet quotes them.

    Parameters
    ----------
    relative_density : float
        ``D_r`` as a fraction in [0, 1].
    mean_stress : float
        Mean effective stress ``p'`` at failure [Pa] (> 0).
    test : {"triaxial", "plane strain"}
    phi_cs : float
        Critical-state friction angle [deg] (33 for quartz sands).
    """
    if not (np.isfinite(relative_density) and 0.0 <= relative_density <= 1.0):
        raise ParameterError("relative_density", relative_density, "must be a fraction in [0, 1]")
    if not (np.isfinite(mean_stress) and mean_stress > 0):
        raise ParameterError("mean_stress", mean_stress, "must be finite and > 0 (Pa)")
    if test not in ("triaxial", "plane strain"):
        raise ParameterError("test", test, "must be 'triaxial' or 'plane strain'")
    ir = float(np.clip(relative_density * (10.0 - np.log(mean_stress / 1e3)) - 1.0, 0.0, 4.0))
    k = 3.0 if test == "triaxial" else 5.0
    return Bolton(ir, float(phi_cs), float(phi_cs + k * ir), 0.3 * ir)


def relative_density(void_ratio: float, e_min: float, e_max: float) -> float:
    """``D_r = (e_max - e) / (e_max - e_min)`` (may leave [0, 1] outside the two states)."""
    if not (np.isfinite(e_min) and np.isfinite(e_max) and e_max > e_min > 0):
        raise ParameterError("e_max", e_max, f"must be finite and above e_min = {e_min!r} > 0")
    return float((e_max - void_ratio) / (e_max - e_min))

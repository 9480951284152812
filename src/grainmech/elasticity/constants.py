"""Engineering constants, averages and constructors of stiffness tensors.

Engineering constants, Voigt/Reuss/Hill averages, isotropic constants and the
constructors of isotropic, transversely isotropic and orthotropic stiffnesses.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from types import MappingProxyType

import numpy as np

from grainmech.conventions import ORDER_2D, ORDER_3D, voigt_to_mandel
from grainmech.elasticity._mandel import (
    as_voigt,
    check_finite_symmetric,
    dimension,
    frame_from_axis,
    isotropic_moduli,
    isotropic_projection,
    unit_vectors,
)
from grainmech.elasticity.conversions import check_stiffness, compliance, rotate_stiffness
from grainmech.errors import GrainmechError, ParameterError


def _couplings(S: np.ndarray, order: Sequence[str], rtol: float) -> dict[str, float]:
    """Normal-shear and shear-shear coupling coefficients ``S_ab / S_bb``."""
    out: dict[str, float] = {}
    scale = float(np.max(np.abs(np.diag(S))))
    for b, lb in enumerate(order):
        for a, la in enumerate(order):
            if a == b or (la[0] == la[1] and lb[0] == lb[1]):
                continue  # the normal-normal ones are Poisson's ratios
            if abs(S[a, b]) > rtol * scale:
                out[f"eta_{la}_{lb}"] = float(S[a, b] / S[b, b])
    return out


@dataclass(frozen=True)
class EngineeringConstants:
    """Engineering constants of a 3D anisotropic stiffness in the given frame.

    The attribute names are the keys of :meth:`as_dict`; every value is a Python float.

    Attributes
    ----------
    E_xx, E_yy, E_zz : float
        Young's moduli ``1/S_11``, ``1/S_22``, ``1/S_33`` (units of ``C``).
    nu_xy, nu_yx, nu_xz, nu_zx, nu_yz, nu_zy : float
        Poisson's ratios, ``nu_ij = -e_jj / e_ii`` under uniaxial stress along ``i``
        (first index = loading direction), i.e. ``nu_ij = -S_ji / S_ii``.  Reciprocity:
        ``nu_ij / E_i = nu_ji / E_j``.
    G_yz, G_xz, G_xy : float
        Shear moduli ``1/S_44``, ``1/S_55``, ``1/S_66`` (Voigt compliance, engineering
        shear strain).
    couplings : mapping str -> float
        Non-zero coupling coefficients ``eta_<a>_<b> = S_ab / S_bb``: the strain component
        ``a`` (engineering shear for shear components) per unit strain ``b`` when only the
        stress component ``b`` acts (Lekhnitskii's coefficients of mutual influence and
        Chentsov's coefficients).  Empty for an orthotropic material in its axes.
    """

    E_xx: float
    E_yy: float
    E_zz: float
    nu_xy: float
    nu_yx: float
    nu_xz: float
    nu_zx: float
    nu_yz: float
    nu_zy: float
    G_yz: float
    G_xz: float
    G_xy: float
    couplings: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self) -> None:
        _floats(self)

    def as_dict(self) -> dict[str, float]:
        """Constants under the attribute names ``E_xx, E_yy, E_zz, nu_xy, ..., G_xy`` + the couplings."""
        return _as_dict(self)


@dataclass(frozen=True)
class PlaneEngineeringConstants:
    """Engineering constants of a 2D stiffness (the 2D material's own moduli).

    The attribute names are the keys of :meth:`as_dict`; every value is a Python float.

    Attributes
    ----------
    E_xx, E_yy : float
        ``1/S_11``, ``1/S_22``.
    nu_xy, nu_yx : float
        ``nu_ij = -S_ji / S_ii`` (first index = loading direction).
    G_xy : float
        ``1/S_33``.
    couplings : mapping str -> float
        Non-zero ``eta_<a>_<b> = S_ab / S_bb`` between normal and shear components.
    """

    E_xx: float
    E_yy: float
    nu_xy: float
    nu_yx: float
    G_xy: float
    couplings: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self) -> None:
        _floats(self)

    def as_dict(self) -> dict[str, float]:
        """Constants under the attribute names ``E_xx, E_yy, nu_xy, nu_yx, G_xy`` + the couplings."""
        return _as_dict(self)


def _floats(obj: EngineeringConstants | PlaneEngineeringConstants) -> None:
    """Store every constant (and coupling) of a frozen constants object as a Python float."""
    for f in fields(obj):
        v = getattr(obj, f.name)
        if f.name == "couplings":
            object.__setattr__(obj, f.name, MappingProxyType({str(k): float(x) for k, x in v.items()}))
        else:
            object.__setattr__(obj, f.name, float(v))


def _as_dict(obj: EngineeringConstants | PlaneEngineeringConstants) -> dict[str, float]:
    d = {f.name: getattr(obj, f.name) for f in fields(obj) if f.name != "couplings"}
    d.update(obj.couplings)
    return d


def engineering_constants(C: np.ndarray, coupling_tol: float = 1e-10
                          ) -> EngineeringConstants | PlaneEngineeringConstants:
    """Young's moduli, Poisson's ratios, shear moduli and couplings in the given frame.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Positive-definite stiffness, library order.
    coupling_tol : float
        Compliance entries with ``|S_ab| <= coupling_tol * max|S_aa|`` count as zero
        and produce no coupling coefficient.

    Returns
    -------
    EngineeringConstants (3D) or PlaneEngineeringConstants (2D)

    Notes
    -----
    From the Voigt compliance ``S = C^-1`` (Lekhnitskii 1981; Nye 1957):
    ``E_i = 1/S_ii``, ``nu_ij = -S_ji/S_ii`` (strain ``j`` over strain ``i`` under stress
    ``i``), ``G = 1/S_44`` etc.  The seed (Figs. 4.4-4.6) quotes ``nu_zx = nu_zy`` and
    ``nu_xy`` for its transversely isotropic packing (axis z); these equalities hold in
    this convention (and in the transposed one).
    """
    M, _ = as_voigt(C)
    S = compliance(M)
    cpl = MappingProxyType(_couplings(S, ORDER_3D if M.shape[0] == 6 else ORDER_2D,
                                      coupling_tol))
    if M.shape[0] == 3:
        return PlaneEngineeringConstants(
            E_xx=1 / S[0, 0], E_yy=1 / S[1, 1], nu_xy=-S[1, 0] / S[0, 0],
            nu_yx=-S[0, 1] / S[1, 1], G_xy=1 / S[2, 2], couplings=cpl)
    return EngineeringConstants(
        E_xx=1 / S[0, 0], E_yy=1 / S[1, 1], E_zz=1 / S[2, 2],
        nu_xy=-S[1, 0] / S[0, 0], nu_yx=-S[0, 1] / S[1, 1],
        nu_xz=-S[2, 0] / S[0, 0], nu_zx=-S[0, 2] / S[2, 2],
        nu_yz=-S[2, 1] / S[1, 1], nu_zy=-S[1, 2] / S[2, 2],
        G_yz=1 / S[3, 3], G_xz=1 / S[4, 4], G_xy=1 / S[5, 5], couplings=cpl)


_METHODS = ("voigt", "reuss", "hill")


def _method(method: str) -> str:
    m = str(method).lower()
    if m not in _METHODS:
        raise GrainmechError(f"method must be one of {_METHODS}; got {method!r}")
    return m


def bulk_modulus(C: np.ndarray, method: str = "hill") -> float:
    """Voigt, Reuss or Hill average bulk modulus (Hill 1952).

    Parameters
    ----------
    C : array
        Stiffness (Voigt 6x6 / 3x3 or tensor).  The Reuss and Hill averages need a
        positive-definite ``C``.
    method : {"voigt", "reuss", "hill"}

    Returns
    -------
    float, units of ``C``.

    Notes
    -----
    3D: ``K_V = (C11+C22+C33 + 2(C12+C13+C23))/9``,
    ``K_R = 1 / (S11+S22+S33 + 2(S12+S13+S23))``.
    2D (areal bulk modulus, ``mean in-plane stress / area strain``):
    ``K_V = (C11+C22+2C12)/4``, ``K_R = 1/(S11+S22+2S12)``.
    Hill = arithmetic mean of the two.  For an isotropic ``C`` all three coincide.
    """
    m = _method(method)
    M, _ = as_voigt(C)
    if M.shape[0] == 6:
        kv = (np.trace(M[:3, :3]) + 2 * (M[0, 1] + M[0, 2] + M[1, 2])) / 9.0
    else:
        kv = (M[0, 0] + M[1, 1] + 2 * M[0, 1]) / 4.0
    if m == "voigt":
        return float(kv)
    S = compliance(M)
    if M.shape[0] == 6:
        kr = 1.0 / (np.trace(S[:3, :3]) + 2 * (S[0, 1] + S[0, 2] + S[1, 2]))
    else:
        kr = 1.0 / (S[0, 0] + S[1, 1] + 2 * S[0, 1])
    return float(kr if m == "reuss" else 0.5 * (kv + kr))


def shear_modulus(C: np.ndarray, method: str = "hill") -> float:
    """Voigt, Reuss or Hill average shear modulus (Hill 1952).

    Parameters
    ----------
    C : array
        Stiffness (Voigt 6x6 / 3x3 or tensor).
    method : {"voigt", "reuss", "hill"}

    Returns
    -------
    float, units of ``C``.

    Notes
    -----
    3D: ``G_V = (C11+C22+C33 - (C12+C13+C23) + 3(C44+C55+C66))/15``,
    ``G_R = 15 / (4(S11+S22+S33) - 4(S12+S13+S23) + 3(S44+S55+S66))``.
    2D: ``G_V = (C11+C22-2C12+4C33)/8``, ``G_R = 2/(S11+S22-2S12+S33)`` (from the two
    isotropic invariants ``C_iijj`` and ``C_ijij``).
    """
    m = _method(method)
    M, _ = as_voigt(C)
    if M.shape[0] == 6:
        gv = (np.trace(M[:3, :3]) - (M[0, 1] + M[0, 2] + M[1, 2])
              + 3 * np.trace(M[3:, 3:])) / 15.0
    else:
        gv = (M[0, 0] + M[1, 1] - 2 * M[0, 1] + 4 * M[2, 2]) / 8.0
    if m == "voigt":
        return float(gv)
    S = compliance(M)
    if M.shape[0] == 6:
        gr = 15.0 / (4 * np.trace(S[:3, :3]) - 4 * (S[0, 1] + S[0, 2] + S[1, 2])
                     + 3 * np.trace(S[3:, 3:]))
    else:
        gr = 2.0 / (S[0, 0] + S[1, 1] - 2 * S[0, 1] + S[2, 2])
    return float(gr if m == "reuss" else 0.5 * (gv + gr))


@dataclass(frozen=True)
class IsotropicConstants:
    """The five isotropic constants (any two determine the rest).

    Attributes
    ----------
    E, nu, G, K, lam : float
        Young's modulus, Poisson's ratio, shear modulus, bulk modulus and Lame's first
        parameter.  For ``dim == 2`` these are the 2D material's own constants:
        ``K = lam + G`` (areal bulk modulus), ``E = 4KG/(K+G)``, ``nu = (K-G)/(K+G)``.
    dim : int
    """

    E: float
    nu: float
    G: float
    K: float
    lam: float
    dim: int = 3

    def as_dict(self) -> dict[str, float]:
        """``{"E", "nu", "G", "K", "lam"}``."""
        return {"E": self.E, "nu": self.nu, "G": self.G, "K": self.K, "lam": self.lam}


def _from_KG(K: float, G: float, dim: int) -> IsotropicConstants:
    if dim == 3:
        return IsotropicConstants(E=9 * K * G / (3 * K + G), nu=(3 * K - 2 * G) / (2 * (3 * K + G)),
                                  G=G, K=K, lam=K - 2 * G / 3, dim=3)
    return IsotropicConstants(E=4 * K * G / (K + G), nu=(K - G) / (K + G), G=G, K=K,
                              lam=K - G, dim=2)


def isotropic_constants(C: np.ndarray, tol: float = 1e-6) -> IsotropicConstants:
    """Exact isotropic constants of an isotropic stiffness.

    Parameters
    ----------
    C : array
        Stiffness (Voigt 6x6 / 3x3 or tensor).
    tol : float
        ``C`` counts as isotropic if ``||C - P_iso(C)|| <= tol ||C||`` (Frobenius norm of
        the tensor, i.e. of the Mandel matrix), where ``P_iso`` is the orthogonal
        projection onto isotropic tensors.

    Returns
    -------
    IsotropicConstants

    Raises
    ------
    GrainmechError
        If ``C`` is not isotropic within ``tol`` (gives the relative distance) or is not
        symmetric/finite.
    """
    M, _ = as_voigt(C)
    check_finite_symmetric(M, 1e-10)
    dim = dimension(M)
    Mm = voigt_to_mandel(M)
    P = isotropic_projection(Mm, dim)
    r = np.linalg.norm(Mm - P) / np.linalg.norm(Mm)
    if r > tol:
        raise GrainmechError(
            f"C is not isotropic: relative distance to its isotropic projection is "
            f"{r:.3g} > tol = {tol:g}")
    K, G = isotropic_moduli(Mm, dim)
    return _from_KG(K, G, dim)


def _pair_to_KG(given: dict[str, float], dim: int) -> tuple[float, float]:
    """Closed-form (K, G) from any two of E, nu, G, K, lam (3D or 2D relations)."""
    g = given
    keys = frozenset(g)
    # a constant not given is NaN: only the two given are used by the branch that matches
    E, nu, G, K, lam = (g.get(k, math.nan) for k in ("E", "nu", "G", "K", "lam"))
    if dim == 3:
        if keys == {"E", "nu"}:
            return E / (3 * (1 - 2 * nu)), E / (2 * (1 + nu))
        if keys == {"E", "G"}:
            return E * G / (3 * (3 * G - E)), G
        if keys == {"E", "K"}:
            return K, 3 * K * E / (9 * K - E)
        if keys == {"E", "lam"}:
            R = np.sqrt(E ** 2 + 9 * lam ** 2 + 2 * E * lam)
            return (E + 3 * lam + R) / 6, (E - 3 * lam + R) / 4
        if keys == {"nu", "G"}:
            return 2 * G * (1 + nu) / (3 * (1 - 2 * nu)), G
        if keys == {"nu", "K"}:
            return K, 3 * K * (1 - 2 * nu) / (2 * (1 + nu))
        if keys == {"nu", "lam"}:
            return lam * (1 + nu) / (3 * nu), lam * (1 - 2 * nu) / (2 * nu)
        if keys == {"G", "K"}:
            return K, G
        if keys == {"G", "lam"}:
            return lam + 2 * G / 3, G
        if keys == {"K", "lam"}:
            return K, 1.5 * (K - lam)
    else:
        if keys == {"E", "nu"}:
            return E / (2 * (1 - nu)), E / (2 * (1 + nu))
        if keys == {"E", "G"}:
            return E * G / (4 * G - E), G
        if keys == {"E", "K"}:
            return K, E * K / (4 * K - E)
        if keys == {"E", "lam"}:
            b = 4 * lam - 2 * E
            G_ = (-b + np.sqrt(b * b + 16 * E * lam)) / 8
            return lam + G_, G_
        if keys == {"nu", "G"}:
            return G * (1 + nu) / (1 - nu), G
        if keys == {"nu", "K"}:
            return K, K * (1 - nu) / (1 + nu)
        if keys == {"nu", "lam"}:
            G_ = lam * (1 - nu) / (2 * nu)
            return lam + G_, G_
        if keys == {"G", "K"}:
            return K, G
        if keys == {"G", "lam"}:
            return lam + G, G
        if keys == {"K", "lam"}:
            return K, K - lam
    raise AssertionError("unreachable")  # pragma: no cover


def isotropic_stiffness(E: float | None = None, nu: float | None = None,
                        G: float | None = None, K: float | None = None,
                        lam: float | None = None, dim: int = 3) -> np.ndarray:
    """Isotropic Voigt stiffness from any two of ``E, nu, G, K, lam``.

    Parameters
    ----------
    E, nu, G, K, lam : float, optional
        Exactly two must be given.  In 2D (``dim=2``) they are the 2D material's own
        constants (``K = lam + G`` the areal bulk modulus, ``E = 4KG/(K+G)``,
        ``nu = (K-G)/(K+G)``).
    dim : {2, 3}

    Returns
    -------
    array, shape (6, 6) or (3, 3)
        ``C11 = lam + 2G``, ``C12 = lam``, shear diagonal ``G``.

    Raises
    ------
    GrainmechError
        Not exactly two constants, a degenerate pair (e.g. ``nu`` with ``lam = 0``), or a
        result that is not positive definite (e.g. ``nu >= 1/2`` in 3D).
    """
    if dim not in (2, 3):
        raise GrainmechError(f"dim must be 2 or 3; got {dim!r}")
    given = {k: v for k, v in (("E", E), ("nu", nu), ("G", G), ("K", K), ("lam", lam))
             if v is not None}
    if len(given) != 2:
        raise GrainmechError(
            f"give exactly two of E, nu, G, K, lam; got {sorted(given) or 'none'}")
    for k, v in given.items():
        if not np.isfinite(v):
            raise GrainmechError(f"{k} = {v!r} is not finite")
    with np.errstate(divide="ignore", invalid="ignore"):
        Kb, Gs = _pair_to_KG({k: float(v) for k, v in given.items()}, dim)
    if not (np.isfinite(Kb) and np.isfinite(Gs)):
        raise GrainmechError(f"the pair {given} does not determine an isotropic material")
    lam_ = Kb - (2 * Gs / 3 if dim == 3 else Gs)
    n = 6 if dim == 3 else 3
    M = np.zeros((n, n))
    M[:dim, :dim] = lam_
    M[range(dim), range(dim)] = lam_ + 2 * Gs
    M[range(dim, n), range(dim, n)] = Gs
    try:
        check_stiffness(M)
    except GrainmechError as exc:
        raise GrainmechError(
            f"isotropic constants {given} give K = {Kb:.6g}, G = {Gs:.6g}: not a "
            f"positive-definite stiffness ({exc})") from None
    return M


def _from_compliance(S: np.ndarray, what: str, params: dict[str, float]) -> np.ndarray:
    try:
        lam = np.linalg.eigvalsh(voigt_to_mandel(np.linalg.inv(S)))
    except np.linalg.LinAlgError:
        lam = np.array([-1.0])
    if not lam[0] > 0:
        raise GrainmechError(f"{what} constants {params} do not give a positive-definite "
                             f"stiffness (smallest Kelvin modulus {lam[0]:.6g})")
    C = np.linalg.inv(S)
    return 0.5 * (C + C.T)


def orthotropic_stiffness(E_xx: float, E_yy: float, E_zz: float, nu_xy: float, nu_xz: float,
                          nu_yz: float, G_yz: float, G_xz: float, G_xy: float) -> np.ndarray:
    """Orthotropic Voigt stiffness (axes x, y, z) from engineering constants.

    Parameters
    ----------
    E_xx, E_yy, E_zz : float
        Young's moduli (the names of :class:`EngineeringConstants`).
    nu_xy, nu_xz, nu_yz : float
        Poisson's ratios ``nu_ij = -e_jj/e_ii`` under stress along ``i``; the transposed
        ones follow from reciprocity ``nu_ji = nu_ij E_j / E_i``.
    G_yz, G_xz, G_xy : float
        Shear moduli.

    Returns
    -------
    array, shape (6, 6)

    Raises
    ------
    GrainmechError
        If the constants do not give a positive-definite stiffness.
    """
    params = dict(E_xx=E_xx, E_yy=E_yy, E_zz=E_zz, nu_xy=nu_xy, nu_xz=nu_xz, nu_yz=nu_yz,
                  G_yz=G_yz, G_xz=G_xz, G_xy=G_xy)
    for k in ("E_xx", "E_yy", "E_zz", "G_yz", "G_xz", "G_xy"):
        if not params[k] > 0:
            raise GrainmechError(f"{k} must be positive; got {params[k]!r}")
    S = np.zeros((6, 6))
    S[0, 0], S[1, 1], S[2, 2] = 1 / E_xx, 1 / E_yy, 1 / E_zz
    S[0, 1] = S[1, 0] = -nu_xy / E_xx
    S[0, 2] = S[2, 0] = -nu_xz / E_xx
    S[1, 2] = S[2, 1] = -nu_yz / E_yy
    S[3, 3], S[4, 4], S[5, 5] = 1 / G_yz, 1 / G_xz, 1 / G_xy
    return _from_compliance(S, "orthotropic", params)


def transversely_isotropic_stiffness(E_p: float, nu_p: float, E_a: float, nu_ap: float,
                                     G_a: float, axis: Sequence[float] = (0.0, 0.0, 1.0)
                                     ) -> np.ndarray:
    """Transversely isotropic Voigt stiffness from engineering constants.

    Parameters
    ----------
    E_p, nu_p : float
        Young's modulus and Poisson's ratio in the plane of isotropy (``E_x = E_y``,
        ``nu_xy``); the in-plane shear modulus is ``E_p / (2 (1 + nu_p))``.
    E_a : float
        Young's modulus along the axis (``E_z``).
    nu_ap : float
        Poisson's ratio for loading along the axis and lateral strain in the plane
        (``nu_zx = nu_zy``).
    G_a : float
        Shear modulus in planes containing the axis (``G_xz = G_yz``).
    axis : 3-vector
        Symmetry axis (normalised); the tensor is built with axis z and rotated.

    Returns
    -------
    array, shape (6, 6)
    """
    nu_pa = nu_ap * E_p / E_a  # nu_xz from reciprocity
    C = orthotropic_stiffness(E_p, E_p, E_a, nu_p, nu_pa, nu_pa, G_a, G_a,
                              E_p / (2 * (1 + nu_p)))
    a = unit_vectors(axis, 3, "axis")
    return rotate_stiffness(C, frame_from_axis(a).T)


def condensed_modulus(C: np.ndarray, component: int, stress_control: Sequence[bool]) -> float:
    """Small-strain modulus ``d sigma_k / d eps_k`` with the other components controlled.

    Strain-controlled components are held (zero increment), stress-controlled ones free
    (zero stress increment): ``C_kk - C_kS C_SS^-1 C_Sk``.
    """
    sc = np.asarray(stress_control, dtype=bool)
    C = np.asarray(C, dtype=float)
    k = int(component)
    if sc[k]:
        raise ParameterError("component", k, "must be strain controlled")
    if not sc.any():
        return float(C[k, k])
    return float(C[k, k] - C[k, sc] @ np.linalg.solve(C[np.ix_(sc, sc)], C[sc, k]))

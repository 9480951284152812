"""Stiffness and compliance tensors: checks, engineering constants, directional moduli,
averages, rotations and material-symmetry classification.

All functions take a stiffness in the library conventions of :mod:`grainmech.conventions`:

* 3D: a 6x6 *Voigt* matrix in the order ``(xx, yy, zz, yz, xz, xy)`` that maps the
  engineering strain ``(e_xx, e_yy, e_zz, 2 e_yz, 2 e_xz, 2 e_xy)`` to the stress, or a
  ``(3, 3, 3, 3)`` tensor ``C_ijkl``;
* 2D: a 3x3 Voigt matrix in the order ``(xx, yy, xy)`` or a ``(2, 2, 2, 2)`` tensor.  A 2D
  stiffness is treated as the 2D material's own stiffness (for a plane-strain stiffness
  the 2D "Young's modulus" is therefore the plane-strain modulus, e.g. ``E / (1 - nu^2)``
  for an isotropic solid).

Internally the *Mandel* (Kelvin) form is used wherever a rotation or a norm is needed: it
is an isometry, so the Frobenius norm of a 6x6 Mandel matrix equals the norm
``sqrt(C_ijkl C_ijkl)`` of the tensor, and a rotation acts as ``M' = K M K^T`` with an
orthogonal 6x6 ``K``.

Units: moduli come out in the units of the stiffness; Poisson's ratios and coupling
coefficients are dimensionless.

References
----------
Nye, J. F. (1957). *Physical Properties of Crystals*. Oxford: Clarendon Press.
Hill, R. (1952). The elastic behaviour of a crystalline aggregate. *Proc. Phys. Soc. A*
65, 349-354.
Lekhnitskii, S. G. (1981). *Theory of Elasticity of an Anisotropic Body*. Moscow: Mir.
Cowin, S. C. & Mehrabadi, M. M. (1987). On the identification of material symmetry for
anisotropic elastic materials. *Q. J. Mech. Appl. Math.* 40, 451-476.
Mehrabadi, M. M. & Cowin, S. C. (1990). Eigentensors of linear anisotropic elastic
materials. *Q. J. Mech. Appl. Math.* 43, 15-41.
Forte, S. & Vianello, M. (1996). Symmetry classes for elasticity tensors. *J. Elasticity*
43, 81-108.
Ting, T. C. T. (1996). *Anisotropic Elasticity: Theory and Applications*. Oxford UP.
Chang, C. S. (1988). The seed report, Section 4.3 and Table 1 (material symmetries).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from functools import lru_cache
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from grainmech.conventions import (
    ORDER_2D,
    ORDER_3D,
    mandel_to_voigt,
    matrix_to_tensor4,
    stress_to_vector,
    tensor4_to_matrix,
    voigt_to_mandel,
)
from grainmech.errors import GrainmechError

__all__ = [
    "SYMMETRY_CLASSES_3D",
    "SYMMETRY_CLASSES_2D",
    "SEED_NAMES",
    "N_INDEPENDENT",
    "check_stiffness",
    "compliance",
    "kelvin_moduli",
    "contracted_tensors",
    "EngineeringConstants",
    "PlaneEngineeringConstants",
    "engineering_constants",
    "directional_young",
    "directional_poisson",
    "directional_shear",
    "bulk_modulus",
    "shear_modulus",
    "IsotropicConstants",
    "isotropic_constants",
    "isotropic_stiffness",
    "transversely_isotropic_stiffness",
    "orthotropic_stiffness",
    "rotation_about",
    "rotate_stiffness",
    "SymmetryClass",
    "symmetry_class",
    "symmetric_projection",
]

#: Names of the eight elastic symmetry classes (Forte & Vianello 1996), highest first.
SYMMETRY_CLASSES_3D: tuple[str, ...] = (
    "isotropic", "cubic", "transversely isotropic", "tetragonal", "trigonal",
    "orthotropic", "monoclinic", "triclinic",
)
#: Names of the four 2D elastic symmetry classes, highest first.
SYMMETRY_CLASSES_2D: tuple[str, ...] = ("isotropic", "square", "orthotropic", "anisotropic")

#: Number of independent elastic constants in the natural frame of each class.
N_INDEPENDENT: Mapping[str, int] = MappingProxyType({
    "isotropic": 2, "cubic": 3, "transversely isotropic": 5, "tetragonal": 6,
    "trigonal": 6, "orthotropic": 9, "monoclinic": 13, "triclinic": 21,
    "square": 3, "anisotropic": 6,
})

#: The seed's names (Chang 1988, Table 1) for the classes it covers.  The seed's
#: "orthotropic with non-coincident stress axes" is the 13-constant *matrix form* of
#: Table 1 (normal stresses coupled to the xy shear strain), i.e. the monoclinic pattern;
#: an orthotropic tensor whose axes are not the coordinate axes also gets this seed name.
SEED_NAMES: Mapping[str, str] = MappingProxyType({
    "isotropic": "isotropic",
    "transversely isotropic": "transverse isotropic",
    "tetragonal": "tetragonal",
    "orthotropic": "orthotropic",
    "monoclinic": "orthotropic with non-coincident stress axes",
})

_SQ2 = float(np.sqrt(2.0))


# ---------------------------------------------------------------------------------------
# input handling
# ---------------------------------------------------------------------------------------

def _as_voigt(C: np.ndarray, name: str = "C") -> tuple[np.ndarray, bool]:
    """Return ``(voigt_matrix, was_tensor4)``; shape errors name the argument."""
    arr = np.asarray(C, dtype=float)
    if arr.shape in ((3, 3, 3, 3), (2, 2, 2, 2)):
        return tensor4_to_matrix(arr), True
    if arr.shape in ((6, 6), (3, 3)):
        return arr.copy(), False
    raise GrainmechError(
        f"{name} must be a 6x6 (3D) or 3x3 (2D) Voigt matrix or a (3,3,3,3)/(2,2,2,2) "
        f"tensor; got shape {arr.shape}")


def _dim(M: np.ndarray) -> int:
    return 3 if M.shape[0] == 6 else 2


def _output(M: np.ndarray, tensor4: bool) -> np.ndarray:
    return matrix_to_tensor4(M) if tensor4 else M


def _check_finite_symmetric(M: np.ndarray, tol: float, name: str = "C") -> None:
    if not np.all(np.isfinite(M)):
        bad = np.argwhere(~np.isfinite(M))[0]
        raise GrainmechError(
            f"{name} has a non-finite entry {name}[{bad[0]}, {bad[1]}] = {M[tuple(bad)]!r}")
    scale = float(np.max(np.abs(M)))
    if scale == 0.0:
        raise GrainmechError(f"{name} is identically zero")
    asym = np.abs(M - M.T)
    i, j = np.unravel_index(np.argmax(asym), asym.shape)
    if asym[i, j] > tol * scale:
        raise GrainmechError(
            f"{name} is not symmetric: {name}[{i}, {j}] = {M[i, j]:.6g} but "
            f"{name}[{j}, {i}] = {M[j, i]:.6g} (relative difference "
            f"{asym[i, j] / scale:.3g} > tol = {tol:g})")


# ---------------------------------------------------------------------------------------
# checks, compliance, Kelvin moduli
# ---------------------------------------------------------------------------------------

def kelvin_moduli(C: np.ndarray) -> np.ndarray:
    """Eigenvalues of the Mandel (Kelvin) stiffness matrix, ascending.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Stiffness (library Voigt order, or tensor).

    Returns
    -------
    array, shape (6,) or (3,)
        The Kelvin moduli (Mehrabadi & Cowin 1990), units of ``C``.  They are the
        eigenvalues of ``C`` as a map on symmetric tensors and do not depend on the frame.
        Their multiplicities are a necessary (not sufficient) symmetry fingerprint:
        isotropic (1, 5), cubic (1, 2, 3), transversely isotropic at least two double
        eigenvalues.
    """
    M, _ = _as_voigt(C)
    Mm = voigt_to_mandel(M)
    return np.linalg.eigvalsh(0.5 * (Mm + Mm.T))


def check_stiffness(C: np.ndarray, tol: float = 1e-10, name: str = "C") -> np.ndarray:
    """Check that a stiffness is finite, symmetric and positive definite.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Stiffness (library Voigt order, or tensor).
    tol : float
        Relative tolerance.  Symmetry: ``|C_ij - C_ji| <= tol * max|C|``.  Positive
        definiteness: the smallest Kelvin modulus must exceed ``tol * largest``.
    name : str
        Name of the argument used in error messages.

    Returns
    -------
    array
        The Kelvin moduli (eigenvalues of the Mandel matrix), ascending.

    Raises
    ------
    GrainmechError
        Wrong shape, non-finite entries, asymmetry, or not positive definite (the message
        gives the smallest and largest Kelvin moduli).
    """
    M, _ = _as_voigt(C, name)
    _check_finite_symmetric(M, tol, name)
    lam = kelvin_moduli(0.5 * (M + M.T))
    if not lam[0] > tol * abs(lam[-1]):
        raise GrainmechError(
            f"{name} is not positive definite: smallest Kelvin (Mandel) eigenvalue = "
            f"{lam[0]:.6g}, largest = {lam[-1]:.6g} (all eigenvalues: "
            f"{np.array2string(lam, precision=4)})")
    return lam


def compliance(C: np.ndarray, tol: float = 1e-10) -> np.ndarray:
    """Compliance (inverse stiffness).

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Positive-definite stiffness.  A Voigt matrix (acting on engineering strain) gives
        a Voigt compliance ``S = C^-1`` that maps the stress vector to the engineering
        strain vector (so ``S_44 = 1/G_yz``).  A tensor gives the compliance tensor
        ``S_ijkl`` with ``e_ij = S_ijkl s_kl`` (inverted through the Mandel form, so the
        factors of 2 and 4 on shear entries are right).
    tol : float
        Passed to :func:`check_stiffness`.

    Returns
    -------
    array, same shape as ``C``, units 1/[C].

    Raises
    ------
    GrainmechError
        If ``C`` is singular or not positive definite (naming the smallest eigenvalue).
    """
    M, t4 = _as_voigt(C)
    check_stiffness(M, tol)
    M = 0.5 * (M + M.T)
    if t4:
        Sm = np.linalg.inv(voigt_to_mandel(M))
        return matrix_to_tensor4(0.5 * (Sm + Sm.T), mandel=True)
    S = np.linalg.inv(M)
    return 0.5 * (S + S.T)


def contracted_tensors(C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two contracted second-order tensors of Cowin & Mehrabadi (1987).

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)

    Returns
    -------
    d, v : arrays, shape (dim, dim)
        Dilatational ``d_ij = C_ijkk`` and Voigt ``v_ij = C_ikjk`` tensors.  The normal of
        every symmetry plane of ``C`` is an eigenvector of both.
    """
    M, _ = _as_voigt(C)
    T = matrix_to_tensor4(M)
    return np.einsum("ijkk->ij", T), np.einsum("ikjk->ij", T)


# ---------------------------------------------------------------------------------------
# engineering constants
# ---------------------------------------------------------------------------------------

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

    Attributes
    ----------
    E_x, E_y, E_z : float
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

    E_x: float
    E_y: float
    E_z: float
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

    def as_dict(self) -> dict[str, float]:
        """Constants under stable keys ``E_xx, E_yy, E_zz, nu_xy, ..., G_xy`` + couplings."""
        d = {
            "E_xx": self.E_x, "E_yy": self.E_y, "E_zz": self.E_z,
            "nu_xy": self.nu_xy, "nu_yx": self.nu_yx, "nu_xz": self.nu_xz,
            "nu_zx": self.nu_zx, "nu_yz": self.nu_yz, "nu_zy": self.nu_zy,
            "G_yz": self.G_yz, "G_xz": self.G_xz, "G_xy": self.G_xy,
        }
        d.update(self.couplings)
        return d


@dataclass(frozen=True)
class PlaneEngineeringConstants:
    """Engineering constants of a 2D stiffness (the 2D material's own moduli).

    Attributes
    ----------
    E_x, E_y : float
        ``1/S_11``, ``1/S_22``.
    nu_xy, nu_yx : float
        ``nu_ij = -S_ji / S_ii`` (first index = loading direction).
    G_xy : float
        ``1/S_33``.
    couplings : mapping str -> float
        Non-zero ``eta_<a>_<b> = S_ab / S_bb`` between normal and shear components.
    """

    E_x: float
    E_y: float
    nu_xy: float
    nu_yx: float
    G_xy: float
    couplings: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    def as_dict(self) -> dict[str, float]:
        """Constants under stable keys ``E_xx, E_yy, nu_xy, nu_yx, G_xy`` + couplings."""
        d = {"E_xx": self.E_x, "E_yy": self.E_y, "nu_xy": self.nu_xy,
             "nu_yx": self.nu_yx, "G_xy": self.G_xy}
        d.update(self.couplings)
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
    M, _ = _as_voigt(C)
    S = compliance(M)
    cpl = MappingProxyType(_couplings(S, ORDER_3D if M.shape[0] == 6 else ORDER_2D,
                                      coupling_tol))
    if M.shape[0] == 3:
        return PlaneEngineeringConstants(
            E_x=1 / S[0, 0], E_y=1 / S[1, 1], nu_xy=-S[1, 0] / S[0, 0],
            nu_yx=-S[0, 1] / S[1, 1], G_xy=1 / S[2, 2], couplings=cpl)
    return EngineeringConstants(
        E_x=1 / S[0, 0], E_y=1 / S[1, 1], E_z=1 / S[2, 2],
        nu_xy=-S[1, 0] / S[0, 0], nu_yx=-S[0, 1] / S[1, 1],
        nu_xz=-S[2, 0] / S[0, 0], nu_zx=-S[0, 2] / S[2, 2],
        nu_yz=-S[2, 1] / S[1, 1], nu_zy=-S[1, 2] / S[2, 2],
        G_yz=1 / S[3, 3], G_xz=1 / S[4, 4], G_xy=1 / S[5, 5], couplings=cpl)


# ---------------------------------------------------------------------------------------
# directional moduli
# ---------------------------------------------------------------------------------------

def _unit(v: np.ndarray, dim: int, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (dim,):
        raise GrainmechError(f"{name} must have trailing dimension {dim}; got shape {v.shape}")
    nrm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(~np.isfinite(nrm)) or np.any(nrm == 0):
        raise GrainmechError(f"{name} contains a zero or non-finite vector")
    return v / nrm


def _mandel_compliance(C: np.ndarray) -> tuple[np.ndarray, int]:
    M, _ = _as_voigt(C)
    check_stiffness(M)
    Sm = np.linalg.inv(voigt_to_mandel(0.5 * (M + M.T)))
    return 0.5 * (Sm + Sm.T), _dim(M)


def directional_young(C: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Young's modulus along direction(s) ``d``: ``E(d) = 1 / (d d : S : d d)``.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3) or tensor
        Positive-definite stiffness.
    d : array, shape (..., 3) or (..., 2)
        Direction(s); normalised internally.

    Returns
    -------
    array, shape (...)
        Units of ``C``.  Equals ``E_x`` for ``d = (1, 0, 0)`` etc.
    """
    Sm, dim = _mandel_compliance(C)
    n = _unit(d, dim, "d")
    a = stress_to_vector(n[..., :, None] * n[..., None, :], mandel=True)
    return 1.0 / np.einsum("...a,ab,...b->...", a, Sm, a)


def directional_poisson(C: np.ndarray, d: np.ndarray, m: np.ndarray,
                        atol: float = 1e-8) -> np.ndarray:
    """Poisson's ratio for loading along ``d`` and lateral direction ``m``.

    ``nu(d, m) = -e_mm / e_dd = -E(d) (m m : S : d d)`` under uniaxial stress along ``d``.

    Parameters
    ----------
    C : array
        Positive-definite stiffness.
    d, m : arrays, shape (..., 3) or (..., 2), broadcastable
        Loading and lateral directions (normalised internally); must be orthogonal.
    atol : float
        Tolerance on ``|d . m|`` after normalisation.

    Returns
    -------
    array, shape (...)
        Dimensionless.  ``directional_poisson(C, ex, ey) == engineering_constants(C).nu_xy``.
    """
    Sm, dim = _mandel_compliance(C)
    n = _unit(d, dim, "d")
    t = _unit(m, dim, "m")
    dot = np.abs(np.sum(n * t, axis=-1))
    if np.any(dot > atol):
        raise GrainmechError(f"m must be orthogonal to d; max |d . m| = {np.max(dot):.3g}")
    a = stress_to_vector(n[..., :, None] * n[..., None, :], mandel=True)
    b = stress_to_vector(t[..., :, None] * t[..., None, :], mandel=True)
    return -np.einsum("...a,ab,...b->...", b, Sm, a) / np.einsum("...a,ab,...b->...", a, Sm, a)


def directional_shear(C: np.ndarray, d: np.ndarray, m: np.ndarray,
                      atol: float = 1e-8) -> np.ndarray:
    """Shear modulus in the plane of orthogonal directions ``d`` and ``m``.

    ``G(d, m) = 1 / (4 sym(d m) : S : sym(d m))`` -- the ratio of the shear stress
    ``s_dm`` to the engineering shear strain ``2 e_dm`` when only ``s_dm`` acts.

    Parameters
    ----------
    C : array
        Positive-definite stiffness.
    d, m : arrays, shape (..., 3) or (..., 2), broadcastable, orthogonal.

    Returns
    -------
    array, shape (...), units of ``C``.  ``G(ey, ez) = G_yz``.
    """
    Sm, dim = _mandel_compliance(C)
    n = _unit(d, dim, "d")
    t = _unit(m, dim, "m")
    dot = np.abs(np.sum(n * t, axis=-1))
    if np.any(dot > atol):
        raise GrainmechError(f"m must be orthogonal to d; max |d . m| = {np.max(dot):.3g}")
    P = 0.5 * (n[..., :, None] * t[..., None, :] + t[..., :, None] * n[..., None, :])
    a = stress_to_vector(P, mandel=True)
    return 1.0 / (4.0 * np.einsum("...a,ab,...b->...", a, Sm, a))


# ---------------------------------------------------------------------------------------
# averages and isotropic constants
# ---------------------------------------------------------------------------------------

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
    M, _ = _as_voigt(C)
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
    M, _ = _as_voigt(C)
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


def _iso_projectors(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Mandel matrices of the spherical (J) and deviatoric (Kd) projectors."""
    m = np.zeros(6 if dim == 3 else 3)
    m[:dim] = 1.0
    J = np.outer(m, m) / dim
    return J, np.eye(m.size) - J


def _iso_KG(Mm: np.ndarray, dim: int) -> tuple[float, float]:
    """Bulk and shear moduli of the isotropic projection of a Mandel matrix."""
    J, Kd = _iso_projectors(dim)
    ndev = Kd.shape[0] - 1
    # P(C) = dim*K J + 2 G Kd  (3D: 3K J + 2G Kd; 2D: 2K J + 2G Kd)
    return float(np.sum(J * Mm)) / dim, float(np.sum(Kd * Mm)) / (2.0 * ndev)


def _iso_project(Mm: np.ndarray, dim: int) -> np.ndarray:
    J, Kd = _iso_projectors(dim)
    K, G = _iso_KG(Mm, dim)
    return dim * K * J + 2 * G * Kd


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
    M, _ = _as_voigt(C)
    _check_finite_symmetric(M, 1e-10)
    dim = _dim(M)
    Mm = voigt_to_mandel(M)
    P = _iso_project(Mm, dim)
    r = np.linalg.norm(Mm - P) / np.linalg.norm(Mm)
    if r > tol:
        raise GrainmechError(
            f"C is not isotropic: relative distance to its isotropic projection is "
            f"{r:.3g} > tol = {tol:g}")
    K, G = _iso_KG(Mm, dim)
    return _from_KG(K, G, dim)


def _pair_to_KG(given: dict[str, float], dim: int) -> tuple[float, float]:
    """Closed-form (K, G) from any two of E, nu, G, K, lam (3D or 2D relations)."""
    g = given
    keys = frozenset(g)
    E, nu, G, K, lam = (g.get(k) for k in ("E", "nu", "G", "K", "lam"))
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


def orthotropic_stiffness(E_x: float, E_y: float, E_z: float, nu_xy: float, nu_xz: float,
                          nu_yz: float, G_yz: float, G_xz: float, G_xy: float) -> np.ndarray:
    """Orthotropic Voigt stiffness (axes x, y, z) from engineering constants.

    Parameters
    ----------
    E_x, E_y, E_z : float
        Young's moduli.
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
    params = dict(E_x=E_x, E_y=E_y, E_z=E_z, nu_xy=nu_xy, nu_xz=nu_xz, nu_yz=nu_yz,
                  G_yz=G_yz, G_xz=G_xz, G_xy=G_xy)
    for k in ("E_x", "E_y", "E_z", "G_yz", "G_xz", "G_xy"):
        if not params[k] > 0:
            raise GrainmechError(f"{k} must be positive; got {params[k]!r}")
    S = np.zeros((6, 6))
    S[0, 0], S[1, 1], S[2, 2] = 1 / E_x, 1 / E_y, 1 / E_z
    S[0, 1] = S[1, 0] = -nu_xy / E_x
    S[0, 2] = S[2, 0] = -nu_xz / E_x
    S[1, 2] = S[2, 1] = -nu_yz / E_y
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
    a = _unit(axis, 3, "axis")
    return rotate_stiffness(C, _frame_from_axis(a).T)


# ---------------------------------------------------------------------------------------
# rotations
# ---------------------------------------------------------------------------------------

def rotation_about(axis: Sequence[float], angle: float) -> np.ndarray:
    """Proper rotation matrix by ``angle`` (radians, right-handed) about ``axis``."""
    a = _unit(axis, 3, "axis")
    return Rotation.from_rotvec(a * float(angle)).as_matrix()


@lru_cache(maxsize=2)
def _mandel_index(dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Index pairs (i, j) of the Mandel components and their weights (1 or sqrt 2)."""
    order = ORDER_3D if dim == 3 else ORDER_2D
    i = np.array(["xyz".index(lab[0]) for lab in order])
    j = np.array(["xyz".index(lab[1]) for lab in order])
    w = np.where(i == j, 1.0, _SQ2)
    return i, j, w


def _mandel_rot(R: np.ndarray) -> np.ndarray:
    """Orthogonal Mandel map ``K`` with ``M' = K M K^T`` for ``C'_ijkl = R_ia R_jb R_kc R_ld C_abcd``.

    ``R`` has shape (..., d, d); returns (..., m, m).  With ``(i, j)`` the index pair of
    Mandel component ``a`` and ``(k, l)`` that of ``b``,
    ``K_ab = w_a w_b (R_ik R_jl + R_il R_jk) / 2`` (``w = 1`` normal, ``sqrt 2`` shear),
    i.e. ``K_ab = B_a : (R B_b R^T)`` for the orthonormal Mandel basis ``B``.
    """
    R = np.asarray(R, dtype=float)
    i, j, w = _mandel_index(R.shape[-1])
    I, J = i[:, None], j[:, None]
    Kk, L = i[None, :], j[None, :]
    return (w[:, None] * w[None, :] / 2.0) * (R[..., I, Kk] * R[..., J, L] + R[..., I, L] * R[..., J, Kk])


def _check_orthogonal(R: np.ndarray, dim: int, atol: float = 1e-8) -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (dim, dim):
        raise GrainmechError(f"R must have shape (..., {dim}, {dim}) for this stiffness; "
                             f"got {R.shape}")
    err = np.max(np.abs(np.einsum("...ki,...kj->...ij", R, R) - np.eye(dim)))
    if not err <= atol:
        raise GrainmechError(f"R is not orthogonal: max |R^T R - I| = {err:.3g}")
    return R


def rotate_stiffness(C: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Transform a stiffness by an orthogonal matrix: ``C'_ijkl = R_ia R_jb R_kc R_ld C_abcd``.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
    R : array, shape (..., 3, 3) or (..., 2, 2)
        Orthogonal matrix (improper allowed).  If the rows of ``R`` are new basis vectors
        expressed in the old frame, ``C'`` holds the components in the new frame; if ``R``
        rotates the material, ``C'`` is the rotated material in the old frame.

    Returns
    -------
    array, shape (..., 6, 6) etc., in the same form (Voigt or tensor) as ``C``.
    """
    M, t4 = _as_voigt(C)
    dim = _dim(M)
    R = _check_orthogonal(R, dim)
    K = _mandel_rot(R)
    Mm = voigt_to_mandel(M)
    out = K @ Mm @ np.swapaxes(K, -1, -2)
    if out.ndim == 2:
        return _output(mandel_to_voigt(out), t4)
    flat = out.reshape(-1, *out.shape[-2:])
    res = np.stack([_output(mandel_to_voigt(x), t4) for x in flat])
    return res.reshape(out.shape[:-2] + res.shape[1:])


# ---------------------------------------------------------------------------------------
# symmetry groups and projections (Mandel, natural frame)
# ---------------------------------------------------------------------------------------

def _kron_avg(Ks: np.ndarray) -> np.ndarray:
    """Projection (as a matrix on row-major vec) that averages M over the group {K}."""
    return np.mean([np.kron(K, K) for K in Ks], axis=0)


def _group_mats(cls: str) -> np.ndarray:
    """Rotation matrices generating the averaging group of ``cls`` in its natural frame.

    Axis classes use only the rotations about z: a 4th-order elasticity tensor invariant
    under an n-fold rotation (n = 2, 3, 4) lies in the monoclinic, trigonal, tetragonal
    class or higher (Forte & Vianello 1996), and invariance under 8 equally spaced
    rotations implies invariance under all of them (Hermann's theorem: the components
    of a rotated 4th-order tensor are trigonometric polynomials of degree 4).
    """
    z = np.array([0.0, 0.0, 1.0])
    if cls in ("transversely isotropic", "tetragonal", "trigonal", "monoclinic"):
        n = {"transversely isotropic": 8, "tetragonal": 4, "trigonal": 3, "monoclinic": 2}[cls]
        return np.array([rotation_about(z, 2 * np.pi * k / n) for k in range(n)])
    if cls == "orthotropic":
        return np.array([np.diag(s) for s in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1))])
    if cls == "cubic":  # the 24 proper rotations of the cube
        mats = []
        for p in itertools.permutations(range(3)):
            for s in itertools.product((1, -1), repeat=3):
                Q = np.zeros((3, 3))
                Q[range(3), p] = s
                if np.linalg.det(Q) > 0:
                    mats.append(Q)
        return np.array(mats)
    # 2D
    if cls == "square":
        return np.array([[[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]
                         for t in np.arange(4) * np.pi / 2])
    if cls == "orthotropic2d":
        return np.array([np.eye(2), np.diag([1.0, -1.0])])
    raise KeyError(cls)


@lru_cache(maxsize=None)
def _projector(cls: str, dim: int) -> np.ndarray:
    """(m^2, m^2) matrix of the orthogonal projection onto ``cls``-invariant tensors."""
    if cls == "isotropic":
        J, Kd = _iso_projectors(dim)
        return np.outer(J.ravel(), J.ravel()) + np.outer(Kd.ravel(), Kd.ravel()) / np.trace(Kd)
    key = "orthotropic2d" if (dim == 2 and cls == "orthotropic") else cls
    P = _kron_avg(_mandel_rot(_group_mats(key)))
    P.setflags(write=False)
    return P


def _natural_residual(Mn: np.ndarray, R: np.ndarray, cls: str) -> np.ndarray:
    """Residual vector (I - P) vec(K M K^T) for frame(s) R; ``Mn`` is normalised."""
    dim = R.shape[-1]
    K = _mandel_rot(R)
    Mp = K @ Mn @ np.swapaxes(K, -1, -2)
    v = Mp.reshape(Mp.shape[:-2] + (-1,))
    P = _projector(cls, dim)
    return v - v @ P.T


# ---------------------------------------------------------------------------------------
# symmetry classification
# ---------------------------------------------------------------------------------------

_AXIS_CLASSES = ("transversely isotropic", "tetragonal", "trigonal", "monoclinic")
_LEVELS_3D = (("isotropic",), ("cubic", "transversely isotropic"), ("tetragonal", "trigonal"),
              ("orthotropic",), ("monoclinic",), ("triclinic",))


def _frame_from_axis(a: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """Right-handed frame (rows x', y', a) with x' the projection of ``ref`` (default e_x,
    else e_y) onto the plane normal to ``a``."""
    a = a / np.linalg.norm(a)
    cands = [ref] if ref is not None else []
    cands += [np.array([1.0, 0, 0]), np.array([0, 1.0, 0])]
    for r in cands:
        t = r - np.dot(r, a) * a
        if np.linalg.norm(t) > 1e-3:
            break
    t = t / np.linalg.norm(t)
    return np.array([t, np.cross(a, t), a])


@lru_cache(maxsize=1)
def _sphere_grid(n: int = 1200, k: int = 8) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fibonacci points on the upper hemisphere, their neighbour lists (with n ~ -n) and
    a frame per point (rows t1, t2, a)."""
    i = np.arange(n)
    z = (i + 0.5) / n
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(1 - z * z)
    P = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    tree = cKDTree(np.vstack([P, -P]))
    _, idx = tree.query(P, k=k + 1)
    nb = idx[:, 1:] % n
    frames = np.array([_frame_from_axis(p) for p in P])
    for arr in (P, nb, frames):
        arr.setflags(write=False)
    return P, nb, frames


def _canon_axis(a: np.ndarray) -> np.ndarray:
    a = a / np.linalg.norm(a)
    for c in (2, 1, 0):
        if abs(a[c]) > 1e-9:
            return a if a[c] > 0 else -a
    return a  # pragma: no cover


def _refine(Mn: np.ndarray, R0: np.ndarray, cls: str, axis_only: bool) -> tuple[float, np.ndarray]:
    """Local least-squares polish of a frame; returns (relative residual, frame)."""
    r0 = float(np.linalg.norm(_natural_residual(Mn, R0, cls)))
    if r0 < 1e-14:
        return r0, R0

    def frame(p: np.ndarray) -> np.ndarray:
        w = np.array([p[0], p[1], 0.0]) if axis_only else p
        return Rotation.from_rotvec(w).as_matrix() @ R0

    def fun(p: np.ndarray) -> np.ndarray:
        return _natural_residual(Mn, frame(p), cls)

    sol = least_squares(fun, np.zeros(2 if axis_only else 3), method="lm",
                        xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=400)
    R = frame(sol.x)
    r = float(np.linalg.norm(_natural_residual(Mn, R, cls)))
    if r > r0:
        return r0, R0
    U, _, Vt = np.linalg.svd(R)  # re-orthonormalise
    return r, U @ Vt


def _dedupe_axes(found: list[tuple[float, np.ndarray]], cos_tol: float = np.cos(np.radians(2.0))
                 ) -> list[tuple[float, np.ndarray]]:
    out: list[tuple[float, np.ndarray]] = []
    for r, R in sorted(found, key=lambda t: t[0]):
        if all(abs(np.dot(R[2], Q[2])) < cos_tol for _, Q in out):
            out.append((r, R))
    return out


class _Search3D:
    """Lazy orientation searches for one normalised Mandel matrix."""

    def __init__(self, Mn: np.ndarray) -> None:
        self.Mn = Mn
        P, nb, frames = _sphere_grid()
        self.grid, self.nb, self.frames = P, nb, frames
        K = _mandel_rot(frames)
        self.Mgrid = (K @ Mn @ np.swapaxes(K, -1, -2)).reshape(len(P), -1)
        # Cowin-Mehrabadi seeds: eigenvectors of the dilatational and Voigt tensors
        d, v = contracted_tensors(matrix_to_tensor4(Mn, mandel=True))
        seeds = np.hstack([np.linalg.eigh(d)[1], np.linalg.eigh(v)[1]]).T
        self.seed_frames = np.array([_frame_from_axis(_canon_axis(s)) for s in seeds])
        self._axes: dict[str, list[tuple[float, np.ndarray]]] = {}
        self.best: dict[str, tuple[float, np.ndarray | None]] = {}

    def axes(self, cls: str, nref: int) -> list[tuple[float, np.ndarray]]:
        """Refined candidate axes for an axis class: list of (residual, frame), best first."""
        if cls in self._axes:
            return self._axes[cls]
        P = _projector(cls, 3)
        r = np.linalg.norm(self.Mgrid - self.Mgrid @ P.T, axis=1)
        locmin = np.flatnonzero(r <= r[self.nb].min(axis=1))
        locmin = locmin[np.argsort(r[locmin])]
        cands = [(float(r[i]), self.frames[i]) for i in locmin]
        rs = np.linalg.norm(_natural_residual(self.Mn, self.seed_frames, cls), axis=-1)
        cands += [(float(x), F) for x, F in zip(rs, self.seed_frames)]
        cands = _dedupe_axes(cands)[:nref]
        refined = [_refine(self.Mn, F, cls, axis_only=True) for _, F in cands]
        out = _dedupe_axes(refined, cos_tol=np.cos(np.radians(0.5)))
        self._axes[cls] = out
        return out

    def frame_class(self, cls: str) -> tuple[float, np.ndarray | None]:
        """Best residual and frame for orthotropic (from 2-fold axes) or cubic (4-fold)."""
        src = "monoclinic" if cls == "orthotropic" else "tetragonal"
        ax = [F[2] for _, F in self.axes(src, 8)]
        frames = []
        for a, b in itertools.permutations(ax[:6], 2):
            if abs(np.dot(a, b)) < 0.5:
                t = b - np.dot(b, a) * a
                t /= np.linalg.norm(t)
                frames.append(np.array([t, np.cross(a, t), a]))
        if not frames:
            frames = [np.eye(3)] + [F for _, F in self.axes(src, 8)[:2]]
        frames_arr = np.array(frames)
        rs = np.linalg.norm(_natural_residual(self.Mn, frames_arr, cls), axis=-1)
        order = np.argsort(rs)[:3]
        best = min((_refine(self.Mn, frames_arr[i], cls, axis_only=False) for i in order),
                   key=lambda t: t[0])
        return best

    def residual(self, cls: str) -> tuple[float, np.ndarray | None]:
        if cls in self.best:
            return self.best[cls]
        if cls == "isotropic":
            P = _iso_project(self.Mn, 3)
            res: tuple[float, np.ndarray | None] = (float(np.linalg.norm(self.Mn - P)), np.eye(3))
        elif cls == "triclinic":
            res = (0.0, None)
        elif cls in _AXIS_CLASSES:
            res = self.axes(cls, 8 if cls == "monoclinic" else 4)[0]
        else:
            res = self.frame_class(cls)
        self.best[cls] = res
        return res


def _nearest_signed_permutation(F: np.ndarray, group: np.ndarray) -> np.ndarray:
    """Among the frames g @ F (g in the symmetry group), the one closest to the identity."""
    cands = np.einsum("gij,jk->gik", group, F)
    return cands[int(np.argmax(np.einsum("gii->g", cands)))]


def _in_plane_twofold(Mn: np.ndarray, F: np.ndarray, n_fold: int) -> np.ndarray:
    """Rotate frame F about its z row so that x' is a 2-fold axis closest to e_x."""
    phis = np.linspace(0.0, np.pi, 181)[:-1]
    Rz = np.array([rotation_about((0, 0, 1), p).T for p in phis])  # rows rotate in-plane
    frames = Rz @ F
    M2 = _projector("monoclinic", 3)
    # 2-fold about x' of the frame: move x' to z and test C2 about z
    to_x = np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0]])  # rows (y', a, x'): x' -> z
    test = to_x @ frames
    K = _mandel_rot(test)
    Mp = (K @ Mn @ np.swapaxes(K, -1, -2)).reshape(len(phis), -1)
    r = np.linalg.norm(Mp - Mp @ M2.T, axis=1)
    i = int(np.argmin(r))

    def fun(p: np.ndarray) -> np.ndarray:
        Fx = rotation_about((0, 0, 1), phis[i] + p[0]).T @ F
        return _natural_residual(Mn, to_x @ Fx, "monoclinic")

    sol = least_squares(fun, [0.0], method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    x = float(sol.x[0])
    # the residual is linear in a small angle error: a few Gauss-Newton steps with a
    # central-difference slope remove what LM leaves when it starts next to the minimum
    for _ in range(3):
        h = 1e-5
        r0 = fun(np.array([x]))
        J = (fun(np.array([x + h])) - fun(np.array([x - h]))) / (2 * h)
        jj = float(J @ J)
        if jj <= 0:
            break
        dx = -float(J @ r0) / jj
        if abs(dx) > 1e-3:
            break
        x += dx
    phi = phis[i] + x
    step = np.pi / n_fold
    opts = [rotation_about((0, 0, 1), phi + k * step).T @ F for k in range(2 * n_fold)]
    return max(opts, key=lambda G: G[0, 0])


@dataclass(frozen=True)
class SymmetryClass:
    """Result of :func:`symmetry_class`.

    Attributes
    ----------
    name : str
        One of :data:`SYMMETRY_CLASSES_3D` (or :data:`SYMMETRY_CLASSES_2D` in 2D).
    seed_name : str or None
        The seed's Table 1 name (``None`` for cubic, trigonal, triclinic and 2D classes).
    axis : array, shape (3,), or None
        Unit symmetry axis (transversely isotropic, tetragonal, trigonal) or the normal of
        the mirror plane (monoclinic); ``None`` otherwise.  Sign: largest-index non-zero
        component positive.
    axes : array, shape (3, 3) / (2, 2), or None
        Proper rotation whose rows are the natural basis vectors, so that
        ``rotate_stiffness(C, axes)`` is in the standard form: symmetry axis / mirror
        normal along z; tetragonal and trigonal x along a 2-fold axis (so ``C16 = 0`` and,
        for trigonal, only ``C14 = -C24 = C56`` couple); orthotropic and cubic axes along
        the symmetry axes, chosen closest to the coordinate axes.  Identity for isotropic,
        ``None`` for triclinic / 2D anisotropic.
    residual : float
        ``||C - P(C)|| / ||C||`` for the reported class in the natural frame, where ``P``
        is the orthogonal projection onto tensors of that symmetry (Frobenius norm of the
        tensor = of its Mandel matrix).  ``<= tol`` by construction (0 for triclinic).
    residuals : mapping str -> float
        The minimised residual of every class that was tested.
    tol : float
    aligned : bool or None
        Whether the natural axes (the axis alone for transversely isotropic and
        monoclinic) coincide with the coordinate axes to 1e-6.
    n_independent : int
        Number of independent constants of the class.
    kelvin_moduli : array
        Eigenvalues of the Mandel matrix (a frame-free cross-check of the class).
    """

    name: str
    seed_name: str | None
    axis: np.ndarray | None
    axes: np.ndarray | None
    residual: float
    residuals: Mapping[str, float]
    tol: float
    aligned: bool | None
    n_independent: int
    kelvin_moduli: np.ndarray

    def __str__(self) -> str:
        ax = "" if self.axis is None else f", axis {np.array2string(self.axis, precision=4)}"
        return f"{self.name} (residual {self.residual:.2e}{ax})"


def _is_signed_perm(F: np.ndarray, atol: float = 1e-6) -> bool:
    A = np.abs(F)
    return bool(np.all(np.abs(A - np.round(A)) < atol) and np.allclose(np.round(A).sum(0), 1))


def symmetry_class(C: np.ndarray, tol: float = 1e-6) -> SymmetryClass:
    """Frame-independent elastic symmetry class of a stiffness.

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3), (3, 3, 3, 3) or (2, 2, 2, 2)
        Symmetric stiffness in any frame (positive definiteness not required).
    tol : float
        Relative tolerance.  ``C`` belongs to a class if some orientation of the class's
        symmetry group ``G`` gives ``||C - P_G(C)||_F <= tol ||C||_F``, with ``P_G`` the
        group average (the orthogonal projection onto ``G``-invariant tensors) and the
        Frobenius norm of the 4th-order tensor (= of its Mandel matrix).  The minimised
        distance is therefore the relative distance from ``C`` to the nearest tensor of the
        class.

    Returns
    -------
    SymmetryClass

    Notes
    -----
    3D method (numerical, in the spirit of Cowin & Mehrabadi 1987):

    1. Isotropy: distance to the isotropic projection (no orientation needed).
    2. For the axis groups -- 8-fold (transversely isotropic; Hermann's theorem), 4-fold
       (tetragonal), 3-fold (trigonal) and 2-fold (monoclinic) rotations -- the residual
       is evaluated for the axes of a 1200-point hemisphere grid and for the eigenvectors
       of the Cowin-Mehrabadi tensors ``d_ij = C_ijkk``, ``v_ij = C_ikjk``; the best local
       minima are polished by least squares.  Grid sampling makes the search robust when
       ``d`` and ``v`` have repeated eigenvalues (cubic, transversely isotropic).
    3. Orthotropic frames are built from pairs of near-orthogonal 2-fold axes, cubic
       frames from pairs of 4-fold axes, and polished over SO(3).
    4. The classes are tried from the highest symmetry down, by levels
       isotropic | cubic, transversely isotropic | tetragonal, trigonal | orthotropic |
       monoclinic | triclinic; the first level with a residual ``<= tol`` wins, ties inside
       a level going to the smaller residual.

    Since an n-fold axis (n = 2, 3, 4) already forces the mirror planes of the class for an
    elasticity tensor (Forte & Vianello 1996), rotations suffice.  The Kelvin moduli are
    returned as an independent check (e.g. isotropic: a five-fold eigenvalue).

    2D: isotropic (projection), square (4-fold rotation, orientation-free), orthotropic
    (mirror line found on a 1-degree grid and polished), anisotropic.
    """
    M, _ = _as_voigt(C)
    _check_finite_symmetric(M, 1e-10)
    M = 0.5 * (M + M.T)
    Mm = voigt_to_mandel(M)
    peak = float(np.abs(Mm).max())
    if peak == 0.0:
        raise GrainmechError("C is zero: no symmetry class")
    Mn = Mm / peak  # scale first: the Frobenius norm of a tiny/huge matrix under/overflows
    Mn = Mn / np.linalg.norm(Mn)
    kel = peak * np.linalg.eigvalsh(Mm / peak)
    if M.shape[0] == 3:
        return _symmetry_class_2d(Mn, tol, kel)
    search = _Search3D(Mn)
    residuals: dict[str, float] = {}
    name, res, F = "triclinic", 0.0, None
    for level in _LEVELS_3D:
        results = {c: search.residual(c) for c in level}
        for c, (r, _) in results.items():
            residuals[c] = r
        ok = [c for c in level if results[c][0] <= tol]
        if ok:
            name = min(ok, key=lambda c: results[c][0])
            res, F = results[name]
            break
    axis = None
    if F is not None:
        if name in _AXIS_CLASSES:
            axis = _canon_axis(F[2])
            F = _frame_from_axis(axis)
            if name == "tetragonal":
                F = _in_plane_twofold(Mn, F, 4)
            elif name == "trigonal":
                F = _in_plane_twofold(Mn, F, 3)
            aligned = _is_signed_perm(F) if name in ("tetragonal", "trigonal") else \
                bool(np.max(np.abs(axis)) > 1 - 1e-6)
        elif name in ("orthotropic", "cubic"):
            group = np.array([np.diag(s) @ np.eye(3)[list(p)]
                              for p in itertools.permutations(range(3))
                              for s in itertools.product((1, -1), repeat=3)])
            group = group[np.linalg.det(group) > 0]
            F = _nearest_signed_permutation(F, group)
            aligned = _is_signed_perm(F)
        else:  # isotropic
            aligned = True
        if aligned and name != "isotropic":
            # snap to the exact coordinate frame when that is as good
            Fs = np.round(F) if name not in ("transversely isotropic", "monoclinic") \
                else _frame_from_axis(np.round(axis))
            rs = float(np.linalg.norm(_natural_residual(Mn, Fs, name)))
            if name in ("tetragonal", "trigonal"):
                # the class residual ignores the in-plane angle: the snapped frame must also
                # keep x' on a 2-fold axis (no spurious C15/C16 in the standard form)
                to_x = np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0]])
                r2 = [float(np.linalg.norm(_natural_residual(Mn, to_x @ G, "monoclinic"))) for G in (F, Fs)]
                rs = max(rs, r2[1] - 2.0 * r2[0])
            if rs <= max(2.0 * res, 1e-13):
                F, res = Fs, rs
                if axis is not None:
                    axis = Fs[2].copy()
    else:
        aligned = None
    seed = SEED_NAMES.get(name)
    if name == "orthotropic" and not aligned:
        seed = SEED_NAMES["monoclinic"]
    return SymmetryClass(name=name, seed_name=seed, axis=axis, axes=F, residual=float(res),
                         residuals=MappingProxyType(residuals), tol=tol, aligned=aligned,
                         n_independent=N_INDEPENDENT[name], kelvin_moduli=kel)


def _rot2(phi: np.ndarray | float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], -2)  # rows = new basis


def _symmetry_class_2d(Mn: np.ndarray, tol: float, kel: np.ndarray) -> SymmetryClass:
    residuals: dict[str, float] = {}
    r_iso = float(np.linalg.norm(Mn - _iso_project(Mn, 2)))
    residuals["isotropic"] = r_iso
    if r_iso <= tol:
        return SymmetryClass("isotropic", None, None, np.eye(2), r_iso,
                             MappingProxyType(residuals), tol, True, 2, kel)
    # mirror-line search (needed for the axes of square and orthotropic)
    phis = np.linspace(0.0, np.pi / 2, 91)[:-1]  # mirrors come in orthogonal pairs
    r = np.linalg.norm(_natural_residual(Mn, _rot2(phis), "orthotropic"), axis=-1)
    cands = np.argsort(r)[:3]

    def fun(p: np.ndarray) -> np.ndarray:
        return _natural_residual(Mn, _rot2(p[0]), "orthotropic")

    best = None
    for i in cands:
        sol = least_squares(fun, [phis[i]], method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
        rr = float(np.linalg.norm(fun(sol.x)))
        if best is None or rr < best[0]:
            best = (rr, float(sol.x[0]))
    r_orth, phi = best  # type: ignore[misc]
    r_sq = float(np.linalg.norm(_natural_residual(Mn, np.eye(2), "square")))
    residuals["square"] = r_sq
    if r_sq <= tol:
        name, res, nfold = "square", r_sq, 4
    else:
        residuals["orthotropic"] = r_orth
        if r_orth <= tol:
            name, res, nfold = "orthotropic", r_orth, 2
        else:
            return SymmetryClass("anisotropic", None, None, None, 0.0,
                                 MappingProxyType(residuals), tol, None, 6, kel)
    opts = [_rot2(phi + k * np.pi / nfold) for k in range(2 * nfold)]
    F = max(opts, key=lambda G: np.trace(G))
    aligned = _is_signed_perm(F)
    if aligned:
        rs = float(np.linalg.norm(_natural_residual(Mn, np.round(F), name)))
        if rs <= max(2.0 * res, 1e-13):
            F, res = np.round(F), rs
    return SymmetryClass(name, None, None, F, res, MappingProxyType(residuals), tol, aligned,
                         N_INDEPENDENT[name], kel)


def symmetric_projection(C: np.ndarray, cls: str, axes: np.ndarray | None = None) -> np.ndarray:
    """Nearest tensor of a given symmetry in a given orientation (group average).

    Parameters
    ----------
    C : array, shape (6, 6), (3, 3) or tensor
    cls : str
        A class name from :data:`SYMMETRY_CLASSES_3D` / :data:`SYMMETRY_CLASSES_2D`.
    axes : array, shape (3, 3) / (2, 2), or shape (3,), optional
        Natural frame (rows = natural basis vectors, as :attr:`SymmetryClass.axes`); for
        the axis classes a 3-vector (the axis) is enough.  Default: the coordinate frame.

    Returns
    -------
    array, same form as ``C``
        The orthogonal projection (Frobenius norm) of ``C`` onto the tensors invariant
        under the class's group in that orientation.  For tetragonal and trigonal the
        group is the n-fold rotation about the axis, so the result may keep a ``C16``
        (tetragonal) or ``C15`` (trigonal) term in the given frame; it is still of that
        class (in a frame rotated about the axis the term vanishes).
    """
    M, t4 = _as_voigt(C)
    dim = _dim(M)
    valid = SYMMETRY_CLASSES_3D if dim == 3 else SYMMETRY_CLASSES_2D
    if cls not in valid:
        raise GrainmechError(f"cls must be one of {valid} for a {dim}D stiffness; got {cls!r}")
    if cls in ("triclinic", "anisotropic"):
        return _output(M.copy(), t4)
    if axes is None:
        F = np.eye(dim)
    else:
        A = np.asarray(axes, dtype=float)
        if dim == 3 and A.shape == (3,):
            if cls not in _AXIS_CLASSES:
                raise GrainmechError(f"axes for class {cls!r} must be a 3x3 frame; got a vector")
            F = _frame_from_axis(_unit(A, 3, "axes"))
        else:
            F = _check_orthogonal(A, dim)
    Mm = voigt_to_mandel(M)
    if cls == "isotropic":
        P = _iso_project(Mm, dim)
    else:
        K = _mandel_rot(F)
        Mnat = K @ Mm @ K.T
        Pnat = (_projector(cls, dim) @ Mnat.ravel()).reshape(Mnat.shape)
        P = K.T @ Pnat @ K
    return _output(mandel_to_voigt(0.5 * (P + P.T)), t4)

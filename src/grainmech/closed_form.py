"""Closed-form stiffness of random packings (seed Ch. 4) and effective-medium references.

Every closed form here is checked in ``tests/test_closed_form.py`` against direct
quadrature of seed Eq. 2.41 (:class:`grainmech.assembly.ContactSet` + Lebedev rule) to
1e-10 relative. Corrections of misprinted seed equations are listed in
``docs/seed-errata.md``.

Scale factor
------------
All fabric closed forms are written with the factor ``scale = (N/V) l^2``: the number of
entries per unit volume times the squared length of the vector carried in the
kinematics. In the seed's own (``seed``) convention this is ``r^2 N / V`` with the seed's
``N/V`` of Eq. 4.1 (each contact counted from both particles) and ``r`` the particle
radius; in the physically consistent (``physical``) convention it is
``N_c l^2 / V`` with ``N_c`` physical contacts and ``l`` the centre-to-centre branch
length, which for equal spheres is exactly twice the seed's value.
:func:`packing_scale` returns it for either convention.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from grainmech.contact.geometry import hertz_kn, hertz_radius, mindlin_kt0
from grainmech.contact.params import Hertz
from grainmech.conventions import SEED_ORDER_2D, SEED_ORDER_3D, reorder
from grainmech.errors import GrainmechError
from grainmech.fabric.coordination import contact_ends_per_volume, contacts_per_volume

__all__ = [
    "packing_scale",
    "spheres_second_order",
    "discs_fourth_order",
    "HertzMindlinIsotropic",
    "isotropic_hertz_mindlin",
    "walton",
    "digby",
]


def _positive(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise GrainmechError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise GrainmechError(f"{name} must be > 0, got {value!r}")
    return v


def _poisson(nu: float) -> float:
    v = float(nu)
    if not (-1.0 < v < 0.5):
        raise GrainmechError(f"poisson must lie in (-1, 0.5), got {nu!r}")
    return v


def packing_scale(void_ratio: float, coordination: float, radius: float, *, dim: int = 3,
                  convention: str = "physical") -> tuple[float, float]:
    """Entries per volume and carried length for a packing of equal grains (seed Eq. 4.1).

    Parameters
    ----------
    void_ratio : float
        e > 0.
    coordination : float
        Mean coordination number (contacts per particle), > 0.
    radius : float
        Particle radius rho (length).
    dim : {2, 3}
        Spheres (3) or discs (2; volumes are areas per unit thickness).
    convention : {"physical", "seed"}
        ``physical``: contacts counted once, ``l = 2 rho``.
        ``seed``: the seed's Eq. 4.1 ``N/V = 3 m / (4 pi rho^3 (1+e))`` (spheres) or
        ``m / (pi rho^2 (1+e))`` (discs), which counts each contact from both particles,
        with ``l = rho``.

    Returns
    -------
    (contacts_per_volume, length) : (float, float)
        Multiply ``contacts_per_volume * length**2`` for the closed forms' ``scale``.
    """
    if dim not in (2, 3):
        raise GrainmechError(f"dim must be 2 or 3, got {dim!r}")
    rho = _positive("radius", radius)
    if convention == "physical":
        return float(contacts_per_volume(void_ratio, coordination, rho, dim)), 2.0 * rho
    if convention == "seed":
        return float(contact_ends_per_volume(void_ratio, coordination, rho, dim)), rho
    raise GrainmechError(f"convention must be 'physical' or 'seed', got {convention!r}")


def spheres_second_order(a20: float, a22: float, b22: float, kn: float, ks: float,
                         scale: float, *, order: str = "library") -> np.ndarray:
    """Stiffness of a packing of equal spheres with a 2nd-order fabric (seed Eq. 4.21-4.33).

    Constant contact stiffnesses ``kn``, ``ks`` and the density of seed Eq. 4.15. The
    printed Eq. 4.21-4.33 were verified term by term against symbolic integration of
    Eq. 4.19 (sympy) and agree; the 13 non-zero constants are, with ``c = scale/15``
    and ``q = scale/30``::

        C11 = c[(3kn+2ks) + 2 a20 (6kn+ks)/7]
        C22 = c[(3kn+2ks) - a20 (6kn+ks)/7 + 6 a22 (6kn+ks)/7]
        C33 = c[(3kn+2ks) - a20 (6kn+ks)/7 - 6 a22 (6kn+ks)/7]
        C12 = c(kn-ks)[1 + a20/7 + 6 a22/7],  C13 = c(kn-ks)[1 + a20/7 - 6 a22/7]
        C23 = c(kn-ks)[1 - 2 a20/7]
        C44 = q[(2kn+3ks) + (a20/7 + 6 a22/7)(2kn + 3ks/2)]
        C55 = q[(2kn+3ks) + (a20/7 - 6 a22/7)(2kn + 3ks/2)]
        C66 = q[(2kn+3ks) - 2 a20 (2kn + 3ks/2)/7]
        C16 = q 12 b22 (kn-ks)/7,  C26 = C36 = q 12 b22 (3kn + ks/2)/7
        C45 = q 12 b22 (kn + 3ks/4)/7

    in the seed's order (zz, yy, xx, zy, zx, xy).

    Parameters
    ----------
    a20, a22, b22 : float
        Seed fabric parameters (Eq. 4.15, 4.17).
    kn, ks : float
        Contact stiffnesses (force/length).
    scale : float
        ``(N/V) l^2`` (1/length); see :func:`packing_scale`. The seed writes ``r^2 N/V``.
    order : {"library", "seed"}
        Component order of the result (Voigt, engineering shear strain).

    Returns
    -------
    array (6, 6)
    """
    c = scale / 15.0
    q = scale / 30.0
    A = 6 * kn + ks
    Bs = 2 * kn + 1.5 * ks
    d = kn - ks
    C = np.zeros((6, 6))
    C[0, 0] = c * ((3 * kn + 2 * ks) + 2 * a20 / 7 * A)
    C[1, 1] = c * ((3 * kn + 2 * ks) - a20 / 7 * A + 6 * a22 / 7 * A)
    C[2, 2] = c * ((3 * kn + 2 * ks) - a20 / 7 * A - 6 * a22 / 7 * A)
    C[0, 1] = c * d * (1 + a20 / 7 + 6 * a22 / 7)
    C[0, 2] = c * d * (1 + a20 / 7 - 6 * a22 / 7)
    C[1, 2] = c * d * (1 - 2 * a20 / 7)
    C[3, 3] = q * ((2 * kn + 3 * ks) + (a20 / 7 + 6 * a22 / 7) * Bs)
    C[4, 4] = q * ((2 * kn + 3 * ks) + (a20 / 7 - 6 * a22 / 7) * Bs)
    C[5, 5] = q * ((2 * kn + 3 * ks) - 2 * a20 / 7 * Bs)
    C[0, 5] = q * 12 * b22 / 7 * d
    C[1, 5] = q * 12 * b22 / 7 * (3 * kn + 0.5 * ks)
    C[2, 5] = q * 12 * b22 / 7 * (3 * kn + 0.5 * ks)
    C[3, 4] = q * 12 * b22 / 7 * (kn + 0.75 * ks)
    C = np.triu(C) + np.triu(C, 1).T
    if order == "seed":
        return C
    if order != "library":
        raise GrainmechError(f"order must be 'library' or 'seed', got {order!r}")
    return reorder(C, to=("xx", "yy", "zz", "yz", "xz", "xy"), frm=SEED_ORDER_3D)


def discs_fourth_order(a2: float, b2: float, a4: float, b4: float, kn: float, ks: float,
                       scale: float, *, order: str = "library") -> np.ndarray:
    """Stiffness of a packing of equal discs with a 4th-order Fourier fabric (seed Eq. 4.37-4.42, corrected).

    Density of seed Eq. 4.34 (``theta`` from the y axis). With ``c = scale/8`` and the
    seed's order (yy, xx, yx)::

        C11 = c[(3kn + ks) + 2 a2 kn + a4 (kn-ks)/2]
        C22 = c[(3kn + ks) - 2 a2 kn + a4 (kn-ks)/2]
        C12 = c[(kn - ks) - a4 (kn-ks)/2]
        C33 = c[(kn + ks) - a4 (kn-ks)/2]
        C13 = c[b2 kn + b4 (kn-ks)/2]
        C23 = c[b2 kn - b4 (kn-ks)/2]

    The printed Eq. 4.37-4.40 equal these with ``scale = 2 m/(pi (1+e))``, i.e. in the
    *physical* counting convention; Eq. 4.41 has half that prefactor and Eq. 4.42 has the
    wrong terms (``2 b2 (kn+ks) - b4 kn``). See ``docs/seed-errata.md`` (E-4.41, E-4.42).

    Parameters
    ----------
    a2, b2, a4, b4 : float
        Seed Fourier coefficients (Eq. 4.34).
    kn, ks : float
        Contact stiffnesses (force/length per unit thickness).
    scale : float
        ``(N/A) l^2`` (dimensionless for discs per unit thickness).
    order : {"library", "seed"}

    Returns
    -------
    array (3, 3)
    """
    c = scale / 8.0
    d = kn - ks
    C = np.zeros((3, 3))
    C[0, 0] = c * ((3 * kn + ks) + 2 * a2 * kn + a4 * d / 2)
    C[1, 1] = c * ((3 * kn + ks) - 2 * a2 * kn + a4 * d / 2)
    C[0, 1] = c * (d - a4 * d / 2)
    C[2, 2] = c * ((kn + ks) - a4 * d / 2)
    C[0, 2] = c * (b2 * kn + b4 * d / 2)
    C[1, 2] = c * (b2 * kn - b4 * d / 2)
    C = np.triu(C) + np.triu(C, 1).T
    if order == "seed":
        return C
    if order != "library":
        raise GrainmechError(f"order must be 'library' or 'seed', got {order!r}")
    return reorder(C, to=("xx", "yy", "xy"), frm=SEED_ORDER_2D)


@dataclass(frozen=True)
class HertzMindlinIsotropic:
    """Moduli of a statistically isotropic Hertz-Mindlin sphere packing (seed Sec. 4.2.2).

    Attributes: ``E``, ``nu``, ``G``, ``K`` (packing moduli, stress units), ``lam``
    (Lame), ``contact_force`` (N per contact, Eq. 4.43), ``contact_radius`` (a),
    ``kn``, ``ks`` (contact stiffnesses), ``scale`` ((N/V) l^2), ``convention``.
    """

    E: float
    nu: float
    G: float
    K: float
    lam: float
    contact_force: float
    contact_radius: float
    kn: float
    ks: float
    scale: float
    convention: str

    def as_dict(self) -> dict:
        """The fields as a plain dict."""
        return asdict(self)


def isotropic_hertz_mindlin(shear_modulus: float, poisson: float, pressure: float, *,
                            void_ratio: float, coordination: float, radius: float,
                            convention: str = "physical") -> HertzMindlinIsotropic:
    """Isotropic packing of equal Hertz-Mindlin spheres under pressure P (seed Eq. 4.43-4.45, corrected).

    Contact force from the Love-Weber average of an isotropic stress (Eq. 4.43, the same
    physical force in both conventions)::

        N = 3 P / ((N/V) l)

    Hertz (Eq. 3.2-3.4, 3.7) for equal spheres: ``R* = rho/2``, ``E* = G/(1-nu)``,
    ``a^3 = 3 N R*/(4 E*)``, ``kn = 2 E* a``; Mindlin no-slip (Eq. 3.11-3.12 with
    theta = 1): ``G* = G/(2(2-nu))``, ``ks = 8 G* a``. Then, with ``scale = (N/V) l^2``,
    ``lam = scale (kn-ks)/15`` and ``G = scale (2kn+3ks)/30``, so (Eq. 4.44, correct as
    printed) ``nu_iso = nu / (2 (5 - 3 nu))`` and (Eq. 4.45 corrected)::

        E_iso = (r^2/3) (5-4nu)/(5-3nu) (9P)^(1/3) [G N/((1-nu) V)]^(2/3)   (seed convention)

    The printed Eq. 4.45 has ``4 r^2/30`` in place of ``r^2/3`` (erratum E-4.45); the
    physical convention doubles the result, which then equals Walton (1987) rough spheres
    (see :func:`walton`).

    Parameters
    ----------
    shear_modulus, poisson : float
        Grain shear modulus G (stress) and Poisson's ratio nu.
    pressure : float
        Isotropic confining stress P > 0 (compression positive).
    void_ratio, coordination, radius : float
        Packing: e, mean coordination number, particle radius.
    convention : {"physical", "seed"}
    """
    G = _positive("shear_modulus", shear_modulus)
    nu = _poisson(poisson)
    P = _positive("pressure", pressure)
    rho = _positive("radius", radius)
    nv, length = packing_scale(void_ratio, coordination, rho, dim=3, convention=convention)
    force = 3.0 * P / (nv * length)
    hz = Hertz(G, nu, rho)  # two equal spheres: R* = rho/2, E* = G/(1-nu), G* = G/(2(2-nu))
    e_star, g_star = hz.effective_modulus, hz.effective_shear_modulus
    a = float(hertz_radius(force, e_star, hz.effective_radius))
    kn = float(hertz_kn(a, e_star))
    ks = float(mindlin_kt0(a, g_star))
    scale = nv * length**2
    lam = scale * (kn - ks) / 15.0
    mu = scale * (2 * kn + 3 * ks) / 30.0
    E = mu * (3 * lam + 2 * mu) / (lam + mu)
    nu_p = lam / (2 * (lam + mu))
    K = lam + 2.0 * mu / 3.0
    return HertzMindlinIsotropic(E, nu_p, mu, K, lam, force, a, kn, ks, scale, convention)


def _random_pack_inputs(shear_modulus: float, poisson: float, pressure: float, porosity: float,
                        coordination: float) -> tuple[float, float, float, float, float]:
    """Validated (mu, nu, P, phi, n) of the effective-medium models."""
    phi = float(porosity)
    if not 0.0 < phi < 1.0:
        raise GrainmechError(f"porosity must lie in (0, 1), got {porosity!r}")
    return (_positive("shear_modulus", shear_modulus), _poisson(poisson), _positive("pressure", pressure),
            phi, _positive("coordination", coordination))


def walton(shear_modulus: float, poisson: float, pressure: float, *, porosity: float,
           coordination: float, rough: bool = True) -> tuple[float, float]:
    """Walton (1987) effective bulk and shear moduli of a random pack of identical spheres.

    Walton, K. (1987), J. Mech. Phys. Solids 35(2), 213-226; as written in Mavko,
    Mukerji & Dvorkin, *The Rock Physics Handbook* (Walton model)::

        A = (1/(4 pi)) (1/mu - 1/(mu + lam)),  B = (1/(4 pi)) (1/mu + 1/(mu + lam))
        K = (1/6) [3 (1-phi)^2 n^2 P / (pi^4 B^2)]^(1/3)
        rough (infinite friction):  G = (3/5) K (5B + A)/(2B + A)
        smooth (no friction):       G = (3/5) K

    Parameters
    ----------
    shear_modulus, poisson : float
        Grain mu and nu.
    pressure : float
        Hydrostatic confining pressure P.
    porosity : float
        phi = e/(1+e) in (0, 1).
    coordination : float
        Mean coordination number n.
    rough : bool
        Infinitely rough (no-slip) or perfectly smooth contacts.

    Returns
    -------
    (K, G) : (float, float)
    """
    mu, nu, P, phi, n = _random_pack_inputs(shear_modulus, poisson, pressure, porosity, coordination)
    lam = 2.0 * mu * nu / (1.0 - 2.0 * nu)
    A = (1.0 / mu - 1.0 / (mu + lam)) / (4.0 * np.pi)
    B = (1.0 / mu + 1.0 / (mu + lam)) / (4.0 * np.pi)
    K = (3.0 * (1.0 - phi) ** 2 * n**2 * P / (np.pi**4 * B**2)) ** (1.0 / 3.0) / 6.0
    G = 0.6 * K * (5 * B + A) / (2 * B + A) if rough else 0.6 * K
    return float(K), float(G)


def digby(shear_modulus: float, poisson: float, pressure: float, *, porosity: float,
          coordination: float, bonded_fraction: float = 1.0) -> tuple[float, float]:
    """Digby (1981) moduli of a random pack of identical spheres with bonded contact regions.

    Digby, P. J. (1981), J. Appl. Mech. 48, 803-808; as in Mavko et al.::

        K = n (1-phi) S_n / (12 pi R),   G = n (1-phi) (S_n + 1.5 S_t) / (20 pi R)
        S_n = 4 mu a / (1-nu),   S_t = 8 mu b / (2-nu)

    with ``a`` the Hertz contact radius under the pressure and ``b = bonded_fraction * a``
    the radius of the initially bonded (no-slip) region. Written in terms of
    ``a/R = [3 pi (1-nu) P / (2 n (1-phi) mu)]^(1/3)`` (the b = 0 limit of Digby's cubic),
    the result does not depend on R. With ``bonded_fraction = 1`` it equals Walton's
    rough result; with 0 the smooth one.
    """
    mu, nu, P, phi, n = _random_pack_inputs(shear_modulus, poisson, pressure, porosity, coordination)
    f = float(bonded_fraction)
    if not 0.0 <= f <= 1.0:
        raise GrainmechError(f"bonded_fraction must lie in [0, 1], got {bonded_fraction!r}")
    a_over_R = (3.0 * np.pi * (1.0 - nu) * P / (2.0 * n * (1.0 - phi) * mu)) ** (1.0 / 3.0)
    Sn = 4.0 * mu * a_over_R / (1.0 - nu)
    St = 8.0 * mu * f * a_over_R / (2.0 - nu)
    K = n * (1.0 - phi) * Sn / (12.0 * np.pi)
    G = n * (1.0 - phi) * (Sn + 1.5 * St) / (20.0 * np.pi)
    return float(K), float(G)

"""All measures of a network in one result, and its JSON form.

All measures of a network in one result (:func:`network_report`) and its JSON form
(:meth:`NetworkReport.to_json`, :func:`network_report_json`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from grainmech.assembly import StressResult
from grainmech.closed_form import spheres_second_order
from grainmech.conventions import order_for
from grainmech.elasticity import engineering_constants
from grainmech.errors import GrainmechError
from grainmech.fabric import fit_density
from grainmech.network.data import Box, ContactNetwork
from grainmech.network.measures import (
    CoordinationResult,
    FabricResult,
    contact_stiffnesses,
    coordination,
    network_fabric,
    network_stress,
    rattler_threshold,
)
from grainmech.network.relaxed import RelaxedResult, relaxed_stiffness
from grainmech.network.stiffness import affine_stiffness

__all__ = ["NetworkReport", "network_report", "network_report_json", "closed_form_from_fit", "to_json"]


def to_json(x: Any) -> Any:
    """``x`` converted for :func:`json.dump`.

    ``x`` with NumPy arrays and scalars as lists and Python numbers (non-finite -> None),
    mapping keys as strings (tuples joined by commas): ready for :func:`json.dump`.
    """
    if isinstance(x, dict):
        return {",".join(map(str, k)) if isinstance(k, tuple) else str(k): to_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [to_json(v) for v in x]
    if isinstance(x, np.ndarray):
        return to_json(x.tolist())
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if np.isfinite(v) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def closed_form_from_fit(fit: Any, net: ContactNetwork, kn: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """Seed closed form (Eq. 4.21-4.33) from a fitted 2nd-order density (3D).

    Uses ``a20, a22, b22`` of the fit (``a21, b21`` are left out, as in Eq. 4.15, so the
    prediction assumes z is a principal fabric axis), the mean ``kn``, ``ks`` over the
    contacts and ``scale = (C/V) <|l|^2>`` (physical counting convention).
    """
    sp_ = fit.density.truncated(2).seed_parameters if hasattr(fit.density, "truncated") else fit.density.seed_parameters
    scale = net.n_contacts / net.volume * float(np.mean(net.branch_length ** 2))
    return spheres_second_order(sp_["a20"], sp_["a22"], sp_["b22"], float(np.mean(kn)), float(np.mean(ks)), scale)


@dataclass(frozen=True)
class NetworkReport:
    """Measures of a contact network (see :func:`network_report`); arrays, not JSON.

    Attributes
    ----------
    source : str
    n_particles, n_contacts : int
    volume : float
        Cell volume [length^3].
    box : Box
    stress : grainmech.assembly.StressResult
        Love-Weber stress (compression positive).
    fabric : FabricResult
    fit : grainmech.fabric.DensityFit
        Spherical-harmonic fit of the normal density of order ``fit_order``.
    fit_order : int
    coordination : CoordinationResult
    order : tuple of str
        Component order of the Voigt matrices.
    min_contacts : int
        Rattler threshold used.
    stiffness_source : str or None
        Where ``kn``, ``ks`` came from (:func:`contact_stiffnesses`); None without a law.
    stiffness_affine, stiffness_closed_form : array (6, 6) or None
        Voigt [stress].
    engineering_affine, engineering_relaxed : EngineeringConstants or None
    relaxed : RelaxedResult or None
    notes : tuple of str
        What was computed and how; why something is missing.
    """

    source: str
    n_particles: int
    n_contacts: int
    volume: float
    box: Box
    stress: StressResult
    fabric: FabricResult
    fit: Any
    fit_order: int
    coordination: CoordinationResult
    order: tuple[str, ...]
    min_contacts: int
    stiffness_source: str | None = None
    stiffness_affine: np.ndarray | None = None
    stiffness_closed_form: np.ndarray | None = None
    engineering_affine: Any = None
    engineering_relaxed: Any = None
    relaxed: RelaxedResult | None = None
    notes: tuple[str, ...] = ()

    def to_json(self) -> dict:
        """The report as a JSON-ready dict (``summary.json`` of ``grainmech dem``).

        Keys: ``source``, ``n_particles``, ``n_contacts``, ``volume``, ``box``, ``stress``,
        ``fabric``, ``coordination``, ``order``, ``shear``, ``stiffness_source``,
        ``stiffness_affine``, ``stiffness_relaxed``, ``stiffness_affine_solved_network``,
        ``stiffness_closed_form``, ``engineering_affine``, ``engineering_relaxed``,
        ``relaxed`` (solver, iterations, residual, counts), ``notes``.
        """
        fab, st, fit, rr = self.fabric, self.stress, self.fit, self.relaxed

        def aniso(a: Any) -> dict:
            return {"deviator_norm": a.deviator_norm, "amplitude": a.amplitude,
                    "principal_values": a.principal_values, "principal_axes": a.principal_axes}

        out: dict[str, Any] = {
            "source": self.source, "n_particles": self.n_particles, "n_contacts": self.n_contacts,
            "volume": self.volume,
            "box": {"origin": self.box.origin, "cell": self.box.cell, "periodic": self.box.periodic},
            "stress": {"tensor": st.stress, "skew": st.skew, "skew_ratio": st.skew_ratio, "mean": st.mean,
                       "convention": "compression positive; sigma = (1/V) sum f (x) l (Love-Weber)"},
            "fabric": {
                "normal2": fab.normal2, "normal4": fab.normal4, "branch2": fab.branch2, "branch4": fab.branch4,
                "normal_anisotropy": aniso(fab.normal_anisotropy),
                "branch_anisotropy": aniso(fab.branch_anisotropy),
                "fit": {"order": self.fit_order, "seed_coefficients": fit.seed_coefficients,
                        "seed_standard_errors": fit.seed_standard_errors, "chi2": fit.chi2, "dof": fit.dof,
                        "p_value": fit.p_value, "message": fit.message},
            },
            "coordination": {k: getattr(self.coordination, k) for k in self.coordination.__dataclass_fields__},
            "order": list(self.order),
            "shear": "engineering (Voigt)",
            "stiffness_affine": self.stiffness_affine,
            "stiffness_relaxed": None if rr is None else rr.C_relaxed,
            "stiffness_closed_form": self.stiffness_closed_form,
            "engineering_affine": None if self.engineering_affine is None else self.engineering_affine.as_dict(),
            "engineering_relaxed": None if self.engineering_relaxed is None else self.engineering_relaxed.as_dict(),
        }
        if self.stiffness_source is not None:
            out["stiffness_source"] = self.stiffness_source
        if rr is not None:
            out["stiffness_affine_solved_network"] = rr.C_affine
            out["relaxed"] = {"solver": rr.solver, "iterations": rr.iterations, "residual": rr.residual,
                              "n_particles": rr.n_particles, "n_contacts": rr.n_contacts,
                              "n_rattlers": rr.n_rattlers}
        out["notes"] = list(self.notes)
        return to_json(out)


def _frictional(net: ContactNetwork, shear_modulus: float | None, ks: float | None) -> bool:
    """True if the contact law has a tangential stiffness or the file tangential forces."""
    if shear_modulus is not None or (ks is not None and ks > 0):
        return True
    if net.ks is not None and bool(np.any(net.ks > 0)):
        return True
    if net.n_contacts == 0:
        return False
    ft = net.force - net.normal_force[:, None] * net.normals
    return bool(np.any(ft != 0))


def network_report(net: ContactNetwork, *, shear_modulus: float | None = None, poisson: float | None = None,
                   stiffness_source: str = "auto", kn: float | None = None, ks: float | None = None,
                   geometric: bool = False, relaxed: bool = True, solver: str = "auto",
                   remove_rattlers: bool = True, min_contacts: int | None = None,
                   fit_order: int = 2) -> NetworkReport:
    """All measures of a network in one :class:`NetworkReport`.

    All measures of a network: stress, fabric, coordination, affine, closed-form and
    relaxed stiffness and their engineering constants.

    Parameters
    ----------
    net : ContactNetwork
    shear_modulus, poisson, stiffness_source, kn, ks :
        Contact law (see :func:`contact_stiffnesses`); without one, no stiffness.
    geometric : bool
        Add the geometric term to the contact stiffness (:func:`effective_ks`).
    relaxed, solver, remove_rattlers, min_contacts :
        Whether and how to compute :func:`relaxed_stiffness`. ``min_contacts`` defaults
        to :func:`rattler_threshold` for the law (frictional if it has a tangential
        stiffness or the file has tangential forces).
    fit_order : int
        Order of the spherical-harmonic fit of the normal density.

    Returns
    -------
    NetworkReport
        Arrays and result objects; :meth:`NetworkReport.to_json` gives the JSON form.
    """
    d = net.dim
    notes: list[str] = []
    st = network_stress(net)
    fab = network_fabric(net)
    if min_contacts is None:
        frictional = _frictional(net, shear_modulus, ks)
        min_contacts = rattler_threshold(d, frictional)
        notes.append(f"rattlers: fewer than {min_contacts} force-carrying contacts "
                     f"({'frictional: 2' if frictional else 'frictionless: d + 1'}), removed iteratively")
    co = coordination(net, min_contacts)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_density(net.normals, fit_order, on_negative="allow")
    base: dict[str, Any] = dict(source=net.source, n_particles=net.n_particles, n_contacts=net.n_contacts,
                                volume=net.volume,
                box=net.box, stress=st, fabric=fab, fit=fit, fit_order=fit_order, coordination=co,
                order=tuple(order_for(d)), min_contacts=int(min_contacts))
    have_law = (shear_modulus is not None and poisson is not None) or kn is not None or \
        (net.kn is not None and net.ks is not None)
    if not have_law:
        notes.append("no contact law (give --material): stiffness tensors not computed")
        return NetworkReport(**base, notes=tuple(notes))
    knv, ksv, used = contact_stiffnesses(net, shear_modulus=shear_modulus, poisson=poisson,
                                         source=stiffness_source, kn=kn, ks=ks)
    Ca = affine_stiffness(net, knv, ksv, geometric=geometric)
    notes.append("affine: seed Eq. 2.26, full tangential projector, all contacts, stiffness terms only"
                 + (" + geometric term -(N/|l|)(I - nn)" if geometric else ""))

    def eng(C: np.ndarray) -> Any:
        try:
            return engineering_constants(C)
        except GrainmechError as exc:  # singular stiffness: report why instead of NaN
            notes.append(f"engineering constants not available: {exc}")
            return None

    ea = eng(Ca)
    Ccf = None
    if d == 3:
        try:
            Ccf = closed_form_from_fit(
                fit_density(net.normals, 2, on_negative="allow") if fit_order != 2 else fit, net, knv, ksv)
            notes.append("closed form: seed Eq. 4.21-4.33 with the fitted a20, a22, b22, mean kn, ks and "
                         "(C/V)<l^2>")
        except GrainmechError as exc:
            notes.append(f"closed form not available: {exc}")
    rr = er = None
    if relaxed:
        rr = relaxed_stiffness(net, knv, ksv, remove_rattlers=remove_rattlers, min_contacts=min_contacts,
                               geometric=geometric, solver=solver)
        er = eng(rr.C_relaxed) if np.any(rr.C_relaxed) else None
        notes.append(f"relaxed: C_affine - (1/V) B^T H^+ B, translations and rotations, rattlers "
                     f"{'removed' if remove_rattlers else 'kept'}; solver {rr.solver}, "
                     f"relative residual {rr.residual:.2g}")
    return NetworkReport(**base, stiffness_source=used, stiffness_affine=Ca, stiffness_closed_form=Ccf,
                         engineering_affine=ea, engineering_relaxed=er, relaxed=rr, notes=tuple(notes))


def network_report_json(net: ContactNetwork, **options: Any) -> dict:
    """:func:`network_report` as a JSON-ready dict (``network_report(...).to_json()``)."""
    return network_report(net, **options).to_json()

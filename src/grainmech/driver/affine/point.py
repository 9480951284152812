"""Material point: contact-set geometry + contact law + per-contact state (seed Ch. 2).

Kinematic hypothesis (seed Eq. 2.13): under a strain increment ``d eps`` (compression
positive) each row of the contact set gets the relative displacement
``delta = d eps . l`` (approach positive), normal part ``d_n = delta . n`` and tangential
part ``delta - d_n n``. The law updates the forces ``f = N n + T`` (exerted by A on B);
the stress is the Love-Weber average ``sigma = sum_c w_c f_c (x) l_c`` (seed Eq. 2.6,
symmetric part) and the tangent stiffness is assembled from the laws' tangent
stiffnesses with :func:`grainmech.assembly.stiffness` (seed Eq. 2.26 / 2.41).

Normals and branch vectors are fixed (small-strain form). The driver can add the
first-order finite-deformation correction of seed Eq. 2.36-2.38 (corrected form of
``docs/seed-errata.md`` E-2.34) to the stress, see :func:`geometric_stiffness`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from grainmech.assembly import ContactSet, static_contact_forces
from grainmech.contact.interface import coulomb_limit, make_law
from grainmech.contact.law import ContactResponse
from grainmech.conventions import stress_to_vector, vector_to_stress
from grainmech.driver.affine.response import (  # noqa: F401 (names this module had)
    Evaluation,
    consistent_tangent,
    contact_stress,
    evaluate,
    geometric_stiffness,
    sliding_open_fractions,
    tangent,
)
from grainmech.driver.affine.solver import run
from grainmech.driver.paths import segment
from grainmech.errors import ConfigError, GrainmechError
from grainmech.material import Microstructure, normal_forces_for_stress

__all__ = ["MaterialPoint", "geometry", "Evaluation", "evaluate", "tangent", "geometric_stiffness"]


def geometry(source: Any, *, extra_degree: int = 4) -> ContactSet:
    """Contact-set geometry from a :class:`~grainmech.material.Microstructure` or a :class:`ContactSet`.

    Parameters
    ----------
    source : Microstructure or ContactSet
        A packing is discretised by quadrature of its fabric density (seed Eq. 2.41,
        ``extra_degree`` as in :meth:`ContactSet.from_density`); a contact set (regular
        packing or measured network) is used as is (its stiffnesses are ignored).
    """
    if isinstance(source, Microstructure):
        cs = source.contact_set(kn=0.0, ks=0.0, extra_degree=extra_degree)
    elif isinstance(source, ContactSet):
        cs = source
    else:
        raise ConfigError("geometry", type(source).__name__, "must be a Microstructure or a ContactSet")
    if cs.dim != 3:
        raise ConfigError("geometry.dim", cs.dim, "the driver works in 3D (6-component paths)")
    return cs


@dataclass(frozen=True)
class MaterialPoint:
    """Converged state of a material point.

    Attributes
    ----------
    contacts : ContactSet
        Geometry (normals, branch vectors ``l`` [length], weights [1/volume]).
    law : ContactLawProtocol (:mod:`grainmech.contact.interface`)
    state : per-contact law state
    response : ContactResponse at ``state``
    strain : (6,) total strain since the reference state, engineering shear, library order
    stress : (6,) stress [force/length^2], compression positive: the Love-Weber stress of
        the contact forces plus ``correction``
    correction : (6,) accumulated first-order finite-deformation correction (seed
        Eq. 2.36-2.38 with errata E-2.34); zero unless the driver runs with
        ``finite_deformation=True``
    """

    contacts: ContactSet
    law: Any
    state: Any
    response: ContactResponse
    strain: np.ndarray
    stress: np.ndarray
    correction: np.ndarray = field(default_factory=lambda: np.zeros(6))

    # --------------------------------------------------------------- derived
    @cached_property
    def tangent(self) -> np.ndarray:
        """Consistent tangent (6, 6) Voigt, from the laws' ``kn``, ``ks`` (seed Eq. 2.26)."""
        return tangent(self.contacts, self.response)

    def fractions(self) -> tuple[float, float]:
        """(sliding, open) fractions of contacts, weighted by ``w``."""
        return sliding_open_fractions(self.contacts, self.response)

    def stored_energy(self) -> float:
        """Elastic energy per unit volume held by the contacts (see the law's notes)."""
        return float(np.dot(self.contacts.weights, self.law.stored_energy(self.state)))

    # --------------------------------------------------------------- constructors
    @classmethod
    def from_forces(cls, source: Any, law: Any, normal_force: np.ndarray,
                    tangential_force: np.ndarray | None = None, *, extra_degree: int = 4,
                    backend: str = "auto") -> MaterialPoint:
        """Point whose contacts carry given forces (virgin tangential history).

        ``law``: a contact parameter object or a law (:class:`~grainmech.contact.interface.ContactLawProtocol`);
        ``backend`` ({"auto", "numpy", "numba"}) selects the evaluation of a parameter object's
        law (:func:`grainmech.contact.update`).
        """
        cs = geometry(source, extra_degree=extra_degree)
        lw = make_law(law, backend=backend)
        st = lw.initial_state(normal_force, tangential_force)
        resp = lw.response(st)
        return cls(cs, lw, st, resp, np.zeros(6), contact_stress(cs, resp))

    @classmethod
    def isotropic(cls, source: Any, law: Any, pressure: float, *, extra_degree: int = 4,
                  backend: str = "auto") -> MaterialPoint:
        """Point under isotropic stress ``pressure`` with purely normal contact forces.

        Forces from :func:`grainmech.material.normal_forces_for_stress` (for an isotropic
        fabric: seed Eq. 4.43, ``N = 3 V P / (N l)``).
        """
        if not np.isfinite(pressure) or pressure <= 0:
            raise ConfigError("pressure", pressure, "must be a positive stress (compression positive)")
        cs = geometry(source, extra_degree=extra_degree)
        N = normal_forces_for_stress(cs, pressure * np.eye(3))
        return cls.from_forces(cs, law, N, None, backend=backend)

    @classmethod
    def at_stress(cls, source: Any, law: Any, sigma: Any, *, initial: str = "state-estimate",
                  start_pressure: float | None = None, n_steps: int = 50, extra_degree: int = 4,
                  backend: str = "auto", **run_options: Any) -> MaterialPoint:
        """Point at an anisotropic stress, by one of two methods (``docs/models/affine.md``).

        Parameters
        ----------
        sigma : (6,) stress vector or (3, 3) tensor, compression positive
        initial : {"state-estimate", "path-following"}
            ``state-estimate`` (seed Sec. 6.3.2): forces ``f_c = sigma F^-1 l_c``
            (:func:`grainmech.assembly.static_contact_forces`, exact Love-Weber inverse),
            tangential parts capped at ``mu N``, each contact put on its virgin branch at
            that force; tangent moduli from those forces. If the cap acts, the stress of
            the point is the Love-Weber stress of the capped forces (smaller deviator).
            ``path-following``: start isotropic at ``start_pressure`` (default: mean
            stress of ``sigma``) and load along the straight stress path to ``sigma`` in
            ``n_steps`` stress-controlled steps with the contact laws' history.
        run_options : passed to :func:`grainmech.driver.run` (path-following only).

        Raises
        ------
        GrainmechError
            If path-following fails (the message names the step and cause).
        """
        sig = np.asarray(sigma, dtype=float)
        if sig.shape == (6,):
            sig = vector_to_stress(sig)
        if sig.shape != (3, 3) or not np.all(np.isfinite(sig)):
            raise ConfigError("sigma", np.asarray(sigma).shape, "must be a finite (6,) vector or (3, 3) tensor")
        cs = geometry(source, extra_degree=extra_degree)
        if initial == "state-estimate":
            lw = make_law(law, backend=backend)
            f = static_contact_forces(cs, sig)
            n = cs.normals
            N = np.einsum("ci,ci->c", f, n)
            T = f - N[:, None] * n
            tension = N < 0
            N = np.where(tension, 0.0, N)
            T = np.where(tension[:, None], 0.0, T)
            mag = np.linalg.norm(T, axis=1)
            cap = coulomb_limit(lw.friction, N)
            scale = np.ones_like(mag)
            np.divide(cap, mag, out=scale, where=mag > cap)
            T = T * scale[:, None]
            return cls.from_forces(cs, lw, N, T)
        if initial == "path-following":
            p0 = float(np.trace(sig) / 3) if start_pressure is None else float(start_pressure)
            pt = cls.isotropic(cs, law, p0, backend=backend)
            path = segment("SSSSSS", stress_to_vector(sig) - pt.stress, n_steps)
            res = run(pt, path, **run_options)
            if not res.success:
                raise GrainmechError(f"path-following initial state failed: {res.message}")
            return res.final
        raise ConfigError("initial", initial, "must be 'state-estimate' or 'path-following'")

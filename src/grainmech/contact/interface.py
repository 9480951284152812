"""One contact-law interface for every driver (material point and packing).

A driver sees a contact law only through :class:`ContactLawProtocol`: parameters ->
initial state -> ``update(state, d_normal, d_tangential) -> (new_state, response)``, a
pure function over arrays with the contact axis first (quadrature directions for the
material-point driver, the contacts of a packing for the packing driver). The response
(:class:`~grainmech.contact.ContactResponse`) carries the forces, the dissipation of the
step and the consistent tangent stiffnesses ``kn``, ``ks`` (along the slip axis),
``ks_perp`` (across it), ``ktn`` (normal-tangential coupling) and the slip axis ``e``,
from which a driver builds the contact tangent (seed Eq. 3.11 with Thornton & Randall's
coupling term)::

    K = kn n n + ks e e + ks_perp (I - n n - e e) + ktn e n

:class:`ContactLaw` is the implementation over :func:`grainmech.contact.update` (the
NumPy reference or its compiled kernel, ``backend``) for every parameter class of
:mod:`grainmech.contact.params`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from grainmech.contact import geometry as geo
from grainmech.contact.forms import law_forms
from grainmech.contact.law import ContactResponse, ContactState, compiled_kernel, state_from_normal_force, update

__all__ = ["ContactLawProtocol", "ContactLaw", "make_law", "coulomb_limit", "contact_tangent"]


@runtime_checkable
class ContactLawProtocol(Protocol):
    """What a driver needs from a contact law (``n`` contacts, 3D tangential vectors).

    Attributes
    ----------
    params : the law's frozen parameter object
    friction : float
        Coulomb coefficient ``mu`` (``inf`` for no sliding).
    """

    @property
    def params(self) -> Any:
        """The law's frozen parameter object."""
        ...

    @property
    def friction(self) -> float:
        """Coulomb coefficient ``mu`` (``inf`` for no sliding)."""
        ...

    def initial_state(self, normal_force: np.ndarray,
                      tangential_force: np.ndarray | None = None) -> ContactState:
        """Virgin contacts at normal forces (n,) and tangential forces (n, 3) [N]."""
        ...

    def update(self, state: ContactState, d_normal: np.ndarray,
               d_tangential: np.ndarray) -> tuple[ContactState, ContactResponse]:
        """Advance by approach increments (n,) and tangential increments (n, 3) [m] (pure)."""
        ...

    def response(self, state: ContactState) -> ContactResponse:
        """Forces and tangents at ``state`` (a zero increment; no dissipation)."""
        ...

    def stored_energy(self, state: ContactState) -> np.ndarray:
        """Elastic energy held by each contact (n,) [J]."""
        ...


def coulomb_limit(mu: float, N: np.ndarray) -> np.ndarray:
    """``mu N`` without ``inf * 0``: 0 where ``N <= 0``, ``inf`` for ``mu = inf`` and ``N > 0``."""
    N = np.asarray(N, dtype=float)
    out = np.zeros_like(N)
    pos = N > 0
    out[pos] = np.inf if math.isinf(mu) else mu * N[pos]
    return out


def contact_tangent(normals: np.ndarray, response: ContactResponse) -> np.ndarray:
    """Consistent contact tangents ``K`` (n, 3, 3), ``dF = K d delta`` (module notes).

    ``K = kn n n + ks e e + ks_perp (I - n n - e e) + ktn e n`` with negative stiffnesses
    clipped to 0 (``ktn`` kept with its sign); ``e = 0`` gives ``kn n n + ks_perp (I - n n)``.
    """
    n = np.asarray(normals, dtype=float)
    e = np.asarray(response.axis, dtype=float)
    kn = np.maximum(response.kn, 0.0)
    ks = np.maximum(response.ks, 0.0)
    ksp = np.maximum(response.ks_perp, 0.0)
    nn = np.einsum("ci,cj->cij", n, n)
    ee = np.einsum("ci,cj->cij", e, e)
    eye = np.eye(n.shape[1])[None]
    return (kn[:, None, None] * nn + ks[:, None, None] * ee + ksp[:, None, None] * (eye - nn - ee)
            + response.ktn[:, None, None] * np.einsum("ci,cj->cij", e, n))


@dataclass(frozen=True)
class ContactLaw:
    """:class:`ContactLawProtocol` over :func:`grainmech.contact.update`.

    Parameters
    ----------
    params : any :mod:`grainmech.contact.params` object
    backend : {"auto", "numpy", "numba"}
        Passed to :func:`grainmech.contact.update` (``numpy``: the reference path).
    """

    params: Any
    backend: str = "auto"

    def __post_init__(self) -> None:
        law_forms(self.params)  # TypeError for anything else
        compiled_kernel(self.params, self.backend)  # ValueError/ImportError for a bad backend

    @property
    def friction(self) -> float:
        """Coulomb coefficient ``mu`` of the law (``inf`` for no sliding)."""
        return float(self.params.friction)

    @property
    def compiled(self) -> bool:
        """The compiled kernel evaluates this law (numba present and the law supported)."""
        return compiled_kernel(self.params, self.backend) is not None

    def initial_state(self, normal_force: np.ndarray,
                      tangential_force: np.ndarray | None = None) -> ContactState:
        """Virgin contacts at ``N`` with tangential force ``T`` on the virgin (skeleton) branch.

        ``|T| <= mu N`` is required (the caller caps). The memory axis is ``T/|T|``, no
        reversal is remembered, so the tangent is seed Eq. 3.11 with theta from Eq. 3.13.
        """
        st = state_from_normal_force(self.params, np.maximum(np.asarray(normal_force, float), 0.0), 3)
        if tangential_force is None:
            return st
        T = np.asarray(tangential_force, dtype=float)
        mag = np.linalg.norm(T, axis=1)
        axis = np.zeros_like(T)
        np.divide(T, mag[:, None], out=axis, where=mag[:, None] > 0)
        muN = coulomb_limit(self.friction, st.normal_force)
        sliding = (mag >= muN * (1.0 - 1e-12)) & (mag > 0)
        return st._replace(tangential_force=T, axis=axis, sliding=sliding)

    def update(self, state: ContactState, d_normal: np.ndarray,
               d_tangential: np.ndarray) -> tuple[ContactState, ContactResponse]:
        """:func:`grainmech.contact.update` with this law's parameters and backend."""
        return update(self.params, state, d_normal, d_tangential, backend=self.backend)

    def response(self, state: ContactState) -> ContactResponse:
        """Forces and tangent at a state (a zero increment of the law).

        With ``backend="auto"`` evaluated by the NumPy reference: one call, cheap in NumPy,
        which spares a run that needs no other call of the per-call compiled kernel (the
        drivers' compiled loops call the law inside) from compiling it.
        """
        n = state.approach.shape[0]
        backend = "numpy" if self.backend == "auto" else self.backend
        _, r = update(self.params, state, np.zeros(n), np.zeros((n, state.tangential_force.shape[1])),
                      backend=backend)
        return r._replace(dissipation=np.zeros(n))

    def stored_energy(self, state: ContactState) -> np.ndarray:
        """Elastic energy estimate per contact [J].

        Normal part exact (Hertz ``2/5 N alpha``, linear ``N alpha / 2``; rods: not
        evaluated, 0); tangential part ``|T|^2 / (2 kt0)``, exact for the elastic-Coulomb
        laws at constant ``N``, a lower bound for the hysteretic laws (whose stored energy
        depends on the slip distribution). Rods: 0.
        """
        forms = law_forms(self.params)
        N = state.normal_force
        if forms.kind == "md" and not forms.compiled:  # rods
            return np.zeros_like(N)
        en = forms.normal_energy(N, state.approach)
        if forms.linear:
            kt0 = forms.kt0(N)
        else:  # 8 G* a with a = (R* alpha)^(1/2) (seed Eq. 3.5, 3.11), as the compiled pass
            kt0 = geo.mindlin_kt0(geo.hertz_radius_from_approach(state.approach, self.params.effective_radius),
                                  self.params.effective_shear_modulus)
        T2 = np.einsum("ci,ci->c", state.tangential_force, state.tangential_force)
        et = np.zeros_like(N)
        np.divide(T2, 2.0 * kt0, out=et, where=kt0 > 0)
        return en + et


def make_law(params: Any, backend: str = "auto") -> ContactLawProtocol:
    """The law for a parameter object (a law object is returned as is).

    Raises
    ------
    ValueError
        ``params`` is not a contact parameter object or law, or ``backend`` is unknown.
    """
    if isinstance(params, ContactLawProtocol) and not isinstance(params, type):
        return params
    try:
        return ContactLaw(params, backend)
    except TypeError:
        raise ValueError(f"law: {type(params).__name__} is not a grainmech.contact parameter object") from None

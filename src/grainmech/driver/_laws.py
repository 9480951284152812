"""Adapter between the driver and the contact laws (the ONE place that knows them).

The driver needs, for many contacts at once (contact axis first):

* ``initial_state(normal_force, tangential_force=None)`` -> state
* ``update(state, d_normal, d_tangential)`` -> ``(new_state, LawResponse)`` (pure)
* ``stored_energy(state)`` -> (n,) elastic energy held by each contact
* ``friction`` (Coulomb coefficient ``mu``)

When this module was written, ``grainmech.contact`` provided the parameter classes and
closed-form geometry (``contact/params.py``, ``contact/geometry.py``) but not yet the
incremental ``update`` functions. This adapter therefore implements the incremental laws
itself, on top of those parameter classes and the Hertz formulas of
``contact/geometry.py``:

``IwanLaw`` -- normal law (Hertz, seed Eq. 3.6-3.7, or a linear spring) plus a tangential
law made of ``M`` parallel vector Jenkins elements (spring ``k_j`` in series with a
Coulomb slider of strength ``s_j``), the Iwan (1967) representation of a Masing material:

* ``M = 1`` with ``k = kt0`` and ``s = mu N``: linear (Cundall-Strack) or Mindlin no-slip
  spring with a Coulomb cap (:class:`~grainmech.contact.params.LinearSpring`,
  :class:`~grainmech.contact.params.HertzMindlin`).
* ``M > 1`` (default 32) with equal stiffnesses ``k_j = kt0/M`` and strengths chosen so
  that the monotonic backbone is the Mindlin-Deresiewicz curve at constant ``N``
  (seed Eq. 3.9-3.10)::

      T(u) = mu N [1 - (1 - u/u*)^(3/2)],  u* = 3 mu N / (2 kt0),  kt0 = 8 G* a

  i.e. the tangent ``dT/du = kt0 (1 - T/(mu N))^(1/3)`` (seed Eq. 3.11). Unloading and
  reloading then follow Masing's rule (seed Eq. 3.13-3.16) automatically, with perfect
  memory of nested reversals and no limit on their number. Writing ``S = sqrt(1-u/u*)``,
  element ``j`` covers ``S in [1 - j/M, 1 - (j-1)/M]`` and its strength is the exact
  integral ``s_j = kt0 u* [dS - d(S^3)/3]`` (they sum to ``mu N``). The error of this
  piecewise-linear backbone is O(1/M^2) in force; it is exact for amplitudes below the
  first slip displacement ``u_1 ~ 2 u*/M``.

Elements store their elastic displacement vectors ``e_j`` (n, M, 3); ``t_j = k_j(N) e_j``.
When ``N`` (hence ``k_j`` and ``s_j``) changes, the element forces follow and are returned
to their slip limit if needed: this is the simple "rescaled Iwan" treatment of varying
normal force, not the full Thornton-Randall rules of the contact module. Dissipation of an
element slip ``dp`` is ``s_j dp`` (exact for radial return). An opening contact releases its
tangential energy, which is counted as dissipated.

The tangent returned is the sticking stiffness ``ks = sum_j k_j [element j did not slip]``
applied through the full projector ``ks (I - n n)`` by the assembly (sliding elements
contribute 0, a slight under-estimate in the direction normal to their force; the driver's
Newton iterations re-evaluate the law, so only convergence speed depends on it).

``ContactLaw`` -- the production path: a thin wrapper of
:func:`grainmech.contact.update` (exact Mindlin-Deresiewicz / Thornton-Randall law with
reversal memory, Jenkins and frictionless laws, rods), which landed while the driver was
written. :func:`make_law` uses it by default (``backend="contact"``); ``backend="iwan"``
selects the independent Iwan implementation above, kept as a cross-check of the
hysteretic law (the two agree to the Iwan discretisation error, tested).

Nothing else in the driver imports contact laws.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from grainmech.contact.geometry import (
    hertz_approach_from_force,
    hertz_normal_force,
    hertz_normal_stiffness_from_approach,
)
from grainmech.contact.params import Hertz, HertzMindlin, LinearSpring, MindlinDeresiewicz
from grainmech.errors import ConfigError

__all__ = ["ContactLaw", "LawState", "LawResponse", "IwanLaw", "make_law", "md_fractions", "DEFAULT_ELEMENTS"]

#: default number of Jenkins elements representing the Mindlin-Deresiewicz backbone
DEFAULT_ELEMENTS = 32


@dataclass(frozen=True)
class LawState:
    """Per-contact history.

    Attributes
    ----------
    approach : (n,) normal approach (overlap) [length], positive in compression
    elastic : (n, M, 3) elastic displacement of each Jenkins element [length]
    """

    approach: np.ndarray
    elastic: np.ndarray


@dataclass(frozen=True)
class LawResponse:
    """Forces and tangent stiffnesses after an update (shapes (n,), (n, 3)).

    ``ks`` is the tangent along the slip (memory) axis ``axis``, ``ks_perp`` the one
    across it and ``ktn = d tau / d alpha`` the normal-tangential coupling (Thornton &
    Randall's ``mu dN (1 - theta)`` term, seed Eq. 3.11), as in
    :class:`grainmech.contact.ContactResponse`; together they give the consistent contact
    tangent ``K = ks_perp (I - n n - e e) + kn n n + ks e e + ktn e n`` that the driver's
    Newton iterations use (:func:`grainmech.driver.point.consistent_tangent`). ``None``
    where a law does not provide them (then ``K = kn n n + ks (I - n n)``).
    """

    normal_force: np.ndarray
    tangential_force: np.ndarray
    kn: np.ndarray
    ks: np.ndarray
    sliding: np.ndarray
    open: np.ndarray
    dissipation: np.ndarray
    ks_perp: np.ndarray | None = None
    ktn: np.ndarray | None = None
    axis: np.ndarray | None = None


def _coulomb_limit(mu: float, N: np.ndarray) -> np.ndarray:
    """``mu N`` without ``inf * 0``: 0 where ``N <= 0``, ``inf`` for ``mu = inf`` and ``N > 0``."""
    N = np.asarray(N, dtype=float)
    out = np.zeros_like(N)
    pos = N > 0
    out[pos] = np.inf if math.isinf(mu) else mu * N[pos]
    return out


def coulomb_limit(mu: float, N: np.ndarray) -> np.ndarray:
    """Public alias of the NaN-free Coulomb limit ``mu N`` (used by the driver)."""
    return _coulomb_limit(mu, N)


def md_fractions(m: int) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and strength fractions of ``m`` Jenkins elements (module notes).

    Returns
    -------
    kfrac, sfrac : arrays (m,)
        ``k_j = kfrac_j kt0`` and ``s_j = sfrac_j mu N``; both sum to 1.
    """
    if m == 1:
        return np.ones(1), np.ones(1)
    S = 1.0 - np.arange(m + 1) / m  # from 1 down to 0
    dS = S[:-1] - S[1:]
    dS3 = S[:-1] ** 3 - S[1:] ** 3
    sfrac = 1.5 * (dS - dS3 / 3.0)
    return np.full(m, 1.0 / m), sfrac


@dataclass(frozen=True)
class IwanLaw:
    """Normal law + Iwan tangential law (see module notes).

    Parameters
    ----------
    params : LinearSpring, Hertz, HertzMindlin or MindlinDeresiewicz
    n_elements : int
        Jenkins elements (1 for linear/Mindlin no-slip laws).
    """

    params: Any
    n_elements: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.params, (LinearSpring, Hertz)):
            raise ConfigError("law", type(self.params).__name__,
                              "the driver adapter supports LinearSpring, Hertz, HertzMindlin and "
                              "MindlinDeresiewicz (Cylinder waits for grainmech.contact.update)")
        if int(self.n_elements) < 1:
            raise ConfigError("n_elements", self.n_elements, "must be >= 1")
        kf, sf = md_fractions(int(self.n_elements))
        object.__setattr__(self, "_kfrac", kf)
        object.__setattr__(self, "_sfrac", sf)

    # ----------------------------------------------------------------- normal law
    @property
    def linear(self) -> bool:
        return isinstance(self.params, LinearSpring)

    @property
    def friction(self) -> float:
        return float(self.params.friction)

    def _normal(self, approach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a = np.maximum(approach, 0.0)
        if self.linear:
            kn = np.where(approach > 0, self.params.kn, 0.0)
            return self.params.kn * a, kn
        return hertz_normal_force(a, self.params), hertz_normal_stiffness_from_approach(a, self.params)

    def _kt0(self, approach: np.ndarray) -> np.ndarray:
        if self.linear:
            return np.where(approach > 0, self.params.ks, 0.0)
        if type(self.params) is Hertz:
            return np.zeros_like(approach)
        # no-slip Mindlin stiffness 8 G* a, a = sqrt(R* alpha) (seed Eq. 3.5, 3.11)
        a = np.sqrt(self.params.effective_radius * np.maximum(approach, 0.0))
        return 8.0 * self.params.effective_shear_modulus * a

    def _strength(self, N: np.ndarray) -> np.ndarray:
        return _coulomb_limit(self.friction, N)

    def approach_from_force(self, N: np.ndarray) -> np.ndarray:
        N = np.maximum(np.asarray(N, dtype=float), 0.0)
        if self.linear:
            return N / self.params.kn
        return hertz_approach_from_force(N, self.params)

    # ----------------------------------------------------------------- API
    def initial_state(self, normal_force: np.ndarray,
                      tangential_force: np.ndarray | None = None) -> LawState:
        """State with given forces, reached by virgin monotonic tangential loading.

        Parameters
        ----------
        normal_force : (n,) compressive normal forces (>= 0)
        tangential_force : (n, 3), optional
            Tangential forces (in the tangent plane); must satisfy ``|T| <= mu N``
            (the caller caps them). Each contact is placed on its virgin backbone at
            ``|T|`` along the direction of ``T``.
        """
        N = np.maximum(np.asarray(normal_force, dtype=float), 0.0)
        n = N.shape[0]
        alpha = self.approach_from_force(N)
        el = np.zeros((n, int(self.n_elements), 3))
        if tangential_force is not None:
            T = np.asarray(tangential_force, dtype=float)
            mag = np.linalg.norm(T, axis=1)
            kt0 = self._kt0(alpha)
            k = kt0[:, None] * self._kfrac[None, :]
            s = self._strength(N)[:, None] * self._sfrac[None, :]
            with np.errstate(divide="ignore", invalid="ignore"):
                uy = np.where(k > 0, s / np.where(k > 0, k, 1.0), 0.0)  # yield displacement
            u = self._backbone_inverse(mag, k, s, uy)
            ej = np.minimum(u[:, None], uy)
            ej = np.where(np.isfinite(ej), ej, 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                d = np.where(mag[:, None] > 0, T / np.where(mag > 0, mag, 1.0)[:, None], 0.0)
            el = ej[:, :, None] * d[:, None, :]
        return LawState(alpha, el)

    @staticmethod
    def _backbone_inverse(mag, k, s, uy):
        """Displacement u with sum_j min(k_j u, s_j) = mag (piecewise linear, exact)."""
        n, m = k.shape
        u = np.zeros(n)
        for i in range(n):
            if mag[i] <= 0:
                continue
            order = np.argsort(uy[i])
            ys, ks, ss = uy[i][order], k[i][order], s[i][order]
            # T(u) at the breakpoints
            cum_s = np.concatenate([[0.0], np.cumsum(ss)])
            k_rem = np.concatenate([np.cumsum(ks[::-1])[::-1], [0.0]])
            done = False
            for j in range(m):
                Tj = cum_s[j] + k_rem[j] * ys[j]
                if mag[i] <= Tj or not np.isfinite(Tj):
                    u[i] = (mag[i] - cum_s[j]) / k_rem[j] if k_rem[j] > 0 else ys[j]
                    done = True
                    break
            if not done:
                u[i] = ys[-1]
        return u

    def update(self, state: LawState, d_normal: np.ndarray,
               d_tangential: np.ndarray) -> tuple[LawState, LawResponse]:
        """Advance every contact by approach ``d_normal`` (n,) and tangential ``d_tangential`` (n, 3)."""
        alpha = state.approach + d_normal
        N, kn = self._normal(alpha)
        is_open = alpha <= 0.0
        kt0 = self._kt0(alpha)
        k = kt0[:, None] * self._kfrac[None, :]
        s = self._strength(N)[:, None] * self._sfrac[None, :]
        e_old = state.elastic
        stored_before_open = 0.5 * np.einsum("cm,cmi,cmi->c", k, e_old, e_old)
        e_tr = e_old + d_tangential[:, None, :]
        t_tr = k[:, :, None] * e_tr
        tmag = np.linalg.norm(t_tr, axis=2)
        slip = tmag > s * (1.0 + 1e-12)
        scale = np.ones_like(tmag)
        np.divide(s, tmag, out=scale, where=slip)
        e_new = e_tr * scale[:, :, None]
        # slip displacement |e_tr| - |e_new| times the strength
        emag_tr = np.linalg.norm(e_tr, axis=2)
        dp = np.where(slip, emag_tr * (1.0 - scale), 0.0)
        sdp = np.zeros_like(dp)
        np.multiply(s, dp, out=sdp, where=slip)  # slip implies a finite strength
        diss = np.sum(sdp, axis=1)
        # contacts that open lose their tangential elastic energy (counted as dissipated)
        if np.any(is_open):
            diss = np.where(is_open, diss + np.where(is_open, stored_before_open, 0.0), diss)
            e_new = np.where(is_open[:, None, None], 0.0, e_new)
            slip = np.where(is_open[:, None], False, slip)
        T = np.einsum("cm,cmi->ci", k, e_new)
        ks = np.sum(np.where(slip, 0.0, k), axis=1)
        sliding = slip[:, -1] | (np.all(slip, axis=1) & (kt0 > 0))
        resp = LawResponse(N, T, kn, ks, sliding & ~is_open, is_open, diss)
        return LawState(alpha, e_new), resp

    def response(self, state: LawState) -> LawResponse:
        """Forces and tangent at a state (elements at their slip limit count as sliding)."""
        alpha = state.approach
        N, kn = self._normal(alpha)
        kt0 = self._kt0(alpha)
        k = kt0[:, None] * self._kfrac[None, :]
        s = self._strength(N)[:, None] * self._sfrac[None, :]
        t = k[:, :, None] * state.elastic
        at_limit = (np.linalg.norm(t, axis=2) >= s * (1.0 - 1e-9)) & (s > 0)
        T = np.einsum("cm,cmi->ci", k, state.elastic)
        ks = np.sum(np.where(at_limit, 0.0, k), axis=1)
        is_open = alpha <= 0.0
        return LawResponse(N, T, kn, ks, at_limit[:, -1] & ~is_open, is_open, np.zeros_like(N))

    def stored_energy(self, state: LawState) -> np.ndarray:
        """Elastic energy per contact: normal (Hertz ``2/5 N alpha`` or ``kn alpha^2/2``) + springs."""
        alpha = np.maximum(state.approach, 0.0)
        N, _ = self._normal(alpha)
        en = 0.5 * N * alpha if self.linear else 0.4 * N * alpha
        k = self._kt0(alpha)[:, None] * self._kfrac[None, :]
        return en + 0.5 * np.einsum("cm,cmi,cmi->c", k, state.elastic, state.elastic)


@dataclass(frozen=True)
class ContactLaw:
    """Wrapper of :func:`grainmech.contact.update` with the driver's law interface.

    Parameters
    ----------
    params : any :mod:`grainmech.contact.params` object
    """

    params: Any

    @property
    def friction(self) -> float:
        return float(self.params.friction)

    def initial_state(self, normal_force: np.ndarray, tangential_force: np.ndarray | None = None):
        """Virgin contacts at ``N`` with tangential force ``T`` on the virgin (skeleton) branch.

        ``|T| <= mu N`` is required (the caller caps). The memory axis is ``T/|T|``, no
        reversal is remembered, so the tangent is seed Eq. 3.11 with theta from Eq. 3.13.
        """
        from grainmech.contact import state_from_normal_force

        st = state_from_normal_force(self.params, np.maximum(np.asarray(normal_force, float), 0.0), 3)
        if tangential_force is None:
            return st
        T = np.asarray(tangential_force, dtype=float)
        mag = np.linalg.norm(T, axis=1)
        axis = np.zeros_like(T)
        np.divide(T, mag[:, None], out=axis, where=mag[:, None] > 0)
        muN = _coulomb_limit(self.friction, st.normal_force)
        sliding = (mag >= muN * (1.0 - 1e-12)) & (mag > 0)
        return st._replace(tangential_force=T, axis=axis, sliding=sliding)

    def update(self, state, d_normal: np.ndarray, d_tangential: np.ndarray):
        from grainmech.contact import update

        new, r = update(self.params, state, d_normal, d_tangential)
        return new, LawResponse(r.normal_force, r.tangential_force, r.kn, r.ks, r.sliding, r.open,
                                r.dissipation, r.ks_perp, r.ktn, r.axis)

    def response(self, state) -> LawResponse:
        """Forces and tangent at a state (a zero increment of the law)."""
        n = state.approach.shape[0]
        _, r = self.update(state, np.zeros(n), np.zeros((n, 3)))
        return replace(r, dissipation=np.zeros(n))

    def stored_energy(self, state) -> np.ndarray:
        """Elastic energy estimate per contact.

        Normal part exact (Hertz ``2/5 N alpha``, linear ``N alpha / 2``); tangential part
        ``|T|^2 / (2 kt0)``, exact for the Jenkins laws (linear spring / Mindlin no-slip with
        Coulomb cap at constant ``N``), a lower bound for the hysteretic laws (whose stored
        energy depends on the slip distribution). Rods: normal part not evaluated (0).
        """
        from grainmech.contact.params import Cylinder as _Cyl

        N = state.normal_force
        a = np.maximum(state.approach, 0.0)
        if isinstance(self.params, LinearSpring):
            en = 0.5 * N * a
            kt0 = np.where(N > 0, self.params.ks, 0.0)
        elif isinstance(self.params, _Cyl):
            return np.zeros_like(N)
        else:
            en = 0.4 * N * a
            kt0 = 8.0 * self.params.effective_shear_modulus * np.sqrt(self.params.effective_radius * a)
        T2 = np.einsum("ci,ci->c", state.tangential_force, state.tangential_force)
        et = np.zeros_like(N)
        np.divide(T2, 2.0 * kt0, out=et, where=kt0 > 0)
        return en + et


def make_law(params: Any, n_elements: int | None = None, backend: str = "contact") -> Any:
    """The driver's incremental law for a parameter object of :mod:`grainmech.contact.params`.

    Parameters
    ----------
    params : LinearSpring | Hertz | HertzMindlin | MindlinDeresiewicz
    n_elements : int, optional
        Iwan backend only: Jenkins elements for :class:`MindlinDeresiewicz` (default
        :data:`DEFAULT_ELEMENTS`); the other laws use one.
    backend : {"contact", "iwan"}
        ``contact``: :func:`grainmech.contact.update` (default); ``iwan``: the
        independent Iwan implementation of this module.
    """
    if isinstance(params, (IwanLaw, ContactLaw)):
        return params
    if backend == "contact":
        from grainmech.contact import law_kind

        try:
            law_kind(params)
        except TypeError:
            raise ConfigError("law", type(params).__name__, "is not a grainmech.contact parameter object") from None
        return ContactLaw(params)
    if backend != "iwan":
        raise ConfigError("backend", backend, "must be 'contact' or 'iwan'")
    if isinstance(params, MindlinDeresiewicz):
        return IwanLaw(params, DEFAULT_ELEMENTS if n_elements is None else int(n_elements))
    if isinstance(params, (LinearSpring, HertzMindlin, Hertz)):
        return IwanLaw(params, 1)
    raise ConfigError("law", type(params).__name__,
                      "not supported by the driver adapter (LinearSpring, Hertz, HertzMindlin, "
                      "MindlinDeresiewicz)")

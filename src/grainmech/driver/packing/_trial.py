"""The contact laws at a trial increment of the packing step solver (:mod:`grainmech.driver.packing.step`).

The law call of a point (NumPy reference or compiled, ``_law_step``), the trial state,
response and contact forces (``evaluate_trial``), the compiled counterparts of that glue
(``_Glue``: :mod:`grainmech.driver.packing._kernels`, used when the point's law runs
compiled) and the elastic energy of frictionless contacts (``frictionless_energy``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np

from grainmech.contact import (
    ContactState,
    update,
)
from grainmech.contact.forms import normal_law
from grainmech.contact.law import CompiledUpdate, compiled_kernel
from grainmech.driver.packing._operators import (
    Kinematics,
)
from grainmech.driver.packing.options import SubstepFailure, law_options

if TYPE_CHECKING:
    from grainmech.driver.packing.point import PackingPoint

def _law_call(point: PackingPoint) -> Callable[[np.ndarray, np.ndarray], tuple]:
    """``update(params, state, dn, dt)`` of the point's law from its state (cached on the point).

    Every trial of a step starts from the same committed state: with the compiled kernel
    its inputs are converted once (:class:`grainmech.contact.law.CompiledUpdate`, the same
    results bit for bit), not at every trial.
    """
    hit = point._cache.get("law")
    if hit is not None and hit[0] is point.state and hit[1] == point.law_backend:
        return hit[2]
    kernel = compiled_kernel(point.params, point.law_backend or "auto")
    params, state, kw = point.params, point.state, law_options(point.law_backend)
    fn = (CompiledUpdate(kernel, params, state) if kernel is not None
          else lambda dn, dt: update(params, state, dn, dt, **kw))
    point._cache["law"] = (state, point.law_backend, fn)
    return fn


def _law_step(point: PackingPoint, dn: np.ndarray, dt: np.ndarray) -> tuple:
    """New contact state and response for law-space increments; a law error fails the step."""
    try:
        return _law_call(point)(dn, dt)
    except ValueError as exc:  # GrainmechError (memory, domain) or bad increment
        raise SubstepFailure(f"contact law error: {exc}") from None


class _Glue:
    """The compiled counterparts (:mod:`grainmech.driver.packing._kernels`) of one kinematics' iteration glue.

    :meth:`evaluate` is :func:`evaluate_trial` with ``G^T f`` and ``V sigma``; :meth:`limit`
    is the trust limit of ``_solve`` (:func:`clip_grain_moves`, :func:`trust_ratio`, :func:`stop_closing`).
    """

    def __init__(self, kin: Kinematics, mod: Any) -> None:
        from grainmech.driver.packing._kernels import grain_positions

        self.kin, self.k = kin, mod
        self.g = (kin.G.indptr, kin.G.indices, kin.G.data)
        self.gt = (kin.Gt.indptr, kin.Gt.indices, kin.Gt.data)
        self.pos = grain_positions(kin.free, kin.n_grains)
        self.l, self.n = np.ascontiguousarray(kin.l, dtype=float), np.ascontiguousarray(kin.n, dtype=float)

    def evaluate(self, point: PackingPoint, dq: np.ndarray, de: np.ndarray) -> tuple:
        """``(state, response, f, G^T f, V sigma)`` of the trial ``(dq, de)`` from ``point``."""
        C = self.n.shape[0]
        dn, dt = np.empty(C), np.empty((C, 3))
        if not self.k.contact_increments(*self.g, np.ascontiguousarray(dq, dtype=float), self.l, self.n,
                                         np.ascontiguousarray(de, dtype=float), point.scale, dn, dt):
            raise SubstepFailure("Newton update not finite")
        st, resp = _law_step(point, dn, dt)
        f, rq, vs = np.empty((C, 3)), np.empty(self.kin.n_free), np.empty(6)
        self.k.forces_balance(resp.normal_force, resp.tangential_force, self.n, self.l, *self.gt, f.reshape(-1), rq,
                              vs)
        return st, resp, f, rq, vs

    def limit(self, dxq: np.ndarray, dxe: np.ndarray, S: np.ndarray, R: np.ndarray, move: float,
              approach: np.ndarray | None, cap: float) -> tuple[np.ndarray, np.ndarray]:
        """The update within the trust limit ``move``, each grain by itself (``approach`` None: no closing cap)."""
        k = self.k
        clipped = np.empty(dxq.size)
        k.clip_moves(np.ascontiguousarray(dxq, dtype=float), self.pos, R, move, clipped)
        d6 = np.zeros(6)
        d6[S] = dxe
        dxe = dxe / max(k.affine_move(self.l, d6) / move, 1.0)
        if approach is not None:
            d6[S] = dxe
            capped = np.empty(dxq.size)
            if k.closing_cap(*self.g, clipped, self.l, self.n, d6, np.ascontiguousarray(approach, dtype=float), cap,
                             self.kin.a, self.kin.b, self.pos, np.ones(self.kin.n_grains), capped):
                return capped, dxe
        return clipped, dxe


#: _Glue per kinematics (weak: dropped with the run's points); None where numba is missing
_GLUE: WeakKeyDictionary = WeakKeyDictionary()


def compiled_glue(point: PackingPoint) -> _Glue | None:
    """The compiled iteration glue when the point's law runs compiled and numba imports, else None (NumPy)."""
    if point.law_backend == "numpy" or compiled_kernel(point.params, point.law_backend or "auto") is None:
        return None
    kin = point.kinematics
    if kin not in _GLUE:
        try:
            from grainmech.driver.packing import _kernels as _packing_kernels
        except ImportError:  # pragma: no cover - numba present whenever a compiled law is
            return None
        _GLUE[kin] = _Glue(kin, _packing_kernels)
    return _GLUE[kin]


def evaluate_trial(point: PackingPoint, dq: np.ndarray, de: np.ndarray):
    """Contact law at the trial increment (from the converged ``point``): state, response, forces."""
    kin, s = point.kinematics, point.scale
    D = kin.delta(dq, de)
    dn = kin.normal_part(D)
    dt = D - dn[:, None] * kin.n
    if not (np.all(np.isfinite(dn)) and np.all(np.isfinite(dt))):
        raise SubstepFailure("Newton update not finite")
    st, resp = _law_step(point, dn * s, dt * s[:, None])
    f = resp.normal_force[:, None] * kin.n + resp.tangential_force
    return st, resp, f


def frictionless_energy(point: PackingPoint, st: ContactState, resp: Any) -> np.ndarray:
    """Elastic energy (C,) of frictionless contacts [energy].

    Hertz ``(2/5) N alpha`` (seed Eq. 3.6 integrated), linear springs ``N^2 / (2 kn)``.
    """
    N = resp.normal_force
    if normal_law(point.params) == "linear":
        return N * N / (2 * point.params.kn)
    return 0.4 * N * np.maximum(st.approach, 0.0) / point.scale

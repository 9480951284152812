"""Bounded least-squares calibration and its uncertainty (Jacobian-based).

The fit minimises ``sum_i r_i^2`` with weighted residuals ``r_i = (pred_i - obs_i) / s_i``
over the parameters within their bounds, with :func:`scipy.optimize.least_squares`
(trust-region reflective, ``method="trf"``). Internally every parameter is mapped to
``[0, 1]`` between its bounds, linearly or in ``log`` (so ``x_scale = 1`` is sensible
whatever the units). The scale ``s_i`` is (``[fit] error``):

* ``"relative"`` (default): ``|obs_i|``, i.e. relative residuals;
* ``"column-rms"``: the RMS of the column's observations (absolute residuals, columns of
  different units made comparable; use it when values cross zero);
* a per-row standard deviation column ``sd_<column>`` overrides both.

Uncertainty (e.g. Seber & Wild 1989, *Nonlinear Regression*, Sec. 2.1; Press et al.,
*Numerical Recipes*, Sec. 15.5): with ``J`` the Jacobian of the weighted residuals at the
optimum (central differences), ``m`` residuals and ``n`` parameters,

    s^2 = RSS / (m - n),     cov = s^2 (J^T J)^-1,

transformed to the parameters' own units with the derivative of the internal map
(delta method; for a ``log`` parameter the standard error of ``ln x`` is also given).
Identifiability: ``J`` is column-normalised and decomposed ``J = U S V^T``; a singular
value below ``rcond * S_max`` means the data do not determine the combination ``v`` of
parameters (the right singular vector). Parameters taking part in such a combination
(``|v_j| > 0.1``) are reported as *not identifiable* with no standard error, and the
covariance of the others is the pseudo-inverse restricted to the determined subspace.
``R^2 = 1 - RSS/TSS`` is given per column (unweighted) and overall (weighted).
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import qmc

from grainmech import parallel as par
from grainmech.calibrate.data import Dataset, read_csv
from grainmech.calibrate.model import DATA_KINDS, parse_settings, predict, set_path, targets_of, validate_data
from grainmech.errors import ConfigError, GrainmechError, ParameterError
from grainmech.io.config import Section, load_toml
from grainmech.io.units import ANGLE_UNITS, config_value, to_float, unit_registry

__all__ = ["FitParameter", "Problem", "FitResult", "load_problem", "problem_from_config", "fit",
           "uncertainty", "latin_hypercube_starts"]


# ------------------------------------------------------------------------- parameters

def _quantity(value: Any, key: str) -> tuple[float, str, str]:
    """(SI value, SI base unit, unit as written) of a number or quantity string."""
    if isinstance(value, str):
        text = value.strip()
        try:
            return float(text), "", ""
        except ValueError:
            pass

        ureg = unit_registry()
        try:
            q = ureg.Quantity(text)
        except Exception as exc:
            raise ConfigError(key, value, f"cannot read this quantity ({exc or type(exc).__name__})") from None
        if not isinstance(q, ureg.Quantity):
            return float(q), "", ""
        base = q.to_base_units()
        si = float(base.magnitude)
        if not math.isfinite(si):
            raise ConfigError(key, value, "must be finite")
        name = "rad" if base.dimensionless and str(q.units) in ANGLE_UNITS else ""
        if not base.dimensionless:
            # a coherent SI name for the base unit (same magnitude), else pint's base units
            name = next((u for u in _SI_NAMES if ureg.Quantity(1, u).dimensionality == base.dimensionality),
                        f"{base.units:~}")
        return si, name, f"{q.units:~}"
    return to_float(value, None, key), "", ""


#: coherent SI units (magnitude 1 in base units) used to name a parameter's SI unit
_SI_NAMES = ("Pa", "N/m", "N", "m", "rad", "Hz", "s", "kg", "J", "1/m**2", "1/m**3", "m**2", "m**3")


@dataclass(frozen=True)
class FitParameter:
    """One fitted parameter: a dotted path into the model config, SI bounds and start.

    ``unit``/``unit_factor``: the display unit (the one written in ``start``) and the SI
    value of one display unit.
    """

    path: str
    start: float
    lower: float
    upper: float
    log: bool = False
    unit: str = ""
    unit_factor: float = 1.0
    si_unit: str = ""

    def to_internal(self, x: np.ndarray | float) -> np.ndarray:
        """Map values ``x`` (SI) to the optimiser's coordinate ``t`` in [0, 1] (linear or log scale)."""
        x = np.asarray(x, dtype=float)
        if self.log:
            return (np.log(x) - math.log(self.lower)) / (math.log(self.upper) - math.log(self.lower))
        return (x - self.lower) / (self.upper - self.lower)

    def from_internal(self, t: np.ndarray | float) -> np.ndarray:
        """Map the optimiser's coordinate ``t`` in [0, 1] back to values (SI); inverse of :meth:`to_internal`."""
        t = np.asarray(t, dtype=float)
        if self.log:
            return np.exp(math.log(self.lower) + t * (math.log(self.upper) - math.log(self.lower)))
        return self.lower + t * (self.upper - self.lower)

    def dx_dt(self, x: float) -> float:
        """Derivative of the parameter with respect to its internal variable."""
        if self.log:
            return x * (math.log(self.upper) - math.log(self.lower))
        return self.upper - self.lower


def parse_parameter(sec: Any) -> FitParameter:
    """A ``[[parameters]]`` table: ``path``, ``start``, ``lower``, ``upper``, ``log``, ``unit``."""
    path = sec.raw("path")
    if not isinstance(path, str):
        raise ConfigError(sec.key("path"), path, "must be a dotted key path string, e.g. 'contacts.shear_modulus'")
    vals = {}
    for k in ("start", "lower", "upper"):
        vals[k] = _quantity(sec.raw(k), sec.key(k))
    dims = {k: v[1] for k, v in vals.items()}
    if len(set(dims.values())) > 1:
        # bare numbers are SI: a bare bound next to a quantity start is taken in SI base units
        written = [k for k, v in vals.items() if v[2]]
        units = {vals[k][1] for k in written}
        if len(units) > 1:
            raise ConfigError(sec.key("lower"), sec.raw("lower"), f"units of start, lower and upper differ "
                              f"({', '.join(f'{k}: {vals[k][1] or 1}' for k in vals)})")
    start, lower, upper = vals["start"][0], vals["lower"][0], vals["upper"][0]
    si_unit = next((v[1] for v in vals.values() if v[1]), "")
    log = sec.boolean("log", False)
    if not lower < upper:
        raise ConfigError(sec.key("upper"), sec.raw("upper"), f"must be greater than lower ({sec.raw('lower')!r})")
    if not lower <= start <= upper:
        raise ConfigError(sec.key("start"), sec.raw("start"), f"must lie within [lower, upper] = "
                          f"[{sec.raw('lower')!r}, {sec.raw('upper')!r}]")
    if log and lower <= 0:
        raise ConfigError(sec.key("lower"), sec.raw("lower"), "must be > 0 for a log parameter")
    unit = sec.raw("unit", vals["start"][2] or vals["lower"][2] or "")
    factor = 1.0
    if unit:
        factor = to_float(f"1 {unit}", si_unit or None, sec.key("unit"))
    sec.finish()
    return FitParameter(path, start, lower, upper, log, str(unit), factor, si_unit)


# ------------------------------------------------------------------------- problem

ERRORS = ("relative", "column-rms")


@dataclass
class Problem:
    """Everything a fit needs (picklable: it travels to Dask workers)."""

    kind: str
    model: dict
    data: Dataset
    parameters: list[FitParameter]
    settings: dict = field(default_factory=dict)
    error: str = "relative"
    max_evaluations: int = 200
    ftol: float = 1e-10
    xtol: float = 1e-10
    gtol: float = 1e-10
    diff_step: float | None = None
    rcond: float = 1e-6
    starts: int = 1
    seed: int = 0
    source: str = ""
    data_source: str = ""

    def __post_init__(self) -> None:
        if self.kind not in DATA_KINDS:
            raise ConfigError("data.kind", self.kind, f"must be one of {', '.join(map(repr, DATA_KINDS))}")
        if not self.parameters:
            raise ConfigError("parameters", None, "give at least one [[parameters]] table")
        paths = [p.path for p in self.parameters]
        dup = sorted({p for p in paths if paths.count(p) > 1})
        if dup:
            raise ConfigError("parameters.path", dup[0], "is given more than once")
        if self.error not in ERRORS:
            raise ConfigError("fit.error", self.error, f"must be one of {', '.join(map(repr, ERRORS))}")
        validate_data(self.kind, self.data, self.settings)
        self.targets = targets_of(self.kind, self.data, self.settings)
        if not self.targets:
            raise self.data.error(f"no column to fit for data kind {self.kind!r} "
                                  f"(possible: {', '.join(DATA_KINDS[self.kind].targets)})")
        for t in self.targets:
            if self.error == "relative" and not self.data.has(f"sd_{t}"):
                bad = np.flatnonzero(self.data[t] == 0)
                if bad.size:
                    raise self.data.error("is zero: relative residuals are undefined; use [fit] "
                                          "error = 'column-rms' or give a column sd_" + t, int(bad[0]), t)
        if self.diff_step is None:
            self.diff_step = 1e-4 if DATA_KINDS[self.kind].slow else 1e-6
        self.scales = self._scales()
        #: every fitted column has a per-row standard deviation (sd_ columns)
        self.known_sd = all(self.data.has(f"sd_{t}") for t in self.targets)

    # -- residuals
    def _scales(self) -> dict[str, np.ndarray]:
        out = {}
        for t in self.targets:
            obs = self.data[t]
            if self.data.has(f"sd_{t}"):
                out[t] = self.data[f"sd_{t}"]
            elif self.error == "relative":
                out[t] = np.abs(obs)
            else:
                rms = float(np.sqrt(np.mean(obs ** 2)))
                if rms == 0:
                    raise self.data.error(f"column {t!r} is all zero: nothing to scale residuals by")
                out[t] = np.full(obs.shape, rms)
        return out

    @property
    def m(self) -> int:
        """Number of residuals: targets x data rows."""
        return len(self.targets) * len(self.data)

    def config_at(self, x: Sequence[float] | np.ndarray) -> dict:
        """The model config with the parameter values ``x`` (SI, parameter order) written at their paths."""
        cfg = copy.deepcopy(self.model)
        for p, v in zip(self.parameters, x):
            set_path(cfg, p.path, config_value(v, p.si_unit))
        return cfg

    def predict(self, x: Sequence[float] | np.ndarray, validate: bool = False) -> dict[str, np.ndarray]:
        """Model predictions ``{target: array (rows,)}`` at parameter values ``x`` (SI)."""
        return predict(self.kind, self.config_at(x), self.data, self.settings, validate=validate)

    def residuals(self, x: Sequence[float] | np.ndarray, validate: bool = False) -> np.ndarray:
        """Scaled residuals ``(prediction - data) / scale`` of every target, shape (m,).

        Raises
        ------
        GrainmechError
            If the model gives non-finite predictions at ``x``.
        """
        pred = self.predict(x, validate)
        r = np.concatenate([(pred[t] - self.data[t]) / self.scales[t] for t in self.targets])
        if not np.all(np.isfinite(r)):
            raise GrainmechError(f"the model gives non-finite predictions at {self.describe(x)}")
        return r

    def x_of(self, t: np.ndarray) -> np.ndarray:
        """Parameter values (SI), shape (n,), from optimiser coordinates ``t`` (n,)."""
        return np.array([p.from_internal(ti) for p, ti in zip(self.parameters, t)], dtype=float)

    def t_of(self, x: np.ndarray) -> np.ndarray:
        """Optimiser coordinates, shape (n,), from parameter values ``x`` (SI) (n,)."""
        return np.array([p.to_internal(xi) for p, xi in zip(self.parameters, x)], dtype=float)

    def describe(self, x: Sequence[float] | np.ndarray) -> str:
        """``"path = value unit, ..."`` of the parameter values ``x`` in their display units."""
        return ", ".join(f"{p.path} = {v / p.unit_factor:.6g}{(' ' + p.unit) if p.unit else ''}"
                         for p, v in zip(self.parameters, x))


#: Shear moduli of the solids grains are made of [Pa]: soft minerals from ~15 GPa (gypsum,
#: halite) to ~90 GPa (garnet); quartz 44, calcite 32, feldspars 25-40, soda-lime glass
#: (glass beads) ~29, steel (balls) ~80 GPa (Mavko, Mukerji & Dvorkin, The Rock Physics
#: Handbook, Table 7.1). A fitted grain modulus outside this range (with margin) means
#: the data's units or the model, not the grains, set the value; it is flagged.
GRAIN_SHEAR_MODULUS_RANGE = (5e9, 100e9)
#: fitted keys that are a grain's own shear modulus (``shear_modulus_equiv`` of the rod
#: law is an equivalent contact constant, not a solid's modulus)
GRAIN_MODULUS_KEYS = ("shear_modulus", "shear_modulus2")


def plausibility_flags(problem: Problem, x: Sequence[float] | np.ndarray) -> list[str]:
    """Fitted values outside a documented physical range, one sentence each.

    A grain shear modulus (``contacts.shear_modulus``...) outside
    :data:`GRAIN_SHEAR_MODULUS_RANGE`.
    """
    lo, hi = GRAIN_SHEAR_MODULUS_RANGE
    out = []
    for p, v in zip(problem.parameters, x):
        if p.path.rsplit(".", 1)[-1] in GRAIN_MODULUS_KEYS and not lo <= float(v) <= hi:
            why = ("; a model too stiff for these data (the affine model is an upper bound) lowers it to make up"
                   if v < lo else "")
            out.append(f"fitted {p.path} = {float(v) / 1e9:.4g} GPa is outside {lo / 1e9:g}-{hi / 1e9:g} GPa, "
                       "the shear moduli of the minerals grains are made of (quartz 44 GPa): it is not the "
                       f"grains' modulus; check the data's units and the model{why}")
    return out


def problem_from_config(cfg: dict, data: Dataset | str | Path, *, source: str = "<config>",
                        starts: int | None = None, seed: int | None = None) -> Problem:
    """Build a :class:`Problem` from a calibration config dict and a dataset or CSV path."""
    root = Section(cfg, "")
    dsec = root.section("data")
    kind = dsec.choice("kind", tuple(DATA_KINDS))
    settings = parse_settings(kind, dsec)
    model = root.raw("model")
    if not isinstance(model, dict):
        raise ConfigError("model", model, "expected a table [model] (the model config)")
    raw_params = root.raw("parameters")
    if not isinstance(raw_params, list) or not raw_params:
        raise ConfigError("parameters", raw_params, "must be a non-empty array of tables [[parameters]]")
    params = [parse_parameter(Section(p, f"parameters[{i}]")) for i, p in enumerate(raw_params)]
    fsec = root.section("fit", {})
    error = fsec.choice("error", ERRORS, "relative")
    kw: dict[str, Any] = dict(max_evaluations=fsec.integer("max_evaluations", 200, min=1),
              ftol=fsec.number("ftol", None, 1e-10, min=0), xtol=fsec.number("xtol", None, 1e-10, min=0),
              gtol=fsec.number("gtol", None, 1e-10, min=0),
              diff_step=fsec.number("diff_step", None, None, min=0, min_inclusive=False),
              rcond=fsec.number("rcond", None, 1e-6, min=0, max=1),
              starts=fsec.integer("starts", 1, min=1), seed=fsec.integer("seed", 0, min=0))
    root.finish()
    if starts is not None:
        kw["starts"] = int(starts)
    if seed is not None:
        kw["seed"] = int(seed)
    if not isinstance(data, Dataset):
        k = DATA_KINDS[kind]
        allowed = k.inputs + k.targets
        data = read_csv(data, required=k.required, one_of=k.targets, allowed=allowed)
    prob = Problem(kind, model, data, params, settings, error, source=source, data_source=data.path, **kw)
    # evaluate once at the start with the model's full key check (unknown keys, ranges)
    prob.residuals([p.start for p in params], validate=True)
    return prob


def load_problem(config_path: str | Path, data_path: str | Path, **kw: Any) -> Problem:
    """Read a calibration TOML and its data CSV."""
    return problem_from_config(load_toml(config_path), data_path, source=str(config_path), **kw)


# ------------------------------------------------------------------------- fitting

@dataclass
class StartResult:
    index: int
    start: np.ndarray      # SI
    x: np.ndarray          # SI
    cost: float            # 0.5 * RSS (weighted)
    nfev: int
    njev: int
    status: int
    message: str
    active: np.ndarray
    error: str = ""


def _solve(problem: Problem, t0: np.ndarray, index: int = 0) -> StartResult:
    """One bounded least-squares run from internal start ``t0``."""
    x0 = problem.x_of(t0)
    try:
        r = least_squares(lambda t: problem.residuals(problem.x_of(t)), t0, bounds=(0.0, 1.0), method="trf",
                          x_scale=1.0, diff_step=problem.diff_step, ftol=problem.ftol or None,
                          xtol=problem.xtol or None, gtol=problem.gtol or None, max_nfev=problem.max_evaluations)
    except GrainmechError as exc:
        return StartResult(index, x0, x0, math.inf, 0, 0, -10, str(exc), np.zeros(len(t0), int), str(exc))
    return StartResult(index, x0, problem.x_of(r.x), float(r.cost), int(r.nfev), int(r.njev or 0),
                       int(r.status), str(r.message), np.asarray(r.active_mask, dtype=int))


def latin_hypercube_starts(problem: Problem, n: int, seed: int = 0) -> np.ndarray:
    """Internal starts (n, k): the given start, then ``n - 1`` seeded Latin-hypercube points.

    Latin hypercube in the internal coordinates (``[0, 1]`` per parameter, i.e. uniform in
    ``log x`` for log parameters), :class:`scipy.stats.qmc.LatinHypercube` (McKay et al. 1979).
    """
    t_start = problem.t_of(np.array([p.start for p in problem.parameters]))
    if n <= 1:
        return t_start[None, :]
    lhs = qmc.LatinHypercube(d=len(problem.parameters), seed=seed).random(n - 1)
    return np.vstack([t_start, lhs])


def _run_item(item: tuple) -> StartResult:
    problem, t0, index = item
    return _solve(problem, t0, index)


@dataclass
class FitResult:
    """Best fit, its statistics and the individual starts."""

    problem: Problem
    x: np.ndarray
    start: np.ndarray
    cost: float
    nfev: int
    njev: int
    status: int
    message: str
    active: np.ndarray
    residuals: np.ndarray           # weighted, at x
    predictions: dict[str, np.ndarray]
    jacobian: np.ndarray            # of the weighted residuals w.r.t. SI parameters
    stats: dict
    starts: list[StartResult]
    seconds: float

    @property
    def success(self) -> bool:
        """Whether the least-squares solver reported convergence (``status > 0``)."""
        return self.status > 0

    def value(self, path: str) -> float:
        """Fitted value (SI) of the parameter at config path ``path``."""
        return float(self.x[[p.path for p in self.problem.parameters].index(path)])

    def std_error(self, path: str) -> float | None:
        """Standard error (SI) of the parameter at ``path``, or None where it is not identifiable."""
        return self.stats["std_error"][[p.path for p in self.problem.parameters].index(path)]


def central_jacobian(problem: Problem, x: np.ndarray, step: float | None = None) -> np.ndarray:
    """Jacobian of the weighted residuals w.r.t. the SI parameters, central differences.

    The step is taken in the internal coordinates (``step`` in ``[0, 1]`` units, default
    ``max(1e-4, 100 diff_step)`` kept inside the bounds) and converted with ``dx/dt``.
    """
    t = problem.t_of(x)
    h0 = step if step is not None else max(1e-4, 100 * (problem.diff_step or 1e-6))
    cols = []
    for j, p in enumerate(problem.parameters):
        h = min(h0, 0.5)
        tp, tm = t.copy(), t.copy()
        tp[j] = min(t[j] + h, 1.0)
        tm[j] = max(t[j] - h, 0.0)
        rp = problem.residuals(problem.x_of(tp))
        rm = problem.residuals(problem.x_of(tm))
        dt = tp[j] - tm[j]
        cols.append((rp - rm) / dt / p.dx_dt(float(x[j])))
    return np.column_stack(cols)


def uncertainty(J: np.ndarray, r: np.ndarray, names: Sequence[str], rcond: float = 1e-6) -> dict:
    """Standard errors, correlation and identifiability from a Jacobian (see module doc).

    Parameters
    ----------
    J : (m, n) Jacobian of the weighted residuals w.r.t. the parameters
    r : (m,) weighted residuals at the optimum
    names : parameter names (for the messages)
    rcond : relative singular-value threshold of identifiability

    Returns
    -------
    dict with ``rss``, ``dof``, ``s2``, ``cov`` (n, n; NaN rows/columns for
    non-identifiable parameters), ``std_error`` (list, None where not identifiable),
    ``correlation``, ``identifiable`` (list of bool), ``singular_values`` (normalised),
    ``unidentified`` (list of combinations ``{name: coefficient}``), ``notes``;
    ``std_error_unscaled``: from ``(J^T J)^-1`` without ``s^2`` (the standard errors when
    the weights are the data's true standard deviations).
    """
    J = np.asarray(J, dtype=float)
    r = np.asarray(r, dtype=float)
    m, n = J.shape
    rss = float(r @ r)
    dof = m - n
    notes = []
    s2 = rss / dof if dof > 0 else math.nan
    if dof <= 0:
        notes.append(f"{m} residuals for {n} parameters: no degrees of freedom left, standard errors undefined")
    norms = np.linalg.norm(J, axis=0)
    ident = norms > 0
    combos: list[dict] = []
    for j in np.flatnonzero(~ident).tolist():
        combos.append({names[j]: 1.0})
        notes.append(f"{names[j]} does not change the predictions at all: not identifiable from these data")
    Js = J[:, ident] / norms[ident]
    idx = np.flatnonzero(ident)
    cov = np.full((n, n), math.nan)
    sv_out = np.zeros(n)
    if idx.size:
        U, S, Vt = np.linalg.svd(Js, full_matrices=False)
        sv_out[: S.size] = S / S[0] if S[0] > 0 else S
        small = S < rcond * S[0]
        for k in np.flatnonzero(small):
            v = Vt[k]
            v = v / np.max(np.abs(v))
            involved = {names[idx[j]]: float(v[j]) for j in range(idx.size) if abs(v[j]) > 0.1}
            combos.append(involved)
            for j in range(idx.size):
                if abs(v[j]) > 0.1:
                    ident[idx[j]] = False
            terms = ", ".join(f"{nm} {c:+.3g}" for nm, c in involved.items())
            notes.append(f"not identifiable: {', '.join(involved)} (changing them together along ({terms}), "
                         "each in units of its own effect on the residuals, leaves the predictions unchanged; "
                         f"singular value {S[k] / S[0]:.1e} of the largest)")
        keep = ~small
        Sinv2 = np.zeros_like(S)
        Sinv2[keep] = 1.0 / S[keep] ** 2
        cov_s = (Vt.T * Sinv2) @ Vt                    # of the scaled parameters
        cov_s = cov_s / np.outer(norms[idx], norms[idx]) * s2
        for a, ia in enumerate(idx):
            for b, ib in enumerate(idx):
                if ident[ia] and ident[ib]:
                    cov[ia, ib] = cov_s[a, b]
    se = [float(math.sqrt(cov[j, j])) if ident[j] and np.isfinite(cov[j, j]) and cov[j, j] >= 0 else None
          for j in range(n)]
    # cov = (J^T J)^-1 without s^2: the standard errors when the weights are the data's true
    # standard deviations (sd_ columns), instead of estimating the scale from the misfit
    se_unscaled = [None if v is None or not (s2 > 0) else v / math.sqrt(s2) for v in se]
    corr = np.full((n, n), math.nan)
    for a in range(n):
        for b in range(n):
            sa, sb = se[a], se[b]
            if sa and sb:
                corr[a, b] = cov[a, b] / (sa * sb)
    return dict(rss=rss, dof=dof, s2=s2, cov=cov, std_error=se, std_error_unscaled=se_unscaled, correlation=corr,
                identifiable=[bool(v) for v in ident], singular_values=sv_out, unidentified=combos, notes=notes)


def _r2(obs: np.ndarray, pred: np.ndarray) -> float:
    tss = float(np.sum((obs - obs.mean()) ** 2))
    return 1.0 - float(np.sum((obs - pred) ** 2)) / tss if tss > 0 else math.nan


def fit(problem: Problem, *, starts: int | None = None, seed: int | None = None, client: Any = None,
        scheduler: str | None = None, workers: int | None = None, parallel: bool | None = None) -> FitResult:
    """Run the calibration.

    Parameters
    ----------
    problem : Problem
    starts : int, optional
        Number of starts (default ``problem.starts``): the given start plus seeded
        Latin-hypercube starts within the bounds.
    seed : int, optional
        Seed of the Latin hypercube (default ``problem.seed``).
    client : distributed.Client, optional
        Run the starts on this client (:func:`grainmech.parallel.map_completed`).
    scheduler, workers :
        Otherwise, with more than one start and ``parallel`` not False, a client is opened
        with :func:`grainmech.parallel.open_client` (``scheduler`` address or a local
        cluster of ``workers`` processes).
    parallel : bool, optional
        Force (True) or forbid (False) Dask for several starts; a single start is serial.
    """
    t_start = time.perf_counter()
    n_starts = problem.starts if starts is None else int(starts)
    if n_starts < 1:
        raise ParameterError("starts", n_starts, "must be >= 1")
    T0 = latin_hypercube_starts(problem, n_starts, problem.seed if seed is None else seed)
    items = [(problem, T0[i], i) for i in range(len(T0))]
    use_dask = len(items) > 1 and parallel is not False
    results: list[StartResult | None] = [None] * len(items)
    if use_dask:
        def collect(cl: Any) -> None:
            for i, res, ok in par.map_completed(_run_item, items, client=cl):
                if ok:
                    results[i] = res
                else:
                    x0 = problem.x_of(T0[i])
                    results[i] = StartResult(i, x0, x0, math.inf, 0, 0, -10, f"failed: {res}",
                                             np.zeros(len(x0), int), str(res))
        if client is not None:
            collect(client)
        else:
            with par.open_client(scheduler=scheduler, workers=workers) as cl:
                collect(cl)
    else:
        for i, it in enumerate(items):
            results[i] = _run_item(it)
    done = [r for r in results if r is not None]
    ok = [r for r in done if math.isfinite(r.cost)]
    if not ok:
        raise GrainmechError("every start failed; first error: " + (done[0].error if done else "none"))
    best = min(ok, key=lambda r: (r.cost, r.index))
    x = best.x
    resid = problem.residuals(x)
    pred = problem.predict(x)
    J = central_jacobian(problem, x)
    names = [p.path for p in problem.parameters]
    st = uncertainty(J, resid, names, problem.rcond)
    # parameters at a bound: the linearised standard error is not a confidence statement
    at_bound = [bool(a != 0) or bool(np.isclose(problem.t_of(x)[j], 0.0) or np.isclose(problem.t_of(x)[j], 1.0))
                for j, a in enumerate(best.active)]
    for j, b in enumerate(at_bound):
        if b:
            st["notes"].append(f"{names[j]} ended at a bound: its standard error assumes an interior optimum")
    st["at_bound"] = at_bound
    st["plausibility"] = plausibility_flags(problem, x)
    st["notes"].extend(st["plausibility"])
    st["relative_std_error"] = [None if se is None else se / abs(v) if v != 0 else None
                                for se, v in zip(st["std_error"], x)]
    st["r2"] = {t: _r2(problem.data[t], pred[t]) for t in problem.targets}
    w_obs = np.concatenate([problem.data[t] / problem.scales[t] for t in problem.targets])
    tss = float(np.sum((w_obs - w_obs.mean()) ** 2))
    st["r2_weighted"] = 1.0 - st["rss"] / tss if tss > 0 else math.nan
    st["rms_weighted_residual"] = float(np.sqrt(st["rss"] / max(resid.size, 1)))
    return FitResult(problem, x, best.start, best.cost, best.nfev, best.njev, best.status, best.message,
                     best.active, resid, pred, J, st, done, time.perf_counter() - t_start)

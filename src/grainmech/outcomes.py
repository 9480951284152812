"""Typed results of the jobs (:mod:`grainmech.jobs`), below :mod:`grainmech.io`.

The outcome of every run kind (:class:`StiffnessOutcome`, :class:`CyclicOutcome`,
:class:`PathOutcome`, :class:`RunComparison`, :class:`DemOutcome`,
:class:`ContactOutcome`) and the report lines written from them. The jobs build them;
:mod:`grainmech.io.reports` writes them; neither needs the other to read them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # annotations only: the drivers load on first use (grainmech stiffness imports none)
    from grainmech.analysis.references import PathMeasures, ReferenceCurves
    from grainmech.driver.base import KinematicModel

__all__ = ["StiffnessOutcome", "RunOutcome", "CyclicOutcome", "PathOutcome", "RunComparison", "DemOutcome",
           "ContactOutcome", "model_of", "envelope_and_loop_warnings", "packing_gmax_line", "run_mean_stress_change",
           "curve_value_problems", "curve_value_warnings", "RecommendedCurve", "recommended_curve"]


def model_of(model: str | KinematicModel) -> KinematicModel:
    """The registered kinematic model of a name (:func:`grainmech.driver.registry.resolve`), or the model itself.

    The registry is imported on first use: this module stays light for the jobs that run no model.
    """
    from grainmech.driver.registry import resolve

    return resolve(model)


def run_mean_stress_change(result: Any) -> float:
    """``p_end / p_0 - 1`` of one run, ``p`` the mean of its normal stresses (``result.stress`` (k+1, 6)).

    At constant volume minus the pore-pressure ratio an undrained test reads; at constant
    sigma_zz the horizontal stresses still change during cycling.
    """
    return float(np.mean(result.stress[-1, :3]) / np.mean(result.stress[0, :3]) - 1.0)


@dataclass
class StiffnessOutcome:
    """Result of a ``stiffness`` job.

    Attributes
    ----------
    result : grainmech.material.StiffnessResult
        Voigt stiffness ``C`` (library order) [Pa], contact set, forces, stress.
    engineering : EngineeringConstants
        Engineering constants of ``C``.
    symmetry : SymmetryClass
        Material symmetry class of ``C``.
    microstructure : grainmech.material.Microstructure
        The analytical description read from the ``[microstructure]`` table.
    dim : int
    """

    result: Any
    engineering: Any
    symmetry: Any
    microstructure: Any
    dim: int
    fabric_fit: dict | None = None  # the fit of a [fabric] normals file (io.schema.build_fabric)

    @property
    def mean_stress(self) -> float:
        """Mean stress of the state [Pa] (compression positive)."""
        return float(np.trace(self.result.stress) / self.dim)


@dataclass
class RunOutcome:
    """Result of a ``run`` job (common part).

    Attributes
    ----------
    kind : str
        The test (``[test] kind``, :data:`grainmech.jobs.RUN_TEST_KINDS`): cyclic simple
        shear or a path.
    pressure : float
        Initial isotropic stress [Pa].
    results : list of grainmech.driver.DriverResult
        One per amplitude (cyclic) or one (path).
    success : bool
    message : str
    seconds : float
    point : grainmech.driver.MaterialPoint
        The initial state.
    warnings : list of str
        Plausibility warnings (value and reason).
    method : str
        ``"affine"``, ``"packing"`` or ``"dem"`` (:data:`grainmech.jobs.RUN_METHODS`); the
        model itself is :attr:`model`.
    details : dict
        For ``"packing"``: the packing (label, grains, rattlers, contacts, void ratio, input
        mean stress, notes of the point) and the largest equilibrium residual of any step.
    """

    kind: str
    pressure: float
    results: list
    success: bool
    message: str
    seconds: float
    point: Any
    warnings: list = field(default_factory=list)
    method: str = "affine"
    details: dict = field(default_factory=dict)

    @property
    def model(self) -> KinematicModel:
        """The kinematic model that made this outcome (:data:`grainmech.driver.registry.MODELS`)."""
        return model_of(self.method)


@dataclass
class CyclicOutcome(RunOutcome):
    """Cyclic simple shear at several amplitudes (``analysis.modulus_reduction``).

    Attributes
    ----------
    amplitudes, G, damping : ndarray (k,)
        Amplitudes reached (decimal strain), secant modulus [Pa], damping ratio (decimal).
    G_max : float
        Small-strain modulus [Pa] that normalises every G/Gmax.
    reference : dict
        Inputs of the empirical reference curves (``pi``, ``ocr``, ``n_cycles``,
        ``frequency``, ``phi`` [rad]).
    empirical_G_max : dict or None
        :func:`empirical_gmax_check`.
    run_amplitudes : ndarray (len(results),)
        Amplitude of every run in ``results``: the completed ones and, after a failure,
        the one that failed (its steps up to the failure are kept).
    envelope : list of dict
        :func:`cyclic_envelope` of every run in ``results`` (every recorded state against
        the Mohr-Coulomb envelope of sands).
    loop_quality : list of grainmech.analysis.LoopQuality
        :func:`grainmech.analysis.loop_quality` of the analysed (last) cycle of every
        completed amplitude.
    keep_beyond_envelope : bool
        ``[model] keep_beyond_envelope``: amplitudes beyond the envelope stay in
        ``site_response_curves.csv``.
    references : grainmech.analysis.references.ReferenceCurves or None
        :func:`grainmech.analysis.references.reference_curves` of the completed amplitudes
        (the empirical curves the report draws and tabulates; None without one).
    """

    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G: np.ndarray = field(default_factory=lambda: np.zeros(0))
    damping: np.ndarray = field(default_factory=lambda: np.zeros(0))
    G_max: float = float("nan")
    reference: dict = field(default_factory=dict)
    empirical_G_max: dict | None = None
    run_amplitudes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    envelope: list = field(default_factory=list)
    loop_quality: list = field(default_factory=list)
    keep_beyond_envelope: bool = False
    references: ReferenceCurves | None = None

    @property
    def beyond_envelope(self) -> np.ndarray:
        """Whether each completed amplitude's run leaves the envelope of sands (bool, len(G))."""
        return np.array([bool(e["beyond_any"]) for e in self.envelope[:len(self.G)]], dtype=bool)

    @property
    def value_problems(self) -> list:
        """:func:`curve_value_problems` of each completed amplitude (``None`` where G/Gmax and damping are usual)."""
        return curve_value_problems(self.G_ratio, self.damping)

    @property
    def site_response_keep(self) -> np.ndarray:
        """Which completed amplitudes go into the site-response curves (bool, len(G)).

        Those within the envelope of sands (all with ``keep_beyond_envelope``) whose G/Gmax
        and damping a site-response program takes (:func:`curve_value_problems`).
        """
        usual = np.array([p is None for p in self.value_problems], dtype=bool)
        return (~self.beyond_envelope | bool(self.keep_beyond_envelope)) & usual

    @property
    def completed_results(self) -> list:
        """Runs of the completed amplitudes (aligned with ``amplitudes``, ``G``, ``damping``)."""
        return [r for r in self.results if r.success][:len(self.G)]

    @property
    def G_ratio(self) -> np.ndarray:
        """G / Gmax at each amplitude."""
        return np.asarray(self.G, dtype=float) / self.G_max

    @property
    def mean_stress_change(self) -> np.ndarray:
        """Relative change of the mean stress over each amplitude's run.

        ``p_end / p_0 - 1``: at constant sigma_zz the horizontal stresses change during
        cycling (affine model).
        """
        return np.array([run_mean_stress_change(r) for r in self.completed_results])


@dataclass
class PathOutcome(RunOutcome):
    """A mixed-control path.

    ``envelope`` is :func:`envelope_check` of its stresses; ``measures``
    (:func:`grainmech.analysis.references.path_measures` of its run) its soil-mechanics
    table (p, q, strains along the loading axis) and its strength (None without a run).
    """

    envelope: dict | None = None
    measures: PathMeasures | None = None


@dataclass
class RunComparison:
    """Several kinematic models on one test (``[model] method`` a list).

    One :class:`RunOutcome` per method, in the config's order.
    """

    outcomes: list

    @property
    def success(self) -> bool:
        """Whether every method succeeded."""
        return all(o.success for o in self.outcomes)

    @property
    def message(self) -> str:
        """Each method's message, prefixed with the method."""
        return "; ".join(f"{o.method}: {o.message}" for o in self.outcomes)

    @property
    def warnings(self) -> list:
        """Every method's warnings."""
        return [w for o in self.outcomes for w in o.warnings]

    @property
    def seconds(self) -> float:
        """Wall time of all methods [s]."""
        return float(sum(o.seconds for o in self.outcomes))

    @property
    def kind(self) -> str:
        """The test kind (the same for every method)."""
        return self.outcomes[0].kind

    @property
    def pressure(self) -> float:
        """The initial mean stress [Pa] (the same for every method)."""
        return self.outcomes[0].pressure

    @property
    def recommended(self) -> RecommendedCurve | None:
        """:func:`recommended_curve` of the models compared (None where there is none)."""
        return recommended_curve(self)


@dataclass
class RecommendedCurve:
    """One modulus-reduction and damping curve of a run with several models.

    The physically based models' points on one Gmax: the packing model's amplitudes where it
    ran, the DEM model's beyond; the affine model (an upper bound that cannot fail) is a
    reference only, never part of the curve. Built by :func:`recommended_curve`.

    Attributes
    ----------
    amplitudes, G, G_ratio, damping : ndarray (k,)
        Shear strain amplitude (decimal, ascending), the secant modulus of the model that made
        the point [Pa], ``G / G_max`` (the one Gmax below) and the damping ratio (decimal).
    models : list of str
        The model that made each point (``"packing"`` or ``"dem"``).
    flags : list of list of str
        Per point: ``beyond_envelope`` (a state of the amplitude's run beyond the envelope of
        sands), ``grains_rearrange`` (a packing-model point whose mean stress drifted at
        constant volume and that no DEM point replaces), ``loop_not_closed`` (the analysed
        cycle out of tolerance) and ``value_flag`` (G/Gmax above 1 or not positive, damping
        outside [0, 1), a NaN: :func:`curve_value_problems`).
    G_max : float
        The one Gmax [Pa] that divides every G.
    G_max_model : str
        The model whose small-strain modulus it is.
    G_max_reason : str
        Why that one.
    choices : list of str
        One sentence per amplitude both physically based models ran: which point is kept and why.
    reference : dict
        The affine model's Gmax and a note (a reference only); empty without an affine model.
    """

    amplitudes: np.ndarray
    G: np.ndarray
    G_ratio: np.ndarray
    damping: np.ndarray
    models: list
    flags: list
    G_max: float
    G_max_model: str
    G_max_reason: str
    choices: list = field(default_factory=list)
    reference: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The curve for ``summary.json`` (plain lists and strings)."""
        return {"G_max_Pa": float(self.G_max), "G_max_model": self.G_max_model, "G_max_reason": self.G_max_reason,
                "amplitudes": [float(a) for a in self.amplitudes], "G_Pa": [float(g) for g in self.G],
                "G_over_Gmax": [float(r) for r in self.G_ratio], "damping": [float(d) for d in self.damping],
                "models": list(self.models), "flags": [list(f) for f in self.flags], "choices": list(self.choices),
                "reference": dict(self.reference),
                "note": "one curve from the physically based models (packing where its fixed geometry holds, "
                        "DEM beyond), every secant G divided by the one Gmax; the affine model is a reference "
                        "only (every contact follows the mean strain: an upper bound that cannot fail)"}


def _model_points(o: CyclicOutcome) -> dict[float, dict]:
    """A cyclic model's completed amplitudes: G, damping and flags per amplitude (its own keys)."""
    n = len(o.G)
    beyond = o.beyond_envelope
    moved = list((o.details or {}).get("rearranging", []))[:n] if o.model.fixed_geometry else []
    moved += [False] * (n - len(moved))
    bad_loop = [not q.ok for q in o.loop_quality[:n]] + [False] * max(0, n - len(o.loop_quality))
    return {float(a): {"G": float(g), "damping": float(d), "beyond": bool(b), "moved": bool(m), "loop": bool(lp)}
            for a, g, d, b, m, lp in zip(o.amplitudes, o.G, o.damping, beyond, moved, bad_loop)}


def _same(a: float, b: float) -> bool:
    """Whether two amplitudes are the same one (as written in a config)."""
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b))


def recommended_curve(comparison: RunComparison) -> RecommendedCurve | None:
    """The one curve to trust of a cyclic run with several models.

    Points: the packing model's completed amplitudes, and the DEM model's at the other
    amplitudes (beyond the packing model's range, or handed over to it). Where both ran an
    amplitude the DEM point is kept if the packing model's grains rearrange there
    (``details["rearranging"]``: its mean stress drifted at constant volume, so its fixed
    reference geometry no longer holds, and the DEM model, whose contacts form and break,
    does), otherwise the packing point (every grain in exact equilibrium, no relaxation
    error); ``choices`` says which with both values.

    One Gmax: the packing model's small-strain modulus (every grain in force and moment
    equilibrium, the exact tangent of the packing at rest) where the packing model ran,
    else the DEM model's. Every point's secant G, the DEM model's too, is divided by it;
    rescaling the DEM points by their own G/Gmax would put two different Gmax on one curve
    (e.g. 251.5 and 228.9 MPa on the same grains) and make the curve jump between models.

    Returns None unless at least two models ran a cyclic test and a physically based model
    completed an amplitude.
    """
    outs = [o for o in comparison.outcomes if isinstance(o, CyclicOutcome)]
    if len(comparison.outcomes) < 2 or not outs:
        return None
    # the physically based models (not an upper bound), the fixed-geometry one first: it is
    # preferred where both ran an amplitude and its grains do not rearrange there
    fixed = next((o for o in outs if o.model.fixed_geometry), None)
    taking = next((o for o in outs if o.model.takes_over), None)
    phys = [o for o in (fixed, taking) if o is not None and len(o.G)]
    if not phys:
        return None
    base = next((o for o in phys if np.isfinite(o.G_max) and o.G_max > 0), None)
    if base is None:
        return None
    if base.model.fixed_geometry:
        why = (f"the {base.model.title}'s Gmax: the small-strain modulus with every grain in force and moment "
               "equilibrium (the exact tangent of the packing at rest, no relaxation tolerance)")
    else:
        why = f"the {base.model.title}'s Gmax (no packing-model Gmax in this run)"
    other = [o for o in phys if o is not base and np.isfinite(o.G_max) and o.G_max > 0]
    if other:
        why += "; " + "; ".join(
            f"the {o.method} model's own Gmax {o.G_max:.4g} Pa is {o.G_max / base.G_max:.3f} of it: its secant G "
            "is divided by this one Gmax, not by its own" for o in other)
    pk = _model_points(fixed) if fixed is not None else {}
    dm = _model_points(taking) if taking is not None else {}
    pk_name, dm_name = (fixed.method if fixed is not None else ""), (taking.method if taking is not None else "")
    points: list[tuple[float, str, dict]] = []
    choices: list[str] = []
    for a, p in pk.items():
        twin = next((v for k, v in dm.items() if _same(k, a)), None)
        if twin is None:
            points.append((a, pk_name, p))
            continue
        rp, rd = p["G"] / base.G_max, twin["G"] / base.G_max
        if p["moved"]:
            points.append((a, dm_name, twin))
            choices.append(f"{a:.3g}: the DEM point (G/Gmax {rd:.4f}, damping {100 * twin['damping']:.2f} %) is kept: "
                           f"the packing model's grains rearrange there (G/Gmax {rp:.4f}, damping "
                           f"{100 * p['damping']:.2f} %), its fixed geometry no longer holds")
        else:
            points.append((a, pk_name, p))
            choices.append(f"{a:.3g}: the packing point (G/Gmax {rp:.4f}, damping {100 * p['damping']:.2f} %) is "
                           f"kept: its grains do not rearrange there and every grain is in exact equilibrium; the "
                           f"DEM model gives G/Gmax {rd:.4f}, damping {100 * twin['damping']:.2f} %")
    points += [(a, dm_name, v) for a, v in dm.items() if not any(_same(a, k) for k in pk)]
    points.sort(key=lambda t: t[0])
    amps = np.array([a for a, _, _ in points])
    G = np.array([v["G"] for _, _, v in points])
    damp = np.array([v["damping"] for _, _, v in points])
    ratio = G / base.G_max
    flags = []
    for (_, _, v), prob in zip(points, curve_value_problems(ratio, damp)):
        f = (["beyond_envelope"] if v["beyond"] else []) + (["grains_rearrange"] if v["moved"] else [])
        f += (["loop_not_closed"] if v["loop"] else []) + (["value_flag"] if prob else [])
        flags.append(f)
    ref = {}
    aff = next((o for o in outs if o.model.upper_bound), None)
    if aff is not None:
        times = (f" (Gmax {aff.G_max / base.G_max:.2f} times the recommended curve's)"
                 if np.isfinite(aff.G_max) else "")
        ref = {"model": aff.method, "G_max_Pa": float(aff.G_max),
               "note": "a reference only: every contact follows the mean strain, an upper bound that cannot fail"
                       + times}
    return RecommendedCurve(amps, G, ratio, damp, [m for _, m, _ in points], flags, float(base.G_max), base.method,
                            why, choices, ref)


@dataclass
class DemOutcome:
    """Result of a ``dem`` job: the network read and its measures.

    Attributes
    ----------
    network : grainmech.network.ContactNetwork
    report : dict
        :func:`grainmech.network.network_report` (stress, fabric, coordination, affine and
        relaxed stiffness, engineering constants, notes).
    """

    network: Any
    report: dict


@dataclass
class ContactOutcome:
    """Result of a ``contact`` job.

    Attributes
    ----------
    columns : dict of str -> ndarray (k+1,)
        :data:`grainmech.io.reports.CONTACT_COLUMNS`; row 0 is the initial state. SI units
        (N and m; N/m and m for a rod contact per unit length).
    law : str
        Class name of the contact law.
    force_unit : str
        ``"N"`` or ``"N/m"`` (rods).
    """

    columns: dict
    law: str
    force_unit: str


def envelope_and_loop_warnings(model: str | KinematicModel, amplitudes: Any, envelope: list,
                               quality: list) -> list[str]:
    """One warning per amplitude beyond the envelope of sands and per loop out of tolerance.

    ``model`` (a model or its name) says how to read its states beyond the envelope
    (``envelope_note``).
    """
    m = model_of(model)
    method = m.name
    out = []
    for a, env, q in zip(amplitudes, envelope, quality):
        if env["beyond_any"]:
            why = m.envelope_note
            r = env["max_ratio"]
            rt = f"up to {r:.3g}" if np.isfinite(r) else "unbounded: sigma3 <= 0"
            out.append(f"{method} model, amplitude {a:.1e}: beyond the envelope of sands from step "
                       f"{env['first_step']} (sigma1/sigma3 {rt}, limit {env['limit']:.2f}: "
                       f"Mohr-Coulomb phi = {env['friction_angle_deg']:g} deg; tau_xz/sigma_zz up to "
                       f"{env['max_tau_over_sigma_zz']:.3g}); {why}")
        out += [f"{method} model, amplitude {a:.1e}: {p}" for p in q.problems]
    return out


#: G/Gmax may exceed 1 by round-off only and still count as usual
_G_RATIO_TOL = 1e-6


def curve_value_problems(g_ratio: Any, damping: Any) -> list[str | None]:
    """What is unusual about each amplitude's G/Gmax and damping, or ``None``.

    A site-response program takes ``0 < G/Gmax <= 1`` and ``0 <= damping < 1``; a value
    outside (G/Gmax above 1 where a loop came out stiffer than the model's Gmax, a NaN) is
    kept in every table with a flag, and left out of the site-response curves.
    """
    out: list[str | None] = []
    for g, d in zip(np.asarray(g_ratio, dtype=float), np.asarray(damping, dtype=float)):
        why = []
        if not np.isfinite(g):
            why.append("G/Gmax is not finite")
        elif g <= 0 or g > 1 + _G_RATIO_TOL:
            why.append(f"G/Gmax = {g:.4g} {'above 1 (a loop stiffer than Gmax)' if g > 1 else 'not positive'}")
        if not np.isfinite(d):
            why.append("damping is not finite")
        elif d < 0 or d >= 1:
            why.append(f"damping = {d:.4g} outside [0, 1)")
        out.append("; ".join(why) or None)
    return out


def curve_value_warnings(method: str, amplitudes: Any, g_ratio: Any, damping: Any) -> list[str]:
    """One warning per amplitude whose G/Gmax or damping is unusual (:func:`curve_value_problems`)."""
    return [f"{method} model, amplitude {a:.1e}: {p}: written with a flag (value_flag = 1 in "
            "modulus_reduction.csv) and left out of the site-response curves"
            for a, p in zip(amplitudes, curve_value_problems(g_ratio, damping)) if p]


def packing_gmax_line(pg: dict, g_affine: float) -> str:
    """The report line of :func:`packing_gmax` beside the affine model's ``g_affine``."""
    if "error" in pg:
        return f"  packing Gmax ({pg['packing']}): not computed: {pg['error']}"
    g = pg["G_max_Pa"]
    line = (f"  packing Gmax ({pg['packing']}, {pg['grains']} grains in equilibrium, void ratio "
            f"{pg['void_ratio']:.3f}, small strain only) = {g:.4g} Pa: the affine Gmax is {g_affine / g:.2f} x this")
    emp = pg.get("empirical_G_max")
    if emp:
        line += (f"; Hardin-Richart (1963) at e = {pg['void_ratio']:.3f}: {emp['G_round_Pa']:.4g} Pa round, "
                 f"{emp['G_angular_Pa']:.4g} Pa angular grains")
    return line

"""Config tables -> library objects (shared by the CLI and the Python API).

Tables understood here (all keys optional unless marked):

``[microstructure]`` (``[packing]`` before: :func:`microstructure_key`)
    ``void_ratio``, ``coordination`` (a number or a correlation name: ``"yanagisawa"``,
    ``"smith"``, ``"filep"``, ``"field"``, ``"chang"``), ``radius`` (length), ``convention``
    (``"physical"`` | ``"seed"``); or directly ``contacts_per_volume`` (1/length^d) and
    ``branch_length`` (length).
``[fabric]``
    ``dim`` (3 | 2); seed parameters ``a20, a22, b22`` (3D) or ``a2, b2, a4, b4`` (2D);
    or ``tensor`` (a fabric tensor N_ij, trace 1); default isotropic.
``[contacts]`` (``[contact]`` for one contact)
    the contact law, read by :func:`build_law` for every command (``docs/config.md``).
``[stress]``
    ``pressure`` (stress), or ``tensor`` (3x3 / 2x2, compression positive).

``[initial]``, ``[[path]]`` of ``grainmech contact``
    :func:`build_contact_path`.

Unit system: quantities with units are converted to SI; bare numbers are taken as SI.
Angles must carry their unit (``"24 deg"``); a bare angle is an error.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech import contact, fabric
from grainmech._deprecated import moved_attribute
from grainmech.contact.forms import law_forms, normal_law
from grainmech.contact.rolling import RollingResistance
from grainmech.errors import ConfigError, GrainmechError
from grainmech.fabric import CORRELATIONS, coordination_number, fit_density
from grainmech.io.config import Section, read_text_file
from grainmech.io.units import to_float
from grainmech.material import Microstructure

__all__ = ["build_fabric", "read_normals", "build_microstructure", "MICROSTRUCTURE", "RENAMED_TABLES",
           "microstructure_key", "renamed_table_warnings", "coordination_relation", "build_law", "build_stress",
           "build_pressure", "check_pressure", "pressure_problem", "PRESSURE_MIN", "PRESSURE_MAX",
           "LAWS", "PACKING_LAWS", "build_contact_path", "contact_units", "ContactInitial",
           "ContactSegment", "build_rolling", "ROLLING_KEYS"]

SEED_3D = ("a20", "a22", "b22")
SEED_2D = ("a2", "b2", "a4", "b4")


def read_normals(path: str | Path, key: str = "fabric.normals") -> np.ndarray:
    """Unit contact normals (n, d) read from a ``.npy`` or text file.

    Unit contact normals from a file: ``.npy`` (array ``(n, d)``) or text (CSV or
    whitespace separated, ``d`` = 2 or 3 columns, ``#`` comments, an optional header
    line). Rows are normalised to unit length; a zero row is an error naming the line.
    """
    p = Path(path)
    if p.suffix.lower() == ".npy":
        try:
            arr = np.load(p, allow_pickle=False)
        except FileNotFoundError:
            raise ConfigError(key, str(path), "file not found") from None
        except (OSError, ValueError, EOFError) as exc:
            raise ConfigError(key, str(path), f"cannot read the .npy file ({type(exc).__name__}: {exc})") from None
        lines: list[int] | None = list(range(1, len(arr) + 1)) if np.ndim(arr) == 2 else None
    else:
        try:
            text = read_text_file(p, "normals")
        except GrainmechError as exc:
            raise ConfigError(key, str(path), str(exc)) from None
        rows: list[list[float]] = []
        lines = []
        for i, line in enumerate(text.splitlines(), 1):
            t = line.split("#", 1)[0].strip()
            if not t:
                continue
            parts = [x for x in t.replace(",", " ").replace(";", " ").split()]
            try:
                rows.append([float(x) for x in parts])
            except ValueError:
                if not rows:  # a header line
                    continue
                raise ConfigError(key, str(path), f"line {i}: not a row of numbers: {line.strip()!r}") from None
            lines.append(i)
        if not rows:
            raise ConfigError(key, str(path), "no normals in the file")
        if len({len(r) for r in rows}) != 1:
            raise ConfigError(key, str(path), "every row needs the same number of columns (2 or 3)")
        arr = np.array(rows, dtype=float)
    if np.ndim(arr) != 2 or arr.shape[1] not in (2, 3):
        raise ConfigError(key, str(path), f"needs 2 or 3 columns (components of each normal), got shape "
                          f"{np.shape(arr)}")
    arr = np.asarray(arr, dtype=float)
    norm = np.linalg.norm(arr, axis=1)
    bad = ~np.isfinite(norm) | (norm == 0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise ConfigError(key, str(path), f"normal on line {lines[i] if lines is not None else i + 1} is zero "
                          "or not finite")
    return arr / norm[:, None]


def build_fabric(sec: Section, fit_report: dict | None = None) -> Any:
    """Contact-normal density from the ``[fabric]`` table.

    Density from ``[fabric]``: seed parameters, a fabric tensor, or a file of measured
    contact normals (``normals = "file.csv"``, ``fit_order = 2``) fitted by
    :func:`grainmech.fabric.fit_density` (moment estimator, chi-square test of the fit;
    a fitted series negative somewhere is shrunk towards isotropy until it is not, and
    the factor is reported). ``fit_report``, if given, receives the fit's summary.
    """
    if sec.has("normals"):
        return _fabric_from_normals(sec, fit_report)
    dim = sec.integer("dim", 3)
    if dim not in (2, 3):
        raise ConfigError(sec.key("dim"), dim, "must be 2 or 3")
    names = SEED_3D if dim == 3 else SEED_2D
    other = SEED_2D if dim == 3 else SEED_3D
    for k in other:
        if sec.has(k):
            raise ConfigError(sec.key(k), sec.data[k], f"is a {'2D' if dim == 3 else '3D'} parameter but dim = {dim}")
    if sec.has("tensor"):
        if any(sec.has(k) for k in names):
            raise ConfigError(sec.key("tensor"), sec.data["tensor"],
                              f"give either tensor or {', '.join(names)}, not both")
        raw = sec.raw("tensor")
        try:
            N = np.asarray(raw, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(sec.key("tensor"), raw, "must be a square array of numbers") from None
        if N.shape != (dim, dim):
            raise ConfigError(sec.key("tensor"), raw, f"must be a {dim}x{dim} array")
        if not np.all(np.isfinite(N)) or abs(np.trace(N) - 1.0) > 1e-6 or not np.allclose(N, N.T):
            raise ConfigError(sec.key("tensor"), raw, "must be symmetric with trace 1 (N_ij = <n_i n_j>)")
        if np.allclose(N, np.eye(dim) / dim, rtol=0, atol=1e-12):
            return fabric.isotropic(dim)
        with sec.checked({"N": "tensor"}):
            return fabric.density_from_fabric_tensor(N)
    vals: dict[str, Any] = {k: sec.number(k, None, 0.0) for k in names}
    if not any(vals.values()):
        # the isotropic density has order 0: quadrature rules are chosen by the order of
        # density x integrand, so an order-2 density with zero coefficients would cost
        # a rule two degrees higher (770 instead of 14 directions for a stiffness)
        return fabric.isotropic(dim)
    cls = fabric.SphericalDensity if dim == 3 else fabric.FourierDensity
    with sec.checked():
        return cls.from_seed(**vals)


#: highest ``fabric.fit_order`` by dimension (3D: spherical harmonics, whose fit grows as the
#: order's fourth power or so; 2D: a Fourier series, cheap)
FIT_MAX_ORDER = {2: 64, 3: 16}


def _fabric_from_normals(sec: Section, fit_report: dict | None) -> Any:
    raw = sec.raw("normals")
    if not isinstance(raw, str) or not raw.strip():
        raise ConfigError(sec.key("normals"), raw, "must be the path of a file of contact normals")
    n = read_normals(raw, sec.key("normals"))
    dim = sec.integer("dim", n.shape[1])
    if dim != n.shape[1]:
        raise ConfigError(sec.key("dim"), dim, f"but the normals in {raw} have {n.shape[1]} components")
    top = FIT_MAX_ORDER[dim]
    order = sec.integer("fit_order", 2, min=2)
    if order > top:
        raise ConfigError(sec.key("fit_order"), order, f"must be <= {top} in {dim}D (time and memory: in 3D order 16 "
                          "takes some 10 s, order 30 minutes; 2 and 4 describe measured fabrics)")
    if order % 2:
        raise ConfigError(sec.key("fit_order"), order, "must be even (the density of normals is centrosymmetric)")
    for k in (SEED_3D + SEED_2D + ("tensor",)):
        if sec.has(k):
            raise ConfigError(sec.key(k), sec.data[k], "give either normals or the density's coefficients, not both")
    with sec.checked({"order": "fit_order"}):
        fit = fit_density(n, order, on_negative="shrink")
    if fit_report is not None:
        fit_report.update(
            source=raw, n_normals=fit.n_normals, order=order, dim=dim, chi2=fit.chi2, dof=fit.dof,
            p_value=fit.p_value, n_bins=fit.n_bins, shrink_factor=fit.shrink_factor,
            seed_coefficients={str(k): v for k, v in fit.seed_coefficients.items()},
            seed_standard_errors={str(k): v for k, v in fit.seed_standard_errors.items()},
            message=fit.message,
            summary=(f"fabric fitted to {fit.n_normals} normals of {raw} (order {order}): "
                     + (f"chi-square {fit.chi2:.4g} on {fit.dof} degrees of freedom, p = {fit.p_value:.3g}"
                        if fit.p_value is not None else "too few normals for a chi-square test")
                     + (f"; the fitted series was negative somewhere and its anisotropy is shrunk by "
                        f"{fit.shrink_factor:.3g}" if fit.shrink_factor < 1 else "")))
    return fit.density


def coordination_relation(sec: Section, void_ratio: float, pressure: float | None) -> float:
    """Coordination number from a relation table at ``microstructure.coordination``.

    Coordination number from a table ``{a, b = 0, n = 0, p_ref = "1 atm"}`` at
    ``microstructure.coordination``: ``m = (a - b e) (p / p_ref)^n`` at the mean stress ``p`` [Pa].

    ``n = 0``, ``a = 23``, ``b = 25`` is seed Eq. 6.4 (``m = 23 - 25 e``); ``n > 0`` is the
    phenomenological pressure dependence ``grainmech calibrate`` can fit
    (``docs/calibrate.md``). ``sec`` is the ``[microstructure]`` section; raises
    :class:`ConfigError` naming the key for a missing mean stress or ``m <= 0``.
    """
    coord = sec.raw("coordination")
    cs = sec.section("coordination")
    a = cs.number("a", None)
    b = cs.number("b", None, 0.0)
    n = cs.number("n", None, 0.0)
    p_ref = cs.number("p_ref", "Pa", 101325.0, min=0, min_inclusive=False)
    cs.finish()
    if n == 0.0:
        m = a - b * void_ratio
    elif pressure is None:
        raise ConfigError(sec.key("coordination"), coord, "a relation with n != 0 needs the mean stress: "
                          "give [stress] pressure (stiffness) or [initial] pressure (run)")
    else:
        m = (a - b * void_ratio) * (pressure / p_ref) ** n
    if not np.isfinite(m) or m <= 0:
        raise ConfigError(sec.key("coordination"), coord, f"gives coordination m = {m:.4g} at void ratio "
                          f"{void_ratio:g}" + ("" if pressure is None else f" and mean stress {pressure:.4g} Pa")
                          + " (must be > 0)")
    return float(m)


#: Mean coordination numbers a config may give (contacts per grain): 1e-3 to 1e3. Far
#: outside every packing (3-14 for spheres, more only for very unequal sizes), and the
#: limits keep the contact forces (which go as 1/m) away from floating-point under- and
#: overflow: a fuzz test's 2e-311 and 9.6e297 gave NaN forces and overflow warnings
#: before the error.
COORDINATION_MIN, COORDINATION_MAX = 1e-3, 1e3


#: The analytical microstructure's table (void ratio, coordination and radius, or contacts
#: per volume and branch length: :func:`build_microstructure`). "packing" names a packing
#: of grains only (``[model] packing``).
MICROSTRUCTURE = "microstructure"
#: config tables renamed: old name -> new name. The old name is still read, with a warning
#: (:func:`renamed_table_warnings`), until the next minor release; both at once are refused.
RENAMED_TABLES = {"packing": MICROSTRUCTURE}


def microstructure_key(root: Section) -> str:
    """The name ``root`` gives the analytical microstructure's table: ``"microstructure"``, or the old ``"packing"``.

    A config written before the rename has ``[packing]``; it is read under that name, so
    that every message names the key as the user wrote it. Without either table the new
    name is returned (a missing table is then reported as ``microstructure``).

    Raises
    ------
    ConfigError
        If both names are given, naming both.
    """
    old = next((o for o, n in RENAMED_TABLES.items() if n == MICROSTRUCTURE and root.has(o)), None)
    if old is None:
        return MICROSTRUCTURE
    if root.has(MICROSTRUCTURE):
        raise ConfigError(root.key(old), None, f"[{root.key(old)}] and [{root.key(MICROSTRUCTURE)}] are the same "
                          f"table ([{old}] is its old name): keep [{root.key(MICROSTRUCTURE)}] only")
    return old


def renamed_table_warnings(cfg: Any, prefix: str = "") -> list[str]:
    """One warning for each renamed table (:data:`RENAMED_TABLES`) that ``cfg`` gives under its old name.

    ``prefix`` is the dotted name of ``cfg`` in its file (``"model"`` in a calibration).
    """
    if not isinstance(cfg, dict):
        return []
    dot = f"{prefix}." if prefix else ""
    return [f"[{dot}{old}] is now [{dot}{new}]; the old name is read until the next minor release"
            for old, new in RENAMED_TABLES.items() if isinstance(cfg.get(old), dict)]


def build_microstructure(sec: Section, density: Any, pressure: float | None = None) -> Any:
    """The :class:`~grainmech.material.Microstructure` of the ``[microstructure]`` table and a density.

    The analytical description (contacts per volume and branch length, or void ratio,
    coordination and radius) from ``[microstructure]`` (``[packing]`` in older configs:
    :func:`microstructure_key`) and a density; ``pressure`` [Pa] is the mean stress a
    coordination relation (:func:`coordination_relation`) is evaluated at.
    """
    convention = sec.choice("convention", ("physical", "seed"), "physical")
    if sec.has("contacts_per_volume") or sec.has("branch_length"):
        nv = sec.number("contacts_per_volume", f"1/m**{density.dim}", min=0, min_inclusive=False)
        bl = sec.number("branch_length", "m", min=0, min_inclusive=False)
        radius = sec.number("radius", "m", None, min=0, min_inclusive=False)
        with sec.checked():
            return Microstructure(density, nv, bl, convention, radius)
    e = sec.number("void_ratio", None, min=0, min_inclusive=False)
    coord = sec.raw("coordination")
    name = coord.strip().lower() if isinstance(coord, str) else None
    if name is not None and name in CORRELATIONS:
        with sec.checked():
            m = float(coordination_number(e, name))
    elif isinstance(coord, dict):
        m = coordination_relation(sec, e, pressure)
    else:
        try:
            m = sec.number("coordination", None, min=COORDINATION_MIN, max=COORDINATION_MAX)
        except ConfigError:
            if isinstance(coord, str):
                raise ConfigError(sec.key("coordination"), coord, "must be a positive number or one of "
                                  f"{', '.join(map(repr, sorted(CORRELATIONS)))}") from None
            raise
    radius = sec.number("radius", "m", min=0, min_inclusive=False)
    with sec.checked():
        return Microstructure.from_grains(density, void_ratio=e, coordination=m, radius=radius, convention=convention)


#: Stresses a config or a data file may give [Pa]: 1 Pa to 1 GPa. 1 Pa is the weight of
#: about a tenth of a millimetre of sand; near 1 GPa quartz grains crush (and a
#: small-strain contact model has long stopped applying). A value outside is a slip of
#: the unit ("1e12 Pa", "100" meant in kPa read as Pa is below 1 kPa and only warned
#: about) and is refused before any work, naming the key and the value.
PRESSURE_MIN, PRESSURE_MAX = 1.0, 1e9
PRESSURE_RANGE_TEXT = "1 Pa to 1 GPa, the stresses granular materials carry (quartz grains crush near 1 GPa)"
#: The narrower range a run may ask of a packing of grains (``method = "packing"`` or
#: ``"dem"``) [Pa]: below 1 kPa a sand's grains barely touch, above 100 MPa quartz grains
#: crush. Checked where the run's methods are known (:mod:`grainmech.jobs.run_config`), not
#: by the library, which also serves other materials and test packings.
GRAINS_PRESSURE_RANGE = (1e3, 1e8)


def pressure_problem(value: float) -> str | None:
    """Why the stress ``value`` [Pa] is refused (``None`` if it lies in the range)."""
    if PRESSURE_MIN <= value <= PRESSURE_MAX:
        return None
    return f"{value:.4g} Pa is outside {PRESSURE_RANGE_TEXT}"


def check_pressure(value: float, key: str, raw: Any = None) -> float:
    """``value`` [Pa] if it lies in :data:`PRESSURE_MIN` .. :data:`PRESSURE_MAX`.

    Raises
    ------
    ConfigError
        Naming ``key`` and the value as written (``raw``, default ``value``).
    """
    problem = pressure_problem(value)
    if problem is not None:
        raise ConfigError(key, value if raw is None else raw, problem)
    return value


def build_pressure(sec: Section, key: str = "pressure") -> float:
    """A mean stress [Pa] in :data:`PRESSURE_MIN` .. :data:`PRESSURE_MAX`."""
    return check_pressure(sec.number(key, "Pa"), sec.key(key), sec.raw(key))


def build_stress(sec: Section, dim: int) -> Any:
    """Pressure (float) or stress tensor from ``[stress]``; None if the table is empty."""
    if sec.has("pressure") and sec.has("tensor"):
        raise ConfigError(sec.key("tensor"), sec.data["tensor"], "give either pressure or tensor, not both")
    if sec.has("pressure"):
        return build_pressure(sec)
    if sec.has("tensor"):
        raw = sec.raw("tensor")
        try:
            S = np.array([[to_float(v, "Pa", sec.key("tensor")) for v in row] for row in raw])
        except TypeError:
            raise ConfigError(sec.key("tensor"), raw, f"must be a {dim}x{dim} array") from None
        if S.shape != (dim, dim) or not np.allclose(S, S.T):
            raise ConfigError(sec.key("tensor"), raw, f"must be a symmetric {dim}x{dim} array")
        if np.abs(S).max() > PRESSURE_MAX:
            raise ConfigError(sec.key("tensor"), raw, f"entries must not exceed {PRESSURE_MAX:g} Pa in size "
                              f"({PRESSURE_RANGE_TEXT})")
        check_pressure(float(np.trace(S)) / dim, sec.key("tensor"), raw)  # its mean stress
        return S
    return None


#: every contact law a config can name (``[contacts] law`` / ``[contact] law``)
LAWS = ("linear", "hertz", "hertz-mindlin", "mindlin-deresiewicz", "cylinder")
#: laws for a packing of equal spheres (``stiffness``, ``run``, ``calibrate``)
PACKING_LAWS = ("linear", "hertz-mindlin", "mindlin-deresiewicz")

#: keys renamed in the config schema: old key -> new key
RENAMED = {"radius1": "radius"}

#: the ``[contacts]`` keys of rolling and twisting resistance (:func:`build_rolling`)
ROLLING_KEYS = ("rolling_friction", "rolling_stiffness", "twisting_friction")


def _friction(sec: Section, required: bool) -> float:
    """Coulomb coefficient from ``friction`` (mu) or ``friction_angle`` (tan phi)."""
    if sec.has("friction") and sec.has("friction_angle"):
        raise ConfigError(sec.key("friction_angle"), sec.data["friction_angle"],
                          "give either friction or friction_angle, not both")
    if sec.has("friction"):
        return sec.number("friction", None, min=0)
    if sec.has("friction_angle"):
        return float(np.tan(sec.angle("friction_angle", max_deg=90.0, max_inclusive=False)))
    if required:
        raise ConfigError(sec.key("friction"), None,
                          f"is required for law = {sec.data.get('law')!r} (or give friction_angle)")
    return float("inf")


def _reversals(sec: Section) -> dict:
    """``max_reversals`` if given (else the law's default, 16)."""
    return {"max_reversals": sec.integer("max_reversals", min=1)} if sec.has("max_reversals") else {}


def build_law(sec: Section, radius: float | None = None, *, laws: tuple[str, ...] = PACKING_LAWS,
              rolling: bool = False) -> Any:
    """Contact-law parameters (:mod:`grainmech.contact`) from a ``[contacts]``/``[contact]`` table.

    The one reader of a contact law for every command. Keys by ``law``:

    * ``"linear"``: ``kn`` (> 0), ``ks`` (>= 0) [force/length], optional ``friction`` or
      ``friction_angle`` (default: no sliding);
    * ``"hertz"``: ``shear_modulus``, ``poisson`` (frictionless; seed Eq. 3.1-3.7);
    * ``"hertz-mindlin"``: as ``hertz`` plus optional ``friction``/``friction_angle``;
    * ``"mindlin-deresiewicz"``: as ``hertz`` plus ``friction`` or ``friction_angle``
      (required) and ``max_reversals`` (16);
    * ``"cylinder"`` (rods, per unit length; seed Eq. 3.8, 3.17): ``shear_modulus_equiv``,
      ``poisson``, ``radius``, optional ``radius2``, ``psi``, ``friction_angle``,
      ``max_reversals``.

    Parameters
    ----------
    sec : Section
        The table.
    radius : float, optional
        Grain radius [m] (``microstructure.radius``, or the grains' median). Without it (one contact,
        ``grainmech contact``) the table itself gives ``radius`` and may describe a second
        body (``radius2``, ``shear_modulus2``, ``poisson2``).
    laws : tuple of str
        The laws this command accepts.
    rolling : bool
        Whether the command reads the rolling-resistance keys (:data:`ROLLING_KEYS`, read by
        :func:`build_rolling`); without it they are an error naming the key.

    Raises
    ------
    ConfigError
        Naming the key and value (unknown keys are reported by ``Section.finish``).
    """
    for old, new in RENAMED.items():
        if sec.has(old):
            raise ConfigError(sec.key(old), sec.data[old], f"renamed: write {new!r} (the grain radius)")
    if not rolling:
        for k in ROLLING_KEYS:
            if sec.has(k):
                raise ConfigError(sec.key(k), sec.data[k], "rolling and twisting resistance needs grain rotations: "
                                  "it is read by grainmech run (packing and DEM models), not by this command")
    law = sec.choice("law", laws)
    if radius is not None and sec.has("radius"):
        raise ConfigError(sec.key("radius"), sec.data["radius"],
                          "the grain radius is microstructure.radius (or the grains' own), not a contact-law key")

    def make(cls: Any, *args: Any, **kw: Any) -> Any:
        with sec.checked(RENAMED):  # the parameter classes name their fields: use the file's keys
            return cls(*args, **kw)

    if law == "linear":
        kn = sec.number("kn", "N/m", min=0, min_inclusive=False)
        ks = sec.number("ks", "N/m", min=0)
        return make(contact.LinearSpring, kn, ks, friction=_friction(sec, False))
    if law == "cylinder":
        G = sec.number("shear_modulus_equiv", "Pa", min=0, min_inclusive=False)
        nu = sec.number("poisson", None, min=-1, max=0.5, min_inclusive=False, max_inclusive=False)
        R = radius if radius is not None else sec.number("radius", "m", min=0, min_inclusive=False)
        R2 = None if radius is not None else sec.number("radius2", "m", None, min=0, min_inclusive=False)
        psi = sec.number("psi", None, min=0, min_inclusive=False)
        phi = sec.angle("friction_angle", max_deg=90.0, max_inclusive=False)
        return make(contact.Cylinder, G, nu, R, psi, phi, R2, **_reversals(sec))
    G = sec.number("shear_modulus", "Pa", min=0, min_inclusive=False)
    nu = sec.number("poisson", None, min=-1, max=0.5, min_inclusive=False, max_inclusive=False)
    if radius is None:
        R1 = sec.number("radius", "m", min=0, min_inclusive=False)
        second: tuple[float | None, float | None, float | None]
        second = (sec.number("radius2", "m", None, min=0, min_inclusive=False),
                  sec.number("shear_modulus2", "Pa", None, min=0, min_inclusive=False),
                  sec.number("poisson2", None, None, min=-1, max=0.5, min_inclusive=False,
                             max_inclusive=False))
    else:
        R1, second = radius, (None, None, None)
    if law == "hertz":
        return make(contact.Hertz, G, nu, R1, *second)
    if law == "hertz-mindlin":
        return make(contact.HertzMindlin, G, nu, R1, *second, friction=_friction(sec, False))
    mu = _friction(sec, True)
    return make(contact.MindlinDeresiewicz, G, nu, R1, *second, friction=mu, **_reversals(sec))


def _dimensionless(sec: Section, k: str) -> float:
    """A finite coefficient ``>= 0`` at ``k``, written as a plain number (no unit, no angle)."""
    raw = sec.raw(k)
    if isinstance(raw, str):
        try:
            float(raw.strip())
        except ValueError:
            raise ConfigError(sec.key(k), raw, "is a dimensionless coefficient (|M| <= mu R* N): write a plain "
                              "number, without a unit") from None
    return sec.number(k, None, min=0)


def build_rolling(sec: Section, law: Any) -> RollingResistance | None:
    """Rolling and twisting resistance from the ``[contacts]`` table, or None.

    Keys (all optional; :mod:`grainmech.contact.rolling`):

    * ``rolling_friction``: ``mu_r >= 0`` (dimensionless): ``|M_r| <= mu_r R* N``;
      required when either other key is given;
    * ``rolling_stiffness``: ``k_roll > 0`` [N/m] (rolling moment stiffness
      ``k_roll R*^2``); omitted: the Mindlin tangential stiffness ``8 G* a`` at the packing's
      mean contact force (Iwashita & Oda 1998), or ``ks`` of linear springs;
    * ``twisting_friction``: ``mu_t >= 0``: ``|M_t| <= mu_t R̄* N``; omitted: ``mu_r``.

    Returns None when the keys are absent or resist nothing (``mu_r = 0`` and ``mu_t = 0``):
    a run is then exactly the run without them.

    Raises
    ------
    ConfigError
        Naming the key and value: a negative, non-finite or unit-carrying coefficient, a
        stiffness <= 0, or a law that cannot carry contact moments (rods: ``'cylinder'``;
        the frictionless ``'hertz'``; linear springs with ``ks = 0`` and no
        ``rolling_stiffness``).
    """
    given = [k for k in ROLLING_KEYS if sec.has(k)]
    if not given:
        return None
    if not sec.has("rolling_friction"):
        k = given[0]
        raise ConfigError(sec.key(k), sec.data[k], "needs contacts.rolling_friction (mu_r; 0 for twisting "
                          "resistance alone)")
    mu_r = _dimensionless(sec, "rolling_friction")
    k_roll = sec.number("rolling_stiffness", "N/m", None, min=0, min_inclusive=False)
    mu_t = _dimensionless(sec, "twisting_friction") if sec.has("twisting_friction") else None
    first = given[0]
    forms = law_forms(law)
    name = sec.data.get("law")
    if normal_law(law) == "cylinder":
        raise ConfigError(sec.key(first), sec.data[first], f"law = {name!r} (rods, forces per unit length) "
                          "carries no contact moments: rolling resistance is for spheres "
                          "('hertz-mindlin', 'mindlin-deresiewicz' or 'linear')")
    if forms.kind == "frictionless":
        raise ConfigError(sec.key(first), sec.data[first], f"law = {name!r} is frictionless (no tangential "
                          "spring): rolling resistance needs a frictional law ('hertz-mindlin' or "
                          "'mindlin-deresiewicz')")
    if forms.linear and not law.ks > 0 and k_roll is None:
        raise ConfigError(sec.key(first), sec.data[first], "law = 'linear' with ks = 0 has no tangential "
                          "stiffness to tie the rolling stiffness to: give contacts.rolling_stiffness")
    with sec.checked():
        rr = RollingResistance(mu_r, k_roll, mu_t)
    return rr if rr.active else None


# ------------------------------------------------------------------ a single contact's path
@dataclass(frozen=True)
class ContactInitial:
    """Initial normal state of a contact: ``mode`` ``"force"`` (N) or ``"disp"`` (approach, m)."""

    mode: str
    value: float


@dataclass(frozen=True)
class ContactSegment:
    """One ramp of a contact path.

    One ramp of a contact path: per channel a mode (``"force"``, ``"disp"`` or ``None``
    = hold) and an absolute target; ``index`` is the ``[[path]]`` entry it came from.
    """

    steps: int
    index: int
    n_mode: str | None
    n_target: float
    t_mode: str | None
    t_target: float


def contact_units(params: Any) -> tuple[str, str]:
    """(force unit, displacement unit) of a contact law: forces per unit length for rods."""
    return ("N/m" if normal_law(params) == "cylinder" else "N"), "m"


def _channel(sec: Section, fkey: str, dkey: str, fu: str, du: str) -> tuple[str | None, float]:
    if sec.has(fkey) and sec.has(dkey):
        raise ConfigError(sec.key(dkey), sec.data[dkey], f"give {fkey} or {dkey}, not both")
    if sec.has(fkey):
        return "force", sec.number(fkey, fu)
    if sec.has(dkey):
        return "disp", sec.number(dkey, du)
    return None, 0.0


def build_contact_path(root: Section, params: Any) -> tuple[ContactInitial, list[ContactSegment]]:
    """Initial state and ramps of a ``grainmech contact`` config.

    ``[initial]`` and ``[[path]]`` of a ``grainmech contact`` config (cycles expanded
    into ramps: ``+A`` in ``steps/2`` steps, then ``count`` times ``-A``, ``+A``).
    """
    fu, du = contact_units(params)
    ini = root.section("initial", {})
    if ini.has("normal_force") and ini.has("approach"):
        raise ConfigError(ini.key("approach"), ini.data["approach"], "give normal_force or approach, not both")
    if ini.has("approach"):
        init = ContactInitial("disp", ini.number("approach", du))
    else:
        init = ContactInitial("force", ini.number("normal_force", fu, 0.0, min=0.0))
    raw = root.raw("path")
    if not isinstance(raw, list) or not raw:
        raise ConfigError("path", raw, "expected a non-empty array of tables [[path]]")
    segs: list[ContactSegment] = []
    for i, item in enumerate(raw):
        sec = Section(item, f"path[{i}]")
        kind = sec.choice("kind", ("ramp", "cycles"), "ramp")
        steps = sec.integer("steps", min=1, max=MAX_CONTACT_STEPS)
        if kind == "ramp":
            n_mode, n_t = _channel(sec, "normal_force", "normal_displacement", fu, du)
            if n_mode == "force" and n_t < 0:
                raise ConfigError(sec.key("normal_force"), sec.data["normal_force"],
                                  "must be >= 0 (compression positive)")
            t_mode, t_t = _channel(sec, "tangential_force", "tangential_displacement", fu, du)
            segs.append(ContactSegment(steps, i, n_mode, n_t, t_mode, t_t))
        else:
            count = sec.integer("count", min=1)
            t_mode, amp = _channel(sec, "tangential_force_amplitude", "tangential_displacement_amplitude", fu, du)
            if t_mode is None:
                raise ConfigError(sec.key("tangential_force_amplitude"), None,
                                  "a cycles segment needs tangential_force_amplitude or "
                                  "tangential_displacement_amplitude")
            if amp <= 0:
                key = "tangential_force_amplitude" if t_mode == "force" else "tangential_displacement_amplitude"
                raise ConfigError(sec.key(key), sec.data[key], "amplitude must be positive")
            if count * steps > MAX_CONTACT_STEPS:
                raise ConfigError(sec.key("count"), count, f"with steps = {steps}: more than {MAX_CONTACT_STEPS:.0e} "
                                  "steps (memory and time)")
            segs.append(ContactSegment(max(1, (steps + 1) // 2), i, None, 0.0, t_mode, amp))
            for _ in range(count):
                segs.append(ContactSegment(steps, i, None, 0.0, t_mode, -amp))
                segs.append(ContactSegment(steps, i, None, 0.0, t_mode, amp))
        sec.finish()
    total = sum(sg.steps for sg in segs)
    if total > MAX_CONTACT_STEPS:
        raise ConfigError("path", f"{total} steps", f"more than {MAX_CONTACT_STEPS:.0e} steps in all (memory and time)")
    if any(sg.t_mode == "force" for sg in segs) and hasattr(params, "ks") and not params.ks > 0:
        raise ConfigError("contact.ks", params.ks, "a path that prescribes a tangential force needs a tangential "
                          "stiffness: ks = 0 carries none (prescribe tangential_displacement instead)")
    return init, segs


#: most steps of a ``grainmech contact`` path (one row each in the table)
MAX_CONTACT_STEPS = 1_000_000

#: grain shear moduli LAMMPS is given [Pa]: soft polymer beads (1 MPa) to diamond (~0.5 TPa)
GRAIN_SHEAR_MODULUS_RANGE = (1e6, 1e12)


def __getattr__(name: str) -> Any:
    return moved_attribute(__name__, name)  # build_packing: build_microstructure (a warning)

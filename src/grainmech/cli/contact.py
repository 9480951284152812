"""``grainmech contact CONFIG.toml -o OUTDIR``: drive one contact through a loading path.

The config names a contact law (``[contact]``), an initial state (``[initial]``) and a
path of segments (``[[path]]``) in which the normal and the tangential channel are each
under force or displacement control. Each step is solved with
:func:`grainmech.contact.solve_step`. Output, written atomically in ``OUTDIR``:

* ``contact.csv`` — one row per step (step 0 is the initial state) with the columns
  ``step, segment, normal_displacement, tangential_displacement, normal_force,
  tangential_force, dissipated_energy, normal_stiffness, tangential_stiffness, sliding``
  (SI units; the tangential quantities are the components along the loading axis ``x``;
  ``normal_displacement`` is the approach);
* ``contact.png`` — tangential force–displacement loop and normal force–approach curve
  (skipped with ``--no-plot``).

Config reference (see ``examples/contact_*.toml``)::

    [contact]
    law = "mindlin-deresiewicz"  # hertz | hertz-mindlin | mindlin-deresiewicz | linear | cylinder
    shear_modulus = "29 GPa"     # hertz family: shear_modulus, poisson, radius1,
    poisson = 0.2                #   optional radius2, shear_modulus2, poisson2,
    radius1 = "1 mm"             #   friction (hertz-mindlin, mindlin-deresiewicz),
    friction = 0.5               #   max_reversals (mindlin-deresiewicz)
    # linear:   kn, ks, friction
    # cylinder: shear_modulus_equiv, poisson, radius, radius2, psi, friction_angle
    #           (with its unit, e.g. "15 deg"), max_reversals

    [initial]
    normal_force = "10 N"        # or approach = "1 um" (per unit length for cylinder)

    [[path]]                     # a ramp: targets reached linearly in `steps` steps
    steps = 20
    normal_force = "20 N"        # or normal_displacement (absolute approach); omit: hold
    tangential_force = "3 N"     # or tangential_displacement (absolute); omit: hold

    [[path]]                     # symmetric cycles of the tangential channel
    kind = "cycles"
    count = 2                    # number of full cycles +A -> -A -> +A
    steps = 40                   # steps per half cycle (the first ramp to +A takes steps/2)
    tangential_force_amplitude = "3 N"   # or tangential_displacement_amplitude

A held channel keeps its current control mode (force or displacement). Unknown keys are
errors.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grainmech.io.results import atomic_write

from grainmech.errors import ConfigError, GrainmechError

__all__ = ["register", "run", "build_params", "build_path", "simulate", "COLUMNS"]

COLUMNS = ("step", "segment", "normal_displacement", "tangential_displacement", "normal_force",
           "tangential_force", "dissipated_energy", "normal_stiffness", "tangential_stiffness",
           "sliding")

_LAWS = ("hertz", "hertz-mindlin", "mindlin-deresiewicz", "linear", "cylinder")


def register(sub: Any) -> None:
    p = sub.add_parser(
        "contact", help="drive one contact through a path of normal/tangential loads",
        description="Drive a single contact (Hertz, Hertz-Mindlin, Mindlin-Deresiewicz, linear or "
                    "rod contact; seed Chapter 3) through segments and cycles of prescribed normal "
                    "and tangential forces or displacements. Writes contact.csv and contact.png.")
    p.add_argument("config", help="TOML config (see examples/contact_*.toml)")
    p.add_argument("-o", "--outdir", required=True, help="output directory (created if needed)")
    p.add_argument("--no-plot", action="store_true", help="do not write contact.png")
    p.set_defaults(func=run)


# ---------------------------------------------------------------------------------------
# config -> library objects
# ---------------------------------------------------------------------------------------
def build_params(sec: Any) -> Any:
    """Contact parameter object from the ``[contact]`` table (a :class:`Section`)."""
    from grainmech.contact import Cylinder, Hertz, HertzMindlin, LinearSpring, MindlinDeresiewicz

    law = sec.choice("law", _LAWS)

    def wrap(fn, *args, **kw):
        try:
            return fn(*args, **kw)
        except ConfigError as exc:  # name the key as it is spelled in the file
            raise ConfigError(sec.key(exc.key), exc.value, exc.problem) from None

    if law in ("hertz", "hertz-mindlin", "mindlin-deresiewicz"):
        G = sec.number("shear_modulus", "Pa")
        nu = sec.number("poisson", None)
        R1 = sec.number("radius1", "m")
        R2 = sec.number("radius2", "m", None)
        G2 = sec.number("shear_modulus2", "Pa", None)
        nu2 = sec.number("poisson2", None, None)
        if law == "hertz":
            return wrap(Hertz, G, nu, R1, R2, G2, nu2)
        if law == "hertz-mindlin":
            mu = sec.number("friction", None, math.inf)
            return wrap(HertzMindlin, G, nu, R1, R2, G2, nu2, friction=mu)
        mu = sec.number("friction", None)
        mr = sec.integer("max_reversals", 16, min=1)
        return wrap(MindlinDeresiewicz, G, nu, R1, R2, G2, nu2, friction=mu, max_reversals=mr)
    if law == "linear":
        return wrap(LinearSpring, sec.number("kn", "N/m"), sec.number("ks", "N/m"),
                    sec.number("friction", None, math.inf))
    # cylinder (per unit length)
    G = sec.number("shear_modulus_equiv", "Pa")
    nu = sec.number("poisson", None)
    R = sec.number("radius", "m")
    R2 = sec.number("radius2", "m", None)
    psi = sec.number("psi", None)
    phi = math.degrees(sec.angle("friction_angle", max_deg=90.0, max_inclusive=False))
    mr = sec.integer("max_reversals", 16, min=1)
    return wrap(Cylinder, G, nu, R, psi, math.radians(phi), R2, max_reversals=mr)


@dataclass
class _Segment:
    """One ramp: per channel ("force" | "disp" | None = hold) and target (absolute)."""

    steps: int
    index: int
    n_mode: str | None
    n_target: float
    t_mode: str | None
    t_target: float


def _units(params: Any) -> tuple[str, str]:
    """(force unit, displacement unit) for reading targets."""
    from grainmech.contact import Cylinder

    return ("N/m" if isinstance(params, Cylinder) else "N"), "m"


def build_path(root: Any, params: Any) -> tuple[dict, list[_Segment]]:
    """Initial conditions and the list of ramps (cycles expanded) from the config root."""
    fu, du = _units(params)
    ini = root.section("initial", {})
    if ini.has("normal_force") and ini.has("approach"):
        raise ConfigError(ini.key("approach"), ini.data["approach"], "give normal_force or approach, not both")
    if ini.has("approach"):
        init = {"mode": "disp", "value": ini.number("approach", du)}
    else:
        init = {"mode": "force", "value": ini.number("normal_force", fu, 0.0, min=0.0)}

    raw = root.raw("path")
    if not isinstance(raw, list) or not raw:
        raise ConfigError("path", raw, "expected a non-empty array of tables [[path]]")
    segs: list[_Segment] = []
    for i, item in enumerate(raw):
        from grainmech.io.config import Section

        sec = Section(item, f"path[{i}]")
        kind = sec.choice("kind", ("ramp", "cycles"), "ramp")
        steps = sec.integer("steps", min=1)
        if kind == "ramp":
            n_mode, n_t = _channel(sec, "normal_force", "normal_displacement", fu, du)
            if n_mode == "force" and n_t < 0:
                raise ConfigError(sec.key("normal_force"), sec.data["normal_force"],
                                  "must be >= 0 (compression positive)")
            t_mode, t_t = _channel(sec, "tangential_force", "tangential_displacement", fu, du)
            segs.append(_Segment(steps, i, n_mode, n_t, t_mode, t_t))
        else:
            count = sec.integer("count", min=1)
            t_mode, amp = _channel(sec, "tangential_force_amplitude",
                                   "tangential_displacement_amplitude", fu, du)
            if t_mode is None:
                raise ConfigError(sec.key("tangential_force_amplitude"), None,
                                  "a cycles segment needs tangential_force_amplitude or "
                                  "tangential_displacement_amplitude")
            if amp <= 0:
                key = "tangential_force_amplitude" if t_mode == "force" else "tangential_displacement_amplitude"
                raise ConfigError(sec.key(key), sec.data[key], "amplitude must be positive")
            segs.append(_Segment(max(1, (steps + 1) // 2), i, None, 0.0, t_mode, amp))
            for _ in range(count):
                segs.append(_Segment(steps, i, None, 0.0, t_mode, -amp))
                segs.append(_Segment(steps, i, None, 0.0, t_mode, amp))
        sec.finish()
    return init, segs


def _channel(sec: Any, fkey: str, dkey: str, fu: str, du: str) -> tuple[str | None, float]:
    if sec.has(fkey) and sec.has(dkey):
        raise ConfigError(sec.key(dkey), sec.data[dkey], f"give {fkey} or {dkey}, not both")
    if sec.has(fkey):
        return "force", sec.number(fkey, fu)
    if sec.has(dkey):
        return "disp", sec.number(dkey, du)
    return None, 0.0


# ---------------------------------------------------------------------------------------
# simulation (no files)
# ---------------------------------------------------------------------------------------
def simulate(params: Any, init: dict, segments: list[_Segment]) -> dict[str, np.ndarray]:
    """Run the path; returns the output columns as arrays (row 0 = initial state)."""
    from grainmech.contact import solve_step, state_from_approach, state_from_normal_force

    if init["mode"] == "force":
        st = state_from_normal_force(params, [init["value"]], dim=1)
    else:
        st = state_from_approach(params, [init["value"]], dim=1)
    _, r0, _, _ = solve_step(params, st, d_normal=[0.0])
    rows: list[tuple] = []
    delta = 0.0
    rows.append((0, -1, float(st.approach[0]), delta, float(st.normal_force[0]), 0.0, 0.0,
                 float(r0.kn[0]), float(r0.ks[0]), False))
    n_mode = init["mode"]
    t_mode = "disp"
    step = 0
    for seg in segments:
        # start values of the ramp, in the segment's control modes
        if seg.n_mode is not None:
            n_mode = seg.n_mode
        if seg.t_mode is not None:
            t_mode = seg.t_mode
        n0 = float(st.normal_force[0]) if n_mode == "force" else float(st.approach[0])
        t0 = float(st.tangential_force[0, 0]) if t_mode == "force" else delta
        n1 = seg.n_target if seg.n_mode is not None else n0
        t1 = seg.t_target if seg.t_mode is not None else t0
        for j in range(1, seg.steps + 1):
            f = j / seg.steps
            nv = n0 + f * (n1 - n0)
            tv = t0 + f * (t1 - t0)
            kw: dict[str, Any] = {}
            if n_mode == "force":
                kw["normal_force"] = [max(nv, 0.0)]
            else:
                kw["d_normal"] = [nv - float(st.approach[0])]
            if t_mode == "force":
                kw["tangential_force"] = [tv]
            else:
                kw["d_tangential"] = np.array([[tv - delta]])
            st, r, _, dt = solve_step(params, st, **kw)
            delta += float(dt[0, 0])
            step += 1
            rows.append((step, seg.index, float(st.approach[0]), delta, float(st.normal_force[0]),
                         float(st.tangential_force[0, 0]), float(st.dissipated_energy[0]),
                         float(r.kn[0]), float(r.ks[0]), bool(r.sliding[0])))
    cols = list(zip(*rows))
    return {name: np.array(col) for name, col in zip(COLUMNS, cols)}


# ---------------------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------------------
def _atomic_write(path: Path, writer) -> None:
    atomic_write(path, writer, binary=True)


def write_csv(path: Path, data: dict[str, np.ndarray]) -> None:
    def writer(fh) -> None:
        fh.write((",".join(COLUMNS) + "\n").encode())
        n = len(data["step"])
        for i in range(n):
            vals = []
            for c in COLUMNS:
                v = data[c][i]
                if c in ("step", "segment"):
                    vals.append(str(int(v)))
                elif c == "sliding":
                    vals.append("1" if bool(v) else "0")
                else:
                    vals.append(repr(float(v)))
            fh.write((",".join(vals) + "\n").encode())

    _atomic_write(path, writer)


def write_plot(path: Path, data: dict[str, np.ndarray], title: str, force_unit: str = "N") -> None:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    ax1.plot(data["tangential_displacement"], data["tangential_force"], "-", lw=1.2)
    ax1.set_xlabel("tangential displacement [m]")
    ax1.set_ylabel(f"tangential force [{force_unit}]")
    ax1.set_title("tangential force-displacement")
    ax1.grid(True, alpha=0.3)
    ax2.plot(data["normal_displacement"], data["normal_force"], "-", lw=1.2, color="C1", marker=".", ms=3)
    ax2.set_xlabel("approach [m]")
    ax2.set_ylabel(f"normal force [{force_unit}]")
    ax2.set_title("normal force-approach")
    ax2.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    _atomic_write(path, lambda fh: fig.savefig(fh, format="png", dpi=110))
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    from grainmech.io.config import Section, load_toml

    cfg = load_toml(args.config)
    root = Section(cfg, "")
    params = build_params(root.section("contact"))
    init, segments = build_path(root, params)
    root.finish()
    outdir = Path(args.outdir)
    if outdir.exists() and not outdir.is_dir():
        raise GrainmechError(f"output path exists and is not a directory: {outdir}")
    outdir.mkdir(parents=True, exist_ok=True)
    data = simulate(params, init, segments)
    write_csv(outdir / "contact.csv", data)
    if not args.no_plot:
        write_plot(outdir / "contact.png", data, f"{type(params).__name__} contact", _units(params)[0])
    print(f"wrote {outdir / 'contact.csv'} ({len(data['step'])} rows)"
          + ("" if args.no_plot else f" and {outdir / 'contact.png'}"))
    return 0

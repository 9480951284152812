"""``grainmech run [CONFIG.toml] [-o OUTDIR] [--resume] [--quiet]``: the material-point driver from a config.

Without CONFIG it runs the built-in default (``grainmech/data/default_run.toml``): cyclic
simple shear of an isotropic Hertz-Mindlin/Mindlin-Deresiewicz quartz sand with three
kinematic models (the seed's affine model at seven amplitudes, the shipped 'dense' packing
with every grain in equilibrium at 1e-6 ... 1e-4, and the same grains in LAMMPS at 3e-4 and
1e-3; 117 s on 2 cores, ``docs/performance.md``), and writes CSV tables, a JSON summary and
PNG plots (loops, G/Gmax and damping with Darendeli 2001, Hardin-Drnevich 1972 and Menq
2003 for the same mean stress) to OUTDIR (default ``./grainmech-out/run``). Every finished
amplitude (and a model's finished path) is saved in ``OUTDIR/resume`` the moment it
finishes; ``--resume`` takes them up after an interruption, even a SIGKILL.
"""

from __future__ import annotations

import argparse
import sys
import time
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from grainmech.errors import Terminated
from grainmech.io.config import load_toml, resolve_file_keys
from grainmech.io.outdir import output_folder
from grainmech.io.reports import default_outdir, write_run_outputs
from grainmech.jobs import RunComparison


def register(sub: Any) -> None:
    """Add the ``grainmech run`` sub-command and its options to ``sub`` (argparse sub-parsers)."""
    p = sub.add_parser("run", help="drive a material point along a loading path (default: cyclic simple shear)",
                       description=__doc__.splitlines()[0])
    p.add_argument("config", nargs="?", help="TOML config (see examples/run_*.toml)")
    p.add_argument("-o", "--outdir", default=default_outdir("run"), help="output folder (default ./%(default)s)")
    p.add_argument("--resume", action="store_true",
                   help="continue the interrupted or killed run in OUTDIR: every amplitude it finished (and a "
                        "model's finished path) is taken up, the rest run; the config must be the same (a changed "
                        "key is refused, naming it). A path test's unfinished path goes on from the last of its "
                        "segments that finished")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=main)


class _Progress:
    """The progress callback of the run: lines on stderr (none with ``--quiet``).

    It also keeps the outcome of the amplitudes each model has finished so far
    (``amplitudes_done``, called by :mod:`grainmech.jobs`), which is written if the run
    is interrupted.
    """

    def __init__(self, quiet: bool, header: str) -> None:
        self.quiet, self.header = quiet, header
        self.finished: dict[str, Any] = {}
        self.handed: tuple | None = None
        self.t0 = time.perf_counter()  # the run's real elapsed time, for an interrupted run's message

    def __call__(self, msg: str) -> None:
        if self.quiet:
            return
        if self.header:  # said with the first progress line: a bad config stops before, with one line
            print(self.header, file=sys.stderr, flush=True)
            self.header = ""
        print(msg, file=sys.stderr, flush=True)

    def amplitudes_done(self, outcome: Any) -> None:
        self.finished[outcome.method] = outcome

    def handed_over(self, amplitudes: Any, why: str) -> None:
        self.handed = (list(amplitudes), why)

    def reused(self, model: str, amplitudes: list[float] | None) -> None:
        """Say (also with ``--quiet``) what ``--resume`` took up of ``model``: its amplitudes, or its path (None)."""
        from grainmech.driver.registry import model as registered
        from grainmech.jobs.resume import listed

        title = registered(model).title
        line = (f"reused the finished path of the {title}" if amplitudes is None else
                f"reused {len(amplitudes)} finished amplitude(s) of the {title}: {listed(amplitudes)}")
        if self.quiet:
            print(f"grainmech run: {line}", file=sys.stderr, flush=True)
        else:
            self(f"[{model}] {line}")

    def elapsed(self) -> float:
        """Seconds since the run began."""
        return time.perf_counter() - self.t0

    def partial(self) -> Any:
        """What the models finished before an interruption (None if nothing)."""
        outs = [o for o in self.finished.values() if len(o.G)]
        if not outs:
            return None
        return outs[0] if len(outs) == 1 else RunComparison(outs)


def _interrupted_message(exc: BaseException, say: _Progress) -> str:
    """"terminated (SIGTERM) after 1200 s; ..." for the summary of an interrupted run.

    The real elapsed time of the run (not the sum of the models' finished amplitudes), and
    per model the amplitudes finished and, where a model had ended before the signal, its
    own message (why it stopped); the amplitudes the packing model handed to the DEM model.
    """
    why = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted (Ctrl-C)"
    parts = []
    for o in say.finished.values():
        ended = not o.message.startswith("interrupted after ")
        parts.append(f"{o.method} model: {len(o.G)} amplitude(s) finished"
                     + (f", {'completed' if o.success else 'stopped'}: {o.message}" if ended else ""))
    if say.handed:
        parts.append(f"handed to the DEM model: {[float(f'{a:.3g}') for a in say.handed[0]]} ({say.handed[1]})")
    return (f"{why} after {say.elapsed():.1f} s; " + "; ".join(parts)
            + "; the amplitudes not finished are not in these files")


def main(args: argparse.Namespace) -> int:
    """Run ``grainmech run`` with the parsed ``args``.

    Results (the Gmax and G/Gmax-damping table, what each model did, the files written)
    go to stdout; progress lines (none with ``--quiet``) and warnings to stderr. On Ctrl-C
    or SIGTERM after some amplitudes have finished, those are written to OUTDIR as a run
    marked ``"interrupted": true`` (``"success": false``) before the interruption goes on
    to :func:`grainmech.cli.main` (one line, status 130 or 143).

    Returns
    -------
    int
        Exit status: 0 on success; input errors raise :class:`~grainmech.errors.GrainmechError`,
        which :func:`grainmech.cli.main` turns into one line and status 2.
    """
    # imported on use: keeps `grainmech --help` start-up light
    from grainmech.jobs import CyclicOutcome, RunComparison, compute_run, packing_gmax_line
    from grainmech.jobs.resume import run_records

    def show(msg: str) -> None:
        print(msg, flush=True)

    def warn(msg: str) -> None:
        print(f"grainmech: warning: {msg}", file=sys.stderr, flush=True)

    if args.config:

        cfg = resolve_file_keys(load_toml(args.config), Path(args.config).parent)
        source = args.config
    else:
        cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
        source = "built-in default (cyclic simple shear, isotropic quartz sand, 100 kPa)"
    say = _Progress(args.quiet, f"grainmech run: {source}")
    with output_folder(args.outdir, "run") as folder:  # checked and locked before the work
        records = run_records(folder.path, cfg, args.resume)  # finished amplitudes, saved as they finish
        try:
            out = compute_run(cfg, progress=say, records=records)
        except KeyboardInterrupt as exc:
            partial = say.partial()
            if partial is None:
                raise  # nothing finished: OUTDIR is left as it was
            why = _interrupted_message(exc, say)
            summary = write_run_outputs(partial, folder.staging, cfg, source, interrupted=why,
                                        seconds=say.elapsed())
            folder.commit(success=False)
            n = sum(len(o.G) for o in (partial.outcomes if isinstance(partial, RunComparison) else [partial]))
            raise type(exc)(f"the {n} finished amplitude(s) are in {args.outdir} "
                            "(summary.json: \"interrupted\": true)") from None
        for w in out.warnings:
            warn(w)
        summary = write_run_outputs(out, folder.staging, cfg, source)
        folder.commit(success=out.success)
    outs = list(out.outcomes) if isinstance(out, RunComparison) else [out]
    for o in outs:
        m = summary["models"][o.method] if "models" in summary else summary
        if len(outs) > 1:
            show(f"{o.method} model ({'completed' if o.success else 'STOPPED: ' + o.message}):")
        det = o.details
        if det and "grains" in det and o.model.engine:
            show(f"  {det['packing']}: {det['grains']} grains in {o.model.engine}, void ratio {det['void_ratio']:.3f}; "
                 f"largest unbalanced force ratio {det.get('max_unbalanced', float('nan')):.2g}")
            for n in det.get("notes", []):
                show(f"  note: {n}")
        elif det and "grains" in det:
            show(f"  {det['packing']}: {det['grains']} grains ({det['rattlers']} rattlers), void ratio "
                  f"{det['void_ratio']:.3f}; largest out-of-balance force ratio "
                  f"{det.get('max_residual', float('nan')):.2g}")
        if det and "amplitudes_note" in det:
            show(f"  {det['amplitudes_note']}")
        if isinstance(o, CyclicOutcome) and len(o.G):
            show(f"  Gmax = {o.G_max:.4g} Pa")
            emp = o.empirical_G_max
            if emp:
                show(f"  Hardin-Richart (1963): {emp['G_round_Pa']:.4g} Pa round grains, "
                     f"{emp['G_angular_Pa']:.4g} Pa angular grains")
                show(("  WARNING: " if emp["flag"] else "  ") + emp["note"])
            pg = (det or {}).get("packing_gmax")
            if pg:
                show(packing_gmax_line(pg, o.G_max))
            beyond, quality = o.beyond_envelope, o.loop_quality
            moved = (det or {}).get("rearranging", [])
            for i, (a, g, dd, c) in enumerate(zip(o.amplitudes, o.G_ratio, o.damping, o.mean_stress_change)):
                marks = []
                if i < len(beyond) and beyond[i]:
                    r = o.envelope[i]["max_ratio"]
                    marks.append("BEYOND ENVELOPE (sigma1/sigma3 "
                                 + (f"{r:.3g}" if r < float("inf") else "unbounded") + ")")
                if i < len(moved) and moved[i]:
                    marks.append("GRAINS REARRANGE (fixed geometry left: see warnings)")
                if i < len(quality) and not quality[i].ok:
                    marks.append("WARNING: loop not closed/symmetric")
                show(f"  amplitude {a:9.2e}   G/Gmax {g:6.3f}   damping {100 * dd:6.2f} %"
                     f"   change of p {100 * c:+6.1f} %" + "".join(f"   {k}" for k in marks))
            if "menq_G_over_Gmax" in m:
                show("  Menq (2003) at these amplitudes: G/Gmax "
                     + " ".join(f"{v:.3f}" for v in m["menq_G_over_Gmax"]) + "; damping "
                     + " ".join(f"{100 * v:.2f}" for v in m["menq_damping"]) + " %")
            if beyond.any():
                env = m["envelope"]
                show(f"  envelope of sands: Mohr-Coulomb phi = {env['friction_angle_deg']:g} deg (sigma1/sigma3 <= "
                     f"{env['limit_sigma1_over_sigma3']:.2f}); {env['note']}")
        elif not isinstance(o, CyclicOutcome) and o.results:
            r = o.results[0]
            last = " ".join(f"{v:.5g}" for v in r.stress[-1])
            show(f"  path: {len(r.stress) - 1} steps ({'completed' if o.success else 'stopped'}); "
                 f"final stress [Pa] (xx yy zz yz xz xy) {last}")
            sg = m.get("strength")
            if sg:
                show(f"  peak friction angle {sg['peak_friction_angle_deg']:.1f} deg (q/p {sg['peak_q_over_p']:.3f} at "
                     f"axial strain {sg['peak_axial_strain']:.3g}); end of path "
                     f"{sg['critical_friction_angle_deg']:.1f} deg (q/p {sg['critical_q_over_p']:.3f}); {sg['note']}")
        env = m.get("envelope")
        if env and env.get("first_step_beyond") is not None:  # a path's
            warn(env["note"])
    rec = summary.get("recommended_curve")
    if rec:
        show(f"recommended curve (recommended_curve.csv): Gmax = {rec['G_max_Pa']:.4g} Pa, {rec['G_max_reason']}")
        for a, r, dd, mod, fl in zip(rec["amplitudes"], rec["G_over_Gmax"], rec["damping"], rec["models"],
                                     rec["flags"]):
            tags = "".join(f"   {k.upper().replace('_', ' ')}" for k in fl)
            show(f"  amplitude {a:9.2e}   G/Gmax {r:6.3f}   damping {100 * dd:6.2f} %   {mod:7s}{tags}")
        for c in rec["choices"]:
            show(f"  at {c}")
        if rec.get("reference"):
            show(f"  affine model: {rec['reference']['note']}")
    if "menq_gamma_r" in summary:
        show(f"references at p = {summary['initial_pressure_Pa']:.6g} Pa (modulus_reduction.png): Darendeli (2001) "
             f"gamma_r = {summary['darendeli_gamma_r']:.3g}; Hardin-Drnevich (1972) gamma_r = "
             f"{summary['hardin_drnevich_gamma_r']:.3g}; Menq (2003) gamma_r = {summary['menq_gamma_r']:.3g}, "
             f"D_min = {100 * summary['menq_d_min']:.2f} % for Cu = {summary['menq_uniformity_coefficient']:.3g}, "
             f"D50 = {1e3 * summary['menq_d50_m']:.3g} mm ({summary['menq_grading_source']})")
    show(f"wrote {len(summary['files'])} files to {args.outdir}")
    if not out.success:
        print(f"grainmech: error: {out.message} (results so far are in {args.outdir})", file=sys.stderr)
        return 1
    return 0

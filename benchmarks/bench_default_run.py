"""Benchmark of the main job: the built-in default ``grainmech run`` (never asserted in tests).

Two measurements:

* ``--cold`` (default on): the first ``grainmech run`` after installing, i.e. with an
  empty numba cache, and the run after it (kernels loaded from the cache). Each is a
  fresh ``python -m grainmech run --quiet`` process in an empty working directory, with
  ``NUMBA_CACHE_DIR`` pointing at a new temporary directory, so the cache of the source
  tree is neither used nor touched. Reports the wall time of each and the numba
  compilations of the cold run (function, signature, seconds; from numba's compile
  events), and both times as multiples of an OpenBLAS dgemm (n = 2048) timed in this
  process (the ratio holds across machines, the seconds do not).
* ``--in-process``: :func:`grainmech.jobs.compute_run` twice in this process (the first
  loads or compiles the kernels), per kinematic model the time of its cyclic runs, the
  number of steps.

Target (issue on fast hot paths): the cold run <= 10 s on 2 cores, later runs ~3 s.

Run: ``python benchmarks/bench_default_run.py [--repeat 1] [--in-process]``
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from importlib import resources

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

# run in the child process: time the CLI and list numba's compilations (outermost first)
_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
comp = []
try:
    from numba.core import event

    class _L(event.Listener):
        stack = []

        def on_start(self, ev):
            self.stack.append(time.perf_counter())

        def on_end(self, ev):
            t = time.perf_counter() - self.stack.pop()
            d = ev.data
            f = getattr(d.get("dispatcher"), "py_func", None)
            name = f"{f.__module__}.{f.__qualname__}" if f is not None else "?"
            comp.append((len(self.stack), name, str(d.get("args"))[:120], t))

    event.register("numba:compile", _L())
except ImportError:
    pass
import grainmech
from grainmech.cli import main
rc = main(["run", "--quiet"])
print(json.dumps({"rc": rc, "wall": time.perf_counter() - t0, "compiles": comp, "package": grainmech.__file__}))
"""


def _cli_run(cache_dir: str) -> tuple[float, dict]:
    """Wall time [s] of one ``grainmech run`` process (interpreter start included) and its report."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    # the child runs in an empty directory: a relative PYTHONPATH (``PYTHONPATH=src``)
    # would silently import the installed package instead of this source tree
    if env.get("PYTHONPATH"):
        env["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p) for p in env["PYTHONPATH"].split(os.pathsep) if p)
    with tempfile.TemporaryDirectory() as cwd:
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", _CHILD], cwd=cwd, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"grainmech run failed:\n{p.stderr[-2000:]}")
    return wall, json.loads(p.stdout.strip().splitlines()[-1])


def cold(repeat: int) -> None:
    """Cold (empty numba cache) and warm ``grainmech run`` in fresh processes."""
    from _yardstick import dgemm_seconds

    t_dgemm = dgemm_seconds()
    print(f"{datetime.date.today()}: yardstick: OpenBLAS dgemm n=2048 {t_dgemm:.3f} s (best of 3)")
    colds, warms = [], []
    report: dict = {}
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as cache:
            t_cold, report = _cli_run(cache)
            t_warm, _ = _cli_run(cache)
        colds.append(t_cold)
        warms.append(t_warm)
    t_dgemm = min(t_dgemm, dgemm_seconds())
    for label, ts in (("first run (empty numba cache)", colds), ("later run (cache loaded)", warms)):
        print(f"{label}: {min(ts):.2f} s = {min(ts) / t_dgemm:.0f} dgemm (best of {repeat}; all: "
              + ", ".join(f"{t:.2f}" for t in ts) + ")")
    print(f"package run: {report.get('package')}")
    top = [c for c in report["compiles"] if c[0] == 0]
    print(f"compilations of the first run: {len(top)} outermost, {sum(c[3] for c in top):.1f} s")
    for depth, name, args, t in report["compiles"]:
        if depth <= 1 and t >= 0.05:
            print(f"  {'  ' * depth}{t:6.2f} s  {name} {args[:80]}")


def in_process() -> None:
    """The default run twice in this process (compile or load, then the cached kernels)."""
    from grainmech.jobs import RunComparison, compute_run

    cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
    for label in ("first run (compiles or loads the kernels)", "later run"):
        t0 = time.perf_counter()
        out = compute_run(cfg)
        wall = time.perf_counter() - t0
        outs = out.outcomes if isinstance(out, RunComparison) else [out]
        print(f"{label}: {wall:.1f} s wall, success {out.success}")
        for o in outs:
            steps = sum(len(r.stress) - 1 for r in o.results)
            prep = o.details.get("prepare_seconds")
            print(f"  {o.method:8s} {o.seconds:6.1f} s cyclic runs ({steps} steps"
                  + (f"; preparation {prep:.1f} s" if prep is not None else "") + f"), Gmax {o.G_max:.4g} Pa")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1, help="cold/warm pairs (the best is reported)")
    ap.add_argument("--in-process", action="store_true", help="also time compute_run twice in this process")
    ap.add_argument("--no-cold", action="store_true", help="skip the fresh-process cold/warm runs")
    a = ap.parse_args()
    if not a.no_cold:
        cold(a.repeat)
    if a.in_process:
        in_process()


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    main()

"""The DEM model on several MPI ranks: one path as an ``mpiexec -n N`` job.

With ``DemSettings(ranks=N)``, N > 1, a DEM path (one amplitude of a series, or a
``kind = "path"`` test) does not run in the calling process: :func:`run_dem_ranks` writes
the packing, the law, the path and the settings to a temporary folder and starts
``mpiexec -n N python -m grainmech.driver.dem._rank IN OUT``. Every rank runs
:func:`grainmech.driver.dem.run_dem` on the same inputs; LAMMPS splits the cell into N
sub-domains (its own domain decomposition), and the network each check needs is gathered
on every rank (:meth:`grainmech.lammps.engine.Lammps.atom_all`), so all ranks take the
same decisions. Rank 0 sends progress lines (JSON) on its standard output and writes the
result; the caller reads both. The result is the same as on one rank up to the order of
floating-point sums (G within 1 % on 'dense', ``docs/models/dem.md``).

The launcher is the ``mpiexec`` next to the Python interpreter (the ``mpich`` wheel of
``grainmech[dem]`` installs it there) or the first on ``PATH``. Each rank runs LAMMPS on
one thread (``OMP_NUM_THREADS=1``). When the caller is interrupted or terminated, the
whole job (launcher and ranks, one process group) is killed; when the caller dies without
cleaning up (killed, out of memory), the launcher gets SIGTERM from the kernel
(``prctl(PR_SET_PDEATHSIG)``, Linux) and ends its ranks.

A rank that dies (killed, out of memory, crashed) ends the job: the launcher ends the
other ranks, and :func:`run_dem_ranks` raises :class:`JobDied` naming the cause (the
signal or exit code the launcher reports); :func:`grainmech.driver.dem.run_dem` turns it
into a failed result, so that in a series only that amplitude fails. Whatever is left of
the job's process group after the launcher ended is killed.

Starting grainmech itself with ``mpiexec`` is not the way to use several ranks (every
rank would run every model and write the output folder): ``grainmech run`` refuses it and
names ``[model.dem] ranks``.
"""

from __future__ import annotations

import ctypes
import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from grainmech.errors import GrainmechError

if TYPE_CHECKING:  # the DEM model imports this module; these are for the annotations only
    from grainmech.driver.dem.run import DemResult
    from grainmech.driver.dem.settings import DemSettings
    from grainmech.driver.paths import LoadPath
    from grainmech.network import ContactNetwork

#: progress callback of a relaxation: ``(LAMMPS time steps so far, unbalanced force ratio)``
Tick = Callable[[int, float], None]

try:  # prctl, for the launcher to end with its parent
    _LIBC: Any = ctypes.CDLL(None, use_errno=True)
except OSError:  # pragma: no cover - no C library to ask
    _LIBC = None

__all__ = ["run_dem_ranks", "mpiexec", "JobDied", "signal_text"]


class JobDied(GrainmechError):
    """A DEM job on several MPI ranks ended without a result (a rank killed, out of memory, crashed)."""


def signal_text(signum: int) -> str:
    """``"signal 9 (SIGKILL: the system's out-of-memory killer, or a user)"``: a process's death, in words."""
    try:
        name = signal.Signals(signum).name
    except ValueError:
        name = "unknown"
    if signum == signal.SIGKILL:
        name += ": the system's out-of-memory killer, or a user"
    return f"signal {signum} ({name})"


def mpiexec() -> str:
    """Path of the MPI launcher: ``mpiexec`` beside the interpreter, else on ``PATH``.

    Raises
    ------
    GrainmechError
        When there is none (the ``mpich`` wheel of ``grainmech[dem]`` installs one).
    """
    here = Path(sys.executable).parent
    for name in ("mpiexec", "mpirun"):
        if (here / name).exists():
            return str(here / name)
    for name in ("mpiexec", "mpirun"):
        found = shutil.which(name)
        if found:
            return found
    raise GrainmechError("[model.dem] ranks > 1 needs an MPI launcher (mpiexec); pip install 'grainmech[dem]' "
                         "installs MPICH's")


def _kill(proc: subprocess.Popen) -> None:
    """Kill the launcher and its ranks (their own process group)."""
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()


def _follow(proc: subprocess.Popen, on_step: Callable[[int, int], None] | None, tick: Tick | None,
            saved: Callable[[int, dict], None] | None = None) -> list[str]:
    """Pass rank 0's progress lines (saved states to ``saved``) on until the job ends; return the launcher's lines.

    When the launcher has ended, what is left of its process group (a rank it did not end)
    is killed before the launcher is reaped (so that the group's id cannot have been reused).
    """
    assert proc.stdout is not None
    other: list[str] = []
    for line in proc.stdout:
        try:
            msg = json.loads(line)
        except ValueError:
            other = (other + [line.strip()])[-40:]
            continue
        if not isinstance(msg, dict):
            continue
        if "step" in msg and on_step is not None:
            on_step(int(msg["step"][0]), int(msg["step"][1]))
        elif "saved" in msg and saved is not None:
            f = Path(msg["saved"][1])
            saved(int(msg["saved"][0]), pickle.loads(f.read_bytes()))
            f.unlink()
        elif "tick" in msg and tick is not None:
            ub = msg["tick"][1]
            tick(int(msg["tick"][0]), float("nan") if ub is None else float(ub))
    if hasattr(os, "waitid"):
        os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOWAIT)  # ended, not reaped: its group id is ours
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    proc.wait()
    return other


def _why_ended(ranks: int, code: int | None, launcher: list[str], err: str) -> str:
    """The message of a job that ended with no result: the rank's signal or exit code as the launcher reports it."""
    text = "\n".join(launcher)
    who = "a rank"  # (the pid MPICH reports is not always the one that died)
    sig = re.search(r"EXIT STRING:.*\(signal (\d+)\)", text)
    exit_code = re.search(r"EXIT CODE: (\d+)", text)
    if sig:
        cause = f"{who} was killed by {signal_text(int(sig.group(1)))}"
    elif exit_code:
        cause = f"{who} ended with exit code {exit_code.group(1)}"
    elif code is not None and code < 0:
        cause = f"the launcher was killed by {signal_text(-code)}"
    else:
        cause = f"the launcher ended with exit code {code}"
    tail = " ".join(err.split()[-60:])
    return (f"the DEM job on {ranks} MPI ranks ended with no result: {cause}"
            + (f"; its error output ends: {tail}" if tail else ""))


def _die_with_parent() -> None:
    """In the launcher's process, before it starts: SIGTERM when its parent dies (Linux ``PR_SET_PDEATHSIG``)."""
    try:
        _LIBC.prctl(1, int(signal.SIGTERM))
    except AttributeError:  # pragma: no cover - not Linux
        pass



def run_dem_ranks(net: ContactNetwork, law: Any, path: LoadPath, settings: DemSettings, *,
                  pressure: float | None = None, on_step: Callable[[int, int], None] | None = None,
                  tick: Tick | None = None, rolling: Any = None, checkpoint: Any = None) -> DemResult:
    """:func:`grainmech.driver.dem.run_dem` as an ``mpiexec -n settings.ranks`` job (module notes).

    ``checkpoint`` (:class:`~grainmech.driver.loop.PathCheckpoint`): the ranks save the path
    at its steps (rank 0 writes each state, this process passes it to ``checkpoint.save``)
    and go on from ``checkpoint.resume``.

    Raises
    ------
    GrainmechError
        What the ranks raised (a packing LAMMPS cannot start from, ...).
    JobDied
        The job ended without a result (a rank killed or crashed): the signal or exit code
        the launcher reports and the end of the ranks' error output.
    """
    launcher = mpiexec()
    with tempfile.TemporaryDirectory(prefix="grainmech-dem-") as tmp:
        src, out, err = Path(tmp) / "in.pkl", Path(tmp) / "out.pkl", Path(tmp) / "stderr.txt"
        after = tuple(checkpoint.after) if checkpoint is not None and checkpoint.save is not None else ()
        src.write_bytes(pickle.dumps((net, law, path, settings, pressure, rolling, after,
                                      checkpoint.resume if checkpoint is not None else None)))
        saved = None if not after else checkpoint.save
        cmd = [launcher, "-n", str(settings.ranks), sys.executable, "-m", "grainmech.driver.dem._rank",
               str(src), str(out)]
        env = dict(os.environ, OMP_NUM_THREADS="1")
        with open(err, "w") as errfh:
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=errfh, text=True, env=env,
                                    start_new_session=True, preexec_fn=_die_with_parent if _LIBC else None)
        old = None
        if threading.current_thread() is threading.main_thread():
            def on_term(signum: int, frame: Any) -> None:
                _kill(proc)
                raise SystemExit(128 + signum)
            old = signal.signal(signal.SIGTERM, on_term)
        reports: list[str] = []
        try:
            reports = _follow(proc, on_step, tick, saved)
        finally:
            _kill(proc)
            if old is not None:
                signal.signal(signal.SIGTERM, old)
        if not out.exists():
            raise JobDied(_why_ended(settings.ranks, proc.returncode, reports, err.read_text(errors="replace")))
        kind, value = pickle.loads(out.read_bytes())
    if kind == "error":
        raise GrainmechError(value)
    return value

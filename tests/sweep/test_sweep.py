"""SweepParameter sweeps on dask (grainmech.sweep, grainmech.parallel, `grainmech sweep`)."""

from __future__ import annotations

import copy
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from grainmech.errors import ConfigError, GrainmechError

pytest.importorskip("distributed")

from grainmech import parallel  # noqa: E402
from grainmech.sweep import load_sweep, run_sweep, sweep_from_dict  # noqa: E402
from grainmech.sweep.design import SweepParameter, latin_hypercube, lhs_unit, monte_carlo  # noqa: E402

BASE = {
    "microstructure": {"void_ratio": 0.62, "coordination": "yanagisawa", "radius": "0.2 mm"},
    "fabric": {"dim": 3, "a20": 0.4},
    "contacts": {"law": "hertz-mindlin", "shear_modulus": "44 GPa", "poisson": 0.08},
    "stress": {"pressure": "200 kPa"},
}


def stiffness_sweep(params=None, **sweep):
    return {"sweep": {"kind": "stiffness", **sweep}, "base": copy.deepcopy(BASE),
            "parameters": params or {"microstructure.void_ratio": {"values": [0.55, 0.65, 0.75]},
                                     "stress.pressure": {"min": "50 kPa", "max": "400 kPa", "num": 3,
                                                         "scale": "log"}}}


@pytest.fixture(scope="module")
def client():
    with parallel.open_client() as c:
        yield c


def read_table(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# ------------------------------------------------------------------------------- parallel
def _square(x):
    if x == 3:
        raise ValueError("three is bad")
    return x * x


def test_map_completed_yields_every_item_and_exceptions(client):
    got = sorted(parallel.map_completed(_square, range(6), client=client), key=lambda t: t[0])
    assert [i for i, _, _ in got] == list(range(6))
    assert [ok for _, _, ok in got] == [True, True, True, False, True, True]
    assert isinstance(got[3][1], ValueError) and "three" in str(got[3][1])
    assert got[5][1] == 25


def test_open_client_errors(monkeypatch):
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 0.5)
    with pytest.raises(GrainmechError, match="cannot connect"):
        with parallel.open_client("tcp://127.0.0.1:9"):
            pass
    with pytest.raises(GrainmechError, match="workers = 0"):
        with parallel.open_client(workers=0):
            pass
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(GrainmechError, match=r'pip install "grainmech\[parallel\]"'):
        with parallel.open_client():
            pass


def test_import_does_not_need_dask():
    code = ("import sys, grainmech, grainmech.sweep, grainmech.jobs, grainmech.parallel; "
            "from grainmech.cli import build_parser; build_parser(); "
            "assert 'distributed' not in sys.modules and 'dask' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


# --------------------------------------------------------------------------------- design
def test_grid_order_units_and_columns():
    sw = sweep_from_dict(stiffness_sweep())
    assert [p.column for p in sw.parameters] == ["microstructure.void_ratio", "stress.pressure [Pa]"]
    vals = [pt.values for pt in sw.points]
    assert len(vals) == 9 and vals[0] == (0.55, 50e3) and vals[1][1] == pytest.approx(np.sqrt(50e3 * 400e3))
    assert vals[-1] == (0.75, 400e3)
    assert [pt.index for pt in sw.points] == list(range(9))
    assert len({pt.id for pt in sw.points}) == 9
    # the id is a stable function of kind + resolved config
    assert [pt.id for pt in sweep_from_dict(stiffness_sweep()).points] == [pt.id for pt in sw.points]
    assert sw.points[4].config["stress"]["pressure"] == pytest.approx(np.sqrt(50e3 * 400e3))
    assert sw.points[4].config["microstructure"]["void_ratio"] == 0.65
    assert BASE["stress"]["pressure"] == "200 kPa"  # base not modified


def test_angles_become_radians():
    sw = sweep_from_dict({"sweep": {"kind": "run", "design": "monte-carlo", "samples": 4},
                          "base": {}, "parameters": {"contacts.friction_angle": {"min": "20 deg", "max": "30 deg"}}},
                         check=False)
    assert sw.parameters[0].column == "contacts.friction_angle [rad]"
    assert all(np.radians(20) <= pt.values[0] <= np.radians(30) for pt in sw.points)


@pytest.mark.parametrize("n", [1, 7, 50])
def test_lhs_stratified_bounded_reproducible(n):
    params = [SweepParameter("a", lo=2.0, hi=5.0), SweepParameter("b", lo=1e3, hi=1e6, scale="log"),
              SweepParameter("c", values=("x", "y"))]
    pts = latin_hypercube(params, n, seed=11)
    a = np.array([p[0] for p in pts])
    b = np.array([p[1] for p in pts])
    assert np.all((a >= 2) & (a <= 5)) and np.all((b >= 1e3) & (b <= 1e6))
    # one sample in each of the n equal strata, per parameter (log space for a log scale)
    for u in ((a - 2) / 3, np.log(b / 1e3) / np.log(1e3)):
        assert sorted(np.floor(u * n).astype(int)) == list(range(n))
    assert lhs_unit(n, 3, 11).shape == (n, 3)
    assert latin_hypercube(params, n, seed=11) == pts
    if n > 1:
        assert latin_hypercube(params, n, seed=12) != pts
        assert {p[2] for p in pts} <= {"x", "y"}


def test_monte_carlo_bounded_reproducible():
    params = [SweepParameter("a", lo=-1.0, hi=1.0), SweepParameter("b", lo=1.0, hi=100.0, scale="log")]
    pts = monte_carlo(params, 200, seed=3)
    a = np.array([p[0] for p in pts])
    b = np.array([p[1] for p in pts])
    assert np.all(np.abs(a) <= 1) and np.all((b >= 1) & (b <= 100))
    assert np.mean(b < 10) == pytest.approx(0.5, abs=0.12)  # log-uniform: half below the geometric mid
    assert monte_carlo(params, 200, seed=3) == pts and monte_carlo(params, 200, seed=4) != pts
    sw = sweep_from_dict(stiffness_sweep({"microstructure.void_ratio": {"min": 0.55, "max": 0.8}},
                                         design="monte-carlo", samples=5, seed=9))
    again = sweep_from_dict(stiffness_sweep({"microstructure.void_ratio": {"min": 0.55, "max": 0.8}},
                                            design="monte-carlo", samples=5, seed=9))
    assert [p.id for p in sw.points] == [p.id for p in again.points]


# ------------------------------------------------------------------------- running sweeps
def test_grid_stiffness_table_equals_library(tmp_path, client):
    from grainmech.contact import HertzMindlin
    from grainmech.elasticity import bulk_modulus, engineering_constants, shear_modulus
    from grainmech.fabric import SphericalDensity, coordination_number
    from grainmech.material import Packing, packing_stiffness

    sw = sweep_from_dict(stiffness_sweep())
    s = run_sweep(sw, tmp_path, client=client, plots=False)
    assert (s["n_points"], s["succeeded"], s["failed"], s["reused"]) == (9, 9, 0, 0)
    rows = read_table(tmp_path / "sweep.csv")
    assert [r["index"] for r in rows] == [str(i) for i in range(9)]
    assert all(r["status"] == "ok" and r["error"] == "" for r in rows)
    dens = SphericalDensity.from_seed(a20=0.4)
    for r in rows:
        e, p = float(r["microstructure.void_ratio"]), float(r["stress.pressure [Pa]"])
        pk = Packing.from_grains(dens, void_ratio=e, coordination=float(coordination_number(e, "yanagisawa")),
                                 radius=0.2e-3)
        C = packing_stiffness(pk, HertzMindlin.for_equal_spheres(44e9, 0.08, 0.2e-3), p).C
        assert float(r["K_hill [Pa]"]) == pytest.approx(bulk_modulus(C, "hill"), rel=1e-12)
        assert float(r["G_hill [Pa]"]) == pytest.approx(shear_modulus(C, "hill"), rel=1e-12)
        assert float(r["E_zz [Pa]"]) == pytest.approx(engineering_constants(C).E_zz, rel=1e-12)
        assert float(r["C33 [Pa]"]) == pytest.approx(C[2, 2], rel=1e-12)
        assert r["symmetry"] == "transversely isotropic"
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["succeeded"] == 9 and len(list((tmp_path / "points").glob("*.json"))) == 9


class Killed(Exception):
    pass


def test_kill_and_resume_gives_identical_table(tmp_path, client):
    sw = sweep_from_dict(stiffness_sweep())
    full = tmp_path / "full"
    run_sweep(sw, full, client=client, plots=False)
    ref = (full / "sweep.csv").read_bytes()

    out = tmp_path / "killed"
    seen = []

    def die(rec):
        seen.append(rec["point_id"])
        if len(seen) == 4:
            raise Killed

    with pytest.raises(Killed):
        run_sweep(sw, out, client=client, plots=False, on_record=die)
    assert len(list((out / "points").glob("*.json"))) == 4
    assert not (out / "sweep.csv").exists()
    s = run_sweep(sw, out, client=client, plots=False)
    assert (s["reused"], s["ran"], s["succeeded"]) == (4, 5, 9)
    assert (out / "sweep.csv").read_bytes() == ref
    # lose two point files (and leave a stray temp file): only those two run again
    for p in sorted((out / "points").glob("*.json"))[:2]:
        p.unlink()
    (out / "points" / ".x.json.tmp").write_text("{partial")
    s = run_sweep(sw, out, client=client, plots=False)
    assert (s["reused"], s["ran"]) == (7, 2)
    assert (out / "sweep.csv").read_bytes() == ref
    rows = read_table(out / "sweep.csv")
    assert len({r["point_id"] for r in rows}) == len(rows) == 9


def test_a_changed_base_config_is_refused_naming_the_key(tmp_path, cli):
    """The finished points are taken up only for the same run kind and base config (and grainmech
    version); another design over the same base reuses the points it shares (a point's id is a
    hash of its whole config)."""
    base = tmp_path / "base.toml"
    base.write_text('[microstructure]\nvoid_ratio = 0.6\ncoordination = 8\nradius = "0.2 mm"\n'
                    '[contacts]\nlaw = "hertz-mindlin"\nshear_modulus = "44 GPa"\npoisson = 0.08\n'
                    '[stress]\npressure = "100 kPa"\n')
    sw = tmp_path / "s.toml"
    sw.write_text('[sweep]\nkind = "stiffness"\nbase = "base.toml"\n'
                  '[parameters."microstructure.void_ratio"]\nvalues = [0.55, 0.65]\n')
    out = tmp_path / "out"
    assert cli("sweep", str(sw), "-o", str(out), "--quiet", "--no-plots").rc == 0
    before = {p.name: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    base.write_text(base.read_text().replace("poisson = 0.08", "poisson = 0.1"))
    res = cli("sweep", str(sw), "-o", str(out), "--quiet", "--no-plots")
    errors = [line for line in res.err.splitlines() if line.startswith("grainmech: error:")]
    assert res.rc == 2 and len(errors) == 1, res.err
    assert errors[0].startswith("grainmech: error: base.contacts.poisson = 0.1: differs from the config of the sweep "
                              "whose points are kept in ") and "(there: 0.08)" in errors[0]
    assert {p.name: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before  # nothing written
    base.write_text(base.read_text().replace("poisson = 0.1", "poisson = 0.08"))
    sw.write_text(sw.read_text().replace("[0.55, 0.65]", "[0.55, 0.6, 0.65]"))
    res = cli("sweep", str(sw), "-o", str(out), "--quiet", "--no-plots")
    assert res.rc == 0 and "3 succeeded, 0 failed, 2 reused" in res.out


def test_two_worker_processes_same_table(tmp_path, client):
    """--workers 2 (process workers: tasks and results are pickled) gives the same table."""
    sw = sweep_from_dict(stiffness_sweep({"microstructure.void_ratio": {"values": [0.6, 0.7]},
                                          "stress.pressure": {"values": ["100 kPa", "300 kPa"]}}))
    run_sweep(sw, tmp_path / "a", client=client, plots=False)
    s = run_sweep(sw, tmp_path / "b", workers=2, plots=False)
    assert s["succeeded"] == 4
    assert (tmp_path / "a" / "sweep.csv").read_bytes() == (tmp_path / "b" / "sweep.csv").read_bytes()


def test_failing_point_recorded_rest_complete_and_retry(tmp_path, client):
    sw = sweep_from_dict(stiffness_sweep({"microstructure.void_ratio": {"values": [0.6, -0.1, 0.7]}}))
    s = run_sweep(sw, tmp_path, client=client, plots=False)
    assert (s["succeeded"], s["failed"], s["failed_points"]) == (2, 1, [1])
    rows = read_table(tmp_path / "sweep.csv")
    assert [r["status"] for r in rows] == ["ok", "failed", "ok"]
    assert "microstructure.void_ratio" in rows[1]["error"] and "-0.1" in rows[1]["error"]
    assert rows[1]["K_hill [Pa]"] == "" and float(rows[2]["K_hill [Pa]"]) > 0
    s = run_sweep(sw, tmp_path, client=client, plots=False)
    assert (s["reused"], s["ran"], s["failed"]) == (3, 0, 1)
    s = run_sweep(sw, tmp_path, client=client, plots=False, retry_failed=True)
    assert (s["reused"], s["ran"], s["failed"]) == (2, 1, 1)


def test_run_kind_sweep(tmp_path, client):
    base = {"microstructure": {"void_ratio": 0.65, "coordination": "chang", "radius": "0.25 mm"},
            "contacts": {"law": "mindlin-deresiewicz", "shear_modulus": "44 GPa", "poisson": 0.08,
                         "friction": 0.5},
            "initial": {"pressure": "100 kPa"},
            "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-5, 1e-4, 1e-3], "n_cycles": 2,
                     "steps_per_cycle": 12},
            "quadrature": {"degree": 5}}
    sw = sweep_from_dict({"sweep": {"kind": "run"}, "base": base,
                          "parameters": {"initial.pressure": {"values": ["50 kPa", "200 kPa"]}}})
    s = run_sweep(sw, tmp_path, client=client)
    assert s["succeeded"] == 2
    rows = read_table(tmp_path / "sweep.csv")
    g = [float(r["G_max [Pa]"]) for r in rows]
    assert 0 < g[0] < g[1]  # stiffer at higher pressure
    for r in rows:
        assert r["success"] == "true"
        ratios = [float(r[f"G/Gmax@{a:g}"]) for a in (1e-5, 1e-4, 1e-3)]
        assert ratios[0] > ratios[1] > ratios[2]
        gr = float(r["gamma_r"])
        assert 1e-4 < gr < 1e-3 and ratios[1] > 0.5 > ratios[2]
        assert float(r["damping@0.001"]) > float(r["damping@1e-05"])
    assert (tmp_path / "summary.png").stat().st_size > 0


def test_dem_kind_sweep(tmp_path, client):
    from grainmech.io.dem import write_liggghts
    from grainmech.network import lattice_network

    net = lattice_network("sc", 3, 1.0, 2e-3, shear_modulus=29e9, poisson=0.15)
    write_liggghts(net, tmp_path / "c.dump", tmp_path / "p.dump")
    (tmp_path / "sweep.toml").write_text("""
[sweep]
kind = "dem"
[base.network]
contacts = "c.dump"
particles = "p.dump"
[base.material]
poisson = 0.15
[base.relaxed]
solver = "direct"
[parameters."material.shear_modulus"]
values = ["29 GPa", "58 GPa"]
""")
    s = run_sweep(load_sweep(tmp_path / "sweep.toml"), tmp_path / "out", client=client, plots=False)
    assert s["succeeded"] == 2
    rows = read_table(tmp_path / "out" / "sweep.csv")
    assert float(rows[0]["z"]) == pytest.approx(6.0, abs=1.0)
    k = [float(r["K_hill_affine [Pa]"]) for r in rows]
    assert k[1] == pytest.approx(2 * k[0], rel=1e-9)  # Hertz-Mindlin stiffness ~ G at fixed overlap


# ------------------------------------------------------------------------ bad sweep files
@pytest.mark.parametrize("mutate, key", [
    (lambda d: d["sweep"].update(kindd="x"), "sweep.kindd"),
    (lambda d: d["sweep"].update(kind="fem"), "sweep.kind"),
    (lambda d: d.pop("base"), "sweep.base"),
    (lambda d: d["sweep"].update(base="nope.toml"), "sweep.base"),
    (lambda d: d.update(parameters={}), "parameters"),
    (lambda d: d.update(parameters={"microstructure.void_ration": {"values": [0.6]}}), "parameters.microstructure.void_ration"),
    (lambda d: d.update(parameters={"microstructure..x": {"values": [0.6]}}), "parameters.microstructure..x"),
    (lambda d: d["parameters"]["stress.pressure"].pop("num"), 'parameters.stress.pressure.num'),
    (lambda d: d["parameters"]["stress.pressure"].update(min="-5 kPa"), 'parameters.stress.pressure.min'),
    (lambda d: d["parameters"]["stress.pressure"].update(max="3 m"), 'parameters.stress.pressure.max'),
    (lambda d: d["parameters"]["stress.pressure"].update(values=[1]), 'parameters.stress.pressure.min'),
    (lambda d: d["parameters"]["stress.pressure"].update(unit="kPa"), 'parameters.stress.pressure.unit'),
    (lambda d: d["parameters"]["stress.pressure"].update(stepz=2), 'parameters.stress.pressure.stepz'),
    (lambda d: d["parameters"]["microstructure.void_ratio"].update(values=[0.6, 0.6]), 'parameters.microstructure.void_ratio.values'),
    (lambda d: d["sweep"].update(design="latin-hypercube"), "sweep.samples"),
    (lambda d: d["sweep"].update(samples=4), "sweep.samples"),
    (lambda d: d["base"]["contacts"].update(law="hooke"), "contacts.law"),
])
def test_bad_sweep_files_name_the_key(mutate, key):
    d = stiffness_sweep()
    mutate(d)
    with pytest.raises(ConfigError) as info:
        sweep_from_dict(d)
    assert info.value.key == key, str(info.value)


def test_cli_sweep_and_errors(tmp_path, cli):
    base = tmp_path / "base.toml"
    base.write_text('[microstructure]\nvoid_ratio = 0.6\ncoordination = 8\nradius = "0.2 mm"\n'
                    '[contacts]\nlaw = "hertz-mindlin"\nshear_modulus = "44 GPa"\npoisson = 0.08\n'
                    '[stress]\npressure = "100 kPa"\n')
    sw = tmp_path / "s.toml"
    sw.write_text('[sweep]\nkind = "stiffness"\nbase = "base.toml"\ndesign = "latin-hypercube"\n'
                  'samples = 4\nseed = 2\n[parameters."stress.pressure"]\nmin = "50 kPa"\nmax = "1 MPa"\n'
                  'scale = "log"\n')
    out = tmp_path / "out"
    res = cli("sweep", str(sw), "-o", str(out), "--quiet")
    assert res.rc == 0
    assert "4 succeeded, 0 failed, 0 reused" in res.out
    res = cli("sweep", str(sw), "-o", str(out), "--quiet", "--no-plots")
    assert res.rc == 0
    assert "0 failed, 4 reused" in res.out
    # the folder holds the latest run only: its --no-plots run left no stale summary.png
    assert not (out / "summary.png").exists() and (out / "sweep.json").exists()
    sw.write_text(sw.read_text().replace("max =", "maxx ="))
    res = cli("sweep", str(sw), "-o", str(out))
    assert res.rc == 2
    err = res.err.strip()
    assert err.count("\n") == 0 and 'parameters.stress.pressure' in err


def test_indexed_keys_into_arrays_of_tables():
    from pathlib import Path

    from grainmech.io.config import load_toml

    base = load_toml(Path(__file__).resolve().parents[2] / "examples" / "run_triaxial_path.toml")
    sw = sweep_from_dict({"sweep": {"kind": "run"}, "base": base,
                          "parameters": {"test.segments[1].amplitude": {"values": [1e-5, 1e-4]}}})
    assert [p.config["test"]["segments"][1]["amplitude"] for p in sw.points] == [1e-5, 1e-4]
    assert base["test"]["segments"][1]["amplitude"] == 1e-4  # the base is not modified
    for key, err in [("test.segments[5].amplitude", "parameters.test.segments[5].amplitude"),
                     ("test.segments[1].amplitudee", "parameters.test.segments[1].amplitudee"),
                     ("test.kind.x", "parameters.test.kind.x")]:
        with pytest.raises(ConfigError) as info:
            sweep_from_dict({"sweep": {"kind": "run"}, "base": base, "parameters": {key: {"values": [1e-5]}}})
        assert info.value.key == err


def test_cheap_points_run_in_batches_and_a_failure_stays_one_point(tmp_path, client):
    """Stiffness points are sent several to a task (a dask task costs about as much as a
    point); a failing point inside a batch fails alone."""
    from grainmech.sweep.runner import _batches

    assert _batches(1000, "stiffness", 1) == [list(range(k, k + 32)) for k in range(0, 992, 32)] + \
        [list(range(992, 1000))]
    assert _batches(1000, "run", 2) == [[k] for k in range(1000)]
    assert _batches(8, "stiffness", 1) == [[0, 1], [2, 3], [4, 5], [6, 7]]
    values = [0.6, 0.62, 0.64, -0.1, 0.66, 0.68, 0.7, 0.72, 0.74, 0.76, 0.78, 0.8]
    sw = sweep_from_dict(stiffness_sweep({"microstructure.void_ratio": {"values": values}}))
    s = run_sweep(sw, tmp_path, client=client, plots=False)
    assert (s["succeeded"], s["failed"], s["failed_points"]) == (11, 1, [3])
    rows = read_table(tmp_path / "sweep.csv")
    assert "-0.1" in rows[3]["error"] and all(float(r["K_hill [Pa]"]) > 0 for k, r in enumerate(rows) if k != 3)

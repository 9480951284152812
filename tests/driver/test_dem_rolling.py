"""Rolling and twisting resistance in LAMMPS: the DEM model, the network read-back and
``grainmech pack`` (skipped when LAMMPS is not importable).

LAMMPS runs the law of :mod:`grainmech.contact.rolling` as ``rolling sds k_roll gamma_roll
mu_roll`` / ``twisting sds k_twist gamma_twist c_twist`` after ``tangential mindlin``: the
moment on grain ``I`` is ``R* n_IJ x F_r + M_t n_IJ`` (``PairGranular::single`` gives
``F_r`` and ``M_t``, read by ``compute pair/local p5 p6 p7 p9``).
"""

import json

import numpy as np
import pytest

from grainmech.contact import HertzMindlin
from grainmech.contact.rolling import RollingResistance
from grainmech.errors import ConfigError, GrainmechError

engine = pytest.importorskip("grainmech.lammps.engine")
try:
    engine.require_lammps()
except GrainmechError:  # pragma: no cover - depends on the environment
    pytest.skip("LAMMPS is not installed (pip install 'grainmech[dem]')", allow_module_level=True)

from grainmech.lammps.granular import measure_moments, pair_coeff, setup_lammps  # noqa: E402
from grainmech.lammps.network import network_from_lammps, unbalanced_ratio  # noqa: E402
from grainmech.lammps.rolling import rolling_of_network, rolling_pair_suffix  # noqa: E402
from grainmech.network import contact_stiffnesses, relaxed_stiffness  # noqa: E402
from grainmech.packing import QUARTZ, load_packing  # noqa: E402


def _grain_torques(net):
    """Torque on every grain from the network's forces (lever ``R - delta/2``) and moments."""
    n = net.normals
    half = 0.5 * net.overlap
    rA = (net.radii[net.i] - half)[:, None] * n
    rB = -(net.radii[net.j] - half)[:, None] * n
    T = np.zeros((net.n_particles, 3))
    np.add.at(T, net.i, np.cross(rA, -net.force) - net.moment)
    np.add.at(T, net.j, np.cross(rB, net.force) + net.moment)
    return T


def _three_spun_spheres():
    """LAMMPS on three spheres in a row, spun differently, with rolling and twisting: (network, torques)."""
    R, L = 1e-4, 2e-3
    x = np.array([[5e-4, 5e-4, 5e-4], [5e-4 + 2 * R - 4e-7, 5e-4, 5e-4], [5e-4 + 4 * R - 8e-7, 5e-4, 5e-4]])
    rolling = RollingResistance(0.5)
    with engine.Lammps(threads=1) as lmp:
        setup_lammps(lmp, x, np.full(3, R), np.diag([L, L, L]), QUARTZ, 0.5, 1e5)
        net0 = network_from_lammps(lmp)
        consts = rolling_of_network(rolling, QUARTZ, net0)
        suffix = rolling_pair_suffix(consts, R, QUARTZ.density)
        assert " rolling sds " in suffix and " twisting sds " in suffix
        lmp.command(pair_coeff(QUARTZ, 0.5, suffix))
        measure_moments(lmp)
        lmp.commands(["timestep 1e-9", "set atom 1 omega 0.0 2.0 1.0", "set atom 2 omega 3.0 0.0 -1.0",
                      "set atom 3 omega 0.5 -1.0 0.0", "run 20"])
        net = network_from_lammps(lmp)
        torque = lmp.atom("torque")[np.argsort(lmp.atom("id"))]
    return net, torque


def test_lammps_runs_rolling_and_the_moments_read_back_are_its_torques():
    """Three spheres in a row, spun differently: LAMMPS accepts ``rolling sds`` and
    ``twisting sds`` with ``tangential mindlin``, and the network's contact moments (by A
    on B) with its forces give exactly the torques LAMMPS applies to each grain.

    LAMMPS runs in a fresh process: after many other LAMMPS runs in the suite's process
    these 20 time steps now and then ended with non-numeric coordinates (the cause, some
    state those runs leave in the process, is not found); alone it never did."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        net, torque = pool.submit(_three_spun_spheres).result(timeout=300)
    assert net.n_contacts == 2 and net.moment is not None
    M = net.moment
    assert np.abs(M).max() > 0
    # twisting (along x) and rolling (normal to it) both present
    assert np.abs(M[:, 0]).max() > 0 and np.abs(M[:, 1:]).max() > 0
    np.testing.assert_allclose(_grain_torques(net), torque, rtol=0, atol=1e-9 * np.abs(torque).max())


@pytest.fixture(scope="module")
def dense_runs():
    from grainmech.driver import parse_mask
    from grainmech.driver.dem import DemSettings, run_dem
    from grainmech.driver.paths import segment

    net = load_packing("dense")
    law = HertzMindlin(29e9, 0.15, float(np.median(net.radii)), friction=0.5)
    path = segment(parse_mask("EEEEEE"), [0, 0, 0, 0, 0, 2e-6], 2)
    return {k: run_dem(net, law, path, DemSettings(), rolling=r)
            for k, r in (("off", None), ("zero", RollingResistance(0.0)), ("on", RollingResistance(0.1)))}


def test_dem_model_with_rolling(dense_runs):
    """Two steps of simple shear (2e-6) on 'dense': the secant G equals the relaxed tensor's
    C66 with the moment springs (measured 2.378e8 Pa against 2.379e8, without rolling
    1.960e8); every recorded state is an equilibrium counting the contact moments; the
    notes state the constants LAMMPS ran."""
    on, off = dense_runs["on"], dense_runs["off"]
    assert on.success and off.success
    g_on = (on.stress[-1, 5] - on.stress[0, 5]) / 2e-6
    g_off = (off.stress[-1, 5] - off.stress[0, 5]) / 2e-6
    assert g_on == pytest.approx(on.elastic_tangent[5, 5], rel=0.01)
    assert g_off == pytest.approx(off.elastic_tangent[5, 5], rel=0.01)
    assert g_on > 1.15 * g_off
    assert np.max(on.unbalanced) < on.settings["tol"]
    note = [n for n in on.notes if n.startswith("rolling resistance")]
    assert len(note) == 1
    assert "mu_r = 0.1" in note[0] and "k_roll = 8 G* a" in note[0] and "Iwashita & Oda 1998" in note[0]
    assert not any("rolling" in n for n in off.notes)


def test_dem_model_with_zero_rolling_is_the_model_without(dense_runs):
    np.testing.assert_array_equal(dense_runs["zero"].stress, dense_runs["off"].stress)
    assert dense_runs["zero"].notes == dense_runs["off"].notes


def test_dem_start_state_with_rolling_is_in_equilibrium_with_its_moments():
    """The re-settled start state balances forces and moments only with the contact
    moments counted (the rolling springs carry part of the grains' moments)."""
    from grainmech.driver.dem import DemPoint

    net = load_packing("dense")
    law = HertzMindlin(29e9, 0.15, float(np.median(net.radii)), friction=0.5)
    with DemPoint.start(net, law, rolling=RollingResistance(0.1)) as pt:
        st = pt.network
        assert pt.rolling is not None and st.moment is not None
        assert unbalanced_ratio(st) < pt.settings.tol
        no_moments = type(st)(st.ids, st.positions, st.radii, st.box, st.i, st.j, st.force, st.branch, st.overlap)
        assert unbalanced_ratio(no_moments) > unbalanced_ratio(st)
        kn, ks, _ = contact_stiffnesses(st, shear_modulus=29e9, poisson=0.15, source="overlap")
        np.testing.assert_allclose(pt.elastic_tangent, relaxed_stiffness(st, kn, ks, rolling=pt.rolling).C_relaxed)
        assert pt.stored_energy() > 0


def test_run_command_passes_rolling_to_the_dem_model(tmp_path, cli):
    text = """
[contacts]
law = "hertz-mindlin"
shear_modulus = "29 GPa"
poisson = 0.15
friction = 0.5
rolling_friction = 0.1
[initial]
pressure = "100 kPa"
[model]
method = "dem"
packing = "dense"
[test]
kind = "path"
[[test.segments]]
control = "EEEEEE"
change = [0, 0, 0, 0, 0, 1e-6]
steps = 1
"""
    (tmp_path / "c.toml").write_text(text)
    r = cli("run", tmp_path / "c.toml", "-o", tmp_path / "out", "--quiet")
    assert r.rc == 0, r.err
    assert "note: rolling resistance (LAMMPS rolling sds / twisting sds): mu_r = 0.1" in r.out
    assert "inert" not in r.err
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert any(n.startswith("rolling resistance") for n in summary["details"]["notes"])


# ------------------------------------------------------------------------- grainmech pack
def test_pack_config_rolling_keys():
    from grainmech.io.pack_config import build_pack_config

    base = {"grains": {"count": 100, "distribution": "uniform", "radius": "0.15 mm"},
            "preparation": {"stress": "100 kPa"}}
    pc = build_pack_config(base)
    assert pc.material.rolling is None and pc.settings.prep_rolling == 0.0
    cfg = json.loads(json.dumps(base))
    cfg["material"] = {"rolling_friction": 0.2, "twisting_friction": 0.1}
    cfg["preparation"].update(friction=0.5, rolling_friction=0.2)
    pc = build_pack_config(cfg)
    assert pc.material.rolling == RollingResistance(0.2, None, 0.1)
    assert pc.settings.prep_rolling == 0.2
    for table, key, value, match in (
            ("material", "rolling_friction", -1, r"material\.rolling_friction = -1"),
            ("material", "rolling_friction", "2 deg", r"material\.rolling_friction = '2 deg': is a dimensionless"),
            ("preparation", "rolling_friction", "nan", r"preparation\.rolling_friction = 'nan': must be finite"),
            ("material", "rolling_stiffness", 0, r"material\.rolling_stiffness = 0")):
        bad = json.loads(json.dumps(cfg))
        bad[table][key] = value
        with pytest.raises(ConfigError, match=match):
            build_pack_config(bad)


@pytest.mark.slow
def test_loosest_preparation_with_rolling_resistance():
    """120 grains (one thread, deterministic) compressed with the grain friction and the
    grains' rolling friction (0.5 and 0.3): looser than without rolling resistance (measured
    e = 0.792 against 0.672 on these grains), in equilibrium counting the contact moments."""
    from grainmech.jobs.pack import pack_job

    cfg = {"grains": {"count": 120, "distribution": "uniform", "radius": "0.15 mm", "spread": 0.1, "seed": 2},
           "material": {"rolling_friction": 0.3},
           "preparation": {"stress": "100 kPa", "friction": 0.5, "rolling_friction": 0.3, "threads": 1}}
    res = pack_job(cfg)
    s = res.summary
    assert s["void_ratio"] > 0.75
    assert set(s["rolling"]) == {"preparation", "grains"}
    assert s["material"]["rolling_friction"] == 0.3
    assert res.network.moment is not None
    assert unbalanced_ratio(res.network) < 1e-5


def test_pack_config_grain_rolling_key():
    """``[preparation] grain_rolling``: "relaxation" (default) or "after"; anything else, or
    "after" for grains without rolling resistance, is refused naming the key."""
    from grainmech.io.pack_config import build_pack_config

    cfg = {"grains": {"count": 100, "distribution": "uniform", "radius": "0.15 mm"},
           "material": {"rolling_friction": 0.25},
           "preparation": {"stress": "100 kPa", "friction": 0.1}}
    assert build_pack_config(cfg).settings.grain_rolling == "relaxation"
    cfg["preparation"]["grain_rolling"] = "after"
    assert build_pack_config(cfg).settings.grain_rolling == "after"
    bad = json.loads(json.dumps(cfg))
    bad["preparation"]["grain_rolling"] = "later"
    with pytest.raises(ConfigError, match=r"preparation\.grain_rolling = 'later': must be one of"):
        build_pack_config(bad)
    del bad["material"]
    bad["preparation"]["grain_rolling"] = "after"
    with pytest.raises(ConfigError, match=r"preparation\.grain_rolling = 'after': needs \[material\] rolling"):
        build_pack_config(bad)


@pytest.mark.slow
def test_preparation_with_grain_rolling_after():
    """120 grains compressed with low friction, the grains' rolling resistance not in the
    preparation (``grain_rolling = "after"``): no contact moments, in force equilibrium, and
    the summary says the rolling springs start unloaded."""
    from grainmech.jobs.pack import pack_job

    cfg = {"grains": {"count": 120, "distribution": "uniform", "radius": "0.15 mm", "spread": 0.1, "seed": 2},
           "material": {"rolling_friction": 0.25},
           "preparation": {"stress": "100 kPa", "friction": 0.1, "grain_rolling": "after", "threads": 1}}
    res = pack_job(cfg)
    s = res.summary
    assert set(s["rolling"]) == {"grains"} and "start unloaded" in s["rolling"]["grains"]
    assert s["material"]["rolling_friction"] == 0.25
    m = res.network.moment
    assert m is None or not np.any(m)
    assert unbalanced_ratio(res.network) < 1e-5

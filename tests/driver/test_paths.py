"""Path presets and stress control with a nonlinear law, against closed forms.

Isotropic compression of Hertz contacts on an isotropic fabric: every contact sees
d_n = eps |l| (eps the normal strain, l = |l| n), so N ~ alpha^(3/2) (seed Eq. 3.6) gives
p/p0 = (1 + eps |l| / alpha0)^(3/2) exactly.
"""

import numpy as np
import pytest

from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import (
    MaterialPoint,
    constant_mean_stress,
    cycles,
    cyclic_triaxial,
    fig610_path,
    isotropic_compression,
    run,
    segment,
    simple_shear,
    triaxial,
)
from grainmech.fabric import isotropic
from grainmech.material import Packing

PK = Packing.from_grains(isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)
LAW = MindlinDeresiewicz(29e9, 0.15, 1e-3, friction=0.5)
P0 = 1e5


@pytest.fixture(scope="module")
def point():
    return MaterialPoint.isotropic(PK, LAW, P0)


def test_isotropic_compression_hertz_closed_form(point):
    r = run(point, isotropic_compression(3 * P0, 10))
    assert r.success, r.message
    a0 = point.state.approach[0]
    lb = np.linalg.norm(point.contacts.branch[0])
    eps = (4.0 ** (2 / 3) - 1) * a0 / lb
    assert np.allclose(r.strain[-1, :3], eps, rtol=1e-8)
    assert np.allclose(r.strain[-1, 3:], 0, atol=1e-12 * eps)
    p = r.stress[:, 0]
    assert np.allclose(p, P0 * (1 + r.strain[:, 0] * lb / a0) ** 1.5, rtol=1e-8)


def test_triaxial_constant_mean_and_fig610_hold_their_constraints(point):
    r = run(point, triaxial(2e-4, 10))
    assert r.success and np.allclose(r.stress[:, 0], P0) and r.stress[-1, 2] > P0
    r = run(point, triaxial(-2e-5, 5))  # extension
    assert r.success and r.stress[-1, 2] < P0
    r = run(point, constant_mean_stress(0.5 * P0, 10))
    assert r.success and np.allclose(r.stress[:, :3].mean(axis=1), P0, rtol=1e-8)
    r = run(point, fig610_path("reduced-compression", P0, 2.0, 10))
    assert r.success
    assert r.stress[-1, 2] == pytest.approx(P0) and r.stress[-1, 0] == pytest.approx(P0 / 2)


def test_simple_shear_control(point):
    r = run(point, simple_shear(1e-4, 10))
    assert r.success
    assert np.allclose(r.strain[:, [0, 1, 3, 5]], 0) and np.allclose(r.stress[:, 2], P0)
    assert r.strain[-1, 4] == pytest.approx(1e-4, rel=1e-12)


def test_cyclic_triaxial_stress_control_returns_and_dissipates(point):
    r = run(point, cyclic_triaxial(0.3 * P0, 2, 40, control="stress", waveform="sine"))
    assert r.success, r.message
    assert r.stress[-1, 2] == pytest.approx(P0, rel=1e-9)
    assert r.dissipation[-1] > 0
    r = run(point, cyclic_triaxial(1e-4, 1, 40, control="strain"))
    assert r.success and r.strain[-1, 2] == pytest.approx(0.0, abs=1e-18)


def test_running_target_survives_control_switch(point):
    """Switch zz from stress to strain control and back: targets restart from the state."""
    path = segment("EESEEE", [0, 0, 0.2 * P0, 0, 0, 0], 3) + segment("EEEEEE", [0, 0, 1e-5, 0, 0, 0], 2)
    path = path + segment("EESEEE", [0, 0, -0.1 * P0, 0, 0, 0], 2)
    r = run(point, path)
    assert r.success
    assert r.stress[3, 2] == pytest.approx(1.2 * P0, rel=1e-9)
    assert r.strain[5, 2] - r.strain[3, 2] == pytest.approx(1e-5, rel=1e-12)
    assert r.stress[7, 2] == pytest.approx(r.stress[5, 2] - 0.1 * P0, rel=1e-9)


def test_triangle_and_sine_waves_end_at_start():
    for wf in ("triangle", "sine"):
        p = cycles("EEEEEE", np.eye(6)[4], 1e-3, 3, 20, wf)
        assert abs(p.increment[:, 4].sum()) < 1e-18
        assert np.cumsum(p.increment[:, 4]).max() == pytest.approx(1e-3)

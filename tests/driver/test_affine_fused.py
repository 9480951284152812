"""The compiled one-pass integration of fully strain-controlled paths (driver/_fused.py)
agrees with the step-by-step driver (solver.run, compiled=False), which is itself checked
against closed forms in tests/driver/test_affine_linear.py / tests/driver/test_affine_cyclic.py.

Independent reference in each case: the step loop evaluates the kinematic hypothesis
(seed Eq. 2.13) with NumPy matrix products, the Love-Weber stress (Eq. 2.6) with
``love_weber_sum`` and the tangent (Eq. 2.26) with ``assembly.stiffness``; the fused
path re-implements all three in compiled code.
"""

import numpy as np
import pytest

from grainmech.contact import HertzMindlin, LinearSpring, MindlinDeresiewicz
from grainmech.driver import MaterialPoint, cyclic_simple_shear, parse_mask, run, segment
from grainmech.driver.paths import cycles
from grainmech.fabric import SphericalDensity, isotropic
from grainmech.material import Packing

pytest.importorskip("numba")

PK = Packing.from_grains(isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)
PK_TI = Packing.from_grains(SphericalDensity.from_seed(a20=0.3, a22=0.1), void_ratio=0.6, coordination=8, radius=1e-3)
MD = MindlinDeresiewicz(29e9, 0.15, 1e-3, friction=0.5)


def _compare(r1, r2, rtol=1e-10):
    assert r1.success and r2.success
    scale = np.abs(r2.stress).max()
    assert np.abs(r1.stress - r2.stress).max() <= rtol * scale
    assert np.allclose(r1.strain, r2.strain, rtol=0, atol=1e-18)
    for key in ("dissipation", "work", "stored"):
        a, b = getattr(r1, key), getattr(r2, key)
        assert np.abs(a - b).max() <= rtol * max(np.abs(b).max(), 1e-300), key
    # weighted fractions: the same contacts slide / are open (sums in another order)
    assert np.allclose(r1.sliding_fraction, r2.sliding_fraction, rtol=1e-12, atol=1e-15)
    assert np.allclose(r1.open_fraction, r2.open_fraction, rtol=1e-12, atol=1e-15)


def _growing(amplitudes, spc):
    """Cycles of different amplitudes: no loop closes exactly on a step end."""
    path = None
    mask = parse_mask("EEEEEE")
    e = np.zeros(6)
    e[4] = 1.0
    for a in amplitudes:
        p = cycles(mask, e, a, 1, spc)
        path = p if path is None else path + p
    return path


def test_fused_path_is_used_and_matches_step_loop_md():
    pt = MaterialPoint.isotropic(PK, MD, 1e5)
    path = _growing([3e-5, 1e-4, 7e-5, 2.2e-4], 40)
    r1 = run(pt, path)
    r2 = run(pt, path, compiled=False)
    assert np.all(r1.iterations[1:] == 1) and np.all(r1.substeps[1:] == 1)
    _compare(r1, r2)
    # tangent (seed Eq. 2.26 from the laws' kn, ks) away from exact ties
    assert np.abs(r1.tangent - r2.tangent).max() <= 1e-9 * np.abs(r2.tangent).max()
    # final state: same forces and memory
    s1, s2 = r1.final.state, r2.final.state
    assert np.allclose(s1.tangential_force, s2.tangential_force, rtol=0, atol=1e-12 * np.abs(s2.normal_force).max())
    assert np.array_equal(s1.depth, s2.depth)
    # continuing from the fused final state equals continuing from the loop's
    more = cyclic_simple_shear(5e-5, 1, 20, constant="volume")
    _compare(run(r1.final, more, compiled=False), run(r2.final, more, compiled=False))


def test_fused_matches_step_loop_exact_loop_closure():
    """Equal-amplitude cycles close their loops exactly on a step end, where the two
    evaluation orders may take the event or not (documented in contact/_kernel.py); the
    stress and energies still agree to rounding."""
    pt = MaterialPoint.isotropic(PK, MD, 1e5)
    path = cyclic_simple_shear(1e-4, 3, 40, constant="volume")
    _compare(run(pt, path), run(pt, path, compiled=False))


@pytest.mark.parametrize("law", [HertzMindlin(29e9, 0.15, 1e-3, friction=0.3),
                                 LinearSpring(kn=2e6, ks=1e6, friction=0.4)])
def test_fused_other_laws_anisotropic_fabric(law):
    pt = MaterialPoint.isotropic(PK_TI, law, 2e5)
    e = np.array([1e-4, -3e-5, 2e-4, 5e-5, -1e-4, 4e-5])
    path = segment("EEEEEE", e, 15) + segment("EEEEEE", -2 * e, 30)
    r1 = run(pt, path)
    r2 = run(pt, path, compiled=False)
    _compare(r1, r2)
    assert np.abs(r1.tangent - r2.tangent).max() <= 1e-9 * np.abs(r2.tangent).max()
    assert r1.sliding_fraction.max() > 0  # the path does make contacts slide


def test_linear_law_gives_C_eps_through_fused_path():
    """With a linear law and no sliding, sigma - sigma0 = C . eps exactly (seed Eq. 2.26)."""
    law = LinearSpring(kn=2e6, ks=1e6, friction=float("inf"))
    pt = MaterialPoint.isotropic(PK_TI, law, 1e5)
    e = np.array([2e-5, 1e-5, -3e-5, 1e-5, 2e-5, -1e-5])
    r = run(pt, segment("EEEEEE", e, 7))
    assert r.iterations[-1] == 1
    assert np.allclose(r.stress[-1] - r.stress[0], pt.tangent @ e, rtol=1e-10, atol=1e-9)


def test_constant_volume_preset_and_bad_value():
    p = cyclic_simple_shear(1e-4, 1, 8, constant="volume")
    assert not p.stress_control.any()
    assert cyclic_simple_shear(1e-4, 1, 8).stress_control[:, 2].all()
    with pytest.raises(ValueError, match="constant"):
        cyclic_simple_shear(1e-4, 1, 8, constant="pressure")

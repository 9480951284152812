"""The DEM model's continuous protocol (grainmech.driver.dem.flow): shearing at a target
inertial number I = gamma_dot d sqrt(rho_s / p) (GDR MiDi 2004) without stopping.

References: the relaxed small-strain tensor of the same packing (Lemaitre & Maloney 2006,
Eq. 12; ``grainmech.network.relaxed_stiffness``) for a cycle of 1e-5, where the packing
does not rearrange; the step-and-relax protocol of the same model for a triaxial path's
first increments.
"""

import math

import numpy as np
import pytest

from grainmech.driver.dem.flow import inertial_number, shear_rate
from grainmech.errors import GrainmechError, ParameterError


def test_rate_and_inertial_number_are_inverse():
    r = shear_rate(1e-3, 3e-4, 2650.0, 1e5)
    assert r == pytest.approx(1e-3 / (3e-4 * math.sqrt(2650.0 / 1e5)))
    assert inertial_number(r, 3e-4, 2650.0, 1e5) == pytest.approx(1e-3)
    assert inertial_number(r, 3e-4, 2650.0, 0.0) == math.inf


def test_protocol_settings_are_validated_naming_the_field():
    from grainmech.driver.dem import DemSettings

    with pytest.raises(ParameterError, match="protocol"):
        DemSettings(protocol="fast")
    with pytest.raises(ParameterError, match="inertial_number"):
        DemSettings(protocol="continuous", inertial_number=0.5)
    with pytest.raises(ParameterError, match="servo_interval"):
        DemSettings(servo_interval=0)


engine = pytest.importorskip("grainmech.lammps.engine")


def _lammps() -> bool:
    try:
        engine.require_lammps()
    except GrainmechError:  # pragma: no cover - depends on the environment
        return False
    return True


@pytest.mark.skipif(not _lammps(), reason="LAMMPS is not installed (pip install 'grainmech[dem]')")
def test_a_small_continuous_cycle_gives_the_relaxed_modulus_and_the_servo_holds_the_stress():
    """'dense', constant normal stress, gamma = 1e-5 at I = 1e-3: secant G within 3 % of G_max (0.995 seen)
    (the relaxed tensor condensed with sigma_zz free); sigma_zz held within 1 % of its start;
    every state records its inertial number (at most the target's 1.1 times)."""
    from grainmech.contact import HertzMindlin
    from grainmech.driver import cyclic_simple_shear
    from grainmech.driver.dem import DemSettings, run_dem
    from grainmech.packing import QUARTZ, load_packing

    net = load_packing("dense")
    law = HertzMindlin(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()), friction=0.5)
    st = DemSettings(protocol="continuous", inertial_number=1e-3)
    r = run_dem(net, law, cyclic_simple_shear(1e-5, 1, 8, constant="stress"), st)
    assert r.success, r.message
    from grainmech.analysis import condensed_modulus, loop_properties

    g_max = condensed_modulus(r.elastic_tangent, 4, [False, False, True, False, False, False])
    lp = loop_properties(r.strain[:, 4], r.stress[:, 4])
    assert lp.secant_modulus == pytest.approx(g_max, rel=0.03)
    assert np.all(np.abs(r.stress[:, 2] / r.stress[0, 2] - 1.0) < 0.01)
    assert r.inertial[0] == 0.0 and 0.0 < r.inertial[1:].max() <= 1.1e-3  # the wave bound sets 1.1e-5 here
    assert any("continuous shearing" in n for n in r.notes)


def test_auto_protocol_shears_monotonic_paths_continuously_and_relaxes_cycles():
    """``protocol = "auto"`` (DemSettings.for_path): a drained triaxial path to 15 % runs
    continuously, every cyclic amplitude (even 1e-2) and a short monotonic path by step and
    relax; the note names the choice and its reason; other protocols are left alone."""
    from grainmech.driver import cyclic_simple_shear, triaxial
    from grainmech.driver.dem import DemSettings

    auto = DemSettings(protocol="auto")
    st, why = auto.for_path(triaxial(0.15, 60))
    assert st.protocol == "continuous" and "monotonic path to a strain of 0.15" in why
    st, why = auto.for_path(cyclic_simple_shear(1e-2, 2, 16))
    assert st.protocol == "relax" and "cyclic path" in why
    st, _ = auto.for_path(triaxial(5e-3, 4))
    assert st.protocol == "relax"
    assert DemSettings().for_path(triaxial(0.15, 60)) == (DemSettings(), None)

"""Driver with linear / Jenkins contact laws: exactness, mixed control, energy, failures.

References: the stiffness tensor of the contact set (assembly, seed Eq. 2.26) for the
linear law; isotropic engineering constants for drained triaxial; exact energy balance
work = stored + dissipated for the elastic-Coulomb (Jenkins) law.
"""

import math

import numpy as np
import pytest

from _hyp import given, settings, st
from grainmech.assembly import stiffness
from grainmech.contact import LinearSpring
from grainmech.driver import Control, MaterialPoint, cyclic_simple_shear, parse_mask, run, segment, triaxial
from grainmech.elasticity import isotropic_constants
from grainmech.errors import ParameterError
from grainmech.fabric import isotropic
from grainmech.material import Packing

PK = Packing.from_grains(isotropic(3), void_ratio=0.6, coordination=8, radius=1e-3)
P0 = 1e5


def _point(friction=math.inf, backend="auto"):
    return MaterialPoint.isotropic(PK, LinearSpring(1e6, 4e5, friction), P0, backend=backend)


@pytest.mark.parametrize("backend", ["auto", "numpy"])
@settings(max_examples=15, deadline=None)
@given(st.lists(st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6), min_size=1, max_size=4))
def test_linear_law_any_strain_path_gives_C_eps(backend, segs):
    """Linear springs (no opening): sigma = sigma0 + C eps exactly, C from assembly (Eq. 2.26)."""
    pt = _point(backend=backend)
    # strains small enough that no contact opens: |eps| l < approach / 2 at every contact
    alpha0 = float(np.min(pt.state.approach))
    scale = 0.5 * alpha0 / float(np.max(np.linalg.norm(pt.contacts.branch, axis=1))) / 24
    segs = [[scale * v for v in s] for s in segs]
    C = stiffness(pt.contacts.with_stiffness(1e6, 4e5))
    path = segment("EEEEEE", segs[0], 2)
    for s in segs[1:]:
        path = path + segment("EEEEEE", s, 3)
    r = run(pt, path)
    assert r.success, r.message
    expect = pt.stress[None, :] + r.strain @ C.T
    assert np.allclose(r.stress, expect, rtol=0, atol=1e-9 * P0)
    assert np.allclose(r.tangent[-1], C, rtol=1e-12, atol=1e-6)


def test_mixed_control_drained_triaxial_gives_young_modulus():
    """Drained triaxial (lateral stress held): d sigma_zz / d eps_zz = E of the isotropic C."""
    pt = _point()
    iso = isotropic_constants(pt.tangent)
    r = run(pt, triaxial(1e-4, 4))
    assert r.success, r.message
    assert np.allclose(r.stress[:, [0, 1, 3, 4, 5]], pt.stress[[0, 1, 3, 4, 5]], atol=1e-6)
    assert (r.stress[-1, 2] - P0) / r.strain[-1, 2] == pytest.approx(iso.E, rel=1e-9)
    assert -r.strain[-1, 0] / r.strain[-1, 2] == pytest.approx(iso.nu, rel=1e-9)


def test_mask_parsing_and_errors():
    """Readable masks are parsed at the edge only; bad ones name the field and value."""
    assert parse_mask("eesEEE") == Control((False, False, True, False, False, False))
    assert str(parse_mask("SSESSS")) == "SSESSS"
    with pytest.raises(ParameterError, match="control"):
        parse_mask("EESEE")
    with pytest.raises(ParameterError, match="steps_per_cycle"):
        cyclic_simple_shear(1e-3, 1, 10)


def test_energy_balance_jenkins_law_exact():
    """Elastic-Coulomb law, cyclic shear with sliding: work = stored change + dissipated."""
    pt = _point(friction=0.3)
    r = run(pt, cyclic_simple_shear(2e-4, 2, 200))
    assert r.success, r.message
    assert r.sliding_fraction.max() > 0.1  # friction is active
    assert r.dissipation[-1] > 0
    balance = r.work - (r.stored - r.stored[0]) - r.dissipation
    assert r.open_fraction.max() == 0
    # trapezoidal work: error O(step) where contacts start to slide inside a step
    assert np.abs(balance).max() < 1e-3 * r.dissipation[-1]


def test_failure_is_reported_with_step_and_cause():
    """A shear stress beyond the frictional strength (stress control) ends the run with
    success False, the step named and the data kept."""
    pt = _point(friction=0.3)
    r = run(pt, segment("SSSSSS", [0, 0, 0, 0, 2 * P0, 0], 200), max_depth=3)
    assert not r.success and r.status == 1
    assert r.message.startswith("step ")
    assert "stress target not reachable" in r.message and "sliding" in r.message
    k = int(r.message.split()[1].rstrip(":"))
    assert r.stress.shape == (k, 6)  # initial row + k-1 converged steps
    assert np.all(np.isfinite(r.stress)) and np.all(np.isfinite(r.tangent))
    assert 0.1 * P0 < r.stress[-1, 4] < 2 * P0  # stopped at the strength, not before


def test_strain_controlled_shear_with_sliding_contacts_converges():
    """Strain-controlled shear at constant sigma_zz is reachable however many contacts
    slide: the consistent Jacobian (normal-tangential coupling ktn = mu kn of sliding
    contacts) keeps Newton converging; the shear stress saturates at the strength."""
    pt = _point(friction=0.3)
    r = run(pt, cyclic_simple_shear(2e-2, 1, 200))
    assert r.success, r.message
    assert np.allclose(r.stress[:, 2], P0, rtol=1e-8)
    assert r.sliding_fraction.max() > 0.5
    tau = r.stress[:, 4]
    # saturated: the last 20 steps of the first quarter change tau by < 1 %
    assert abs(tau[50] - tau[30]) < 0.01 * abs(tau[50])

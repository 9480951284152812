"""Seed Sec. 6.3.2 / Fig. 6.10-6.12: moduli along three stress paths, both initial-state methods.

Analytic reference (derived in docs/models/affine.md): for an isotropic fabric the static
estimate gives f = sigma . n (up to a constant), so with sigma = diag(s3, s3, s1) and
n = (sin t, 0, cos t): T/N = (R - 1) sin t cos t / (sin^2 t + R cos^2 t), R = s1/s3,
maximal at tan t = sqrt(R) where it equals (R - 1)/(2 sqrt R). Setting it to tan(phi_mu)
gives R* = (1 + sin phi_mu)/(1 - sin phi_mu) = 2.371 for phi_mu = 24 deg (the seed: "2.3").
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from grainmech.assembly import static_contact_forces
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint, fig610_path, fig610_stress, geometry, run
from grainmech.elasticity import engineering_constants
from grainmech.fabric import isotropic
from grainmech.material import Packing

PHI = math.radians(24.0)
R_STAR = (1 + math.sin(PHI)) / (1 - math.sin(PHI))
# G = 7.5e6 psi, nu = 0.13, phi_mu = 24 deg, 10 psi isotropic start (units: psi, inch)
LAW = MindlinDeresiewicz(7.5e6, 0.13, 0.01, friction=math.tan(PHI))
PK = Packing.from_grains(isotropic(3), void_ratio=0.6, coordination=8, radius=0.01)
CS = geometry(PK, extra_degree=31)
P0 = 10.0


def test_critical_ratio_analytic_matches_static_estimate_on_fine_set():
    cs = geometry(PK, extra_degree=121)  # dense Lebedev set

    def excess(R):
        f = static_contact_forces(cs, np.diag([1.0, 1.0, R]))
        Nn = np.einsum("ci,ci->c", f, cs.normals)
        T = np.linalg.norm(f - Nn[:, None] * cs.normals, axis=1)
        return float(np.max(T / Nn)) - math.tan(PHI)

    R_num = brentq(excess, 1.01, 5.0)
    assert R_STAR == pytest.approx(2.3712, abs=1e-4)
    assert R_num == pytest.approx(R_STAR, rel=5e-3)  # discrete directions: max T/N <= continuum


@pytest.mark.parametrize("kind", ["compression", "constant-mean", "reduced-compression"])
def test_state_estimate_sliding_starts_at_critical_ratio_and_moduli_drop(kind):
    def at(R):
        s1, s3 = fig610_stress(kind, P0, R)
        pt = MaterialPoint.at_stress(CS, LAW, [s3, s3, s1, 0, 0, 0], initial="state-estimate")
        return pt, engineering_constants(pt.tangent).as_dict()

    below, eb = at(0.97 * R_STAR)
    above, ea = at(1.1 * R_STAR)
    assert below.fractions()[0] == 0.0
    assert above.fractions()[0] > 0.1
    # below R*: stress reproduced exactly (no cap); above: the cap lowers the deviator
    s1, s3 = fig610_stress(kind, P0, 0.97 * R_STAR)
    assert below.stress[2] / below.stress[0] == pytest.approx(s1 / s3, rel=1e-10)
    assert above.stress[2] / above.stress[0] < 1.1 * R_STAR
    # moduli drop appreciably across R* (seed Fig. 6.11-6.12)
    assert ea["E_zz"] < 0.93 * eb["E_zz"]
    assert ea["G_xz"] < 0.95 * eb["G_xz"]


def test_path_following_vs_state_estimate():
    """Both methods agree at the isotropic start; path-following slides later (history)."""
    pt0 = MaterialPoint.isotropic(CS, LAW, P0)
    r = run(pt0, fig610_path("compression", P0, 3.0, 20), engineering=True)
    assert r.success, r.message
    e_iso = engineering_constants(pt0.tangent).as_dict()
    est = MaterialPoint.at_stress(CS, LAW, [P0, P0, P0, 0, 0, 0], initial="state-estimate")
    assert np.allclose(est.tangent, pt0.tangent, rtol=1e-10)
    assert r.engineering["E_zz"][0] == pytest.approx(e_iso["E_zz"], rel=1e-12)
    ratio = r.stress[:, 2] / r.stress[:, 0]
    assert np.allclose(ratio[-1], 3.0, rtol=1e-8)
    # at R = 2.5 > R* the estimate already slides, the loaded packing does not yet
    k = int(np.argmin(np.abs(ratio - 2.5)))
    assert r.sliding_fraction[k] == 0.0
    s1, s3 = fig610_stress("compression", P0, ratio[k])
    est = MaterialPoint.at_stress(CS, LAW, [s3, s3, s1, 0, 0, 0])
    assert est.fractions()[0] > 0.1
    # path-following through the same function
    pf = MaterialPoint.at_stress(CS, LAW, [s3, s3, s1, 0, 0, 0], initial="path-following",
                                 start_pressure=P0, n_steps=10)
    assert pf.stress[2] / pf.stress[0] == pytest.approx(ratio[k], rel=1e-8)

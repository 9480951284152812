"""The empirical references and a path's strength a run's outcome carries (analysis.references).

Values checked against the published forms written out here: Darendeli (2001, Table 8.12)
``gamma_r = 0.0352 % (p/pa)^0.3483`` for PI 0, OCR 1; Hardin & Drnevich (1972)
``gamma_r = p sin(phi') / Gmax``, ``D_max = 33 - 1.5 log10 N`` %; Menq (2003)
``gamma_r = 0.12 Cu^-0.6 (p/pa)^(0.5 Cu^-0.15)`` %; Mohr-Coulomb ``sin phi = (s1 - s3)/(s1 + s3)``.
"""

from __future__ import annotations

import json
import math
import tomllib
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import CYCLIC
from grainmech.analysis.references import (
    SAND_ENVELOPE_RATIO,
    SAND_ENVELOPE_TAU_RATIO,
    path_measures,
    reference_curves,
)

PA = 101325.0
REF = dict(pi=0.0, ocr=1.0, n_cycles=10.0, frequency=1.0, phi=math.radians(33))


def test_reference_curves_at_the_published_reference_strains():
    emp = {"G_angular_Pa": 1.2e8}
    r = reference_curves([1e-6, 1e-5, 1e-4], 1e5, REF, 4e8, emp)
    assert r.gamma[0] == pytest.approx(1e-6) and r.gamma[-1] == pytest.approx(1e-4) and len(r.gamma) == 60
    assert r.darendeli.gamma_r == pytest.approx(0.0352e-2 * (1e5 / PA) ** 0.3483, rel=1e-6)
    # Hardin-Drnevich on Hardin-Richart's angular-grain Gmax, not the model's
    assert r.hd_gmax == 1.2e8 and "angular" in r.hd_gmax_source
    assert r.hardin_drnevich.gamma_r == pytest.approx(1e5 * math.sin(math.radians(33)) / 1.2e8, rel=1e-12)
    assert r.hardin_drnevich.d_max == pytest.approx(0.315)
    # G/Gmax = 1 / (1 + gamma/gamma_r): one half at gamma_r
    k = np.argmin(np.abs(np.log(r.gamma / r.hardin_drnevich.gamma_r)))
    assert r.hd_ratio[k] == pytest.approx(1 / (1 + r.gamma[k] / r.hardin_drnevich.gamma_r))
    assert r.menq is None and r.menq_at_amplitudes is None  # no grading given


def test_one_amplitude_a_decade_either_side_and_the_model_gmax_without_a_void_ratio():
    r = reference_curves([1e-5], 1e5, REF, 4e8, None)
    assert r.gamma[0] == pytest.approx(1e-6) and r.gamma[-1] == pytest.approx(1e-4)
    assert r.hd_gmax == 4e8 and "model" in r.hd_gmax_source  # said so


def test_menq_on_the_grid_and_at_the_amplitudes():
    ref = {**REF, "uniformity_coefficient": 1.5, "d50": 0.2e-3, "grading_source": "[reference] keys"}
    amps = [1e-5, 3e-4]
    r = reference_curves(amps, 2e5, ref, 4e8, None)
    cu, s = 1.5, 2e5 / PA
    assert r.menq.gamma_r == pytest.approx(0.12e-2 * cu ** -0.6 * s ** (0.5 * cu ** -0.15), rel=1e-12)
    assert r.menq.curvature == pytest.approx(0.86 + 0.1 * math.log10(s))
    assert r.menq_at_amplitudes.G_ratio == pytest.approx(
        1 / (1 + (np.asarray(amps) / r.menq.gamma_r) ** r.menq.curvature))
    assert r.grading_source == "[reference] keys"


def test_no_curves_without_an_amplitude_inputs_or_a_gmax():
    assert reference_curves([], 1e5, REF, 4e8) is None
    assert reference_curves([1e-5], 1e5, {}, 4e8) is None
    assert reference_curves([1e-5], 1e5, REF, float("nan"), None) is None


def test_the_envelope_of_sands_in_numbers():
    sn = math.sin(math.radians(50))
    assert SAND_ENVELOPE_RATIO == pytest.approx((1 + sn) / (1 - sn))
    assert SAND_ENVELOPE_RATIO == pytest.approx(7.55, abs=5e-3)
    assert SAND_ENVELOPE_TAU_RATIO == pytest.approx(math.tan(math.radians(50)))


def test_path_measures_of_a_triaxial_compression():
    # sigma_zz from 100 to 300 kPa at sigma_xx = sigma_yy = 100 kPa, eps_zz to 1e-3, lateral -2e-4
    k = 11
    t = np.linspace(0.0, 1.0, k)
    stress = np.zeros((k, 6))
    stress[:, :3] = 1e5
    stress[:, 2] = 1e5 + 2e5 * t
    strain = np.zeros((k, 6))
    strain[:, 2] = 1e-3 * t
    strain[:, 0] = strain[:, 1] = -2e-4 * t
    pm = path_measures(SimpleNamespace(stress=stress, strain=strain))
    assert pm.axis == "zz"
    p, q = pm.rows[-1, 0], pm.rows[-1, 1]
    assert p == pytest.approx(5e5 / 3) and q == pytest.approx(2e5)
    assert pm.rows[-1, 3] == pytest.approx(1e-3) and pm.rows[-1, 4] == pytest.approx(6e-4)
    sg = pm.strength
    assert sg.peak_friction_angle_deg == pytest.approx(30.0)  # sin phi = 200/400
    assert sg.peak_q_over_p == pytest.approx(1.2)
    assert sg.dilatancy_rate == pytest.approx(0.6) and not sg.critical
    assert path_measures(SimpleNamespace(stress=stress[:2], strain=strain[:2])).strength is None


def test_the_outcome_carries_its_references_and_the_writer_writes_them(tmp_path):
    from grainmech.io.reports import write_run_outputs
    from grainmech.jobs import compute_run

    cfg = tomllib.loads(CYCLIC)  # the small cyclic run of the command-line tests: void ratio 0.65, 100 kPa
    out = compute_run(cfg)
    r = out.references
    assert r is not None and r.hd_gmax == out.empirical_G_max["G_angular_Pa"]
    e = 0.65  # Hardin & Richart (1963), angular grains, p in kPa
    g_ang = 3230.0 * (2.97 - e) ** 2 / (1 + e) * math.sqrt(100.0) * 1e3
    assert r.hardin_drnevich.gamma_r == pytest.approx(1e5 * math.sin(math.radians(33)) / g_ang, rel=1e-9)
    write_run_outputs(out, tmp_path, cfg, "test")
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["darendeli_gamma_r"] == r.darendeli.gamma_r and s["hardin_drnevich_gamma_r"] == r.hardin_drnevich.gamma_r
    assert s["menq_gamma_r"] == r.menq.gamma_r and s["menq_G_over_Gmax"] == list(r.menq_at_amplitudes.G_ratio)

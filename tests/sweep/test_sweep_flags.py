"""Sweep rows of `run` points carry the envelope flags `grainmech run` prints, and the
recommended curve of a run with several models."""

from __future__ import annotations

import math

import numpy as np

from grainmech import jobs
from grainmech.outcomes import CyclicOutcome, RunComparison
from grainmech.sweep.kinds import envelope_columns, recommended_columns, run_kind_point

BASE = {"microstructure": {"void_ratio": 0.65, "coordination": "chang", "radius": "0.25 mm"},
        "contacts": {"law": "mindlin-deresiewicz", "shear_modulus": "44 GPa", "poisson": 0.08,
                     "friction_angle": "27 deg"},
        "initial": {"pressure": "100 kPa"},
        "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-6, 1e-5, 1e-4, 1e-3, 3e-3], "n_cycles": 2,
                 "steps_per_cycle": 24},
        "quadrature": {"degree": 7}}


def test_run_row_flags_the_amplitudes_run_marks_beyond_envelope():
    """The example sweep's base point: the affine model leaves the envelope at 1e-3 and 3e-3."""
    out = jobs.execute_run(jobs.prepare_run(BASE))
    row = run_kind_point(BASE)
    marked = [f"{a:g}" for a, b in zip(out.amplitudes, out.beyond_envelope) if b]
    assert marked == ["0.001", "0.003"]  # what `grainmech run` prints as BEYOND ENVELOPE
    assert [row[f"beyond_envelope@{a:g}"] for a in out.amplitudes] == [0, 0, 0, 1, 1]
    assert [row[f"value_flag@{a:g}"] for a in out.amplitudes] == [0, 0, 0, 0, 0]
    assert row["beyond_envelope_amplitudes"] == 2
    # the row's numbers are run_scalars' (unchanged); gamma_r_within_envelope uses 1e-6 ... 1e-4 only
    assert row["G/Gmax@0.001"] == float(out.G_ratio[3])
    # G/Gmax crosses 0.5 only between 1e-4 and 1e-3, i.e. beyond the envelope: gamma_r (run_scalars)
    # comes from a beyond-envelope amplitude, the curve within the envelope gives none
    assert 1e-4 < row["gamma_r"] < 1e-3 and out.G_ratio[2] > 0.5 > out.G_ratio[3]
    assert math.isnan(row["gamma_r_within_envelope"])
    assert math.isnan(jobs.reference_strain(out.amplitudes[:3], out.G_ratio[:3]))
    assert "recommended: G_max [Pa]" not in row  # one model: no recommended curve


def _cyclic(method: str, amps, G, damping, gmax, beyond) -> CyclicOutcome:
    env = [{"beyond_any": b, "max_ratio": 3.0} for b in beyond]
    return CyclicOutcome(kind="cyclic-simple-shear", pressure=1e5, results=[], success=True, message="completed",
                         seconds=1.0, point=None, method=method, amplitudes=np.array(amps), G=np.array(G),
                         damping=np.array(damping), G_max=gmax, envelope=env)


def test_envelope_and_recommended_columns_of_a_comparison():
    aff = _cyclic("affine", [1e-4, 1e-3], [2.8e8, 2.0e8], [0.01, 0.05], 3e8, [False, True])
    pk = _cyclic("packing", [1e-4], [2.0e8], [0.04], 2.5e8, [False])
    dem = _cyclic("dem", [1e-3], [1.0e8], [0.14], 2.0e8, [False])
    cols = envelope_columns(aff)
    assert cols["beyond_envelope@0.001"] == 1 and cols["beyond_envelope@0.0001"] == 0
    assert math.isnan(cols["gamma_r_within_envelope"])  # one amplitude within: no crossing of 0.5
    rec = recommended_columns(RunComparison([aff, pk, dem]))
    assert rec["recommended: G_max [Pa]"] == 2.5e8 and rec["recommended: G_max_model"] == "packing"
    assert rec["recommended: G/Gmax@0.0001"] == 0.8 and rec["recommended: G/Gmax@0.001"] == 0.4
    assert rec["recommended: model@0.001"] == "dem" and rec["recommended: flags@0.001"] == ""

"""The recommended curve of a run with several models (outcomes.recommended_curve), on
synthetic outcomes: no driver, no LAMMPS."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from grainmech.analysis.loops import LoopQuality
from grainmech.outcomes import CyclicOutcome, RunComparison, recommended_curve

REF = {"pi": 0.0, "ocr": 1.0, "n_cycles": 10.0, "frequency": 1.0, "phi": np.radians(33.0)}


def _env(beyond: bool) -> dict:
    return {"beyond_any": beyond, "max_ratio": 9.0 if beyond else 3.0, "max_tau_over_sigma_zz": 0.5,
            "max_mobilised_friction_deg": 30.0, "first_step": 3 if beyond else None,
            "ratio": np.zeros(0), "beyond": np.zeros(0, dtype=bool), "limit": 7.55, "friction_angle_deg": 50.0}


def _quality(ok: bool = True) -> LoopQuality:
    c = 0.0 if ok else 0.2
    return LoopQuality(1e-5, 1e3, 1e3, -1e3, 0.0, c, 0.0, 0.0)


def _model(method: str, amps, G, damping, gmax, beyond=None, details=None, loops_ok=None) -> CyclicOutcome:
    n = len(amps)
    beyond = beyond or [False] * n
    loops_ok = loops_ok or [True] * n
    return CyclicOutcome(kind="cyclic-simple-shear", pressure=1e5, results=[], success=True, message="completed",
                         seconds=1.0, point=None, method=method, details=details or {},
                         amplitudes=np.array(amps), G=np.array(G), damping=np.array(damping), G_max=gmax,
                         reference=dict(REF), run_amplitudes=np.array(amps), envelope=[_env(b) for b in beyond],
                         loop_quality=[_quality(k) for k in loops_ok])


def _default_like() -> RunComparison:
    """The built-in default's shape: affine at every amplitude, packing up to 1e-4, DEM at 3e-4 and 1e-3."""
    aff = _model("affine", [1e-6, 1e-5, 1e-4, 3e-4, 1e-3], [3.0e8, 2.95e8, 2.7e8, 2.4e8, 2.0e8],
                 [0.001, 0.004, 0.02, 0.04, 0.06], 3.0e8, beyond=[False, False, False, True, True])
    pk = _model("packing", [1e-6, 1e-5, 1e-4], [2.5e8, 2.4e8, 2.0e8], [0.002, 0.01, 0.05], 2.5e8,
                details={"rearranging": [False, False, False]})
    dem = _model("dem", [3e-4, 1e-3], [1.5e8, 1.0e8], [0.09, 0.14], 2.0e8, loops_ok=[True, False])
    return RunComparison([aff, pk, dem])


def test_packing_points_then_dem_points_on_the_packing_gmax():
    rec = recommended_curve(_default_like())
    assert rec.G_max == 2.5e8 and rec.G_max_model == "packing"
    np.testing.assert_allclose(rec.amplitudes, [1e-6, 1e-5, 1e-4, 3e-4, 1e-3])
    assert rec.models == ["packing", "packing", "packing", "dem", "dem"]
    # the DEM secant G over the packing model's Gmax (1.5e8 / 2.5e8), not over its own (1.5e8 / 2.0e8 = 0.75)
    np.testing.assert_allclose(rec.G_ratio, [1.0, 0.96, 0.8, 0.6, 0.4])
    np.testing.assert_allclose(rec.damping, [0.002, 0.01, 0.05, 0.09, 0.14])
    assert rec.flags == [[], [], [], [], ["loop_not_closed"]]
    assert "0.800 of it" in rec.G_max_reason  # the DEM model's own Gmax, 2.0e8 / 2.5e8
    assert rec.choices == []
    # the affine model is a reference only: its points are not on the curve
    assert rec.reference["model"] == "affine" and rec.reference["G_max_Pa"] == 3.0e8
    assert "1.20 times" in rec.reference["note"]


def test_where_both_ran_the_dem_point_is_kept_only_where_the_packing_grains_rearrange():
    pk = _model("packing", [1e-5, 1e-4, 3e-4], [2.4e8, 2.0e8, 1.6e8], [0.01, 0.05, 0.08], 2.5e8,
                details={"rearranging": [False, False, True]})
    dem = _model("dem", [1e-4, 3e-4, 1e-3], [1.9e8, 1.5e8, 1.0e8], [0.06, 0.09, 0.14], 2.3e8,
                 beyond=[False, False, True])
    rec = recommended_curve(RunComparison([pk, dem]))
    assert rec.models == ["packing", "packing", "dem", "dem"]
    np.testing.assert_allclose(rec.G, [2.4e8, 2.0e8, 1.5e8, 1.0e8])
    np.testing.assert_allclose(rec.G_ratio, [0.96, 0.8, 0.6, 0.4])
    assert rec.flags == [[], [], [], ["beyond_envelope"]]
    assert len(rec.choices) == 2
    assert rec.choices[0].startswith("0.0001: the packing point (G/Gmax 0.8000")
    assert "DEM model gives G/Gmax 0.7600" in rec.choices[0]
    assert rec.choices[1].startswith("0.0003: the DEM point (G/Gmax 0.6000") and "rearrange" in rec.choices[1]
    assert rec.reference == {}


def test_a_rearranging_packing_point_no_dem_replaces_is_flagged_and_values_above_one_too():
    pk = _model("packing", [1e-5, 1e-4], [2.4e8, 2.0e8], [0.01, 0.05], 2.5e8, details={"rearranging": [False, True]})
    dem = _model("dem", [1e-6], [2.6e8], [0.001], 2.6e8)  # DEM stiffer than the packing Gmax at 1e-6
    rec = recommended_curve(RunComparison([pk, dem]))
    assert rec.models == ["dem", "packing", "packing"]
    np.testing.assert_allclose(rec.G_ratio, [1.04, 0.96, 0.8])
    assert rec.flags == [["value_flag"], [], ["grains_rearrange"]]


def test_dem_gmax_without_packing_and_no_curve_without_physical_models():
    aff = _model("affine", [1e-5, 1e-4], [3e8, 2.8e8], [0.001, 0.01], 3e8)
    dem = _model("dem", [1e-4, 1e-3], [1.8e8, 1.0e8], [0.05, 0.14], 2.0e8)
    rec = RunComparison([aff, dem]).recommended
    assert rec.G_max_model == "dem" and rec.models == ["dem", "dem"]
    np.testing.assert_allclose(rec.G_ratio, [0.9, 0.5])
    assert recommended_curve(RunComparison([aff])) is None
    assert recommended_curve(RunComparison([aff, _model("affine", [1e-5], [3e8], [0.001], 3e8)])) is None


def test_writer_writes_the_csv_the_summary_and_the_page(tmp_path):
    from grainmech.io.reports import RECOMMENDED_COLUMNS, write_run_outputs

    summary = write_run_outputs(_default_like(), tmp_path / "o", {}, "synthetic")
    rows = list(csv.reader((tmp_path / "o" / "recommended_curve.csv").open()))
    assert tuple(rows[0]) == RECOMMENDED_COLUMNS
    assert [r[4] for r in rows[1:]] == ["packing", "packing", "packing", "dem", "dem"]
    assert [float(r[2]) for r in rows[1:]] == pytest.approx([1.0, 0.96, 0.8, 0.6, 0.4])
    assert rows[-1][5] == "loop_not_closed" and rows[1][5] == ""
    on_disk = json.loads((tmp_path / "o" / "summary.json").read_text())["recommended_curve"]
    assert on_disk["G_max_model"] == "packing" and on_disk["G_max_Pa"] == 2.5e8
    assert on_disk["G_over_Gmax"] == pytest.approx([1.0, 0.96, 0.8, 0.6, 0.4])
    assert "recommended_curve.csv" in summary["files"]
    page = (tmp_path / "o" / "index.html").read_text()
    assert "recommended curve" in page and "recommended_curve.csv" in page

"""A complete computation is written whole: an unexpected value is flagged, not refused."""

from __future__ import annotations

import csv
import dataclasses
import json

import numpy as np

from grainmech.io.reports import write_run_outputs
from grainmech.io.site_response import read_curves
from grainmech.jobs import compute_run

CFG = {
    "microstructure": {"void_ratio": 0.65, "coordination": "chang", "radius": "0.25 mm"},
    "contacts": {"law": "mindlin-deresiewicz", "shear_modulus": "44 GPa", "poisson": 0.08, "friction": 0.5},
    "initial": {"pressure": "100 kPa"},
    "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-6, 1e-5, 1e-4], "n_cycles": 2, "steps_per_cycle": 8},
    "quadrature": {"degree": 5},
}


def test_g_over_gmax_above_one_is_written_with_a_flag_and_left_out_of_the_site_curves(tmp_path):
    out = compute_run(CFG)
    # a loop stiffer than the model's Gmax (as a small DEM packing with Cundall damping gives)
    G = np.asarray(out.G, dtype=float).copy()
    G[1] = 1.03 * out.G_max
    odd = dataclasses.replace(out, G=G)
    summary = write_run_outputs(odd, tmp_path, CFG, "test")
    assert "site_response_curves.csv" in summary["files"] and "modulus_reduction.csv" in summary["files"]
    rows = list(csv.DictReader(open(tmp_path / "modulus_reduction.csv")))
    assert [int(r["value_flag [0/1]"]) for r in rows] == [0, 1, 0]
    assert float(rows[1]["G_over_Gmax [-]"]) > 1  # written as computed
    c = read_curves(tmp_path / "site_response_curves.csv")
    assert np.allclose(c.strain, [1e-6, 1e-4]) and "1.0e-05 (G/Gmax = 1.03 above 1" in c.comment
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["value_problems"][1].startswith("G/Gmax = 1.03")
    assert "nan" not in (tmp_path / "modulus_reduction.csv").read_text().lower()

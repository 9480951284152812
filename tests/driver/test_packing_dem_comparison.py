"""The packing driver against LAMMPS on the same packing (cyclic simple shear).

Reference: ``tests/data/dem_reference/dense-cyclic.json`` — LAMMPS (``pair_style
granular hertz/material`` + ``tangential mindlin``, i.e. Hertz normal force and
``k_t = 8 G* a`` with a Coulomb cap; quasi-static, checked against half the strain rate
and double the drag) on the re-settled 'dense' reference packing of
``dense-probes-*.npz`` (2000 grains, no tangential forces at rest), constant-volume
cyclic simple shear γ_xy at 1e-5 and 1e-4: a ramp to +γ in four increments, then one
cycle of sixteen increments. The packing driver runs the same strain path with
``HertzMindlin`` (the same contact model) on the same network.

Tolerances are those of the packing-driver specification: secant G within 5 %, damping
ratio within 0.01 (absolute). Seen (``docs/models/packing.md``, 2026-11-26): γ = 1e-5,
G 195.84 vs 195.77 MPa, D 0.106 % vs 0.069 %, 2.8 s; γ = 1e-4, G 180.18 vs 179.83 MPa,
D 2.75 % vs 2.54 %, 11.8 s (150 s, 2026-11-25, before the Anderson-accelerated
iterations and the step-relative acceptance; ~6 minutes before that, when this case ran
only with ``GRAINMECH_LONG_TESTS=1``). One grain's out-of-balance force may stay at a few
per cent of the mean contact force where its imbalance no longer changes the stress.
The figure ``docs/packing-dem-comparison.png`` (``benchmarks/plot_dem_comparison.py``)
shows both loops against LAMMPS'.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from grainmech.analysis import loop_properties
from grainmech.contact import HertzMindlin
from grainmech.driver import concatenate, segment
from grainmech.driver.packing import PackingOptions, PackingPoint, run_packing
from grainmech.io.dem import read_network

REF = Path(__file__).resolve().parents[1] / "data" / "dem_reference"
K_XY = 5  # library order xx yy zz yz xz xy


@pytest.fixture(scope="module")
def reference() -> dict:
    return json.loads((REF / "dense-cyclic.json").read_text())


@pytest.fixture(scope="module")
def point(reference: dict) -> PackingPoint:
    net = read_network(REF / "dense-probes-contacts.npz", REF / "dense-probes-particles.npz")
    m = reference["material"]
    law = HertzMindlin(m["shear_modulus_Pa"], m["poisson"], 1.5e-4, friction=m["friction"])
    return PackingPoint.from_network(net, law, options=PackingOptions(law_backend="auto", tangent="none"))


@pytest.mark.parametrize("k", [0, 1], ids=["gamma=1e-5", "gamma=1e-4"])
def test_cyclic_simple_shear_matches_lammps(point: PackingPoint, reference: dict, k: int) -> None:
    amp = reference["amplitudes"][k]
    assert amp == [1e-5, 1e-4][k]
    ref = reference["runs"]["reference"]
    assert ref["settings"]["constant"] == "volume" and ref["settings"]["points_per_cycle"] == 16
    e = np.zeros(6)
    e[K_XY] = amp / 4
    parts = [segment("EEEEEE", e, 1)] * 4 + [segment("EEEEEE", -e, 1)] * 8 + [segment("EEEEEE", e, 1)] * 8
    res = run_packing(point, concatenate(parts), PackingOptions(law_backend="auto", tangent="none"))
    assert res.success, res.message
    lp = loop_properties(res.strain[4:, K_XY], res.stress[4:, K_XY])
    g_ref, d_ref = ref["G_Pa"][k], ref["damping"][k]
    assert lp.secant_modulus == pytest.approx(g_ref, rel=0.05)
    assert abs(lp.damping - d_ref) <= 0.01
    # every step ends in equilibrium or within the accepted stress tolerance (the residual
    # is the largest grain's out-of-balance force over the mean contact force)
    assert np.all(res.residual[1:] < [1e-2, 0.1][k])

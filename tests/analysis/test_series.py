"""``grainmech.modulus_reduction`` (= ``grainmech.analysis.modulus_reduction``) takes a model.

The default is the affine model (the seed's kinematic hypothesis), as before; ``model=``
runs the packing model's (or the DEM model's) series through the registry. Each is checked
against the model's own series function called directly, bit for bit, and against the
small-strain limit every model must meet: at an amplitude of 1e-6 the secant modulus is
Gmax (G/Gmax within 1e-3 of 1).
"""

from __future__ import annotations

import numpy as np
import pytest

import grainmech as gm
from grainmech.analysis import modulus_reduction
from grainmech.contact import MindlinDeresiewicz
from grainmech.driver import MaterialPoint
from grainmech.driver import modulus_reduction as affine_series
from grainmech.driver.packing import (
    PackingPoint,
    equilibrate_network,
    packing_modulus_reduction,
    perturbed_fcc_network,
)
from grainmech.errors import ParameterError
from grainmech.fabric import isotropic
from grainmech.material import Microstructure

MD = MindlinDeresiewicz(29e9, 0.15, 1.0, friction=0.5)
AMPS = [1e-6, 1e-4]


def _same(a, b) -> None:
    for k in ("amplitude", "G", "G_ratio", "damping"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k
    assert a.G_max == b.G_max


def test_the_package_name_is_the_analysis_function():
    assert gm.modulus_reduction is modulus_reduction


def test_the_default_is_the_affine_model():
    ms = Microstructure.from_grains(isotropic(3), void_ratio=0.65, coordination=8.0, radius=2.5e-4)
    point = MaterialPoint.isotropic(ms, MindlinDeresiewicz(44e9, 0.08, 2.5e-4, friction=0.5), 1e5, extra_degree=5)
    a = gm.modulus_reduction(point, AMPS, n_cycles=2, steps_per_cycle=16)
    _same(a, affine_series(point, AMPS, n_cycles=2, steps_per_cycle=16))
    _same(a, gm.modulus_reduction(point, AMPS, model="affine", n_cycles=2, steps_per_cycle=16))
    assert a.G_ratio[0] == pytest.approx(1.0, abs=1e-3) and a.G_ratio[1] < a.G_ratio[0]


def test_the_packing_model_through_the_registry():
    net = equilibrate_network(perturbed_fcc_network(3, seed=1, vacancies=0.05), MD)
    point = PackingPoint.from_network(net, MD)
    a = gm.modulus_reduction(point, AMPS, model="packing", n_cycles=1, steps_per_cycle=16)
    _same(a, packing_modulus_reduction(point, AMPS, n_cycles=1, steps_per_cycle=16))
    assert a.G_ratio[0] == pytest.approx(1.0, abs=1e-3)


def test_an_unknown_model_names_the_known_ones():
    with pytest.raises(ParameterError, match=r"^model = 'relaxed': is not a kinematic model: the known ones are "
                                             r"\['affine', 'packing', 'dem'\]"):
        gm.modulus_reduction(None, AMPS, model="relaxed")

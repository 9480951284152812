"""Issue 30 item 4: "packing" names a packing of grains only.

The analytical fabric-and-density description is ``material.Microstructure`` (with
``microstructure_stiffness``), the seed's rod packings are rod arrays
(``rods.ARRAYS``, ``regular_array``, ``rods.random_arrays``). The old names work for one
release and warn (DeprecationWarning) on use; the library itself uses none of them. The
config table is ``[microstructure]``; ``[packing]``, its old name, is read with a config
warning (tests/io/test_renamed_tables.py).
"""

from __future__ import annotations

import importlib
import sys
import tomllib
import warnings

import numpy as np
import pytest

STIFFNESS_TOML = """
[microstructure]
void_ratio = 0.65
coordination = 8.7
radius = "0.25 mm"
[contacts]
law = "hertz-mindlin"
shear_modulus = "29 GPa"
poisson = 0.15
[stress]
pressure = "100 kPa"
"""


def test_microstructure_and_its_old_names():
    """Walton (1987)-type check on linear springs, physical counting: K = Nv l^2 kn / 9
    (the same closed form as tests/io/test_config_schema.py), through the new and old names."""
    import grainmech as gm
    from grainmech import material
    from grainmech.contact import LinearSpring
    from grainmech.elasticity import bulk_modulus
    from grainmech.fabric import isotropic

    nv, length, kn, ks = 2.0e9, 5e-4, 3e6, 1e6
    ms = material.Microstructure(isotropic(3), nv, length)
    new = material.microstructure_stiffness(ms, LinearSpring(kn, ks))
    assert bulk_modulus(new.C, "voigt") == pytest.approx(nv * length**2 * kn / 9, rel=1e-12)
    with pytest.warns(DeprecationWarning, match="material.Packing is deprecated: it is .*material.Microstructure"):
        old_cls = material.Packing
    assert old_cls is material.Microstructure
    with pytest.warns(DeprecationWarning, match="microstructure_stiffness"):
        old = material.packing_stiffness(old_cls(isotropic(3), nv, length), LinearSpring(kn, ks))
    assert np.array_equal(old.C, new.C)
    with pytest.warns(DeprecationWarning, match="grainmech.Packing is deprecated: it is grainmech.Microstructure"):
        assert gm.Packing is material.Microstructure
    assert gm.microstructure_stiffness is material.microstructure_stiffness
    assert gm.Microstructure is material.Microstructure
    with pytest.raises(AttributeError):
        material.NoSuchName  # noqa: B018


def test_rod_arrays_and_their_old_names():
    from grainmech import rods
    from grainmech.rods import random_arrays, regular

    with pytest.warns(DeprecationWarning, match="rods.PACKINGS is deprecated: it is grainmech.rods.ARRAYS"):
        assert rods.PACKINGS is rods.ARRAYS
    with pytest.warns(DeprecationWarning, match="regular.PACKINGS"):
        assert regular.PACKINGS is regular.ARRAYS
    with pytest.warns(DeprecationWarning, match="regular_array"):
        old = rods.regular_packing("hexagonal", diameter=2e-3)
    new = rods.regular_array("hexagonal", diameter=2e-3)
    assert np.array_equal(old.normals, new.normals) and np.array_equal(old.weights, new.weights)
    with pytest.warns(DeprecationWarning, match="array_geometry"):
        assert rods.packing_geometry("B") is rods.array_geometry("B")
    with pytest.warns(DeprecationWarning, match="grainmech.rods.random_packing is deprecated"):
        import grainmech.rods.random_packing as old_module

        importlib.reload(old_module)
    with pytest.warns(DeprecationWarning, match="random_array"):
        cs = old_module.packing("one-size")
    assert cs is random_arrays.random_array("one-size")  # the same cached array
    with pytest.warns(DeprecationWarning, match="array_stats"):
        assert old_module.packing_stats(cs) == random_arrays.array_stats(cs)
    assert old_module.strains is random_arrays.strains


def test_the_library_uses_no_deprecated_name():
    """A stiffness config with its [microstructure] table, a regular and a random rod array: no
    DeprecationWarning from grainmech."""
    from grainmech.jobs import compute_stiffness
    from grainmech.material import Microstructure
    from grainmech.rods import regular_array
    from grainmech.rods.random_arrays import array_stats, random_array

    with warnings.catch_warnings():
        warnings.filterwarnings("error", category=DeprecationWarning, module="grainmech")
        out = compute_stiffness(tomllib.loads(STIFFNESS_TOML))
        assert isinstance(out.microstructure, Microstructure)
        assert array_stats(regular_array("square"))["coordination"] == pytest.approx(4.0)
        assert array_stats(random_array("one-size"))["particles"] == 271


def test_fabric_coordination_and_its_old_module_name():
    """fabric/packing.py (packing density and coordination correlations, seed Sec. 4.1.1) is
    fabric/coordination.py: "packing" names a packing of grains only (issue 30 item 4)."""
    from grainmech.fabric import coordination

    with pytest.warns(DeprecationWarning, match="grainmech.fabric.packing is deprecated: it is grainmech.fabric"):
        import grainmech.fabric.packing as old_module

        importlib.reload(old_module)
    assert old_module.coordination_number is coordination.coordination_number
    assert old_module.contacts_per_volume is coordination.contacts_per_volume
    assert set(old_module.__all__) == set(coordination.__all__)


def test_network_figures_and_their_old_names():
    """The figures of a contact network are grainmech.plots' (matplotlib in one place, and
    the network package below the plots); the documented old names warn for one release."""
    import grainmech.network as network
    from grainmech import plots

    with pytest.warns(DeprecationWarning, match="grainmech.network.plot_rose is deprecated: it is grainmech.plots"):
        assert network.plot_rose is plots.plot_rose
    with pytest.warns(DeprecationWarning, match="grainmech.network.plot_normal_density is deprecated"):
        assert network.plot_normal_density is plots.plot_normal_density
    sys.modules.pop("grainmech.network.plotting", None)
    with pytest.warns(DeprecationWarning, match="grainmech.network.plotting is deprecated: it is grainmech.plots"):
        old_module = importlib.import_module("grainmech.network.plotting")
    assert old_module is plots
    with pytest.raises(AttributeError):
        network.no_such_name  # noqa: B018

"""``grainmech pack`` config (grainmech.io.pack_config.build_pack_config): strict keys, units,
errors naming the key and the value."""

import pytest

from grainmech.errors import ConfigError
from grainmech.io.pack_config import build_pack_config
from grainmech.packing import GLASS, QUARTZ, D50Cu, SieveCurve


def base(**over):
    cfg = {"grains": {"count": 500, "distribution": "d50-cu", "d50": "0.3 mm", "cu": 1.5},
           "preparation": {"stress": "100 kPa"}}
    for k, v in over.items():
        cfg.setdefault(k, {}).update(v)
    return cfg


def test_defaults_and_units():
    pc = build_pack_config(base())
    assert isinstance(pc.grading, D50Cu) and pc.grading.d50 == pytest.approx(3e-4)
    assert pc.settings.stress == (1e5, 1e5, 1e5)
    assert pc.material == QUARTZ and pc.settings.prep_friction == 0.0
    assert pc.n_grains == 500 and pc.max_size_ratio == 4.0


def test_glass_anisotropic_sieve():
    pc = build_pack_config({
        "grains": {"count": 100, "distribution": "sieve", "sizes": ["0.1 mm", "0.2 mm", "0.4 mm"],
                   "passing": [0, 40, 100]},
        "material": {"name": "glass", "friction": 0.3},
        "preparation": {"stress": ["100 kPa", "100 kPa", "0.2 MPa"], "friction": 0.3}})
    assert isinstance(pc.grading, SieveCurve)
    assert pc.material.shear_modulus == GLASS.shear_modulus and pc.material.friction == 0.3
    assert pc.settings.stress == (1e5, 1e5, 2e5)


@pytest.mark.parametrize("cfg, key", [
    (base(grains={"count": 10}), "grains.count"),
    (base(grains={"colour": "red"}), "grains.colour"),
    (base(preparation={"stress": "100 kg"}), "preparation.stress"),
    (base(preparation={"stress": "-5 kPa"}), "preparation.stress"),
    (base(preparation={"stress": ["1 kPa", "2 kPa"]}), "preparation.stress"),
    (base(material={"name": "granite"}), "material.name"),
    (base(material={"poisson": 0.7}), "material.poisson"),
    (base(grains={"cu": 0.5}), "grains.cu"),
])
def test_bad_values_name_the_key(cfg, key):
    with pytest.raises(ConfigError) as e:
        build_pack_config(cfg)
    assert e.value.key == key


def test_missing_stress():
    cfg = base()
    del cfg["preparation"]["stress"]
    with pytest.raises(ConfigError, match="preparation.stress"):
        build_pack_config(cfg)

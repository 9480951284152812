"""``[microstructure]``, the analytical microstructure's table, and ``[packing]``, its old name.

A config written before the rename still runs, with one warning naming the new table, and
gives the same numbers; both names at once are refused naming both; every message names
the key as the user wrote it.
"""

from __future__ import annotations

import copy
import tomllib
import warnings

import numpy as np
import pytest

from conftest import CYCLIC as RUN
from grainmech.errors import ConfigError
from grainmech.io.config import Section
from grainmech.io.schema import build_microstructure, microstructure_key, renamed_table_warnings
from grainmech.jobs import compute_stiffness, input_warnings, prepare_run, prepare_stiffness

WARNING = "[packing] is now [microstructure]; the old name is read until the next minor release"

STIFFNESS = """
[microstructure]
void_ratio = 0.62
coordination = "chang"
radius = "0.2 mm"
[fabric]
a20 = 0.3
[contacts]
law = "hertz-mindlin"
shear_modulus = "29 GPa"
poisson = 0.15
friction = 0.5
[stress]
pressure = "100 kPa"
"""



def _same(a, b) -> bool:
    """Two Microstructures are the same numbers (the density compared by its coefficients)."""
    return (np.array_equal(a.density.coefficients, b.density.coefficients)
            and (a.contacts_per_volume, a.branch_length, a.convention, a.radius)
            == (b.contacts_per_volume, b.branch_length, b.convention, b.radius))


def _old(cfg: dict) -> dict:
    """The same config with the table under its old name, in the same place."""
    return {("packing" if k == "microstructure" else k): copy.deepcopy(v) for k, v in cfg.items()}


def test_the_old_name_warns_and_gives_the_same_stiffness():
    new = tomllib.loads(STIFFNESS)
    old = _old(new)
    assert input_warnings(new) == [] and input_warnings(old) == [WARNING]
    a, b = compute_stiffness(new), compute_stiffness(old)
    assert np.array_equal(a.result.C, b.result.C)
    assert _same(a.microstructure, b.microstructure)


def test_the_old_name_warns_and_gives_the_same_run_spec():
    new = tomllib.loads(RUN)
    old = _old(new)
    a, b = prepare_run(new), prepare_run(old)
    assert WARNING in b.warnings and WARNING not in a.warnings
    assert _same(a.microstructure, b.microstructure) and a.void_ratio == b.void_ratio == 0.65
    assert [w for w in b.warnings if w != WARNING] == a.warnings


def test_both_names_are_refused_naming_both():
    cfg = tomllib.loads(RUN)
    cfg["packing"] = copy.deepcopy(cfg["microstructure"])
    for prepare in (prepare_run, prepare_stiffness):
        with pytest.raises(ConfigError) as e:
            prepare(cfg)
        assert e.value.key == "packing"
        assert str(e.value) == ("packing: [packing] and [microstructure] are the same table ([packing] is its old "
                                "name): keep [microstructure] only")
    with pytest.raises(ConfigError, match=r"^model\.packing: \[model\.packing\] and \[model\.microstructure\]"):
        microstructure_key(Section(cfg, "model"))


@pytest.mark.parametrize("table", ["microstructure", "packing"])
def test_messages_name_the_key_as_written(table):
    cfg = tomllib.loads(STIFFNESS)
    if table == "packing":
        cfg = _old(cfg)
    cfg[table]["void_ratio"] = -1
    with pytest.raises(ConfigError, match=rf"^{table}\.void_ratio = -1: must lie in"):
        prepare_stiffness(cfg)
    cfg[table]["void_ratio"] = 0.62
    cfg[table]["coordination"] = 2.0
    assert input_warnings(cfg)[-1].startswith(f"{table}.coordination = 2: outside 4-12")
    del cfg[table]["radius"]
    with pytest.raises(ConfigError, match=rf"^{table}\.radius: required key is missing"):
        prepare_stiffness(cfg)


def test_a_run_of_the_packing_model_refuses_the_table_by_its_name():
    cfg = _old(tomllib.loads(RUN))
    cfg["model"] = {"method": "packing", "packing": "dense"}
    with pytest.raises(ConfigError, match=r"^packing: \[packing\] describes the affine model's analytical"):
        prepare_run(cfg)


def test_a_missing_table_is_named_by_its_new_name():
    cfg = tomllib.loads(STIFFNESS)
    del cfg["microstructure"]
    with pytest.raises(ConfigError, match=r"^microstructure: "):
        prepare_stiffness(cfg)


def test_warnings_name_tables_inside_a_calibration_model():
    assert renamed_table_warnings({"packing": {}}, "model") == [
        "[model.packing] is now [model.microstructure]; the old name is read until the next minor release"]
    # a key named packing that is not a table (a rod array in a calibration) is not the old table
    assert renamed_table_warnings({"packing": "one-size"}) == []


def test_calibration_model_reads_either_name_with_the_same_prediction():
    from grainmech.calibrate.data import from_arrays
    from grainmech.calibrate.model import predict

    model = {"microstructure": {"void_ratio": 0.6, "coordination": 8.0, "radius": 1e-3}, "fabric": {"dim": 3},
             "contacts": {"law": "hertz-mindlin", "shear_modulus": 30e9, "poisson": 0.2}}
    data = from_arrays({"pressure": np.array([5e4, 1e5, 2e5]), "void_ratio": np.array([0.55, 0.6, 0.7]),
                        "G": np.ones(3)})
    a = predict("modulus-pressure", model, data, {})["G"]
    b = predict("modulus-pressure", _old(model), data, {})["G"]
    assert np.array_equal(a, b)
    both = dict(model, packing=model["microstructure"])
    with pytest.raises(ConfigError, match=r"^model\.packing: .*keep \[model\.microstructure\] only"):
        predict("modulus-pressure", both, data, {})


def test_sweep_keys_follow_the_base_configs_name():
    from grainmech.sweep import sweep_from_dict

    base = tomllib.loads(STIFFNESS)
    sweep = {"sweep": {"kind": "stiffness"}, "base": base,
             "parameters": {"packing.void_ratio": {"values": [0.6, 0.7]}}}
    with pytest.raises(ConfigError, match=r"^parameters\.packing\.void_ratio: the base config calls this table "
                                          r"\[microstructure\] .*write 'microstructure\.void_ratio'"):
        sweep_from_dict(sweep)
    old = dict(sweep, base=_old(base))
    sw = sweep_from_dict(old)
    assert [p.config["packing"]["void_ratio"] for p in sw.points] == [0.6, 0.7]


def test_site_layers_write_into_the_profiles_table():
    pytest.importorskip("distributed")
    from grainmech.site import read_profile

    prof = {"site": {"k0": 0.5}, "model": {"method": "affine"}, "packing": {"coordination": 8.0, "radius": "0.25 mm"},
            "contacts": tomllib.loads(RUN)["contacts"],
            "layers": [{"name": "top", "thickness": "4 m", "unit_weight": "18 kN/m^3", "void_ratio": 0.7}]}
    (layer,) = read_profile(copy.deepcopy(prof)).layers
    assert layer.run_config["packing"]["void_ratio"] == 0.7 and "microstructure" not in layer.run_config
    new = _old(prof)  # the other way round
    new["microstructure"] = new.pop("packing")
    (layer,) = read_profile(new).layers
    assert layer.run_config["microstructure"]["void_ratio"] == 0.7 and "packing" not in layer.run_config
    both = dict(prof, microstructure=prof["packing"])
    with pytest.raises(ConfigError, match=r"^packing: \[packing\] and \[microstructure\]"):
        read_profile(both)


def test_cli_prints_the_warning_and_refuses_both(tmp_path, cli):
    old = tmp_path / "old.toml"
    old.write_text(STIFFNESS.replace("[microstructure]", "[packing]"))
    res = cli("stiffness", str(old), "--json")
    assert res.rc == 0 and f"grainmech: warning: {WARNING}" in res.err
    both = tmp_path / "both.toml"
    both.write_text(STIFFNESS + STIFFNESS.split("[fabric]")[0].replace("[microstructure]", "[packing]"))
    res = cli("stiffness", str(both))
    assert res.rc == 2 and res.err.strip().splitlines() == [
        "grainmech: error: packing: [packing] and [microstructure] are the same table ([packing] is its old "
        "name): keep [microstructure] only"]


def test_build_packing_is_the_old_name_of_build_microstructure():
    from grainmech.io import schema

    with pytest.warns(DeprecationWarning, match="grainmech.io.schema.build_packing is deprecated: it is "
                                                "grainmech.io.schema.build_microstructure"):
        old = schema.build_packing
    assert old is build_microstructure
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert schema.build_microstructure is build_microstructure

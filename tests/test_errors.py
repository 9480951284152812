"""One exception rule: ParameterError for library arguments, ConfigError where config is read."""

from __future__ import annotations

import pickle

import pytest

from grainmech import contact, fabric
from grainmech.errors import ConfigError, GrainmechError, ParameterError
from grainmech.io.config import Section
from grainmech.io.schema import build_law, build_microstructure


def test_both_are_user_errors_with_the_same_message_form():
    for cls in (ParameterError, ConfigError):
        assert issubclass(cls, GrainmechError) and issubclass(cls, ValueError)
    assert not issubclass(ParameterError, ConfigError) and not issubclass(ConfigError, ParameterError)
    assert str(ParameterError("poisson", 0.7, "must lie in (-1, 0.5)")) == "poisson = 0.7: must lie in (-1, 0.5)"
    assert str(ConfigError("contacts.poisson", None, "required key is missing")) == \
        "contacts.poisson: required key is missing"


@pytest.mark.parametrize("exc", [ParameterError("kn", -1.0, "must be > 0"), ConfigError("a.kn", -1.0, "must be > 0")])
def test_errors_survive_pickling(exc):
    """Sweeps and calibrations send errors between Dask processes."""
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc) and str(back) == str(exc) and back.value == -1.0


def test_library_calls_raise_parameter_error_naming_the_argument():
    with pytest.raises(ParameterError) as e:
        contact.HertzMindlin(shear_modulus=-1.0, poisson=0.2, radius1=1e-3, friction=0.5)
    assert e.value.name == "shear_modulus" and e.value.value == -1.0
    assert not isinstance(e.value, ConfigError)
    with pytest.raises(ParameterError, match="void_ratio"):
        fabric.coordination_number(5.0, "chang")


def test_config_readers_rename_library_errors_to_the_file_key():
    """Values the reader passes on unchecked come back as ConfigError naming the file's key."""
    law = {"law": "mindlin-deresiewicz", "shear_modulus": 1e9, "poisson": 0.2, "friction": 0.5,
           "max_reversals": 5000}  # the law's own limit (4096), not the reader's
    with pytest.raises(ConfigError) as e:
        build_law(Section(law, "contacts"), radius=1e-3)
    assert e.value.key == "contacts.max_reversals" and e.value.value == 5000
    with pytest.raises(ConfigError) as e:
        build_microstructure(Section({"void_ratio": 5.0, "coordination": "chang", "radius": 1e-3}, "microstructure"),
                             fabric.isotropic(3))
    assert e.value.key == "microstructure.void_ratio" and e.value.value == 5.0


def test_section_checked_names_the_key_or_the_section():
    sec = Section({"fit_order": 3}, "fabric")
    with pytest.raises(ConfigError) as e, sec.checked({"order": "fit_order"}):
        raise ParameterError("order", 3, "must be even")
    assert e.value.key == "fabric.fit_order" and str(e.value) == "fabric.fit_order = 3: must be even"
    with pytest.raises(ConfigError) as e, sec.checked():
        raise ParameterError("N", "array of shape (4,)", "must be (d, d)")
    assert e.value.key == "fabric" and "N = 'array of shape (4,)': must be (d, d)" in str(e.value)
    with pytest.raises(GrainmechError, match="not a parameter error") as e, sec.checked():
        raise GrainmechError("not a parameter error")
    assert not isinstance(e.value, ConfigError)


def test_cli_message_names_the_key_and_value(cli, tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[microstructure]\nvoid_ratio = 5.0\ncoordination = "chang"\nradius = "1 mm"\n')
    r = cli("stiffness", cfg)
    assert r.rc == 2
    assert "microstructure.void_ratio = 5.0" in r.err and "Traceback" not in r.err

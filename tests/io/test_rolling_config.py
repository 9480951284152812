"""Rolling and twisting resistance in a ``grainmech run`` config (``[contacts]``
``rolling_friction``, ``rolling_stiffness``, ``twisting_friction``): what the run spec
carries (``RunSpec.rolling``), what is refused before any model runs (ConfigError naming
the key and the value, exit status 2), and the affine model saying it is inert there."""

import copy
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from conftest import default_run_affine
from grainmech.contact.rolling import RollingResistance
from grainmech.errors import ConfigError
from grainmech.jobs.run_config import prepare_run


def _default() -> dict:
    """The smooth-quartz run config (no rolling keys; ``tests/data/smooth_quartz_run.toml``)."""
    return tomllib.loads((Path(__file__).resolve().parents[1] / "data" / "smooth_quartz_run.toml").read_text())


def _affine(**contacts) -> dict:
    cfg = tomllib.loads(default_run_affine())
    cfg["test"]["amplitudes"] = [1e-5, 1e-4]
    cfg["test"]["steps_per_cycle"] = 8
    cfg["contacts"].update(contacts)
    return cfg


def _packing(**contacts) -> dict:
    cfg = _default()
    cfg["model"] = {"method": "packing", "packing": "dense"}
    del cfg["microstructure"]
    cfg["contacts"].update(contacts)
    return cfg


def test_keys_absent_or_zero_give_no_rolling():
    assert prepare_run(_packing()).rolling is None
    assert prepare_run(_packing(rolling_friction=0.0)).rolling is None
    assert prepare_run(_packing(rolling_friction=0, twisting_friction=0)).rolling is None


def test_spec_carries_the_rolling_resistance():
    r = prepare_run(_packing(rolling_friction=0.1)).rolling
    assert r == RollingResistance(0.1)
    assert r.stiffness is None and r.mu_twist == 0.1
    r = prepare_run(_packing(rolling_friction=0.1, rolling_stiffness="2e5 N/m", twisting_friction=0.05)).rolling
    assert r == RollingResistance(0.1, 2e5, 0.05)
    r = prepare_run(_packing(rolling_friction=0.1, rolling_stiffness="0.2 MN/m")).rolling
    assert r.stiffness == pytest.approx(2e5)
    # twisting resistance alone
    r = prepare_run(_packing(rolling_friction=0, twisting_friction=0.05)).rolling
    assert r is not None and r.friction == 0 and r.mu_twist == 0.05


@pytest.mark.parametrize(("contacts", "match"), [
    ({"rolling_friction": -0.1}, r"contacts\.rolling_friction = -0\.1: must lie in \[0, inf\)"),
    ({"rolling_friction": float("nan")}, r"contacts\.rolling_friction = nan: must be finite"),
    ({"rolling_friction": "nan"}, r"contacts\.rolling_friction = 'nan': must be finite"),
    ({"rolling_friction": "1 deg"}, r"contacts\.rolling_friction = '1 deg': is a dimensionless coefficient"),
    ({"rolling_friction": True}, r"contacts\.rolling_friction = True"),
    ({"rolling_friction": 0.1, "twisting_friction": "5 deg"}, r"contacts\.twisting_friction = '5 deg'"),
    ({"rolling_friction": 0.1, "twisting_friction": -1}, r"contacts\.twisting_friction = -1"),
    ({"rolling_friction": 0.1, "rolling_stiffness": 0}, r"contacts\.rolling_stiffness = 0: must lie in \(0, inf\)"),
    ({"rolling_friction": 0.1, "rolling_stiffness": "1 m"}, r"contacts\.rolling_stiffness = '1 m': has units"),
    ({"rolling_friction": 0.1, "rolling_stiffness": -5e5}, r"contacts\.rolling_stiffness = -500000"),
    ({"twisting_friction": 0.1}, r"contacts\.twisting_friction = 0\.1: needs contacts\.rolling_friction"),
    ({"rolling_frictoin": 0.1}, r"contacts\.rolling_frictoin = 0\.1: unknown key"),
])
def test_bad_values_name_the_key_and_value(contacts, match):
    with pytest.raises(ConfigError, match=match):
        prepare_run(_packing(**contacts))


def test_linear_springs_without_ks_need_a_rolling_stiffness():
    cfg = _packing(rolling_friction=0.1)
    cfg["test"] = {"kind": "path", "segments": [{"control": "EEEEEE", "change": [0, 0, 0, 0, 1e-6, 0],
                                                 "steps": 2}]}
    del cfg["reference"]
    cfg["contacts"] = {"law": "linear", "kn": 1e6, "ks": 0, "rolling_friction": 0.1}
    with pytest.raises(ConfigError, match=r"contacts\.rolling_friction = 0\.1: law = 'linear' with ks = 0"):
        prepare_run(cfg)
    cfg["contacts"]["rolling_stiffness"] = 1e5  # given: linear springs carry it
    assert prepare_run(cfg).rolling == RollingResistance(0.1, 1e5)


def test_laws_that_cannot_carry_contact_moments_are_refused():
    from grainmech.io.config import Section
    from grainmech.io.schema import LAWS, build_law, build_rolling

    sec = Section({"law": "hertz", "shear_modulus": "44 GPa", "poisson": 0.08, "rolling_friction": 0.1}, "contacts")
    law = build_law(sec, 1e-4, laws=LAWS, rolling=True)
    with pytest.raises(ConfigError, match=r"contacts\.rolling_friction = 0\.1: law = 'hertz' is frictionless"):
        build_rolling(sec, law)
    sec = Section({"law": "cylinder", "shear_modulus_equiv": "1 GPa", "poisson": 0.2, "psi": 1.0,
                   "friction_angle": "20 deg", "rolling_friction": 0.2}, "contacts")
    law = build_law(sec, 1e-3, laws=("cylinder",), rolling=True)
    with pytest.raises(ConfigError, match=r"contacts\.rolling_friction = 0\.2: law = 'cylinder' \(rods"):
        build_rolling(sec, law)


def test_commands_without_grain_rotations_refuse_the_keys():
    from grainmech.jobs.stiffness import prepare_stiffness

    cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_stiffness.toml").read_text())
    cfg.setdefault("contacts", {})["rolling_friction"] = 0.1
    with pytest.raises(ConfigError, match=r"contacts\.rolling_friction = 0\.1: rolling and twisting resistance "
                                          r"needs grain rotations"):
        prepare_stiffness(cfg)


def test_cli_exit_status_2_before_any_model_runs(tmp_path, cli):
    text = default_run_affine().replace('friction = 0.5', 'friction = 0.5\nrolling_friction = "1 deg"')
    (tmp_path / "c.toml").write_text(text)
    r = cli("run", tmp_path / "c.toml", "-o", tmp_path / "out", "--quiet")
    assert r.rc == 2
    assert "contacts.rolling_friction = '1 deg'" in r.err
    assert not (tmp_path / "out").exists()


def test_affine_model_says_rolling_is_inert(tmp_path, cli):
    spec = prepare_run(_affine(rolling_friction=0.1))
    assert spec.rolling == RollingResistance(0.1)
    assert any("inert in the affine model" in w for w in spec.warnings)
    text = default_run_affine().replace('friction = 0.5', 'friction = 0.5\nrolling_friction = 0.1')
    text = text.replace("amplitudes = [1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3]", "amplitudes = [1e-5, 1e-4]")
    (tmp_path / "c.toml").write_text(text)
    r = cli("run", tmp_path / "c.toml", "-o", tmp_path / "out", "--quiet")
    assert r.rc == 0, r.err
    assert "grainmech: warning: contacts.rolling_friction = 0.1: rolling and twisting resistance is inert in " \
           "the affine model" in r.err
    import json

    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert any("inert in the affine model" in n for n in summary["details"]["notes"])


def test_affine_numbers_do_not_move():
    """mu_r > 0 is inert in the affine model and mu_r = 0 is no rolling at all: the same numbers."""
    from grainmech.jobs.run import execute_run

    base = execute_run(prepare_run(_affine()))
    for extra in ({"rolling_friction": 0.0}, {"rolling_friction": 0.3, "twisting_friction": 0.1}):
        out = execute_run(prepare_run(_affine(**extra)))
        np.testing.assert_array_equal(out.G, base.G)
        np.testing.assert_array_equal(out.damping, base.damping)
        assert out.G_max == base.G_max


def test_no_warning_with_packing_alone():
    spec = prepare_run(_packing(rolling_friction=0.1))
    assert not any("inert" in w for w in spec.warnings)


def test_default_config_unchanged():
    cfg = _default()
    before = copy.deepcopy(cfg)
    spec = prepare_run(cfg)
    assert spec.rolling is None
    assert cfg == before


def test_built_in_default_carries_the_chosen_rolling_friction():
    """The built-in default models a sand: mu_r = 0.25 (docs/contact-laws.md), said inert for
    the affine model, carried by the packing and DEM models, on the sand packing 'nevada-medium'."""
    cfg = tomllib.loads(resources.files("grainmech.data").joinpath("default_run.toml").read_text())
    spec = prepare_run(cfg)
    assert spec.rolling == RollingResistance(0.25)
    assert cfg["model"]["packing"] == "nevada-medium"
    assert any("inert in the affine model" in w for w in spec.warnings)

"""One config schema per concept: one reader of the contact law for every command, one
name for the grain radius, constant stiffnesses through ``LinearSpring``, the isotropic
fabric with the smallest exact quadrature rule, and messages that name the key."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from grainmech.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "src" / "grainmech" / "data"
EX = ROOT / "examples"


def _toml(path: Path) -> dict:
    return tomllib.loads(path.read_text())


def _stiffness_cfg() -> dict:
    return _toml(DATA / "default_stiffness.toml")


# ------------------------------------------------------------------------- angles
def test_stiffness_config_bare_angle_rejected_and_units_agree():
    """`grainmech stiffness` reads the contact law with the same reader as `run`, so its
    friction_angle follows the one angle rule (docs/config.md)."""
    from grainmech.jobs import compute_stiffness, prepare_stiffness

    cfg = _stiffness_cfg()
    cfg["contacts"]["friction_angle"] = 24
    with pytest.raises(ConfigError, match=r"contacts\.friction_angle = 24: an angle needs its unit: "
                                          r"write e\.g\. '24 deg' or '24 rad'"):
        prepare_stiffness(cfg)
    cfg["contacts"]["friction_angle"] = "24 deg"
    a = prepare_stiffness(cfg).contacts
    cfg["contacts"]["friction_angle"] = f"{math.radians(24)!r} rad"
    b = prepare_stiffness(cfg).contacts
    assert a == b and a.friction == pytest.approx(math.tan(math.radians(24)), rel=1e-15)
    np.testing.assert_array_equal(compute_stiffness(cfg).result.C, compute_stiffness(
        {**cfg, "contacts": {**cfg["contacts"], "friction_angle": "24 deg"}}).result.C)


def test_sweep_base_with_a_bare_angle_is_rejected(tmp_path):
    from grainmech.sweep.spec import load_sweep

    text = (EX / "sweep_cyclic_gmax.toml").read_text()
    assert 'friction_angle = "27 deg"' in text
    bad = tmp_path / "s.toml"
    bad.write_text(text.replace('min = "20 deg"', "min = 20"))
    with pytest.raises(ConfigError, match=r"parameters\.contacts\.friction_angle\.min = 20: an angle needs its unit"):
        load_sweep(bad)
    bad.write_text(text.replace('min = "20 deg"', 'min = "20 deg"\nunit = "rad"')
                   .replace('max = "35 deg"', "max = 0.6"))
    assert load_sweep(bad, check=False).parameters[-1].unit == "rad"  # a stated unit applies


def test_shipped_configs_have_no_bare_angle():
    """Every example and built-in config carries the unit of every angle key."""
    def walk(node, where):
        if isinstance(node, dict):
            for k, v in node.items():
                if "angle" in k and not isinstance(v, dict):
                    assert isinstance(v, str), f"{where}.{k} = {v!r}"
                walk(v, f"{where}.{k}")
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, f"{where}[{i}]")

    files = sorted(EX.glob("*.toml")) + sorted(DATA.glob("*.toml"))
    assert len(files) >= 10
    for f in files:
        walk(_toml(f), f.name)


# --------------------------------------------------------------------- contact law
def test_one_reader_for_the_contact_law():
    """The same law table gives the same object in `stiffness`, `run` and `contact`
    (whose table names the grain radius itself, `radius`, as packing.radius does)."""
    from grainmech.contact import HertzMindlin
    from grainmech.io.config import Section
    from grainmech.io.schema import LAWS, build_law
    from grainmech.jobs import prepare_run, prepare_stiffness

    table = {"law": "hertz-mindlin", "shear_modulus": "44 GPa", "poisson": 0.08, "friction": 0.5}
    cfg = _stiffness_cfg()
    cfg["contacts"] = dict(table)
    st = prepare_stiffness(cfg).contacts
    run_cfg = _toml(DATA / "default_run.toml")
    run_cfg["contacts"] = dict(table)
    run_cfg["microstructure"]["radius"] = cfg["microstructure"]["radius"]
    rn = prepare_run(run_cfg).law
    one = build_law(Section({**table, "radius": cfg["microstructure"]["radius"]}, "contact"), None, laws=LAWS)
    assert st == rn == one == HertzMindlin(44e9, 0.08, 0.25e-3, friction=0.5)


def test_radius_has_one_name():
    from grainmech.io.config import Section
    from grainmech.io.schema import LAWS, build_law
    from grainmech.jobs import prepare_run

    sec = Section({"law": "hertz", "shear_modulus": "1 GPa", "poisson": 0.2, "radius1": "1 mm"}, "contact")
    with pytest.raises(ConfigError, match=r"^contact\.radius1 = '1 mm': renamed: write 'radius'"):
        build_law(sec, None, laws=LAWS)
    cfg = _toml(DATA / "default_run.toml")
    cfg["contacts"]["radius"] = "1 mm"
    with pytest.raises(ConfigError, match=r"contacts\.radius = '1 mm': the grain radius is "
                                          r"microstructure\.radius \(or the grains' own\)"):
        prepare_run(cfg)


def test_linear_spring_is_the_constant_stiffness_law():
    """`packing_stiffness(pk, LinearSpring(kn, ks))` needs no stress. Isotropic fabric,
    physical counting (Chang 1988 Eq. 4.21-4.22 with a20 = 0; Walton 1987 for springs):
    K = Nv l^2 kn / 9, G = Nv l^2 (2 kn + 3 ks) / 30."""
    import grainmech.material as material
    from grainmech.contact import LinearSpring
    from grainmech.elasticity import bulk_modulus, shear_modulus
    from grainmech.fabric import isotropic
    from grainmech.material import Packing, packing_stiffness

    assert not hasattr(material, "ConstantStiffness")
    nv, l, kn, ks = 2.0e9, 5e-4, 3e6, 1e6
    res = packing_stiffness(Packing(isotropic(3), nv, l), LinearSpring(kn, ks))
    assert bulk_modulus(res.C, "voigt") == pytest.approx(nv * l**2 * kn / 9, rel=1e-12)
    assert shear_modulus(res.C, "voigt") == pytest.approx(nv * l**2 * (2 * kn + 3 * ks) / 30, rel=1e-12)
    assert len(res.contacts) == 14  # degree-4 integrand x order-0 density: Lebedev 14 points
    with pytest.raises(Exception, match="stress"):
        from grainmech.contact import HertzMindlin
        packing_stiffness(Packing(isotropic(3), nv, l), HertzMindlin(1e9, 0.2, 1e-3))


def test_linear_config_gives_a_linear_spring():
    from grainmech.contact import LinearSpring
    from grainmech.jobs import compute_stiffness, prepare_stiffness

    cfg = _toml(EX / "stiffness_seed_fig4_4_orthotropic.toml")
    spec = prepare_stiffness(cfg)
    assert isinstance(spec.contacts, LinearSpring)
    assert np.all(np.isfinite(compute_stiffness(cfg).result.C))


@pytest.mark.parametrize("fabric", [{"dim": 3}, {}, {"a20": 0.0}, {"tensor": [[1 / 3, 0, 0], [0, 1 / 3, 0],
                                                                              [0, 0, 1 / 3]]}])
def test_isotropic_fabric_uses_the_14_point_rule(fabric):
    """An isotropic fabric under an isotropic stress gives uniform forces: the stiffness
    integrand is of degree 4, exact with Lebedev's 14 points (it used 770 when the config
    built an order-2 density with zero coefficients)."""
    from grainmech.jobs import compute_stiffness

    cfg = _stiffness_cfg()
    cfg["fabric"] = fabric
    out = compute_stiffness(cfg)
    assert len(out.result.contacts) == 14
    cfg["fabric"] = {"a20": 1e-9}  # not isotropic: varying forces, high-degree rule
    ref = compute_stiffness(cfg)
    assert len(ref.result.contacts) > 14
    np.testing.assert_allclose(out.result.C, ref.result.C, rtol=1e-7, atol=1e-7 * ref.result.C.max())


# ------------------------------------------------------------------------ messages
def test_misspelt_required_key_is_named_with_a_suggestion():
    from grainmech.jobs import prepare_stiffness

    cfg = _stiffness_cfg()
    cfg["contacts"]["poison"] = cfg["contacts"].pop("poisson")
    with pytest.raises(ConfigError) as exc:
        prepare_stiffness(cfg)
    assert str(exc.value) == "contacts.poison = 0.08: unknown key 'poison' (did you mean 'poisson'?)"


def test_misspelt_optional_key_is_named_with_a_suggestion():
    from grainmech.jobs import prepare_stiffness

    cfg = _stiffness_cfg()
    cfg["microstructure"]["conventon"] = "seed"
    with pytest.raises(ConfigError, match=r"microstructure\.conventon = 'seed': unknown key 'conventon' "
                                          r"\(did you mean 'convention'\?\)"):
        prepare_stiffness(cfg)


def test_no_message_says_none():
    from grainmech.jobs import prepare_run, prepare_stiffness

    cfg = _stiffness_cfg()
    del cfg["microstructure"]["void_ratio"]
    with pytest.raises(ConfigError) as exc:
        prepare_stiffness(cfg)
    assert str(exc.value) == "microstructure.void_ratio: required key is missing"
    run = _toml(DATA / "default_run.toml")
    del run["contacts"]["friction"]
    with pytest.raises(ConfigError) as exc:
        prepare_run(run)
    assert "None" not in str(exc.value) and str(exc.value).startswith("contacts.friction: is required")
    assert str(ConfigError("a.b", None, "x")) == "a.b: x"
    assert str(ConfigError("a.b", 0, "x")) == "a.b = 0: x"


def test_quadrature_degree_131_accepted_and_beyond_named():
    """docs/config.md: quadrature.degree up to 131 (the highest Lebedev rule) for an
    isotropic fabric; beyond it, the message names the key and the limit."""
    from grainmech.jobs import prepare_run

    cfg = _toml(DATA / "default_run.toml")
    cfg["quadrature"] = {"degree": 131}
    assert prepare_run(cfg).degree == 131
    cfg["quadrature"] = {"degree": 133}
    with pytest.raises(ConfigError, match=r"quadrature\.degree = 133: must be <= 131"):
        prepare_run(cfg)
    aniso = copy.deepcopy(cfg)
    aniso["fabric"] = {"a20": 0.2}
    aniso["quadrature"] = {"degree": 131}
    with pytest.raises(ConfigError, match=r"quadrature\.degree = 131: must be <= 129 for this fabric "
                                          r"\(density of order 2\)"):
        prepare_run(aniso)

"""The model registry (:mod:`grainmech.driver.registry`): one :class:`KinematicModel` per
model, what the jobs dispatch through instead of comparing a model's name."""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest

from grainmech.driver.base import KinematicModel
from grainmech.driver.registry import MODELS, model, resolve
from grainmech.errors import ConfigError, ParameterError

SRC = Path(__file__).resolve().parents[2] / "src" / "grainmech"

#: the protocol's attributes and their types
ATTRIBUTES = {"name": str, "title": str, "needs_grains": bool, "settings_section": (str, type(None)),
              "amplitudes_key": (str, type(None)), "steps_per_cycle_key": (str, type(None)),
              "max_amplitude": float, "upper_bound": bool, "fixed_geometry": bool, "takes_over": bool,
              "engine": (str, type(None)), "envelope_note": str}


@pytest.mark.parametrize("name", list(MODELS))
def test_every_registered_model_keeps_the_protocol(name: str) -> None:
    m = MODELS[name]
    assert isinstance(m, KinematicModel)
    assert m.name == name and model(name) is m and resolve(m) is m and resolve(name) is m
    for attr, typ in ATTRIBUTES.items():
        assert isinstance(getattr(m, attr), typ), attr
    assert m.max_amplitude > 0
    for method in ("series", "path", "details"):
        assert callable(getattr(m, method))
    # the flags are exclusive: an upper bound has no grains to hand over or take over
    assert not (m.upper_bound and (m.fixed_geometry or m.takes_over or m.needs_grains))
    assert not (m.fixed_geometry and m.takes_over)


def test_the_registry_holds_the_three_models_of_a_run_in_order() -> None:
    from grainmech.jobs import RUN_METHODS
    from grainmech.jobs.run import MODEL_JOBS

    assert list(MODELS) == ["affine", "packing", "dem"] and RUN_METHODS == tuple(MODELS)
    assert set(MODEL_JOBS) == set(MODELS.values())  # every model has its job, no job without a model
    # one model hands over, one takes over, one is the upper bound
    assert [m.name for m in MODELS.values() if m.fixed_geometry] == ["packing"]
    assert [m.name for m in MODELS.values() if m.takes_over] == ["dem"]
    assert [m.name for m in MODELS.values() if m.upper_bound] == ["affine"]


@pytest.mark.parametrize("name", ["fem", "Affine", ""])
def test_an_unknown_model_names_the_known_ones(name) -> None:  # noqa: ANN001
    with pytest.raises(ParameterError) as err:
        model(name)
    assert str(err.value) == f"method = {name!r}: is not a kinematic model: the known ones are " \
                             "['affine', 'packing', 'dem']"


def test_an_unknown_method_in_a_config_is_one_line_naming_the_known_ones() -> None:
    from grainmech.jobs import prepare_run

    with pytest.raises(ConfigError, match=r"^model\.method = 'fem': must be one of \['affine', 'packing', 'dem'\]"):
        prepare_run({"model": {"method": "fem"}})


#: a string literal naming a model, compared (==, !=, in, not in) with something
_NAME = r"[\"'](?:affine|packing|dem)[\"']"
_COMPARISON = re.compile(rf"(?:==|!=)\s*{_NAME}|{_NAME}\s*(?:==|!=|not\s+in\b|in\b)|\bin\s*\(\s*{_NAME}")
#: ``for k in ("packing", "network", ...)``: a loop over config keys, not a comparison
_LOOP = re.compile(rf"\bfor\s+\w+\s+in\s*\(\s*{_NAME}")


def method_name_comparisons(root: Path = SRC) -> list[str]:
    """``path:line: code`` of every comparison of a model's name in the source (code only, not text)."""
    found = []
    for path in sorted(root.rglob("*.py")):
        text = path.read_text()
        lines = text.splitlines()
        tokens = tokenize.generate_tokens(io.StringIO(text).readline)
        # the lines that hold code (a docstring or comment naming a model compares nothing)
        code_lines = {t.start[0] for t in tokens if t.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE,
                                                                  tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER)
                      and not (t.type == tokenize.STRING and t.string.startswith(('"""', "'''")))}
        for k in sorted(code_lines):
            line = lines[k - 1].split("#")[0]
            if _COMPARISON.search(line) and not _LOOP.search(line):
                found.append(f"{path.relative_to(root.parent)}:{k}: {line.strip()}")
    return found


def test_the_counter_finds_a_comparison_and_skips_text(tmp_path: Path) -> None:
    (tmp_path / "m.py").write_text('"""A "packing" in text."""\n\nif method == "dem":\n    pass\n'
                                   'x = "affine" in methods  # "dem" in a comment\n'
                                   'for k in ("packing", "network"):\n    pass\n')
    assert [f.split(": ", 1)[1] for f in method_name_comparisons(tmp_path)] == ['if method == "dem":',
                                                                             'x = "affine" in methods']


def test_at_most_three_comparisons_of_a_model_name_remain() -> None:
    """The jobs, the CLI, the outcomes and the writer ask a model's attributes (upper_bound,
    fixed_geometry, takes_over, needs_grains, engine, ...: grainmech.driver.registry), not its
    name; the few left read a config."""
    found = method_name_comparisons()
    assert len(found) <= 3, "compare a model's attributes, not its name:\n" + "\n".join(found)

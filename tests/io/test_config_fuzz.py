"""Hypothesis-generated bad config values: every bad file gives a clear error, never a crash."""

import json
import math

from _hyp import HealthCheck, given, settings, st

BASE = {
    "microstructure": {"void_ratio": 0.6, "coordination": 8, "radius": "0.2 mm"},
    "fabric": {"a20": 0.2, "a22": 0.05, "b22": 0.0},
    "contacts": {"law": "hertz-mindlin", "shear_modulus": "30 GPa", "poisson": 0.2},
    "stress": {"pressure": "100 kPa"},
}
KEYS = [(t, k) for t, tab in BASE.items() for k in tab]

bad_values = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-10**6, 10**6),
    st.booleans(),
    st.text(max_size=12),
    st.sampled_from(["15 parsecs", "3 kg", "-1 MPa", "nan", "inf", "1e999 Pa", "0.2 mm mm", "abc deg"]),
    st.lists(st.floats(allow_nan=False), max_size=3),
)


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        body = json.dumps(v, ensure_ascii=False)[1:-1]
        # TOML forbids raw control characters (incl. DEL) in basic strings: escape them
        return '"' + "".join(f"\\u{ord(c):04x}" if ord(c) < 0x20 or ord(c) == 0x7F else c for c in body) + '"'
    return "[" + ", ".join(_toml_value(x) for x in v) + "]"


def _dump(cfg):
    out = []
    for t, tab in cfg.items():
        out.append(f"[{t}]")
        out += [f"{k} = {_toml_value(v)}" for k, v in tab.items()]
    return "\n".join(out) + "\n"


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(KEYS + [("microstructure", "unknown_key"), ("contacts", "frictoin")]), value=bad_values)
def test_bad_values_give_one_line_error_naming_the_key(tmp_path, key, value, cli):
    cfg = {t: dict(tab) for t, tab in BASE.items()}
    cfg[key[0]][key[1]] = value
    path = tmp_path / "fuzz.toml"
    path.write_text(_dump(cfg), encoding="utf-8")
    res = cli("stiffness", str(path), "--json")
    rc = res.rc
    out, err = res.out, res.err
    assert "Traceback" not in err
    if rc == 0:  # the value happened to be valid (e.g. a plausible number): output must be finite
        assert "NaN" not in out and "Infinity" not in out
        return
    assert rc == 2
    # the error is one line (absurd magnitudes may also print NumPy overflow warnings before it)
    last = err.strip().splitlines()[-1]
    assert last.startswith("grainmech: error:")
    assert f"{key[0]}.{key[1]}" in last or key[1] in last or "negative" in last or "tension" in last, err


def test_base_config_is_valid(tmp_path, cli):
    p = tmp_path / "ok.toml"
    p.write_text(_dump(BASE))
    assert cli("stiffness", str(p), "--json").rc == 0


import pytest  # noqa: E402


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize(("key", "value", "named"), [
    (("microstructure", "coordination"), 2.225073858507e-311, "microstructure.coordination"),
    (("microstructure", "coordination"), 9.638604024989455e+297, "microstructure.coordination"),
    (("microstructure", "coordination"), 1e-4, "microstructure.coordination"),
    (("fabric", "a22"), 3.068012262549445e+154, "negative"),
    (("fabric", "b22"), 1.7e308, "negative"),
])
def test_values_found_by_the_fuzzer_are_refused_without_warnings(tmp_path, cli, key, value, named):
    """Values the hypothesis test above drew (a subnormal and a huge coordination number,
    fabric coefficients near the float range) gave NaN forces or overflow warnings before
    the error. The coordination number is now bounded to [1e-3, 1e3] (far outside every
    packing) and impossible fabric coefficients are refused before any evaluation: one
    error line, no RuntimeWarning."""
    cfg = {t: dict(tab) for t, tab in BASE.items()}
    cfg[key[0]][key[1]] = value
    path = tmp_path / "found.toml"
    path.write_text(_dump(cfg), encoding="utf-8")
    res = cli("stiffness", str(path), "--json")
    assert res.rc == 2
    lines = res.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("grainmech: error:") and named in lines[0], res.err

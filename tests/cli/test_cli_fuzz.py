"""A seeded fuzz of the commands' configs through the command line, in-process.

Each case takes a small valid config of one command, replaces one value with a drawn one
(absurd magnitudes, NaN and infinity, units on dimensionless keys, negative or zero
counts, long names, empty or truncated files) and runs ``grainmech <command>``. Whatever
the value, the command must

* end with status 0, 1 or 2 and never print a traceback;
* write no ``nan`` or ``inf`` into a CSV or JSON file (a ratio that is unbounded is an
  empty cell with a flag column);
* leave nothing in the output folder when it refuses the input (status 2).

Commands that would run LAMMPS or a local Dask cluster (``run`` with the packing and DEM
models, ``pack``, ``calibrate``) carry one more bad value read after the drawn one, so
they stop at validation; ``run`` (affine), ``site`` (affine), ``stiffness``, ``contact``,
``sweep`` and ``dem`` run the accepted cases with tiny sizes.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from pathlib import Path

from _hyp import HealthCheck, given, settings, st

# ------------------------------------------------------------------ configs
RUN = {
    "microstructure": {"void_ratio": 0.65, "coordination": "chang", "radius": "0.25 mm"},
    "contacts": {"law": "mindlin-deresiewicz", "shear_modulus": "44 GPa", "poisson": 0.08, "friction": 0.5},
    "initial": {"pressure": "100 kPa"},
    "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-5], "n_cycles": 2, "steps_per_cycle": 8},
    "quadrature": {"degree": 5},
}
PATH = {
    "microstructure": RUN["microstructure"], "contacts": RUN["contacts"], "initial": RUN["initial"],
    "quadrature": {"degree": 5},
    "test": {"kind": "path", "segments": [{"control": "SSEEEE", "change": [0, 0, 1e-4, 0, 0, 0], "steps": 4}]},
}
GRAINS = {  # packing / DEM model: n_cycles = 1 (read after the model's keys) stops them at validation
    "model": {"method": "dem", "packing": "dense", "dem_steps_per_cycle": 16, "dem": {"tol": 1e-4}},
    "contacts": {"law": "hertz-mindlin", "shear_modulus": "29 GPa", "poisson": 0.15, "friction": 0.5},
    "initial": {"pressure": "100 kPa"},
    "test": {"kind": "cyclic-simple-shear", "amplitudes": [1e-4], "n_cycles": 1, "steps_per_cycle": 8},
}
SITE = {
    "site": {"k0": 0.5},
    "model": {"method": "affine"},
    "microstructure": RUN["microstructure"], "contacts": RUN["contacts"], "quadrature": {"degree": 5},
    "test": {"amplitudes": [1e-5], "n_cycles": 2, "steps_per_cycle": 8},
    "layers": [{"name": "sand", "thickness": "4 m", "unit_weight": "19 kN/m^3", "vs": "150 m/s"}],
    "bedrock": {"vs": "760 m/s", "unit_weight": "22 kN/m^3", "damping": 0.01},
    "motion": {"file": "motion.at2", "format": "peer"},
}
PACK = {  # [preparation] max_steps = 1 (read after the rest) stops it at validation
    "grains": {"count": 60, "distribution": "d50-cu", "d50": "0.3 mm", "cu": 1.5, "max_size_ratio": 3},
    "material": {"name": "quartz", "density": "2650 kg/m^3", "shear_modulus": "29 GPa"},
    "preparation": {"stress": "100 kPa", "friction": 0.0, "max_steps": 1},
}
STIFFNESS = {
    "microstructure": {"void_ratio": 0.6, "coordination": 8, "radius": "0.2 mm"},
    "fabric": {"a20": 0.2, "a22": 0.05, "b22": 0.0},
    "contacts": {"law": "hertz-mindlin", "shear_modulus": "30 GPa", "poisson": 0.2},
    "stress": {"pressure": "100 kPa"},
}
CONTACT = {
    "contact": {"law": "linear", "kn": "1e6 N/m", "ks": "5e5 N/m", "friction": 0.5},
    "initial": {"normal_force": "10 N"},
    "path": [{"kind": "cycles", "count": 1, "steps": 8, "tangential_force_amplitude": "1 N"}],
}
SWEEP = {
    "sweep": {"kind": "stiffness", "design": "latin-hypercube", "samples": 2, "seed": 1},
    "base": STIFFNESS,
    "parameters": {"stress.pressure": {"min": "50 kPa", "max": "200 kPa"}},
}
CALIBRATE = {  # an unknown [fit] key (read last) stops it before the Dask cluster starts
    "data": {"kind": "modulus-pressure"},
    "model": {"microstructure": {"void_ratio": 0.65, "radius": "0.01 in", "coordination": 8},
              "fabric": {"dim": 3}, "contacts": {"law": "hertz-mindlin", "shear_modulus": "7.5e6 psi",
                                                   "poisson": 0.13}},
    "parameters": [{"path": "contacts.shear_modulus", "start": "1e5 psi", "lower": "1e3 psi", "upper": "1e9 psi",
                    "log": True}],
    "fit": {"error": "relative", "not_a_key": 1},
}
DEM_MATERIAL = {"material": {"shear_modulus": "29 GPa", "poisson": 0.15}, "stiffness": {"source": "overlap"},
                "relaxed": {"enabled": True}, "fabric": {"fit_order": 2}}

#: (command, base config, extra CLI arguments)
COMMANDS = {
    "run": (RUN, ()), "run-path": (PATH, ()), "run-grains": (GRAINS, ()), "site": (SITE, ("--no-response",)),
    "pack": (PACK, ()), "stiffness": (STIFFNESS, ("--json",)), "contact": (CONTACT, ("--no-plot",)),
    "sweep": (SWEEP, ("--no-plots",)), "calibrate": (CALIBRATE, ("--no-plot",)), "dem": (DEM_MATERIAL, ("--no-plots",)),
}


def _leaves(cfg, prefix=()):
    """Paths (tuples of keys / list indices) of every value of a config."""
    if isinstance(cfg, dict):
        items = cfg.items()
    elif isinstance(cfg, list) and cfg and isinstance(cfg[0], dict):
        items = enumerate(cfg)
    else:
        return [prefix]
    return [p for k, v in items for p in _leaves(v, prefix + (k,))]


def _extra_keys(cmd):
    """Keys a case may add (valid ones the base does not give), as leaf paths."""
    return {"run": [("test", "waveform"), ("test", "constant"), ("fabric", "normals"), ("fabric", "fit_order"),
                    ("model", "dem"), ("model", "method")],
            "run-grains": [("model", "dem", k) for k in ("safety", "viscous", "ramp_steps", "chunk", "threads",
                                                        "max_ramp_strain", "liquefaction", "settle", "damping")]
            + [("model", "network"), ("model", "particles"), ("model", "method")],
            "site": [("layers", 0, "name"), ("layers", 0, "friction_angle"), ("bedrock", "damping")],
            "pack": [("grains", "spread"), ("grains", "radius"), ("material", "poisson"), ("grains", "distribution"),
                     ("preparation", "stress_tol")],
            "contact": [("path", 0, "steps"), ("path", 0, "count")],
            "sweep": [("sweep", "samples")]}.get(cmd, [])


FILE_BODIES = ["", "\n", "ITEM: TIMESTEP\n", "id1,id2\n", "PK\x03\x04", "garbage", "1,2,3\n4,5\n"]
AT2 = "title\nevent\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= {n}, DT= {dt} SEC\n{values}\n"

values = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e-300, 1e300, -1.0, 0.0, 0.99, 1e12]),
    st.sampled_from([0, -1, 1, 2, 3, 7, 10**6 + 1, 10**12, 2**62, 1e-300, 1e300, 0.49, 0.5, 0.999999, 1e-9, 0.99,
                     1000]),
    st.sampled_from(["1 deg", "50 %", "1e300 Pa", "1e-300 m", "nan", "inf", "-1 MPa", "0.3 mm", "1e12 N/m", "",
                     "x" * 300, "1e300 m/s", "1e-300 kN/m^3", "dense", "cundall", "path", "volume", "sine"]),
    st.booleans(),
    st.lists(st.sampled_from([1e-6, 1e-4, 0.5, 0.03, -1e-5, 1e300]), min_size=0, max_size=3),
)


def _toml(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml(x)}" for k, x in v.items()) + "}"


def _dump(cfg):
    """TOML text of a config whose tables hold values, inline tables or arrays of tables."""
    out, tables = [], []
    for t, tab in cfg.items():
        if isinstance(tab, list):
            for item in tab:
                tables.append(f"[[{t}]]\n" + "".join(f"{k} = {_toml(v)}\n" for k, v in item.items()))
        elif isinstance(tab, dict):
            body = {k: v for k, v in tab.items() if not (isinstance(v, dict) and t != "parameters")}
            subs = {k: v for k, v in tab.items() if isinstance(v, dict) and t != "parameters"}
            tables.append(f"[{t}]\n" + "".join(f"{json.dumps(k) if '.' in k else k} = {_toml(v)}\n"
                                               for k, v in body.items()))
            for k, sub in subs.items():
                tables.append(_dump({f"{t}.{k}": sub}))
        else:
            out.append(f"{t} = {_toml(tab)}\n")
    return "".join(out) + "\n".join(tables)


def _set(cfg, path, value):
    cur = cfg
    for k in path[:-1]:
        if isinstance(cur, dict):
            cur = cur.setdefault(k, {})
        else:
            cur = cur[k]
    cur[path[-1]] = value


def _copy(cfg):
    return json.loads(json.dumps(cfg))


_counter = itertools.count()
BAD_TOKEN = re.compile(r"(?<![A-Za-z_])(nan|-?inf|infinity)(?![A-Za-z_])", re.IGNORECASE)


def _check(res, out: Path):
    assert res.rc in (0, 1, 2), (res.rc, res.err)
    assert "Traceback" not in res.err, res.err
    files = [p for p in out.rglob("*") if p.is_file()] if out.exists() else []
    if res.rc == 2:
        assert not files, (res.err, files)
        return
    for p in files:
        if p.suffix in (".csv", ".json"):
            text = p.read_text(encoding="utf-8")
            body = "\n".join(ln for ln in text.splitlines() if not ln.startswith("#"))
            bad = BAD_TOKEN.search(body.replace("NaN-free", ""))
            assert bad is None, (p.name, bad.group(0), body[max(0, bad.start() - 200):bad.end() + 50])


cases = st.sampled_from(sorted(COMMANDS)).flatmap(
    lambda cmd: st.tuples(st.just(cmd), st.sampled_from(_leaves(COMMANDS[cmd][0]) + _extra_keys(cmd)), values,
                          st.sampled_from(FILE_BODIES), st.integers(0, 3)))


@settings(max_examples=250, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=cases)
def test_cli_fuzz(tmp_path, cli, case):
    cmd, path, value, body, variant = case
    base, extra = COMMANDS[cmd]
    work = tmp_path / f"case{next(_counter)}"
    work.mkdir()
    out = work / "out"
    cfg = _copy(base)
    if path in (("model", "network"), ("model", "particles"), ("fabric", "normals")):
        (work / "f.npz" if variant % 2 else work / "f.csv").write_text(body, encoding="utf-8")
        value = "f.npz" if variant % 2 else ("f.csv" if variant else "missing.csv")
        if path[0] == "model":
            cfg["model"].pop("packing", None)
    _set(cfg, path, value)
    if cmd == "site":  # an AT2 motion: a drawn time step, number of points and values
        dt = {0: "0.01", 1: "NAN", 2: "1e-300", 3: "0.01"}[variant]
        vals = ["0.01"] * 16 if variant != 3 else ["0.01", "nan", "1e300"] + ["0.0"] * 13
        (work / "motion.at2").write_text(AT2.format(n=len(vals), dt=dt, values=" ".join(vals)))
    args = []
    if cmd == "dem":  # a contact file of the drawn body; the material from the config
        (work / "c.csv").write_text(body, encoding="utf-8")
        (work / "m.toml").write_text(_dump(cfg), encoding="utf-8")
        args = ["dem", str(work / "c.csv"), "--material", str(work / "m.toml")]
    else:
        name = {"run-path": "run", "run-grains": "run"}.get(cmd, cmd)
        (work / "c.toml").write_text(_dump(cfg), encoding="utf-8")
        args = [name, str(work / "c.toml")]
        if cmd == "calibrate":
            (work / "d.csv").write_text("pressure [psi],void_ratio,G [psi]\n10,0.6,1e4\n20,0.6,1.4e4\n"
                                        if variant else body, encoding="utf-8")
            args.append(str(work / "d.csv"))
    if cmd != "stiffness":
        args += ["-o", str(out), "--quiet"]
    res = cli(*args, *extra)
    _check(res, out)


def test_accepted_tiny_cases_write_finite_files(tmp_path, cli):
    """The bases of the commands that run (affine run and path, stiffness, contact, sweep) are accepted."""
    for cmd in ("run", "run-path", "contact", "sweep"):
        base, extra = COMMANDS[cmd]
        work = tmp_path / cmd
        work.mkdir()
        (work / "c.toml").write_text(_dump(base), encoding="utf-8")
        res = cli({"run-path": "run"}.get(cmd, cmd), str(work / "c.toml"), "-o", str(work / "out"), "--quiet",
                  *extra)
        assert res.rc == 0, (cmd, res.err)
        _check(res, work / "out")

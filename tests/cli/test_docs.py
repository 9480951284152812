"""The docs say what the program does, the CLI
is thin (parse -> jobs -> print) and `import grainmech` is a notebook-grade API."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
SRC = ROOT / "src" / "grainmech"
EX = ROOT / "examples"

TINY_RUN = """
[microstructure]
void_ratio = 0.65
coordination = 8.0
radius = "0.25 mm"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "44 GPa"
poisson = 0.08
friction = 0.5
[initial]
pressure = "100 kPa"
[quadrature]
degree = 5
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-5, 1e-4]
n_cycles = 2
steps_per_cycle = 16
"""


def test_run_csv_columns_are_the_documented_ones(tmp_path, cli):
    cfg = tmp_path / "c.toml"
    cfg.write_text(TINY_RUN)
    assert cli("run", cfg, "-o", tmp_path / "o", "--quiet").rc == 0
    files = sorted(p.name for p in (tmp_path / "o").glob("cycles_gamma_*.csv"))
    assert files  # one per amplitude, named by it
    header = (tmp_path / "o" / files[0]).read_text().splitlines()[0].split(",")
    comps = ("xx", "yy", "zz", "yz", "xz", "xy")
    expected = (["step"] + [f"strain_{c} [-]" for c in comps] + [f"stress_{c} [Pa]" for c in comps]
                + ["sliding_fraction [-]", "open_fraction [-]", "dissipated_energy [J/m^3]", "work [J/m^3]",
                   "stored_energy [J/m^3]", "stress_ratio_sigma1_sigma3 [-]", "stress_ratio_unbounded [0/1]",
                   "beyond_sand_envelope [0/1]"])
    assert header == expected
    doc = (DOCS / "config.md").read_text()
    para = doc[doc.index("`cycles_gamma_<amplitude>.csv`"):doc.index("`path.csv`",
                                                                       doc.index("`cycles_gamma_<amplitude>.csv`"))]
    assert "no\ntangent constants" in para or "no tangent constants" in para
    for col in expected:
        assert f"`{col}`" in para
    # every column of modulus_reduction.csv is named in its paragraph too
    mr = (tmp_path / "o" / "modulus_reduction.csv").read_text().splitlines()[0].split(",")
    assert {"menq_G_over_Gmax [-]", "max_stress_ratio_unbounded [0/1]", "value_flag [0/1]"} <= set(mr)
    start = doc.index("`modulus_reduction.csv` (`shear_strain_amplitude [-]`")
    para = doc[start:doc.index("`site_response_curves.csv`", start)]
    for col in mr:
        assert f"`{col}`" in para, col


def test_unknown_key_message_is_the_documented_one(tmp_path, cli):
    text = (EX / "stiffness_transversely_isotropic_sand.toml").read_text()
    assert "poisson = " in text
    cfg = tmp_path / "c.toml"
    cfg.write_text(text.replace("poisson = ", "poison = "))
    r = cli("stiffness", cfg)
    assert r.rc == 2
    assert "unknown key 'poison' (did you mean 'poisson'?)" in r.err and "None" not in r.err
    assert "unknown key 'poison' (did you mean 'poisson'?)" in (DOCS / "config.md").read_text()
    assert "= None" not in (DOCS / "config.md").read_text()


def test_doc_references_exist():
    """Every docs/<path>.md named in the docs (docs/models/ too), the README, ARCHITECTURE.md,
    the sources, the examples and the tests exists, and so does every picture a page shows."""
    files = (sorted(DOCS.rglob("*.md")) + [ROOT / "README.md", ROOT / "ARCHITECTURE.md"]
             + sorted(SRC.rglob("*.py")) + sorted(SRC.rglob("*.toml")) + sorted(EX.glob("*"))
             + sorted((ROOT / "tests").rglob("*.py")) + sorted((ROOT / "benchmarks").glob("*.py")))
    missing = []
    for f in files:
        if not f.is_file() or f.suffix not in (".md", ".py", ".toml"):
            continue
        text = f.read_text()
        for name in re.findall(r"docs/([\w./-]+?\.md)\b", text):
            if not (DOCS / name).exists():
                missing.append(f"{f.relative_to(ROOT)}: docs/{name}")
        if f.suffix == ".md":
            for pic in re.findall(r"!\[[^]]*\]\(([^)\s]+)\)", text):
                if not pic.startswith("http") and not (f.parent / pic).exists():
                    missing.append(f"{f.relative_to(ROOT)}: picture {pic}")
    assert not missing, missing


def test_docs_are_named_after_the_rooms():
    """One page per kinematic model under docs/models/ (named as [model] method), making
    packings in docs/packings.md, contact networks in docs/networks.md; no page keeps an old name."""
    from grainmech.driver.registry import MODELS

    assert sorted(p.stem for p in (DOCS / "models").glob("*.md")) == sorted(MODELS)
    for old in ("driver", "packing-driver", "dem-model", "packing", "dem", "tensors"):
        assert not (DOCS / f"{old}.md").exists(), old
    assert (DOCS / "packings.md").read_text().startswith("# Making packings")
    assert (DOCS / "networks.md").read_text().startswith("# DEM contact networks")


def test_output_units_are_what_conventions_md_says():
    """conventions.md promised an output-units key that does not exist: it now says results
    are always SI, and a config asking for other output units is an unknown key."""
    from grainmech.errors import ConfigError
    from grainmech.jobs import prepare_run

    doc = (DOCS / "conventions.md").read_text()
    assert "unless a config says" not in doc and "always written in SI" in doc
    cfg = tomllib.loads(TINY_RUN)
    cfg["output"] = {"units": "kPa"}
    with pytest.raises(ConfigError, match="unknown key 'output'"):
        prepare_run(cfg)


def test_fabric_md_point_count_of_degree_23_is_what_run_uses():
    from grainmech.driver import MaterialPoint
    from grainmech.jobs import prepare_run

    cfg = tomllib.loads((SRC / "data" / "default_run.toml").read_text())
    spec = prepare_run(cfg)
    assert spec.degree == 23
    point = MaterialPoint.isotropic(spec.microstructure, spec.law, spec.pressure, extra_degree=spec.degree)
    assert len(point.contacts) == 194
    assert "23 (194)" in (DOCS / "fabric.md").read_text()
    assert "194 directions" in (DOCS / "config.md").read_text()
    assert "194 directions" in (SRC / "data" / "default_run.toml").read_text()


def test_contact_help_is_the_full_reference(cli):
    """docs/config.md: `grainmech contact --help` prints the full reference."""
    res = cli("contact", "--help")
    assert res.rc == 0
    out = res.out
    for key in ("law", "shear_modulus", "poisson", "radius", "radius2", "shear_modulus2", "poisson2",
                "friction", "friction_angle", "max_reversals", "kn", "ks", "shear_modulus_equiv", "psi",
                "normal_force", "approach", "steps", "normal_displacement", "tangential_force",
                "tangential_displacement", "kind", "count", "tangential_force_amplitude",
                "tangential_displacement_amplitude", "contact.csv", "contact.png"):
        assert re.search(rf"\b{re.escape(key)}\b", out), key
    assert "full reference" in " ".join((DOCS / "config.md").read_text().split())


def test_one_output_folder_rule(cli, tmp_path):
    """Every command that writes files defaults to ./grainmech-out/<command>, listed in
    .gitignore; README shows -o as optional for dem (it writes its files without it)."""
    from grainmech.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name in ("run", "contact", "dem", "reproduce", "sweep", "calibrate"):
        p = sub.choices[name]
        out = next(a for a in p._actions if a.dest == "outdir")
        assert out.default == f"grainmech-out/{name}" and not out.required, name
    assert "grainmech-out/" in (ROOT / ".gitignore").read_text().split()
    readme = (ROOT / "README.md").read_text()
    dem_line = next(ln for ln in readme.splitlines() if ln.startswith("grainmech dem "))
    assert "[-o OUTDIR]" in dem_line
    r = cli("dem", EX / "dem_table_contacts.csv", "--particles", EX / "dem_table_particles.csv", "--no-plots")
    assert r.rc == 0
    assert (tmp_path / "grainmech-out" / "dem" / "summary.json").exists()  # conftest: cwd = tmp_path
    r = cli("contact", EX / "contact_md_growing_cycles.toml", "--no-plot")
    assert r.rc == 0 and (tmp_path / "grainmech-out" / "contact" / "contact.csv").exists()


def test_readme_opens_with_the_two_setup_commands():
    readme = (ROOT / "README.md").read_text()
    first = readme[readme.index("```bash") + 8:readme.index("```", readme.index("```bash") + 7)]
    assert first.strip().splitlines() == ['pip install ".[all]" && grainmech run',
                                          'pip install -e ".[all,test]" && python -m pytest -q']


# ----------------------------------------------------------------------------- thin CLI
def test_cli_modules_hold_no_physics():
    """parse -> jobs -> print: no NumPy, no matplotlib, no writer in the CLI modules."""
    for f in sorted((SRC / "cli").glob("*.py")):
        text = f.read_text()
        assert "matplotlib" not in text, f.name
        assert "atomic_write" not in text and "savefig" not in text, f.name
        if f.name in ("run.py", "contact.py", "dem.py"):
            assert "import numpy" not in text or f.name == "dem.py", f.name
            assert "solve_step" not in text and "sin(" not in text and "log10" not in text, f.name


def test_run_kind_is_switched_in_one_place():
    hits = [f"{f.relative_to(SRC)}" for f in SRC.rglob("*.py") if '"cyclic-simple-shear"' in f.read_text()]
    assert hits == ["jobs/spec.py"], hits
    from grainmech.jobs import CyclicOutcome, PathOutcome, compute_run

    out = compute_run(tomllib.loads(TINY_RUN))
    assert isinstance(out, CyclicOutcome) and not isinstance(out, PathOutcome)
    assert out.G_ratio.shape == (2,) and np.all(out.G_ratio <= 1.0 + 1e-9)


def test_dem_command_goes_through_jobs(monkeypatch, cli, tmp_path):
    import grainmech.jobs.network as jobs

    calls = []
    real = jobs.execute_dem
    monkeypatch.setattr(jobs, "execute_dem", lambda spec, *a: calls.append(spec) or real(spec, *a))
    r = cli("dem", EX / "dem_table_contacts.csv", "--particles", EX / "dem_table_particles.csv",
            "--material", EX / "dem_material.toml", "-o", tmp_path / "o", "--no-plots", "--json")
    assert r.rc == 0 and len(calls) == 1
    assert calls[0].contacts == EX / "dem_table_contacts.csv"
    assert calls[0].options["shear_modulus"] > 0


def test_hardin_drnevich_reference():
    """Hardin & Drnevich (1972): tau_max = p sin(phi'), gamma_r = tau_max/Gmax,
    D_max = 33 - 1.5 log10 N (%). At 100 kPa, 33 deg, Gmax 407 MPa, N = 10: tau_max =
    54.46 kPa, gamma_r = 1.338e-4 (the 0.0134 % of the default run), D_max = 31.5 %."""
    from grainmech.analysis import hardin_drnevich_reference

    hd = hardin_drnevich_reference(100e3, math.radians(33.0), 407e6, 10)
    assert hd.tau_max == pytest.approx(100e3 * 0.544639, rel=1e-6)
    assert hd.gamma_r == pytest.approx(54463.9 / 407e6, rel=1e-5)
    assert hd.d_max == pytest.approx(0.315, rel=1e-12)
    assert "Drnevich" in hd.citation
    with pytest.raises(ValueError, match="friction_angle"):
        hardin_drnevich_reference(100e3, 33.0, 407e6)


# -------------------------------------------------------------------------- notebook API
def test_import_grainmech_is_light_and_gives_the_main_objects():
    code = ("import sys, grainmech as gm\n"
            "heavy = [m for m in ('matplotlib', 'numba', 'scipy', 'numpy') if m in sys.modules]\n"
            "print(','.join(heavy) or 'none')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(SRC.parent), "PATH": ""})
    assert out.stdout.strip() == "none"
    import grainmech as gm

    for name in ("SphericalDensity", "isotropic", "HertzMindlin", "MindlinDeresiewicz", "LinearSpring",
                 "Packing", "packing_stiffness", "MaterialPoint", "run", "cyclic_simple_shear",
                 "modulus_reduction", "darendeli", "hardin_drnevich", "hardin_richart", "ContactNetwork",
                 "relaxed_stiffness", "plots"):
        assert name in gm.__all__ and getattr(gm, name) is not None, name
    with pytest.raises(AttributeError):
        gm.no_such_thing  # noqa: B018


def test_plots_take_and_return_axes_and_keep_the_backend(tmp_path, cli):
    matplotlib = pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from grainmech import plots

    before = matplotlib.get_backend()
    fig = Figure()
    ax = fig.subplots()
    assert plots.modulus_reduction([1e-5, 1e-4], [0.9, 0.6], ax=ax) is ax
    assert plots.damping([1e-5, 1e-4], [0.01, 0.05], ax=ax) is ax
    cfg = tmp_path / "c.toml"
    cfg.write_text(TINY_RUN)
    assert cli("run", cfg, "-o", tmp_path / "o", "--quiet").rc == 0
    assert (tmp_path / "o" / "modulus_reduction.png").stat().st_size > 0
    assert matplotlib.get_backend() == before
    src = "\n".join(f.read_text() for f in SRC.rglob("*.py") if f.name != "network.py")
    assert "matplotlib.use(" not in src


def test_python_dash_m_grainmech():
    out = subprocess.run([sys.executable, "-m", "grainmech", "--version"], capture_output=True, text=True,
                         env={"PYTHONPATH": str(SRC.parent), "PATH": ""})
    assert out.returncode == 0 and out.stdout.startswith("grainmech ")

"""The package's structure, read from its imports (``ast``, every import of a module,
those inside functions and under ``TYPE_CHECKING`` included):

* a module's private names stay in it: at most :data:`MAX_PRIVATE_IMPORTS` names that
  start with an underscore are imported from another module (a private *module* may be
  imported within its own package, not from outside it);
* dependencies point one way: each package imports only from its own layer and the layers
  below it, in the order of the layer line of ARCHITECTURE.md (parsed from the file, so the
  map and this test cannot drift apart), and no packages import each other in a cycle.
"""

from __future__ import annotations

import ast
import re
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
PACKAGE = SRC / "grainmech"

#: private names imported across modules, at most
MAX_PRIVATE_IMPORTS = 60

#: package-level imports that break the layer order and are known, each with the reason;
#: the set only shrinks (an entry goes with the change that removes its import)
KNOWN_LAYER_EXCEPTIONS: set[tuple[str, str]] = set()


def _module_name(path: Path) -> tuple[str, bool]:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    package = parts[-1] == "__init__"
    if package:
        parts = parts[:-1]
    return ".".join(parts), package


def _is_module(dotted: str) -> bool:
    base = SRC.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or base.is_dir()


def _imports() -> list[tuple[str, str, str | None, int]]:
    """``(importer, imported module, name or None, line)`` of every grainmech import in src."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        mod, package = _module_name(path)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                out += [(mod, a.name, None, node.lineno) for a in node.names if a.name.startswith("grainmech")]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod.split(".") if package else mod.split(".")[:-1]
                    base = base[:len(base) - (node.level - 1)]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                if target == "grainmech" or target.startswith("grainmech."):
                    out += [(mod, target, a.name, node.lineno) for a in node.names]
    return out


def _private_imports() -> list[tuple[str, str, str]]:
    """``(importer, module, name)`` of each private name imported from another module."""
    found = set()
    for importer, target, name, _ in _imports():
        parts = target.split(".")
        for k, part in enumerate(parts):  # a private module reached from outside its package
            parent = ".".join(parts[:k])
            if part.startswith("_") and not part.startswith("__") and importer != parent \
                    and not importer.startswith(parent + "."):
                found.add((importer, target, name or part))
        if name is None:
            continue
        if not name.startswith("_") or name.startswith("__") or target == importer:
            continue
        if _is_module(f"{target}.{name}") and (importer == target or importer.startswith(target + ".")):
            continue  # a private module of the importer's own package
        found.add((importer, target, name))
    return sorted(found)


def test_private_names_stay_in_their_module():
    found = _private_imports()
    if len(found) <= MAX_PRIVATE_IMPORTS:
        return
    pairs = Counter((importer, module) for importer, module, _ in found)
    worst = "\n".join(f"  {n:3d}  {importer} <- {module}" for (importer, module), n in pairs.most_common(15))
    raise AssertionError(f"{len(found)} private names are imported from another module (at most "
                         f"{MAX_PRIVATE_IMPORTS}): move the code to the module whose idea it is, or make the "
                         f"name public where it is the module's API. Worst offenders:\n{worst}")


def _unit(module: str) -> str:
    """The layer unit of a module: the package or top-level module under grainmech."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def _layers() -> list[list[str]]:
    """The layer line of ARCHITECTURE.md, bottom first: the backticked names between the arrows."""
    text = (ROOT / "ARCHITECTURE.md").read_text(encoding="utf-8")
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    line = next(p for p in section.split("\n\n") if "←" in p)
    line = re.sub(r"\([^)]*\)", "", line)  # remarks in parentheses are not layers
    return [re.findall(r"`([A-Za-z_]\w*)`", part) for part in line.split("←")]


def _unit_imports() -> dict[tuple[str, str], list[str]]:
    edges: dict[tuple[str, str], list[str]] = defaultdict(list)
    for importer, target, name, line in _imports():
        dotted = f"{target}.{name}" if name is not None and target == "grainmech" else target
        if name is not None and target == "grainmech" and not _is_module(dotted):
            dotted = target  # from grainmech import __version__
        a, b = _unit(importer), _unit(dotted)
        if a != b and "grainmech" not in (a, b) and a != "__main__":
            edges[(a, b)].append(f"{importer}:{line}")
    return edges


def test_architecture_lists_every_package_once_in_its_layer_line():
    layers = _layers()
    listed = [name for layer in layers for name in layer]
    assert len(layers) >= 8, f"ARCHITECTURE.md: no layer line found (got {layers})"
    assert len(listed) == len(set(listed)), f"ARCHITECTURE.md lists a package twice: {listed}"
    units = {_unit(_module_name(p)[0]) for p in PACKAGE.rglob("*.py")} - {"grainmech", "__main__"}
    assert not units - set(listed), f"ARCHITECTURE.md's layer line does not list {sorted(units - set(listed))}"
    assert not set(listed) - units, f"ARCHITECTURE.md's layer line lists {sorted(set(listed) - units)}, not in src"


def test_imports_follow_the_layers_of_architecture_md():
    level = {name: k for k, layer in enumerate(_layers()) for name in layer}
    upward = {edge: where for edge, where in _unit_imports().items()
              if level[edge[1]] > level[edge[0]] and edge not in KNOWN_LAYER_EXCEPTIONS}
    listing = "\n".join(f"  {a} -> {b} ({', '.join(w[:3])})" for (a, b), w in sorted(upward.items()))
    assert not upward, f"imports against the layer order of ARCHITECTURE.md:\n{listing}"


def test_no_packages_import_each_other_in_a_cycle():
    graph: dict[str, set[str]] = defaultdict(set)
    for a, b in _unit_imports():
        if (a, b) not in KNOWN_LAYER_EXCEPTIONS:
            graph[a].add(b)

    def reaches(start: str, goal: str) -> bool:
        seen, todo = set(), [start]
        while todo:
            node = todo.pop()
            if node == goal:
                return True
            if node not in seen:
                seen.add(node)
                todo += graph[node]
        return False

    cycles = sorted((a, b) for a in list(graph) for b in graph[a] if reaches(b, a))
    assert not cycles, f"packages in an import cycle: {cycles}"


def test_known_exceptions_are_still_needed():
    edges = _unit_imports()
    stale = sorted(edge for edge in KNOWN_LAYER_EXCEPTIONS if edge not in edges)
    assert not stale, f"KNOWN_LAYER_EXCEPTIONS lists imports that are gone (remove them): {stale}"


#: what the writer may import from ``analysis``: constants and the types of what an outcome
#: carries; the physics (curves, strength, tables) comes with the outcome (jobs call it)
IO_ALLOWED_ANALYSIS_NAMES = {"SAND_PEAK_FRICTION_DEG", "SAND_ENVELOPE_RATIO", "SAND_ENVELOPE_TAU_RATIO",
                             "ReferenceCurves", "PathMeasures", "StrengthResult", "LoopQuality"}


def test_the_writer_imports_no_physics_from_analysis():
    bad = []
    for importer, target, name, line in _imports():
        if not (importer == "grainmech.io" or importer.startswith("grainmech.io.")):
            continue
        if target == "grainmech" and name == "analysis":
            bad.append(f"{importer}:{line} imports grainmech.analysis whole")
        elif target == "grainmech.analysis" or target.startswith("grainmech.analysis."):
            if name is None or name not in IO_ALLOWED_ANALYSIS_NAMES:
                bad.append(f"{importer}:{line} {target}.{name or ''}")
    assert not bad, ("io computes no physics: these imports of analysis are not constants or types "
                     "(compute them in the job and carry them on the outcome):\n" + "\n".join(bad))

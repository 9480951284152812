"""Every module under src/ stays at most MAX_LINES lines (ARCHITECTURE.md: one module, one
responsibility), every function at most MAX_FUNCTION_LINES (functions of ~120 lines at
most; the limit leaves a margin). A module or function that grows past it is
split along the ideas its docstrings name; the parts import each other through public
names, and no module stays behind at the old path (its importers move to the new one).

The allow-list names the modules exempt for now, each with the reason; it only shrinks
(remove an entry with the split that brings its module under the limit).
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
MAX_LINES = 800
#: longest function (``def`` to its last line, docstring included; nested functions
#: count on their own and within their enclosing function)
MAX_FUNCTION_LINES = 150

#: modules allowed over MAX_LINES for now (paths relative to the repository root)
ALLOWED: set[str] = set()


def _line_counts() -> dict[str, int]:
    root = SRC.parent
    return {p.relative_to(root).as_posix(): len(p.read_text(encoding="utf-8").splitlines())
            for p in sorted(SRC.rglob("*.py"))}


def test_no_module_passes_the_line_limit():
    over = {path: n for path, n in _line_counts().items() if n > MAX_LINES and path not in ALLOWED}
    listing = "\n".join(f"  {path}: {n} lines" for path, n in sorted(over.items(), key=lambda kv: -kv[1]))
    assert not over, f"modules over {MAX_LINES} lines (split them; see ARCHITECTURE.md):\n{listing}"


def test_the_allow_list_names_existing_modules():
    counts = _line_counts()
    missing = sorted(path for path in ALLOWED if path not in counts)
    assert not missing, f"ALLOWED in tests/test_module_size.py names modules that do not exist: {missing}"


def _function_lengths(text: str) -> list[tuple[str, int, int]]:
    """``(qualified name, first line, lines)`` of every function and method in ``text``."""
    found: list[tuple[str, int, int]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                end = child.end_lineno if child.end_lineno is not None else child.lineno
                found.append((name, child.lineno, end - child.lineno + 1))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(text), "")
    return found


def test_no_function_passes_the_line_limit():
    root = SRC.parent
    over = [f"  {path.relative_to(root).as_posix()}:{line} {name}: {n} lines"
            for path in sorted(SRC.rglob("*.py"))
            for name, line, n in _function_lengths(path.read_text(encoding="utf-8")) if n > MAX_FUNCTION_LINES]
    assert not over, (f"functions over {MAX_FUNCTION_LINES} lines (split them into the phases their docstrings "
                      "name):\n" + "\n".join(over))


def test_the_function_measure_counts_every_line():
    text = "def f():\n" + "    x = 1\n" * 200 + "\n\nclass C:\n    def g(self):\n        def h():\n            pass\n"
    got = {name: (line, n) for name, line, n in _function_lengths(text)}
    assert got == {"f": (1, 201), "C.g": (205, 3), "C.g.h": (206, 2)}


def _only_reexports(text: str) -> bool:
    """Whether a module's body is nothing but imports, ``__all__`` and ``sys.modules[...] = ...``."""
    body = ast.parse(text).body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]  # the docstring
    if not body:
        return False

    def plain(node: ast.stmt) -> bool:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            return True
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            t = node.targets[0]
            return (isinstance(t, ast.Name) and t.id == "__all__") or (
                isinstance(t, ast.Subscript) and ast.unparse(t.value) == "sys.modules")
        return False

    return all(plain(node) for node in body)


def test_no_module_only_reexports_another():
    """Moving code leaves no alias module behind (old documented paths are served by
    grainmech/_deprecated.py's MOVED_MODULES, with a warning); a package's __init__ may re-export."""
    root = SRC.parent
    aliases = [p.relative_to(root).as_posix() for p in sorted(SRC.rglob("*.py"))
               if p.name != "__init__.py" and _only_reexports(p.read_text(encoding="utf-8"))]
    assert not aliases, "modules that only re-export another (import from the real path instead):\n" + "\n".join(
        aliases)


def test_the_alias_check_finds_an_alias():
    assert _only_reexports('"""Old path."""\nimport sys\nfrom a import b as _m\nsys.modules[__name__] = _m\n')
    assert _only_reexports("from grainmech.elasticity import *\nfrom grainmech.elasticity import __all__\n")
    assert not _only_reexports("import numpy as np\n\n\ndef f():\n    return np.pi\n")

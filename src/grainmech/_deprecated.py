"""Old names kept for one release: each use warns (:class:`DeprecationWarning`) and names the new one.

The module paths and names that moved are listed here, in :data:`MOVED_MODULES` and
:data:`MOVED_NAMES`, and nowhere else: importing an old module path gives the module at
its new path (no file stays behind at the old one), an old name of a module that still
exists is served by that module's ``__getattr__`` (:func:`moved_attribute`). All of them
go in the next minor release.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType
from typing import Any

__all__ = ["warn_renamed", "renamed_attribute", "moved_attribute", "MOVED_MODULES", "MOVED_NAMES",
           "install_module_aliases"]

#: old module path -> the module it is now (documented paths only; private ones just moved)
MOVED_MODULES: dict[str, str] = {
    "grainmech.tensors": "grainmech.elasticity",
    "grainmech.fabric.packing": "grainmech.fabric.coordination",
    "grainmech.packing.engine": "grainmech.lammps.engine",
    "grainmech.packing.rolling": "grainmech.lammps.rolling",
    "grainmech.packing.reference": "grainmech.lammps.probes",
    "grainmech.network.plotting": "grainmech.plots",
}

#: old ``module.name`` -> ``module.name`` it is now (for modules that still exist)
MOVED_NAMES: dict[str, str] = {
    "grainmech.packing.prepare.GrainMaterial": "grainmech.lammps.granular.GrainMaterial",
    "grainmech.packing.prepare.SORT_MIN_GRAINS": "grainmech.lammps.granular.SORT_MIN_GRAINS",
    "grainmech.packing.prepare.setup_lammps": "grainmech.lammps.granular.setup_lammps",
    "grainmech.packing.prepare.critical_time_step": "grainmech.lammps.granular.critical_time_step",
    "grainmech.packing.prepare.network_from_lammps": "grainmech.lammps.network.network_from_lammps",
    "grainmech.packing.prepare.unbalanced_ratio": "grainmech.lammps.network.unbalanced_ratio",
    "grainmech.network.plot_rose": "grainmech.plots.plot_rose",
    "grainmech.network.plot_normal_density": "grainmech.plots.plot_normal_density",
    "grainmech.io.schema.build_packing": "grainmech.io.schema.build_microstructure",
}


def warn_renamed(old: str, new: str, stacklevel: int = 3) -> None:
    """Warn that ``old`` is deprecated and ``new`` is its name now (the old name goes in the next release)."""
    warnings.warn(f"{old} is deprecated: it is {new} now (the old name is removed in the next release)",
                  DeprecationWarning, stacklevel=stacklevel)


def renamed_attribute(module: str, name: str, renamed: dict[str, str], namespace: dict[str, Any]) -> Any:
    """The value of the deprecated module attribute ``name`` (a key of ``renamed``), with a warning.

    For a module's ``__getattr__``: ``renamed`` maps each old name to its new name in the
    module's ``namespace`` (its ``globals()``). Raises :class:`AttributeError` for any
    other name.
    """
    new = renamed.get(name)
    if new is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    warn_renamed(f"{module}.{name}", f"{module}.{new}", stacklevel=4)
    return namespace[new]


def moved_attribute(module: str, name: str) -> Any:
    """The value of ``module.name`` that moved to another module (:data:`MOVED_NAMES`), with a warning.

    For a module's ``__getattr__``; raises :class:`AttributeError` for a name not listed.
    """
    new = MOVED_NAMES.get(f"{module}.{name}")
    if new is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    warn_renamed(f"{module}.{name}", new, stacklevel=4)
    where, _, attr = new.rpartition(".")
    return getattr(importlib.import_module(where), attr)


def _importer_level() -> int:
    """The ``stacklevel`` of the code that imports, for :func:`warn_renamed` called by the loader.

    :func:`warnings.warn` does not count the import machinery's frames; this module's own are
    counted until the first frame outside it.
    """
    frame = sys._getframe(1)
    level = 2  # warn_renamed, then the loader's create_module
    while frame.f_back is not None:
        frame = frame.f_back
        name = frame.f_code.co_filename
        if "importlib" in name and "_bootstrap" in name:
            continue
        level += 1
        if name != __file__:
            break
    return level


class _AliasLoader(importlib.abc.Loader):
    """Gives the module at the new path for an old one, with the warning."""

    def __init__(self, old: str, new: str) -> None:
        self.old, self.new = old, new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warn_renamed(self.old, self.new, stacklevel=_importer_level())
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the module at the new path is already imported."""


class _MovedModuleFinder(importlib.abc.MetaPathFinder):
    """Finds the old module paths of :data:`MOVED_MODULES`."""

    def find_spec(self, fullname: str, path: Any, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        new = MOVED_MODULES.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(fullname, new))


def install_module_aliases() -> None:
    """Let the old module paths of :data:`MOVED_MODULES` be imported (once per interpreter)."""
    if not any(isinstance(f, _MovedModuleFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _MovedModuleFinder())

"""Old names kept for one release: each use warns (:class:`DeprecationWarning`) and names the new one."""

from __future__ import annotations

import warnings
from typing import Any

__all__ = ["warn_renamed", "renamed_attribute"]


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

"""TOML configuration reading with strict keys and units at the edge.

A config is read with :func:`load_toml` and consumed through :class:`Section`, which hands
out values by key (converting units with :func:`grainmech.io.units.to_float`) and, when
closed with :meth:`Section.finish`, raises :class:`~grainmech.errors.ConfigError` for any
key that was not used — unknown keys are errors, never silently ignored.
"""

from __future__ import annotations

import copy
import difflib
import math
import tomllib
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from grainmech.errors import ConfigError, GrainmechError, ParameterError
from grainmech.io.units import to_float

__all__ = ["load_toml", "read_text_file", "Section"]

_MISSING = object()


def read_text_file(path: str | Path, what: str) -> str:
    """The text of a UTF-8 file, or a GrainmechError naming the path.

    The text of a UTF-8 file; a missing file, a directory or bad encoding is a
    GrainmechError naming the path (``what`` names the kind of file: "config", "data").
    """
    p = Path(path)
    if not p.exists():
        raise GrainmechError(f"{what} file not found: {p}")
    if p.is_dir():
        raise GrainmechError(f"{what} path is a directory, not a file: {p}")
    try:
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise GrainmechError(f"{p}: not a UTF-8 text file ({exc.reason})") from None


def load_toml(path: str | Path, allow_empty: bool = False) -> dict:
    """Read a TOML file; syntax errors become a GrainmechError naming file and line.

    A file with no table and no key (empty, or comments only) is an error unless
    ``allow_empty``: the message says so instead of naming the first key a command misses.
    """
    text = read_text_file(path, "config")
    try:
        cfg = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise GrainmechError(f"{Path(path)}: invalid TOML: {exc}") from None
    if not cfg and not allow_empty:
        raise GrainmechError(f"{Path(path)}: the config is empty (no table, no key); the examples/ folder has a "
                             "config for every command")
    return cfg


class Section:
    """One table of a config, with its dotted name for error messages."""

    def __init__(self, data: Any, name: str) -> None:
        if not isinstance(data, dict):
            raise ConfigError(name, data, "expected a table")
        self.data = data
        self.name = name
        self._used: set[str] = set()
        self._children: list[Section] = []

    def key(self, k: str) -> str:
        """Dotted key of ``k`` in this section, for messages (``section.k``)."""
        return f"{self.name}.{k}" if self.name else k

    def has(self, k: str) -> bool:
        """Whether the section has the key ``k``."""
        return k in self.data

    def raw(self, k: str, default: Any = _MISSING) -> Any:
        """The value of ``k`` as written (no conversion), or ``default``; marks ``k`` as read.

        Raises
        ------
        ConfigError
            If ``k`` is missing and there is no default (naming a likely misspelling).
        """
        self._used.add(k)
        if k not in self.data:
            if default is _MISSING:
                # a misspelling of this key is the likelier mistake: name it
                unread = [u for u in self.data if u not in self._used]
                close = difflib.get_close_matches(k, unread, n=1)
                if close:
                    raise ConfigError(self.key(close[0]), self.data[close[0]],
                                      f"unknown key {close[0]!r} (did you mean {k!r}?)")
                raise ConfigError(self.key(k), None, "required key is missing")
            return default
        return self.data[k]

    def number(self, k: str, unit: str | None = None, default: Any = _MISSING, *,
               min: float | None = None, max: float | None = None,
               min_inclusive: bool = True, max_inclusive: bool = True) -> float:
        """A float in ``unit`` with an optional allowed range (named in the error)."""
        v = self.raw(k, default)
        if v is default and default is not _MISSING:
            return v
        x = to_float(v, unit, self.key(k))
        lo_bad = min is not None and (x < min if min_inclusive else x <= min)
        hi_bad = max is not None and (x > max if max_inclusive else x >= max)
        if lo_bad or hi_bad:
            lo = "" if min is None else ("[" if min_inclusive else "(") + f"{min:g}"
            hi = "" if max is None else f"{max:g}" + ("]" if max_inclusive else ")")
            rng = f"{lo or '(-inf'}, {hi or 'inf)'}"
            raise ConfigError(self.key(k), v, f"must lie in {rng}" + (f" (in {unit})" if unit else ""))
        return x

    def angle(self, k: str, default: Any = _MISSING, *, max_deg: float | None = None,
              max_inclusive: bool = True) -> float:
        """An angle in radians; the value must carry its unit (``"24 deg"``, ``"0.42 rad"``).

        One rule for every config (``docs/config.md``): a bare number is an error, since
        engineers write friction angles in degrees and the library works in radians, and
        a silent choice between the two has misled users. The range is ``[0, max_deg]``.
        """
        v = self.raw(k, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            raise ConfigError(self.key(k), v, "an angle needs its unit: write e.g. "
                                              f"'{v:g} deg' or '{v:g} rad'")
        x = to_float(v, "rad", self.key(k))
        hi = None if max_deg is None else math.radians(max_deg)
        if x < 0 or (hi is not None and (x > hi if max_inclusive else x >= hi)):
            rng = f"[0, {max_deg:g} deg" + ("]" if max_inclusive else ")") if max_deg is not None else ">= 0"
            raise ConfigError(self.key(k), v, f"must lie in {rng}")
        return x

    def integer(self, k: str, default: Any = _MISSING, *, min: int | None = None, max: int | None = None) -> int:
        """The integer at ``k`` (``>= min``, ``<= max`` if given), or ``default``; else a ConfigError naming the key."""
        v = self.raw(k, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, bool) or not isinstance(v, int):
            raise ConfigError(self.key(k), v, "expected an integer")
        if min is not None and v < min:
            raise ConfigError(self.key(k), v, f"must be >= {min}")
        if max is not None and v > max:
            raise ConfigError(self.key(k), v, f"must be <= {max} (memory and time)")
        return v

    def choice(self, k: str, options: Iterable[str], default: Any = _MISSING) -> str:
        """The value at ``k``, one of ``options``, or ``default``; a ConfigError lists the options otherwise."""
        opts = tuple(options)
        v = self.raw(k, default)
        if v not in opts:
            raise ConfigError(self.key(k), v, f"must be one of {', '.join(map(repr, opts))}")
        return v

    def boolean(self, k: str, default: Any = _MISSING) -> bool:
        """The boolean at ``k`` (TOML true/false), or ``default``."""
        v = self.raw(k, default)
        if not isinstance(v, bool):
            raise ConfigError(self.key(k), v, "expected true or false")
        return v

    def section(self, k: str, default: Any = _MISSING) -> Section:
        """The sub-table at ``k`` as a :class:`Section` (its keys are checked by :meth:`finish`)."""
        v = self.raw(k, default)
        child = Section(v, self.key(k))
        self._children.append(child)
        return child

    @contextmanager
    def checked(self, rename: Mapping[str, str] | None = None) -> Iterator[None]:
        """Report the library's checks of values read from this section by their keys.

        A :class:`~grainmech.errors.ParameterError` raised inside the ``with`` block is
        re-raised as a :class:`~grainmech.errors.ConfigError`: an argument that is a key
        of this section (after ``rename``, library name -> config key) is named by its
        dotted key, any other by this section's name followed by the library's message.

        Parameters
        ----------
        rename : mapping of str to str, optional
            Library argument names that the config spells differently.
        """
        try:
            yield
        except ParameterError as exc:
            name = (rename or {}).get(exc.name, exc.name)
            if self.has(name):
                raise ConfigError(self.key(name), exc.value, exc.problem) from None
            where = self.name or "config"
            raise ConfigError(where, None, str(exc)) from None

    def finish(self) -> None:
        """Raise for keys that were never read (unknown or misspelt keys), here and in sub-tables."""
        for child in self._children:
            child.finish()
        unknown = sorted(set(self.data) - self._used)
        if unknown:
            k = unknown[0]
            close = difflib.get_close_matches(k, sorted(self._used), n=1)
            raise ConfigError(self.key(k), self.data[k], f"unknown key {k!r}"
                              + (f" (did you mean {close[0]!r}?)" if close else "")
                              + (f" (other unknown keys: {', '.join(unknown[1:])})" if len(unknown) > 1 else ""))


#: config keys holding a file path, read relative to the config file's folder
FILE_KEYS = (("fabric", "normals"), ("model", "network"), ("model", "particles"))


def resolve_file_keys(cfg: dict, base_dir: str | Path) -> dict:
    """A copy of ``cfg`` with its relative file paths resolved against ``base_dir``.

    A copy of ``cfg`` with the relative file paths of :data:`FILE_KEYS` made relative
    to ``base_dir`` (the folder of the config file) instead of the working directory.
    """
    out = copy.deepcopy(cfg)
    for table, key in FILE_KEYS:
        sec = out.get(table)
        if isinstance(sec, dict) and isinstance(sec.get(key), str) and not Path(sec[key]).is_absolute():
            sec[key] = str(Path(base_dir) / sec[key])
    return out


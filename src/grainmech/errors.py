"""Exception types raised by grainmech.

All user-facing errors derive from :class:`GrainmechError` (itself a ``ValueError``) so
the CLI can print one line and exit with status 2 without a traceback.
"""

from __future__ import annotations


class GrainmechError(ValueError):
    """Base class of errors a user can act on (bad input, impossible request)."""


class ConfigError(GrainmechError):
    """A configuration key has a bad value; the message names the key and the value.

    ``value = None`` means the key has no value (it is missing): the message is then
    ``"key: problem"``, never ``"key = None"``.
    """

    def __init__(self, key: str, value: object, problem: str) -> None:
        self.key = key
        self.value = value
        self.problem = problem
        super().__init__(f"{key}: {problem}" if value is None else f"{key} = {value!r}: {problem}")


class NegativeDensityError(GrainmechError):
    """A contact-normal density is negative somewhere (not a valid distribution)."""

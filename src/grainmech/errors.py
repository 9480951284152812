"""Exception types raised by grainmech.

All user-facing errors derive from :class:`GrainmechError` (itself a ``ValueError``) so
the CLI can print one line and exit with status 2 without a traceback.

One rule decides which type a check raises:

- :class:`ParameterError` for a bad argument of a library function or class (the
  message names the argument or field and its value);
- :class:`ConfigError` only where a configuration file is read (the message names the
  file's key and its value). A config reader that passes a value to the library
  re-raises the library's :class:`ParameterError` as a :class:`ConfigError` naming the
  key it read.
"""

from __future__ import annotations


class GrainmechError(ValueError):
    """Base class of errors a user can act on (bad input, impossible request)."""


class ParameterError(GrainmechError):
    """An argument or parameter of a library call has a bad value.

    The message names the argument (or field) and the value. ``value = None`` means the
    argument has no usable value: the message is then ``"name: problem"``.

    Parameters
    ----------
    name : str
        Name of the argument or field, as the caller wrote it.
    value : object
        The offending value, or ``None`` when it is missing.
    problem : str
        What is wrong with it, e.g. ``"must be > 0"``.
    """

    def __init__(self, name: str, value: object, problem: str) -> None:
        self.name = name
        self.value = value
        self.problem = problem
        super().__init__(f"{name}: {problem}" if value is None else f"{name} = {value!r}: {problem}")

    def __reduce__(self) -> tuple[type, tuple[str, object, str]]:
        return (type(self), (self.name, self.value, self.problem))


class ConfigError(GrainmechError):
    """A configuration key has a bad value; the message names the key and the value.

    ``value = None`` means the key has no value (it is missing): the message is then
    ``"key: problem"``, never ``"key = None"``.

    Parameters
    ----------
    key : str
        Dotted key of the configuration file, e.g. ``"contacts.shear_modulus"``.
    value : object
        The value read for the key, or ``None`` when the key is missing.
    problem : str
        What is wrong with it.
    """

    def __init__(self, key: str, value: object, problem: str) -> None:
        self.key = key
        self.value = value
        self.problem = problem
        super().__init__(f"{key}: {problem}" if value is None else f"{key} = {value!r}: {problem}")

    def __reduce__(self) -> tuple[type, tuple[str, object, str]]:
        return (type(self), (self.key, self.value, self.problem))


class NegativeDensityError(GrainmechError):
    """A contact-normal density is negative somewhere (not a valid distribution)."""


class Terminated(KeyboardInterrupt):
    """The process received SIGTERM (a batch scheduler's stop).

    Raised by the command line's SIGTERM handler; a :class:`KeyboardInterrupt`, so that
    everything that cleans up after Ctrl-C (output folders, worker processes) does the
    same for SIGTERM. The command line exits with status 143 (128 + 15).
    """

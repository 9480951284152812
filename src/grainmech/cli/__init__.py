"""Command-line interface: ``grainmech <command> ...``.

The CLI is thin: it parses arguments, calls the library and writes files through
:mod:`grainmech.io`. Each sub-command lives in its own module exposing
``register(subparsers)``; the parser's ``func(args) -> int`` does the work.
User errors (:class:`~grainmech.errors.GrainmechError`, missing files) print one line on
stderr and exit with status 2; ``--debug`` (before or after the sub-command) shows the
traceback instead. Ctrl-C prints "grainmech: interrupted" and exits with 130; SIGTERM (a
batch scheduler stopping the job) is handled the same way (:class:`~grainmech.errors.Terminated`,
a ``KeyboardInterrupt``), prints "grainmech: terminated" and exits with 143. A command
that can keep what it finished before the signal (``run``: the finished amplitudes)
writes it and adds it to that one line. Output piped into a program that stops reading
(``grainmech stiffness | head -1``) ends quietly.

Streams: the results a user reads (tables, summaries, the files written) go to stdout;
progress lines, warnings and errors to stderr. ``--quiet`` silences the progress lines
only, never a warning or an error.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from collections.abc import Sequence
from typing import Any

from grainmech import __version__
from grainmech._mpi import mpi_world_size
from grainmech.errors import GrainmechError, Terminated

#: sub-command modules, each with ``register(subparsers)``
_COMMANDS = ("stiffness", "contact", "run", "dem", "reproduce", "sweep", "calibrate", "pack", "site")


def build_parser() -> argparse.ArgumentParser:
    """The ``grainmech`` argument parser with every sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="grainmech",
        description="Stiffness, fabric and cyclic behaviour of granular materials from "
                    "their micro-structure.")
    parser.add_argument("--version", action="version", version=f"grainmech {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMANDS:
        try:
            mod = importlib.import_module(f"grainmech.cli.{name}")
        except ModuleNotFoundError as exc:  # an optional command whose module is absent
            if exc.name == f"grainmech.cli.{name}":
                continue
            raise
        mod.register(sub)
    for p in sub.choices.values():
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show tracebacks on errors")
    return parser


def _quiet_broken_pipe() -> int:
    """The reader of stdout went away: stop quietly (no traceback, no flush error at exit)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a real file (e.g. captured in tests)
        pass
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 success, 2 input error (one line on stderr, no traceback
        unless ``--debug``), 1 a run that did not complete (a full disk: one line too),
        130 interrupted (Ctrl-C), 143 terminated (SIGTERM).
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    ranks = mpi_world_size()
    if ranks > 1:  # every rank would run the whole command and write the same folder
        print(f"grainmech: error: grainmech was started as {ranks} MPI ranks (mpiexec); start it once and set "
              f"[model.dem] ranks = {ranks} to run the DEM model on {ranks} ranks", file=sys.stderr)
        return 2
    if not getattr(args, "quiet", False):
        _announce_compilation()
    previous = _catch_sigterm()
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt as exc:
        if args.debug:
            raise
        what = "terminated" if isinstance(exc, Terminated) else "interrupted"
        print(f"grainmech: {what}" + (f"; {exc.args[0]}" if exc.args else ""), file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    except BrokenPipeError:
        return _quiet_broken_pipe()
    except (GrainmechError, FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        if args.debug:
            raise
        msg = str(exc) if not isinstance(exc, OSError) else f"{exc.strerror}: {exc.filename}"
        print(f"grainmech: error: {msg}", file=sys.stderr)
        return int(getattr(exc, "exit_status", 2))  # 1: not an input error (a full disk)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _raise_terminated(signum: int, frame: object) -> None:
    raise Terminated()


def _catch_sigterm() -> Any:
    """Turn SIGTERM into :class:`~grainmech.errors.Terminated` for this command.

    Returns the previous handler (restored at the end), or ``None`` where no handler can
    be set (not the main thread, no SIGTERM on this platform).
    """
    try:
        return signal.signal(signal.SIGTERM, _raise_terminated)
    except (ValueError, AttributeError, OSError):
        return None


#: printed once, when numba starts compiling (not when it loads a cached kernel)
COMPILE_NOTICE = ("grainmech: compiling the contact-law kernels with numba (first run after installing or "
                  "upgrading, 10-20 s; later runs load them from the cache)")


_NOTICE: list = []  # the one listener of this process


def _announce_compilation() -> object | None:
    """Say on stderr, once per process, that numba is compiling.

    Say on stderr, once per process, that numba is compiling: the first run of a
    command after installing spends most of its time there, silently otherwise. Uses
    numba's compile events, which fire for a compilation and not for a cache load.
    Registers one listener per process (returned; ``None`` without numba).
    """
    if _NOTICE:
        return _NOTICE[0]
    try:
        from numba.core import event
    except ImportError:  # no numba: the NumPy reference paths, nothing to compile
        return None

    class _Notice(event.Listener):
        said = False

        def on_start(self, ev: object) -> None:
            if not self.said:
                self.said = True
                print(COMPILE_NOTICE, file=sys.stderr, flush=True)

        def on_end(self, ev: object) -> None:
            pass

    listener = _Notice()
    event.register("numba:compile", listener)
    _NOTICE.append(listener)
    return listener


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

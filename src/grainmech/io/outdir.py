"""A command's output folder as one unit: checked first, written aside, swapped in at the end.

Every command that writes a folder (``run``, ``contact``, ``dem``, ``reproduce``,
``sweep``, ``calibrate``) opens it with :func:`output_folder` *before* computing:

1. OUTDIR is created if needed and must be writable -- the error comes before the work;
2. a lock file ``OUTDIR/.grainmech.lock`` is taken (``fcntl.flock`` where available, else
   an exclusive create): a second grainmech process on the same OUTDIR stops at once with
   "output folder ... is in use by another grainmech process (pid N)";
3. the files are written into a fresh hidden staging folder inside OUTDIR
   (:attr:`OutputFolder.staging`, same file system, so every move is a rename);
4. on success the staged files are moved into OUTDIR (:func:`os.replace`, one rename per
   file), and the files the *previous* run wrote (listed in its manifest
   ``OUTDIR/.grainmech-manifest.json``) that this run did not write are removed -- a
   stale ``amplitude_...csv`` or ``summary.png`` never sits beside the new results. Files
   that no grainmech run listed (the user's own) are never touched;
5. if the computation or the writing raises an error, what was staged is kept and a
   ``summary.json`` saying ``"success": false`` with the error is added unless the
   command wrote its own -- the folder then describes the failed run, not an older one.
   An input error (:class:`GrainmechError`) raised before anything was written means the
   run never started: OUTDIR stays as it was;
6. a full file system (no space left, a file-size or quota limit: :class:`~grainmech.io.results.StorageFullError`)
   is not a failed run to describe: the staging folder is removed and OUTDIR is left
   exactly as it was -- the previous results stay -- and the error is one line naming the
   file that could not be written (the command line exits with status 1). The manifest is
   written into the staging folder and moved in last, so the moves themselves need no room;
7. on Ctrl-C or SIGTERM (:class:`KeyboardInterrupt`, :class:`~grainmech.errors.Terminated`)
   the staging folder is removed and OUTDIR is left exactly as it was (removed again if
   this run created it): no partial folder -- unless the command has already committed
   what it finished before the signal (``grainmech run`` commits its finished amplitudes
   as a run marked interrupted, then re-raises). The lock is released in every case.

The manifest records the command, the time, success and the files of the run.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

from grainmech.errors import GrainmechError
from grainmech.io.results import StorageFullError, storage_full, write_json

__all__ = ["OutputFolder", "output_folder", "LOCK_NAME", "MANIFEST_NAME", "FolderInUseError"]

LOCK_NAME = ".grainmech.lock"
MANIFEST_NAME = ".grainmech-manifest.json"
_STAGING_PREFIX = ".grainmech-staging-"


class FolderInUseError(GrainmechError):
    """Another grainmech process holds the lock of the output folder."""


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


class _Lock:
    """An exclusive lock on ``path`` held by this process.

    An exclusive lock on ``path``: ``flock`` (released by the kernel if the process
    dies), else an ``O_EXCL`` file holding the pid (a stale one of a dead pid is taken
    over).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fd: int | None = None

    def _holder(self) -> str:
        try:
            return self.path.read_text(encoding="ascii").strip() or "?"
        except OSError:
            return "?"

    def _busy(self) -> FolderInUseError:
        return FolderInUseError(
            f"output folder {self.path.parent} is in use by another grainmech process (pid {self._holder()}); "
            "wait for it to finish or choose another folder with -o")

    def acquire(self) -> None:
        fcntl: ModuleType | None
        try:
            import fcntl
        except ImportError:  # pragma: no cover (not POSIX)
            fcntl = None
        if fcntl is None:  # pragma: no cover
            for _ in range(2):
                try:
                    self.fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
                    break
                except FileExistsError:
                    h = self._holder()
                    if h.isdigit() and not _pid_alive(int(h)):
                        with contextlib.suppress(OSError):
                            os.unlink(self.path)
                        continue
                    raise self._busy() from None
            else:
                raise self._busy()
        else:
            while True:
                fd = os.open(self.path, os.O_CREAT | os.O_RDWR, 0o644)
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:
                    os.close(fd)
                    raise self._busy() from None
                # the holder may have unlinked the file between our open and our lock
                try:
                    same = os.path.samestat(os.fstat(fd), os.stat(self.path))
                except FileNotFoundError:
                    same = False
                if same:
                    self.fd = fd
                    break
                os.close(fd)
        os.ftruncate(self.fd, 0)
        os.write(self.fd, f"{os.getpid()}\n".encode("ascii"))

    def release(self) -> None:
        if self.fd is None:
            return
        with contextlib.suppress(OSError):
            os.unlink(self.path)
        os.close(self.fd)
        self.fd = None


class OutputFolder:
    """An output folder opened by :func:`output_folder`.

    Attributes
    ----------
    path : Path
        The final folder (OUTDIR).
    staging : Path
        Where the command writes its files; moved into :attr:`path` at the end.
    command : str
        The command's name (recorded in the manifest).
    """

    def __init__(self, path: Path, command: str, staging: Path, created: bool, lock: _Lock) -> None:
        self.path, self.command, self.staging = path, command, staging
        self._created, self._lock = created, lock
        self.success: bool | None = None

    # ---------------------------------------------------------------- helpers
    def _old_manifest(self) -> list[str]:
        try:
            data = json.loads((self.path / MANIFEST_NAME).read_text(encoding="utf-8"))
            return [str(f) for f in data.get("files", [])]
        except (OSError, ValueError, AttributeError):
            return []

    def _staged(self) -> list[str]:
        return sorted(str(p.relative_to(self.staging)) for p in self.staging.rglob("*") if p.is_file())

    def _write_failure_summary(self, exc: BaseException) -> None:
        if (self.staging / "summary.json").exists():
            return
        write_json(self.staging / "summary.json", {
            "command": self.command, "success": False,
            "message": f"{type(exc).__name__}: {exc}",
            "note": "the run stopped with this error; the other files here are what it wrote before",
            "files": self._staged() + ["summary.json"]})

    def commit(self, success: bool = True) -> list[str]:
        """Move the staged files into :attr:`path` and write the manifest.

        Move the staged files into :attr:`path`, remove the previous run's files that
        this run did not write, write the manifest. Returns the files (relative paths).
        """
        files = self._staged()
        old = self._old_manifest()
        # written before anything moves: a full disk stops here with OUTDIR as it was
        write_json(self.staging / MANIFEST_NAME, {
            "command": self.command, "success": bool(success),
            "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "files": files})
        for rel in files + [MANIFEST_NAME]:
            dst = self.path / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            if dst.is_dir():
                shutil.rmtree(dst)
            os.replace(self.staging / rel, dst)
        keep = set(files)
        for rel in old:
            p = self.path / rel
            if rel not in keep and ".." not in Path(rel).parts and p.is_file():
                with contextlib.suppress(OSError):
                    p.unlink()
                    # drop directories the old run created and this one left empty
                    for parent in p.relative_to(self.path).parents:
                        if str(parent) == ".":
                            break
                        with contextlib.suppress(OSError):
                            (self.path / parent).rmdir()
        self._discard_staging()
        self.success = bool(success)
        return files

    def _discard_staging(self) -> None:
        shutil.rmtree(self.staging, ignore_errors=True)

    def abandon(self) -> None:
        """Drop everything this run staged; remove OUTDIR again if this run created it."""
        self._discard_staging()
        if self._created:
            self._lock.release()
            with contextlib.suppress(OSError):
                self.path.rmdir()  # only if empty: nothing else was put there meanwhile


def _full(exc: BaseException, folder: OutputFolder) -> StorageFullError:
    """The one-line error of a run that found the file system full (``exc``), naming the file in OUTDIR."""
    if isinstance(exc, StorageFullError):
        path, reason = exc.path, exc.reason
    else:
        path = Path(getattr(exc, "filename", None) or folder.path)
        reason = getattr(exc, "strerror", None) or str(exc)
    with contextlib.suppress(ValueError):
        path = folder.path / path.relative_to(folder.staging)
    return StorageFullError(path, reason, f"nothing was written, {folder.path} is as it was before this run")


def _rename_staging_in(exc: BaseException, staging: Path, final: Path) -> None:
    """Make the message of ``exc`` name ``final`` where it names the (now removed) ``staging`` folder."""
    if exc.args and isinstance(exc.args[0], str) and str(staging) in exc.args[0]:
        exc.args = (exc.args[0].replace(str(staging), str(final)),) + exc.args[1:]


@contextlib.contextmanager
def output_folder(outdir: str | Path, command: str) -> Iterator[OutputFolder]:
    """Open OUTDIR for one run of ``command`` (see the module docstring).

    Parameters
    ----------
    outdir : path
        The output folder (created if needed, with its parents).
    command : str
        Name of the command, recorded in the manifest and in a failure summary.

    Yields
    ------
    OutputFolder
        Write into ``folder.staging``; files needed during the run that must persist even
        if it is interrupted (a sweep's finished points) go directly into ``folder.path``.

    Raises
    ------
    GrainmechError
        OUTDIR is not a directory, cannot be created or written.
    FolderInUseError
        Another grainmech process is writing OUTDIR.
    """
    p = Path(outdir)
    if p.exists() and not p.is_dir():
        raise GrainmechError(f"output path exists and is not a directory: {p}")
    created = not p.exists()
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GrainmechError(f"cannot create output directory {p}: {exc.strerror}") from None
    if not os.access(p, os.W_OK | os.X_OK):
        raise GrainmechError(f"cannot write in output directory {p}: permission denied")
    lock = _Lock(p / LOCK_NAME)
    try:
        lock.acquire()
    except PermissionError as exc:
        raise GrainmechError(f"cannot write in output directory {p}: {exc.strerror}") from None
    except OSError as exc:
        if storage_full(exc):
            lock.release()
            if created:
                with contextlib.suppress(OSError):
                    p.rmdir()
            raise StorageFullError(p / LOCK_NAME, exc.strerror or str(exc), f"nothing was written to {p}") from None
        raise
    try:
        # leftovers of a run killed with SIGKILL (no cleanup ran): we hold the lock now
        for old in p.glob(_STAGING_PREFIX + "*"):
            shutil.rmtree(old, ignore_errors=True)
        staging = Path(tempfile.mkdtemp(prefix=_STAGING_PREFIX, dir=p))
        folder = OutputFolder(p, command, staging, created, lock)
        try:
            yield folder
        except KeyboardInterrupt:
            if folder.success is None:  # nothing committed: leave OUTDIR as it was
                folder.abandon()
            raise
        except BaseException as exc:
            if storage_full(exc) and folder.success is None:  # no room: leave OUTDIR as it was
                folder.abandon()
                raise _full(exc, folder) from None
            if isinstance(exc, SystemExit) and not exc.code:
                if folder.success is None:
                    folder.commit()
                raise
            if folder.success is None and isinstance(exc, GrainmechError) and not folder._staged():
                # an input error found before anything was computed: the run never started,
                # the previous results stay
                folder.abandon()
            elif folder.success is None:
                try:
                    folder._write_failure_summary(exc)
                    folder.commit(success=False)
                except (OSError, StorageFullError):
                    folder.abandon()
                else:  # the staged files are in OUTDIR now: an error naming one names it there
                    _rename_staging_in(exc, staging, p)
            raise
        else:
            if folder.success is None:
                try:
                    folder.commit()
                except StorageFullError as exc:
                    folder.abandon()
                    raise _full(exc, folder) from None
    finally:
        lock.release()

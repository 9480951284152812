"""A full disk: one line, exit status 1, and the previous results left as they were.

A real full disk is made with a file-size limit (``RLIMIT_FSIZE``, ``ulimit -f``): a write
beyond it fails with ``EFBIG`` (SIGXFSZ ignored, as Python does), as a write on a full
file system fails with ``ENOSPC``; both are the same fault for a writer.
"""

from __future__ import annotations

import errno
import hashlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

from grainmech.io import outdir, results
from grainmech.io.outdir import MANIFEST_NAME, output_folder
from grainmech.io.results import StorageFullError, atomic_write, write_text

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "contact_md_growing_cycles.toml"

#: runs grainmech with a file-size limit of argv[1] bytes, the command in argv[2:]
LIMITED = """
import resource, signal, sys
limit = int(sys.argv[1])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
from grainmech.cli import main
sys.exit(main(sys.argv[2:]))
"""


def _digests(d: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.iterdir()) if p.is_file()}


def _grainmech(tmp_path: Path, limit: int | None, *args: str) -> subprocess.CompletedProcess:
    if limit is None:
        cmd = [sys.executable, "-m", "grainmech", *args]
    else:
        cmd = [sys.executable, "-c", LIMITED, str(limit), *args]
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=600)


def test_a_full_disk_keeps_the_previous_results_and_says_so_in_one_line(tmp_path) -> None:
    """``grainmech contact`` writes a 60 kB table: under a 20 kB limit the second run fails
    with one line naming the file and exit 1, and the first run's folder is unchanged
    (same files, same bytes, no staging folder, no lock)."""
    first = _grainmech(tmp_path, None, "contact", str(EXAMPLE), "-o", "out", "--no-plot")
    assert first.returncode == 0, first.stderr
    before = _digests(tmp_path / "out")
    assert (tmp_path / "out" / "contact.csv").stat().st_size > 20_000  # the limit bites
    again = _grainmech(tmp_path, 20_000, "contact", str(EXAMPLE), "-o", "out", "--no-plot")
    assert again.returncode == 1, again.stderr
    err = again.stderr.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in again.stderr
    assert err[0] == ("grainmech: error: cannot write out/contact.csv: File too large (the disk is full or a "
                      "file-size or quota limit was reached); nothing was written, out is as it was before this run")
    assert _digests(tmp_path / "out") == before
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(before)
    # a folder the failed run would have created is not left behind
    new = _grainmech(tmp_path, 20_000, "contact", str(EXAMPLE), "-o", "new", "--no-plot")
    assert new.returncode == 1 and not (tmp_path / "new").exists()


def test_atomic_write_leaves_no_temporary_file_and_names_the_file(tmp_path, monkeypatch) -> None:
    def full(fh) -> None:  # noqa: ANN001
        fh.write("a")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(StorageFullError, match=r"cannot write .*table\.csv: No space left on device"):
        atomic_write(tmp_path / "table.csv", full)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(OSError) as other:  # other errors are not a full disk
        atomic_write(tmp_path / "table.csv", lambda fh: (_ for _ in ()).throw(OSError(errno.EIO, "I/O error")))
    assert not isinstance(other.value, StorageFullError)
    assert results.storage_full(OSError(errno.EDQUOT, "Disk quota exceeded"))
    assert not results.storage_full(OSError(errno.EACCES, "Permission denied"))


def test_a_manifest_that_does_not_fit_moves_nothing(tmp_path, monkeypatch) -> None:
    """The manifest is written before any file is moved: a disk that fills up then leaves
    the previous results whole."""
    out = tmp_path / "out"
    with output_folder(out, "run") as f:
        write_text(f.staging / "summary.json", '{"old": 1}')
        write_text(f.staging / "cycles.csv", "1\n")
    before = _digests(out)
    real = outdir.write_json

    def full(path, obj):  # noqa: ANN001, ANN202
        if Path(path).name == MANIFEST_NAME:
            raise StorageFullError(path, "No space left on device")
        return real(path, obj)

    monkeypatch.setattr(outdir, "write_json", full)
    with pytest.raises(StorageFullError, match="nothing was written"):
        with output_folder(out, "run") as f:
            write_text(f.staging / "summary.json", '{"new": 1}')
    assert _digests(out) == before
    assert json.loads((out / "summary.json").read_text()) == {"old": 1}
    assert not list(out.glob(".grainmech-staging-*"))

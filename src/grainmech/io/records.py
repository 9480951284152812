"""Finished parts of a long run, saved the moment they finish, for a run that takes them up again.

A cyclic test is a list of amplitudes, each run from the same initial state; a model's
path is one run. ``grainmech run`` saves each finished one into ``OUTDIR/resume/``,
outside the staging folder (:mod:`grainmech.io.outdir`), so that it survives Ctrl-C,
SIGTERM and SIGKILL::

    OUTDIR/resume/
      config.json                        the config the records came from (normalised:
                                         :func:`normal_config`) and grainmech's version
      <model>-<amplitude>-<key>.npz      one finished amplitude of one model: its whole
                                         run (every array of the DriverResult) and the
                                         model's Gmax
      <model>-path-<key>.npz             one model's finished path
      <model>-path-step<k>-<key>.pkl     a model's path saved after step k, the end of
                                         one of its segments (its point and rows, the DEM
                                         model's LAMMPS restart file; pickled), while the
                                         path runs; the latest one only

Every file is written to a temporary name and renamed (:func:`grainmech.io.results.atomic_write`):
a file that exists is complete. ``key`` (:func:`record_key`) is a hash of everything that
produced the record: the normalised config, the model, the amplitude and grainmech's
version. ``grainmech run --resume`` (:class:`RunRecords`) refuses a folder whose
``config.json`` differs from the present config, naming the first key that differs
(:func:`first_difference`), and takes up every record whose key matches.

What a finished run is: one that returned (completed, stopped by the model's physics,
liquefied), not one that was interrupted or whose process died before it recorded a
state (:func:`finished`). ``grainmech site`` names its amplitude files with the same
:func:`record_key` and :func:`amp_id`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import io
import json
import pickle
from pathlib import Path
from typing import Any

import numpy as np

import grainmech
from grainmech.driver.base import DriverResult, Status
from grainmech.errors import ConfigError, GrainmechError
from grainmech.io.config import FILE_KEYS
from grainmech.io.results import atomic_write, ensure_dir, write_json

__all__ = ["RECORDS_DIR", "RunRecords", "amp_id", "record_key", "normal_config", "first_difference", "finished",
           "save_result", "load_result", "save_config", "check_config"]

#: the folder of the records inside OUTDIR
RECORDS_DIR = "resume"
_CONFIG = "config.json"


def amp_id(a: float) -> float:
    """An amplitude as a dictionary key (12 significant digits: the same one as written in a config)."""
    return float(f"{float(a):.12g}")


def record_key(inputs: dict, model: str, amplitude: float | None, version: str | None = None) -> str:
    """A 16-hex-digit hash of what produces one record.

    SHA-256 of the canonical JSON of ``inputs`` (the config and whatever else decides the
    result) with the model's name, the amplitude (:func:`amp_id`; ``None`` for a path)
    and grainmech's version (default the running one).
    """
    blob = json.dumps({**inputs, "method": model, "amplitude": None if amplitude is None else amp_id(amplitude),
                       "version": grainmech.__version__ if version is None else version},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:16]


def _file_digest(path: str) -> str | None:
    """``"sha256:<hex>"`` of a file's content, or None if it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
    except OSError:
        return None
    return "sha256:" + h.hexdigest()


def normal_config(cfg: dict, leave_out: tuple[tuple[str, str], ...] = ()) -> dict:
    """The config as the records compare it: a JSON round trip without the keys ``leave_out``.

    ``leave_out`` names ``(table, key)`` pairs that do not change a record (a run's
    amplitude lists and its list of models: every amplitude starts from the same initial
    state). A file named by a config key (:data:`grainmech.io.config.FILE_KEYS`) stands
    as the hash of its content, so a changed file counts as a changed key and a moved one
    does not.
    """
    out = json.loads(json.dumps(cfg, default=str, sort_keys=True))
    for table, key in leave_out:
        sec = out.get(table)
        if isinstance(sec, dict):
            sec.pop(key, None)
    for table, key in FILE_KEYS:
        sec = out.get(table)
        if isinstance(sec, dict) and isinstance(sec.get(key), str):
            digest = _file_digest(sec[key])
            if digest is not None:
                sec[key] = digest
    return out


def first_difference(old: Any, new: Any, where: str = "") -> str | None:
    """The dotted key of the first difference between two JSON values (keys in sorted order), or None.

    A list of tables of the same length (``[[layers]]``) is followed into the first table
    that differs (``layers[0].void_ratio``); any other list that differs is named as a
    whole (``test.amplitudes``); the empty string names the top level.
    """
    if (isinstance(old, list) and isinstance(new, list) and len(old) == len(new)
            and all(isinstance(v, dict) for v in old + new)):
        for i, (a, b) in enumerate(zip(old, new)):
            d = first_difference(a, b, f"{where}[{i}]")
            if d is not None:
                return d
        return None
    if isinstance(old, dict) and isinstance(new, dict):
        for k in sorted(set(old) | set(new)):
            sub = f"{where}.{k}" if where else str(k)
            if k not in old or k not in new:
                return sub
            d = first_difference(old[k], new[k], sub)
            if d is not None:
                return d
        return None
    return None if old == new else where


def finished(result: Any) -> bool:
    """Whether a run's result is a finished one worth keeping.

    It returned with at least its initial state recorded and was not interrupted: it
    completed, the model stopped (no equilibrium of its fixed geometry, its range left:
    the same inputs stop it again) or it liquefied. A run whose process died before it
    recorded a state (a DEM worker killed or out of memory) runs again.
    """
    return int(result.status) != Status.INTERRUPTED and len(result.strain) > 0


def _result_classes() -> dict[str, type]:
    """Every :class:`~grainmech.driver.base.DriverResult` class imported so far, by module and name."""
    seen: dict[str, type] = {}
    todo: list[type] = [DriverResult]
    while todo:
        c = todo.pop()
        seen[f"{c.__module__}.{c.__qualname__}"] = c
        todo.extend(c.__subclasses__())
    return seen


def _plain(v: Any) -> Any:
    """A field value as JSON: NumPy scalars as Python numbers, tuples as lists."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    return v


def save_result(path: str | Path, result: Any, meta: dict) -> Path:
    """Save a run's result (every field of its DriverResult class but the live ``final`` state) and ``meta``.

    Arrays are stored as they are (bit for bit, ``.npz``); the other fields, the class
    and ``meta`` as JSON inside the same file. Written atomically.
    """
    arrays: dict[str, np.ndarray] = {}
    fields: dict[str, Any] = {}
    tuples: list[str] = []
    dicts: dict[str, list[str]] = {}
    for f in dataclasses.fields(result):
        v = getattr(result, f.name)
        if f.name == "final":
            continue
        if isinstance(v, np.ndarray):
            arrays[f"a.{f.name}"] = v
        elif isinstance(v, dict) and v and all(isinstance(x, np.ndarray) for x in v.values()):
            dicts[f.name] = [str(k) for k in v]
            for i, x in enumerate(v.values()):
                arrays[f"d.{f.name}.{i}"] = x
        else:
            if isinstance(v, tuple):
                tuples.append(f.name)
            fields[f.name] = _plain(v)
    head = {"class": f"{type(result).__module__}.{type(result).__qualname__}", "fields": fields,
            "tuples": tuples, "dicts": dicts, "meta": _plain(meta)}
    arrays["meta"] = np.array(json.dumps(head))
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # type: ignore[arg-type]  # (numpy's stub types the keywords as allow_pickle)
    return atomic_write(path, lambda fh: fh.write(buf.getvalue()), binary=True)


def load_result(path: str | Path) -> tuple[Any, dict] | None:
    """A result saved by :func:`save_result` and its ``meta``; None if absent, unreadable or of an unknown class."""
    try:
        with np.load(path, allow_pickle=False) as z:
            head = json.loads(str(z["meta"]))
            arrays = {k: np.array(z[k]) for k in z.files if k != "meta"}
        cls = _result_classes().get(head["class"])
        if cls is None:
            return None
        kw: dict[str, Any] = dict(head["fields"])
        for name in head["tuples"]:
            kw[name] = tuple(kw[name])
        for k, v in arrays.items():
            if k.startswith("a."):
                kw[k[2:]] = v
        for name, keys in head["dicts"].items():
            kw[name] = {key: arrays[f"d.{name}.{i}"] for i, key in enumerate(keys)}
        return cls(final=None, **kw), head["meta"]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


class RunRecords:
    """The records of one run's output folder (``OUTDIR/resume``, see the module docstring).

    Parameters
    ----------
    folder : path
        ``OUTDIR/resume``.
    config : dict
        The run's config, normalised (:func:`normal_config`).
    resume : bool
        True: take up the records there (:meth:`start` checks that the config is the
        same); False: a new run, whose first record replaces what is there.
    """

    def __init__(self, folder: str | Path, config: dict, resume: bool) -> None:
        self.folder, self.config, self.resume = Path(folder), config, bool(resume)
        self._started = False  # config.json written by this run
        self._cache: dict[str, tuple[Any, dict] | None] = {}

    def start(self) -> None:
        """Check, before the run, that the records may be taken up (``resume`` only).

        Raises
        ------
        GrainmechError
            No ``config.json`` in the folder: nothing to resume.
        ConfigError
            The config differs from the one the records came from (names the first key
            that differs), or grainmech's version does.
        """
        if not self.resume:
            return
        if not check_config(self.folder / _CONFIG, self.config, "the run being resumed",
                            "--resume takes up only the same config: restore it, or run without --resume (or use "
                            "another -o)", self.folder.parent):
            raise GrainmechError(f"--resume: nothing to resume in {self.folder.parent}: no {RECORDS_DIR}/{_CONFIG} "
                                 "(a run writes it with its first finished amplitude or path); run without --resume")
        self._started = True

    def _name(self, model: str, amplitude: float | None) -> Path:
        key = record_key({"config": self.config}, model, amplitude)
        what = "path" if amplitude is None else f"{amp_id(amplitude):.12g}"
        return self.folder / f"{model}-{what}-{key}.npz"

    def get(self, model: str, amplitude: float | None = None) -> tuple[Any, dict] | None:
        """The saved result of ``model`` at ``amplitude`` (None: its path) and its meta, or None.

        Only with ``resume``: a new run takes nothing up.
        """
        if not self.resume:
            return None
        p = self._name(model, amplitude)
        if str(p) not in self._cache:
            got = load_result(p)
            ok = got is not None and got[1].get("key") == p.stem.rsplit("-", 1)[1]
            self._cache[str(p)] = got if ok else None
        return self._cache[str(p)]

    def save(self, model: str, amplitude: float | None, result: Any, meta: dict | None = None) -> Path | None:
        """Save a finished result (:func:`finished`; others are not saved: None).

        A finished path replaces the model's path saved at a segment's end (:meth:`save_step`).
        """
        if not finished(result):
            return None
        self._begin()
        p = self._name(model, amplitude)
        out = save_result(p, result, {**(meta or {}), "model": model, "amplitude": amplitude,
                                      "key": p.stem.rsplit("-", 1)[1]})
        if amplitude is None:
            self._drop_steps(model)
        return out

    def _begin(self) -> None:
        """Before this run's first record: a new run replaces what an earlier one left; config.json."""
        if self._started:
            return
        ensure_dir(self.folder)
        if not self.resume:
            for old in [*self.folder.glob("*.npz"), *self.folder.glob("*.pkl")]:
                with contextlib.suppress(OSError):
                    old.unlink()
        save_config(self.folder / _CONFIG, self.config)
        self._started = True

    def _steps(self, model: str) -> dict[int, Path]:
        """The model's path states saved at a segment's end by this config: step -> file."""
        key = record_key({"config": self.config}, model, None)
        out = {}
        for f in self.folder.glob(f"{model}-path-step*-{key}.pkl"):
            with contextlib.suppress(ValueError):
                out[int(f.name[len(f"{model}-path-step"):].split("-", 1)[0])] = f
        return out

    def _drop_steps(self, model: str, keep: int | None = None) -> None:
        for k, f in self._steps(model).items():
            if k != keep:
                with contextlib.suppress(OSError):
                    f.unlink()

    def save_step(self, model: str, k: int, state: dict) -> Path:
        """Save ``model``'s path state after step ``k`` (a segment's end), replacing the one before.

        ``state`` is the model's picklable state (:class:`grainmech.driver.loop.PathCheckpoint`).
        """
        self._begin()
        key = record_key({"config": self.config}, model, None)
        p = self.folder / f"{model}-path-step{int(k)}-{key}.pkl"
        atomic_write(p, lambda fh: pickle.dump({"key": key, "step": int(k), "state": state}, fh,
                                               protocol=pickle.HIGHEST_PROTOCOL), binary=True)
        self._drop_steps(model, keep=int(k))
        return p

    def step(self, model: str) -> tuple[int, dict] | None:
        """``(k, state)`` of ``model``'s path saved after step ``k`` by an earlier run of this config, or None.

        Only with ``resume``. The latest one that reads back whole; a file that does not is skipped.
        """
        if not self.resume:
            return None
        for k, f in sorted(self._steps(model).items(), reverse=True):
            try:
                with open(f, "rb") as fh:
                    got = pickle.load(fh)
            except Exception:  # noqa: BLE001 - a file that does not read back is not taken up
                continue
            if isinstance(got, dict) and got.get("step") == k and isinstance(got.get("state"), dict):
                return k, got["state"]
        return None


def save_config(path: str | Path, config: dict) -> Path:
    """Save the normalised ``config`` records came from, with grainmech's version (:func:`check_config` reads it)."""
    return write_json(path, {"version": grainmech.__version__, "config": config})


def check_config(path: str | Path, config: dict, what: str, hint: str, where: str | Path | None = None) -> bool:
    """Whether records made from the config saved at ``path`` (:func:`save_config`) may be taken up.

    Returns False when nothing is saved there; True when the saved config and version
    equal ``config`` and the running version. ``where``: the output folder a message names
    (default the file's folder).

    Raises
    ------
    ConfigError
        A key differs: the message names the first (:func:`first_difference`), its value
        here and there (``what``: whose records they are, ``"the run being resumed"``), and
        says what to do (``hint``).
    GrainmechError
        The records were made by another version of grainmech.
    """
    try:
        old = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    folder = Path(path).parent if where is None else where
    if not isinstance(old, dict) or old.get("version") != grainmech.__version__:
        raise GrainmechError(f"the records of {what} in {folder} were made by grainmech "
                             f"{old.get('version') if isinstance(old, dict) else '?'}, this is "
                             f"{grainmech.__version__}: they are not taken up; {hint}")
    key = first_difference(old.get("config"), config)
    if key is not None:
        raise ConfigError(key or "(config)", _value_at(config, key),
                          f"differs from the config of {what} in {folder} "
                          f"(there: {_value_at(old.get('config'), key)!r}); {hint}")
    return True


def _value_at(cfg: Any, key: str) -> Any:
    """The value at a dotted ``key`` of a config (None where it is missing)."""
    v = cfg
    for part in key.replace("[", ".[").split(".") if key else []:
        if part.startswith("[") and part.endswith("]"):  # a table of a list of tables: layers[0]
            i = int(part[1:-1])
            if not isinstance(v, list) or i >= len(v):
                return None
            v = v[i]
            continue
        if not isinstance(v, dict) or part not in v:
            return None
        v = v[part]
    return v

"""Run a soil profile: every layer on dask.distributed, saved as it finishes, resumable.

Order of work (``docs/site-profile.md``):

1. every layer's run config is checked (:func:`grainmech.site.layer.prepare_layer`) --
   a bad layer stops everything with one line naming it, before anything is written;
2. the layers with a measured ``vs`` whose anchoring is not saved are anchored
   (:func:`grainmech.site.layer.anchor_task`, in parallel); a ``vs`` that needs a grain
   modulus outside 1-1000 GPa is a bad input (nothing written); each anchoring is saved
   in ``OUTDIR/layers/<NN-name>/``;
3. every layer runs the amplitudes it has not saved (:func:`grainmech.site.layer.run_task`,
   in parallel on the workers of :func:`grainmech.parallel.open_client`, as ``grainmech
   sweep`` does, or one after the other here); each amplitude is saved in
   ``OUTDIR/layers/<NN-name>/`` the moment it finishes, so a killed run restarted on the
   same folder skips every finished amplitude (:mod:`grainmech.site.amplitudes`; a layer
   with every amplitude saved only rebuilds its curve); the layer's record is written to
   ``OUTDIR/layers/<NN-name>.json`` when it is done;
4. curve files, ``layers.csv``, ``profile.png``, the site response (with ``[motion]``
   and pystrata), ``summary.json`` and ``index.html``.
"""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from grainmech.errors import ConfigError
from grainmech.io.motion import read_motion
from grainmech.io.outdir import output_folder
from grainmech.io.records import check_config, normal_config, save_config
from grainmech.io.results import ensure_dir
from grainmech.io.site_profile import read_anchor, write_anchor, write_layer_record
from grainmech.jobs.progress import Heartbeat
from grainmech.parallel import map_completed, open_client
from grainmech.site.layer import anchor_task, check_anchor, failed_record, layer_key, prepare_layer, run_task
from grainmech.site.outputs import write_outputs
from grainmech.site.profile import SiteProfile

__all__ = ["run_site", "LayerWatch", "SITE_PROGRESS_EVERY"]

#: seconds between two progress lines while a layer runs (at most)
SITE_PROGRESS_EVERY = 10.0


def _say(quiet: bool) -> Callable[[str], None]:
    def say(msg: str) -> None:
        if not quiet:
            print(msg, file=sys.stderr, flush=True)
    return say


def _in_process(client: Any, scheduler: str | None, workers: int | None) -> bool:
    """Whether the layers run one after the other in this process (no cluster)."""
    return client is None and scheduler is None and (workers is None or workers == 1)


#: a model's line saying that one of its amplitudes stopped (``jobs.model.execute_model``)
_STOPPED = re.compile(r"^\[\w+\] amplitude \S+ stopped: ")


class LayerWatch:
    """What the site's progress line says while layers run (read by a :class:`Heartbeat`).

    ``start(label)`` (a layer starts in this process), ``note(message)`` (the model's own
    progress lines: amplitude, step, its time left), ``done(seconds)`` (a layer finished).
    :meth:`line` says which layer runs and for how long, the model's latest line, and the
    time left of the profile once a layer has finished in this run (the mean seconds of the
    layers finished times the layers left, less what the running one has had). On a
    cluster the layers run elsewhere: the line counts them and gives the elapsed time.
    """

    def __init__(self, total: int, todo: int, in_process: bool, clock: Callable[[], float] = time.perf_counter,
                 say: Callable[[str], None] | None = None):
        self.total, self.todo, self.in_process, self.clock = total, todo, in_process, clock
        self.say = say
        self.t0 = self.t_layer = clock()
        self.label, self.index, self.latest, self.t_latest = "", 0, "", 0.0
        self.seconds: list[float] = []

    def start(self, label: str) -> None:
        """A layer starts in this process."""
        self.label, self.latest = label, ""
        self.index += 1
        self.t_layer = self.clock()

    def note(self, message: str) -> None:
        """The model's latest progress line; an amplitude's stop is also said at once (with ``say``)."""
        self.latest, self.t_latest = message, self.clock()
        if self.say is not None and _STOPPED.match(message):
            self.say(f"[site] layer {self.index}/{self.todo} {self.label}: {message}")

    def done(self, seconds: float | None) -> None:
        """A layer finished after ``seconds`` (None: not known)."""
        if seconds is not None:
            self.seconds.append(float(seconds))

    def line(self) -> str:
        """The progress line now."""
        now = self.clock()
        if not self.in_process:
            text = (f"[site] {len(self.seconds)}/{self.todo} layer(s) of this run finished on the cluster, "
                    f"{now - self.t0:.0f} s")
        else:
            text = f"[site] layer {self.index}/{self.todo} {self.label}: running {now - self.t_layer:.0f} s"
            if self.latest:
                age = now - self.t_latest
                text += f"; {self.latest}" + (f" ({age:.0f} s ago)" if age >= 1 else "")
        if self.seconds:
            left_layers = self.todo - len(self.seconds)
            mean = sum(self.seconds) / len(self.seconds)
            running = (now - self.t_layer) if self.in_process else 0.0
            text += f"; profile: about {max(mean * left_layers - running, 0.0):.0f} s left"
        return text


def _parallel(fn: Callable[[Any], Any], items: list, client: Any, scheduler: str | None,
              workers: int | None, local: Callable[[Any], Any] | None = None) -> Any:
    """``(index, value, ok)`` of ``fn`` over ``items`` in completion order.

    On a Dask cluster (:func:`grainmech.parallel.map_completed`) when a client, a
    scheduler or more than one worker is given; in this process, one item after the other,
    otherwise (what one in-process Dask worker would do, without starting a cluster), with
    ``local`` instead of ``fn`` when given (it may hold what cannot travel to a worker).
    """
    if _in_process(client, scheduler, workers):
        for i, item in enumerate(items):
            try:
                value, ok = (local or fn)(item), True
            except Exception as exc:  # noqa: BLE001 (reported as the item's failure, as on Dask)
                value, ok = exc, False
            yield i, value, ok
        return

    if client is not None:
        yield from map_completed(fn, items, client=client)
        return
    with open_client(scheduler, workers) as cl:
        yield from map_completed(fn, items, client=cl)


def run_site(profile: SiteProfile, outdir: str | Path, *, client: Any = None, scheduler: str | None = None,
             workers: int | None = None, quiet: bool = True, response: bool = True, resume: bool = True) -> dict:
    """Run every layer of ``profile`` not yet recorded in ``outdir``; write every output.

    Parameters
    ----------
    profile : SiteProfile
        From :func:`grainmech.site.read_profile` / :func:`grainmech.site.load_profile`.
    outdir : path
        Output folder; every finished amplitude is saved in ``outdir/layers/<NN-name>/``.
    client, scheduler, workers
        As :func:`grainmech.sweep.run_sweep`: a Dask client, or a scheduler address, or a
        number of local workers; default (none of them, or ``workers = 1``): the layers
        one after the other in this process.
    quiet : bool
        No progress lines on stderr.
    response : bool
        Run the site-response calculation when ``[motion]`` is given and pystrata is
        installed.
    resume : bool
        Skip every amplitude (and anchoring) saved in ``outdir`` by an earlier run with the
        same inputs (``grainmech site --resume``); False: run everything again.

    Returns
    -------
    dict
        The summary (also ``summary.json``): ``succeeded``, ``stopped``, ``failed``,
        ``reused``, ``ran``, ``files``, ``layers`` (the records) ...

    Raises
    ------
    ConfigError
        A bad layer or anchoring (nothing written).
    """
    say = _say(quiet)
    t0 = time.perf_counter()
    base = str(profile.base_dir.resolve())
    for layer in profile.layers:  # 1. every layer's config, before any work
        prepare_layer(layer, base)
    motion = None
    if profile.motion is not None:  # a bad motion file is a bad input too

        motion = read_motion(profile.motion.path, profile.motion.format, profile.motion.units)
    with output_folder(outdir, "site") as folder:
        summary = _run_in(folder, profile, base, say, (client, scheduler, workers), response, motion, t0, resume)
        folder.commit(success=summary["stopped"] == 0 and summary["failed"] == 0)
    return summary


#: what the saved amplitudes of ``OUTDIR/layers`` came from (:func:`profile_record`), checked by ``--resume``
PROFILE_CONFIG = "profile-config.json"


def profile_record(profile: SiteProfile) -> dict:
    """The profile as ``--resume`` compares it (:func:`grainmech.io.records.normal_config`).

    Its config without the tables that do not change a layer's curve (``[motion]``,
    ``[bedrock]``: the response is computed again anyway), the amplitude list and the list
    of models (each amplitude starts from the same state).
    """
    raw = {k: v for k, v in profile.raw.items() if k not in ("motion", "bedrock")}
    return normal_config(raw, (("test", "amplitudes"), ("model", "method")))


def _run_in(folder: Any, profile: SiteProfile, base: str, say: Callable[[str], None], cluster: tuple,
            response: bool, motion: Any, t0: float, resume: bool = True) -> dict:
    ldir = folder.path / "layers"
    made_of = profile_record(profile)
    if resume:  # records of another profile are not taken up: refused naming the first key that differs
        check_config(ldir / PROFILE_CONFIG, made_of, "the profile being resumed",
                     "run without --resume (every amplitude again) or into another folder", where=folder.path)
    records: dict[int, dict] = {}
    anchors: dict[int, dict] = {}
    for layer in profile.layers:
        if layer.vs is not None and resume:
            a = read_anchor(ldir / layer.slug, layer_key(layer))
            if a is not None:
                anchors[layer.index] = a
    say(f"grainmech site: {profile.source}: {len(profile.layers)} layers ({profile.method.replace('+', ' + ')} "
        "model); " + ("finished amplitudes saved in the output folder are skipped" if resume else
                      "every amplitude runs (--resume skips those saved in the output folder)"))
    errors: dict[int, BaseException] = {}
    need = [la for la in profile.layers if la.vs is not None and la.index not in anchors]
    if need:  # 2. anchoring: a bad vs is an input error, raised before anything is written
        say(f"anchoring {len(need)} layer(s) to their measured Vs")
        for i, value, ok in _parallel(anchor_task, [(la, base) for la in need], *cluster):
            if ok:
                anchors[need[i].index] = value
            else:
                errors[need[i].index] = value
        for la in need:
            err = errors.get(la.index)
            if isinstance(err, ConfigError):
                raise err
            if err is None:
                check_anchor(la, anchors[la.index])
    ensure_dir(ldir)
    save_config(ldir / PROFILE_CONFIG, made_of)
    for la in need:
        if la.index in anchors:
            write_anchor(ldir / la.slug, layer_key(la), anchors[la.index])
    for la in need:  # a model that cannot give its Gmax at the layer's stress: the layer stops there
        if la.index in errors:
            rec = failed_record(la, errors[la.index])
            rec.update(status="stopped", message=f"anchoring to the measured Vs failed: {rec['message']}")
            write_layer_record(ldir / f"{la.slug}.json", rec)
            records[la.index] = rec
            say(f"{la.label}: stopped: {rec['message']}")
    todo = [la for la in profile.layers if la.index not in records]
    if todo:  # 3. the layers, every amplitude saved as it finishes
        tasks = [(la, base, anchors.get(la.index), str(ldir / la.slug), resume) for la in todo]
        watch = LayerWatch(len(profile.layers), len(todo), _in_process(cluster[0], cluster[1], cluster[2]), say=say)

        def local(task: tuple) -> dict:
            watch.start(task[0].label)
            return run_task(task, watch.note)

        # a line at least every 10 s while a layer runs (which layer, the model's amplitude and step, time left)
        with Heartbeat(say, watch.line, SITE_PROGRESS_EVERY):
            client, scheduler, workers = cluster
            for i, value, ok in _parallel(run_task, tasks, client, scheduler, workers, local=local):
                la = todo[i]
                rec = value if ok else failed_record(la, value)
                write_layer_record(ldir / f"{la.slug}.json", rec)
                records[la.index] = rec
                watch.done(rec.get("seconds"))
                say(f"[{len(records)}/{len(profile.layers)}] {la.label}: {rec['status']}"
                    + ("" if rec["status"] == "ok" else f": {rec['message']}")
                    + (f" ({rec.get('amplitudes_run', 0)} amplitude(s) run, {rec.get('amplitudes_reused', 0)} "
                       "reused" if "amplitudes_run" in rec else " (")
                    + (f", {rec['seconds']:.1f} s)" if rec.get("seconds") is not None else ")"))
    ordered = [records[la.index] for la in profile.layers]
    reused = sum(1 for r in ordered if r.get("amplitudes_reused") and not r.get("amplitudes_run"))
    return write_outputs(folder.staging, profile, ordered, reused=reused, ran=len(ordered) - reused,
                         response=response, say=say, seconds=time.perf_counter() - t0, motion=motion)

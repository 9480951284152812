"""Run a sweep on dask.distributed: persist every point as it finishes, resume, tabulate.

Layout of the output directory::

    OUTDIR/
      sweep.json             the sweep as read (kind, design, parameters, base config)
      points/<point-id>.json one file per finished point (written atomically)
      points-config.json     the run kind and base config the points came from, grainmech's version
      sweep.csv              the table: one row per point, in point-index order
      sweep.parquet          the same table, if pyarrow is installed
      summary.json           counts (succeeded, failed, reused, ran), timings, files
      summary.png            headline outputs against the swept inputs (unless disabled)

A point's file is written (temporary file + ``os.replace``) as soon as its result
arrives, so a killed sweep loses at most the points that were running. Restarted on the
same directory, the sweep reuses every point whose file exists -- ``status = "ok"``, or
``"failed"`` unless ``retry_failed`` -- and runs only the others; the final table is
built from the point files and is identical to an uninterrupted run. A point's id is a
hash of its whole config, so another design or other parameter values reuse the points
they share; a changed run kind, base config or grainmech version is refused before
anything runs, naming the first key that differs (:func:`grainmech.io.records.check_config`).
"""

from __future__ import annotations

import csv
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from grainmech.io.config import resolve_file_keys
from grainmech.io.outdir import output_folder
from grainmech.io.records import check_config, normal_config, save_config
from grainmech.io.results import _jsonable, atomic_write, ensure_dir, write_json
from grainmech.parallel import map_completed, open_client
from grainmech.sweep.kinds import SWEEP_KINDS, run_point
from grainmech.sweep.report import summary_plot
from grainmech.sweep.spec import Point, Sweep

__all__ = ["run_sweep", "load_record", "table_rows", "write_table", "evaluate_task", "evaluate_batch"]

TABLE = "sweep.csv"
#: what the points of ``OUTDIR/points`` came from (:func:`grainmech.io.records.save_config`), in OUTDIR
POINTS_CONFIG = "points-config.json"


def evaluate_task(task: tuple[str, dict, str | None]) -> dict[str, Any]:
    """Worker function: run one point and time it -> ``{"outputs": ..., "seconds": ...}``."""
    t0 = time.perf_counter()
    outputs = run_point(task)
    return {"outputs": outputs, "seconds": time.perf_counter() - t0}


def evaluate_batch(tasks: list[tuple[str, dict, str | None]]) -> list[tuple[bool, Any]]:
    """Worker function for several points: ``[(ok, evaluate_task(t) or the exception)]``.

    A failing point never stops the others of the batch.
    """
    out: list[tuple[bool, Any]] = []
    for t in tasks:
        try:
            out.append((True, evaluate_task(t)))
        except Exception as exc:  # noqa: BLE001 (recorded as the point's failure)
            out.append((False, exc))
    return out


def _batches(n: int, kind: str, workers: int) -> list[list[int]]:
    """Point indices grouped into tasks.

    At most the kind's batch size, and at least four tasks per worker thread so that the
    workers stay busy to the end.
    """
    size = max(1, min(SWEEP_KINDS[kind].batch, n // (4 * max(workers, 1))))
    return [list(range(k, min(n, k + size))) for k in range(0, n, size)]


def _normalise(obj: Any) -> Any:
    """What a JSON round trip gives (NumPy -> Python, non-finite -> None)."""
    return json.loads(json.dumps(_jsonable(obj)))


def load_record(path: Path) -> dict | None:
    """A point file, or None if it is missing or unreadable (then the point runs again)."""
    try:
        with open(path, encoding="utf-8") as fh:
            rec = json.load(fh)
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("status") not in ("ok", "failed"):
        return None
    return rec


def _inputs(sweep: Sweep, pt: Point) -> dict[str, Any]:
    return {p.column: v for p, v in zip(sweep.parameters, pt.values)}


def _record(sweep: Sweep, pt: Point, value: Any, ok: bool) -> dict:
    rec: dict[str, Any] = {"point_id": pt.id, "index": pt.index, "kind": sweep.kind,
                           "inputs": _inputs(sweep, pt)}
    if ok:
        rec.update(status="ok", error="", outputs=value["outputs"], seconds=value["seconds"])
    else:
        msg = str(value) or type(value).__name__
        rec.update(status="failed", error=f"{type(value).__name__}: {msg}", outputs={}, seconds=None)
    rec["config"] = pt.config
    return _normalise(rec)


def table_rows(sweep: Sweep, records: dict[str, dict]) -> tuple[list[str], list[list[Any]]]:
    """Header and rows (point-index order) from the point records (keyed by point id)."""
    out_cols: list[str] = []
    seen: set[str] = set()
    for pt in sweep.points:
        for k in records[pt.id].get("outputs", {}):
            if k not in seen:
                seen.add(k)
                out_cols.append(k)
    in_cols = [p.column for p in sweep.parameters]
    header = ["index", "point_id"] + in_cols + out_cols + ["status", "error"]
    rows = []
    for pt in sweep.points:
        rec = records[pt.id]
        outs = rec.get("outputs", {})
        rows.append([pt.index, pt.id] + list(_normalise(list(pt.values)))
                    + [outs.get(k) for k in out_cols] + [rec["status"], rec.get("error", "")])
    return header, rows


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    return str(v)


def write_table(outdir: Path, header: list[str], rows: list[list[Any]]) -> list[str]:
    """``sweep.csv`` (full float precision) and, if pyarrow is importable, ``sweep.parquet``."""

    def w(fh: Any) -> None:
        wr = csv.writer(fh, lineterminator="\n")
        wr.writerow(header)
        for r in rows:
            wr.writerow([_cell(v) for v in r])

    atomic_write(outdir / TABLE, w)
    files = [TABLE]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return files
    cols = {h: [r[j] for r in rows] for j, h in enumerate(header)}
    arrays = {}
    for h, vals in cols.items():
        try:
            arrays[h] = pa.array(vals)
        except (pa.ArrowInvalid, pa.ArrowTypeError):  # mixed types: keep as text
            arrays[h] = pa.array([None if v is None else _cell(v) for v in vals])
    atomic_write(outdir / "sweep.parquet", lambda fh: pq.write_table(pa.table(arrays), fh), binary=True)
    return files + ["sweep.parquet"]


class _Progress:
    """One status line on stderr (rewritten in place on a terminal)."""

    def __init__(self, total: int, quiet: bool) -> None:
        self.total, self.quiet = total, quiet
        self.done = self.failed = 0
        self.t0 = time.perf_counter()
        self.tty = sys.stderr.isatty()
        self.every = max(1, total // 20)

    def update(self, rec: dict) -> None:
        self.done += 1
        self.failed += rec["status"] != "ok"
        if self.quiet:
            return
        if rec["status"] != "ok":
            self._line(f"point {rec['index']} ({rec['point_id']}) failed: {rec['error']}", newline=True)
        if self.tty or self.done % self.every == 0 or self.done == self.total:
            el = time.perf_counter() - self.t0
            self._line(f"[{self.done}/{self.total}] points done, {self.failed} failed, {el:.1f} s",
                       newline=not self.tty or self.done == self.total)

    def _line(self, text: str, newline: bool) -> None:
        if self.tty:
            sys.stderr.write("\r\033[K" + text + ("\n" if newline else ""))
        else:
            sys.stderr.write(text + "\n")
        sys.stderr.flush()


def run_sweep(sweep: Sweep, outdir: str | Path, *, client: Any = None, scheduler: str | None = None,
              workers: int | None = None, retry_failed: bool = False, quiet: bool = True,
              plots: bool = True, on_record: Callable[[dict], None] | None = None) -> dict:
    """Run the points of ``sweep`` not yet in ``outdir``; write the table and summary.

    Parameters
    ----------
    sweep : Sweep
        From :func:`grainmech.sweep.load_sweep`.
    outdir : path
        Output directory (created); reused points are read from ``outdir/points``.
    client : distributed.Client, optional
        Use this client; otherwise :func:`grainmech.parallel.open_client` is called with
        ``scheduler`` and ``workers`` (only if some point needs running).
    retry_failed : bool
        Run again the points recorded as failed.
    quiet : bool
        No progress lines on stderr.
    plots : bool
        Write ``summary.png`` (matplotlib).
    on_record : callable, optional
        Called with each new point record right after its file is written.

    Returns
    -------
    dict
        The summary (also written to ``summary.json``): ``n_points``, ``succeeded``,
        ``failed``, ``reused``, ``ran``, ``seconds``, ``files`` ...
    """
    # checked and locked before the work; the table, plot and summary are staged and moved
    # in at the end, the finished points persist in OUTDIR/points as they arrive (resume)
    with output_folder(outdir, "sweep") as folder:
        summary = _run_in(folder, sweep, client=client, scheduler=scheduler, workers=workers,
                          retry_failed=retry_failed, quiet=quiet, plots=plots, on_record=on_record)
        folder.commit(success=summary["failed"] == 0)
    return summary


def _run_in(folder: Any, sweep: Sweep, *, client: Any, scheduler: str | None, workers: int | None,
            retry_failed: bool, quiet: bool, plots: bool,
            on_record: Callable[[dict], None] | None) -> dict:
    """The body of :func:`run_sweep` in an opened :class:`grainmech.io.outdir.OutputFolder`."""
    t0 = time.perf_counter()
    out, stage = folder.path, folder.staging
    pdir = ensure_dir(out / "points")
    made_of = {"kind": sweep.kind, "base": normal_config(resolve_file_keys(sweep.base, sweep.base_dir))}
    if not check_config(out / POINTS_CONFIG, made_of, "the sweep whose points are kept",
                        "a sweep takes up its finished points only for the same run kind and base config: restore "
                        "it, or use another -o (or remove the folder points/ there to run every point again)"):
        save_config(out / POINTS_CONFIG, made_of)
    write_json(stage / "sweep.json", sweep.describe())
    records: dict[str, dict] = {}
    todo: list[Point] = []
    for pt in sweep.points:
        rec = load_record(pdir / f"{pt.id}.json")
        if rec is not None and (rec["status"] == "ok" or not retry_failed):
            records[pt.id] = rec
        else:
            todo.append(pt)
    reused = len(records)
    prog = _Progress(len(todo), quiet)
    if not quiet:
        sys.stderr.write(f"grainmech sweep: {sweep.source}: {len(sweep.points)} points ({sweep.kind}, "
                         f"{sweep.design}), {reused} reused, {len(todo)} to run\n")
    if todo:
        base_dir = str(sweep.base_dir.resolve())
        tasks = [(sweep.kind, pt.config, base_dir) for pt in todo]

        def consume(cl: Any) -> None:
            groups = _batches(len(tasks), sweep.kind, sum(cl.nthreads().values()))
            items = [[tasks[i] for i in g] for g in groups]
            for b, value, ok in map_completed(evaluate_batch, items, client=cl):
                # a failed task (lost worker, cancelled) fails each of its points
                results = value if ok else [(False, value)] * len(groups[b])
                for i, (pok, pval) in zip(groups[b], results):
                    pt = todo[i]
                    rec = _record(sweep, pt, pval, pok)
                    write_json(pdir / f"{pt.id}.json", rec)
                    records[pt.id] = rec
                    prog.update(rec)
                    if on_record is not None:
                        on_record(rec)

        if client is not None:
            consume(client)
        else:
            with open_client(scheduler, workers) as cl:
                consume(cl)
    header, rows = table_rows(sweep, records)
    files = write_table(stage, header, rows)
    n_ok = sum(records[pt.id]["status"] == "ok" for pt in sweep.points)
    summary = {"source": sweep.source, "kind": sweep.kind, "design": sweep.design,
               "n_points": len(sweep.points), "succeeded": n_ok, "failed": len(sweep.points) - n_ok,
               "reused": reused, "ran": len(todo), "seconds": time.perf_counter() - t0,
               "failed_points": [pt.index for pt in sweep.points if records[pt.id]["status"] != "ok"],
               "files": ["sweep.json", "points/"] + files}
    if plots and n_ok:
        if summary_plot(sweep, header, rows, stage / "summary.png"):
            summary["files"].append("summary.png")
    summary["files"].append("summary.json")
    write_json(stage / "summary.json", summary)
    return summary

"""Dask glue: run many independent grainmech jobs on a ``dask.distributed`` cluster.

Two functions, used by the parameter sweeps (:mod:`grainmech.sweep`) and by multi-start
calibration:

* :func:`open_client` -- a context manager yielding a :class:`distributed.Client`: an
  in-process local cluster by default, ``workers=N`` local workers, or an existing
  cluster given by its scheduler address. The cluster it creates is shut down on exit.
* :func:`map_completed` -- submit ``fn(item)`` for every item and yield
  ``(index, result_or_exception, ok)`` in completion order.

Dask is an optional dependency (``pip install "grainmech[parallel]"``); it is imported
only when these functions are called, so ``import grainmech`` never needs it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
from collections.abc import Callable, Iterable, Iterator
from multiprocessing import resource_tracker
from typing import Any

from grainmech.errors import GrainmechError

__all__ = ["open_client", "map_completed", "import_distributed"]

#: seconds to wait for an existing scheduler before giving up
CONNECT_TIMEOUT = 10.0

#: environment of local worker processes (``workers > 1``)
_ONE_THREAD = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "OPENBLAS_NUM_THREADS": "1"}


def import_distributed() -> Any:
    """Import and return :mod:`distributed`, or raise a :class:`GrainmechError` telling the user how to install it."""
    try:
        import distributed  # noqa: PLC0415 (optional dependency, imported lazily)
    except ImportError as exc:
        raise GrainmechError(
            "parallel execution needs dask.distributed, which is not installed "
            f"({exc}); install it with: pip install \"grainmech[parallel]\"") from None
    return distributed


@contextlib.contextmanager
def open_client(scheduler: str | None = None,
                workers: int | None = None) -> Iterator[Any]:
    """Yield a :class:`distributed.Client`; shut down what was started on exit.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler (``"tcp://host:8786"``). When given, ``workers``
        must be ``None`` and the cluster is left running on exit (only the client closes).
    workers : int, optional
        Number of local workers. ``None`` or ``1``: one in-process worker with one
        thread (``LocalCluster(processes=False)``, no process start-up cost; compiled
        kernels may still use every core). ``N > 1``: ``N`` worker processes with one
        thread each (numerical code holds the GIL), started with ``NUMBA_NUM_THREADS``
        and the BLAS thread counts set to 1 so that ``N`` workers use ``N`` cores.

    Raises
    ------
    GrainmechError
        If dask.distributed is not installed, ``workers`` is not a positive integer, both
        arguments are given, or the scheduler cannot be reached.
    """
    distributed = import_distributed()
    if scheduler is not None and workers is not None:
        raise GrainmechError(f"workers = {workers!r}: give either a scheduler address or "
                             "a number of local workers, not both")
    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise GrainmechError(f"workers = {workers!r}: must be a positive integer")

    if scheduler is not None:
        if not isinstance(scheduler, str) or not scheduler.strip():
            raise GrainmechError(f"scheduler = {scheduler!r}: must be a scheduler address "
                                 "such as 'tcp://127.0.0.1:8786'")
        try:
            client = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT,
                                        set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise GrainmechError(f"scheduler = {scheduler!r}: cannot connect to the dask "
                                 f"scheduler ({type(exc).__name__}: {exc})") from None
        try:
            yield client
        finally:
            client.close()
        return

    n = 1 if workers is None else workers
    processes = n > 1
    # one thread per worker process: parallelism comes from the workers, so the compiled
    # kernels (numba prange) and BLAS must not each start a thread per core as well
    extra = {"env": dict(_ONE_THREAD)} if processes else {}
    if processes:
        _start_quiet_resource_tracker()
    cluster = distributed.LocalCluster(
        n_workers=n, threads_per_worker=1, processes=processes,
        dashboard_address=None, silence_logs=logging.CRITICAL,
        # no dashboard; the scheduler's small HTTP server (health, metrics) on a free port
        scheduler_kwargs={"dashboard_address": ":0"}, **extra)
    interrupted = False
    try:
        client = distributed.Client(cluster, set_as_default=False)
        try:
            yield client
        except KeyboardInterrupt:
            # Ctrl-C: stop the worker processes now (a task cannot be interrupted; a
            # graceful close would wait for the running ones)
            interrupted = True
            _quiet_logs()
            _kill_workers(cluster)
            raise
        finally:
            _close(client, interrupted)
    finally:
        _close(cluster, interrupted)


#: warnings filter handed to Python's multiprocessing resource tracker (``-W`` syntax)
_TRACKER_FILTER = "ignore:resource_tracker:UserWarning:multiprocessing.resource_tracker"


def _start_quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker without its shutdown warnings.

    Dask's local worker processes register semaphores with the resource tracker, a helper
    process that shares this process's stderr and, when every process has exited, unlinks
    what was left registered, with a warning for each. After Ctrl-C the workers are killed
    (:func:`_kill_workers`) before they unregister theirs, so the tracker's
    ``resource_tracker: ... leaked semaphore objects`` warnings (and a second warning for
    each one already unlinked) came out on the terminal *after* "grainmech: interrupted",
    the one line the user should see. The tracker inherits its
    warnings filters from ``sys.warnoptions`` when it starts, so it is started here with
    a filter for its own ``resource_tracker:`` warnings; the clean-up itself still runs.
    Nothing changes if the tracker is already running.
    """
    saved = list(sys.warnoptions)
    sys.warnoptions.append(_TRACKER_FILTER)
    try:
        resource_tracker.ensure_running()
    finally:
        sys.warnoptions[:] = saved


#: seconds granted to the client and to the cluster to close after Ctrl-C
_FAST_CLOSE = 0.5


def _close(obj: Any, interrupted: bool) -> None:
    """Close a Dask client or cluster.

    Close a client or cluster; after Ctrl-C within :data:`_FAST_CLOSE` seconds, and
    without waiting for an in-process worker's running task (its thread is a daemon
    thread: it ends with the process).
    """
    if not interrupted:
        obj.close()
        return
    try:
        obj.close(timeout=_FAST_CLOSE)
    except Exception:  # noqa: BLE001 (a timeout or a closed comm: we are leaving anyway)
        # an in-process worker still runs its task: do not let distributed's exit hook
        # wait for it again (the process ends, and the task's thread with it)
        if hasattr(obj, "shutdown_on_close"):
            obj.shutdown_on_close = False


def _quiet_logs() -> None:
    """Silence the main process's Dask, Tornado and asyncio loggers after Ctrl-C.

    Killing the workers breaks the client's open connections; the background senders then
    log tracebacks of closed streams ("grainmech: interrupted" is the one line to print).
    """
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _kill_workers(cluster: Any) -> None:
    """SIGKILL the worker processes of a local cluster (nothing for in-process workers)."""
    for w in list(getattr(cluster, "workers", {}).values()):
        pid = getattr(w, "pid", None)
        if isinstance(pid, int) and pid > 0:
            try:
                os.kill(pid, getattr(signal, "SIGKILL", signal.SIGTERM))
            except OSError:
                pass


def _call(fn: Callable[[Any], Any], item: Any) -> Any:
    """Run ``fn(item)`` in a worker thread with one numba thread (thread-local setting)."""
    try:
        import numba  # noqa: PLC0415 (optional dependency)
    except ImportError:
        pass
    else:
        if numba.get_num_threads() != 1:
            numba.set_num_threads(1)
    return fn(item)


def map_completed(fn: Callable[[Any], Any], items: Iterable[Any], *,
                  client: Any) -> Iterator[tuple[int, Any, bool]]:
    """Submit ``fn(item)`` for each item; yield results as they complete.

    Parameters
    ----------
    fn : callable
        A picklable function of one argument (module-level, for process workers).
    items : iterable
        The arguments; item ``i`` gets index ``i``.
    client : distributed.Client
        From :func:`open_client`.

    Yields
    ------
    (index, value, ok) : tuple[int, object, bool]
        ``value`` is ``fn(items[index])`` when ``ok``, else the exception it raised (a
        failing item never stops the others). The order is the completion order.

    Notes
    -----
    Tasks are submitted with ``pure=False`` so equal items are still run separately.
    Closing the generator early cancels the tasks that have not finished. Each task runs
    with numba's thread count set to 1 in its worker thread (:func:`_call`): the
    parallelism is over items, and numba's OpenMP kernels launched from a dask worker
    thread with more threads ran ~35 % slower (measured on the cyclic driver).
    """
    distributed = import_distributed()
    items = list(items)
    futures = client.map(_call, [fn] * len(items), items, pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    try:
        # with_results: the results arrive with the completion events (no extra round
        # trip per task); raise_errors=False: an error arrives as the exception object
        for fut, value in distributed.as_completed(futures, with_results=True, raise_errors=False,
                                                   loop=client.loop):
            i = index[fut.key]
            ok = fut.status == "finished"
            if not ok and not isinstance(value, BaseException):
                try:
                    value = fut.exception()
                except BaseException as err:  # cancelled, lost worker, ...
                    value = err
            fut.release()
            yield i, value, ok
    finally:
        pending = [f for f in futures if not f.done()]
        if pending:
            client.cancel(pending)

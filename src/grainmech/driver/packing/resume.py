"""A packing model's path run saved at a segment's end and taken up again (``grainmech run --resume``).

:func:`saved_state` is what :func:`grainmech.driver.packing.point.run_resolved` saves
through a :class:`~grainmech.driver.loop.PathCheckpoint` after a segment of the path:
the packing point (without its cached factorisation, which is made again from the same
elastic operator), the rows recorded so far, the path loop's running targets, and the
run's solver counters and last-step predictor (:class:`RunContext`), so that the run
goes on as the uninterrupted one does. :func:`resumed` takes such a state up.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

from grainmech.driver.loop import PathCheckpoint, copied_rows, restore_rows
from grainmech.driver.packing.options import RunContext

__all__ = ["saved_state", "resumed", "CONTEXT_FIELDS"]

#: the solver context's fields a resumed run takes over (not the preconditioner, the
#: options or the current step's budget, which the run makes again)
CONTEXT_FIELDS = tuple(f.name for f in fields(RunContext) if f.name not in ("prec", "opts", "budget"))


def saved_state(point: Any, rows: dict, acc: dict, ctx: RunContext, targets: Any) -> dict:
    """The picklable state of a packing model's path run after a step (module notes)."""
    return {"point": replace(point, _cache={}), "rows": copied_rows(rows), "acc": dict(acc),
            "context": {name: getattr(ctx, name) for name in CONTEXT_FIELDS}, "targets": targets}


def resumed(checkpoint: PathCheckpoint | None, point: Any, rows: dict, acc: dict) -> tuple[Any, Any, dict]:
    """Take up ``checkpoint.resume`` (a :func:`saved_state`), if any: fill ``rows`` and ``acc``.

    Returns the point to start from, the ``resume`` argument of
    :func:`~grainmech.driver.loop.follow_path` (None: from the path's start) and the solver
    counters to restore (empty: none).
    """
    if checkpoint is None or checkpoint.resume is None:
        return point, None, {}
    k, state = checkpoint.resume
    restore_rows(rows, state["rows"])
    acc.update(state["acc"])
    return state["point"], (k, state["targets"]), dict(state["context"])

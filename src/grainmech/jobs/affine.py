"""The affine model in ``grainmech run`` (``[model] method = "affine"``).

The seed's material point (kinematic hypothesis: every contact follows the mean strain,
seed Eq. 2.13) on the analytical fabric of the config.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from grainmech.driver import MaterialPoint, run
from grainmech.driver.affine.model import AFFINE
from grainmech.jobs.model import JobStep, ModelRun, execute_model
from grainmech.jobs.packing import packing_gmax
from grainmech.jobs.run_config import affine_rolling_note
from grainmech.jobs.spec import RunSpec
from grainmech.outcomes import RunOutcome

__all__: list[str] = []


def _execute_affine(spec: RunSpec, say: Callable[[str], None], step: JobStep | None = None) -> RunOutcome:
    """The seed's material point (kinematic hypothesis) on the analytical fabric.

    With ``[model] gmax_packing`` the outcome's details carry the packing's own Gmax
    (:func:`~grainmech.jobs.packing.packing_gmax`), computed after the series. Rolling
    resistance (``spec.rolling``) is inert here (no grain rotates): the details' notes say so.
    Nothing is handed to it (``step``).
    """
    point = MaterialPoint.isotropic(spec.microstructure, spec.law, spec.pressure, extra_degree=spec.degree)
    details: dict = {}
    if spec.rolling is not None:  # said as a warning too (prepare_run)
        details["notes"] = [affine_rolling_note(spec.rolling)]

    def finish(results: list) -> None:
        if spec.gmax_grains is not None:
            details["packing_gmax"] = packing_gmax(spec, say)

    details.update(AFFINE.details(point))
    # the series runs each amplitude with the run this module imported (grainmech.driver.run)
    model = ModelRun(AFFINE, point, f"{len(point.contacts)} directions",
                     series=partial(AFFINE.series, point, runner=run),
                     path=partial(AFFINE.path, point), void_ratio=spec.void_ratio, details=details, finish=finish,
                     saves_segments=True)
    return execute_model(model, spec, say, step)

"""Calibration of model parameters against measured data (``grainmech calibrate``).

* :mod:`grainmech.calibrate.data` - the data CSV (units in the header, clear errors);
* :mod:`grainmech.calibrate.model` - parameters (dotted paths into a model config) ->
  predictions for each data kind;
* :mod:`grainmech.calibrate.fit` - bounded least squares, multi-start, standard errors,
  correlation and identifiability from the Jacobian;
* :mod:`grainmech.calibrate.report` - result files (CSV, JSON, PNG), written atomically.

See ``docs/calibrate.md``.
"""

from grainmech.calibrate.data import Dataset, read_csv
from grainmech.calibrate.fit import (
    FitParameter,
    FitResult,
    Problem,
    fit,
    latin_hypercube_starts,
    load_problem,
    problem_from_config,
    uncertainty,
)
from grainmech.calibrate.model import DATA_KINDS

__all__ = ["Dataset", "FitResult", "DATA_KINDS", "FitParameter", "Problem", "fit", "latin_hypercube_starts",
           "load_problem", "problem_from_config", "read_csv", "uncertainty"]

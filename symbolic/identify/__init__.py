"""Identification of model parameters from measured data by IDIM-LS (inverse dynamic model, least squares).

:func:`identify` takes measurements, a regressor ``regressor(q, qd, qdd)`` returning Y (``samples × N ×
P``, τ = Y·β) and the parameter names, treats the data as Gautier and Janot do and solves the stacked
system by ordinary or weighted least squares: an :class:`Identification` (each parameter's value, σ and
relative σ, cond(W), the relative error). :func:`cross_validate` gives the relative error on another
data set; :func:`run` does it all from files (for the command line). The treatment, the estimator and
its statistics: docs/data.md, "IDIM-LS".

Example (the 1-DOF EMPS model τ = M q̈ + Fv q̇ + Fc sign(q̇) + offset)::

    import numpy as np
    from symbolic import data, identify

    def emps(q, qd, qdd):
        return np.stack([qdd, qd, np.sign(qd), np.ones_like(qd)], axis=-1)

    m = data.load("emps_estimation.experiment.toml", coordinates=["q"])
    result = identify.identify(m, emps, ["M", "Fv", "Fc", "offset"])
    print(result.table())
"""

from __future__ import annotations

from symbolic.identify.least_squares import (
    RELATIVE_SIGMA_THRESHOLD,
    Identification,
    IdentificationError,
    ParameterEstimate,
    solve,
)
from symbolic.identify.pipeline import Report, Validation, cross_validate, identify, run
from symbolic.identify.processing import Observation, Processing, RegressorFunction, Settings, observe

__all__ = [
    "RELATIVE_SIGMA_THRESHOLD",
    "Identification",
    "IdentificationError",
    "Observation",
    "ParameterEstimate",
    "Processing",
    "RegressorFunction",
    "cross_validate",
    "Report",
    "Settings",
    "Validation",
    "identify",
    "observe",
    "run",
    "solve",
]

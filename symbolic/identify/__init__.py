"""Identification of model parameters from measured data by IDIM-LS (inverse dynamic model, least squares).

Given a regressor ``Y(q, q̇, q̈)`` with ``τ = Y·β`` (a callable ``regressor(q, qd, qdd)`` returning
``samples × N × P``) and parameter names, :func:`identify` treats the measurements as Gautier and Janot
do (:mod:`symbolic.identify.processing`: zero-phase low-pass of positions, central differences, border
samples dropped, parallel decimation of τ and Y, stacking over coordinates) and solves the stacked
system by ordinary or weighted least squares (:mod:`symbolic.identify.least_squares`), returning each
parameter's value, σ and relative σ, cond(W) and the relative error. :func:`cross_validate` gives the
relative error on another data set; :func:`run` does it all from files (for the command line).

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

"""The model's own terms, linear in its base parameters, and their weighted least-squares fit.

The nominal model is identified as ``symbolic identify`` does it (:mod:`symbolic.identify.model`): its
symbolic regressor's base columns, the IDIM-LS data treatment, weighted least squares by
:func:`symbolic.identify.least_squares.solve` (Gautier's per-coordinate weights and statistics), and
the model-file parameters that a base parameter determines (``direct_parameters``). One difference:
a base parameter that no ``[parameters]`` entry moves — its value is fixed by numbers written inline
in the model file, e.g. ``mass = "2.5"`` — is not re-identified but kept at that value, its column
moved to the known side (τ − Y_fixed·β_fixed = Y_free·β_free). Parameters that the regressor
depends on (lengths, gravity, Stribeck velocities) are fixed as in identification.
"""

from __future__ import annotations

import types
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from symbolic.derive.dynamics import DynamicModel
from symbolic.derive.regressor import Regressor
from symbolic.identify.least_squares import Identification, ParameterEstimate, solve
from symbolic.identify.model import ModelParameter, base_regressor, direct_parameters, geometric_parameters, model_base
from symbolic.identify.processing import Observation
from symbolic.numeric.base_parameters import BaseParameters
from symbolic.workflow.dataset import DataSet

_TERMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class ModelTerms:
    """The base columns of a model's regressor, split into re-identified (free) and fixed ones.

    Attributes
    ----------
    model
        The derived model.
    names
        Base-parameter names (all of them, in the regressor's order).
    free
        For each base parameter, whether a ``[parameters]`` entry (other than geometry) moves it.
    nominal
        β at the model file's values (the fixed ones keep these).
    """

    model: DynamicModel = field(repr=False)
    reg: Regressor = field(repr=False)
    base: BaseParameters = field(repr=False)
    names: tuple[str, ...]
    free: np.ndarray
    nominal: np.ndarray
    regressor: object = field(repr=False)
    _columns: dict = field(default_factory=dict, repr=False)

    @property
    def free_names(self) -> tuple[str, ...]:
        return tuple(n for n, f in zip(self.names, self.free) if f)

    def columns(self, data: DataSet) -> np.ndarray:
        """The base columns on ``data``, reduced: ``samples × N × len(names)`` (computed once per data set);
        a time-varying model's at each sample's time."""
        key = id(data)
        if key not in self._columns:
            s = data.states
            self._columns[key] = (data, data.reduce(self.regressor(s.q, s.qd, s.qdd, t=data.measurements.t)))
        return self._columns[key][1]

    def known(self, data: DataSet) -> np.ndarray:
        """τ minus the fixed terms, ``samples × N``."""
        fixed = ~self.free
        return data.tau - self.columns(data)[:, :, fixed] @ self.nominal[fixed]


def model_terms(model: DynamicModel) -> ModelTerms:
    """The :class:`ModelTerms` of ``model`` (once per model object)."""
    if model not in _TERMS:
        reg, base = model_base(model)
        theta = dict(zip(reg.theta, reg.theta_expressions))
        movable = set(model.parameter_symbols) - geometric_parameters(model, reg)
        free = np.array([bool(e.xreplace(theta).free_symbols & movable) for e in base.expressions])
        _TERMS[model] = ModelTerms(model, reg, base, base.names, free, np.asarray(base.values, float), base_regressor(model))
    return _TERMS[model]


def wls(data: DataSet, columns: np.ndarray, known: np.ndarray, names: Sequence[str]) -> Identification:
    """IDIM-LS weighted least squares of ``known = columns·x`` (``samples × N`` and ``samples × N × P``)."""
    observation = Observation(data.coordinates, data.t, known, columns, data.states.processing)
    return solve(observation, tuple(names), "wls")


@dataclass(frozen=True, eq=False)
class NominalFit:
    """The nominal model identified on the estimation data.

    Attributes
    ----------
    terms
        The model's terms.
    identification
        The WLS result over the free base parameters.
    beta
        All base parameters: the free ones identified, the fixed ones at their inline values.
    parameters
        Model-file parameters that a base parameter determines, with σ.
    """

    terms: ModelTerms = field(repr=False)
    identification: Identification
    beta: np.ndarray
    parameters: dict[str, ModelParameter]

    def predict(self, data: DataSet) -> np.ndarray:
        """τ of the model at the measured (filtered) states of ``data``: ``samples × N``."""
        return self.terms.columns(data) @ self.beta


def fit_nominal(terms: ModelTerms, data: DataSet) -> NominalFit:
    """Identify the free base parameters of ``terms`` on ``data`` (module docstring)."""
    free = terms.free
    ident = wls(data, terms.columns(data)[:, :, free], terms.known(data), terms.free_names)
    beta = terms.nominal.copy()
    beta[free] = ident.values
    sigmas = np.zeros(len(beta))
    sigmas[free] = ident.sigmas
    estimates = [ParameterEstimate(n, float(b), float(s), 100.0 * s / abs(b) if b else float("inf"), False)
                 for n, b, s in zip(terms.names, beta, sigmas)]
    parameters = direct_parameters(terms.model, terms.reg, terms.base, types.SimpleNamespace(parameters=estimates))
    return NominalFit(terms, ident, beta, parameters)


def final_nominal(terms: ModelTerms, values: np.ndarray) -> NominalFit:
    """The model's own parameters from a joint fit whose first columns are ``terms``' free base parameters
    (the search's final design), without σ."""
    beta = terms.nominal.copy()
    beta[terms.free] = values[:int(terms.free.sum())]
    estimates = [ParameterEstimate(n, float(b), 0.0, 0.0, False) for n, b in zip(terms.names, beta)]
    parameters = direct_parameters(terms.model, terms.reg, terms.base, types.SimpleNamespace(parameters=estimates))
    return NominalFit(terms, None, beta, parameters)


def relative_gap(measured: np.ndarray, predicted: np.ndarray) -> float:
    """‖τ_meas − τ_model‖/‖τ_meas‖ in %, stacked over coordinates and samples."""
    return float(100.0 * np.linalg.norm(measured - predicted) / np.linalg.norm(measured))


def coordinate_gaps(data: DataSet, predicted: np.ndarray) -> dict[str, float | None]:
    """The same per coordinate; ``None`` for an unactuated coordinate (τ = 0 logged, a beam's modal
    coordinate), whose gap relative to its force is not defined (its residual counts in the stacked gap)."""
    return {c: relative_gap(data.tau[:, j], predicted[:, j]) if np.any(data.tau[:, j]) else None
            for j, c in enumerate(data.coordinates)}

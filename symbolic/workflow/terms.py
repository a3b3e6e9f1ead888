"""The model's own terms, linear in its base parameters, and their weighted least-squares fit.

The nominal model is identified as ``symbolic identify`` does it (:mod:`symbolic.identify.model`): its
symbolic regressor's base columns, the IDIM-LS data treatment, weighted least squares by
:func:`symbolic.identify.least_squares.solve` (Gautier's per-coordinate weights and statistics), and
the model-file parameters that a base parameter determines (``direct_parameters``). One difference:
a base parameter that no ``[parameters]`` entry moves — its value is fixed by numbers written inline
in the model file, e.g. ``mass = "2.5"`` — is not re-identified but kept at that value, its column
moved to the known side (τ − Y_fixed·β_fixed = Y_free·β_free). Parameters that the regressor
depends on (lengths, gravity, Stribeck velocities) are fixed as in identification, and so are the
parameters kept at their values (``fixed = true``, ``diagnose(fix=...)``): the standard parameters they
determine are known columns (:func:`symbolic.identify.known.split_base`), exactly as if their values were
written inline. The fit is bounded as identification's is (:func:`symbolic.identify.known.beta_bounds`).

A coordinate without an actuator (τ = 0 in the data) has a homogeneous equation that any common multiple
of its parameters satisfies (:mod:`symbolic.identify.known`). Where ``symbolic identify`` refuses it, the
workflow holds one of those parameters at the model file's value — an inertial one if there is one, the
value a model is usually sure of — and says so (:attr:`NominalFit.notes`): the other parameters of the
equation are then measured against it (a stiffness against the link's inertia).
"""

from __future__ import annotations

import dataclasses
import types
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.products import Product
from symbolic.derivation.regressor import Regressor
from symbolic.identify.least_squares import Identification, ParameterEstimate, norm, solve
from symbolic.identify.known import FIX_HINT, beta_bounds, homogeneous_groups, model_parameters_of, scale_holds, split_base
from symbolic.identify.model import ModelParameter, base_regressor, direct_parameters, geometric_parameters, model_base
from symbolic.identify.processing import Observation
from symbolic.identify.separation import Motion, parameter_label, relation, separating_motion
from symbolic.numeric.base_parameters import BaseParameters
from symbolic.workflow.dataset import DataSet

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
    fixed: frozenset = frozenset()
    """The parameters kept at their values (``fixed = true``, ``fix=``)."""

    @property
    def free_names(self) -> tuple[str, ...]:
        return tuple(n for n, f in zip(self.names, self.free) if f)

    def columns(self, data: DataSet) -> np.ndarray:
        """The base columns on ``data``, reduced: ``samples × N × len(names)`` (computed once per data set's states
        and treatment: the same data with the force treated otherwise, :func:`~symbolic.workflow.dataset.with_held_force`,
        share them); a time-varying model's at each sample's time."""
        s, p = data.states, data.states.processing
        key = (id(s.q), id(s.qd), id(s.qdd), id(data.measurements.t), p.border, p.decimation)  # data holds them alive
        if key not in self._columns:
            self._columns[key] = (data, data.reduce(self.regressor(s.q, s.qd, s.qdd, t=data.measurements.t)))
        return self._columns[key][1]

    def known(self, data: DataSet) -> np.ndarray:
        """τ minus the fixed terms, ``samples × N``."""
        fixed = ~self.free
        return data.tau - self.columns(data)[:, :, fixed] @ self.nominal[fixed]


def model_terms(model: DynamicModel, fixed: frozenset[sp.Symbol] = frozenset()) -> ModelTerms:
    """The :class:`ModelTerms` of ``model`` with the parameters ``fixed`` kept (once per model object and set,
    kept in ``model.products``)."""
    if not fixed:
        return model.products.get(TERMS)
    built = model.products.get(FIXED_TERMS)
    fixed = frozenset(fixed)
    if fixed not in built:  # each fit of a diagnosis asks again: the base regressor compiles once per set
        built[fixed] = _build_terms(model, fixed)
    return built[fixed]


def _build_terms(model: DynamicModel, fixed: frozenset[sp.Symbol] = frozenset()) -> ModelTerms:
    reg, base = model_base(model)
    geometric = geometric_parameters(model, reg)
    if fixed:
        base = split_base(model, reg, base, fixed, geometric).base
    theta = dict(zip(reg.theta, reg.theta_expressions))
    movable = set(model.parameter_symbols) - geometric - fixed
    free = np.array([bool(e.xreplace(theta).free_symbols & movable) for e in base.expressions])
    regressor = base_regressor(model, base=base) if fixed else base_regressor(model)
    return ModelTerms(model, reg, base, base.names, free, np.asarray(base.values, float), regressor, fixed=fixed)


TERMS: Product[ModelTerms] = Product("model terms", _build_terms)
FIXED_TERMS: Product[dict[frozenset, ModelTerms]] = Product("model terms with fixed parameters", lambda model: {})


def hold_scales(terms: ModelTerms, data: DataSet) -> tuple[ModelTerms, tuple[str, ...]]:
    """``terms`` with one parameter of each homogeneous equation held at its model value, and what was held
    (module docstring); ``terms`` itself when no coordinate of ``data`` is without force."""
    columns = terms.columns(data)
    held = {n: float(v) for n, v, f in zip(terms.names, terms.nominal, terms.free) if not f}
    groups = homogeneous_groups(data.coordinates, data.tau, columns, terms.names, held)
    if not groups:
        return terms, ()
    reg, base, model = terms.reg, terms.base, terms.model
    known = geometric_parameters(model, reg) | terms.fixed
    kinds = dict(zip(reg.theta, reg.kinds))
    inertial = {n for n, k in zip(base.names, base.independent) if kinds[reg.theta[k]] == "inertial"}
    free, notes = terms.free.copy(), []
    for group in groups:
        name = scale_holds(group, columns, data.coordinates, terms.names, terms.nominal, inertial)
        k = terms.names.index(name)
        free[k] = False
        every, _ = model_parameters_of(model, reg, base, [name], known)
        c = group.coordinates
        notes.append(f"{'coordinate ' + c[0] + ' has' if len(c) == 1 else 'coordinates ' + ', '.join(c) + ' have'} no "
                     f"actuator in the data (τ = 0): the equation holds for any common multiple of "
                     f"{', '.join(group.parameters)}, so the data cannot separate their scale; {name}"
                     f"{' (' + ', '.join(every) + ')' if every else ''} is held at the model file's value "
                     f"{terms.nominal[k]:.6g} and the others are measured against it; to choose, keep a known value "
                     f"fixed: --fix NAME {FIX_HINT}")
    return dataclasses.replace(terms, free=free), tuple(notes)


def wls(data: DataSet, columns: np.ndarray, known: np.ndarray, names: Sequence[str],
        bounds: dict[str, tuple[float, float]] | None = None) -> Identification:
    """IDIM-LS weighted least squares of ``known = columns·x`` (``samples × N`` and ``samples × N × P``),
    within ``bounds`` ({name: (lower, upper)}) where given. Without columns (a model whose every value is
    written inline, before an effect is added) nothing is estimated: the residual is ``known`` itself, and its
    per-coordinate RMS are the weights' σ_j."""
    observation = Observation(data.coordinates, data.t, known, columns, data.states.processing)
    if columns.shape[2] == 0:
        return _nothing_estimated(observation)
    return solve(observation, tuple(names), "wls", bounds=bounds)


def _nothing_estimated(observation: Observation) -> Identification:
    """The :class:`Identification` of a system without columns: no estimate, σ_j the RMS of each coordinate's
    ``y`` (all its samples are degrees of freedom), the relative error 100 %."""
    per = observation.samples
    sigmas = tuple(norm(observation.tau[:, j]) / np.sqrt(per) for j in range(len(observation.coordinates)))
    empty = np.zeros(0)
    return Identification(names=(), values=empty, sigmas=empty, covariance=np.zeros((0, 0)), method="wls",
                          condition_number=1.0, relative_error=100.0, residual_sigma=1.0, coordinate_sigmas=sigmas,
                          coordinates=observation.coordinates, rows=per * len(observation.coordinates),
                          processing=observation.processing)


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
    notes: tuple[str, ...] = ()
    """What the fit had to assume (a parameter held because the data cannot separate its scale)."""

    def predict(self, data: DataSet) -> np.ndarray:
        """τ of the model at the measured (filtered) states of ``data``: ``samples × N``."""
        return self.terms.columns(data) @ self.beta


def fit_nominal(terms: ModelTerms, data: DataSet) -> NominalFit:
    """Identify the free base parameters of ``terms`` on ``data`` (module docstring)."""
    terms, notes = hold_scales(terms, data)
    free = terms.free
    known = geometric_parameters(terms.model, terms.reg) | terms.fixed
    bounds = beta_bounds(terms.model, terms.reg, terms.base, terms.free_names, known)
    ident = wls(data, terms.columns(data)[:, :, free], terms.known(data), terms.free_names, bounds)
    beta = terms.nominal.copy()
    beta[free] = ident.values
    sigmas = np.zeros(len(beta))
    sigmas[free] = ident.sigmas
    estimates = [ParameterEstimate(n, float(b), float(s), 100.0 * s / abs(b) if b else float("inf"), False,
                                   bound=ident.at_bound.get(n))
                 for n, b, s in zip(terms.names, beta, sigmas)]
    parameters = direct_parameters(terms.model, terms.reg, terms.base, types.SimpleNamespace(parameters=estimates),
                                   terms.fixed)
    held = {f"base parameter {n}" for n in np.asarray(terms.names)[~free]}
    parameters = {k: p for k, p in parameters.items() if p.source not in held}  # a value held, not identified
    return NominalFit(terms, ident, beta, parameters, notes)


def final_nominal(terms: ModelTerms, values: np.ndarray) -> NominalFit:
    """The model's own parameters from a joint fit whose first columns are ``terms``' free base parameters
    (the search's final design), without σ."""
    beta = terms.nominal.copy()
    beta[terms.free] = values[:int(terms.free.sum())]
    estimates = [ParameterEstimate(n, float(b), 0.0, 0.0, False) for n, b in zip(terms.names, beta)]
    parameters = direct_parameters(terms.model, terms.reg, terms.base, types.SimpleNamespace(parameters=estimates),
                                   terms.fixed)
    return NominalFit(terms, None, beta, parameters)


def relative_gap(measured: np.ndarray, predicted: np.ndarray) -> float:
    """‖τ_meas − τ_model‖/‖τ_meas‖ in %, stacked over coordinates and samples; NaN where τ_meas = 0 (a
    coordinate without an actuator), where a relative gap means nothing."""
    size = norm(measured)
    return float(100.0 * norm(measured - predicted) / size) if size > 0 else float("nan")


def coordinate_gaps(data: DataSet, predicted: np.ndarray) -> dict[str, float | None]:
    """The same per coordinate; ``None`` for an unactuated coordinate (τ = 0 logged, a beam's modal
    coordinate), whose gap relative to its force is not defined (its residual counts in the stacked gap)."""
    return {c: relative_gap(data.tau[:, j], predicted[:, j]) if np.any(data.tau[:, j]) else None
            for j, c in enumerate(data.coordinates)}


def inseparable(terms: ModelTerms, data: DataSet, names: Sequence[str], what: str = "these data") -> str:
    """The sentence for the base parameters ``names`` of ``terms`` that ``data`` cannot separate (a
    :class:`~symbolic.identify.least_squares.RankDeficient`'s): the model's parameters they hold and a motion
    that would separate them (:mod:`symbolic.identify.separation`), ``what`` naming the data."""
    index = [terms.names.index(n) for n in names]
    combination = relation(data.stack(terms.columns(data)[:, :, index]))
    s, p = data.states, data.states.processing
    inner = slice(p.border[0], len(s.q) - p.border[1])
    motion = Motion.of(s.q[inner], s.qd[inner], s.qdd[inner], p.rate, float(data.t[0]))
    phrase = separating_motion(lambda m: terms.regressor(m.q, m.qd, m.qdd, t=m.t)[:, :, index], combination, motion,
                               data.coordinates)
    known = geometric_parameters(terms.model, terms.reg) | set(terms.fixed)
    labels = [parameter_label(terms.model, terms.reg, terms.base, n, known) for n in names]
    listed = ", ".join(labels[:-1]) + f" and {labels[-1]}" if len(labels) > 1 else labels[0]
    pair = [label.split(" (of ", 1)[0] for label in labels[:2]]  # model parameters alone in one, else base names
    design = "" if phrase is None or len(pair) < 2 else (
        f"; to design it: symbolic excite MODEL --experiment EXP.toml --duration T --separate {','.join(pair)}"
        + (" (or another two of them)" if len(labels) > 2 else ""))
    return (f"not identifiable from {what}: {listed} cannot be separated; a motion that would separate them: "
            + (phrase or "none (they are the same function of the states)") + design)


def solve_normal(gram: np.ndarray, right: np.ndarray) -> np.ndarray:
    """Least-squares coefficients from the normal equations, columns scaled to unit norm (the candidate
    systems are small and well conditioned once scaled; the SVD is kept for the identification itself).
    A system the data do not determine — a candidate collinear with the model's terms on a cross-validation
    fold's training blocks (an axis that moves one way there) — gets the least-norm solution, silently: the
    candidate's held-out error says what it is worth. A system that is not finite (columns overflowing on
    hostile data) gets zero coefficients: the candidate explains nothing there, and is not named."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        scale = np.sqrt(np.clip(np.diag(gram), 1e-300, None))
        scaled = gram / np.outer(scale, scale)
        rhs = right / scale
    if not (np.all(np.isfinite(scaled)) and np.all(np.isfinite(rhs))):
        return np.zeros(len(right))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", scipy.linalg.LinAlgWarning)
            x = scipy.linalg.solve(scaled, rhs, assume_a="pos", check_finite=False)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgError, scipy.linalg.LinAlgWarning):
        try:
            x = np.linalg.lstsq(scaled, rhs, rcond=None)[0]
        except np.linalg.LinAlgError:  # the SVD did not converge: nothing to take from this system
            return np.zeros(len(right))
    return x / scale


def own_rows(model: DynamicModel, names: Sequence[str]) -> dict[str, str]:
    """``{name: coordinate}`` for those of ``names`` whose every standard parameter θ acts on one row of τ = Y·θ
    alone (Y's column structurally zero elsewhere) and that Y does not depend on: a joint's friction, its rotor
    inertia, a spring of its own, the first link's inertial values — not a later link's, which the joints before
    it feel too, nor a length."""
    import sympy as sp

    from symbolic.identify.model import geometric_parameters

    reg = model.regressor()
    coordinates = list(model.robot.generalized_coordinates)
    geometric = {s.name for s in geometric_parameters(model, reg)}
    names = [n for n in names if n not in geometric]
    rows: dict[str, set[int]] = {}
    for k, expression in enumerate(reg.theta_expressions):
        acting = {i for i in range(reg.Y.rows) if reg.Y[i, k] != 0}
        for symbol in sp.sympify(expression).free_symbols:
            rows.setdefault(symbol.name, set()).update(acting)
    return {n: coordinates[next(iter(rows[n]))] for n in names if len(rows.get(n, ())) == 1}

"""Identification of a model file's parameters: the symbolic regressor, base parameters, IDIM-LS, and
the way back to the model file (Janot IV–V; Khalil & Dombre 14; Gautier's IDIM-LS).

:func:`identify_model` evaluates the model's regressor τ = Y·θ (:mod:`symbolic.derivation.regressor`) on
the measured states, keeps the base columns (:mod:`symbolic.numeric.base_parameters`) and solves for
the base parameters β by the IDIM-LS pipeline of :mod:`symbolic.identify.pipeline`. The model file's
own parameters follow in two ways:

* directly, where a base parameter is one model parameter up to known factors (EMPS: β = M, Fv, Fc,
  offset): p = (β − b)/a and σ_p = σ_β/|a| (:attr:`ModelIdentification.parameters`);
* with ``consistent=True``, as the physically consistent parameters closest to the least-squares fit in
  its own metric (:mod:`symbolic.identify.consistent`: the R of the QR of [W y], so the problem's size
  does not grow with the samples; each body parameterized exactly by log-Cholesky coordinates, friction,
  stiffness and damping signs and ``min``/``max`` as bounds). Every parameter that enters θ and is neither
  geometry nor fixed comes back (σ = ∞ for those the data do not determine alone), so that the written
  model reproduces the consistent fit's relative error.

Parameters kept at their values (``fixed = true``, ``fix=``) are not estimated: the standard parameters
they determine move to the side of τ and the base parameters are those of the other columns
(:mod:`symbolic.identify.known`, which also gives the bounds of the linear fit and refuses what the
data cannot separate).

Parameters that Y depends on (lengths of the DH table, gravity, Stribeck velocities) are geometry:
they stay at their values in the model file.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from symbolic.data import Measurements, load
from symbolic.data.measurements import check_forces
from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.regressor import Regressor
from symbolic.codegen.c_batch import batch_source
from symbolic.codegen.compiled_regressor import FUNCTION, compiled_batch
from symbolic.derivation.products import Product
from symbolic.identify.consistent import ConsistentFit
from symbolic.identify.known import (beta_bounds, fixed_symbols, homogeneous_groups, model_parameters_of, not_separable,
                                     parameter_bounds, rank_hint, split_base)
from symbolic.identify.least_squares import Identification, RankDeficient, defined, percent, solve
from symbolic.identify.least_squares import Validation
from symbolic.identify.pipeline import cross_validate
from symbolic.identify.processing import Observation, Settings, observe
from symbolic.numeric.base_parameters import BaseParameters, model_base_parameters, theta_values
from symbolic.codegen.functions import compile_vectorized

@dataclass(frozen=True)
class ModelParameter:
    """A model-file parameter determined by the data: value, σ, relative σ (%), and how it was found."""

    name: str
    value: float
    sigma: float
    relative_sigma: float
    nominal: float
    source: str  # "base parameter <name>" or "consistent fit"
    bound: str | None = None  # "min"/"max": held at that bound by the bounded least squares

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"value": self.value, "sigma": self.sigma, "relative_sigma": defined(self.relative_sigma)}
        if self.bound is not None:
            out["at_bound"] = self.bound
        return out


@dataclass(frozen=True, eq=False)
class ModelIdentification:
    """Identified base parameters of a model and the model-file parameters they determine."""

    model: DynamicModel = field(repr=False)
    base: BaseParameters = field(repr=False)
    identification: Identification
    parameters: dict[str, ModelParameter]
    validation: Validation | None = None
    observation: Observation | None = field(default=None, repr=False)
    fixed: dict[str, float] = field(default_factory=dict)
    """Model-file parameters kept at their values (``fixed = true``, ``fix=``)."""
    consistent: ConsistentFit | None = None
    """With ``consistent=True``: the physically consistent fit (its own relative error, bodies, time)."""
    undetermined: tuple[str, ...] = ()
    """Model-file parameters the data do not determine alone (:func:`undetermined_parameters`): left out of
    ``parameters``, or, with ``consistent=True``, given with σ = ∞."""
    alignment: Any = None
    """A bag's alignment (:class:`symbolic.data.bags.Alignment`: time base, rates, gaps, dropped messages)."""

    def figures(self, folder: str | Path) -> tuple[Path, ...]:
        """PNG figures of measured vs predicted τ and the residual per coordinate (and of the cross-test).

        Raises :class:`symbolic.identify.figures.MatplotlibMissing` without matplotlib.
        """
        from symbolic.description.units import coordinate_units
        from symbolic.identify.figures import draw

        return draw(self.identification, self.observation, Path(folder), self.validation,
                    coordinate_units(self.model.robot))

    def values(self) -> dict[str, float]:
        """{model parameter: identified value}, for writing back into the model file."""
        return {name: p.value for name, p in self.parameters.items()}

    def to_dict(self) -> dict[str, Any]:
        """The JSON contract of ``symbolic identify --json``."""
        ident = self.identification
        base = []
        for k, name in enumerate(ident.names):
            estimate = ident.parameters[k]
            entry = {"name": name, "expression": str(self.base.expressions[k]), "value": estimate.value,
                     "sigma": estimate.sigma, "relative_sigma": defined(estimate.relative_sigma)}
            entry.update({key: value for key, value in estimate.to_dict().items()
                          if key in ("fixed", "at_bound", "unconstrained")})
            base.append(entry)
        return {
            "model": self.model.name,
            "parameters": {name: p.to_dict() for name, p in self.parameters.items()},
            "fixed": dict(self.fixed),
            "base_parameters": base,
            "condition_number": ident.condition_number,
            "relative_error": ident.relative_error,
            "validation_relative_error": None if self.validation is None else self.validation.relative_error,
            "consistent": None if self.consistent is None else self.consistent.to_dict(),
            "undetermined": list(self.undetermined),
        } | ({} if self.alignment is None else {"alignment": self.alignment.to_dict()})

    def undetermined_note(self) -> str | None:
        """One line naming the parameters the data do not determine alone and what to do, or ``None``."""
        if not self.undetermined:
            return None
        names = ", ".join(self.undetermined)
        if self.consistent is not None:
            return (f"not determined alone by these data: {names} (they enter only combinations of base parameters: "
                    "their values are one of many that fit equally, σ = ∞); keep those you know at their values "
                    "with --fix NAME,... (a weighed mass, a CAD inertia) and the others follow")
        return (f"not identified: {names} enter only combinations of base parameters (listed above), so the data do "
                "not determine them alone; --consistent gives every one (the physically consistent values closest to "
                "the fit), or keep those you know at their values with --fix NAME,... and the others follow")

    def table(self) -> str:
        """Base parameters with σ, then the model-file parameters they determine."""
        lines = [self.identification.table()]
        width = max([9] + [len(n) for n in self.base.names])
        lines.append("")
        lines.append("base parameters as combinations of the standard parameters:")
        lines += [f"  {n:<{width}} = {e}" for n, e in zip(self.base.names, self.base.expressions)]
        if self.parameters:
            lines.append("")
            lines.append(f"{'model parameter':<16}  {'identified':>14}  {'sigma':>12}  {'sigma %':>8}  {'nominal':>12}  from")
            for p in self.parameters.values():
                bound = f" (at its {p.bound})" if p.bound else ""
                lines.append(f"{p.name:<16}  {p.value:>14.6g}  {p.sigma:>12.4g}  {percent(p.relative_sigma):>8s}  {p.nominal:>12.6g}  {p.source}{bound}")
        if self.consistent is not None:
            lines.append(self.consistent.summary())
        if self.fixed:
            lines.append("kept at their values (fixed): " + ", ".join(f"{n} = {v:.6g}" for n, v in self.fixed.items()))
        note = self.undetermined_note()
        if note:
            lines.append(note)
        if self.validation is not None:
            lines.append(f"validation: relative error {self.validation.relative_error:.4g} %")
        return "\n".join(lines)


def model_base(model: DynamicModel) -> tuple[Regressor, BaseParameters]:
    """The regressor and base parameters of ``model`` (built once per model, kept in ``model.products`` and on disk)."""
    return model.regressor(), model_base_parameters(model)


COMPILE_WORK = 2_000_000
"""Samples × statements above which the base regressor is evaluated by compiled C (when a compiler is
there): below it (EMPS: 25 000 samples × 6 statements) NumPy is fast enough and compiling (0.2–1 s, once
per machine) would cost more than it saves."""


def base_regressor(model: DynamicModel, p: Sequence[float] | None = None, compiled: bool | None = None,
                   base: BaseParameters | None = None):
    """``regressor(q, qd, qdd) -> samples × N × len(β)``: the base columns of Y at parameters ``p``.

    ``base``: other base parameters of the model's regressor (default :func:`model_base`'s), e.g. the
    split of :func:`symbolic.identify.known.split_base` with its known columns last.

    ``compiled``: True evaluates through a C loop (:mod:`symbolic.codegen.compiled_regressor`), False
    through NumPy; None (default) chooses C for large work (:data:`COMPILE_WORK`) when a compiler is found, and
    for any work once it has done so.
    A time-varying model's regressor (a [[force]] in time) needs the sample times: ``regressor(q, qd, qdd,
    t=times)``; its attribute ``time_varying`` says so (:func:`symbolic.identify.processing.observe` reads it).
    """
    reg, own = model_base(model)
    base = own if base is None else base
    columns, groups = _columns_and_inputs(model, reg, base)
    p = model.parameter_vector.coerce(p)
    statements = len(reg.sub.program(list(columns)))
    built: dict[str, Any] = {}  # each evaluator is built on first use (lambdify or C source: 0.1-0.3 s)

    def regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
        samples = np.shape(q)[0]
        times = []
        if model.time_varying:
            if t is None or np.shape(t) != (samples,):
                raise ValueError(f"model {model.name}'s forces depend on time: give the {samples} sample times t "
                                 f"(got {'none' if t is None else np.shape(t)})")
            times = [np.reshape(np.asarray(t, float), (samples, 1))]
        # small work too once the C loop is loaded: building NumPy's evaluator as well would cost 0.1 s
        if compiled or (compiled is None and (samples * statements > COMPILE_WORK or built.get("c") is not None)):
            if "c" not in built:
                source = model.products.get(BATCH_SOURCE) if base is own else None
                built["c"] = compiled_batch(reg.sub, groups, model.parameter_symbols, columns, source)
            if built["c"] is not None:
                return built["c"](q, qd, qdd, *times, p)
        if "numpy" not in built:
            built["numpy"] = compile_vectorized(reg.sub, [*groups, model.parameter_symbols], columns, (model.n, len(base.independent)))
        return built["numpy"](q, qd, qdd, *times, p)

    regressor.time_varying = model.time_varying
    return regressor


def _columns_and_inputs(model: DynamicModel, reg: Regressor, base: BaseParameters) -> tuple[sp.Matrix, list]:
    """The base columns of Y (N × len(β)) and the symbol groups a sample gives them (q, q̇, q̈ and, for a
    time-varying model, t)."""
    columns = reg.Y.extract(list(range(model.n)), list(base.independent))
    return columns, [model.coordinates, model.velocities, model.accelerations, *([[model.time]] if model.time_varying else [])]


def _own_batch_source(model: DynamicModel) -> str:
    reg, base = model_base(model)
    columns, groups = _columns_and_inputs(model, reg, base)
    return batch_source(FUNCTION, reg.sub, groups, model.parameter_symbols, list(columns))


BATCH_SOURCE: Product[str] = Product("base regressor C loop", _own_batch_source, persist=True)
"""The C loop of the model's own base regressor (:func:`base_regressor`), kept in the cache folder: a warm process
loads the compiled library without printing its source again (0.2 s per model for the Panda)."""


def identify_model(
    model: DynamicModel,
    data: str | Path | Measurements,
    *,
    experiment: str | Path | None = None,
    validation: str | Path | Measurements | None = None,
    settings: Settings | None = None,
    method: str = "wls",
    consistent: bool = False,
    fix: Sequence[str] = (),
    exclude: Sequence[tuple[float, float]] = (),
) -> ModelIdentification:
    """IDIM-LS of ``model``'s base parameters on ``data`` (a data or experiment file, or measurements).

    ``experiment`` maps a data file that lacks the canonical columns (its [signals], [window], ...);
    ``validation`` (a data or experiment file) is the cross-test set. Both are loaded for the model by
    :func:`symbolic.data.load` (its rule for a validation file; the model's drive gains for ``u_<c>``). ``fix`` names parameters kept at their values
    besides those with ``fixed = true`` (:mod:`symbolic.identify.known`: their terms move to the side of
    τ); ``min``/``max`` and the signs of the parameters' roles bound the estimates. ``exclude``: time intervals
    ``(start, stop)`` (s) whose treated samples are left out of the least squares (a collision's burst).

    Raises
    ------
    IdentificationError
        When the data cannot separate parameters: a rank-deficient set, or the equation of a coordinate
        without an actuator (τ = 0), which any common multiple of its parameters satisfies; the message
        names them and the parameters to fix.
    """
    coordinates = model.robot.generalized_coordinates
    reg, full = model_base(model)  # first: a model the regressor cannot cover is refused before reading data
    fixed = fixed_symbols(model, fix)
    geometric = geometric_parameters(model, reg)
    split = split_base(model, reg, full, fixed, geometric) if fixed else None
    base, held = (split.base, split.known_values()) if split else (full, {})
    loaded = load(data, coordinates, model=model.robot, experiment=experiment, validation=validation)
    for measured in (loaded, loaded.validation):  # zero forces: every parameter fits, a relative error is 0/0
        if measured is not None:
            check_forces(measured)
    regressor = base_regressor(model, base=base)
    observation = observe(loaded, regressor, len(base.names), settings)
    if exclude:
        observation = observation.without(exclude)
    ident = _solve(model, reg, base, observation, method, held, geometric | fixed)
    checked = None
    if loaded.validation is not None:
        checked = cross_validate(ident, loaded.validation, regressor, settings)
    fitted = None
    if consistent:
        parameters, fitted = consistent_fit(model, reg, base, ident, observation, fixed)
    else:
        parameters = direct_parameters(model, reg, base, ident, fixed)
    return ModelIdentification(model, base, ident, parameters, checked, observation,
                               {s.name: float(model.parameters[s]) for s in model.parameter_symbols if s in fixed},
                               fitted, undetermined_parameters(model, reg, fixed, parameters), loaded.alignment)


def undetermined_parameters(model: DynamicModel, reg: Regressor, fixed: frozenset[sp.Symbol],
                            parameters: dict[str, ModelParameter]) -> tuple[str, ...]:
    """The model-file parameters that enter θ, are neither geometry nor ``fixed``, and that ``parameters``
    does not determine: absent (no base parameter is that parameter alone: m1, I1 of a planar arm, which
    enter only combinations), or with σ = ∞ (the consistent fit's, not determined alone). In the model's order."""
    known = geometric_parameters(model, reg) | set(fixed)
    entering = set().union(*(e.free_symbols for e in reg.theta_expressions)) if reg.theta_expressions else set()
    return tuple(s.name for s in model.parameter_symbols if s in entering and s not in known
                 and (s.name not in parameters or not np.isfinite(parameters[s.name].sigma)))


def _solve(model: DynamicModel, reg: Regressor, base: BaseParameters, observation: Observation, method: str,
           held: dict[str, float], known: set[sp.Symbol]) -> Identification:
    """:func:`solve` with the known columns held, the bounds of the parameters, and the checks of what the
    data cannot separate (:mod:`symbolic.identify.known`)."""
    groups = homogeneous_groups(observation.coordinates, observation.tau, observation.regressor, base.names, held)
    if groups:
        every, inertial = model_parameters_of(model, reg, base, groups[0].parameters, known)
        raise not_separable(groups[0], every, inertial)
    free = [n for n in base.names if n not in held]
    try:
        return solve(observation, base.names, method, fixed=held, bounds=beta_bounds(model, reg, base, free, known))
    except RankDeficient as error:
        raise rank_hint(error, model_parameters_of(model, reg, base, error.parameters, known)[0]) from None


_GEOMETRIC: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""Per model: {id(regressor): (regressor, its geometric parameters)} (:func:`geometric_parameters`)."""


def geometric_parameters(model: DynamicModel, reg: Regressor) -> set[sp.Symbol]:
    """Model parameters that Y depends on (fixed during identification). Computed once per model and regressor:
    a diagnosis asks some fourteen times, and collecting the free symbols of the Panda's program takes 0.04 s."""
    found = _GEOMETRIC.setdefault(model, {})
    if id(reg) not in found:
        used: set[sp.Symbol] = set()
        for _, definition in reg.sub.program(list(reg.Y)):
            used |= definition.free_symbols
        for e in reg.Y:
            used |= e.free_symbols
        found[id(reg)] = (reg, frozenset(used & set(model.parameter_symbols)))
    return set(found[id(reg)][1])


def direct_parameters(model: DynamicModel, reg: Regressor, base: BaseParameters, ident: Identification,
                      fixed: frozenset[sp.Symbol] = frozenset()) -> dict[str, ModelParameter]:
    """Model parameters that a single base parameter determines: β = a·p + b with the other model
    parameters in β fixed (geometry, and the ``fixed`` ones) — p = (β − b)/a, σ_p = σ_β/|a|.

    When several base parameters determine the same p (one model parameter written in several places, e.g.
    an ``EI`` shared by a beam's two bending directions), their values p_k are combined by generalized least
    squares, p = (1ᵀC⁻¹1)⁻¹1ᵀC⁻¹p_k and σ_p² = (1ᵀC⁻¹1)⁻¹, with C the covariance of the p_k
    (``ident.covariance`` scaled by 1/(a_k a_l); the diagonal σ_k² when ``ident`` has no covariance).
    """
    fixed = geometric_parameters(model, reg) | set(fixed)
    nominal = model.parameters
    theta = dict(zip(reg.theta, reg.theta_expressions))
    found: dict[sp.Symbol, list[tuple[int, float, float]]] = {}
    for k, expression in enumerate(base.expressions):
        in_parameters = sp.expand(expression.xreplace(theta))
        unknown = in_parameters.free_symbols - fixed
        if len(unknown) != 1:
            continue
        (p,) = unknown
        a = sp.diff(in_parameters, p)
        if a.free_symbols & {p} or sp.diff(in_parameters, p, 2) != 0:
            continue
        values = {s: v for s, v in nominal.items() if s in fixed}
        a_value = float(a.xreplace(values))
        b_value = float(in_parameters.xreplace({p: sp.Integer(0)}).xreplace(values))
        if a_value != 0:
            found.setdefault(p, []).append((k, a_value, b_value))
    out: dict[str, ModelParameter] = {}
    for p, determinations in found.items():
        value, sigma = _combined(determinations, ident)
        relative = 100.0 * sigma / abs(value) if value != 0 else float("inf")
        names = ", ".join(base.names[k] for k, _, _ in determinations)
        source = f"base parameter{'s' if len(determinations) > 1 else ''} {names}"
        out[p.name] = ModelParameter(p.name, value, sigma, relative, nominal[p], source, _bound(determinations, ident))
    return out


def _bound(determinations: list[tuple[int, float, float]], ident) -> str | None:
    """The bound ("min"/"max") at which the parameter's one base parameter was held, flipped when a < 0."""
    if len(determinations) != 1:
        return None
    k, a, _ = determinations[0]
    bound = getattr(ident.parameters[k], "bound", None)
    return {"min": "max", "max": "min"}[bound] if bound is not None and a < 0 else bound


def _combined(determinations: list[tuple[int, float, float]], ident) -> tuple[float, float]:
    """p and σ_p from the base parameters k with β_k = a_k·p + b_k (:func:`direct_parameters`)."""
    index = [k for k, _, _ in determinations]
    a = np.array([a for _, a, _ in determinations])
    values = np.array([(ident.parameters[k].value - b) / a_k for k, a_k, b in determinations])
    sigmas = np.array([ident.parameters[k].sigma for k in index]) / np.abs(a)
    if len(index) == 1:
        return float(values[0]), float(sigmas[0])
    if not np.all(sigmas > 0):  # a base parameter kept at its known value: p is that value
        known = sigmas == 0
        return float(values[known].mean()), 0.0
    covariance = getattr(ident, "covariance", None)
    C = np.diag(sigmas**2) if covariance is None else np.asarray(covariance)[np.ix_(index, index)] / np.outer(a, a)
    weights = np.linalg.solve(C, np.ones(len(index)))
    information = float(weights.sum())
    return float(weights @ values / information), float(np.sqrt(1.0 / information))


def consistent_fit(model, reg: Regressor, base: BaseParameters, ident: Identification, observation,
                   fixed_parameters: frozenset[sp.Symbol] = frozenset()) -> tuple[dict[str, ModelParameter], ConsistentFit | None]:
    """The physically consistent model-file parameters closest to the least-squares fit in its own metric
    (:mod:`symbolic.identify.consistent`): every parameter that enters θ and is neither geometry nor
    fixed comes back, with σ = ∞ for those the data do not determine alone."""
    from symbolic.identify.consistent import fit, problem, row_weights

    fixed = geometric_parameters(model, reg) | set(fixed_parameters)
    free = [s for s in model.parameter_symbols if s not in fixed and any(s in e.free_symbols for e in reg.theta_expressions)]
    if not free:
        return {}, None
    prob = problem(model, reg, free, parameter_bounds(model))
    K = np.zeros((len(base.names), len(reg.theta)))  # β = K·θ: BaseParameters.from_theta as a matrix
    K[np.arange(len(base.independent)), list(base.independent)] = 1.0
    K[:, list(base.dependent)] = base.K
    weights = row_weights(ident.method, ident.coordinate_sigmas, observation.samples)
    p0 = np.array([model.parameters[s] for s in free], float)
    result, p, covariance = fit(prob, K, observation.W, observation.y, weights, p0, np.asarray(ident.values),
                                name=model.name)
    out = {}
    for k, symbol in enumerate(free):
        sigma, value = float(np.sqrt(covariance[k, k])), float(p[k])
        determined = bool(np.isfinite(sigma))
        relative = 100.0 * sigma / abs(value) if value and determined else float("inf")
        out[symbol.name] = ModelParameter(symbol.name, value, sigma, relative, model.parameters[symbol],
                                          "consistent fit" if determined else "consistent fit (not determined alone)")
    return out, result

"""A derived model's values at its nominal parameters: finite and real, or refused.

:func:`check_values` (called at the end of :func:`symbolic.derivation.dynamics.derive`) evaluates D(Q), g(Q),
k(Q), friction, applied forces and τ at the nominal parameters in double precision (the straight-line
program through :func:`sympy.lambdify` with Python's ``math``), at Q = 0 and
:data:`SEEDED_CONFIGURATIONS` seeded configurations, and raises a one-line
:class:`~symbolic.errors.ModelError` for an entry that is not finite or not real at all of them. The
rule: docs/model-format.md, "Limits"; why in the derive layer: docs/architecture.md, "Equations of
motion".
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Protocol

import sympy as sp

from symbolic.errors import ModelError



class DynamicModel(Protocol):
    """What the check reads of the :class:`~symbolic.derivation.dynamics.DynamicModel` being derived (the check
    runs inside :func:`~symbolic.derivation.dynamics.derive`, so it takes the model by these attributes
    instead of importing the module that calls it)."""

    robot: Any
    reduced: Any
    sub: Any
    parameters: Any
    coordinates: Any
    velocities: Any
    accelerations: Any

CHECKED = (("D", "D"), ("gravity", "g"), ("stiffness", "k"), ("friction", "friction"), ("applied", "applied"), ("tau", "tau"))
"""Fields of :class:`~symbolic.derivation.dynamics.ReducedForms` checked, in order, with their names in
messages. A field the model does not have is skipped; τ comes last because it contains every term
of the equations of motion (a Coriolis term not already covered by D, g and k shows there)."""

SEEDED_CONFIGURATIONS = 3
"""Configurations drawn (fixed seed) in addition to Q = 0; coordinates and velocities uniform in [-1, 1]."""

SEED = 15
"""Seed of the configurations, fixed so that a refusal names the same point on every run."""

_ERRORS = (
    (ZeroDivisionError, "not finite (division by zero)"),
    (OverflowError, "not finite (overflow)"),
    (ValueError, "not finite or not real (math domain error: log(0), sqrt or log of a negative number, acos beyond ±1, …)"),
    (TypeError, "not real (a complex intermediate value)"),
)


def check_values(model: DynamicModel) -> None:
    """Refuse ``model`` if an entry of D, g, k, friction, applied forces or τ is not finite and real at
    the nominal parameters at every configuration tried.

    Raises
    ------
    ModelError
        Naming the entry (``D[1,1]``), the configuration and what is wrong, e.g.
        ``model.toml: D[1,1]: not finite at the nominal parameters (q1 = 0, q2 = 0): division by zero``.
    """
    entries = list(_entries(model))
    if not entries:
        return
    points = _configurations(model)
    evaluate = _compile(model, [e for _, e in entries])
    if all(_problem(evaluate, point) is None for point in points):
        return  # the common case: one compiled program, every entry fine everywhere
    for label, expr in entries:
        single = _compile(model, [expr])
        problems = [_problem(single, point) for point in points]
        if all(problems):
            where = _describe(model, expr, points[0])
            raise ModelError(
                model.robot.source,
                label,
                f"{problems[0]} at the nominal parameters, at {where} and at {len(points) - 1} other configurations tried "
                "(every entry of the equations of motion must be finite and real)",
            )


def _entries(model: DynamicModel) -> Iterator[tuple[str, sp.Expr]]:
    """(label, expression) for each checked entry; D by its upper triangle (it is symmetric)."""
    reduced = model.reduced
    for field, name in CHECKED:
        value = getattr(reduced, field, None)
        if isinstance(value, sp.MatrixBase):
            rows, cols = value.shape
            for i in range(rows):
                for j in range(i if field == "D" else 0, cols):
                    label = f"{name}[{i},{j}]" if cols > 1 else f"{name}[{i}]"
                    yield label, value[i, j]
        elif isinstance(value, sp.Expr):
            yield name, value


def _variables(model: DynamicModel) -> list[sp.Symbol]:
    return [*model.coordinates, *model.velocities, *model.accelerations]


def _configurations(model: DynamicModel) -> list[dict[sp.Symbol, float]]:
    """Q = Q̇ = Q̈ = 0, then seeded points with every coordinate, velocity and acceleration in [-1, 1]."""
    variables = _variables(model)
    rng = random.Random(SEED)
    points = [dict.fromkeys(variables, 0.0)]
    for _ in range(SEEDED_CONFIGURATIONS):
        points.append({v: round(rng.uniform(-1.0, 1.0), 3) for v in variables})
    return points


def _compile(model: DynamicModel, outputs: Sequence[sp.Expr]) -> Callable[[dict[sp.Symbol, float]], list]:
    """The outputs as a function of a configuration, parameters at their nominal values.

    Any other free symbol an output may carry (a later model feature) is set to 0, like Q at the
    first configuration.
    """
    program = model.sub.program(outputs)
    nominal = model.parameters
    known = set(_variables(model)) | set(nominal)
    inner = set(model.sub.definition)
    extra = set().union(*(e.free_symbols for e in outputs), *(d.free_symbols for _, d in program)) - known - inner
    arguments = [*_variables(model), *nominal, *sorted(extra, key=sp.default_sort_key)]
    raw = sp.lambdify([arguments], list(outputs), modules="math", cse=lambda exprs: (program, exprs))
    fixed = [float(v) for v in nominal.values()] + [0.0] * len(extra)

    def evaluate(point: dict[sp.Symbol, float]) -> list:
        return raw([point[v] for v in _variables(model)] + fixed)

    return evaluate


def _problem(evaluate: Callable[[dict[sp.Symbol, float]], list], point: dict[sp.Symbol, float]) -> str | None:
    """What is wrong with the outputs at ``point`` ("not finite: division by zero", ...), or None."""
    try:
        values = evaluate(point)
    except tuple(kind for kind, _ in _ERRORS) as error:
        return next(text for kind, text in _ERRORS if isinstance(error, kind))
    for value in values:
        if isinstance(value, complex):
            return f"not real (≈ {value:.6g})"
        if not math.isfinite(value):
            return f"not finite ({value})"
    return None


def _describe(model: DynamicModel, expr: sp.Expr, point: dict[sp.Symbol, float]) -> str:
    """The configuration, with velocities and accelerations only when ``expr`` depends on them."""
    depends = model.sub.dependencies(expr) | expr.free_symbols
    shown = list(model.coordinates) + [v for v in (*model.velocities, *model.accelerations) if v in depends]
    return ", ".join(f"{v.name} = {point[v]:g}" for v in shown)

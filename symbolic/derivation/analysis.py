"""Decoupling and gravity-balancing conditions, and counterbalance design (Madill 4.2.1–4.2.4).

:func:`decoupling` returns, for a derived model, the parameter combinations that must vanish for D(Q) to
be diagonal (``decoupling``, Madill (4.6)/(4.9): α₃ = 0), for a diagonal entry of D(Q) to be constant
(``constant_inertia``), for a Coriolis row to be free of a coordinate and its velocity (``coriolis``,
4.2.3) and for V_g(Q) to be constant (``balancing``, (4.2)/(4.3)), each checked at a parameter set to a
relative tolerance of :data:`RELATIVE_TOLERANCE` (an :class:`Analysis`); :func:`counterbalance` solves
them for chosen parameters (4.2.4, a :class:`Design`). A condition is the coefficient of one
trigonometric monomial in the canonical form of :func:`symbolic.derivation.simplify.reduce_pythagoras`;
entries larger than :data:`symbolic.derivation.simplify.SIZE_LIMIT` are not analysed but listed in
:attr:`Analysis.skipped`. The method and why: docs/architecture.md, "Decoupling and balancing".
"""

from __future__ import annotations

import logging
import math
import re
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.simplify import SIZE_LIMIT, tree_size, trig_monomials

KINDS = ("decoupling", "constant_inertia", "coriolis", "balancing")
RELATIVE_TOLERANCE = 1e-9

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Skipped:
    """An entry left out of the analysis: its expanded form is larger than ``SIZE_LIMIT`` tree nodes."""

    name: str
    kind: str
    size: int

    def readable(self) -> str:
        return f"{self.name}: not analysed (expanded size {self.size}, limit {SIZE_LIMIT})"


@dataclass(frozen=True)
class Check:
    """A condition evaluated for one parameter set."""

    value: float
    scale: float  # Σ|terms|: the size the value is compared with
    holds: bool | None

    @property
    def relative(self) -> float:
        return abs(self.value) / self.scale if self.scale else 0.0


@dataclass(frozen=True)
class Condition:
    """A parameter combination that must vanish, with what it multiplies in the model."""

    name: str
    kind: str
    expression: sp.Expr
    functions: tuple[sp.Expr, ...]
    assuming_nonzero: tuple[sp.Symbol, ...] = ()
    unit: str = ""
    feasible: bool | None = None  # False: cannot vanish while every parameter keeps its nominal sign

    @property
    def equation(self) -> sp.Eq:
        return sp.Eq(self.expression, 0)

    def readable(self) -> str:
        return f"{sp.sstr(self.expression)} = 0"

    def check(self, values: Mapping[sp.Symbol, float]) -> Check:
        terms = sp.Add.make_args(sp.expand(self.expression))
        try:
            numbers = [float(t.xreplace(values)) for t in terms]
        except TypeError:
            return Check(float("nan"), float("nan"), None)
        value, scale = sum(numbers), sum(abs(x) for x in numbers)
        return Check(value, scale, abs(value) <= RELATIVE_TOLERANCE * scale)


@dataclass
class Analysis:
    """All conditions of a model, with checks at a parameter set (nominal by default)."""

    model: DynamicModel
    conditions: list[Condition]
    values: dict[sp.Symbol, float] = field(default_factory=dict)
    skipped: list[Skipped] = field(default_factory=list)

    def of_kind(self, kind: str) -> list[Condition]:
        return [c for c in self.conditions if c.kind == kind]

    def holds(self, kind: str) -> bool:
        return all(c.check(self.values).holds for c in self.of_kind(kind))

    def offending(self, kind: str) -> list[Condition]:
        """Conditions of ``kind`` that fail at the analysed parameters."""
        return [c for c in self.of_kind(kind) if not c.check(self.values).holds]

    def infeasible(self, kind: str) -> list[Condition]:
        """Conditions of ``kind`` that no parameter set with the nominal signs can satisfy."""
        return [c for c in self.of_kind(kind) if c.feasible is False]

    def to_dict(self) -> dict:
        out = []
        for c in self.conditions:
            check = c.check(self.values)
            out.append(
                {
                    "name": c.name,
                    "kind": c.kind,
                    "expression": str(c.expression),
                    "holds": check.holds,
                    "value": check.value,
                    "relative": check.relative,
                    "unit": c.unit,
                    "multiplies": [str(f) for f in c.functions],
                    "assuming_nonzero": [str(s) for s in c.assuming_nonzero],
                    "feasible": c.feasible,
                }
            )
        skipped = [{"name": s.name, "kind": s.kind, "size": s.size, "limit": SIZE_LIMIT} for s in self.skipped]
        return {"model": self.model.name, "conditions": out, "skipped": skipped}

    def summary(self) -> str:
        lines = [f"model {self.model.name}: {len(self.conditions)} conditions"]
        if self.skipped:
            lines[0] += f"; {len(self.skipped)} entries too large to analyse (expanded size above {SIZE_LIMIT})"
        for kind in KINDS:
            conditions = self.of_kind(kind)
            skipped = [s for s in self.skipped if s.kind == kind]
            if not conditions and not skipped:
                continue
            if not conditions:
                lines.append(f"\n{kind}: not analysed")
            else:
                verdict = "holds" if self.holds(kind) else "does not hold"
                scope = " for the analysed entries" if skipped else ""
                lines.append(f"\n{kind}: {verdict}{scope} at the given parameters")
            lines += [f"  {s.readable()}" for s in skipped]
            for c in conditions:
                check = c.check(self.values)
                state = "holds" if check.holds else f"fails by {check.value:.4g} {c.unit}".rstrip() + f" ({check.relative:.2g} of its terms)"
                extra = "" if c.feasible is not False else "  [met only with a parameter at 0 or of the opposite sign to its nominal value]"
                lines.append(f"  {c.name}: {c.readable()}  -> {state}{extra}")
        return "\n".join(lines)


# -- building conditions ---------------------------------------------------------------------


def _units(model: DynamicModel) -> dict[sp.Symbol, sp.Expr]:
    """Parameter -> its unit as a SymPy product of unit symbols (from strings like 'kg*m^2', 'm/s^2')."""
    out = {}
    for p in model.robot.parameters:
        unit = sp.Integer(1)
        text = p.unit.replace(" ", "")
        if text:
            sign = 1
            for token in re.split(r"([*/])", text):
                if token == "*":
                    sign = 1
                elif token == "/":
                    sign = -1
                elif token:
                    base, _, exponent = token.partition("^")
                    try:
                        power = int(exponent) if exponent else 1
                    except ValueError:
                        power = 1
                    unit *= sp.Symbol(base) ** (sign * power)
        out[p.symbol] = unit
    return out


def _unit_of(expr: sp.Expr, units: Mapping[sp.Symbol, sp.Expr]) -> str:
    first = sp.Add.make_args(sp.expand(expr))[0]
    coefficient, rest = first.as_coeff_Mul()
    unit = rest.xreplace({s: units.get(s, 1) for s in rest.free_symbols})
    return "" if unit == 1 else sp.sstr(unit).replace("**", "^")


def _primitive(expr: sp.Expr) -> tuple[sp.Expr, tuple[sp.Symbol, ...]]:
    """Split off numeric content and single-symbol factors of a sum; normalise the sign.

    g·(m₁l_c1 + m₃l_c3 + m_r l₁) gives (m₁l_c1 + m₃l_c3 + m_r l₁, (g,)). A plain product of symbols
    (e.g. I_zz6 or m₆r_z6) is kept whole: then the condition is that product vanishing.
    """
    expr = sp.factor_terms(sp.expand(expr))
    _, expr = expr.as_coeff_Mul()
    kept, dropped = [], []
    for factor in sp.Mul.make_args(expr):
        base, _ = factor.as_base_exp()
        if base.is_Symbol:
            dropped.append(base)
        elif not base.is_Number:
            kept.append(factor)
    if not kept:  # a monomial: nothing to set aside
        kept, dropped = [expr], []
    core = sp.expand(sp.Mul(*kept))
    if core.could_extract_minus_sign():
        core = sp.expand(-core)
    return core, tuple(sorted(set(dropped), key=sp.default_sort_key))


def _feasible(expr: sp.Expr, values: Mapping[sp.Symbol, float]) -> bool | None:
    """False when expr has a definite sign once every parameter keeps its nominal sign."""
    signed = {}
    for s in expr.free_symbols:
        v = values.get(s)
        if v is None:
            return None
        signed[s] = sp.Symbol(s.name, positive=True) if v > 0 else (-sp.Symbol(s.name, positive=True) if v < 0 else sp.Integer(0))
    e = sp.expand(expr.xreplace(signed))
    if e == 0:
        return True
    if e.is_positive or e.is_negative:
        return False
    return None


def decoupling(
    model: DynamicModel,
    parameters: Mapping[str, float] | None = None,
    kinds: Iterable[str] = KINDS,
) -> Analysis:
    """The decoupling and balancing conditions of ``model`` (Madill 4.2), checked at ``parameters``.

    Parameters
    ----------
    model
        A derived model.
    parameters
        Values by parameter name overriding the nominal ones for the numeric checks.
    kinds
        Which families to compute (the constant-inertia and Coriolis families expand the diagonal of
        D and the Coriolis vector, which takes time for six or more coordinates).
    """
    kinds = list(kinds)
    unknown = set(kinds) - set(KINDS)
    if unknown:
        raise ValueError(f"unknown condition kind(s) {sorted(unknown)} (allowed: {', '.join(KINDS)})")
    values = dict(model.parameters)
    for name, value in (parameters or {}).items():
        values[sp.Symbol(name, real=True)] = float(value)
    q, qd = list(model.coordinates), list(model.velocities)
    names = model.robot.generalized_coordinates
    units = _units(model)
    conditions: list[Condition] = []
    skipped: list[Skipped] = []

    def small(kind: str, label: str, expr: sp.Expr) -> bool:
        """Whether ``expr`` is within the limit; if not, it is recorded as skipped."""
        size = tree_size(expr)
        if size <= SIZE_LIMIT:
            return True
        skipped.append(Skipped(label, kind, size))
        return False

    def add(kind: str, label: str, expr: sp.Expr, variables, keep_constant: bool = True) -> None:
        if not small(kind, label, expr):
            return
        groups: dict[sp.Expr, list[sp.Expr]] = {}
        dropped_of: dict[sp.Expr, tuple] = {}
        for function, coefficient in trig_monomials(expr, variables).items():
            if function == 1 and not keep_constant:
                continue
            core, dropped = _primitive(coefficient)
            groups.setdefault(core, []).append(function)
            dropped_of[core] = tuple(sorted(set(dropped_of.get(core, ())) | set(dropped), key=sp.default_sort_key))
        for k, (core, functions) in enumerate(sorted(groups.items(), key=lambda kv: sp.default_sort_key(kv[0]))):
            suffix = f" #{k + 1}" if len(groups) > 1 else ""
            conditions.append(
                Condition(
                    name=f"{label}{suffix}",
                    kind=kind,
                    expression=core,
                    functions=tuple(functions),
                    assuming_nonzero=dropped_of[core],
                    unit=_unit_of(core, units),
                    feasible=_feasible(core, values),
                )
            )

    n = model.n

    def decoupling_family() -> None:
        D = model.D
        for i in range(n):
            for j in range(i + 1, n):
                add("decoupling", f"D[{names[i]},{names[j]}] = 0", D[i, j], q)

    def constant_inertia_family() -> None:
        D = model.D
        for i in range(n):
            add("constant_inertia", f"D[{names[i]},{names[i]}] constant", D[i, i], q, keep_constant=False)

    def coriolis_family() -> None:
        h = model.coriolis_vector
        for k in range(n):
            if not small("coriolis", f"coriolis row {names[k]}", h[k]):
                continue  # its derivatives are as large
            for j in range(n):
                if j == k:
                    continue
                for variable, what in ((q[j], names[j]), (qd[j], f"{names[j]}_dot")):
                    derivative = sp.diff(h[k], variable)
                    if derivative != 0:
                        add("coriolis", f"coriolis row {names[k]} free of {what}", derivative, q + qd)

    def balancing_family() -> None:
        add("balancing", "V independent of Q", model.potential_energy, q, keep_constant=False)

    families = {"decoupling": decoupling_family, "constant_inertia": constant_inertia_family,
                "coriolis": coriolis_family, "balancing": balancing_family}
    for kind in KINDS:
        if kind in kinds:
            start, before, passed = time.perf_counter(), len(conditions), len(skipped)
            families[kind]()
            log.info("%s: %s conditions: %d in %.1f s%s", model.name, kind, len(conditions) - before, time.perf_counter() - start,
                     f" ({len(skipped) - passed} entries above the size limit skipped)" if len(skipped) > passed else "")
    return Analysis(model, conditions, values, skipped)


# -- counterbalance design -------------------------------------------------------------------


@dataclass
class Design:
    """Result of :func:`counterbalance`: values of the free parameters and what is left unmet."""

    solution: dict[sp.Symbol, sp.Expr]
    values: dict[str, float]
    unmet: list[Condition]
    analysis: Analysis

    @property
    def feasible(self) -> bool:
        return not self.unmet

    def problem(self, free: Sequence[str]) -> str | None:
        """Why this design does not do what was asked for the ``free`` parameters, or None.

        A free parameter that no condition determines (it appears in none, or its solution depends on
        another that is undetermined) is reported first, then the conditions that cannot be met.
        """
        undetermined = [name for name in free if not math.isfinite(self.values.get(name, math.nan))]
        if undetermined:
            used = sorted({s.name for c in self.analysis.conditions for s in c.expression.free_symbols})
            return (f"no {' or '.join(sorted({c.kind for c in self.analysis.conditions})) or 'analysis'} condition determines "
                    f"{', '.join(undetermined)} (parameters in the conditions: {', '.join(used) or 'none'})")
        if self.unmet:
            return (f"{len(self.unmet)} condition(s) cannot be met with the free parameters {', '.join(free)}: "
                    + "; ".join(c.name for c in self.unmet))
        return None

    def summary(self) -> str:
        lines = [f"{k} = {v:.6g}" for k, v in self.values.items()]
        if self.unmet:
            lines.append("cannot be met:")
            lines += [f"  {c.name}: {c.readable()}" for c in self.unmet]
        if self.analysis.skipped:
            lines.append("not taken into account:")
            lines += [f"  {s.readable()}" for s in self.analysis.skipped]
        return "\n".join(lines)


def counterbalance(
    model: DynamicModel,
    free: Sequence[str],
    kinds: Sequence[str] = ("balancing", "decoupling"),
    parameters: Mapping[str, float] | None = None,
) -> Design:
    """Solve the ``kinds`` conditions for the ``free`` parameters (Madill 4.2.4).

    The conditions are solved in the order that uses each free parameter once, as Madill adjusts the
    counterbalances: a condition with a single free parameter first, its solution substituted into
    the rest. Conditions that cannot be met with the free parameters are returned in ``unmet``.
    """
    analysis = decoupling(model, parameters, kinds)
    symbols = [sp.Symbol(name, real=True) for name in free]
    known = set(model.parameter_symbols)
    missing = [s.name for s in symbols if s not in known]
    if missing:
        raise ValueError(f"unknown free parameter(s) {missing} (parameters: {', '.join(p.name for p in model.robot.parameters)})")
    pending = [c for c in analysis.conditions if c.expression.free_symbols & set(symbols)]
    unmet = [c for c in analysis.conditions if not c.expression.free_symbols & set(symbols) and not c.check(analysis.values).holds]
    solution: dict[sp.Symbol, sp.Expr] = {}
    progress = True
    while pending and progress:
        progress = False
        for c in list(pending):
            expr = sp.expand(c.expression.xreplace(solution))
            unknowns = [s for s in symbols if s in expr.free_symbols and s not in solution]
            if len(unknowns) == 1:
                roots = sp.solve(expr, unknowns[0], dict=False)
                if roots:
                    solution[unknowns[0]] = sp.simplify(roots[0])
                    pending.remove(c)
                    progress = True
            elif not unknowns:
                pending.remove(c)
                if not Condition(c.name, c.kind, expr, c.functions).check(analysis.values).holds:
                    unmet.append(c)
                progress = True
    if pending:  # coupled conditions: solve them together
        exprs = [sp.expand(c.expression.xreplace(solution)) for c in pending]
        unknowns = [s for s in symbols if s not in solution]
        found = sp.solve(exprs, unknowns, dict=True)
        if found:
            solution.update({k: sp.simplify(v) for k, v in found[0].items()})
        else:
            unmet += pending
    for s in list(solution):
        solution[s] = sp.simplify(solution[s].xreplace(solution))
    values = {}
    for s, expr in solution.items():
        number = expr.xreplace(analysis.values)
        if number.free_symbols:
            values[s.name] = float("nan")
        else:
            values[s.name] = float(number)
    return Design(solution, values, unmet, analysis)


# -- flexible links (Madill 4.2.1: the sag of link 5 moves the centre of mass) -----------------


def modal_coordinates(model: DynamicModel) -> list[sp.Symbol]:
    return [sp.Symbol(n, real=True) for b in model.robot.beams for n in b.nu + b.eta]


def flexible_conditions(analysis: Analysis) -> list[Condition]:
    """Conditions that exist only because of beam deflections (they multiply modal coordinates)."""
    modal = set(modal_coordinates(analysis.model))
    return [c for c in analysis.conditions if any(f.free_symbols & modal for f in c.functions)]

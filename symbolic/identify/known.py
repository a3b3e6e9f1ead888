"""Known values stay known, results stay physical: fixed parameters (:func:`split_base`), bounds
(:func:`parameter_bounds`, :func:`beta_bounds`), and what the data cannot separate (:func:`homogeneous_groups`).

What a model file may say and what identification does with it: docs/model-format.md, "Known values and bounds".
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import weakref
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from symbolic import cache as disk
from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.regressor import Regressor
from symbolic.description.robot import Directional, Robot, coordinate_symbol, velocity_symbol
from symbolic.errors import IdentificationError, ModelError, listing
from symbolic.numeric.base_parameters import BaseParameters, base_parameters, theta_values

_SPLITS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_BOUNDS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

FIX_HINT = "(or fixed = true in its [parameters] entry)"


def fixed_symbols(model: DynamicModel, fix: Iterable[str] = ()) -> frozenset[sp.Symbol]:
    """The parameters kept at their values: ``fixed = true`` in the model file and the names in ``fix``.

    Raises
    ------
    ModelError
        For a name in ``fix`` that is not a parameter of the model (one line, with the parameters).
    """
    fix = [n.strip() for n in fix if n.strip()]
    unknown = unknown_parameters(model.robot, fix)
    if unknown:
        names = [p.name for p in model.robot.parameters]
        raise ModelError(model.robot.source, "--fix", f"unknown parameter(s) {listing(unknown)} "
                                                      f"(the model's parameters: {listing(names)})")
    return frozenset(p.symbol for p in model.robot.parameters if p.fixed or p.name in fix)


def unknown_parameters(robot: Robot, names: Iterable[str]) -> list[str]:
    """The names among ``names`` that are not parameters of ``robot``, in their order: the names to fix that
    :func:`fixed_symbols` refuses (``--fix``), and that a campaign refuses in its tasks' ``fix`` before any work."""
    known = {p.name for p in robot.parameters}
    return [n for n in names if n not in known]


@dataclass(frozen=True, eq=False)
class Split:
    """Base parameters over the unknown columns, followed by the known standard parameters.

    Attributes
    ----------
    base
        :class:`BaseParameters` whose first entries are the base parameters of the unknown columns and
        whose last ones are the known θ (each its own column, coefficient 1, no regrouping): the
        regressor of ``base.independent`` gives both, and ``base.from_theta`` both values.
    known
        The names of the known entries (θ names), in ``base.names``.
    symbols
        The fixed parameters that made them known.
    """

    base: BaseParameters
    known: tuple[str, ...]
    symbols: frozenset[sp.Symbol]

    @property
    def held(self) -> np.ndarray:
        """True for the known entries of ``base.names``."""
        return np.array([n in self.known for n in self.base.names], bool)

    def known_values(self) -> dict[str, float]:
        """{θ name: value at the model file's values} of the known entries."""
        return {n: float(v) for n, v in zip(self.base.names, self.base.values) if n in self.known}


def split_base(model: DynamicModel, reg: Regressor, full: BaseParameters, fixed: frozenset[sp.Symbol],
               geometric: set[sp.Symbol]) -> Split:
    """The :class:`Split` of ``model`` for the ``fixed`` parameters (computed once per model and set).

    A standard parameter θ_k that fixed parameters (``fixed = true``, ``--fix NAME``) determine completely
    (with geometry and numbers; e.g. ZZ_link = J_l with J_l fixed) is a known term: its column moves to the
    side of τ,

        τ − Y_k·θ_k = Y_u·θ_u,

    and the base parameters are computed over the other columns. A column that was regrouped into a known
    one becomes a base column of its own (knowing YY2 separates ZZ1 from ZZR1). A θ that holds a fixed
    parameter and a free one (Izz + m·c² with m fixed) stays unknown; the fixed value enters when the
    model-file parameters are computed from β (β = a·p + b).

    ``full`` is the base of all columns (returned unchanged when no acting θ is known), ``geometric`` the
    parameters Y depends on (known anyway, but they alone do not make a θ known: a θ that is a number
    or holds geometry only is identified as before).
    """
    cache = _SPLITS.setdefault(model, {})
    if fixed not in cache:
        acting = set(full.independent) | set(full.dependent)
        known = [k for k, e in enumerate(reg.theta_expressions)
                 if k in acting and e.free_symbols & fixed and e.free_symbols <= fixed | geometric]
        if not known:
            cache[fixed] = Split(full, (), fixed)
        else:
            rest = [k for k in range(len(reg.theta)) if k not in known]
            free = base_parameters(model, reg, columns=rest)
            names = free.names + tuple(reg.theta[k].name for k in known)
            K = np.vstack([free.K, np.zeros((len(known), len(free.dependent)))])  # noqa: N806
            expressions = free.expressions + tuple(reg.theta[k] for k in known)
            combined = BaseParameters(names, free.independent + tuple(known), free.dependent, K, expressions,
                                      np.zeros(len(names)), free.gap)
            combined = dataclasses.replace(combined, values=combined.from_theta(theta_values(model, reg)))
            cache[fixed] = Split(combined, tuple(names[len(free.names):]), fixed)
    return cache[fixed]


# -- bounds ------------------------------------------------------------------------------------------

def role_signs(model: DynamicModel) -> dict[sp.Symbol, str]:
    """{parameter: its role} for parameters that must be ≥ 0 by what they are: a mass, a diagonal inertia
    entry, a friction coefficient, a rotor inertia, a beam's density, bending stiffness or tip mass, and a
    ``[[force]]`` coefficient that acts as a stiffness or a damping (the force's derivative with respect to its
    own coordinate or velocity is −c·p with c > 0) — each when it enters as c·p with a number c > 0 and its
    nominal value is ≥ 0."""
    robot = model.robot
    values = model.parameters
    roles: dict[sp.Symbol, str] = {}

    def scaled(expression: sp.Expr | None, role: str) -> None:
        """A parameter p when ``expression`` is c·p with a number c > 0."""
        if expression is None:
            return
        expression = sp.sympify(expression)
        symbols = [s for s in expression.free_symbols if s in values]
        if len(symbols) == 1 and expression.free_symbols == set(symbols):
            p = symbols[0]
            c = sp.simplify(expression / p)
            if c.is_number and c > 0 and values[p] >= 0:
                roles.setdefault(p, role)

    for body in robot.bodies:
        scaled(body.mass, "a mass")
        for key in ("xx", "yy", "zz"):
            scaled((body.inertia or {}).get(key), "a principal inertia")
    for drive in robot.drives:
        scaled(drive.rotor_inertia, "a rotor inertia")
    for f in robot.frictions:
        for value in (f.viscous, f.coulomb):
            for part in ((value.positive, value.negative) if isinstance(value, Directional) else (value,)):
                scaled(part, "a friction coefficient")
        if f.stribeck is not None:
            scaled(f.stribeck.static, "a friction coefficient")
    for beam in robot.beams:
        for value, role in ((beam.density, "a beam's density"), (beam.EI_v, "a bending stiffness"),
                            (beam.EI_w, "a bending stiffness"), (beam.tip_mass, "a tip mass")):
            scaled(value, role)
    for force in robot.forces:
        for variable, role in ((coordinate_symbol(force.coordinate), "a stiffness"),
                               (velocity_symbol(force.coordinate), "a damping")):
            scaled(-sp.diff(force.expression, variable), role)
    return roles


def parameter_bounds(model: DynamicModel) -> dict[sp.Symbol, tuple[float, float]]:
    """{parameter: (lower, upper)} from ``min``/``max`` and the signs of :func:`role_signs` (only bounded ones)."""
    roles = role_signs(model)
    out = {}
    for p in model.robot.parameters:
        lower = max(p.minimum if p.minimum is not None else -np.inf, 0.0 if p.symbol in roles else -np.inf)
        upper = p.maximum if p.maximum is not None else np.inf
        if np.isfinite(lower) or np.isfinite(upper):
            out[p.symbol] = (float(lower), float(upper))
    return out


def beta_bounds(model: DynamicModel, reg: Regressor, base: BaseParameters, names: Sequence[str],
                known: set[sp.Symbol]) -> dict[str, tuple[float, float]]:
    """Bounds on the base parameters ``names`` implied by :func:`parameter_bounds`.

    β in the model's parameters (``known`` ones, geometry and fixed, at their values) is
    Σ_u a_u·p_u + c; when it is linear in the unknown p_u, lower = c + Σ a_u·(lower_u if a_u > 0 else
    upper_u) and likewise the upper bound (a sum of masses with positive coefficients is ≥ its known part);
    the bounded least squares of :func:`symbolic.identify.least_squares.solve` enforces them. Bases with a
    product of unknowns get none. Computed once per
    model, base and sets (0.4 s of SymPy for the Panda's 43 base parameters; the workflow fits several times),
    and kept in the cache folder (:mod:`symbolic.cache`) under :func:`_bounds_key`: a diagnosis in a second
    process reads them (0.08 s a model for the Panda) instead.
    """
    key = (base.names, tuple(names), frozenset(known))
    cache = _BOUNDS.setdefault(model, {})
    if key not in cache:
        stored = _bounds_key(model, base, names, known)
        found = disk.load(BOUNDS_ENTRY, stored)
        if found is not None and isinstance(found[0], dict):
            cache[key] = found[0]
        else:
            cache[key] = _beta_bounds(model, reg, base, names, known)
            disk.save(BOUNDS_ENTRY, stored, cache[key])
    return dict(cache[key])


BOUNDS_ENTRY = "base parameter bounds"
"""The kind of :func:`beta_bounds`' entries in the cache folder."""


def _bounds_key(model: DynamicModel, base: BaseParameters, names: Sequence[str], known: set[sp.Symbol]) -> str:
    """What :func:`beta_bounds` is a function of, as the key of its cache entry: the robot description's digest
    (its parameters, their values and bounds; the regressor and its θ follow from it), the base (its names, the
    columns kept and the regrouping K: β = θ_b + K·θ_d), the names bounded and the parameters known."""
    text = json.dumps([model.products.digest, list(base.names), list(base.independent), list(base.dependent),
                       np.asarray(base.K, dtype=float).tobytes().hex(), list(names), sorted(map(str, known))])
    return hashlib.sha256(text.encode()).hexdigest()


def _beta_bounds(model: DynamicModel, reg: Regressor, base: BaseParameters, names: Sequence[str],
                 known: set[sp.Symbol]) -> dict[str, tuple[float, float]]:
    bounds = parameter_bounds(model)
    values = {s: v for s, v in model.parameters.items() if s in known}
    theta = dict(zip(reg.theta, reg.theta_expressions))
    out = {}
    for name, expression in zip(base.names, base.expressions):
        if name not in names:
            continue
        beta = sp.expand(expression.xreplace(theta).xreplace(values))
        unknown = sorted(beta.free_symbols, key=str)
        if not unknown or not any(u in bounds for u in unknown):
            continue
        slopes = _slopes(beta, tuple(unknown))
        if any(not s.is_number for s in slopes):
            continue  # not linear in the unknown parameters
        low = high = float(beta.xreplace({u: 0 for u in unknown}))
        for u, slope in zip(unknown, map(float, slopes)):
            lo, hi = bounds.get(u, (-np.inf, np.inf))
            low += slope * (lo if slope > 0 else hi) if slope else 0.0
            high += slope * (hi if slope > 0 else lo) if slope else 0.0
        if np.isfinite(low) or np.isfinite(high):
            out[name] = (low, high)
    return out


@functools.lru_cache(maxsize=4096)
def _slopes(beta: sp.Expr, unknown: tuple[sp.Symbol, ...]) -> tuple[sp.Expr, ...]:
    """∂β/∂u for each unknown u: kept across models, since a patched model (a diagnosis adds friction, a
    payload, corrected values) shares most of its base parameters, and their derivatives, with the original."""
    return tuple(sp.diff(beta, u) for u in unknown)


def polynomial_lower_bound(beta: sp.Expr, bounds: Mapping[sp.Symbol, tuple[float, float]]) -> float:
    """A lower bound of the base parameter ``beta`` (a polynomial in the model's parameters, geometry
    already replaced by numbers) over the parameters' ``bounds`` (:func:`parameter_bounds`; others free),
    for the combinations :func:`beta_bounds` leaves out (products of unknowns: ZZR1 = I1 + m1·c1² + m2·l1²).

    Each monomial is split into a multiplier M, the product of the parameters bounded below by 0 (masses,
    principal inertias), and a rest; the rests of one multiplier form a polynomial Q in the sign-free
    parameters (centres of mass). When Q is separable and at most quadratic in each of them,
    Q = d + Σ_v (a_v·v² + b_v·v) with a_v > 0 (or a_v = b_v = 0), its minimum is L = d − Σ_v b_v²/(4·a_v),
    and M·Q ≥ M_low·L (L ≥ 0) or M_high·L (L < 0). The sum over multipliers is the bound: the parallel-axis
    sum m·(c² + 2·c·l + l²) = m·(c + l)² gives L = 0, not −∞. −∞ when any group is not of that form.
    """
    beta = sp.expand(beta)
    unknown = sorted(beta.free_symbols, key=str)
    if not unknown:
        return float(beta)
    nonneg = [bounds.get(u, (-np.inf, np.inf))[0] >= 0 for u in unknown]
    groups: dict[tuple[int, ...], list[tuple[tuple[int, ...], float]]] = {}
    for powers, coefficient in sp.Poly(beta, *unknown).terms():
        key = tuple(k if n else 0 for k, n in zip(powers, nonneg))
        rest = tuple(0 if n else k for k, n in zip(powers, nonneg))
        groups.setdefault(key, []).append((rest, float(coefficient)))
    total = 0.0
    for key, terms in groups.items():
        low = _separable_minimum(terms)
        scale = sum(abs(c) for _, c in terms)
        if abs(low) <= 1e-9 * scale:
            low = 0.0  # a perfect square written with rounded numbers
        lows = [bounds[u][0] ** k for u, k in zip(unknown, key) if k]
        highs = [bounds[u][1] ** k for u, k in zip(unknown, key) if k]
        total += low * (float(np.prod(lows)) if low >= 0 else float(np.prod(highs)))
        if not np.isfinite(total):
            return -np.inf
    return total


def _separable_minimum(terms: Sequence[tuple[tuple[int, ...], float]]) -> float:
    """min over the reals of Σ c·Π v^k (``terms``) when it is d + Σ_v (a_v·v² + b_v·v), a_v > 0 or
    a_v = b_v = 0; −∞ otherwise."""
    constant, square, linear = 0.0, {}, {}
    for powers, c in terms:
        used = [(i, k) for i, k in enumerate(powers) if k]
        if not used:
            constant += c
        elif len(used) == 1 and used[0][1] in (1, 2):
            i, k = used[0]
            target = square if k == 2 else linear
            target[i] = target.get(i, 0.0) + c
        else:
            return -np.inf
    for i in set(square) | set(linear):
        a, b = square.get(i, 0.0), linear.get(i, 0.0)
        if a > 0:
            constant -= b * b / (4.0 * a)
        elif a < 0 or b != 0:
            return -np.inf
    return constant


# -- homogeneous equations ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Homogeneous:
    """Coordinates whose forces are all zero (after the known terms) and the parameters in their equations."""

    coordinates: tuple[str, ...]
    parameters: tuple[str, ...]


def homogeneous_groups(coordinates: Sequence[str], tau: np.ndarray, regressor: np.ndarray, names: Sequence[str],
                       held: Mapping[str, float]) -> list[Homogeneous]:
    """Groups of coordinates with τ − Y_k·β_k ≡ 0 and the unknown parameters acting on their rows.

    A coordinate without an actuator has τ = 0, and its equation 0 = Σ_k Y_jk·β_k holds for any common
    multiple of the parameters in it. Their scale then rests on the coupling with the actuated coordinates,
    and least squares sets it from the noise: in the regressor of the homogeneous rows (twice-differentiated
    positions), noise pulls the scale towards zero, and the per-coordinate weights of WLS, computed from the
    residual of those rows, pull harder. On a hub with a torsional spring (tests/test_known.py) the stiffness
    came out 0.153 ± 5.4 % against a true 0.7. Identification refuses such groups with the parameters to fix
    (:func:`not_separable`), the workflow holds one of them at its model value and says so
    (:func:`scale_holds`). A fixed value in the equation (a known inertia) gives it a right-hand side and ends
    the ambiguity.

    ``tau`` is ``samples × N``, ``regressor`` ``samples × N × len(names)``, ``held`` the known columns'
    values. A parameter acts on a coordinate when its column there exceeds 1e-9 of the largest column
    there (smaller is rounding). Coordinates sharing a parameter are one group (one scale).
    """
    names = list(names)
    mask = np.array([n in held for n in names], bool)
    rhs = tau - regressor[:, :, mask] @ np.array([held[n] for n in names if n in held], float) if mask.any() else tau
    groups: list[tuple[set[str], set[int]]] = []
    for j, c in enumerate(coordinates):
        if np.any(rhs[:, j] != 0):
            continue
        norms = np.linalg.norm(regressor[:, j, :], axis=0)
        acting = {k for k in np.flatnonzero(norms > 1e-9 * norms.max(initial=0.0)) if not mask[k]}
        if not acting:
            continue  # an equation with no unknown left: nothing to scale
        merged = ({c}, set(acting))
        for g in [g for g in groups if g[1] & acting]:
            groups.remove(g)
            merged = (merged[0] | g[0], merged[1] | g[1])
        groups.append(merged)
    order = {c: j for j, c in enumerate(coordinates)}
    return [Homogeneous(tuple(sorted(cs, key=order.get)), tuple(names[k] for k in sorted(ks))) for cs, ks in groups]


def model_parameters_of(model: DynamicModel, reg: Regressor, base: BaseParameters, names: Iterable[str],
                        known: set[sp.Symbol]) -> tuple[list[str], list[str]]:
    """(all, inertial) model-file parameters in the base parameters ``names`` that are not ``known``."""
    theta = dict(zip(reg.theta, reg.theta_expressions))
    kinds = dict(zip(reg.theta, reg.kinds))
    every: list[str] = []
    inertial: list[str] = []
    for name in names:
        present = base.expressions[base.names.index(name)].free_symbols
        for t in (t for t in reg.theta if t in present):
            for s in sorted(theta[t].free_symbols - known, key=str):
                if s.name not in every:
                    every.append(s.name)
                if kinds.get(t) == "inertial" and s.name not in inertial:
                    inertial.append(s.name)
    return every, inertial


def not_separable(group: Homogeneous, parameters: Sequence[str], inertial: Sequence[str]) -> IdentificationError:
    """The one-line error for a homogeneous group: which parameters, and what to fix."""
    c = group.coordinates
    where = f"coordinate {c[0]} has" if len(c) == 1 else f"coordinates {', '.join(c)} have"
    if parameters:
        remedy = f"keep a known value fixed: --fix {','.join(inertial or parameters[:1])} {FIX_HINT}"
        named = f" (parameters {listing(parameters)})"
    else:  # numbers written inline only: identification estimates them, and nothing names them
        remedy = "write one of their known values as a [parameters] entry with fixed = true"
        named = ""
    return IdentificationError(
        f"{where} no actuator in the data (τ = 0): the equation holds for any common multiple of "
        f"{listing(group.parameters)}{named}, so the data cannot separate their scale; {remedy}")


def rank_hint(error: IdentificationError, parameters: Sequence[str]) -> IdentificationError:
    """A rank-deficiency error with the model-file parameters to fix appended, and for a pair of base parameters
    the ``symbolic excite --separate`` that designs a motion separating them (docs/data.md, "Designs for doubt")."""
    pair = tuple(getattr(error, "parameters", ()))
    design = (f"; or design a motion that separates them: symbolic excite MODEL --experiment EXP.toml --duration T "
              f"--separate {','.join(pair)}") if len(pair) == 2 else ""
    if not parameters:
        return IdentificationError(f"{error}{design}") if design else error
    return IdentificationError(f"{error}; or keep known values fixed (--fix with some of {listing(parameters)}) "
                               f"{FIX_HINT}{design}")


def scale_holds(group: Homogeneous, regressor: np.ndarray, coordinates: Sequence[str], names: Sequence[str],
                nominal: np.ndarray, inertial: set[str]) -> str:
    """The parameter of ``group`` to hold at its model value so that its equation gets a scale: among the
    inertial ones if any (a mass or an inertia is the value usually known), the one whose term
    ‖Y_jk‖·|β_k| on the group's rows is largest."""
    rows = [list(coordinates).index(c) for c in group.coordinates]
    candidates = [n for n in group.parameters if n in inertial] or list(group.parameters)
    size = {n: float(np.linalg.norm(regressor[:, rows, list(names).index(n)]) * abs(nominal[list(names).index(n)]))
            for n in candidates}
    return max(candidates, key=lambda n: size[n])

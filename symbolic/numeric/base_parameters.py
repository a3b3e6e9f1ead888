"""Base (identifiable) parameters: β = θ_b + K θ_d from the regressor at sampled states (Gautier 1990).

The columns of the stacked regressor W (Y at many random states, one block of N rows per state)
that are linear combinations of others cannot be identified. The columns are taken in θ's order
(links from the base outwards, Khalil's XX … M within a link, then beams, drives, friction, forces) and a
column is a base column when it is not a combination of the columns before it: QR without pivoting
of the column-normalised W, |R_kk| > ``tolerance`` (the relative residual of column k after its
predecessors). This is the numerical form of Khalil and Gautier's regrouping rules: a link's YY,
MZ and M are regrouped into the parameters of the links before it, which keep their names with an
R (ZZ1 + YY2 + … = ZZR1). Columns whose norm is below ``tolerance`` of the largest column's are
zero up to rounding: those parameters do not act and are neither base nor regrouped. With b
the base and d the other columns, W_d = W_b K (least squares) and τ = Y θ = Y_b (θ_b + K θ_d) = Y_b β.
Coefficients of K below ``1e-10`` of the largest are set to zero (they are rounding, not regrouping).
The rank decision is checked by the gap: the smallest kept residual and the largest rejected one are
returned (:attr:`BaseParameters.gap`).

States are drawn from a seeded generator: positions uniform in [−π, π] (±0.5 for prismatic-looking
coordinates does not matter here: the rank is a property of almost every state), velocities in
[−3, 3], accelerations in [−10, 10]; 30·len(θ)/N states, at least 200. The parameters of the model
that Y depends on (lengths, gravity) are fixed at their nominal values. A time-varying model's Y (a
[[force]] in time t) is evaluated at a time uniform in [0, 10] s per state as well.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.products import Product
from symbolic.derivation.regressor import Regressor
from symbolic.codegen.functions import compile_function

TOLERANCE = 1e-8
"""A column whose residual after its predecessors is below this fraction of its norm is dependent."""

KINDS = re.compile(r"^(XX|XY|XZ|YY|YZ|ZZ|MX|MY|MZ|M|rho|EIv|EIw|mp)(.*)$")
"""The kinds of the inertial and beam parameters, after which a regrouped one takes Khalil's R (ZZ1 → ZZR1)."""


@dataclass(frozen=True)
class BaseParameters:
    """β = θ_b + K θ_d.

    Attributes
    ----------
    names
        Base-parameter names: the base column's θ name, with Khalil's R after its kind (ZZ1 → ZZR1)
        when other parameters are regrouped into it.
    independent, dependent
        Indices into θ of the base columns b (in β order) and of the others d.
    K
        r × len(d) regrouping coefficients.
    expressions
        Each β as a SymPy linear combination of the θ symbols.
    values
        β at the nominal parameters.
    gap
        (smallest relative residual of a base column, largest of a dependent one): the rank is
        unambiguous when the two are many orders of magnitude apart.
    """

    names: tuple[str, ...]
    independent: tuple[int, ...]
    dependent: tuple[int, ...]
    K: np.ndarray
    expressions: tuple[sp.Expr, ...]
    values: np.ndarray
    gap: tuple[float, float]

    def from_theta(self, theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, float)
        return theta[list(self.independent)] + self.K @ theta[list(self.dependent)]


def regressor_function(model: DynamicModel, reg: Regressor):
    """Y(q, q̇, q̈, p) as an N×len(θ) array; ``Y(q, q̇, q̈, p, t=…)`` for a time-varying model."""
    states = [model.coordinates, model.velocities, model.accelerations]
    if not model.time_varying:
        return compile_function(reg.sub, [*states, model.parameter_symbols], reg.Y, (model.n, len(reg.theta)))
    timed = compile_function(reg.sub, [*states, [model.time], model.parameter_symbols], reg.Y, (model.n, len(reg.theta)))
    return lambda q, qd, qdd, p, t=0.0: timed(q, qd, qdd, [t], p)


def theta_values(model: DynamicModel, reg: Regressor, p=None) -> np.ndarray:
    """θ at parameter values ``p`` (default nominal)."""
    values = model.parameter_vector.with_array(p).by_symbol()
    return np.array([float(e.xreplace(values)) for e in reg.theta_expressions])


def stacked(model: DynamicModel, reg: Regressor, states: int | None = None, seed: int = 0, p=None) -> np.ndarray:
    """W: Y at ``states`` random states stacked (states·N × len(θ))."""
    Y = regressor_function(model, reg)
    n = model.n
    count = states or max(200, int(np.ceil(30 * len(reg.theta) / n)))
    rng = np.random.default_rng(seed)
    p = model.parameter_vector.coerce(p)
    if model.time_varying:
        rows = [Y(rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n), rng.uniform(-10, 10, n), p, t=rng.uniform(0, 10))
                for _ in range(count)]
    else:
        rows = [Y(rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n), rng.uniform(-10, 10, n), p) for _ in range(count)]
    return np.vstack(rows)


def base_parameters(model: DynamicModel, reg: Regressor, tolerance: float = TOLERANCE, seed: int = 0,
                    columns: Sequence[int] | None = None) -> BaseParameters:
    """The base parameters of ``reg`` (see the module docstring).

    ``columns``: the indices into θ to take part (default all). The others are known terms, moved to the
    side of τ (τ − Y_k·θ_k = Y_u·θ_u, :mod:`symbolic.identify.known`): they are neither base nor regrouped,
    and a column that was a combination of them becomes a base column of its own.
    """
    W = stacked(model, reg, seed=seed)
    norms = np.linalg.norm(W, axis=0)
    if columns is not None:
        norms[np.setdiff1d(np.arange(W.shape[1]), np.asarray(columns, int))] = 0.0
    acting = np.flatnonzero(norms > tolerance * norms.max(initial=0.0))  # others are rounding noise
    import scipy.linalg  # here: a model whose base parameters are read from the cache never needs it (0.3-0.6 s)

    R = scipy.linalg.qr(W[:, acting] / norms[acting], mode="r")[0]
    residual = np.abs(np.diag(R))
    keep = residual > tolerance
    b, d = [int(k) for k in acting[keep]], [int(k) for k in acting[~keep]]
    r = len(b)
    gap = (float(residual[keep].min(initial=np.inf)), float(residual[~keep].max(initial=0.0)))
    # K from a least-squares fit of the dependent columns on the base ones (same as R_bb⁻¹R_bd, in θ order)
    K = np.linalg.lstsq(W[:, b], W[:, d], rcond=None)[0] if d else np.zeros((r, 0))
    K[np.abs(K) < 1e-10 * max(np.abs(K).max(initial=0.0), 1.0)] = 0.0
    theta = reg.theta
    expressions, names = [], []
    for i, k in enumerate(b):
        terms = [theta[k]] + [sp.Float(float(_round(K[i, j])), 12) * theta[d[j]] for j in range(len(d)) if K[i, j] != 0]
        expressions.append(sp.Add(*terms))
        names.append(_name(theta[k].name, reg.kinds[k], regrouped=len(terms) > 1))
    values = BaseParameters(tuple(names), tuple(b), tuple(d), K, tuple(expressions), np.zeros(r), gap)
    return BaseParameters(tuple(names), tuple(b), tuple(d), K, tuple(expressions),
                          values.from_theta(theta_values(model, reg)), gap)


def _build(model: DynamicModel) -> BaseParameters:
    return base_parameters(model, model.regressor())


BASE_PARAMETERS: Product[BaseParameters] = Product("base parameters", _build, persist=True)
"""The base parameters of a model's regressor at the default tolerance and seed."""


def model_base_parameters(model: DynamicModel) -> BaseParameters:
    """The base parameters of ``model``'s regressor (module docstring), computed once per model and kept on disk.

    Raises :class:`~symbolic.errors.ModelError` for a model the regressor does not cover (beams).
    """
    return model.products.get(BASE_PARAMETERS)


def _round(x: float) -> float:
    return float(f"{x:.12g}")


def _name(theta: str, kind: str, regrouped: bool) -> str:
    """A base parameter's name: its column's θ name, with Khalil's R after an inertial or beam parameter's
    kind (ZZ1 → ZZR1) or at the end of the others' (Fv_q → Fv_qR, Fc → FcR) when others are regrouped into it."""
    if not regrouped:
        return theta
    m = KINDS.match(theta) if kind in ("inertial", "beam") else None
    return f"{m.group(1)}R{m.group(2)}" if m else f"{theta}R"

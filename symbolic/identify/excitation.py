"""Excitation design: a periodic reference whose log will determine the base parameters best (docs/data.md,
"Excitation design").

The reference of every coordinate is a finite Fourier series of period T = 2π/ω_f (Swevers, Ganseman, Tükel,
De Schutter, Van Brussel, IEEE Trans. Robot. Autom. 13(5), 1997, (12)–(13))::

    q_i(t)   = q_i0 + Σ_l  a_il/(ω_f l)·sin(ω_f l t) − b_il/(ω_f l)·cos(ω_f l t)       l = 1 … L
    q̇_i(t)   =        Σ_l  a_il·cos(ω_f l t) + b_il·sin(ω_f l t)
    q̈_i(t)   =        Σ_l −a_il ω_f l·sin(ω_f l t) + b_il ω_f l·cos(ω_f l t)

At rest at t = 0 (and so at t = T): q̇_i(0) = Σ_l a_il = 0 and q̈_i(0) = ω_f Σ_l l·b_il = 0, two linear
equalities per coordinate, eliminated exactly: a_iL = −Σ_{l<L} a_il and b_iL = −Σ_{l<L} l·b_il / L, so the
optimiser moves the other 2L − 1 coefficients (L ≥ 2: with one harmonic the equalities leave no motion).

The design maximises the information of the base parameters β (τ = W β, :mod:`symbolic.numeric.base_parameters`)
that the log would carry: M = Σ_k W_kᵀ Σ⁻¹ W_k, W_k the base regressor at the reference's state at the grid
times t_k and Σ = diag(σ_j²) the equivalent force noise per coordinate (:mod:`symbolic.identify.excitation_noise`);
criterion D (−log det M, default), A, the condition number, or D and the condition number together
(:mod:`symbolic.identify.excitation_criteria`).
Under, at every grid time, |q_i − mid_i| ≤ half range, |q̇_i| ≤ v_i, |q̈_i| ≤ a_i (linear in the coefficients)
and |τ_i| ≤ τ_i with τ = W(q, q̇, q̈)·β at the model's nominal values. The regressor is translated into CasADi
(the straight-line program of the generated code) and mapped over the grid; the criterion's gradient is its
closed-form ∂/∂M = G chained with the per-sample ∂tr(G·M_k)/∂(q, q̇, q̈) (CasADi's AD of one sample, compiled)
and the linear basis (:class:`_Objective`), and IPOPT (in the casadi wheel; limited-memory Hessian) solves
from several random starts (seeded). The result is verified on a grid ten times finer; a limit crossed there
(between grid points) is tightened by the excess and the start solved again, warm (from the previous solve's
point and multipliers, :data:`WARM_START`); a start still over a limit after three re-solves is scaled inside
(:func:`_shrink`). Collision avoidance (with the
robot itself and its surroundings) is not part of the design.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from symbolic.description.joint_limits import coordinate_limits
from symbolic.derivation.dynamics import DynamicModel
from symbolic.errors import IdentificationError
from symbolic.identify.excitation_criteria import CRITERIA, ds_optimal, positive_definite
from symbolic.numeric.blas import one_blas_thread

LOG = logging.getLogger(__name__)

KINDS = ("position", "velocity", "acceleration", "torque")
HARMONICS = 5
"""Default number of harmonics L per coordinate."""
STARTS = 3
"""Default number of random starts."""
FINER = 10
"""The verification grid is this many times finer than the design grid."""
IPOPT_OPTIONS = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-7,
                 "ipopt.hessian_approximation": "limited-memory", "ipopt.max_iter": 300}
"""IPOPT's options (CasADi's names): quiet, limited-memory Hessian (the criterion's second derivatives are not
formed), at most 300 iterations per solve."""
WARM_START = {"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-6, "ipopt.warm_start_bound_push": 1e-6,
              "ipopt.warm_start_mult_bound_push": 1e-6, "ipopt.warm_start_slack_bound_push": 1e-6}
"""IPOPT's options when a start is solved again with tightened limits: from the previous solve's point and
multipliers, with a small barrier parameter (the solution moves a little), rather than from the barrier's start."""
SIGN_VELOCITY = 1e-2
"""ε of the smooth sign tanh(v/ε) the optimiser sees in place of Coulomb friction's sign(v) (coordinate units per
second): with the exact sign, M and τ jump where a velocity crosses zero at a grid point, and IPOPT's line search
stalls. Limits are verified, and σ predicted, with the exact sign."""
TOLERANCE = 1e-6
"""Relative excess over a limit tolerated on the verification grid."""


@dataclass(frozen=True)
class Limits:
    """Per coordinate (the model's order): position bounds, and bounds on |q̇|, |q̈| and |τ| (``inf``: none).

    ``origin`` says where each came from: ``{"velocity q1": "model file", ...}``.
    """

    coordinates: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    torque: np.ndarray
    origin: Mapping[str, str] = field(default_factory=dict)

    def scaled(self, factors: Mapping[str, np.ndarray]) -> Limits:
        """The limits with ``factors`` ({kind: per-coordinate factor ≤ 1}) applied; position about its middle."""
        middle, half = 0.5 * (self.lower + self.upper), 0.5 * (self.upper - self.lower)
        f = {k: np.asarray(factors.get(k, np.ones(len(self.coordinates))), float) for k in KINDS}
        with np.errstate(invalid="ignore"):
            lower = np.where(np.isfinite(half), middle - f["position"] * half, self.lower)
            upper = np.where(np.isfinite(half), middle + f["position"] * half, self.upper)
        return Limits(self.coordinates, lower, upper, self.velocity * f["velocity"],
                      self.acceleration * f["acceleration"], self.torque * f["torque"], self.origin)

    def to_dict(self) -> dict[str, Any]:
        return {c: {"position": [float(self.lower[i]), float(self.upper[i])], "velocity": float(self.velocity[i]),
                    "acceleration": float(self.acceleration[i]), "torque": float(self.torque[i])}
                for i, c in enumerate(self.coordinates)}


def model_file_limits(model: DynamicModel) -> dict[str, dict[str, Any]]:
    """The limits a model file declares: ``joint.limit`` of its general (URDF) frames, URDF ``<limit>``
    included — lower/upper → position, velocity → velocity, effort → torque — as bounds of the coordinates
    (:func:`symbolic.description.joint_limits.coordinate_limits`: a joint variable ±q + offset). DH frames
    declare none."""
    found: dict[str, dict[str, Any]] = {k: {} for k in KINDS}
    for c, limits in coordinate_limits(model.robot).items():
        if limits.lower is not None:
            found["position"][c] = (limits.lower, limits.upper)
        if limits.velocity is not None:
            found["velocity"][c] = limits.velocity
        if limits.effort is not None:
            found["torque"][c] = limits.effort
    return found


def resolve_limits(model: DynamicModel, *sources: tuple[str, Mapping[str, Mapping[str, Any]]]) -> Limits:
    """The limits of every coordinate: the model file's (:func:`model_file_limits`), replaced by each of
    ``sources`` in turn (``(origin, {kind: {coordinate: value}})``, e.g. the experiment's ``[excitation]``, then
    the command line). A limit no source declares is refused with what to declare.

    Raises
    ------
    IdentificationError
        Naming the coordinates and the limit missing, and where to declare it.
    """
    names = tuple(model.robot.generalized_coordinates)
    merged: dict[str, dict[str, Any]] = {k: {} for k in KINDS}
    origin: dict[str, str] = {}
    for where, declared in (("model file", model_file_limits(model)), *sources):
        for kind in KINDS:
            for c, value in (declared.get(kind) or {}).items():
                merged[kind][c], origin[f"{kind} {c}"] = value, where
    for kind in KINDS:
        missing = [c for c in names if c not in merged[kind]]
        if missing:
            example = "[-1.0, 1.0]" if kind == "position" else "2.0"
            raise IdentificationError(
                f"no {kind} limit for coordinate{'s' if len(missing) > 1 else ''} {', '.join(missing)}: declare it in the "
                f"experiment's [excitation] table ({kind} = {{ {missing[0]} = {example} }}, or one number for every "
                f"coordinate; inf for none) or with --{kind} {missing[0]}={example.strip('[]').replace(', ', ':')}"
                + (" (or as joint.limit in the model file)" if kind in ("position", "velocity", "torque") else ""))
    position = np.array([merged["position"][c] for c in names], float).reshape(len(names), 2)
    return Limits(names, position[:, 0], position[:, 1], *(np.array([merged[k][c] for c in names], float)
                                                            for k in KINDS[1:]), origin)


# -- the Fourier series -------------------------------------------------------------------------------------


def basis(t: np.ndarray, period: float, harmonics: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Φ_q, Φ_q̇, Φ_q̈ (``len(t) × (1 + 2L)``): q = Φ_q·c for a coordinate's c = [q0, a_1…a_L, b_1…b_L]
    (module docstring)."""
    t = np.asarray(t, float).reshape(-1, 1)
    omega = 2.0 * np.pi / period * np.arange(1, harmonics + 1)
    s, c = np.sin(omega * t), np.cos(omega * t)
    ones, zeros = np.ones((len(t), 1)), np.zeros((len(t), 1))
    return (np.hstack([ones, s / omega, -c / omega]), np.hstack([zeros, c, s]),
            np.hstack([zeros, -s * omega, c * omega]))


def rest_null_space(harmonics: int) -> np.ndarray:
    """Z ((1 + 2L) × (2L − 1)): c = Z·z meets Σ a_l = 0 and Σ l·b_l = 0 for every z, by construction
    (a_L and b_L are the combinations of the others that make the sums zero)."""
    L = harmonics  # noqa: N806
    Z = np.zeros((1 + 2 * L, 2 * L - 1))  # noqa: N806
    Z[0, 0] = 1.0
    for l in range(L - 1):  # noqa: E741
        Z[1 + l, 1 + l] = 1.0
        Z[L, 1 + l] = -1.0
        Z[1 + L + l, L + l] = 1.0
        Z[2 * L, L + l] = -(l + 1) / L
    return Z


@dataclass(frozen=True)
class FourierTrajectory:
    """A periodic reference per coordinate (module docstring): ``offsets`` q_i0 (N), ``a`` and ``b`` (N × L)."""

    coordinates: tuple[str, ...]
    period: float
    offsets: np.ndarray
    a: np.ndarray
    b: np.ndarray

    @property
    def harmonics(self) -> int:
        return self.a.shape[1]

    def coefficients(self) -> np.ndarray:
        """(1 + 2L) × N: column i is coordinate i's [q0, a, b]."""
        return np.vstack([self.offsets, self.a.T, self.b.T])

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ at times ``t`` (``len(t) × N`` each)."""
        C = self.coefficients()  # noqa: N806
        return tuple(phi @ C for phi in basis(t, self.period, self.harmonics))  # type: ignore[return-value]

    @classmethod
    def from_free(cls, coordinates: Sequence[str], period: float, harmonics: int, z: np.ndarray) -> FourierTrajectory:
        """The trajectory of the free coefficients z (N·(2L − 1), coordinate by coordinate; :func:`rest_null_space`)."""
        n = len(coordinates)
        C = rest_null_space(harmonics) @ np.asarray(z, float).reshape(n, 2 * harmonics - 1).T  # noqa: N806
        return cls(tuple(coordinates), float(period), C[0].copy(), C[1:1 + harmonics].T.copy(), C[1 + harmonics:].T.copy())

    def to_dict(self) -> dict[str, Any]:
        return {"period": self.period, "harmonics": self.harmonics,
                "coordinates": {c: {"q0": float(self.offsets[i]), "a": self.a[i].tolist(), "b": self.b[i].tolist()}
                                for i, c in enumerate(self.coordinates)}}


def reference_samples(trajectory: FourierTrajectory, rate: float) -> tuple[np.ndarray, ...]:
    """t (0 … T at ``rate``, both ends included), q, q̇, q̈ of ``trajectory``: the reference as a log records it."""
    count = int(round(trajectory.period * rate)) + 1
    t = np.arange(count) / rate
    return (t, *trajectory.evaluate(t))


# -- the regressor in CasADi ---------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CasadiRegressor:
    """The base regressor W(q, q̇, q̈) (N × b) and the functions the design maps over a grid.

    ``information(q, qd, qdd, w) -> Wᵀdiag(w)W`` (b × b), ``torque(q, qd, qdd) -> W·β`` (N), β the base
    parameters at the model's nominal values, ``torque_jacobian(q, qd, qdd) -> ∂τ/∂[q; q̇; q̈]`` (N × 3N; compiled
    C when a compiler is found, :func:`symbolic.codegen.compiled.compile_casadi`: its source depends on the model
    alone, so it is compiled once per machine).
    """

    n: int
    names: tuple[str, ...]
    beta: np.ndarray
    regressor: ca.Function
    information: ca.Function
    torque: ca.Function
    torque_jacobian: ca.Function
    information_gradient: ca.Function
    """``(q, qd, qdd, w, G) -> ∂ tr(G·W_kᵀdiag(w)W_k)/∂[q; q̇; q̈]`` (3N; compiled like ``torque_jacobian``): the
    per-sample factor of the criterion's gradient (:class:`_Objective`)."""


def has_sign(model: DynamicModel) -> bool:
    """Whether the base regressor holds sign(·) (Coulomb friction): its columns jump where a velocity crosses zero."""
    from symbolic.identify.model import model_base

    reg, base = model_base(model)
    columns = list(reg.Y.extract(list(range(model.n)), list(base.independent)))
    return any(d.has(sp.sign) for _, d in reg.sub.program(columns)) or any(c.has(sp.sign) for c in columns)


def casadi_regressor(model: DynamicModel, sign_velocity: float | None = None) -> CasadiRegressor:
    """Translate the base columns of the model's regressor into CasADi SX (the straight-line program of the
    generated code, :func:`symbolic.codegen.casadi.program_to_sx`) at the nominal parameter values.

    ``sign_velocity`` ε: sign(v) becomes tanh(v/ε) (what the optimiser sees, :data:`SIGN_VELOCITY`); ``None``:
    the exact sign (what the limits are verified on and identify uses)."""
    from symbolic.codegen.casadi import program_to_sx
    from symbolic.identify.model import model_base

    if model.time_varying:
        raise IdentificationError(f"model {model.name}'s forces depend on time t: an excitation design for a "
                                  "time-varying model is not supported")
    reg, base = model_base(model)
    n, b = model.n, len(base.names)
    columns = reg.Y.extract(list(range(n)), list(base.independent))
    q, qd, qdd, w = (ca.SX.sym(name, n) for name in ("q", "qd", "qdd", "w"))
    p = ca.DM(model.parameter_vector.coerce(None))
    groups = [model.coordinates, model.velocities, model.accelerations, model.parameter_symbols]
    module = None if sign_velocity is None else {"sign": lambda v: ca.tanh(v / sign_velocity)}
    flat = program_to_sx(reg.sub, columns, groups, [q, qd, qdd, ca.SX(p)], module)
    W = ca.reshape(flat, b, n).T  # lambdify's outputs are row-major  # noqa: N806
    beta = np.asarray(base.values, float)
    tau = ca.mtimes(W, ca.DM(beta))
    M = ca.mtimes(W.T, ca.mtimes(ca.diag(w), W))  # noqa: N806
    G = ca.SX.sym("G", b, b)  # noqa: N806
    suffix = f"{_identifier(model.name)}{'' if sign_velocity is None else '_smooth'}"
    return CasadiRegressor(
        n, tuple(base.names), beta,
        ca.Function("W", [q, qd, qdd], [W], ["q", "qd", "qdd"], ["W"]),
        _compiled(ca.Function(f"M_{suffix}", [q, qd, qdd, w], [M], ["q", "qd", "qdd", "w"], ["M"])),
        ca.Function("tau", [q, qd, qdd], [tau], ["q", "qd", "qdd"], ["tau"]),
        _compiled(ca.Function(f"dtau_{suffix}", [q, qd, qdd],
                              [ca.jacobian(tau, ca.vertcat(q, qd, qdd))], ["q", "qd", "qdd"], ["dtau"])),
        _compiled(ca.Function(f"dM_{suffix}", [q, qd, qdd, w, G],
                              [ca.gradient(ca.sum1(ca.sum2(G * M)), ca.vertcat(q, qd, qdd))],
                              ["q", "qd", "qdd", "w", "G"], ["dM"])))


def _identifier(name: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in name)


def _compiled(function: ca.Function) -> ca.Function:
    """``function`` compiled (cached per machine), or itself without a compiler."""
    from symbolic.codegen.compiled import compile_casadi

    return compile_casadi(function) or function


def information_matrix(regressor: CasadiRegressor, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                       weights: np.ndarray) -> np.ndarray:
    """M = Σ_k W_kᵀ diag(weights) W_k over the samples (rows of q, q̇, q̈), numerically."""
    mapped = regressor.information.map("M_sum", "serial", len(q), [3], [0], {})  # summed over the samples
    return np.asarray(mapped(q.T, qd.T, qdd.T, np.asarray(weights, float)))


def torques(regressor: CasadiRegressor, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """τ = W·β at the samples (``samples × N``)."""
    return np.asarray(regressor.torque.map(len(q))(q.T, qd.T, qdd.T)).T


# -- the optimisation ----------------------------------------------------------------------------------------


class _WithJacobian(ca.Callback):
    """A callback that gives CasADi its Jacobian as another callback (:attr:`jacobian_class`), kept alive here:
    CasADi holds no Python reference to it."""

    jacobian_class: type

    def _on_grid(self, regressor: CasadiRegressor, grid: np.ndarray, period: float, harmonics: int) -> None:
        """The design's layout: N coordinates, K grid points, m free coefficients per coordinate, and the
        state bases B_s = Φ_s·Z (3 × K × m: q, q̇, q̈ linear in the coefficients)."""
        ca.Callback.__init__(self)
        self.regressor, self.n, self.K = regressor, regressor.n, len(grid)
        Z = rest_null_space(harmonics)  # noqa: N806
        self.B = np.stack([phi @ Z for phi in basis(grid, period, harmonics)])
        self.m = Z.shape[1]
        self.kept = []

    def get_n_in(self) -> int:
        return 1

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.n * self.m, 1)

    def states(self, z: np.ndarray) -> list[np.ndarray]:
        """q, q̇, q̈ at the grid points (K × N each) of the coefficients ``z`` (coordinate by coordinate)."""
        C = np.asarray(z, float).reshape(self.n, self.m).T  # noqa: N806
        return [b @ C for b in self.B]

    def has_jacobian(self) -> bool:
        return True

    def get_jacobian(self, name, inames, onames, opts):
        jacobian = self.jacobian_class(name, self)
        self.kept.append(jacobian)
        return jacobian


class _Jacobian(ca.Callback):
    """The Jacobian of ``outer`` at (its input, its output), one matrix."""

    def __init__(self, name: str, outer: ca.Callback) -> None:
        ca.Callback.__init__(self)
        self.outer = outer
        self.construct(name, {})

    def get_n_in(self) -> int:
        return 2

    def get_n_out(self) -> int:
        return 1


class _Constraints(_WithJacobian):
    """g(z) = [q; q̇; q̈; τ] at the grid points (each K × N, stacked column by column: coordinate blocks) with its
    Jacobian assembled from the structure: the states are linear in z, s_k = B_s[k]·z per coordinate
    (B_s = Φ_s·Z), and τ_k depends on z only through the state at t_k, so
    ∂τ_jk/∂z_(i,r) = Σ_s (∂τ_j/∂s_i)_k B_s[k, r] with the per-sample ∂τ/∂s of
    :attr:`CasadiRegressor.torque_jacobian` (compiled) — where CasADi's AD of the whole map would propagate every
    one of the N·(2L − 1) directions through every sample (ten times slower for the Panda)."""

    def __init__(self, regressor: CasadiRegressor, grid: np.ndarray, period: float, harmonics: int) -> None:
        self._on_grid(regressor, grid, period, harmonics)
        self.linear = np.vstack([np.kron(np.eye(self.n), b) for b in self.B])  # (3·N·K) × (N·m)
        pattern = np.vstack([np.kron(np.eye(self.n), np.ones((3 * self.K, self.m))).reshape(self.n, 3, self.K, -1)
                             .transpose(1, 0, 2, 3).reshape(3 * self.n * self.K, -1),
                             np.ones((self.n * self.K, self.n * self.m))]).astype(bool)
        rows, columns = np.nonzero(pattern.T)
        self.sparsity = ca.Sparsity.triplet(pattern.shape[0], pattern.shape[1], columns.tolist(), rows.tolist())
        """The Jacobian's structure: q, q̇, q̈ of coordinate i depend on its own coefficients alone (IPOPT factorises
        about a third of a dense Jacobian's nonzeros)."""
        self.nonzero = pattern.T
        self.construct("constraints", {})

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(4 * self.n * self.K, 1)

    def eval(self, arg):
        states = self.states(np.asarray(arg[0]).ravel())
        tau = np.asarray(self.regressor.torque.map(self.K)(*(x.T for x in states))).T
        return [np.concatenate([x.T.ravel() for x in (*states, tau)])]

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        states = self.states(z)
        A = np.asarray(self.regressor.torque_jacobian.map(self.K)(*(x.T for x in states)))  # noqa: N806
        A = A.reshape(self.n, self.K, 3, self.n)  # [j, k, s, i]: column k·3N + s·N + i of the map's horzcat  # noqa: N806
        torque = np.einsum("jksi,skr->jkir", A, self.B).reshape(self.n * self.K, self.n * self.m)
        return np.vstack([self.linear, torque])


class _ConstraintJacobian(_Jacobian):
    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return self.outer.get_sparsity_in(0) if i == 0 else self.outer.get_sparsity_out(0)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return self.outer.sparsity

    def eval(self, arg):
        jacobian = self.outer.jacobian(np.asarray(arg[0]).ravel())
        return [ca.DM(self.outer.sparsity, jacobian.T[self.outer.nonzero])]  # nonzeros column by column


_Constraints.jacobian_class = _ConstraintJacobian


class _Objective(_WithJacobian):
    """The criterion of M(z) = Σ_k W_kᵀdiag(w)W_k / K over the grid, with its gradient assembled as the constraints'
    Jacobian is: with G = ∂criterion/∂M (closed form, :mod:`~symbolic.identify.excitation_criteria`),
    ∂criterion/∂z_(i,r) = (1/K) Σ_k Σ_s (∂ tr(G M_k)/∂s_i)_k B_s[k, r], the per-sample factor computed by the
    compiled :attr:`CasadiRegressor.information_gradient` and B_s = Φ_s·Z linear in z. M and that factor are
    compiled C (CasADi's interpreted reverse mode through the mapped M took nine tenths of a Panda start's 40 s in
    a profile; with this, most of a start is IPOPT's own work).
    Outside the criterion's domain (M not positive definite) the value is 1e10 with no slope (IPOPT backtracks)."""

    def __init__(self, regressor: CasadiRegressor, grid: np.ndarray, period: float, harmonics: int,
                 weights: np.ndarray, criterion) -> None:
        self._on_grid(regressor, grid, period, harmonics)
        self.criterion, self.weights = criterion, np.asarray(weights, float)
        self.information = regressor.information.map("M_sum", "serial", self.K, [3], [0], {})
        self.gradient_map = regressor.information_gradient.map(self.K)
        self.last: tuple[bytes, list[np.ndarray], np.ndarray] | None = None
        """The last z, its states and M: IPOPT asks for the value and then the gradient at the same point."""
        self.construct("objective", {})

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(1, 1)

    def matrix(self, z: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """The states at the grid points and M(z) (computed once per z)."""
        key = z.tobytes()
        if self.last is None or self.last[0] != key:
            states = self.states(z)
            M = np.asarray(self.information(*(x.T for x in states), self.weights)) / self.K  # noqa: N806
            self.last = (key, states, M)
        return self.last[1], self.last[2]

    def evaluate(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        """The criterion and its gradient in z."""
        states, M = self.matrix(np.ascontiguousarray(z, float))  # noqa: N806
        if not positive_definite(M):
            return 1e10, np.zeros(self.n * self.m)
        value, G = self.criterion(M)  # noqa: N806
        h = np.asarray(self.gradient_map(*(x.T for x in states), self.weights, G)) / self.K  # 3N × K
        gradient = np.einsum("sik,skr->ir", h.reshape(3, self.n, self.K), self.B)
        return float(value), gradient.ravel()

    def eval(self, arg):
        return [self.evaluate(np.asarray(arg[0]).ravel())[0]]


class _ObjectiveGradient(_Jacobian):
    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return self.outer.get_sparsity_in(0) if i == 0 else ca.Sparsity.dense(1, 1)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(1, self.outer.n * self.outer.m)

    def eval(self, arg):
        return [self.outer.evaluate(np.asarray(arg[0]).ravel())[1].reshape(1, -1)]


_Objective.jacobian_class = _ObjectiveGradient


@dataclass(eq=False)
class Problem:
    """The design problem on a grid: the NLP in the free coefficients z, its constraints and criterion."""

    regressor: CasadiRegressor
    limits: Limits
    period: float
    harmonics: int
    grid: np.ndarray
    weights: np.ndarray
    criterion: str
    exact: CasadiRegressor | None = None
    """The regressor with the exact sign, on which limits are verified (default: ``regressor``)."""
    separate: tuple[int, ...] = ()
    """Base parameters to separate: the criterion is then Ds-optimality for them
    (:func:`~symbolic.identify.excitation_criteria.ds_optimal`), whatever ``criterion`` names."""
    constraints: _Constraints = field(init=False, repr=False)
    objective: _Objective = field(init=False, repr=False)
    solver: Any = field(init=False, repr=False)
    warm_solver: Any = field(init=False, repr=False)
    bounds: tuple[np.ndarray, np.ndarray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.exact = self.exact or self.regressor
        n, L, K = self.regressor.n, self.harmonics, len(self.grid)  # noqa: N806
        function = ds_optimal(self.separate) if self.separate else CRITERIA[self.criterion]
        z = ca.MX.sym("z", n * (2 * L - 1))
        self.objective = _Objective(self.regressor, self.grid, self.period, L, self.weights, function)
        f = self.objective(z)
        self.constraints = _Constraints(self.regressor, self.grid, self.period, L)
        g = self.constraints(z)
        self.bounds = self._constraint_bounds(self.limits, K)
        self.solver = ca.nlpsol("excitation", "ipopt", {"x": z, "f": f, "g": g}, dict(IPOPT_OPTIONS))
        self.warm_solver = ca.nlpsol("excitation_warm", "ipopt", {"x": z, "f": f, "g": g},
                                     {**IPOPT_OPTIONS, **WARM_START})

    @staticmethod
    def _constraint_bounds(limits: Limits, K: int) -> tuple[np.ndarray, np.ndarray]:  # noqa: N803
        rows = [(limits.lower, limits.upper), (-limits.velocity, limits.velocity),
                (-limits.acceleration, limits.acceleration), (-limits.torque, limits.torque)]
        lower = np.concatenate([np.repeat(lo, K) for lo, _ in rows])  # ca.vec is column-major: coordinate blocks
        upper = np.concatenate([np.repeat(hi, K) for _, hi in rows])
        return lower, upper

    def with_limits(self, limits: Limits) -> None:
        """Tighten the constraint bounds (the NLP is unchanged)."""
        self.bounds = self._constraint_bounds(limits, len(self.grid))

    def solve(self, z0: np.ndarray, warm: Mapping[str, Any] | None = None) -> tuple[np.ndarray, str, dict[str, Any]]:
        """IPOPT from ``z0``: the free coefficients, IPOPT's return status and its result. ``warm``: the result of
        a previous solve, whose multipliers start this one (:data:`WARM_START`)."""
        if warm is None:
            solver, given = self.solver, {}
        else:
            solver, given = self.warm_solver, {"lam_g0": warm["lam_g"], "lam_x0": warm["lam_x"]}
        result = solver(x0=z0, lbg=self.bounds[0], ubg=self.bounds[1], **given)
        return np.asarray(result["x"]).ravel(), str(solver.stats().get("return_status", "unknown")), result

    def value(self, z: np.ndarray) -> float:
        return self.objective.evaluate(np.asarray(z, float))[0]

    def gradient(self, z: np.ndarray) -> np.ndarray:
        return self.objective.evaluate(np.asarray(z, float))[1]

    def trajectory(self, z: np.ndarray) -> FourierTrajectory:
        return FourierTrajectory.from_free(self.limits.coordinates, self.period, self.harmonics, z)


REFINE = 101
"""Points of the local grid that :func:`violation` lays over ±one step around each peak of the verification grid."""
PEAK = 0.99
"""A local peak of |q − middle|, |q̇|, |q̈| or |τ| on the verification grid is refined when it reaches this share of
the coordinate's largest."""


def violation(regressor: CasadiRegressor, trajectory: FourierTrajectory, limits: Limits,
              t: np.ndarray) -> dict[str, np.ndarray]:
    """Per kind, per coordinate: the largest ratio of the excursion to its limit on the times ``t`` (≤ 1: inside),
    refined between them.

    A peak between two times of ``t`` exceeds both: for a harmonic of frequency ω sampled every h, by up to
    1 − cos(ωh/2) ≈ (ωh)²/8 relative (1.2e-4 for the EMPS design's verification grid, 60 times
    :data:`TOLERANCE`). So around every local peak of ``t`` within :data:`PEAK` of its coordinate's largest (the
    signed extremes of q, q̇, q̈ and τ), a grid of :data:`REFINE` points over ± one step of ``t`` is evaluated too,
    which leaves (ωh/100)²/8 — below 1e-7 there. Position: :func:`position_ratio`."""
    t = np.asarray(t, float)
    q, qd, qdd = trajectory.evaluate(t)
    tau = torques(regressor, q, qd, qdd)
    if len(t) > 2:
        step = float(np.median(np.diff(t)))
        middle = np.where(np.isfinite(limits.lower + limits.upper), 0.5 * (limits.lower + limits.upper), 0.0)
        peaks = set()
        for signal in (q - middle, qd, qdd, tau):
            for values in (signal, -signal):
                top = values.max(axis=0)
                local = (values > np.roll(values, 1, axis=0)) & (values >= np.roll(values, -1, axis=0))  # a flat run: none
                high = local & (values >= np.where(top > 0, PEAK * top, top))
                peaks.update(np.flatnonzero(high.any(axis=1)).tolist())
        offsets = np.linspace(-step, step, REFINE)
        local_t = (t[sorted(peaks)][:, None] + offsets[None, :]).ravel()
        if local_t.size:
            t = np.concatenate([t, local_t])
            more = trajectory.evaluate(local_t)
            q, qd, qdd = (np.vstack([a, b]) for a, b in zip((q, qd, qdd), more))
            tau = np.vstack([tau, torques(regressor, *more)])
    tau = torques(regressor, q, qd, qdd)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = {"position": position_ratio(q, limits.lower, limits.upper),
                 "velocity": np.abs(qd).max(axis=0) / limits.velocity,
                 "acceleration": np.abs(qdd).max(axis=0) / limits.acceleration,
                 "torque": np.abs(tau).max(axis=0) / limits.torque}
    return {k: np.nan_to_num(v, nan=0.0) for k, v in ratio.items()}


def position_ratio(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Per coordinate (columns of ``q``), how far the positions go towards their bounds, 1 at a bound.

    Both bounds finite: the largest |q − middle| over the half range. One bound (the other ±inf): with g the
    least distance of q to it (negative beyond it) and s = max q − min q the excursion, s/(g + s) for g ≥ 0 and
    1 − g/s beyond it (∞ for a constant q beyond it). No bound: 0."""
    q = np.asarray(q, float)
    out = np.zeros(q.shape[1])
    for i, (low, high) in enumerate(zip(lower, upper)):
        column = q[:, i]
        if np.isfinite(low) and np.isfinite(high):
            out[i] = np.abs(column - 0.5 * (low + high)).max() / (0.5 * (high - low))
        elif np.isfinite(low) or np.isfinite(high):
            gap = float((column - low).min() if np.isfinite(low) else (high - column).min())
            span = float(np.ptp(column))
            if gap >= 0:
                out[i] = span / (gap + span) if gap + span > 0 else 1.0
            else:
                out[i] = 1.0 - gap / span if span > 0 else math.inf
    return out


def random_start(rng: np.random.Generator, problem: Problem, fill: float = 0.6) -> np.ndarray:
    """Free coefficients of a random reference inside the limits: random coefficients decaying as 1/l, each
    coordinate scaled to use ``fill`` of its position range, velocity and acceleration bounds (the tightest),
    centred in its range, then all shrunk until |τ| is within ``fill`` of its bound (a few halvings at most)."""
    n, L = problem.regressor.n, problem.harmonics  # noqa: N806
    decay = np.concatenate([[1.0], 1.0 / np.arange(1, L), 1.0 / np.arange(1, L)])
    z = rng.standard_normal((n, 2 * L - 1)) * decay
    z[:, 0] = 0.0
    limits, fine = problem.limits, np.linspace(0.0, problem.period, FINER * len(problem.grid), endpoint=False)
    trajectory = problem.trajectory(z.ravel())
    q, qd, qdd = trajectory.evaluate(fine)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.nanmin(np.vstack([fill * (limits.upper - limits.lower) / np.ptp(q, axis=0),
                                     fill * limits.velocity / np.abs(qd).max(axis=0),
                                     fill * limits.acceleration / np.abs(qdd).max(axis=0)]), axis=0)
    scale = np.where(np.isfinite(scale), scale, 1.0)
    z *= scale[:, None]
    middle = np.where(np.isfinite(limits.lower + limits.upper), 0.5 * (limits.lower + limits.upper),
                      np.where(np.isfinite(limits.lower), limits.lower + 1.0, np.where(np.isfinite(limits.upper),
                                                                                      limits.upper - 1.0, 0.0)))
    q = problem.trajectory(z.ravel()).evaluate(fine)[0]
    z[:, 0] = middle - 0.5 * (q.max(axis=0) + q.min(axis=0))
    for _ in range(6):
        if violation(problem.exact, problem.trajectory(z.ravel()), limits, fine)["torque"].max() <= fill:
            break
        z[:, 1:] *= 0.7
        q = problem.trajectory(z.ravel()).evaluate(fine)[0]
        z[:, 0] += middle - 0.5 * (q.max(axis=0) + q.min(axis=0))
    return z.ravel()


# -- the design ----------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Start:
    """One random start: the criterion at the start and after the solve, IPOPT's status, and the worst ratio to a
    limit on the verification grid (a start is a candidate for the design when it is at most 1 + :data:`TOLERANCE`)."""

    index: int
    """Which start (0, 1, …): the starts are drawn in turn from one generator seeded by ``seed``."""
    start_value: float
    value: float
    status: str
    worst: float
    seconds: float
    worst_kind: str = ""
    """The kind of limit (position, velocity, acceleration, torque) closest to or beyond its bound."""


@dataclass(frozen=True, eq=False)
class Design:
    """An excitation design: the reference, the criterion, the limits, and how it was found.

    Attributes
    ----------
    trajectory
        The designed reference.
    criterion
        ``"d"``, ``"a"``, ``"condition"``, ``"dc"`` or ``"ds"``; ``value`` its value on the design grid (M normalised
        per grid point),
        ``start_value`` the best start's value before the solve.
    limits
        The limits declared (those tightened on the verification grid are in ``margins``).
    worst
        {kind: largest ratio to the limit per coordinate on the verification grid} (≤ 1 + 1e-6).
    starts
        Every start.
    weights
        1/σ² per coordinate used in M.
    """

    trajectory: FourierTrajectory
    criterion: str
    value: float
    start_value: float
    limits: Limits
    worst: Mapping[str, np.ndarray]
    starts: tuple[Start, ...]
    weights: np.ndarray
    grid_points: int
    seconds: float
    regressor: CasadiRegressor = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {"criterion": self.criterion, "value": self.value, "start_value": self.start_value,
                "grid_points": self.grid_points, "seconds": self.seconds,
                "worst_ratio_to_limit": {k: dict(zip(self.limits.coordinates, map(float, v)))
                                         for k, v in self.worst.items()},
                "starts": [{"start": s.index, "start_value": s.start_value, "value": s.value, "status": s.status,
                            "worst_ratio": s.worst, "worst_kind": s.worst_kind, "seconds": s.seconds}
                           for s in self.starts],
                "limits": self.limits.to_dict(), "trajectory": self.trajectory.to_dict()}


def design(model: DynamicModel, limits: Limits, duration: float, *, weights: Sequence[float] | None = None,
           harmonics: int = HARMONICS, criterion: str = "d", starts: int = STARTS, seed: int = 0,
           grid_points: int | None = None, separate: Sequence[int] = ()) -> Design:
    """The periodic reference of period ``duration`` (s) that optimises ``criterion`` under ``limits``
    (module docstring).

    Parameters
    ----------
    model
        The derived model; its base parameters at the nominal values give the torques.
    limits
        From :func:`resolve_limits`.
    duration
        T, the period and length of the reference (s), > 0.
    weights
        1/σ_j² per coordinate (the equivalent force noise, :func:`symbolic.identify.excitation_noise.equivalent_noise`);
        default 1.
    harmonics
        L ≥ 2 harmonics per coordinate.
    criterion
        A name of :data:`~symbolic.identify.excitation_criteria.CRITERIA`.
    starts, seed
        Random starts, drawn from ``numpy.random.default_rng(seed)``: the same seed, the same design.
    grid_points
        Grid of the constraints and of M (default max(100, 20·L): 20 points per period of the highest harmonic); verified on one :data:`FINER` times finer.
    separate
        Indices of base parameters (two, for ``symbolic excite --separate A,B``) to separate: Ds-optimality for
        them (:func:`~symbolic.identify.excitation_criteria.ds_optimal`) replaces ``criterion``, and the design's
        criterion is ``"ds"``.

    Raises
    ------
    IdentificationError
        For a duration, harmonics, criterion or start count that cannot be used (one line each), or when no start
        gives a reference inside the limits.
    """
    check_options(duration, harmonics, criterion, starts)
    started = time.perf_counter()
    regressor = casadi_regressor(model)
    smooth = casadi_regressor(model, SIGN_VELOCITY) if has_sign(model) else regressor
    n = regressor.n
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    K = grid_points or max(100, 20 * harmonics)  # noqa: N806
    grid = np.linspace(0.0, duration, K, endpoint=False)
    fine = np.linspace(0.0, duration, FINER * K, endpoint=False)
    separate = tuple(int(i) for i in separate)
    criterion = "ds" if separate else criterion
    problem = Problem(smooth, limits, float(duration), harmonics, grid, w / w.mean(), criterion, regressor, separate)
    LOG.info("excitation: %d coordinates × %d harmonics, %d base parameters, %d grid points, criterion %s, %d start(s)",
             n, harmonics, len(regressor.names), K, criterion, starts)
    rng = np.random.default_rng(seed)
    best, runs = None, []
    for k in range(starts):
        with one_blas_thread():  # M is b × b (b ≈ 50), factored at every iteration: threads cost more than they give
            z, run = _one_start(problem, random_start(rng, problem), fine, k)
        runs.append(run)
        LOG.info("excitation: start %d/%d: criterion %.6g -> %.6g (%s, worst ratio to a limit %.6f (%s), %.1f s)",
                 k + 1, starts, run.start_value, run.value, run.status, run.worst, run.worst_kind, run.seconds)
        if run.worst <= 1.0 + TOLERANCE and (best is None or run.value < best[1].value):
            best = (z, run)
    if best is None:
        raise IdentificationError(f"no start of {starts} gave a reference inside the limits (worst ratio to a limit "
                                  f"{min(r.worst for r in runs):.4g}): loosen the limits or give more --starts")
    trajectory = problem.trajectory(best[0])
    return Design(trajectory, criterion, best[1].value, best[1].start_value, limits,
                  violation(regressor, trajectory, limits, fine), tuple(runs), w, K, time.perf_counter() - started,
                  regressor)


def check_options(duration: float, harmonics: int, criterion: str, starts: int) -> None:
    """One line per option that cannot be used."""
    if isinstance(duration, bool) or not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise IdentificationError(f"--duration: the reference's period T must be a time > 0 s, got {duration!r}")
    if isinstance(harmonics, bool) or not isinstance(harmonics, int) or harmonics < 2:
        raise IdentificationError(f"--harmonics: at least 2 harmonics are needed (at rest at t = 0 and T, one "
                                  f"harmonic leaves no motion), got {harmonics!r}")
    if criterion not in CRITERIA:
        raise IdentificationError(f"--criterion: unknown criterion {criterion!r} (allowed: {', '.join(CRITERIA)})")
    if isinstance(starts, bool) or not isinstance(starts, int) or starts < 1:
        raise IdentificationError(f"--starts: at least 1 random start, got {starts!r}")


def _one_start(problem: Problem, z0: np.ndarray, fine: np.ndarray, index: int) -> tuple[np.ndarray, Start]:
    """Solve from ``z0``; where the verification grid finds a limit crossed between grid points, tighten that
    limit by the excess (and 1e-4 more) and solve again from the result (three times at most)."""
    started = time.perf_counter()
    start_value = problem.value(z0)
    declared, tightened = problem.limits, problem.limits
    factors = {k: np.ones(problem.regressor.n) for k in KINDS}
    z, status, worst, worst_kind, warm = z0, "not solved", math.inf, "", None
    for _ in range(4):
        problem.with_limits(tightened)
        z, status, warm = problem.solve(z, warm)
        ratios = violation(problem.exact, problem.trajectory(z), declared, fine)
        worst_kind = max(ratios, key=lambda k: float(ratios[k].max()))
        worst = float(ratios[worst_kind].max())
        if worst <= 1.0 + TOLERANCE:
            break
        for k, v in ratios.items():
            factors[k] = np.where(v > 1.0, factors[k] / v * (1.0 - 1e-4), factors[k])
        tightened = declared.scaled(factors)
    problem.with_limits(declared)
    if worst > 1.0 + TOLERANCE:
        z, worst, worst_kind, scale = _shrink(problem, z, fine)
        status += f"; amplitudes × {scale:.6f}" if worst <= 1.0 + TOLERANCE else ""
    return z, Start(index, start_value, problem.value(z), status, worst, time.perf_counter() - started, worst_kind)


def _shrink(problem: Problem, z: np.ndarray, fine: np.ndarray) -> tuple[np.ndarray, float, str, float]:
    """The last resort of a start still over a limit after its re-solves: every coefficient but the offsets scaled
    by (1 − 1e-4)/(worst ratio), as long as that lowers the worst ratio (five times at most). q̇, q̈ and the excursion
    about q0 scale exactly, τ not exactly (gravity's part depends on the positions alone). Returns z, the
    worst ratio and its kind on the verification grid, and the scale applied."""
    n = problem.regressor.n
    scale, worst, kind = 1.0, math.inf, ""
    for _ in range(5):
        shrunk = z.reshape(n, -1).copy()
        shrunk[:, 1:] *= scale
        ratios = violation(problem.exact, problem.trajectory(shrunk.ravel()), problem.limits, fine)
        kind_now = max(ratios, key=lambda k: float(ratios[k].max()))
        worst_now = float(ratios[kind_now].max())
        if worst_now >= worst:
            break
        best, worst, kind = (shrunk.ravel(), scale), worst_now, kind_now
        if worst <= 1.0 + TOLERANCE:
            break
        scale *= (1.0 - 1e-4) / worst
    return best[0], worst, kind, best[1]

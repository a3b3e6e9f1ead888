"""The functions every export target provides (docs/contracts.md, "Generated C" / "Generated CasADi").

Each entry names the function, its inputs (q, qd, qdd, tau, p; and t, the time in seconds, for the
functions that hold the applied forces of a time-varying model) and its outputs as expressions in
the model's intermediate symbols; the C printer and the CasADi translator both start from here, so
the two targets compute the same thing.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import sympy as sp

from symbolic.derivation.derivatives import InverseDynamicsDerivatives, inverse_dynamics_derivatives
from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.products import Product
from symbolic.derivation.regressor import Regressor
from symbolic.derivation.subexpressions import Subexpressions
from symbolic.codegen.program import LARGE_PROGRAM, BatchedTrig, Program, batch_trig, build_program, program_size

log = logging.getLogger(__name__)


def model_regressor(model: DynamicModel) -> Regressor:
    """The parameter regressor of ``model`` (:meth:`DynamicModel.regressor`, derived once)."""
    return model.regressor()


@dataclass(frozen=True)
class FunctionSpec:
    name: str
    inputs: tuple[str, ...]
    output: str
    rows: int
    cols: int
    expressions: tuple[sp.Expr, ...]  # row-major; the outputs of ``arrays`` one after the other
    doc: str
    sub: Subexpressions | None = None  # the intermediates the expressions use (default: the model's)
    more_outputs: tuple[tuple[str, int, int], ...] = ()  # further output arrays (name, rows, cols), after ``output``

    @property
    def arrays(self) -> tuple[tuple[str, int, int], ...]:
        """Every output array as (name, rows, cols), in argument order: ``output`` first."""
        return ((self.output, self.rows, self.cols), *self.more_outputs)


def input_symbols(model: DynamicModel) -> dict[str, tuple[sp.Symbol, ...]]:
    """Symbols of each input array, in slot order (``t``, the time, only for a time-varying model)."""
    n = model.n
    time = {"t": (model.time,)} if model.time_varying else {}
    return {
        "q": model.coordinates,
        "qd": model.velocities,
        "qdd": model.accelerations,
        "tau": tuple(sp.Symbol(f"_tau{i}", real=True) for i in range(n)),
        **time,
        "p": model.parameter_symbols,
    }


def timed(model: DynamicModel, *inputs: str) -> tuple[str, ...]:
    """``inputs`` with ``"t"`` before ``"p"`` for a time-varying model (a function that holds Q(q, qd, t))."""
    return (*inputs[:-1], "t", inputs[-1]) if model.time_varying else inputs


@dataclass(frozen=True)
class SolvedSpec:
    """An exported function computed from other exported functions by a small dense solve (no expressions).

    The C template and the CasADi translator each implement these by name with the same arithmetic
    (Cholesky factor of D(q), triangular solves); this entry gives both the name, inputs, output and doc.
    ``status`` is the C return value's meaning (CasADi returns only the output).
    """

    name: str
    inputs: tuple[str, ...]
    output: str
    rows: int
    cols: int
    doc: str
    status: str
    more_outputs: tuple[tuple[str, int, int], ...] = ()  # further output arrays (name, rows, cols), after ``output``

    @property
    def arrays(self) -> tuple[tuple[str, int, int], ...]:
        """Every output array as (name, rows, cols), in argument order: ``output`` first."""
        return ((self.output, self.rows, self.cols), *self.more_outputs)


SOLVED_INPUT_SIZES = {"u": 3}
"""Inputs of solved functions that are not one of :func:`input_symbols`' arrays, with their lengths."""


def solved_specs(model: DynamicModel) -> list[SolvedSpec]:
    """forward_dynamics, its derivatives (docs/contracts.md, "Derivatives of the dynamics", (2)), the state-space A and
    B; and at a declared end effector its operational (apparent) inertia and mass (Janot (18)).

    See :mod:`symbolic.numeric.operational` for the definitions and docs/contracts.md for the C signatures.
    """
    n = model.n
    state = timed(model, "q", "qd", "tau", "p")
    singular = "0 on success, 1 when D(q) is not positive definite ({} then left unspecified)"
    specs = [SolvedSpec("forward_dynamics", state, "qdd", n, 1,
                        "Forward dynamics qdd = D(q)^-1 (tau - coriolis - gravity - stiffness - friction + applied), by Cholesky.",
                        singular.format("qdd is")),
             SolvedSpec("forward_dynamics_derivatives", state, "dqdd_dq", n, n,
                        "Derivatives of forward dynamics, each N*N row-major (dqdd_dq[i*N + j] = d qdd_i / d q_j): "
                        "dqdd_dq = -D^-1 dtau_dq, dqdd_dqd = -D^-1 dtau_dqd, dqdd_dtau = D^-1, the inverse dynamics "
                        "derivatives taken at the qdd of forward dynamics (one Cholesky factor of D(q))",
                        singular.format("the outputs are"), (("dqdd_dqd", n, n), ("dqdd_dtau", n, n))),
             SolvedSpec("A", state, "A", 2 * n, 2 * n,
                        "State matrix A = d xdot / d x of xdot = (qd, qdd), x = (q, qd): 2N*2N row-major, "
                        "[[0, I], [dqdd_dq, dqdd_dqd]] (Madill 3.9.4)", singular.format("A is")),
             SolvedSpec("B", state, "B", 2 * n, n,
                        "Input matrix B = d xdot / d tau: 2N*N row-major, [[0], [D^-1]] (Madill 3.9.4)", singular.format("B is"))]
    if model.robot.end_effector is not None:
        specs += [
            SolvedSpec("operational_inertia", ("q", "p"), "Lambda", 3, 3,
                       "Operational-space (apparent) inertia Lambda = (J D^-1 J^T)^-1 at the end effector, 3*3 row-major, "
                       "kg (linear part; Janot's M_op = J^-T D J^-1 for a square J)",
                       "0 on success, 1 when D(q) is not positive definite, 2 when J D^-1 J^T is singular (a Cholesky "
                       "pivot not above 1e-12 times its trace: J of rank below 3); Lambda is then left unspecified"),
            SolvedSpec("apparent_mass", ("q", "u", "p"), "m", 1, 1,
                       "Apparent mass m = u.u / (u^T J D^-1 J^T u) felt pushing the end effector along u[3] (any length; "
                       "base frame), the point free in the other directions, kg",
                       "0 on success, 1 when D(q) is not positive definite (m unspecified), 2 when u is zero (m "
                       "unspecified), 3 when the point cannot move along u (m = INFINITY)"),
        ]
    return specs


def function_specs(model: DynamicModel) -> list[FunctionSpec]:
    """inertia, coriolis, coriolis_matrix, gravity, stiffness, friction, applied, inverse_dynamics,
    inverse_dynamics_derivatives, and end_effector_jacobian (models with an end effector) and the regressor.

    Every output is a part of the one composition in :func:`symbolic.derivation.derive`; nothing is
    assembled here.
    """
    r = model.reduced
    n = model.n
    return [
        FunctionSpec("inertia", ("q", "p"), "D", n, n, tuple(r.D), "D(q), N*N row-major, symmetric positive definite (rotor inertias included)"),
        FunctionSpec("coriolis", ("q", "qd", "p"), "h", n, 1, tuple(r.coriolis_ne), "(I (x) qd^T) C(q) qd: centripetal and Coriolis terms (Madill 3.82)"),
        FunctionSpec("coriolis_matrix", ("q", "qd", "p"), "C", n, n, tuple(r.coriolis_matrix),
                     "C(q, qd), N*N row-major, C[k][j] = sum_i c_ijk qd_i: C qd = coriolis and dD/dt - 2C skew-symmetric"),
        FunctionSpec("gravity", ("q", "p"), "g", n, 1, tuple(r.gravity), "g(q) = dV_gravity/dq"),
        FunctionSpec("stiffness", ("q", "p"), "k", n, 1, tuple(r.stiffness), "k(q) = dV_strain/dq (zero for rigid models)"),
        FunctionSpec("friction", ("q", "qd", "p"), "f", n, 1, tuple(r.friction),
                     "f(q, qd): friction of the [[friction]] entries, opposing motion (zero without them)"),
        FunctionSpec("applied", timed(model, "q", "qd", "p"), "Q", n, 1, tuple(r.applied),
                     "Q(q, qd): generalized forces of the [[force]] entries, exerted on the system (zero without them)"),
        FunctionSpec("inverse_dynamics", timed(model, "q", "qd", "qdd", "p"), "tau", n, 1, tuple(r.tau),
                     "tau = D(q) qdd + coriolis + gravity + stiffness + friction - applied (recursive Newton-Euler)"),
        _derivative_spec(model),
    ] + _jacobian_specs(model) + _regressor_specs(model)


def _derivative_spec(model: DynamicModel) -> FunctionSpec:
    """inverse_dynamics_derivatives: ∂τ/∂q and ∂τ/∂q̇ in the intermediates of τ (:mod:`symbolic.derivation.derivatives`)."""
    n = model.n
    derivatives = model.products.get(DERIVATIVES)
    return FunctionSpec("inverse_dynamics_derivatives", timed(model, "q", "qd", "qdd", "p"), "dtau_dq", n, n,
                        derivatives.dq + derivatives.dqd,
                        "Derivatives of inverse dynamics, each N*N row-major: dtau_dq[i*N + j] = d tau_i / d q_j, "
                        "dtau_dqd[i*N + j] = d tau_i / d qd_j (d tau / d q by the chain rule through the intermediates of "
                        "tau; d tau / d qd = 2 C(q, qd) + d(friction - applied) / d qd; d tau / d qdd = D(q))", derivatives.sub, (("dtau_dqd", n, n),))


def _jacobian_specs(model: DynamicModel) -> list[FunctionSpec]:
    if model.robot.end_effector is None:
        return []
    n = model.n
    return [FunctionSpec("end_effector_jacobian", ("q", "p"), "J", 3, n, tuple(model.end_effector_jacobian()),
                         "J(q) of the end-effector point (Madill (3.57)), 3*N row-major, base frame: "
                         "its velocity is J qd and a force F on it is tau = J^T F")]


def _regressor_specs(model: DynamicModel) -> list[FunctionSpec]:
    reg = model_regressor(model)
    n, t = model.n, len(reg.theta)
    kinds = "per-frame inertial parameters, beams" if model.robot.beams else "per-frame inertial parameters"
    return [
        FunctionSpec("regressor", timed(model, "q", "qd", "qdd", "p"), "Y", n, t, tuple(reg.Y),
                     "Y(q, qd, qdd), N*NTHETA row-major: tau = Y theta (standard parameters, see NAME_theta_names)", reg.sub),
        FunctionSpec("standard_parameters", ("p",), "theta", t, 1, tuple(reg.theta_expressions),
                     f"theta(p): the standard parameters (Khalil's {kinds}, rotor inertias, friction, forces)"),
    ]


def _build_programs(model: DynamicModel) -> dict[str, Program]:
    """Every function's program; all of a model's take the large-program path when its largest one is large
    (:data:`~symbolic.codegen.program.LARGE_PROGRAM`): one rule per model, and the smaller programs of a large
    model (hundreds of definitions each) are not left to the slower elimination."""
    specs = function_specs(model)
    large = max(program_size(spec.sub or model.sub, spec.expressions) for spec in specs) > LARGE_PROGRAM
    if large:
        log.info("%s: large programs (over %d definitions): repeated subtrees shared only", model.name, LARGE_PROGRAM)
    built = {}
    for spec in specs:
        start = time.perf_counter()
        built[spec.name] = build_program(spec.sub or model.sub, spec.expressions, large=large)
        elapsed = time.perf_counter() - start
        log.log(logging.INFO if elapsed > 0.1 else logging.DEBUG, "%s: %s program (CSE): %d statements in %.1f s",
                model.name, spec.name, len(built[spec.name].statements), elapsed)
    return built


def _build_batched(model: DynamicModel) -> dict[str, BatchedTrig]:
    inputs = input_symbols(model)
    order = [s for group in inputs.values() for s in group]
    return {name: batch_trig(p, set(order), order=order) for name, p in programs(model).items()}


DERIVATIVES: Product[InverseDynamicsDerivatives] = Product("inverse dynamics derivatives", inverse_dynamics_derivatives,
                                                            persist=True)
PROGRAMS: Product[dict[str, Program]] = Product("programs", _build_programs, persist=True)
BATCHED_PROGRAMS: Product[dict[str, BatchedTrig]] = Product("batched programs", _build_batched, persist=True)


def programs(model: DynamicModel) -> dict[str, Program]:
    """Straight-line programs of every function spec, built once per model (CSE is the slow part; kept on disk)."""
    return model.products.get(PROGRAMS)


def batched_programs(model: DynamicModel) -> dict[str, BatchedTrig]:
    """:func:`programs` with the sines and cosines of each function's angles batched (what the C computes).

    Coordinate angles come first in slot order, so that angles q[1], ..., q[6] form one run.
    """
    return model.products.get(BATCHED_PROGRAMS)

"""The derived dynamic model: D(Q), Christoffel C, g, τ and the state-space form (Madill 3.9).

:func:`derive` runs the derivation once, in intermediate symbols (see
:mod:`symbolic.derivation.subexpressions`), and returns a :class:`DynamicModel`. The contract attributes of
docs/contracts.md (``.D``, ``.christoffel``, ``.coriolis_vector``, ``.gravity``, ``.stiffness``) are the fully
expanded SymPy forms in coordinate and parameter symbols, computed on first access; the compact
forms used for code generation stay in :attr:`DynamicModel.reduced`.

Equations of motion (Madill (3.82) with elastic forces, friction and applied forces):

    D(Q)Q̈ + (I_N⊗Q̇ᵀ)C(Q)Q̇ + g(Q) + k(Q) + f(Q̇) − Q(Q, Q̇) = τ − J(Q)ᵀF_ext,

composed once here (rotor inertia of the drives inside D); the numeric, CasADi and C layers read
:attr:`ReducedForms.tau`, :attr:`ReducedForms.bias` and the parts, never assemble their own.

A ``[[force]]`` may depend on time ``t`` (a mains disturbance): then Q, τ and the bias hold the symbol
:attr:`DynamicModel.time` and :attr:`DynamicModel.time_varying` is true; every numerical layer then
takes the time as an extra input (docs/contracts.md).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, fields
from functools import cached_property

import sympy as sp

from symbolic import cache
from symbolic.derivation import christoffel as ch
from symbolic.derivation.forces import applied_vector
from symbolic.derivation.friction import friction_vector
from symbolic.derivation.kinematics import Kinematics
from symbolic.derivation.products import Product, Products, sympy_reducer
from symbolic.derivation.regressor import Regressor, regressor
from symbolic.derivation.rigid_stage import RigidForms, Steps, rigid_stage
from symbolic.description.validation import validate
from symbolic.description.parameters import ParameterVector
from symbolic.description.robot import TIME, Robot, digest, acceleration_symbol, coordinate_symbol, velocity_symbol
from symbolic.derivation.subexpressions import Subexpressions
from symbolic.derivation.validity import check_values

log = logging.getLogger(__name__)


@dataclass
class ReducedForms(RigidForms):
    """Derived quantities as short expressions in the intermediates of :attr:`DynamicModel.sub` (the rigid
    forms, :class:`~symbolic.derivation.rigid_stage.RigidForms`, then τ, friction, applied forces and the bias).

    Attributes
    ----------
    D
        Inertia matrix D(Q), N×N.
    dD
        [∂D/∂Q_1, …, ∂D/∂Q_N].
    christoffel
        Symmetric Christoffel matrix, N²×N (block k holds c_ijk).
    coriolis
        (I_N⊗Q̇ᵀ)CQ̇ from the Christoffel symbols (3.82).
    coriolis_matrix
        C(Q,Q̇) with C(Q,Q̇)Q̇ = coriolis and Ḋ − 2C(Q,Q̇) skew-symmetric.
    gravity
        g(Q) = ∂V_g/∂Qᵀ (Newton–Euler with Q̇ = Q̈ = 0).
    potential
        V_g(Q).
    tau
        τ = DQ̈ + (I⊗Q̇ᵀ)CQ̇ + g + k + f − Q: what the actuators supply (Newton–Euler for rigid
        models, plus the rotors' inertia, friction and applied forces).
    coriolis_ne
        (I⊗Q̇ᵀ)CQ̇ by Newton–Euler (Q̈ = 0, no gravity): the same vector as ``coriolis``, cheaper.
    stiffness, strain
        k = ∂V_strain/∂Qᵀ and V_strain (Madill (3.80)); zero for rigid models.
    friction
        f(Q̇) of the [[friction]] entries (Janot (15)–(17)), opposing motion.
    applied
        Q(Q, Q̇) of the [[force]] entries, exerted on the system.
    bias
        τ at Q̈ = 0: (I⊗Q̇ᵀ)CQ̇ + g + k + f − Q, so that D Q̈ = τ − bias (forward dynamics).
    """

    tau: sp.Matrix
    friction: sp.Matrix
    applied: sp.Matrix
    bias: sp.Matrix


@dataclass(eq=False)  # identity semantics: what is built from a model is kept per model object
class DynamicModel:
    """A robot's derived dynamics. Build with :func:`derive`.

    What the layers build from it (regressor, base parameters, programs, numeric model, ...) is kept in
    :attr:`products` (:mod:`symbolic.derivation.products`).
    """

    robot: Robot
    sub: Subexpressions
    kinematics: Kinematics
    reduced: ReducedForms
    timings: dict[str, float] = field(default_factory=dict)

    def __getstate__(self) -> dict:
        """The derivation only: the expanded forms (cached properties) and the products are not kept."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    @cached_property
    def products(self) -> Products:
        """What has been built from this model, each built once (:mod:`symbolic.derivation.products`)."""
        return Products(self)

    def regressor(self) -> Regressor:
        """The parameter regressor τ = Y·θ (:mod:`symbolic.derivation.regressor`, beams included), derived once."""
        return self.products.get(REGRESSOR)

    @property
    def parameter_vector(self) -> ParameterVector:
        """The nominal parameter values (names ↔ symbols ↔ array, :mod:`symbolic.description.parameters`)."""
        return self.robot.parameter_vector

    # -- symbols -------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.robot.name

    @property
    def coordinates(self) -> tuple[sp.Symbol, ...]:
        """Generalized coordinates Q (N)."""
        return tuple(coordinate_symbol(c) for c in self.robot.generalized_coordinates)

    @property
    def velocities(self) -> tuple[sp.Symbol, ...]:
        return tuple(velocity_symbol(c) for c in self.robot.generalized_coordinates)

    @property
    def accelerations(self) -> tuple[sp.Symbol, ...]:
        return tuple(acceleration_symbol(c) for c in self.robot.generalized_coordinates)

    @property
    def time(self) -> sp.Symbol:
        """The time symbol ``t`` (s) that the [[force]] expressions of a time-varying model hold."""
        return TIME

    @property
    def time_varying(self) -> bool:
        """Whether Q(Q, Q̇, t), hence τ and the bias, depend on time (a [[force]] expression holds ``t``)."""
        return self.robot.time_varying

    @property
    def parameters(self) -> dict[sp.Symbol, float]:
        """Parameter symbols with their nominal values, in model-file order."""
        return self.robot.parameter_values

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        return self.robot.parameter_symbols

    @property
    def n(self) -> int:
        return len(self.robot.generalized_coordinates)

    # -- expanded contract attributes ------------------------------------------------------
    def expand(self, expr: sp.Expr | sp.Matrix) -> sp.Expr | sp.Matrix:
        """Replace intermediates by their definitions: a SymPy object in Q, Q̇, Q̈ and parameters."""
        if isinstance(expr, sp.MatrixBase):
            return expr.applyfunc(self.sub.expand)
        return self.sub.expand(expr)

    @cached_property
    def D(self) -> sp.Matrix:
        """D(Q), N×N, symmetric."""
        return self.expand(self.reduced.D)

    @cached_property
    def christoffel(self) -> sp.Matrix:
        """N²×N: blocks C_1 … C_N of Christoffel symbols c_ijk (Madill (3.81), symmetric form)."""
        return self.expand(self.reduced.christoffel)

    @cached_property
    def coriolis_vector(self) -> sp.Matrix:
        """(I_N⊗Q̇ᵀ)C(Q)Q̇ of (3.82)."""
        return self.expand(self.reduced.coriolis)

    @cached_property
    def coriolis_matrix(self) -> sp.Matrix:
        """C(Q,Q̇) with C(Q,Q̇)Q̇ = coriolis_vector and Ḋ − 2C(Q,Q̇) skew-symmetric."""
        return self.expand(self.reduced.coriolis_matrix)

    @cached_property
    def gravity(self) -> sp.Matrix:
        """g(Q) = ∂V_g/∂Qᵀ."""
        return self.expand(self.reduced.gravity)

    @cached_property
    def potential_energy(self) -> sp.Expr:
        """V_g(Q)."""
        return self.expand(self.reduced.potential)

    @cached_property
    def stiffness(self) -> sp.Matrix:
        """∂V_strain/∂Qᵀ (Madill (3.80)): zero for rigid models."""
        return self.expand(self.reduced.stiffness)

    @cached_property
    def strain_energy(self) -> sp.Expr:
        """V_strain(Q) (Madill (3.80))."""
        return self.expand(self.reduced.strain)

    @cached_property
    def friction(self) -> sp.Matrix:
        """f(Q, Q̇): friction of the [[friction]] entries (Janot (15)–(17)), zero without them."""
        return self.expand(self.reduced.friction)

    @cached_property
    def applied(self) -> sp.Matrix:
        """Q(Q, Q̇, t): generalized forces of the [[force]] entries, exerted on the system."""
        return self.expand(self.reduced.applied)

    @cached_property
    def inverse_dynamics(self) -> sp.Matrix:
        """τ = D Q̈ + (I⊗Q̇ᵀ)CQ̇ + g + k + f − Q."""
        return self.expand(self.reduced.tau)

    def christoffel_symbol(self, i: int, j: int, k: int) -> sp.Expr:
        """c_ijk = ½(∂d_kj/∂Q_i + ∂d_ki/∂Q_j − ∂d_ij/∂Q_k), the (i, j) entry of block C_k (0-based)."""
        return self.christoffel[k * self.n + i, j]

    def christoffel_literal(self) -> sp.Matrix:
        """C = Z·∂D/∂Qᵀ exactly as printed in Madill (3.81), expanded (blocks not symmetric)."""
        return self.expand(ch.christoffel_literal(self.reduced.dD))

    def end_effector_jacobian(self) -> sp.Matrix:
        """J(Q) (3.57) of the end-effector point over all of Q (3×N; zero columns for modal
        coordinates: the point is fixed in a frame), in intermediates."""
        rigid = self.kinematics.end_effector_jacobian()
        return sp.Matrix.hstack(rigid, sp.zeros(3, self.n - rigid.shape[1]))

    def jacobian(self) -> sp.Matrix:
        """End-effector Jacobian J(Q) (3.57), expanded."""
        return self.expand(self.end_effector_jacobian())

    def operation_counts(self) -> dict[str, int]:
        """Operations of the straight-line programs for each output (``count_ops`` of definitions)."""
        r = self.reduced
        return {
            "D": self.sub.count_ops(list(r.D.upper_triangular())),
            "christoffel": self.sub.count_ops(list(r.christoffel)),
            "coriolis": self.sub.count_ops(list(r.coriolis)),
            "coriolis_matrix": self.sub.count_ops(list(r.coriolis_matrix)),
            "gravity": self.sub.count_ops(list(r.gravity)),
            "tau": self.sub.count_ops(list(r.tau)),
            "friction": self.sub.count_ops(list(r.friction)),
            "applied": self.sub.count_ops(list(r.applied)),
        }

    def summary(self) -> str:
        """A short human-readable description of the derived model."""
        ops = self.operation_counts()
        lines = [
            f"model {self.name}: {self.robot.description}".rstrip(": "),
            f"  coordinates ({self.n}): {', '.join(self.robot.generalized_coordinates)}",
            f"  parameters ({len(self.robot.parameters)}): {', '.join(p.name for p in self.robot.parameters)}",
            f"  frames {len(self.robot.frames)}, bodies {len(self.robot.bodies)}, constraints {len(self.robot.constraints)}",
            f"  intermediates {len(self.sub)}; derivation {sum(self.timings.values()):.2f} s",
            "  operations: " + ", ".join(f"{k} {v}" for k, v in ops.items()),
        ]
        limits = [(f.theta if f.joint.type != "prismatic" else f.d, f.joint.limits) for f in self.robot.frames
                  if f.joint is not None and f.joint.limits]
        if limits:  # a URDF's <limit>: kept with the model, reported here (the equations do not use them)
            lines.append("  joint limits: " + "; ".join(f"{c} " + " ".join(f"{k} {v:g}" for k, v in lim.items()) for c, lim in limits))
        return "\n".join(lines)


def derive(robot: Robot) -> DynamicModel:
    """Derive D(Q), the Christoffel matrix, Coriolis terms, g, elastic forces and τ for ``robot``.

    Rigid bodies enter through the composite-rigid-body form of D and a Newton–Euler pass; flexible
    beams (Madill 3.4–3.8) add their D_f (3.76), gravitational (3.79) and strain (3.80) energies, and
    a model with beams takes τ = DQ̈ + (I⊗Q̇ᵀ)CQ̇ + g + k from the Lagrangian quantities (hierarchical
    equations (3.83)). Progress is logged at INFO level (``logging.getLogger("symbolic")``).

    A derivation is a function of the robot description only: it is kept in the cache folder under the
    description's digest (:mod:`symbolic.cache`) and read from there by the next process that derives
    the same description.
    """
    robot = validate(robot)
    key = digest(robot)
    start = time.perf_counter()
    found = cache.load("derivation", key, {"robot": robot}.__getitem__)
    if found is not None and isinstance(found[0], DynamicModel):
        log.info("%s: derivation read from the cache in %.2f s", robot.name, time.perf_counter() - start)
        return found[0]
    model = _derive(robot)
    cache.save("derivation", key, model, lambda obj: "robot" if obj is robot else None, sympy_reducer)
    return model


REGRESSOR: Product[Regressor] = Product("regressor", lambda model: regressor(model.robot), persist=True)
"""The parameter regressor of a model (:meth:`DynamicModel.regressor`)."""


def _derive(robot: Robot) -> DynamicModel:
    """:func:`derive` of a validated robot, computed: the rigid stage (:mod:`symbolic.derivation.rigid_stage`,
    reused when an earlier derivation had the same skeleton), then friction and applied forces."""
    log.info("%s: deriving (%d coordinates, %d bodies)", robot.name, len(robot.generalized_coordinates), len(robot.bodies))
    started = time.perf_counter()
    step = Steps(robot.name)
    stage = rigid_stage(robot, step)
    sub = stage.sub
    friction = step("friction", lambda: friction_vector(robot).applyfunc(sub.add))
    applied = step("applied forces", lambda: applied_vector(robot).applyfunc(sub.add))
    # The one composition of the equations of motion (docs/architecture.md, "Equations of motion").
    tau = (stage.tau_body + friction - applied).applyfunc(sub.add)
    bias = (stage.coriolis_ne + stage.gravity + stage.stiffness + friction - applied).applyfunc(sub.add)
    rigid = {f.name: getattr(stage, f.name) for f in fields(RigidForms)}
    reduced = ReducedForms(**rigid, tau=tau, friction=friction, applied=applied, bias=bias)
    model = DynamicModel(robot, sub, stage.kin, reduced, step.timings)
    step("value check", lambda: check_values(model))
    log.info("%s: derived in %.1f s (%d intermediates)", robot.name, time.perf_counter() - started, len(sub))
    return model

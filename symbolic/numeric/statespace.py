"""State-space form (Madill (3.114)) and its linearisation (Madill 3.9.4), evaluated numerically.

X = [Qᵀ Q̇ᵀ]ᵀ, U = [τᵀ F_extᵀ]ᵀ (F_ext only when the model declares an end effector):

    Ẋ = [ X₂ ; D(X₁)⁻¹( [I −Jᵀ] U − (I⊗X₂ᵀ)C X₂ − g − k − f + Q ) ].

The linearisation A = ∂F/∂X, B = ∂F/∂U is computed from exact symbolic derivatives
(∂D/∂Q, ∂P/∂Q, ∂P/∂Q̇ with P = (I⊗Q̇ᵀ)CQ̇ + g + k + f − Q, ∂(JᵀF)/∂Q), not by finite differences:

    ∂Q̈/∂Q_k = −D⁻¹( ∂D/∂Q_k Q̈ + ∂P/∂Q_k + ∂(JᵀF)/∂Q_k ),   ∂Q̈/∂Q̇ = −D⁻¹ ∂P/∂Q̇,   B = [0; D⁻¹[I −Jᵀ]].
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.products import Product
from symbolic.codegen.functions import compile_function

def numeric_model(model: DynamicModel) -> NumericModel:
    """The :class:`NumericModel` of ``model``, built once per model object (its compiled functions are kept)."""
    return model.products.get(NUMERIC_MODEL)


class NumericModel:
    """Numerical functions of a :class:`~symbolic.derivation.dynamics.DynamicModel`.

    All functions take the parameter vector ``p`` last, in ``model.robot.parameters`` order;
    :attr:`p0` holds the nominal values. Those that hold the applied forces (``applied``, ``bias``,
    ``inverse_dynamics``, ``forward_dynamics``, ``state_derivative``, ``linearize``) take the time
    ``t`` (s) as a keyword; it matters only for a time-varying model (:attr:`time_varying`).
    """

    def __init__(self, model: DynamicModel) -> None:
        self.model = model
        self.sub = model.sub
        self.q = list(model.coordinates)
        self.qd = list(model.velocities)
        self.qdd = list(model.accelerations)
        self.p = list(model.parameter_symbols)
        self.parameters = model.parameter_vector
        self.p0 = self.parameters.array()
        self.n = model.n
        self.has_force = model.robot.end_effector is not None
        self.force = sp.symbols("_F0:3", real=True)
        self.time_varying = model.time_varying
        self._time = [[model.time]] if self.time_varying else []
        """The time argument group of functions holding Q: [[t]] for a time-varying model, else none."""

    def _at(self, t: float) -> list[list[float]]:
        """The time argument (``[[t]]``) of functions holding Q, or nothing for a model without time."""
        return [[t]] if self.time_varying else []

    def _fn(self, args, outputs, shape=None):
        return compile_function(self.sub, args, outputs, shape)

    @cached_property
    def _inertia(self):
        return self._fn([self.q, self.p], self.model.reduced.D, (self.n, self.n))

    @cached_property
    def _coriolis(self):
        return self._fn([self.q, self.qd, self.p], self.model.reduced.coriolis)

    @cached_property
    def _coriolis_matrix(self):
        return self._fn([self.q, self.qd, self.p], self.model.reduced.coriolis_matrix, (self.n, self.n))

    @cached_property
    def _gravity(self):
        return self._fn([self.q, self.p], self.model.reduced.gravity)

    @cached_property
    def _potential(self):
        return self._fn([self.q, self.p], [self.model.reduced.potential])

    @cached_property
    def _stiffness(self):
        return self._fn([self.q, self.p], self.model.reduced.stiffness)

    def stiffness(self, q, p=None) -> np.ndarray:
        return self._stiffness(q, self.params(p))

    @cached_property
    def _strain(self):
        return self._fn([self.q, self.p], [self.model.reduced.strain])

    def strain_energy(self, q, p=None) -> float:
        return float(self._strain(q, self.params(p))[0])

    @cached_property
    def _tau(self):
        return self._fn([self.q, self.qd, self.qdd, *self._time, self.p], self.model.reduced.tau)

    @cached_property
    def _bias(self):
        return self._fn([self.q, self.qd, *self._time, self.p], self.model.reduced.bias)

    @cached_property
    def _friction(self):
        return self._fn([self.q, self.qd, self.p], self.model.reduced.friction)

    @cached_property
    def _applied(self):
        return self._fn([self.q, self.qd, *self._time, self.p], self.model.reduced.applied)

    def friction(self, q, qd, p=None) -> np.ndarray:
        """f(Q, Q̇) of the [[friction]] entries."""
        return self._friction(q, qd, self.params(p))

    def applied(self, q, qd, p=None, *, t: float = 0.0) -> np.ndarray:
        """Q(Q, Q̇, t) of the [[force]] entries."""
        return self._applied(q, qd, *self._at(t), self.params(p))

    def bias(self, q, qd, p=None, *, t: float = 0.0) -> np.ndarray:
        """τ at Q̈ = 0: (I⊗Q̇ᵀ)CQ̇ + g + k + f − Q."""
        return self._bias(q, qd, *self._at(t), self.params(p))

    @cached_property
    def _dD(self):
        return self._fn([self.q, self.p], sp.Matrix.vstack(*self.model.reduced.dD))

    @cached_property
    def _jacobian(self):
        return self._fn([self.q, self.p], self.model.end_effector_jacobian(), (3, self.n))

    @cached_property
    def _end_effector_position(self):
        ee = self.model.robot.end_effector
        return self._fn([self.q, self.p], self.model.kinematics.point_position(ee.frame, sp.Matrix(ee.point)), (3,))

    def params(self, p=None) -> np.ndarray:
        """``p`` as an array of all the parameters (checked), or :attr:`p0` for ``None``."""
        return self.p0 if p is None else self.parameters.coerce(p)

    def inertia(self, q, p=None) -> np.ndarray:
        return self._inertia(q, self.params(p))

    def coriolis(self, q, qd, p=None) -> np.ndarray:
        return self._coriolis(q, qd, self.params(p))

    def coriolis_matrix(self, q, qd, p=None) -> np.ndarray:
        return self._coriolis_matrix(q, qd, self.params(p))

    def gravity(self, q, p=None) -> np.ndarray:
        return self._gravity(q, self.params(p))

    def potential(self, q, p=None) -> float:
        return float(self._potential(q, self.params(p))[0])

    def inverse_dynamics(self, q, qd, qdd, p=None, *, t: float = 0.0) -> np.ndarray:
        return self._tau(q, qd, qdd, *self._at(t), self.params(p))

    def inertia_derivatives(self, q, p=None) -> np.ndarray:
        """∂D/∂Q_k stacked: shape (N, N, N), index [k, i, j]."""
        return self._dD(q, self.params(p)).reshape(self.n, self.n, self.n)

    def inertia_rate(self, q, qd, p=None) -> np.ndarray:
        return np.einsum("kij,k->ij", self.inertia_derivatives(q, p), np.asarray(qd, float))

    def jacobian(self, q, p=None) -> np.ndarray:
        return self._jacobian(q, self.params(p))

    def end_effector_position(self, q, p=None) -> np.ndarray:
        """p₀ = R p + d (3.43) of the end-effector point, base frame."""
        return self._end_effector_position(q, self.params(p))

    def forward_dynamics(self, q, qd, tau, p=None, force=None, *, t: float = 0.0) -> np.ndarray:
        """Q̈ = D⁻¹(τ − JᵀF − (I⊗Q̇ᵀ)CQ̇ − g − k − f + Q) (3.114), by Cholesky; raises if D is not positive definite."""
        rhs = np.asarray(tau, float) - self.bias(q, qd, p, t=t)
        if force is not None:
            rhs = rhs - self.jacobian(q, p).T @ np.asarray(force, float)
        factor = np.linalg.cholesky(self.inertia(q, p))
        return np.linalg.solve(factor.T, np.linalg.solve(factor, rhs))

    def state_derivative(self, x, u, p=None, *, t: float = 0.0) -> np.ndarray:
        """F(X, U, t) of (3.114)."""
        x = np.asarray(x, float)
        u = np.asarray(u, float)
        q, qd = x[: self.n], x[self.n :]
        force = u[self.n :] if self.has_force and u.size > self.n else None
        return np.concatenate([qd, self.forward_dynamics(q, qd, u[: self.n], p, force, t=t)])

    # -- linearisation ---------------------------------------------------------------------
    @cached_property
    def _linear_terms(self):
        """∂P/∂Q (N×N), ∂P/∂Q̇ (N×N), ∂(JᵀF)/∂Q (N×N) as compiled functions; P = bias = τ at Q̈ = 0."""
        m = self.model
        sub = self.sub
        P = m.reduced.bias
        dP_dq = sp.Matrix(self.n, self.n, lambda i, k: sub.add(sub.diff(P[i], self.q[k])))
        dP_dqd = sp.Matrix(self.n, self.n, lambda i, k: sub.add(sub.diff(P[i], self.qd[k])))
        funcs = {
            "dP_dq": self._fn([self.q, self.qd, *self._time, self.p], dP_dq, (self.n, self.n)),
            "dP_dqd": self._fn([self.q, self.qd, *self._time, self.p], dP_dqd, (self.n, self.n)),
        }
        if self.has_force:
            JtF = m.end_effector_jacobian().T * sp.Matrix(self.force)
            dJtF = sp.Matrix(self.n, self.n, lambda i, k: sub.add(sub.diff(JtF[i], self.q[k])))
            funcs["dJtF_dq"] = self._fn([self.q, self.force, self.p], dJtF, (self.n, self.n))
        return funcs

    def linearize(self, x0, u0, p=None, *, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """A = ∂F/∂X, B = ∂F/∂U at (X⁰, U⁰, t) (Madill 3.9.4), from exact derivatives."""
        n = self.n
        x0 = np.asarray(x0, float).ravel()
        u0 = np.asarray(u0, float).ravel()
        inputs_allowed = (n, n + 3) if self.has_force else (n,)
        if x0.size != 2 * n or u0.size not in inputs_allowed:
            raise ValueError(
                f"linearize: X⁰ = [Q; Q̇] needs {2 * n} values (got {x0.size}) and U⁰ "
                + (f"= [τ; F] {n + 3} values, or {n} for τ alone with F = 0" if self.has_force else f"= τ {n} values")
                + f" (got {u0.size})")
        q, qd = x0[:n], x0[n:]
        force = u0[n:] if self.has_force and u0.size > n else np.zeros(3)
        D = self.inertia(q, p)
        qdd = self.forward_dynamics(q, qd, u0[:n], p, force if self.has_force else None, t=t)
        terms = self._linear_terms
        dD = self.inertia_derivatives(q, p)
        dP_dq = terms["dP_dq"](q, qd, *self._at(t), self.params(p))
        lhs = np.einsum("kij,j->ik", dD, qdd) + dP_dq
        if self.has_force:
            lhs += terms["dJtF_dq"](q, force, self.params(p))
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -np.linalg.solve(D, lhs)
        A[n:, n:] = -np.linalg.solve(D, terms["dP_dqd"](q, qd, *self._at(t), self.params(p)))
        inputs = np.eye(n) if not self.has_force else np.hstack([np.eye(n), -self.jacobian(q, p).T])
        B = np.zeros((2 * n, inputs.shape[1]))
        B[n:, :] = np.linalg.solve(D, inputs)
        return A, B


def natural_frequencies(model: DynamicModel, q0=None, p=None, rigid_tolerance: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [rad/s] and mode shapes of the model linearised about a rest point.

    Generalised eigenproblem K x = ω² D(Q⁰) x with K = ∂(g + k)/∂Q at Q⁰ (Madill 3.9.4 with Q̇ = 0,
    U = 0); rigid-body modes (ω² ≤ rigid_tolerance·max ω²) are dropped. Returns (ω ascending, modes as
    columns).
    """
    from scipy.linalg import eigh

    num = numeric_model(model)
    n = model.n
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, float)
    terms = num._linear_terms
    zeros = np.zeros(n)
    K = terms["dP_dq"](q0, zeros, *num._at(0.0), num.params(p))  # at Q̇ = 0 only ∂(g + k)/∂Q remains
    K = (K + K.T) / 2
    D = num.inertia(q0, p)
    w2, vectors = eigh(K, D)
    keep = w2 > rigid_tolerance * max(w2.max(), 1e-300)
    return np.sqrt(w2[keep]), vectors[:, keep]


NUMERIC_MODEL: Product[NumericModel] = Product("numeric model", NumericModel)
"""The :class:`NumericModel` of a model (:func:`numeric_model`; compiled functions: kept in memory only)."""

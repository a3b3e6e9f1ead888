"""Identities that hold for every valid model (hypothesis): D = Dᵀ ≻ 0, Ḋ − 2C skew,
C(Q,Q̇)Q̇ = (I⊗Q̇ᵀ)CQ̇, g = ∂V/∂Q, τ(Q̈ = 0) = h + g + k + f − Q, and the linearisation A, B
against finite differences (away from the velocities where friction's sign(·) switches).

Valid parameters: each body's mass and inertia parameters scaled by its own factor in [0.2, 5]
(a positive scaling keeps every body's spatial inertia positive semidefinite).
Tolerances: exact identities 1e-9 relative; finite differences (central, step 1e-5; unit step for the
affine dependence on U) 1e-5 relative.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from conftest import derived
from symbolic.numeric import numeric_model

ROBOTS = ["fivebar", "puma560", "panda", "janot_branch", "omni", "single_flexible_link", "madill_beam", "fivebar_flexible"]
SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def scaled_parameters(model, factors) -> np.ndarray:
    p = numeric_model(model).p0.copy()
    index = {s: i for i, s in enumerate(model.parameter_symbols)}
    for body, factor in zip(model.robot.bodies, factors):
        inertial = set(body.mass.free_symbols)
        for e in body.inertia.values():
            inertial |= e.free_symbols
        for s in inertial:
            p[index[s]] *= factor
    return p


def sign_arguments(model, qd) -> np.ndarray:
    """The velocities inside sign(·) of the friction laws (q̇ of each joint with friction, at qd)."""
    arguments = sorted({a.args[0] for e in model.friction for a in e.atoms(sp.sign)}, key=sp.default_sort_key)
    values = dict(zip(model.velocities, qd))
    return np.array([float(a.xreplace(values)) for a in arguments])


def state(draw, model):
    """Angles in [−π, π], velocities in [−3, 3]; modal coordinates (beam deflections) within ±1 cm-scale
    amplitudes, so that elastic forces stay in the range where finite differences are meaningful."""
    n = model.n
    modal = ["_nu" in c or "_eta" in c for c in model.robot.generalized_coordinates]
    q = np.array([draw(st.floats(-0.01, 0.01) if m else st.floats(-np.pi, np.pi)) for m in modal])
    qd = np.array([draw(st.floats(-0.1, 0.1) if m else st.floats(-3, 3)) for m in modal])
    factors = draw(st.lists(st.floats(0.2, 5), min_size=len(model.robot.bodies), max_size=len(model.robot.bodies)))
    return q, qd, scaled_parameters(model, factors)


@pytest.mark.parametrize("name", ROBOTS)
@SETTINGS
@given(data=st.data())
def test_inertia_symmetric_positive_definite(name, data) -> None:
    model = derived(name)
    q, _, p = state(data.draw, model)
    D = numeric_model(model).inertia(q, p)
    assert np.array_equal(D, D.T)
    assert np.linalg.eigvalsh(D).min() > 0


@pytest.mark.parametrize("name", ROBOTS)
@SETTINGS
@given(data=st.data())
def test_passivity_and_coriolis_identities(name, data) -> None:
    model = derived(name)
    num = numeric_model(model)
    q, qd, p = state(data.draw, model)
    C = num.coriolis_matrix(q, qd, p)
    Ddot = num.inertia_rate(q, qd, p)
    N = Ddot - 2 * C
    # relative to the size of the terms, not of N (which vanishes at some states)
    assert np.linalg.norm(N + N.T) <= 1e-9 * max(np.linalg.norm(Ddot) + 2 * np.linalg.norm(C), 1e-12)
    h = num.coriolis(q, qd, p)
    assert np.linalg.norm(C @ qd - h) <= 1e-9 * max(np.linalg.norm(h), 1e-12)
    # inverse dynamics with zero acceleration = Christoffel form + gravity + elastic forces
    # (relative to the weight moment of the whole robot at 1 m where everything cancels, as at rest in
    # the balanced five-bar: Newton-Euler and first moments then leave different rounding residues)
    tau = num.inverse_dynamics(q, qd, np.zeros(model.n), p)
    g, k = num.gravity(q, p), num.stiffness(q, p)
    f, Q = num.friction(q, qd, p), num.applied(q, qd, p)
    values = dict(zip(model.parameter_symbols, p))
    weight = float(sp.Matrix(model.robot.gravity).xreplace(values).norm()) * sum(abs(float(b.mass.xreplace(values))) for b in model.robot.bodies)
    parts = np.linalg.norm(h) + np.linalg.norm(g) + np.linalg.norm(k) + np.linalg.norm(f) + np.linalg.norm(Q)
    scale = max(np.linalg.norm(tau), parts, weight * 1.0)
    assert np.linalg.norm(tau - h - g - k - f + Q) <= 1e-9 * scale


@pytest.mark.parametrize("name", ROBOTS)
def test_gravity_is_gradient_of_potential(name) -> None:
    """g = ∂V/∂Q: V differentiated symbolically (chain rule through intermediates), evaluated at 20 states.

    Parameters are scaled per body (factors in [0.5, 2]) so that the balanced nominal five-bar
    (g ≡ 0) does not make the comparison vacuous.
    """
    model = derived(name)
    sub = model.sub
    gradient = sp.Matrix([sub.add(sub.diff(model.reduced.potential, q)) for q in model.coordinates])
    from symbolic.codegen.functions import compile_function

    grad = compile_function(sub, [model.coordinates, model.parameter_symbols], gradient)
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, model.n)
        p = scaled_parameters(model, rng.uniform(0.5, 2, len(model.robot.bodies)))
        g = numeric_model(model).gravity(q, p)
        assert np.linalg.norm(g) > 1e-6
        assert np.linalg.norm(grad(q, p) - g) <= 1e-9 * np.linalg.norm(g)


@pytest.mark.parametrize("name", ROBOTS)
@settings(max_examples=8, deadline=None)
@given(data=st.data())
def test_linearisation_matches_finite_differences(name, data) -> None:
    model = derived(name)
    num = numeric_model(model)
    q, qd, p = state(data.draw, model)
    assume(np.all(np.abs(sign_arguments(model, qd)) > 1e-3))  # sign(q̇) is not differentiable at 0
    n_u = model.n + (3 if num.has_force else 0)
    u = np.array(data.draw(st.lists(st.floats(-2, 2), min_size=n_u, max_size=n_u)))
    x = np.r_[q, qd]
    A, B = num.linearize(x, u, p)
    step = 1e-5  # central differences; F is affine in U, so B's differences use a unit step (exact)
    A_fd = np.column_stack(
        [(num.state_derivative(x + step * e, u, p) - num.state_derivative(x - step * e, u, p)) / (2 * step) for e in np.eye(x.size)]
    )
    B_fd = np.column_stack(
        [(num.state_derivative(x, u + e, p) - num.state_derivative(x, u - e, p)) / 2 for e in np.eye(u.size)]
    )
    assert np.linalg.norm(A - A_fd) <= 1e-5 * max(np.linalg.norm(A), 1.0)
    assert np.linalg.norm(B - B_fd) <= 1e-5 * max(np.linalg.norm(B), 1.0)

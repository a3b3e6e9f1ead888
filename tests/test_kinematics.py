"""Kinematics against independent computations: DH products, Madill (3.52)/(3.53) taken literally,
finite differences, and virtual work (3.58).

The recursive body Jacobians of :mod:`symbolic.kinematics` are compared with
J^Ω = [S⁻¹(Rᵀ ∂R/∂q_i)] (3.52) and J^v = ∂d/∂q (3.53) computed by plain SymPy differentiation of the
product of DH matrices (:func:`symbolic.kinematics.dh_transform`), at 10 seeded states, 1e-12 absolute.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from conftest import derived
from symbolic.derivation.kinematics import dh_transform, unskew
from symbolic.numeric import numeric_model


def chain_transform(robot, frame: str) -> sp.Matrix:
    """H_0^frame as the plain product of DH matrices (constraints substituted)."""
    frames = {f.name: f for f in robot.frames}
    subs = robot.constraint_substitution
    H = sp.eye(4)
    name = frame
    while name != "base":
        f = frames[name]
        H = dh_transform(robot.convention, *(getattr(f, k).xreplace(subs) for k in ("theta", "d", "a", "alpha"))) * H
        name = f.parent
    return H


@pytest.mark.parametrize("name, frame", [("puma560", "6"), ("panda", "7"), ("fivebar", "e"), ("janot_branch", "4")])
def test_jacobians_are_madill_3_52_and_3_53(name: str, frame: str) -> None:
    model = derived(name)
    robot = model.robot
    q = model.coordinates
    H = chain_transform(robot, frame).xreplace(robot.parameter_values)
    R, d = H[:3, :3], H[:3, 3]
    JO_literal = sp.Matrix.hstack(*[unskew(R.T * sp.diff(R, x)) for x in q])
    Jv_literal = d.jacobian(q)
    literal = sp.lambdify([q], [JO_literal, Jv_literal, R, d])
    kin = model.kinematics
    from symbolic.codegen.functions import compile_function

    args = [q, model.parameter_symbols]
    jacobians = compile_function(model.sub, args, sp.Matrix.vstack(kin.jacobian_omega(frame), kin.jacobian_v(frame)))
    placement = compile_function(model.sub, args, sp.Matrix.hstack(kin.rotation(frame), kin.translation(frame)))
    rng = np.random.default_rng(3)
    for _ in range(10):
        x = rng.uniform(-np.pi, np.pi, len(q))
        JO, Jv, Rn, dn = (np.array(a, dtype=float) for a in literal(x))
        J = jacobians(x, numeric_model(model).p0)
        H = placement(x, numeric_model(model).p0)
        np.testing.assert_allclose(J[0:3], JO, atol=1e-12)
        np.testing.assert_allclose(J[3:6], Jv, atol=1e-12)
        np.testing.assert_allclose(H[:, :3], Rn, atol=1e-12)
        np.testing.assert_allclose(H[:, 3], dn.ravel(), atol=1e-12)


@pytest.mark.parametrize("name", ["fivebar", "puma560", "panda", "janot_branch", "omni"])
def test_end_effector_jacobian_and_virtual_work(name: str) -> None:
    """J of (3.57) by central differences of p₀ (3.43) (step 1e-6, 1e-8 absolute); τ = JᵀF (3.58)
    equals the generalized force of F by virtual work, F·dp₀ = τ·dQ."""
    model = derived(name)
    kin = model.kinematics
    ee = model.robot.end_effector
    from symbolic.codegen.functions import compile_function

    args = [model.coordinates, model.parameter_symbols]
    position = compile_function(model.sub, args, kin.point_position(ee.frame, sp.Matrix(ee.point)))
    p0 = numeric_model(model).p0
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, model.n)
        J = numeric_model(model).jacobian(q)
        h = 1e-6
        J_fd = np.column_stack([(position(q + h * e, p0) - position(q - h * e, p0)) / (2 * h) for e in np.eye(model.n)])
        np.testing.assert_allclose(J, J_fd, atol=1e-8)
        F = rng.normal(size=3)
        dq = rng.normal(size=model.n) * 1e-7
        work = F @ (position(q + dq, p0) - position(q - dq, p0)) / 2
        assert abs(work - (J.T @ F) @ dq) <= 1e-12 * max(1.0, np.linalg.norm(F))

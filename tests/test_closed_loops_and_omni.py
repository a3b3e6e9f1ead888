"""Janot's haptic branch (closed loops, (8)–(12)) and the Omni-like arm (Milne (5))."""

from __future__ import annotations

import numpy as np
import sympy as sp

import symbolic
from conftest import derived
from symbolic.derivation.transmission import constraint_jacobian, equivalent_tree, passive_state
from symbolic.derivation.simplify import trig_zero
from symbolic.numeric import numeric_model


def test_janot_L_matches_equation_12() -> None:
    robot = symbolic.robots.load("janot_branch")
    Lt_printed = sp.Matrix([[0, 0, 0], [-1, 1, 0], [1, -1, -1]])  # Janot (12), rows q1 q2 q5
    assert constraint_jacobian(robot).T == Lt_printed


def test_janot_closed_loop_torques_equation_12() -> None:
    """Γ_m = [I₃ Lᵀ] Γ_ar: closed-loop model vs equivalent tree, 20 seeded states, 1e-10 relative."""
    closed = derived("janot_branch")
    robot = closed.robot
    tree = symbolic.derive(equivalent_tree(robot))
    assert [str(q) for q in tree.coordinates] == ["q1", "q2", "q5", "q3", "q6", "q4"]  # Janot's Γ_ar order
    Lt = np.array(constraint_jacobian(robot).T, dtype=float)
    rng = np.random.default_rng(12)
    for _ in range(20):
        qa, qda, qdda = rng.uniform(-1.5, 1.5, 3), rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3)
        qp, qdp, qddp = passive_state(robot, qa, qda, qdda)
        gamma_ar = numeric_model(tree).inverse_dynamics(np.r_[qa, qp], np.r_[qda, qdp], np.r_[qdda, qddp])
        gamma_m = numeric_model(closed).inverse_dynamics(qa, qda, qdda)
        expected = np.hstack([np.eye(3), Lt]) @ gamma_ar
        assert np.linalg.norm(gamma_m - expected) <= 1e-10 * np.linalg.norm(expected)


def test_omni_yaw_inertia_is_milne_5() -> None:
    model = derived("omni")
    L1, L2, m1, m2, Ib, go, g1, g2 = sp.symbols("L1 L2 m1 m2 I_base gamma_offs gamma1 gamma2", real=True)
    phi = sp.pi - g1 - g2 - go
    milne5 = (
        Ib
        + sp.Rational(1, 3) * m1 * L1**2 * sp.cos(g1) ** 2
        + m2 * (L1 * sp.cos(g1) + L2 / 2 * sp.cos(phi)) ** 2
        + sp.Rational(1, 12) * m2 * L2**2 * sp.cos(phi) ** 2
    )
    assert trig_zero(model.D[0, 0] - milne5)
    # the yaw axis is vertical: no gravity torque on it (Milne 2.1.1)
    assert model.gravity[0] == 0

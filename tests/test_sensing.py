"""Strain sensing (Madill Appendix C, 3.11), tip deflection and τ = JᵀF along a flexible link (3.56)–(3.58)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import symbolic
from symbolic.derivation.flexible import beam_jacobian, beam_point
from symbolic.codegen.functions import compile_function
from symbolic.derivation.sensing import (check_strain_matrix, force_from_root_strain, generalized_force, strain_matrix,
                              tip_deflection, tip_deflection_from_strain)
from symbolic.numeric import numeric_model


@pytest.fixture(scope="module")
def link():
    model = symbolic.derive(symbolic.robots.load("single_flexible_link"))
    return model, model.robot.beams[0]


def test_strain_matrix_and_tip_deflection(link) -> None:
    model, beam = link
    l = sp.Symbol("l", real=True)
    K = strain_matrix(beam, [0, l / 2], 0.0127)
    Kn = check_strain_matrix(K, model.parameters)
    nu = np.array([0.003, -0.001])
    strains = Kn @ nu
    tip_map = np.array(tip_deflection_from_strain(beam, K).xreplace(model.parameters).evalf(), dtype=float)
    v_tip, _ = tip_deflection(beam)
    names = dict(zip(sp.symbols("link_nu1 link_nu2", real=True), nu))
    assert abs((tip_map @ strains)[0] - float(v_tip.xreplace({**model.parameters, **names}))) < 1e-15
    with pytest.raises(ValueError, match="singular"):
        check_strain_matrix(strain_matrix(beam, [0.1, 0.1], 0.0127), model.parameters)


def test_force_from_root_strain_3_115(link) -> None:
    """Static tip load F on the cantilever: root strain from the assumed-modes solution (4 modes) against
    (3.115), F ≈ EI ε(0)/(h l); Euler–Bernoulli makes it exact, the 4-mode series is within 2 %."""
    text = symbolic.robots.path("single_flexible_link").read_text().replace("modes_v = 2", "modes_v = 4")
    model = symbolic.derive(symbolic.loads(text, "link"))
    beam = model.robot.beams[0]
    values = model.parameters
    nu = [s for s in model.coordinates if "_nu" in s.name]
    K = np.array([[float(sp.diff(model.stiffness[model.coordinates.index(a)], b).xreplace(values)) for b in nu] for a in nu])
    F = 2.0
    load = generalized_force(model.kinematics, beam, beam.length, sp.Matrix([0, F, 0]), model.coordinates)
    rhs = np.array([float(model.expand(load[model.coordinates.index(a)]).xreplace({**values, **{s: 0 for s in model.coordinates}})) for a in nu])
    deflection = np.linalg.solve(K, rhs)
    h = 0.0127
    root = np.array(strain_matrix(beam, [0, 0.1, 0.2, 0.3], h).xreplace(values).evalf(), dtype=float)[0] @ deflection
    estimate = float(force_from_root_strain(beam, h).xreplace(values)) * root
    assert abs(estimate - F) <= 0.02 * F


def test_beam_jacobian_is_derivative_of_position(link) -> None:
    """J(Q, x) (3.56) against central differences of p₀ (3.43), step 1e-6, 1e-8 absolute."""
    model, beam = link
    x = sp.Rational(3, 10)
    args = [model.coordinates, model.parameter_symbols]
    position = compile_function(model.sub, args, beam_point(model.kinematics, beam, x).applyfunc(model.sub.add))
    jacobian = compile_function(model.sub, args, beam_jacobian(model.kinematics, beam, x, model.coordinates).applyfunc(model.sub.add))
    p0 = numeric_model(model).p0
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = np.r_[rng.uniform(-np.pi, np.pi), rng.uniform(-0.01, 0.01, model.n - 1)]
        J = jacobian(q, p0)
        step = 1e-6
        fd = np.column_stack([(position(q + step * e, p0) - position(q - step * e, p0)) / (2 * step) for e in np.eye(model.n)])
        np.testing.assert_allclose(J, fd, atol=1e-8)

"""Degenerate sizes: one coordinate (N = 1) and no parameters (P = 0, every value inline).

References are the textbook pendulum equations, written out here independently of the package:
a point mass m on a massless link of length a (N = 1), and the planar double pendulum with point
masses at the link ends (N = 2), both with gravity g along −y and relative joint angles. Tolerances:
1e-13 relative for evaluations (a few roundings of O(1) numbers), 1e-12 for solves.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import casadi
import numpy as np
import pytest

import models
import symbolic
from c_library import STRICT, CModel, compile_shared, gcc
from symbolic.numeric import numeric_model

M, A, G = 2.0, 0.5, 9.81  # the single pendulum: mass, length, gravity
M1, M2, L1, L2 = 1.0, 0.8, 0.5, 0.4  # the double pendulum

SINGLE = models.pendulum("pendulum1", ("q1",), (M,), (A,), G, inline=True, end_effector=True)
DOUBLE = models.pendulum("pendulum2", ("q1", "q2"), (M1, M2), (L1, L2), G, inline=True)


def single_reference(q, qd, qdd):
    """D, bias (Coriolis + gravity) and τ of the single pendulum."""
    D = np.array([[M * A**2]])
    bias = np.array([M * G * A * np.cos(q[0])])
    return D, bias, D @ qdd + bias


def double_reference(q, qd, qdd):
    """D, bias and τ of the double pendulum (e.g. Spong, Hutchinson & Vidyasagar, 7.4 with point masses)."""
    c1, c2, s2, c12 = np.cos(q[0]), np.cos(q[1]), np.sin(q[1]), np.cos(q[0] + q[1])
    D = np.array(
        [
            [M1 * L1**2 + M2 * (L1**2 + L2**2 + 2 * L1 * L2 * c2), M2 * (L2**2 + L1 * L2 * c2)],
            [M2 * (L2**2 + L1 * L2 * c2), M2 * L2**2],
        ]
    )
    h = M2 * L1 * L2 * s2 * np.array([-(2 * qd[0] * qd[1] + qd[1] ** 2), qd[0] ** 2])
    g = G * np.array([(M1 + M2) * L1 * c1 + M2 * L2 * c12, M2 * L2 * c12])
    return D, h + g, D @ qdd + h + g


MODELS = {"pendulum1": (SINGLE, single_reference), "pendulum2": (DOUBLE, double_reference)}


def close(ours, reference, rtol):
    scale = max(np.linalg.norm(reference), 1e-300)
    assert np.linalg.norm(np.asarray(ours, float) - reference) <= rtol * scale, (ours, reference)


def states(n: int, count: int = 10):
    rng = np.random.default_rng(15)
    for _ in range(count):
        yield rng.uniform(-np.pi, np.pi, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> dict[str, tuple[symbolic.DynamicModel, Path]]:
    out = {}
    for name, (text, _) in MODELS.items():
        model = symbolic.derive(symbolic.loads(text, f"{name}.toml"))
        directory = tmp_path_factory.mktemp(name)
        symbolic.export.generate(model, directory)
        out[name] = (model, directory)
    return out


def test_models_have_no_parameters(generated) -> None:
    for name, (model, _) in generated.items():
        assert model.robot.parameters == () and numeric_model(model).p0.shape == (0,), name


def test_one_coordinate_numeric_model() -> None:
    """forward_dynamics inverts inverse_dynamics, and linearize gives the pendulum's A and B (with F_ext)."""
    model = symbolic.derive(symbolic.loads(SINGLE, "pendulum1.toml"))
    num = numeric_model(model)
    assert num.inertia([0.3]).shape == (1, 1) and num.jacobian([0.3]).shape == (3, 1)
    for q, qd, qdd in states(1):
        D, bias, tau = single_reference(q, qd, qdd)
        close(num.inverse_dynamics(q, qd, qdd), tau, 1e-13)
        close(num.forward_dynamics(q, qd, tau), qdd, 1e-12)
        force = np.array([0.7, -1.1, 0.4])
        J = A * np.array([[-np.sin(q[0])], [np.cos(q[0])], [0.0]])
        close(num.forward_dynamics(q, qd, tau, force=force), qdd - (J.T @ force) / D[0, 0], 1e-12)
        # Ẍ = (τ − JᵀF − m g a cos q)/(m a²): ∂/∂q = (m g a sin q − ∂(JᵀF)/∂q)/(m a²), ∂(JᵀF)/∂q = −a(F_x cos q + F_y sin q)
        u = np.concatenate([tau, force])
        Amat, Bmat = num.linearize(np.concatenate([q, qd]), u)
        dJtF = -A * (force[0] * np.cos(q[0]) + force[1] * np.sin(q[0]))
        close(Amat, np.array([[0.0, 1.0], [(M * G * A * np.sin(q[0]) - dJtF) / D[0, 0], 0.0]]), 1e-12)
        close(Bmat, np.vstack([np.zeros((1, 4)), np.hstack([[[1.0]], -J.T]) / D[0, 0]]), 1e-12)


@pytest.mark.parametrize("name", list(MODELS))
def test_no_parameter_c_builds_strict_and_matches_reference(name: str, generated, tmp_path: Path) -> None:
    model, directory = generated[name]
    reference = MODELS[name][1]
    c = CModel(compile_shared(directory / f"{name}.c", tmp_path / f"lib{name}.so"), name, model.n, 0)
    p = np.zeros(0)
    for q, qd, qdd in states(model.n):
        D, bias, tau = reference(q, qd, qdd)
        close(c.inertia(q, p), D, 1e-13)
        close(c.inverse_dynamics(q, qd, qdd, p), tau, 1e-13)
        close(c.coriolis(q, qd, p) + c.gravity(q, p), bias, 1e-13)
        qdd_back, status = c.forward_dynamics(q, qd, tau, p)
        assert status == 0
        close(qdd_back, qdd, 1e-12)


@pytest.mark.parametrize("name", list(MODELS))
def test_no_parameter_c_runs_clean_under_sanitizers(name: str, generated, tmp_path: Path) -> None:
    """Every function, with p = NULL and with p = NAME_parameter_defaults, under ASan and UBSan; forward
    dynamics inverts inverse dynamics and the regressor reproduces it (τ = Y θ)."""
    _, directory = generated[name]
    program = tmp_path / "main.c"
    program.write_text(
        f"""#include <math.h>
#include "{name}.h"
int main(void)
{{
    double q[{name}_NQ], qd[{name}_NQ], qdd[{name}_NQ], tau[{name}_NQ], back[{name}_NQ];
    double D[{name}_NQ * {name}_NQ], C[{name}_NQ * {name}_NQ], h[{name}_NQ], g[{name}_NQ], k[{name}_NQ], f[{name}_NQ], Q[{name}_NQ];
    double Y[{name}_NQ * {name}_NTHETA], theta[{name}_NTHETA];
    const double *parameters[2];
    int i, j, c;
    parameters[0] = 0;
    parameters[1] = {name}_parameter_defaults;
    if ({name}_NP != 0) return 4;
    for (j = 0; j < 2; ++j) {{
        const double *p = parameters[j];
        for (i = 0; i < {name}_NQ; ++i) {{ q[i] = 0.1 * (i + 1); qd[i] = -0.2 * i; qdd[i] = 0.3; }}
        {name}_inertia(q, p, D);
        {name}_coriolis(q, qd, p, h);
        {name}_coriolis_matrix(q, qd, p, C);
        {name}_gravity(q, p, g);
        {name}_stiffness(q, p, k);
        {name}_friction(q, qd, p, f);
        {name}_applied(q, qd, p, Q);
        {name}_inverse_dynamics(q, qd, qdd, p, tau);
        if ({name}_forward_dynamics(q, qd, tau, p, back) != 0) return 1;
        for (i = 0; i < {name}_NQ; ++i) if (fabs(back[i] - qdd[i]) > 1e-12) return 2;
        {name}_regressor(q, qd, qdd, p, Y);
        {name}_standard_parameters(p, theta);
        for (i = 0; i < {name}_NQ; ++i) {{ /* tau = Y theta */
            double t = 0.0;
            for (c = 0; c < {name}_NTHETA; ++c) t += Y[i * {name}_NTHETA + c] * theta[c];
            if (fabs(t - tau[i]) > 1e-12 * (1.0 + fabs(tau[i]))) return 5;
        }}
        if (!(D[0] > 0.0) || {name}_coordinate_names[0] == 0 || {name}_theta_names[0] == 0) return 3;
        (void)C; (void)h; (void)g; (void)k; (void)f; (void)Q;
    }}
    return 0;
}}
"""
    )
    exe = tmp_path / "check"
    flags = [*STRICT[:-1], "-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
    build = subprocess.run([gcc(), *flags, f"-I{directory}", "-o", str(exe), str(program), str(directory / f"{name}.c"), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1"})
    assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("name", list(MODELS))
def test_no_parameter_casadi_files_load_and_match_reference(name: str, generated) -> None:
    model, directory = generated[name]
    reference = MODELS[name][1]
    load = {f: casadi.Function.load(str(directory / f"{name}_{f}.casadi")) for f in ("inertia", "inverse_dynamics", "forward_dynamics", "A", "B")}
    assert load["inertia"].size_in(1) == (0, 1)
    p: list[float] = []
    n = model.n
    for q, qd, qdd in states(n):
        D, bias, tau = reference(q, qd, qdd)
        close(np.array(load["inertia"](q, p)), D, 1e-13)
        close(np.array(load["inverse_dynamics"](q, qd, qdd, p)).ravel(), tau, 1e-13)
        close(np.array(load["forward_dynamics"](q, qd, tau, p)).ravel(), qdd, 1e-12)
        # B = [0; D⁻¹]; A's lower-left block by central differences of the reference (step 1e-6: error ~1e-10)
        close(np.array(load["B"](q, qd, tau, p)), np.vstack([np.zeros((n, n)), np.linalg.inv(D)]), 1e-12)
        Amat = np.array(load["A"](q, qd, tau, p))
        for k in range(n):
            step = np.zeros(n)
            step[k] = 1e-6
            plus = np.linalg.solve(reference(q + step, qd, qdd)[0], tau - reference(q + step, qd, qdd)[1])
            minus = np.linalg.solve(reference(q - step, qd, qdd)[0], tau - reference(q - step, qd, qdd)[1])
            close(Amat[n:, k], (plus - minus) / 2e-6, 1e-7)


def test_numeric_functions_name_the_sizes_they_expect() -> None:
    """A wrong-length argument is a ValueError naming the sizes, not a NumPy broadcasting error."""
    import warnings

    import numpy as np

    import symbolic

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        num = symbolic.numeric_model(symbolic.derive(symbolic.robots.load("puma560")))
    with pytest.raises(ValueError, match=r"expected arguments of sizes 6 \(q1, q2, q3, …\).*got sizes \[5, 6, 6"):
        num.inverse_dynamics(np.zeros(5), np.zeros(6), np.zeros(6))
    with pytest.raises(ValueError, match=r"U⁰ = \[τ; F\] 9 values, or 6 for τ alone"):
        num.linearize(np.zeros(12), np.zeros(8))
    assert num.linearize(np.zeros(12), np.zeros(6))[1].shape == (12, 9)

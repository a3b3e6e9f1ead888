"""Physically consistent identification (symbolic.identify.consistent, ``identify --consistent``).

References kept out of the code under test:

* the pseudo-inertia of a body made of point masses, J = Σ mᵢ·[rᵢ; 1]·[rᵢ; 1]ᵀ (its definition), against
  :func:`pseudo_inertia` of the same body's mass, centre of mass and inertia computed from the points;
* Pinocchio's ``LogCholeskyParameters`` (Rucker & Wensing's parameterization as Pinocchio implements it)
  against :func:`from_log_cholesky`, where Pinocchio is installed;
* derivatives (the Jacobian of the first pass, the Hessian of the second) against central finite differences;
* a synthetic two-joint spatial arm whose data come from an infeasible truth (a body with a negative
  inertia about its centre of mass: its ZZ about the joint axis is negative, which no feasible body has),
  so that the least-squares optimum is infeasible: the consistent answer is feasible and its full-sample
  cost is no worse than a brute-force minimisation of the full-sample cost in another parameterization
  (m = u², Σ_c = B·Bᵀ, B any 3×3: unconstrained, BFGS from several starts);
* the same arm with a feasible truth: the consistent fit is the least-squares optimum (1e-8);
* the model written by ``identify --consistent --out`` loads and reproduces the reported relative error.
"""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import symbolic
from symbolic.cli import main
from symbolic.data import Measurements
from symbolic.identify import consistent
from symbolic.identify.consistent import from_log_cholesky, log_cholesky
from symbolic.identify.pseudo_inertia import body_of_standard, pseudo_inertia, pseudo_of_standard, standard_parameters
from symbolic.identify.known import fixed_symbols, parameter_bounds
from symbolic.identify.model import geometric_parameters, identify_model, model_base
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import theta_values

BODY_KEYS = ("m{k}", "cx{k}", "cy{k}", "cz{k}", "Ixx{k}", "Ixy{k}", "Ixz{k}", "Iyy{k}", "Iyz{k}", "Izz{k}")
NOMINAL = {1: (3.0, 0.01, -0.05, 0.02, 0.05, 0.002, -0.003, 0.04, 0.001, 0.03),
           2: (2.0, 0.20, 0.01, -0.02, 0.004, 0.001, 0.002, 0.03, -0.001, 0.032)}


IDENTIFIABLE = ("m1", "cx1", "cy1", "cz1", "Ixx1", "Ixy1", "Ixz1", "Iyy1", "Iyz1", "Izz1", "m2", "cz2")
"""Kept fixed for :func:`arm_text`'s identifiable variant: link 1 entirely, and link 2's mass and height of
its centre of mass; the other eight of link 2 and the two frictions are then ten parameters for ten base
parameters (ZZR1, XXR2, XY2, XZ2, YZ2, ZZ2, MX2, MY2, Fv1, Fv2), and with m2 fixed the feasible set in them
is closed and convex in the standard parameters (J ⪰ 0 at fixed m): the closest feasible point exists."""


def arm_text(fv: tuple[float, float] = (0.3, 0.2), fixed: tuple[str, ...] = ()) -> str:
    """A two-joint spatial arm (joint 1 about the vertical, joint 2 horizontal), each body with its ten
    parameters (mass, centre of mass, full inertia about it) free unless named in ``fixed``, viscous
    friction on both joints."""
    lines = ['name = "arm3d"', 'coordinates = ["q1", "q2"]', 'gravity = ["0", "0", "-9.81"]', "", "[parameters]"]
    for k, values in NOMINAL.items():
        for key, value in zip(BODY_KEYS, values):
            name = key.format(k=k)
            lines.append(f"{name} = {{ value = {value!r}, fixed = true }}" if name in fixed else f"{name} = {value!r}")
    lines += [f"Fv1 = {fv[0]!r}", f"Fv2 = {fv[1]!r}", ""]
    lines += ['[[frame]]', 'name = "1"', 'parent = "base"', 'dh = { theta = "q1", d = "0.3", a = "0", alpha = "pi/2" }', "",
              '[[frame]]', 'name = "2"', 'parent = "1"', 'dh = { theta = "q2", d = "0", a = "0.4", alpha = "0" }', ""]
    for k in (1, 2):
        lines += ['[[body]]', f'name = "link{k}"', f'frame = "{k}"', f'mass = "m{k}"',
                  f'com = ["cx{k}", "cy{k}", "cz{k}"]',
                  f'inertia = {{ xx = "Ixx{k}", xy = "Ixy{k}", xz = "Ixz{k}", yy = "Iyy{k}", yz = "Iyz{k}", zz = "Izz{k}" }}', ""]
    for k in (1, 2):
        lines += ['[[friction]]', f'coordinate = "q{k}"', f'viscous = "Fv{k}"', ""]
    return "\n".join(lines)


@pytest.fixture(scope="module")
def arm() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.loads(arm_text(), "arm3d.toml"))


@pytest.fixture(scope="module")
def identifiable() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.loads(arm_text(fixed=IDENTIFIABLE), "arm3d.toml"))


def trajectory(t: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ of a sum of three sines per joint (frequencies 0.2–0.9 Hz, random phases)."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.2, 0.9, (2, 3))
    a = rng.uniform(0.3, 0.8, (2, 3))
    phase = rng.uniform(0, 2 * np.pi, (2, 3))
    arg = 2 * np.pi * f[None] * t[:, None, None] + phase[None]
    w = 2 * np.pi * f[None]
    return (np.sum(a * np.sin(arg), -1), np.sum(a * w * np.cos(arg), -1), np.sum(-a * w**2 * np.sin(arg), -1))


def data(model, p: np.ndarray, noise: float, seed: int = 1, seconds: float = 10.0, rate: float = 200.0) -> Measurements:
    t = np.arange(0.0, seconds, 1.0 / rate)
    q, qd, qdd = trajectory(t, seed)
    num = numeric_model(model)
    tau = np.array([num.inverse_dynamics(q[k], qd[k], qdd[k], p) for k in range(len(t))])
    if noise:
        tau = tau + np.random.default_rng(seed + 7).normal(0, 1, tau.shape) * noise * np.sqrt(np.mean(tau**2, axis=0))
    return Measurements.from_arrays(t, model.robot.generalized_coordinates, q, tau, qd=qd, qdd=qdd)


def with_values(model, changes: dict[str, float]) -> np.ndarray:
    names = [s.name for s in model.parameter_symbols]
    p = numeric_model(model).p0.copy()
    for name, value in changes.items():
        p[names.index(name)] = value
    return p


def bodies(values: dict[str, float]) -> list[np.ndarray]:
    """The pseudo-inertia of each link at ``values`` (model-file names)."""
    out = []
    for k in (1, 2):
        m, cx, cy, cz, xx, xy, xz, yy, yz, zz = (values[key.format(k=k)] for key in BODY_KEYS)
        out.append(pseudo_inertia(m, (cx, cy, cz), np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])))
    return out


# -- the body's parameters -------------------------------------------------------------------------------

def point_masses(seed: int, count: int, spread: float, offset) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """Random point masses as a body, from their definition: J = Σ m·[r; 1]·[r; 1]ᵀ, the total mass, the centre
    of mass and the inertia about it."""
    rng = np.random.default_rng(seed)
    masses, points = rng.uniform(0.1, 1.0, count), rng.normal(0, spread, (count, 3)) + offset
    J = sum(m * np.outer(np.append(r, 1), np.append(r, 1)) for m, r in zip(masses, points))
    m = masses.sum()
    c = masses @ points / m
    Ic = sum(mi * ((r - c) @ (r - c) * np.eye(3) - np.outer(r - c, r - c)) for mi, r in zip(masses, points))
    return J, m, c, Ic


def test_pseudo_inertia_of_point_masses_is_its_definition() -> None:
    J, m, c, Ic = point_masses(4, 7, 0.2, [0.1, -0.05, 0.3])
    np.testing.assert_allclose(pseudo_inertia(m, c, Ic), J, rtol=1e-12, atol=1e-14)
    back = body_of_standard(standard_parameters(m, c, Ic))
    np.testing.assert_allclose(back[0], m, rtol=1e-14)
    np.testing.assert_allclose(back[1], c, rtol=1e-12)
    np.testing.assert_allclose(back[2], Ic, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(pseudo_of_standard(standard_parameters(m, c, Ic)), J, rtol=1e-12, atol=1e-14)


def test_log_cholesky_round_trip_and_pinocchio() -> None:
    rng = np.random.default_rng(5)
    for _ in range(20):
        phi = rng.normal(0, 1, 10)
        m, c, Ic = from_log_cholesky(phi)
        assert np.linalg.eigvalsh(pseudo_inertia(m, c, Ic))[0] > 0
        np.testing.assert_allclose(log_cholesky(m, c, Ic), phi, rtol=1e-9, atol=1e-9)
    pin = pytest.importorskip("pinocchio")
    for _ in range(5):
        phi = rng.normal(0, 1, 10)
        m, c, Ic = from_log_cholesky(phi)
        reference = pin.LogCholeskyParameters(phi).toPseudoInertia().toMatrix()
        np.testing.assert_allclose(pseudo_inertia(m, c, Ic), reference, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("products", [(), ((0, 1),), ((0, 2),), ((1, 2),), ((0, 1), (1, 2)), ((0, 2), (1, 2)),
                                      ((0, 1), (0, 2)), ((0, 1), (0, 2), (1, 2))])
def test_pattern_order_keeps_the_zeros_of_the_inertia(products) -> None:
    """Every zero pattern of the products: the factor in the chosen order has no fill, so S = L·Lᵀ of
    that pattern is any positive definite matrix of the pattern (round trip to 1e-12)."""
    order, edges = consistent._pattern_order(set(products))
    rng = np.random.default_rng(len(products))
    B = rng.normal(0, 1, (3, 3))
    sigma = B @ B.T + 3 * np.eye(3)
    mask = np.eye(3, dtype=bool)
    for i, j in products:
        mask[i, j] = mask[j, i] = True
    sigma = np.where(mask, sigma, 0.0)
    L = consistent._upper_cholesky(sigma[np.ix_(order, order)])
    free = {(k, k) for k in range(3)} | set(edges)
    outside = [L[k, l] for k in range(3) for l in range(k, 3) if (k, l) not in free]
    assert np.allclose(outside, 0.0, atol=1e-12)
    inverse = np.argsort(order)
    np.testing.assert_allclose((L @ L.T)[np.ix_(inverse, inverse)], sigma, atol=1e-12)


# -- derivatives ----------------------------------------------------------------------------------------

def free_of(model):
    reg, _ = model_base(model)
    fixed = geometric_parameters(model, reg) | fixed_symbols(model)
    return reg, [s for s in model.parameter_symbols if s not in fixed and any(s in e.free_symbols for e in reg.theta_expressions)]


def builtin(name: str):
    """A built-in robot, derived (its model-file warnings are not what these tests look at)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return symbolic.derive(symbolic.robots.load(name))


@pytest.mark.parametrize("linear", [False, True])
@pytest.mark.parametrize("name", ["arm3d", "puma560"])
def test_jacobians_match_finite_differences(name: str, linear: bool, arm) -> None:
    """∂p/∂φ (both coordinate systems, full bodies and the PUMA's diagonal inertias and partial centres of
    mass) and ∂θ/∂p against central differences (step 1e-6, agreement 1e-7 of the largest entry)."""
    model = arm if name == "arm3d" else builtin(name)
    reg, free = free_of(model)
    prob = consistent.problem(model, reg, free, parameter_bounds(model))
    p0 = np.array([model.parameters[s] for s in free])
    phi = prob.start(p0) + np.random.default_rng(0).normal(0, 0.05, prob.size)
    if linear:
        phi = np.abs(prob.linear(phi))
    _, jac = prob.parameters(phi, linear)
    h = 1e-6
    numeric = np.column_stack([(prob.parameters(phi + h * e, linear)[0] - prob.parameters(phi - h * e, linear)[0]) / (2 * h)
                               for e in np.eye(prob.size)])
    assert np.max(np.abs(jac - numeric)) <= 1e-7 * np.max(np.abs(jac))
    p = prob.parameters(phi, linear)[0]
    numeric = np.column_stack([(prob.theta(p + h * e) - prob.theta(p - h * e)) / (2 * h) for e in np.eye(len(p))])
    assert np.max(np.abs(prob.theta_jacobian(p) - numeric)) <= 1e-7 * np.max(np.abs(numeric))
    # θ(p) is the model's own map
    full = model.parameter_vector.array()
    full[[model.parameter_vector.index(s) for s in free]] = p
    np.testing.assert_allclose(prob.theta(p), theta_values(model, reg, full), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("linear", [False, True])
@pytest.mark.parametrize("name", ["arm3d", "puma560"])
def test_hessian_matches_finite_differences(name: str, linear: bool, arm) -> None:
    """The second-order terms of Newton's pass, (∂p/∂φ)ᵀ·(Σ w_k·∇²θ_k)·(∂p/∂φ) + Σ q_j·∇²p_j, against central
    differences of the gradient of wᵀθ(p(φ)) for a random w (agreement 1e-7 of the largest entry)."""
    model = arm if name == "arm3d" else builtin(name)
    reg, free = free_of(model)
    prob = consistent.problem(model, reg, free, parameter_bounds(model))
    rng = np.random.default_rng(1)
    phi = prob.start(np.array([model.parameters[s] for s in free])) + rng.normal(0, 0.05, prob.size)
    if linear:
        phi = np.abs(prob.linear(phi))
    w = rng.normal(0, 1, len(reg.theta))

    def gradient(x):
        p, dp = prob.parameters(x, linear)
        return dp.T @ (prob.theta_jacobian(p).T @ w)

    p, dp = prob.parameters(phi, linear)
    H = dp.T @ prob.theta_hessian(p, w) @ dp + prob.curvature(phi, prob.theta_jacobian(p).T @ w, linear)
    h = 1e-6
    numeric = np.column_stack([(gradient(phi + h * e) - gradient(phi - h * e)) / (2 * h) for e in np.eye(prob.size)])
    assert np.max(np.abs(H - numeric)) <= 1e-7 * np.max(np.abs(numeric))
    np.testing.assert_array_equal(H, H.T)


@pytest.mark.parametrize("case", ["convex inside", "convex on the boundary", "indefinite", "hard case"])
def test_trust_region_step_meets_the_optimality_conditions(case: str) -> None:
    """The step of the Newton pass against Moré & Sorensen's conditions for the global minimiser of
    gᵀs + ½·sᵀHs over ‖s‖ ≤ Δ: (H + μ·1)·s = −g with μ ≥ 0, H + μ·1 ⪰ 0, μ·(Δ − ‖s‖) = 0 (1e-8)."""
    rng = np.random.default_rng(len(case))
    V = np.linalg.qr(rng.normal(size=(6, 6)))[0]
    lam = {"convex inside": [1, 2, 3, 4, 5, 6], "convex on the boundary": [1, 2, 3, 4, 5, 6],
           "indefinite": [-2, -1, 1, 2, 3, 4], "hard case": [-2, 1, 1, 2, 3, 4]}[case]
    H = V @ np.diag(lam) @ V.T
    g = V @ np.array([0.0 if case == "hard case" else 1.0, 1.0, -1.0, 0.5, 0.2, 1.0])
    radius = {"convex inside": 10.0, "convex on the boundary": 0.3, "indefinite": 1.0, "hard case": 5.0}[case]
    step, predicted = consistent._trust_step(g, H, radius)
    norm = np.linalg.norm(step)
    assert norm <= radius * (1 + 1e-9)
    mu = -float(step @ (H @ step + g)) / float(step @ step)
    assert mu >= -1e-8
    np.testing.assert_allclose((H + mu * np.eye(6)) @ step, -g, atol=1e-8 * np.linalg.norm(g))
    assert np.linalg.eigvalsh(H + mu * np.eye(6))[0] >= -1e-8
    assert abs(mu * (radius - norm)) <= 1e-8 * max(mu, 1.0) * radius
    assert predicted == pytest.approx(-(g @ step + 0.5 * step @ H @ step), rel=1e-12)


def test_start_reproduces_feasible_parameters(arm) -> None:
    """p(φ(p)) = p for the nominal (feasible) parameters: the parameterization covers them."""
    reg, free = free_of(arm)
    prob = consistent.problem(arm, reg, free, parameter_bounds(arm))
    p0 = np.array([arm.parameters[s] for s in free])
    np.testing.assert_allclose(prob.parameters(prob.start(p0))[0], p0, rtol=1e-9, atol=1e-12)
    assert [b.name for b in prob.bodies] == ["link1", "link2"] and not prob.penalties


# -- the fit ------------------------------------------------------------------------------------------

def full_cost(result, values: dict[str, float], model, reg, weights) -> float:
    """‖diag(w)·(y − W·β(p))‖² over every sample, β from the model's own θ(p)."""
    full = model.parameter_vector.updated(values).array()
    beta = result.base.from_theta(theta_values(model, reg, full))
    r = (result.observation.y - result.observation.W @ beta) * weights
    return float(r @ r)


def brute_force(result, model, reg, free, weights, seeds=(0, 1, 2)) -> tuple[float, dict[str, float]]:
    """Minimum of the full-sample cost over feasible link-2 bodies (m2 fixed) and Fv ≥ 0 by BFGS in another
    parameterization: c_x, c_y free, Σ_c = B·Bᵀ (B any 3×3), Fv = v²."""
    import scipy.optimize

    symbols = [s.name for s in free]
    theta = sp.lambdify([list(free)], [e.xreplace({s: v for s, v in model.parameters.items() if s not in set(free)})
                                       for e in reg.theta_expressions], modules="numpy")
    W, y = result.observation.W * weights[:, None], result.observation.y * weights
    K = np.zeros((len(result.base.names), len(reg.theta)))
    K[np.arange(len(result.base.independent)), list(result.base.independent)] = 1.0
    K[:, list(result.base.dependent)] = result.base.K
    WK = W @ K

    def values(x):
        sigma = x[2:11].reshape(3, 3) @ x[2:11].reshape(3, 3).T
        Ic = np.trace(sigma) * np.eye(3) - sigma
        return {"cx2": x[0], "cy2": x[1], "Ixx2": Ic[0, 0], "Ixy2": Ic[0, 1], "Ixz2": Ic[0, 2], "Iyy2": Ic[1, 1],
                "Iyz2": Ic[1, 2], "Izz2": Ic[2, 2], "Fv1": x[11] ** 2, "Fv2": x[12] ** 2}

    def cost(x):
        v = values(x)
        r = WK @ np.array(theta([v[n] for n in symbols]), float) - y
        return float(r @ r)

    best = (np.inf, None)
    for seed in seeds:
        x = np.random.default_rng(seed).normal(0, 0.3, 13)
        for _ in range(3):  # restarts from the last answer refresh BFGS's curvature
            x = scipy.optimize.minimize(cost, x, method="BFGS", options={"gtol": 1e-9, "maxiter": 20000}).x
        if cost(x) < best[0]:
            best = (cost(x), values(x))
    return best


@pytest.mark.slow
def test_infeasible_least_squares_gives_the_closest_feasible_parameters(identifiable) -> None:
    """Data from a link 2 with Izz = −0.05 about its centre of mass (its ZZ about joint 2 is then negative,
    which no body has), on the arm whose free parameters the data determine: the answer's bodies are
    feasible (eigenvalues of each pseudo-inertia ≥ −1e-9 of its largest), Fv ≥ 0, its full-sample cost
    exceeds the least squares' (the optimum was infeasible) and is within 1e-9 (relative) of a brute-force
    minimisation's or below it, and the β of both agree to 1e-6 in the metric of the fit (‖R·Δβ‖ relative
    to ‖R·β‖)."""
    model = identifiable
    truth = with_values(model, {"Izz2": -0.05, "Ixx2": 0.004, "Iyy2": 0.03, "cx2": 0.05})
    result = identify_model(model, data(model, truth, noise=0.01), consistent=True)
    assert result.consistent.converged, result.consistent.message
    reg, free = free_of(model)
    values = {**{s.name: model.parameters[s] for s in model.parameter_symbols}, **result.values()}
    for J in bodies(values):
        eig = np.linalg.eigvalsh(J)
        assert eig[0] >= -1e-9 * eig[-1]
    assert values["Fv1"] >= 0 and values["Fv2"] >= 0
    weights = consistent.row_weights(result.identification.method, result.identification.coordinate_sigmas,
                                     result.observation.samples)
    ours = full_cost(result, result.values(), model, reg, weights)
    r_ls = (result.observation.y - result.observation.W @ result.identification.values) * weights
    assert ours > (r_ls @ r_ls) * (1 + 1e-3), "the least-squares optimum should be infeasible here"
    reference, reference_values = brute_force(result, model, reg, free, weights)
    assert ours <= reference * (1 + 1e-9)
    R = np.linalg.qr(result.observation.W * weights[:, None], mode="r")
    full = model.parameter_vector.updated(reference_values).array()
    beta_reference = result.base.from_theta(theta_values(model, reg, full))
    assert np.linalg.norm(R @ (result.consistent.beta - beta_reference)) <= 1e-6 * np.linalg.norm(R @ beta_reference)
    assert result.consistent.relative_error > result.consistent.least_squares_relative_error
    assert "link2" in result.consistent.boundary


def test_feasible_least_squares_is_the_answer(arm) -> None:
    """A feasible truth (the nominal bodies, scaled) with noise: the least-squares β is feasible and the
    consistent fit returns it (‖R·Δβ‖ ≤ 1e-8·‖R·β‖), with the same relative error."""
    truth = with_values(arm, {"m2": 2.4, "Izz2": 0.04, "Fv1": 0.5})
    result = identify_model(arm, data(arm, truth, noise=0.005, seed=3), consistent=True)
    weights = consistent.row_weights(result.identification.method, result.identification.coordinate_sigmas,
                                     result.observation.samples)
    R = np.linalg.qr(result.observation.W * weights[:, None], mode="r")
    beta = np.asarray(result.identification.values)
    assert np.linalg.norm(R @ (result.consistent.beta - beta)) <= 1e-8 * np.linalg.norm(R @ beta)
    assert result.consistent.relative_error == pytest.approx(result.identification.relative_error, rel=1e-8)
    assert not result.consistent.boundary


@pytest.mark.parametrize("fixed", [(), IDENTIFIABLE])
def test_written_model_reproduces_the_reported_gap(fixed, tmp_path: Path, capsys) -> None:
    """``identify --consistent --out``: every inertial parameter that is not fixed is written, the fixed
    ones keep their values; the file loads and its values give the reported relative error (1e-9 relative)
    on the same data (with all parameters free the fit need not converge: what it reports is written)."""
    model_file = tmp_path / "arm3d.toml"
    model_file.write_text(arm_text(fixed=fixed), encoding="utf-8")
    model = symbolic.derive(symbolic.load(model_file))
    truth = with_values(model, {"Izz2": -0.05, "cx2": 0.05})
    log = tmp_path / "log.csv"
    symbolic.data.write(data(model, truth, noise=0.01), log)
    out = tmp_path / "identified.toml"
    assert main(["-q", "identify", str(model_file), str(log), "--consistent", "--out", str(out), "--json"]) == 0
    import json

    report = json.loads(capsys.readouterr().out)
    assert report["kept"] == {}
    written = symbolic.load(out)
    inertial = {key.format(k=k) for k in (1, 2) for key in BODY_KEYS}
    assert set(report["parameters"]) == inertial - set(fixed) | {"Fv1", "Fv2"}
    for p in written.parameters:
        expected = report["parameters"][p.name]["value"] if p.name in report["parameters"] else model.parameters[p.symbol]
        assert p.value == expected, p.name
    again = identify_model(symbolic.derive(written), log)
    reg, _ = model_base(again.model)
    beta = again.base.from_theta(theta_values(again.model, reg))
    y, W = again.observation.y, again.observation.W
    gap = 100 * np.linalg.norm(y - W @ beta) / np.linalg.norm(y)
    assert gap == pytest.approx(report["consistent"]["relative_error"], rel=1e-9)


def test_bodies_the_parameterization_cannot_hold_get_penalties() -> None:
    """The tests' planar arm writes each centre of mass as an expression (c1 − l1) and gives only zz: its
    bodies are kept physical by penalties, named as such; the answer's I1, I2 and masses are ≥ 0 within
    1e-6 of their size although the data come from I2 = −0.01."""
    from models import arm as arm_model

    model = symbolic.derive(symbolic.loads(arm_model(), "arm.toml"))
    truth = with_values(model, {"I2": -0.01})
    t = np.arange(0.0, 10.0, 1 / 200)
    q, qd, qdd = trajectory(t, 2)
    num = numeric_model(model)
    tau = np.array([num.inverse_dynamics(q[k], qd[k], qdd[k], truth) for k in range(len(t))])
    result = identify_model(model, Measurements.from_arrays(t, ("q1", "q2"), q, tau, qd=qd, qdd=qdd), consistent=True)
    assert result.consistent.penalized == ("link1", "link2") and result.consistent.exact == ()
    values = result.values()
    for name in ("I1", "I2", "m1", "m2"):
        assert values[name] >= -1e-6 * max(abs(model.parameter_vector[name]), 1e-3), name


def test_progress_is_reported_when_the_fit_is_long(arm, monkeypatch, caplog) -> None:
    monkeypatch.setattr(consistent, "PROGRESS_AFTER", 0.0)
    truth = with_values(arm, {"Izz2": -0.05})
    with caplog.at_level(logging.INFO, logger="symbolic.identify.consistent"):
        identify_model(arm, data(arm, truth, noise=0.01, seconds=4.0), consistent=True)
    messages = [r.getMessage() for r in caplog.records]
    assert any(m.startswith("arm3d: consistent fit: ") for m in messages)
    assert any(m.startswith("arm3d: consistent fit done in ") for m in messages)


def test_identification_without_consistent_does_not_import_scipy(tmp_path: Path) -> None:
    import subprocess
    import sys

    model_file = tmp_path / "arm3d.toml"
    model_file.write_text(arm_text(), encoding="utf-8")
    code = ("import sys, numpy as np, symbolic\n"
            "from symbolic.identify import consistent, model\n"
            "assert 'scipy.optimize' not in sys.modules, 'imported with the module'\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={"PYTHONPATH": str(Path(symbolic.__file__).parents[1]), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr

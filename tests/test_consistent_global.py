"""Consistent identification at its certified global optimum (issue 38 §3: symbolic.identify.conic).

References kept out of the code under test:

* a synthetic two-joint spatial arm with a known consistent truth: without noise the fit gives the truth's
  base parameters (1e-8 in the metric of the fit); with it, where the least squares are already consistent,
  the consistent fit is the least squares (1e-9 relative);
* an independent solve of the same convex problem (Wensing et al. 2017's SDP) in Burer–Monteiro form — each
  body's J = L·Lᵀ with L a full 4×4 lower-triangular factor, so that every J is positive semidefinite,
  minimised without constraints by L-BFGS from several starts; for this convex problem with full-size factors
  every local minimum is global (Burer & Monteiro 2005), so the best of the starts bounds the optimum from
  above: the certified lower bound must lie below it, and the written model's cost within 1.001 of it;
* the Franka Panda's measured log (Gaz et al. 2019, read from ../shared/data/franka_panda; skipped without it)
  and the 6-DOF arm of bench/consistent.py (the PUMA 560 with hidden scaled bodies, 2 % noise): converged,
  the written model's cost at most 1.001 times the certified lower bound, every written pseudo-inertia
  positive semidefinite (smallest eigenvalue ≥ −1e-12 of its largest).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import symbolic
from symbolic.identify import conic, consistent
from symbolic.identify.pseudo_inertia import pseudo_inertia
from symbolic.identify.known import fixed_symbols, parameter_bounds
from symbolic.identify.model import geometric_parameters, identify_model, model_base
from symbolic.numeric.base_parameters import theta_values
from test_consistent import arm_text, data, point_masses, with_values

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def arm() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.loads(arm_text(), "arm3d.toml"))


def summary_of(result):
    """(R, z, ρ, K, the problem, free parameters) of an identification's consistent fit, rebuilt as
    symbolic.identify.model.consistent_fit builds them."""
    model, base = result.model, result.base
    reg, _ = model_base(model)
    fixed = geometric_parameters(model, reg) | fixed_symbols(model)
    free = [s for s in model.parameter_symbols if s not in fixed and any(s in e.free_symbols for e in reg.theta_expressions)]
    prob = consistent.problem(model, reg, free, parameter_bounds(model))
    K = np.zeros((len(base.names), len(reg.theta)))
    K[np.arange(len(base.independent)), list(base.independent)] = 1.0
    K[:, list(base.dependent)] = base.K
    weights = consistent.row_weights(result.identification.method, result.identification.coordinate_sigmas,
                                     result.observation.samples)
    summary = consistent.Summary.of(result.observation.W, result.observation.y, weights)
    return summary, K, prob, free


def written_pseudo_inertias(result) -> list[np.ndarray]:
    """J of (4) of every body of the model with the fit's values written into it."""
    values = {**{s.name: v for s, v in result.model.parameters.items()}, **result.values()}
    out = []
    for body in result.model.robot.bodies:
        number = lambda e: float(symbolic_value(e, values))  # noqa: E731
        Ic = np.array([[number(body.inertia[k]) for k in row] for row in (("xx", "xy", "xz"), ("xy", "yy", "yz"),
                                                                            ("xz", "yz", "zz"))])
        out.append(pseudo_inertia(number(body.mass), [number(c) for c in body.com], Ic))
    return out


def symbolic_value(expression, values: dict[str, float]) -> float:
    import sympy as sp

    expression = sp.sympify(expression)
    return float(expression.xreplace({s: values[s.name] for s in expression.free_symbols}))


def burer_monteiro(summary, K, prob, p0: np.ndarray, starts: int = 2, seed: int = 0) -> float:
    """The smallest ‖R·K·θ − z‖² + ρ² found by L-BFGS over J_b = L_b·L_bᵀ (L_b 4×4 lower triangular), the
    problem's other parameters free, from the nominal values p0 and ``starts − 1`` random starts. Only for
    problems whose bodies are all written with their ten parameters and no bounds (the Panda's)."""
    import scipy.optimize

    lifted = conic.lift(prob, np.zeros(len(prob.free)) + 1.0)
    assert lifted is not None and lifted.exact and not len(lifted.g) and not len(lifted.e)
    M = summary.R @ K @ lifted.T
    d = summary.z - summary.R @ K @ lifted.t0
    rows, cols = np.tril_indices(4)
    blocks = [conic.pseudo_rows(b, lifted.size)[:, list(b)] for b in lifted.blocks]  # svec(J) = P·x_b
    inverse = [np.linalg.inv(P) for P in blocks]
    n = 10 * len(lifted.blocks)

    def unpack(v: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        x, factors = np.zeros(lifted.size), []
        for k, block in enumerate(lifted.blocks):
            L = np.zeros((4, 4))
            L[rows, cols] = v[10 * k:10 * k + 10]
            factors.append(L)
            J = L @ L.T
            x[list(block)] = inverse[k] @ np.array([J[i, j] * (1.0 if i == j else np.sqrt(2)) for i, j in conic.PSD_ORDER])
        x[n:] = v[n:]
        return x, factors

    def cost(v: np.ndarray) -> tuple[float, np.ndarray]:
        x, factors = unpack(v)
        r = M @ x - d
        gx = 2.0 * M.T @ r
        grad = np.zeros_like(v)
        for k, block in enumerate(lifted.blocks):
            g = inverse[k].T @ gx[list(block)]  # ∂f/∂svec(J)
            G = np.zeros((4, 4))
            for value, (i, j) in zip(g, conic.PSD_ORDER):
                G[i, j] = G[j, i] = value * (1.0 if i == j else np.sqrt(2) / 2)
            grad[10 * k:10 * k + 10] = (2.0 * G @ factors[k])[rows, cols]
        grad[n:] = gx[n:]
        return float(r @ r), grad

    nominal = conic.lifted_point(prob, p0)
    rng = np.random.default_rng(seed)
    best = np.inf
    for attempt in range(starts):
        v0 = np.zeros(lifted.size)
        for k, block in enumerate(lifted.blocks):
            J = conic.pseudo_matrix(nominal, block) + 1e-6 * np.eye(4)
            L = np.linalg.cholesky(J)
            if attempt:
                L = L * rng.uniform(0.3, 3.0) + rng.normal(0, 0.3, (4, 4)) * np.sqrt(np.trace(J) / 4)
            v0[10 * k:10 * k + 10] = np.tril(L)[rows, cols]
        v0[n:] = nominal[n:]
        found = scipy.optimize.minimize(cost, v0, jac=True, method="L-BFGS-B",
                                        options={"maxiter": 2000, "maxfun": 4000, "ftol": 1e-15, "gtol": 1e-12})
        best = min(best, found.fun)
    return best + summary.rho**2


def check_certified(result, *, independent: float | None = None) -> None:
    """Converged, within 1.001 of the certified lower bound, the bound below an independent solve's cost, the
    written bodies positive semidefinite, and the certificate's cost the written model's."""
    fit = result.consistent
    assert fit.converged, fit.message
    certificate = fit.certificate
    assert certificate is not None and certificate.solver.startswith("clarabel")
    assert certificate.guaranteed_ratio <= 1.001, certificate.to_dict()
    assert certificate.cost >= (certificate.lower_bound - certificate.dual_error) * (1 - 1e-12)
    if independent is not None:
        assert certificate.lower_bound - certificate.dual_error <= independent * (1 + 1e-9)
        assert certificate.cost <= 1.001 * independent
    summary, K, _, _ = summary_of(result)
    r = summary.R @ fit.beta - summary.z
    assert float(r @ r) + summary.rho**2 == pytest.approx(certificate.cost, rel=1e-9)
    for J in written_pseudo_inertias(result):
        eig = np.linalg.eigvalsh(J)
        assert eig[0] >= -1e-12 * eig[-1], eig


def test_pseudo_rows_are_the_second_moments_of_point_masses() -> None:
    """svec(J) of conic.pseudo_rows against J = Σ m·[r; 1]·[r; 1]ᵀ of point masses (the definition, not the
    code's formula), for a body placed at indices 3…12 of a longer x; and back through _standard_of_pseudo."""
    from symbolic.identify.pseudo_inertia import standard_parameters

    J, m, c, Ic = point_masses(11, 5, 0.3, [0.2, -0.1, 0.05])
    block = tuple(range(3, 13))
    x = np.random.default_rng(12).normal(size=15)
    x[list(block)] = standard_parameters(m, c, Ic)
    np.testing.assert_allclose(conic.pseudo_matrix(x, block), J, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(conic._standard_of_pseudo(J, block, 15)[list(block)], x[list(block)], rtol=1e-12, atol=1e-14)


def test_noise_free_data_give_the_truth(arm) -> None:
    """A consistent truth (the nominal bodies, changed) without noise: the fit's base parameters are the
    truth's to 1e-8 in the metric of the fit, the certificate's optimum is ~0 above the rows' own residual."""
    truth = with_values(arm, {"m2": 2.4, "Izz2": 0.04, "cx2": 0.15, "Fv1": 0.5})
    result = identify_model(arm, data(arm, truth, noise=0.0, seed=2), consistent=True)
    reg, _ = model_base(arm)
    beta_truth = result.base.from_theta(theta_values(arm, reg, truth))
    summary, *_ = summary_of(result)
    assert np.linalg.norm(summary.R @ (result.consistent.beta - beta_truth)) <= 1e-8 * np.linalg.norm(summary.R @ beta_truth)
    assert result.consistent.converged, result.consistent.message


def test_consistent_least_squares_are_returned_exactly(arm) -> None:
    """With noise, a truth well inside the feasible set: the least squares are consistent and the
    consistent fit returns them (‖R·Δβ‖ ≤ 1e-9·‖R·β‖, the same relative error to 1e-9)."""
    truth = with_values(arm, {"m2": 2.4, "Izz2": 0.04, "Fv1": 0.5})
    result = identify_model(arm, data(arm, truth, noise=0.005, seed=3), consistent=True)
    summary, *_ = summary_of(result)
    beta = np.asarray(result.identification.values)
    assert np.linalg.norm(summary.R @ (result.consistent.beta - beta)) <= 1e-9 * np.linalg.norm(summary.R @ beta)
    assert result.consistent.relative_error == pytest.approx(result.identification.relative_error, rel=1e-9)
    check_certified(result)


def test_infeasible_truth_reaches_the_certified_optimum(arm) -> None:
    """An infeasible truth (Izz2 < 0 about the centre of mass): the least squares are not consistent, the
    answer is on the boundary, converged and certified within 1.001 (the arm has Fv ≥ 0 bounds: the convex
    form carries them)."""
    truth = with_values(arm, {"Izz2": -0.05, "cx2": 0.05})
    result = identify_model(arm, data(arm, truth, noise=0.01), consistent=True)
    assert result.consistent.relative_error > result.identification.relative_error
    assert result.values()["Fv1"] >= 0 and result.values()["Fv2"] >= 0
    check_certified(result)
    assert result.consistent.certificate.exact


def panda_result():
    sys.path.insert(0, str(ROOT / "tests"))
    from shared_data import panda_folder, panda_measurements

    folder = panda_folder()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = symbolic.derive(symbolic.robots.load("panda"))
    return identify_model(model, panda_measurements(folder), consistent=True)


@pytest.mark.slow
def test_panda_log_reaches_the_certified_global_optimum() -> None:
    """The Panda's measured log: converged, within 1.001 of the certified lower bound, which lies below an
    independent Burer–Monteiro solve's best cost (and the written model within 1.001 of that)."""
    result = panda_result()
    summary, K, prob, free = summary_of(result)
    independent = burer_monteiro(summary, K, prob, np.array([result.model.parameters[s] for s in free]))
    check_certified(result, independent=independent)
    assert result.consistent.certificate.exact


@pytest.mark.slow
def test_six_axis_arm_reaches_the_certified_optimum() -> None:
    """bench/consistent.py's 6-DOF arm (PUMA 560, hidden scaled bodies, 10 s, 2 % noise): its model writes
    products of inertia as 0 about free centres of mass, so the convex form is a relaxation whose bound holds
    for the model's problem too: converged and within 1.001 of it; the bound above the unconstrained least
    squares' cost."""
    sys.path.insert(0, str(ROOT / "bench"))
    from consistent import puma

    model, measured = puma(10.0)
    result = identify_model(model, measured, consistent=True)
    check_certified(result)
    certificate = result.consistent.certificate
    assert not certificate.exact and any("= 0 about a free centre of mass" in d for d in certificate.dropped)
    summary, *_ = summary_of(result)
    assert certificate.lower_bound - certificate.dual_error >= summary.rho**2 * (1 - 1e-12)


def test_mass_bounds_are_kept_by_the_convex_form() -> None:
    """The all-free arm lets the data-blind masses run off (tens of kg on the first axis); with ``min``/``max``
    on the masses in the model file the convex form keeps them inside (as linear inequalities on m) and the
    answer is still certified."""
    text = arm_text().replace("m1 = 3.0", "m1 = { value = 3.0, min = 1.0, max = 6.0 }")
    text = text.replace("m2 = 2.0", "m2 = { value = 2.0, min = 1.0, max = 4.0 }")
    model = symbolic.derive(symbolic.loads(text, "arm3d.toml"))
    truth = with_values(model, {"Izz2": -0.05, "cx2": 0.05})
    result = identify_model(model, data(model, truth, noise=0.01), consistent=True)
    values = result.values()
    assert 1.0 - 1e-9 <= values["m1"] <= 6.0 + 1e-9 and 1.0 - 1e-9 <= values["m2"] <= 4.0 + 1e-9, values
    check_certified(result)

"""Physically consistent identification benchmark (issues 23 §1, 38 §3): ``identify --consistent`` time, gap
and how far the written model is from the certified global optimum.

* The Franka Panda's measured log (Gaz et al. 2019, ../shared/data/franka_panda; skipped without it), the
  built-in 7-DOF model (no friction): the consistent fit alone (median of ``--repeat`` runs on the same
  least-squares summary) and the whole ``identify_model(..., consistent=True)`` (load, treatment,
  regressor, least squares, consistent fit), with the least-squares and the consistent relative errors.
* A synthetic 6-DOF arm, the built-in PUMA 560, its bodies scaled by hidden factors (the tests' hidden
  truth), τ from its regressor along a five-harmonic Fourier trajectory at 1 kHz with 2 % noise, for logs of
  10 s and 60 s: the consistent fit does not grow with the log.
* The path it replaced (bounded nonlinear least squares over every sample with finite-difference
  Jacobians, kept below as :func:`old_consistent_fit`) on the PUMA log of 10 s, in a subprocess stopped
  after ``--old-limit`` seconds (the issue measured 31 min 32 s on a 30 s 6-DOF log): the ratio is against it.

Each row also gives the written model's cost ‖y_w − W_w·β‖² over the certified lower bound of the global
optimum (the Lagrange dual of the convex form, Wensing et al. 2017, solved with Clarabel and recomputed in
NumPy: symbolic/identify/conic.py), and at most that ratio allowing for the dual point's rounding.

Goals: a 6- or 7-DOF arm in ≤ 10 s whatever the log's length (issue 23); the written model within 1.001× of
the global optimum, converged, ≤ 5 s (issue 38).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def puma(seconds: float, rate: float = 1000.0, noise: float = 0.02):
    """The PUMA 560 and a synthetic log of ``seconds`` (hidden truth of tests/test_identify_model.py)."""
    import symbolic
    from symbolic.data import Measurements
    from symbolic.identify.model import base_regressor, model_base
    from symbolic.numeric.base_parameters import theta_values
    from test_identify_model import fourier, hidden_truth

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = symbolic.derive(symbolic.robots.load("puma560"))
    reg, base = model_base(model)
    truth = hidden_truth(model, seed=3)
    t = np.arange(0.0, seconds, 1.0 / rate)
    q, qd, qdd = fourier(model.n, t, seed=5)
    beta = base.from_theta(theta_values(model, reg, truth))
    tau = base_regressor(model)(q, qd, qdd) @ beta
    tau = tau + np.random.default_rng(6).normal(0, 1, tau.shape) * noise * np.sqrt(np.mean(tau**2, axis=0))
    return model, Measurements.from_arrays(t, model.robot.generalized_coordinates, q, tau, qd=qd, qdd=qdd)


def fit_alone(result, repeat: int) -> float:
    """Median seconds of the consistent fit (QR of [W y] included) on the identification's own data."""
    from symbolic.identify.consistent import fit, problem, row_weights
    from symbolic.identify.known import fixed_symbols, parameter_bounds
    from symbolic.identify.model import geometric_parameters, model_base

    model, base, ident, obs = result.model, result.base, result.identification, result.observation
    reg, _ = model_base(model)
    fixed = geometric_parameters(model, reg) | fixed_symbols(model)
    free = [s for s in model.parameter_symbols if s not in fixed and any(s in e.free_symbols for e in reg.theta_expressions)]
    prob = problem(model, reg, free, parameter_bounds(model))
    K = np.zeros((len(base.names), len(reg.theta)))
    K[np.arange(len(base.independent)), list(base.independent)] = 1.0
    K[:, list(base.dependent)] = base.K
    weights = row_weights(ident.method, ident.coordinate_sigmas, obs.samples)
    p0 = np.array([model.parameters[s] for s in free])
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fit(prob, K, obs.W, obs.y, weights, p0, np.asarray(ident.values))
        runs.append(time.perf_counter() - t0)
    return statistics.median(runs)


def row(label: str, model, measurements, repeat: int) -> tuple[str, float]:
    from symbolic.identify.model import identify_model

    identify_model(model, measurements)  # warm: regressor evaluators built, compiled library cached
    t0 = time.perf_counter()
    plain = identify_model(model, measurements)
    t1 = time.perf_counter()
    result = identify_model(model, measurements, consistent=True)
    t2 = time.perf_counter()
    c = result.consistent
    alone = fit_alone(result, repeat)
    k = c.certificate
    ratios = "| | " if k is None else (f"{k.ratio:.7f} | {k.guaranteed_ratio:.7f}"
                                        f"{'' if k.exact else ' (relaxation)'} | ")
    line = (f"| {label} | {result.observation.samples} | {alone:.2f} | {t2 - t1:.2f} | {t1 - t0:.2f} | "
            f"{plain.identification.relative_error:.3f} | {c.relative_error:.3f} | {ratios}{c.evaluations} | "
            f"{'yes' if c.converged else 'no: ' + c.message} |")
    return line, alone


OLD = r'''
import sys, time, warnings
sys.path.insert(0, {tests!r}); sys.path.insert(0, {bench!r})
import numpy as np, sympy as sp
from consistent import puma, old_consistent_fit
from symbolic.identify.model import identify_model, model_base
model, m = puma({seconds})
result = identify_model(model, m)
reg, base = model_base(model)
t0 = time.perf_counter()
values = old_consistent_fit(model, reg, base, result.identification, result.observation)
print(time.perf_counter() - t0)
'''


def old_consistent_fit(model, reg, base, ident, observation):
    """The consistent fit this benchmark replaces (symbolic/identify/model.py before issue 23): bounded
    nonlinear least squares over every sample of W·β(p) − y, finite-difference Jacobian, penalty residuals
    on each body's eigenvalues, a weak pull to the nominal values."""
    import scipy.optimize
    import sympy as sp

    from symbolic.identify.known import parameter_bounds
    from symbolic.identify.model import geometric_parameters

    fixed = geometric_parameters(model, reg)
    nominal = model.parameter_vector
    symbols = list(nominal.symbols)
    free = [s for s in symbols if s not in fixed and any(s in e.free_symbols for e in reg.theta_expressions)]
    p0 = nominal.array()
    index = [nominal.index(s) for s in free]
    theta_of = sp.lambdify([symbols], list(reg.theta_expressions), modules="numpy")
    bounds = parameter_bounds(model)
    lower = np.array([bounds.get(s, (-np.inf, np.inf))[0] for s in free])
    upper = np.array([bounds.get(s, (-np.inf, np.inf))[1] for s in free])
    weights = np.repeat(1.0 / np.asarray(ident.coordinate_sigmas), observation.samples)
    W, y = observation.W * weights[:, None], observation.y * weights
    scale = max(np.linalg.norm(y), 1e-300)
    tensors = [sp.lambdify([symbols], b.inertia_tensor, modules="numpy") for b in model.robot.bodies]
    start = np.clip(p0[index], lower, upper)
    typical = np.maximum(np.abs(start), 1e-3 * max(np.abs(start).max(initial=0.0), 1e-12))
    prior = 1e-6 * scale / np.sqrt(len(free))

    def residual(x):
        p = p0.copy()
        p[index] = x
        beta = base.from_theta(np.array(theta_of(p), float))
        penalty = []
        for tensor in tensors:
            a, b, c = np.linalg.eigvalsh(np.array(tensor(p), float))
            penalty += [1e3 * scale * max(0.0, -a), 1e3 * scale * max(0.0, c - a - b)]
        return np.concatenate([W @ beta - y, penalty, prior * (x - start) / typical])

    return scipy.optimize.least_squares(residual, start, bounds=(lower, upper), x_scale=typical, method="trf").x


def old_path(seconds: float, limit: float) -> str:
    code = OLD.format(tests=str(ROOT / "tests"), bench=str(ROOT / "bench"), seconds=seconds)
    try:
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=limit,
                              env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "HOME": str(Path.home())})
    except subprocess.TimeoutExpired:
        return f"> {limit:.0f}"
    if done.returncode != 0:
        return f"failed ({done.stderr.strip().splitlines()[-1] if done.stderr.strip() else done.returncode})"
    return f"{float(done.stdout.split()[-1]):.1f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/consistent.md")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--old-limit", type=float, default=600.0)
    args = parser.parse_args()
    lines = ["# Physically consistent identification (issues 23 §1, 38 §3)", "",
             f"Seconds; the fit alone is the median of {args.repeat} runs on the same least-squares summary "
             "(QR of [W y] included); `identify` is one run of `identify_model(..., consistent=True)` after a warm-up "
             "(data treatment, regressor and least squares included), beside the same without `--consistent`. "
             "Relative errors in % over all samples.", "",
             "Cost ratio: the written model's weighted cost over the certified lower bound of the global optimum; "
             "at most: allowing for the dual point's rounding (`Certificate.guaranteed_ratio`); (relaxation): the "
             "model writes products of inertia as 0 about free centres of mass, and the bound is that of the convex "
             "relaxation without them (a bound for the model's problem too). Evaluations: Clarabel's interior-point "
             "iterations (primal and dual), plus the log-Cholesky passes' evaluations on a relaxation.", "",
             "| log | samples after decimation | consistent fit | identify --consistent | identify | LS error % | "
             "consistent error % | cost ratio | at most | evaluations | converged |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    fits: dict[str, float] = {}
    try:
        import symbolic
        from shared_data import PANDA_FILES, panda_measurements

        folder = ROOT.parent / "shared" / "data" / "franka_panda"
        if all((folder / f).is_file() for f in PANDA_FILES):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = symbolic.derive(symbolic.robots.load("panda"))
            line, fits["panda"] = row("Franka Panda, measured, 21 s (7 DOF)", model, panda_measurements(folder), args.repeat)
            lines.append(line)
        else:
            lines.append("| Franka Panda | skipped: ../shared/data/franka_panda not found | | | | | | | | | |")
    except ImportError as error:
        lines.append(f"| Franka Panda | skipped: {error} | | | | | | | | | |")
    for seconds in (10.0, 60.0):
        model, measured = puma(seconds)
        line, fits[f"puma {seconds:.0f}"] = row(f"PUMA 560, synthetic, {seconds:.0f} s at 1 kHz (6 DOF)", model, measured,
                                                args.repeat)
        lines.append(line)
    old = old_path(10.0, args.old_limit)
    try:
        ratio = f": ratio ×{fits['puma 10'] / float(old.lstrip('> ')):.4f}{' or less' if old.startswith('>') else ''}"
    except ValueError:
        ratio = ""
    lines += ["", f"The path replaced (in a subprocess, stopped after {args.old_limit:.0f} s), on the 10 s PUMA log: {old} s "
              f"(the consistent fit now {fits['puma 10']:.2f} s{ratio}).", ""]
    lines += ["Goal (issue 23): a 6- or 7-DOF arm in ≤ 10 s whatever the log's length. The issue's measurement of the "
              "path replaced: 31 min 32 s on a 6-DOF arm with a 30 s log, the written model's gap 10.8 % against 3.5 % for "
              "its fit.", "",
              "Goal (issue 38 §3): the written model within 1.001× of the global optimum on the Panda and the 6-DOF arm "
              "logs, converged, ≤ 5 s whatever the log's length. Before: the Panda's fit reported converged false, its "
              "written model 1.050× the optimum in relative error (the issue's measurement).", ""]
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

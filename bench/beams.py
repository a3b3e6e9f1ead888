"""Flexible links in identification and in the workflow (issue 21 §6): the figures of docs/data.md, "Flexible links".

* IDIM-LS of the simulated rig of tests/test_identify_beams.py (Madill's beam, one horizontal and one
  vertical mode, light hub, soft beam, 2 kHz, 20 s): z = (β̂ − β)/σ of every base parameter per seed.
* Central differences against a lightly damped mode: Madill's beam as shipped (first mode 35 Hz) sampled
  at 1 kHz, the base parameters with q̇, q̈ from the treatment and with the exact columns.
* Errors in variables on the homogeneous rows: the planar flexible link of tests/workflow_cases.py, hub of
  0.677 and 0.05 kg·m², WLS and OLS, relative errors of the beam's parameters.
* The workflow on the planar link: model = truth, damper left out, hub friction left out; what is named
  per seed, and the time.

Run: ``python bench/beams.py --out bench/results/beams.md`` (about 3 minutes on one core).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def rig(lines: list[str], seeds: int) -> None:
    import test_identify_beams as t
    from symbolic.data import Measurements
    from symbolic.identify.model import identify_model
    from symbolic.identify.processing import Settings

    t.SECONDS = 20.0
    lines += ["## IDIM-LS of the simulated rig", "", "z = (β̂ − β)/σ, WLS, bandwidth 5 Hz:", "",
              "| seed | z of " + ", ".join(("ZZ_e (J0)", "ρ", "EI_v", "EI_w", "m_p")) + " | largest abs(z) | identification (s) |",
              "|---|---|---|---|"]
    model = t.rig(1)
    for seed in range(seeds):
        times, q, tau = t.logged(1, seed)
        start = time.perf_counter()
        result = identify_model(model, Measurements.from_arrays(times, model.robot.generalized_coordinates, q, tau),
                                settings=Settings(bandwidth=5.0))
        elapsed = time.perf_counter() - start
        z = (result.identification.values - t.true_base(model)) / result.identification.sigmas
        lines.append(f"| {seed} | {', '.join(f'{v:+.2f}' for v in z)} | {np.abs(z).max():.2f} | {elapsed:.2f} |")
    lines.append("")


def differences(lines: list[str]) -> None:
    import scipy.integrate

    import symbolic
    from symbolic.data import Measurements
    from symbolic.identify.model import identify_model, model_base
    from symbolic.identify.processing import Settings
    from symbolic.numeric import numeric_model
    from symbolic.numeric.base_parameters import theta_values

    text = symbolic.robots.path("madill_beam").read_text().replace("modes_v = 3", "modes_v = 1").replace("modes_w = 1", "modes_w = 0")
    model = symbolic.derive(symbolic.loads(text, "madill_beam, 1 mode"))
    num, n, p = numeric_model(model), model.n, numeric_model(model).p0
    w = 2 * np.pi * np.array([0.3, 0.7, 1.3, 2.9, 5.3, 9.1, 17.0, 31.0])
    amplitude, phase = 0.5 / (w / (2 * np.pi)) ** 0.8, np.random.default_rng(1).uniform(0, 2 * np.pi, len(w))

    def torque(tk, x):
        return 40.0 * (amplitude @ np.sin(w * tk + phase) - x[0]) + 4.0 * (amplitude * w @ np.cos(w * tk + phase) - x[n])

    def rate(tk, x):
        tau = np.zeros(n)
        tau[0] = torque(tk, x)
        return np.concatenate([x[n:], num.forward_dynamics(x[:n], x[n:], tau, p)])

    times = np.arange(0.0, 10.0, 1e-3)
    run = scipy.integrate.solve_ivp(rate, (0, times[-1]), np.zeros(2 * n), t_eval=times, method="DOP853", rtol=1e-9, atol=1e-12)
    q, qd = run.y[:n].T, run.y[n:].T
    tau = np.zeros_like(q)
    tau[:, 0] = [torque(tk, x) for tk, x in zip(times, run.y.T)]
    qdd = np.array([num.forward_dynamics(a, b, c, p) for a, b, c in zip(q, qd, tau)])
    reg, base = model_base(model)
    truth = base.from_theta(theta_values(model, reg, p))
    frequency = np.sort(np.abs(np.linalg.eigvals(num.linearize(np.zeros(2 * n), np.zeros(n))[0])))[-1] / (2 * np.pi)
    lines += ["## Central differences against a lightly damped mode", "",
              f"Madill's beam as shipped, one mode, {frequency:.1f} Hz with the hub free, sampled at 1 kHz "
              f"(two central differences read q̈ at that frequency {100 * (1 - (np.sinc(2 * frequency / 1000)) ** 2):.2f} % low), "
              "noise-free, bandwidth 40 Hz, OLS; relative error of the base parameters:", "",
              "| q̇, q̈ | " + " | ".join(base.names) + " |", "|---|" + "---|" * len(base.names)]
    for label, extra in (("central differences", {}), ("exact columns", {"qd": qd, "qdd": qdd})):
        m = Measurements.from_arrays(times, model.robot.generalized_coordinates, q, tau, **extra)
        values = identify_model(model, m, settings=Settings(bandwidth=40.0), method="ols").identification.values
        lines.append(f"| {label} | " + " | ".join(f"{100 * (v / b - 1):+.3g} %" for v, b in zip(values, truth)) + " |")
    lines.append("")


def shrinkage(lines: list[str]) -> None:
    import symbolic
    import workflow_cases as cases
    from symbolic.identify.model import identify_model

    from symbolic.identify.processing import Settings

    lines += ["## Errors in variables on the homogeneous rows", "",
              "The planar link (tip 0.1 kg, EI 10 N·m², damper 3.3), seed 1, 1 % force noise, deflection noise 0.1 % "
              "of its range, bandwidth 10 Hz (the default at 500 Hz); relative error of the re-identified parameters:", "",
              "| hub (kg·m²) | rate (Hz) | method | I_h | ρ | EI | m_t | c_b |", "|---|---|---|---|---|---|---|---|"]
    for hub, rate in ((0.677, 500.0), (0.05, 500.0), (0.05, 2000.0)):
        truth = cases.planar_flexible_link(hub=hub)
        data = cases.measurements(truth, 1, 0.01, measured=("q0",), pulses=0.1 if hub < 0.1 else 0.5,
                                  unactuated=("link_nu1",), deflection_noise=1e-3, rate=rate)
        model = symbolic.derive(symbolic.loads(truth, "truth"))
        for method in ("wls", "ols"):
            found = identify_model(model, data, method=method, settings=Settings(bandwidth=10.0)).parameters
            lines.append(f"| {hub} | {rate:g} | {method.upper()} | " + " | ".join(
                f"{100 * (found[k].value / found[k].nominal - 1):+.3g} % ({(found[k].value - found[k].nominal) / found[k].sigma:+.1f}σ)"
                for k in ("I_h", "rho", "EIv", "m_t", "c_b")) + " |")
    lines.append("")


def workflow(lines: list[str], seeds: int) -> None:
    import symbolic
    import workflow_cases as cases
    from symbolic.workflow import diagnose

    models = {"truth": cases.planar_flexible_link(), "damper left out": cases.planar_flexible_link(damped=False),
              "hub friction left out": cases.planar_flexible_link().replace('[[friction]]\ncoordinate = "q0"\nviscous = "Fv"\n', "")}
    lines += ["## The workflow on the planar flexible link", "", "| seed | model | named | held-out gap before → after | time (s) |",
              "|---|---|---|---|---|"]
    for seed in range(1, seeds + 1):
        data = cases.measurements(models["truth"], seed, 0.01, measured=("q0",), pulses=0.1, unactuated=("link_nu1",),
                                  deflection_noise=1e-3)
        for label, text in models.items():
            with tempfile.TemporaryDirectory() as folder:
                path = Path(folder) / "link.toml"
                path.write_text(text)
                start = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", symbolic.ModelWarning)
                    d = diagnose(path, data, out=Path(folder) / "out", figures=False)
                elapsed = time.perf_counter() - start
            named = ", ".join(f"{f.effect} on {f.coordinate} ({', '.join(f'{k} {v:.4g}' for k, v in f.parameters.items())})"
                              for f in d.found) or "nothing"
            lines.append(f"| {seed} | {label} | {named} | {d.before.gap['validation']:.3g} → {d.after.gap['validation']:.3g} % | {elapsed:.1f} |")
    lines.append("")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench/results/beams.md")
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    lines = ["# Flexible links in identification (bench/beams.py)", ""]
    rig(lines, args.seeds)
    differences(lines)
    shrinkage(lines)
    workflow(lines, args.seeds + 1)
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())

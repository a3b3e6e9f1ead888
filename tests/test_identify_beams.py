"""IDIM-LS of a flexible link's beam parameters from a simulated log (symbolic.identify with [[beam]]).

The rig: Madill's experimental beam (madill_beam.toml) with one horizontal mode, on a hub turning about the
vertical, with its vertical mode (gravity sags it, nothing else moves it) or bending in the horizontal plane
only (``modes_w = 0``). The truth is written here — a lighter hub and a softer beam than the file's, so that
the first mode rings at 3.7 Hz as a laboratory flexible link does and the hub's torque feels the beam — and
the log is made here: the truth's forward dynamics integrated by SciPy (DOP853, rtol 1e-10) under a PD loop
on the hub following a multisine, sampled at 2 kHz; the hub's torque is logged, the modal coordinates are
unactuated (τ = 0 on their rows). Nothing of the truth reaches the identification but the log.

The deflections' equations are homogeneous (τ = 0 on the modal rows): any common multiple of ρ, EI and m_p
satisfies them, and identification refuses to choose (tests/test_known.py); the density is weighed
(``--fix rho``, the file's value the truth's here) and EI, m_p and J0 are measured against it.

* Noise-free log with exact q̇, q̈ columns: the model parameters within 1e-4 (what is left is the position
  filter's attenuation at the multisine's highest line).
* Realistic log: the hub angle from an 18-bit encoder, the deflections with white gauge noise of 0.1 % of
  their range, 2 % force noise; positions only (q̇, q̈ by the IDIM-LS treatment, bandwidth 5 Hz): every
  base parameter and model parameter within 3σ of the truth (seeds 0–4 at 20 s measured
  |z| ≤ 2.3; the suite runs seed 1 at 12 s).
* The same log with the deflection as two root strain gauges (Madill Appendix C), converted to modal
  coordinates by the experiment file's [signals] with the factor 1/(h φ₁''(0)) computed here by quadrature:
  ``symbolic identify`` on the experiment recovers the parameters within 3σ.
* The built-in flexible five-bar (Madill 3.13) through ``symbolic identify`` and ``symbolic diagnose``: its
  beam's ρ, EI and m_p within 3σ, nothing named when the model is the truth.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
import scipy.optimize

import symbolic
from symbolic.cli import main
from symbolic.data import Measurements
from symbolic.identify.model import identify_model, model_base
from symbolic.identify.processing import Settings
from symbolic.numeric import numeric_model
from symbolic.numeric.base_parameters import theta_values

TRUTH = {"J0": 0.034, "rho": 0.25, "EI": 1.8, "M_p": 0.09}
"""Hub inertia (kg·m²), density (kg/m), bending stiffness (N·m²) and tip mass (kg) of the simulated rig."""
RATE, SECONDS = 2000.0, 12.0


@lru_cache(maxsize=None)
def rig(modes_w: int) -> symbolic.DynamicModel:
    text = symbolic.robots.path("madill_beam").read_text().replace("modes_v = 3", "modes_v = 1")
    text = text.replace("rho = { value = 0.163,", f"rho = {{ value = {TRUTH['rho']!r},")  # weighed: kept fixed
    return symbolic.derive(symbolic.loads(text.replace("modes_w = 1", f"modes_w = {modes_w}"), f"rig ({modes_w} vertical modes)"))


def truth(model: symbolic.DynamicModel) -> np.ndarray:
    p = numeric_model(model).p0.copy()
    names = [s.name for s in model.parameter_symbols]
    for name, value in TRUTH.items():
        p[names.index(name)] = value
    return p


@lru_cache(maxsize=None)
def simulated(modes_w: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t, q, q̇, q̈, τ of the truth under a PD loop on the hub (gains 2 N·m/rad, 0.3 N·m·s/rad) following
    a multisine of 0.2–6.3 Hz, from rest with the beam sagging under gravity."""
    model = rig(modes_w)
    num, p, n = numeric_model(model), truth(model), model.n
    q0 = np.zeros(n)
    stiffness = np.array([num.stiffness(e, p) for e in np.eye(n)]).T  # linear in the modal coordinates
    q0[1:] = -np.linalg.solve(stiffness[1:, 1:], num.gravity(q0, p)[1:])
    rng = np.random.default_rng(seed)
    w = 2 * np.pi * np.array([0.2, 0.5, 0.9, 1.7, 2.9, 4.1, 6.3])
    amplitude, phase = 0.4 / np.sqrt(w / (2 * np.pi)), rng.uniform(0, 2 * np.pi, len(w))

    def hub_torque(t: float, x: np.ndarray) -> float:
        return 2.0 * (amplitude @ np.sin(w * t + phase) - x[0]) + 0.3 * (amplitude * w @ np.cos(w * t + phase) - x[n])

    def rate(t: float, x: np.ndarray) -> np.ndarray:
        tau = np.zeros(n)
        tau[0] = hub_torque(t, x)
        return np.concatenate([x[n:], num.forward_dynamics(x[:n], x[n:], tau, p)])

    t = np.arange(0.0, SECONDS, 1.0 / RATE)
    run = scipy.integrate.solve_ivp(rate, (0.0, t[-1]), np.concatenate([q0, np.zeros(n)]), t_eval=t, method="DOP853",
                                    rtol=1e-10, atol=1e-12)
    assert run.success
    q, qd = run.y[:n].T, run.y[n:].T
    tau = np.zeros_like(q)
    tau[:, 0] = [hub_torque(tk, xk) for tk, xk in zip(t, run.y.T)]
    qdd = np.array([num.forward_dynamics(a, b, c, p) for a, b, c in zip(q, qd, tau)])
    return t, q, qd, qdd, tau


def logged(modes_w: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """t, q, τ as a rig logs them: an 18-bit hub encoder, gauge noise 0.1 % of the deflections' range, 2 %
    force noise."""
    t, q, _, _, tau = simulated(modes_w, seed)
    rng = np.random.default_rng(seed + 100)
    resolution = 2 * np.pi / 2**18
    q = q.copy()
    q[:, 0] = np.round(q[:, 0] / resolution) * resolution
    q[:, 1:] += rng.normal(0, 1e-3 * np.ptp(q[:, 1]), q[:, 1:].shape)
    tau = tau.copy()
    tau[:, 0] += rng.normal(0, 0.02 * np.sqrt(np.mean(tau[:, 0] ** 2)), len(t))
    return t, q, tau


def true_base(model: symbolic.DynamicModel) -> np.ndarray:
    reg, base = model_base(model)
    return base.from_theta(theta_values(model, reg, truth(model)))


@pytest.mark.parametrize("modes_w", [1, 0])
def test_noise_free_log_gives_the_truth(modes_w: int) -> None:
    model = rig(modes_w)
    t, q, qd, qdd, tau = simulated(modes_w, 1)
    data = Measurements.from_arrays(t, model.robot.generalized_coordinates, q, tau, qd=qd, qdd=qdd)
    with pytest.raises(symbolic.IdentificationError, match="no actuator.*--fix"):
        identify_model(model, data, settings=Settings(bandwidth=5.0), method="ols")
    result = identify_model(model, data, settings=Settings(bandwidth=5.0), method="ols", fix=("rho",))
    error = {name: result.parameters[name].value / value - 1 for name, value in TRUTH.items() if name != "rho"}
    assert max(map(abs, error.values())) < 1e-4, error


@pytest.mark.parametrize("modes_w", [1, 0])
def test_beam_parameters_recovered_within_sigma(modes_w: int) -> None:
    model = rig(modes_w)
    t, q, tau = logged(modes_w, 1)
    result = identify_model(model, Measurements.from_arrays(t, model.robot.generalized_coordinates, q, tau),
                            settings=Settings(bandwidth=5.0), fix=("rho",))
    ident = result.identification
    assert {"EIv_beam", "mp_beam"} <= set(ident.names) and ident.fixed == ("rho_beam",)
    for name, value in {k: v for k, v in TRUTH.items() if k != "rho"}.items():  # EI from EIv (and EIw: combined)
        estimate = result.parameters[name]
        assert abs(estimate.value - value) <= 3 * estimate.sigma, (name, estimate)
    assert result.parameters["EI"].source == ("base parameters EIv_beam, EIw_beam" if modes_w else "base parameter EIv_beam")


def root_curvature(length: float) -> float:
    """φ₁''(0) of the first clamped-free mode normalised to ∫₀ˡ φ² dx = 1, by root finding and quadrature."""
    k = scipy.optimize.brentq(lambda k: np.cos(k) * np.cosh(k) + 1, 1.0, 2.5, xtol=1e-15)
    s = (np.cosh(k) + np.cos(k)) / (np.sinh(k) + np.sin(k))
    shape = lambda x: np.cosh(k * x) - np.cos(k * x) - s * (np.sinh(k * x) - np.sin(k * x))  # noqa: E731
    norm = np.sqrt(scipy.integrate.quad(lambda x: shape(x) ** 2, 0, 1, epsabs=1e-14, epsrel=1e-12)[0])
    return 2 * k**2 / norm / length**2.5  # Φ''(0) = 2k²


def test_cli_identifies_the_beam_from_root_strains(tmp_path: Path, capsys) -> None:
    """The log holds the hub angle (rad), the hub torque and two root strain gauges (amplified strain
    ε = h v''(0), ε = b w''(0), Appendix C); the experiment converts them to the modal coordinates with one
    constant each and says the modal coordinates are unactuated."""
    model = rig(1)
    t, q, tau = logged(1, 1)
    length = dict(zip([s.name for s in model.parameter_symbols], numeric_model(model).p0))["L"]
    h, b = 0.0016, 0.0095  # half-thickness and half-width (m) of the gauges' faces
    curvature = root_curvature(length)
    columns = {"time": t, "angle": q[:, 0], "torque": tau[:, 0], "strain_v": h * curvature * q[:, 1],
               "strain_w": b * curvature * q[:, 2], "zero": np.zeros_like(t)}
    log = tmp_path / "rig.csv"
    np.savetxt(log, np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns), comments="", fmt="%.17g")
    (tmp_path / "rig.toml").write_text(symbolic.robots.path("madill_beam").read_text().replace("modes_v = 3", "modes_v = 1")
                                       .replace("rho = { value = 0.163,", f"rho = {{ value = {TRUTH['rho']!r},"))
    experiment = tmp_path / "rig.experiment.toml"
    experiment.write_text(f'''data = "rig.csv"
model = "rig.toml"

[constants]
per_strain_v = {float(1 / (h * curvature))!r}
per_strain_w = {float(1 / (b * curvature))!r}

[signals]
t = "time"
q_q0 = "angle"
q_beam_nu1 = "strain_v * per_strain_v"
q_beam_eta1 = "strain_w * per_strain_w"
tau_q0 = "torque"
tau_beam_nu1 = "zero"
tau_beam_eta1 = "zero"

[identification]
bandwidth = 5.0
''')
    assert main(["-q", "identify", str(tmp_path / "rig.toml"), str(experiment), "--fix", "rho", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    for name, value in {k: v for k, v in TRUTH.items() if k != "rho"}.items():
        estimate = result["parameters"][name]
        assert abs(estimate["value"] - value) <= 3 * estimate["sigma"], (name, estimate)


# -- the built-in flexible five-bar (Madill 3.13) through the command line ---------------------------------


@lru_cache(maxsize=None)
def fivebar_log(folder: Path) -> Path:
    """The five-bar with link 5 flexible moved along Swevers-type Fourier series (five harmonics of 0.1 Hz;
    ±0.8 rad on the joints, ±2 mm·m^(1/2) on the modal coordinates) with τ from the model's inverse dynamics
    and 1 % noise: a check that the beam's regressor identifies the built-in model (τ on the modal rows is
    what would move the beam so, not an experiment's zero)."""
    model = symbolic.derive(symbolic.robots.load("fivebar_flexible"))
    num, n = numeric_model(model), model.n
    t = np.arange(0.0, 20.0, 1 / 200.0)
    rng = np.random.default_rng(3)
    wf, k = 2 * np.pi * 0.1, np.arange(1, 6)
    modal = np.array(["_nu" in c or "_eta" in c for c in model.robot.generalized_coordinates])
    a, b = rng.normal(0, 1, (n, 5)), rng.normal(0, 1, (n, 5))
    scale = np.where(modal, 2e-3, 0.8)[:, None] / np.sum(np.hypot(a, b) / (wf * k), axis=1, keepdims=True)
    a, b, phase = a * scale, b * scale, np.outer(t, k * wf)
    q = np.sin(phase) @ (a / (wf * k)).T - np.cos(phase) @ (b / (wf * k)).T + np.where(np.arange(n) == 2, np.pi, 0.0)
    qd = np.cos(phase) @ a.T + np.sin(phase) @ b.T
    qdd = -(np.sin(phase) * k * wf) @ a.T + (np.cos(phase) * k * wf) @ b.T
    tau = np.array([num.inverse_dynamics(*x) for x in zip(q, qd, qdd)])
    tau += rng.normal(0, 1, tau.shape) * 0.01 * np.sqrt(np.mean(tau**2, axis=0))
    path = folder / "fivebar_flexible.csv"
    symbolic.data.write(Measurements.from_arrays(t, model.robot.generalized_coordinates, q, tau), path)
    return path


def test_identify_accepts_the_flexible_fivebar(tmp_path: Path, capsys) -> None:
    assert main(["-q", "identify", "fivebar_flexible", str(fivebar_log(tmp_path)), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    for name, value in {"rho": 0.163, "EI": 88.32, "m_p": 0.043}.items():  # the file's values: the truth here
        estimate = result["parameters"][name]
        assert abs(estimate["value"] - value) <= 3 * estimate["sigma"], (name, estimate)
    names = [p["name"] for p in result["base_parameters"]]
    assert {"rho_link5", "EIv_link5", "EIw_link5", "mp_link5"} <= set(names)


@pytest.mark.slow
def test_diagnose_accepts_the_flexible_fivebar(tmp_path: Path, capsys) -> None:
    """The model is the truth: nothing named (17 s)."""
    assert main(["-q", "diagnose", "fivebar_flexible", str(fivebar_log(tmp_path)), "--out", str(tmp_path / "out"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["found"] == [] and result["gap_before"]["validation"] < 1.0
    assert result["gap_detail"]["before"]["estimation"]["force"]["link5_nu1"] is not None  # τ logged on the modal rows here

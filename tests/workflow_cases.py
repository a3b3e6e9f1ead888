"""Synthetic hidden-truth cases for the discrepancy workflow (tests/test_workflow*.py).

The truth is written in the tests, as model-file text (tests/models.py) with the effect (a ``[[friction]]`` key, a
``[[force]]``, a rotor inertia, a compliant load); the data are the truth model simulated in closed
loop (:func:`symbolic.simulation.simulator.simulate`, a PD loop with an encoder, following a Swevers-type
reference: five harmonics of a 0.1 Hz fundamental per joint), with white noise on the logged force
and the positions quantised. The workflow is then given the model
*without* the effect and the data: nothing of the truth reaches the search code.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

import symbolic
from symbolic.data import Experiment, Measurements
from symbolic.numeric import numeric_model
from symbolic.simulation.simulator import simulate

# the models (tests/models.py), here for the tests that name them cases.arm, cases.axis, ...
from models import (ARM_FRICTION1, ARM_FRICTION2, ARM_PARAMETERS, arm, axis,  # noqa: F401
                    flexible_link, rigid_link, with_load)

def trajectory(n: int, t: np.ndarray, seed: int, amplitude: float = 1.2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈: per joint a finite Fourier series (5 harmonics of 0.1 Hz, random coefficients) about a
    random mean position; ``amplitude`` bounds the speed (rad/s)."""
    rng = np.random.default_rng(seed)
    wf = 2 * np.pi * 0.1
    k = np.arange(1, 6)
    a, b = rng.normal(0, 1, (n, 5)), rng.normal(0, 1, (n, 5))
    scale = amplitude / np.sum(np.hypot(a, b) / (wf * k), axis=1, keepdims=True)
    a, b = a * scale, b * scale
    q0 = rng.uniform(-0.3, 0.3, n)
    phase = np.outer(t, k * wf)
    s = np.sin(phase) @ (a / (wf * k)).T - np.cos(phase) @ (b / (wf * k)).T
    sd = np.cos(phase) @ a.T + np.sin(phase) @ b.T
    sdd = -(np.sin(phase) * k * wf) @ a.T + (np.cos(phase) * k * wf) @ b.T
    return q0 + s, sd, sdd


CONTROL_BANDWIDTH_HZ = 4.0
"""Closed-loop bandwidth of the synthetic PD loops (well above the 0.5 Hz the excitation reaches)."""


def controller_table(model, q0: np.ndarray, resolution: float, coordinates: tuple[str, ...]) -> dict:
    """A PD loop per measured coordinate, tuned on the truth's inertia at ``q0``: natural frequency
    :data:`CONTROL_BANDWIDTH_HZ`, damping 0.7 (the way a commissioning engineer would tune it), an encoder
    of ``resolution`` and a 2-tap average on the backward-difference velocity, as on EMPS."""
    num = numeric_model(model)
    inertia = np.diag(num.inertia(np.concatenate([q0, np.zeros(model.n - len(q0))])))
    names = list(model.robot.generalized_coordinates)
    w = 2 * np.pi * CONTROL_BANDWIDTH_HZ
    d = np.array([inertia[names.index(c)] for c in coordinates])
    return {"kind": "pd", "coordinates": list(coordinates), "kp": [float(x) for x in d * w**2],
            "kd": [float(x) for x in 2 * 0.7 * w * d], "reference": "ref",
            "quantisation": [resolution] * len(coordinates), "velocity_filter": [0.5, 0.5]}


def measurements(text: str, seed: int, noise: float, seconds: float = 40.0, rate: float = 500.0,
                 resolution: float = 2 * np.pi / 2**20, measured: tuple[str, ...] | None = None,
                 pulses: float = 0.0, held: bool = False, logged_feedforward: bool = False,
                 current: tuple[float, int] | None = None, unactuated: tuple[str, ...] = (),
                 deflection_noise: float = 0.0) -> Measurements:
    """Data of the truth model ``text`` simulated in closed loop (:func:`symbolic.simulation.simulator.simulate`):
    a PD loop (:func:`controller_table`) with a computed-torque feedforward (:func:`_feedforward`) follows
    the Fourier reference, reads an encoder of ``resolution`` (default 20 bits per turn: with 18 bits, the twice-differentiated quantisation left in q̈ below the 50 Hz cut-off — errors in the regressor that the F-test does not model — made 1–2 % effects at the band edge significant);
    the log holds the quantised positions of the ``measured`` coordinates (default: the model's
    ``coordinates``, not the modal or added ones), the force (centred on the samples) with white noise (``noise`` ×
    τ's rms per coordinate; sensor noise, not acting on the plant) and the reference; the controller
    table is attached as an experiment's would be. ``pulses`` > 0 adds to the drive a square wave of
    period 1 s and that amplitude (in force units), as EMPS's pulse set does: its edges excite resonances
    that the smooth reference does not reach. ``held=True`` logs the held command itself at t_k (as EMPS's
    log of the drive voltage does), which leads the force acting over the sample by half a sample.
    ``logged_feedforward``: the log keeps the feedforward
    (columns ``ff_<c>``) and the controller table adds it as its disturbance, so that a simulation of a
    model in the logged loop (``diagnose(simulate=True)``) is driven as the truth was. ``current`` = (level,
    bits) adds the force measured as a drive's current (:func:`current_like`) after the white noise.
    ``unactuated``: coordinates logged as well, outside the loop and with zero force (a link's deflection, a
    beam's modal coordinates): quantised like the others (an encoder on the deflection), or, with
    ``deflection_noise`` > 0, with white noise of that fraction of the largest of their ranges instead (strain
    gauges' noise floor, the same on each)."""
    model = symbolic.derive(symbolic.loads(text, "<truth>"))
    coordinates = tuple(measured or model.robot.coordinates)
    t = np.arange(0.0, seconds, 1.0 / rate)
    reference, rd, rdd = trajectory(len(coordinates), t, seed)
    table = controller_table(model, reference[0], resolution, coordinates)
    # the kind "pd" damps the measured velocity, not the tracking error's: the velocity feedforward kd·ṙ
    # completes it to a PD on the error (else the axis lags 2ζ/ω behind the reference)
    feedforward = _feedforward(model, coordinates, reference, rd, rdd, t) + rd * np.asarray(table["kd"])
    feedforward = feedforward + pulses * np.where(np.floor(t) % 2 == 0, 0.5, -0.5)[:, None]
    table["disturbance"] = [f"ff_{c}" for c in coordinates]
    extras = {f"ff_{c}": feedforward[:, k] for k, c in enumerate(coordinates)}
    drive = Measurements.from_arrays(t, coordinates, reference, np.zeros_like(reference), ref=reference, extras=extras)
    run = simulate(model, drive, controller=table)
    names = list(run.simulated.coordinates)
    order = [names.index(c) for c in coordinates]
    q = np.asarray(run.simulated.q)[:, order]
    command = np.asarray(run.simulated.tau)[:, order]
    free = np.asarray(run.simulated.q)[:, [names.index(c) for c in unactuated]]
    # the force the controller holds over [t_k, t_k+1), reported at t_k as an integrating current sensor
    # does: its mean over [t_k − T/2, t_k + T/2], aligned with the positions (a log of the held command
    # leads them by half a sample, which the inverse model reads as a small inertia or lag term)
    tau = command if held else np.concatenate([command[:1], 0.5 * (command[1:] + command[:-1])])
    rng = np.random.default_rng(seed + 1000)
    tau = tau + rng.normal(0, 1, tau.shape) * noise * np.sqrt(np.mean(tau**2, axis=0))
    if current is not None:
        tau = current_like(tau, rng, *current)
    if unactuated:
        if deflection_noise > 0:
            free = free + rng.normal(0, 1, free.shape) * deflection_noise * np.ptp(free, axis=0).max()
        else:
            free = np.round(free / resolution) * resolution
        reference = np.hstack([reference, np.zeros_like(free)])  # the loop holds no reference for them
    q = np.round(q / resolution) * resolution
    if unactuated:
        q, tau, coordinates = np.hstack([q, free]), np.hstack([tau, np.zeros_like(free)]), coordinates + tuple(unactuated)
    logged = Measurements.from_arrays(t, coordinates, q, tau, ref=reference, extras=extras if logged_feedforward else None)
    if logged_feedforward:
        return Experiment.of(logged, controller=table)
    return Experiment.of(logged, controller={k: v for k, v in table.items() if k != "disturbance"})


def current_like(tau: np.ndarray, rng: np.random.Generator, level: float, bits: int) -> np.ndarray:
    """τ as a drive reports it from its motor current: each drive's range is 1.5 × the largest force it
    supplies in the log (a drive sized for its joint), the current sensor's noise is white with ``level`` ×
    that range (the same on a joint that barely moves as on one that lifts the arm: a light wrist joint's
    force is then mostly noise) and the current is read by an ADC of ``bits`` over ± the range."""
    span = 1.5 * np.abs(tau).max(axis=0)
    noisy = tau + rng.normal(0, 1, tau.shape) * level * span
    step = 2 * span / 2**bits
    return np.round(noisy / step) * step


INDUSTRIAL_DRIVES = {  # Corke's PUMA 560 motors (mdl_puma560): rotor inertia (kg·m²), gear ratio, and the
    # viscous (N·m·s/rad) and Coulomb (N·m) friction referred to the joint, rounded
    "q1": (200e-6, 62.6, 5.8, 24.7), "q2": (200e-6, 107.8, 9.5, 13.6), "q3": (200e-6, 53.7, 4.0, 7.1),
    "q4": (33e-6, 76.0, 0.41, 0.85), "q5": (33e-6, 71.9, 0.43, 0.67), "q6": (33e-6, 76.7, 0.22, 0.30),
}


def industrial_arm(drop: dict[str, tuple[str, ...]] | None = None, scale: dict[str, float] | None = None) -> str:
    """A 6-DOF industrial arm: the built-in PUMA 560 with its motors' rotor inertias (``[[drive]]``, reflected
    as Ia·ratio²) and viscous and Coulomb friction on every joint (:data:`INDUSTRIAL_DRIVES`). ``drop`` leaves
    friction keys out per joint (``{"q6": ("coulomb",)}``: the model without it); ``scale`` multiplies a
    joint's Coulomb level (the truth of a case)."""
    from symbolic import robots

    text = robots.path("puma560").read_text(encoding="utf-8")
    drop, scale = drop or {}, scale or {}
    parameters, tables = [], []
    for c, (rotor, ratio, viscous, coulomb) in INDUSTRIAL_DRIVES.items():
        parameters += [f"Ia_{c} = {rotor!r}", f"Fv_{c} = {viscous!r}", f"Fc_{c} = {coulomb * scale.get(c, 1.0)!r}"]
        keys = [f'{key} = "F{key[0]}_{c}"' for key in ("viscous", "coulomb") if key not in drop.get(c, ())]
        tables.append(f'[[drive]]\ncoordinate = "{c}"\nratio = "{ratio!r}"\nrotor_inertia = "Ia_{c}"\n')
        if keys:
            tables.append(f'[[friction]]\ncoordinate = "{c}"\n' + "\n".join(keys) + "\n")
    text = text.replace("[parameters]\n", "[parameters]\n" + "\n".join(parameters) + "\n", 1)
    return text + "\n" + "\n".join(tables)


def _feedforward(model, coordinates, q, qd, qdd, t) -> np.ndarray:
    """The computed-torque feedforward of a well-tuned loop: the truth's inverse dynamics along the
    reference (unmeasured coordinates held at rest), on the measured coordinates. It keeps the loop
    from sticking at velocity reversals, where a PD loop alone dwells until its error overcomes Coulomb
    friction; the workflow never sees it (the log holds the total force). A disturbance in time (a
    [[force]] in t) is left out: the machine's controller does not know it, and the loop rejects it."""
    if model.time_varying:
        steady = dataclasses.replace(model.robot, forces=tuple(f for f in model.robot.forces
                                                                if model.time not in f.expression.free_symbols))
        model = symbolic.derive(steady)
    num = numeric_model(model)
    names = list(model.robot.generalized_coordinates)
    rows = [names.index(c) for c in coordinates]
    full = np.zeros((len(q), model.n, 3))
    full[:, rows, 0], full[:, rows, 1], full[:, rows, 2] = q, qd, qdd
    return np.array([num.inverse_dynamics(x[:, 0], x[:, 1], x[:, 2])[rows] for x in full])


MODELS = Path(__file__).resolve().parent / "models"
"""Model files written for the tests (tests/models/)."""


def flexible_rig(stiffness_factor: float = 1.0) -> str:
    """Text of the hub + link + torsional spring rig (tests/models/flexible_rig.toml), its root stiffness
    Ks multiplied by ``stiffness_factor`` (the truth of a case whose model file has it wrong)."""
    text = (MODELS / "flexible_rig.toml").read_text(encoding="utf-8")
    old = "Ks = { value = 1.0,"
    assert text.count(old) == 1
    return text.replace(old, f"Ks = {{ value = {1.0 * stiffness_factor!r},")


def model_file(folder: Path, text: str, name: str = "model.toml") -> Path:
    """Write a model file for the workflow to read (and patch)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def planar_flexible_link(hub: float = 0.05, tip_mass: float = 0.1, stiffness: float = 10.0, damper: float = 3.3,
                         friction: str = 'viscous = "Fv"', damped: bool = True) -> str:
    """:func:`flexible_link` as a laboratory flexible-link rig: one horizontal mode, no vertical bending
    (``modes_w = 0``: gravity acts along the hub's axis, the out-of-plane bending does not couple to the hub),
    a light hub of ``hub`` kg·m² and a soft beam (EI = ``stiffness`` N·m²) with a tip mass of ``tip_mass`` kg,
    so that the beam's first mode (10.4 Hz with the hub free, 8.7 Hz held) is within the treatment's band and
    the hub's torque feels it. ``damped=False`` leaves out the structural damper of the first mode."""
    text = flexible_link(tip_mass, damper, friction).replace("modes_v = 2", "modes_v = 1").replace("modes_w = 1", "modes_w = 0")
    for old, new in (("EIv = { value = 88.32", f"EIv = {{ value = {stiffness!r}"), ("EIw = { value = 88.32", f"EIw = {{ value = {stiffness!r}"),
                     ("I_h = { value = 0.677", f"I_h = {{ value = {hub!r}")):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    return text if damped else text[:text.index("[[force]]")]

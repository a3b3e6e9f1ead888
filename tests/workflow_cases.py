"""Synthetic hidden-truth cases for the discrepancy workflow (tests/test_workflow*.py).

The truth is written here, in the tests, as model-file text with the effect (a ``[[friction]]`` key, a
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
from symbolic.data import Measurements
from symbolic.numeric import numeric_model
from symbolic.simulation.simulator import simulate

AXIS = '''# A rotary axis about a vertical axis (gravity along the rotation axis: no gravity torque).
name = "axis"
description = "rotary axis: rotor inertia and friction"
coordinates = ["q"]
gravity = ["0", "0", "-9.81"]

[parameters]
J = {{ value = {J}, unit = "kg*m^2", description = "inertia about the axis" }}
{parameters}
[[frame]]
name = "rotor"
parent = "base"
dh = {{ theta = "q", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "rotor"
frame = "rotor"
mass = "2.0"
inertia = {{ xx = "{inertia}/2", yy = "{inertia}/2", zz = "{inertia}" }}

[[friction]]
coordinate = "q"
{friction}
{extra}'''

ARM = '''# A two-link planar arm in a vertical plane (standard DH), friction on both joints.
name = "arm"
description = "two-link planar arm in a vertical plane"
coordinates = ["q1", "q2"]
gravity = ["0", "-9.81", "0"]

[parameters]
l1 = 0.4
m1 = 3.0
m2 = 2.0
c1 = 0.2
c2 = 0.15
I1 = 0.04
I2 = 0.02
{parameters}
[[frame]]
name = "1"
parent = "base"
dh = {{ theta = "q1", d = "0", a = "l1", alpha = "0" }}

[[frame]]
name = "2"
parent = "1"
dh = {{ theta = "q2", d = "0", a = "0.3", alpha = "0" }}

[[body]]
name = "link1"
frame = "1"
mass = "m1"
com = ["c1 - l1", "0", "0"]
inertia = {{ zz = "I1" }}

[[body]]
name = "link2"
frame = "2"
mass = "m2"
com = ["c2 - 0.3", "0", "0"]
inertia = {{ zz = "I2" }}

[[friction]]
coordinate = "q1"
{friction1}

[[friction]]
coordinate = "q2"
{friction2}
{extra}'''


def axis(parameters: str = "Fv = 0.3\nFc = 0.4\n", friction: str = 'viscous = "Fv"\ncoulomb = "Fc"',
         extra: str = "", J: float = 0.05, inertia: str = "J") -> str:
    """Text of the rotary axis model; the defaults are the nominal model (inertia, viscous, Coulomb)."""
    return AXIS.format(J=J, parameters=parameters, friction=friction, extra=extra, inertia=inertia)


ARM_PARAMETERS = "Fv1 = 0.8\nFv2 = 0.5\nFc1 = 0.6\nFc2 = 0.4\n"
ARM_FRICTION1 = 'viscous = "Fv1"\ncoulomb = "Fc1"'
ARM_FRICTION2 = 'viscous = "Fv2"\ncoulomb = "Fc2"'


def arm(parameters: str = ARM_PARAMETERS, friction1: str = ARM_FRICTION1, friction2: str = ARM_FRICTION2,
        extra: str = "") -> str:
    """Text of the two-link arm; the defaults are the nominal model (viscous and Coulomb on both joints)."""
    return ARM.format(parameters=parameters, friction1=friction1, friction2=friction2, extra=extra)


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
                 unactuated: tuple[str, ...] = (), deflection_noise: float = 0.0) -> Measurements:
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
    model in the logged loop (``diagnose(simulate=True)``) is driven as the truth was.
    ``unactuated``: coordinates logged as well, outside the loop and with zero force (a beam's modal
    coordinates, as strain gauges give them), with white noise of ``deflection_noise`` × the largest of
    their ranges (a noise floor of the gauges, the same on each)."""
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
    # the force the controller holds over [t_k, t_k+1), reported at t_k as an integrating current sensor
    # does: its mean over [t_k − T/2, t_k + T/2], aligned with the positions (a log of the held command
    # leads them by half a sample, which the inverse model reads as a small inertia or lag term)
    tau = command if held else np.concatenate([command[:1], 0.5 * (command[1:] + command[:-1])])
    rng = np.random.default_rng(seed + 1000)
    tau = tau + rng.normal(0, 1, tau.shape) * noise * np.sqrt(np.mean(tau**2, axis=0))
    q = np.round(q / resolution) * resolution
    if unactuated:
        free = np.asarray(run.simulated.q)[:, [names.index(c) for c in unactuated]]
        free = free + rng.normal(0, 1, free.shape) * deflection_noise * np.ptp(free, axis=0).max()  # one gauge noise floor
        q, tau, coordinates = np.hstack([q, free]), np.hstack([tau, np.zeros_like(free)]), coordinates + tuple(unactuated)
        reference = np.hstack([reference, np.zeros_like(free)])
    logged = Measurements.from_arrays(t, coordinates, q, tau, ref=reference, extras=extras if logged_feedforward else None)
    if logged_feedforward:
        return dataclasses.replace(logged, controller=table)
    return dataclasses.replace(logged, controller={k: v for k, v in table.items() if k != "disturbance"})


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


def with_load(text: str, coordinate: str, frame: str, load: float, frequency: float, damping: float,
              name: str = "x", parent: str = "base") -> str:
    """``text`` with a load of inertia ``load`` on a compliant coupling to revolute ``coordinate`` (whose
    frame ``frame`` has parent ``parent`` and θ = coordinate): a second mass whose deflection ``name`` the
    data do not measure, ringing at ``frequency`` Hz with ``damping`` when the coordinate is held."""
    w = 2 * np.pi * frequency
    coordinates = text.split("coordinates = ", 1)[1].split("\n", 1)[0]
    text = text.replace(f"coordinates = {coordinates}", f"coordinates = {coordinates[:-1]}, \"{name}\"]", 1)
    return text + f'''
[[frame]]
name = "{frame}_load"
parent = "{parent}"
dh = {{ theta = "{coordinate} + {name}", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "{frame}_load"
frame = "{frame}_load"
mass = "0"
inertia = {{ xx = "{load / 2!r}", yy = "{load / 2!r}", zz = "{load!r}" }}

[[force]]
name = "coupling"
coordinate = "{name}"
expression = "-{load * w * w!r}*{name} - {2 * damping * w * load!r}*qd_{name}"
'''


def model_file(folder: Path, text: str, name: str = "model.toml") -> Path:
    """Write a model file for the workflow to read (and patch)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def flexible_link(tip_mass: float, damper: float, friction: str = 'viscous = "Fv"', parameters: str = "Fv = 0.5\n") -> str:
    """The built-in flexible single link (Madill's beam on a hub, ``single_flexible_link.toml``) made to ring
    within the data treatment's pass band: a tip mass of ``tip_mass`` kg (1 kg brings the first bending mode
    with the hub held from ≈ 65 Hz down to ≈ 8.6 Hz and gives it ≈ 30 % of the hub's inertia), one vertical
    mode (gravity acts along the hub's axis: the vertical bending does not couple to the hub at rest), a
    damper ``damper`` on the first horizontal modal coordinate (structural damping; the model format has no
    beam damping key, a ``[[force]]`` on the modal coordinate is one) and friction on the hub."""
    from symbolic import robots

    text = robots.path("single_flexible_link").read_text(encoding="utf-8")
    for old, new in (("modes_w = 2", 'modes_w = 1\ntip_mass = "m_t"'),
                     ("\n[[frame]]", f"m_t = {tip_mass!r}\nc_b = {damper!r}\n{parameters}\n[[frame]]")):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    return text + f'''
[[friction]]
coordinate = "q0"
{friction}

[[force]]
name = "structural_damping"
coordinate = "link_nu1"
expression = "-c_b*qd_link_nu1"
'''


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


RIGID_LINK = '''# The flexible single link as a rigid body: hub and beam (with its tip mass) turning as one.
name = "rigid_link"
description = "hub and link as one rigid body"
coordinates = ["q0"]
gravity = ["0", "0", "-9.81"]

[parameters]
J = {{ value = {J!r}, unit = "kg*m^2", description = "hub, beam and tip mass about the hub axis" }}
Fv = 0.5

[[frame]]
name = "e"
parent = "base"
dh = {{ theta = "q0", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "hub_and_link"
frame = "e"
mass = "0"
inertia = {{ xx = "J/2", yy = "J/2", zz = "J" }}

[[friction]]
coordinate = "q0"
viscous = "Fv"
'''


def rigid_link(inertia: float) -> str:
    """The rigid counterpart of :func:`flexible_link`: one body of the whole ``inertia`` about the hub axis
    and the same friction, nothing but the flexibility missing."""
    return RIGID_LINK.format(J=inertia)

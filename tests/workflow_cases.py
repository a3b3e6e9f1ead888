"""Synthetic hidden-truth cases for the discrepancy workflow (tests/test_workflow*.py).

The truth is written here, in the tests, as model-file text with the effect (a ``[[friction]]`` key, a
``[[force]]``, a rotor inertia); τ is the truth model's inverse dynamics (Newton–Euler through
``numeric_model``, not the regressor the workflow uses) along a Swevers-type excitation (five harmonics
of a 0.1 Hz fundamental per joint), with white noise on τ and encoder quantisation on q. The workflow is then given the model
*without* the effect and the data: nothing of the truth reaches the search code.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import symbolic
from symbolic.data import Measurements
from symbolic.numeric import numeric_model

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


def measurements(text: str, seed: int, noise: float, seconds: float = 40.0, rate: float = 500.0,
                 resolution: float = 2 * np.pi / 2**18) -> Measurements:
    """Data of the truth model ``text``: τ by inverse dynamics, noise (fraction of τ's rms per joint) and
    an encoder of ``resolution`` on q."""
    model = symbolic.derive(symbolic.loads(text, "<truth>"))
    t = np.arange(0.0, seconds, 1.0 / rate)
    q, qd, qdd = trajectory(model.n, t, seed)
    num = numeric_model(model)
    tau = np.array([num.inverse_dynamics(q[i], qd[i], qdd[i]) for i in range(len(t))])
    rng = np.random.default_rng(seed + 1000)
    tau = tau + rng.normal(0, 1, tau.shape) * noise * np.sqrt(np.mean(tau**2, axis=0))
    measured = np.round(q / resolution) * resolution
    return Measurements.from_arrays(t, model.robot.generalized_coordinates, measured, tau)


def model_file(folder: Path, text: str, name: str = "model.toml") -> Path:
    """Write a model file for the workflow to read (and patch)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path

"""The truth of the 6-axis response cases: an industrial arm under its PD loop, integrated apart from the product.

The arm is tests/workflow_cases.py's industrial arm (the built-in PUMA 560 with its motors' rotor inertias and
viscous friction; no Coulomb friction, so that the truth needs no set-valued friction on six coupled joints). Its
dynamics are Pinocchio's (tests/reference_pinocchio.py builds the model from the DH numbers alone: ``crba``,
``rnea``) with the rotors' reflected inertia Ia·ratio² on the diagonal and the viscous friction added here; it is
integrated by SciPy's DOP853 (rtol 1e-10) from sample to sample with the force held. The loop is written here
too: a PD on the encoder's reading (quantised, backward-difference velocity) with a computed-torque feedforward
along the reference, which the log keeps (as a controller's feedforward is logged) and the experiment's
``[controller]`` declares as its disturbance. ``drive_gain``: the drive applies g·command on a joint, the log
holding the command — the hidden truth of a case; nothing here reaches the searching code but the log and the
``[controller]``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

import workflow_cases as cases
from reference_pinocchio import build, pin, require_pinocchio

import symbolic
from symbolic.data import Experiment, Measurements

SETTLE = 0.5
"""Seconds the arm is held at the reference's start, under the loop, before the log begins (it starts at rest)."""

FADE = 1.0
"""Seconds over which the reference leaves rest (a smoothstep): the log starts at rest, as a machine's does."""


def truth_text() -> str:
    """The arm's model file: every joint's viscous friction and rotor, no Coulomb friction."""
    return cases.industrial_arm(drop={c: ("coulomb",) for c in cases.INDUSTRIAL_DRIVES})


def experiment(seed: int, *, seconds: float = 10.0, rate: float = 500.0, counts: int = 2**18, noise: float = 0.01,
               drive_gain: dict[str, float] | None = None, log_delay: dict[str, int] | None = None,
               own_scale: dict[str, float] | None = None) -> Measurements:
    """The log (positions read by the encoders, the commanded force with white noise of ``noise`` × its rms per
    joint, the reference and the feedforward) of the arm under its loop, following tests/workflow_cases.py's
    Fourier reference of ``seed``, as an :class:`~symbolic.data.Experiment` with the loop's ``[controller]``.
    ``drive_gain``: per joint, the drive applies g·command; ``log_delay``: per joint, the logged force lags the
    command by that many samples (a logging path's delay); ``own_scale``: per joint, the machine's rotor inertia and
    viscous friction are this many times the model file's (what a drive gain of 1/scale looks like to IDIM-LS)."""
    require_pinocchio()
    from scipy.integrate import solve_ivp

    with warnings.catch_warnings():  # the built-in PUMA's link inertias as Corke gives them (puma560.toml)
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        robot = symbolic.loads(truth_text(), "<six-axis truth>")
    model = build(robot)
    data = model.createData()
    names = list(cases.INDUSTRIAL_DRIVES)
    armature = np.array([rotor * ratio**2 for rotor, ratio, _, _ in cases.INDUSTRIAL_DRIVES.values()])
    viscous = np.array([v for _, _, v, _ in cases.INDUSTRIAL_DRIVES.values()])
    gains = np.array([(drive_gain or {}).get(c, 1.0) for c in names])
    scales = np.array([(own_scale or {}).get(c, 1.0) for c in names])
    armature, viscous = armature * scales, viscous * scales

    def mass(q: np.ndarray) -> np.ndarray:
        M = pin.crba(model, data, q).copy()
        return np.triu(M) + np.triu(M, 1).T + np.diag(armature)

    def inverse(q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        return pin.rnea(model, data, q, v, a) + armature * a + viscous * v

    def forward(_: float, x: np.ndarray, tau: np.ndarray) -> np.ndarray:
        q, v = x[:6], x[6:]
        return np.concatenate([v, np.linalg.solve(mass(q), tau - inverse(q, v, np.zeros(6)))])

    period = 1.0 / rate
    t = np.arange(int(round(seconds * rate))) / rate
    r, rd, rdd = _faded(t, *cases.trajectory(6, t, seed))
    settle = int(round(SETTLE * rate))
    r = np.vstack([np.repeat(r[:1], settle, axis=0), r])
    rd = np.vstack([np.zeros((settle, 6)), rd])
    rdd = np.vstack([np.zeros((settle, 6)), rdd])
    w = 2 * math.pi * cases.CONTROL_BANDWIDTH_HZ
    d = np.diag(mass(r[0]))
    kp, kd = d * w**2, 2 * 0.7 * w * d
    # the pd kind damps the measured velocity: kd·ṙ in the feedforward makes it a PD on the tracking error
    feedforward = np.array([inverse(r[k], rd[k], rdd[k]) for k in range(len(r))]) + kd * rd
    resolution = 2 * math.pi / counts
    x = np.concatenate([r[0], np.zeros(6)])
    read, command = np.empty((len(r), 6)), np.empty((len(r), 6))
    last = None
    for k in range(len(r)):
        measured = np.floor(x[:6] / resolution + 0.5) * resolution
        velocity = np.zeros(6) if last is None else (measured - last) / period
        command[k] = kp * (r[k] - measured) - kd * velocity + feedforward[k]
        read[k], last = measured, measured
        x = solve_ivp(forward, (0.0, period), x, method="DOP853", rtol=1e-10, atol=1e-12,
                      args=(gains * command[k],)).y[:, -1]
    for k, c in enumerate(names):
        late = (log_delay or {}).get(c, 0)
        if late:
            command[late:, k] = command[:-late, k].copy()
    read, command, r, feedforward = read[settle:], command[settle:], r[settle:], feedforward[settle:]
    rng = np.random.default_rng(seed + 1000)
    logged = command + rng.normal(0.0, 1.0, command.shape) * noise * np.sqrt(np.mean(command**2, axis=0))
    extras = {f"ff_{c}": feedforward[:, k] for k, c in enumerate(names)}
    log = Measurements.from_arrays(t, tuple(names), read, logged, ref=r, extras=extras)
    table = {"kind": "pd", "coordinates": names, "kp": [float(v) for v in kp], "kd": [float(v) for v in kd],
             "reference": "ref", "quantisation": [resolution] * 6, "disturbance": [f"ff_{c}" for c in names]}
    return Experiment.of(log, controller=table)


def _faded(t: np.ndarray, r: np.ndarray, rd: np.ndarray, rdd: np.ndarray) -> tuple[np.ndarray, ...]:
    """r₀ + s(t)·(r − r₀) and its two derivatives, s the smoothstep 3u² − 2u³ of u = t/:data:`FADE` (then 1)."""
    u = np.clip(t / FADE, 0.0, 1.0)[:, None]
    inside = (t < FADE)[:, None]
    s, s1, s2 = 3 * u**2 - 2 * u**3, np.where(inside, 6 * u * (1 - u) / FADE, 0.0), np.where(inside, (6 - 12 * u) / FADE**2, 0.0)
    e = r - r[:1]
    return r[:1] + s * e, s1 * e + s * rd, s2 * e + 2 * s1 * rd + s * rdd

"""Closed-loop logs made without the product's simulator: truth for the output-error tests.

:func:`axis_pd_log` runs a 1-DOF axis J·q̈ = τ − Fv·q̇ − Fc·sgn(q̇) under a discrete PD loop with
zero-order hold. Between two samples τ is constant, so the motion has a closed form: while sliding in the
direction s = sgn(q̇), q̇(t) = v∞ + (q̇₀ − v∞)·e^{−t/τm} with v∞ = (τ − s·Fc)/Fv and τm = J/Fv, q its
integral. The set-valued Coulomb friction is handled as stick/slip events: a velocity reaching zero inside
an interval is located exactly (a logarithm); there the axis sticks while |τ| ≤ Fc (for the rest of the
interval, τ being held) and else slides off in the direction of τ. No step size, no smoothing: errors are
those of floating point only.

The loop is the machine's: the encoder reads q rounded to its resolution (round half up, as a counter
does), the velocity is the backward difference of the readings (0 at the first sample), u_k = kp·(r_k −
q_m,k) − kd·v_k is applied over [t_k, t_k+1). The log holds the readings and the force with added noise.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _slide(q0: float, v0: float, tau: float, s: float, J: float, Fv: float, Fc: float, t: float) -> tuple[float, float]:
    """Position and velocity after t of sliding in direction s from (q0, v0) under the constant force tau."""
    v_inf = (tau - s * Fc) / Fv
    decay = math.exp(-t * Fv / J)
    return q0 + v_inf * t + (v0 - v_inf) * J / Fv * (1.0 - decay), v_inf + (v0 - v_inf) * decay


def _zero_crossing(v0: float, tau: float, s: float, J: float, Fv: float, Fc: float) -> float:
    """Time at which sliding in direction s (s = sgn v0) brings the velocity to 0; inf if it never does."""
    v_inf = (tau - s * Fc) / Fv
    if v_inf * s >= 0:  # the asymptote is on the same side: the velocity never reaches zero
        return math.inf
    return J / Fv * math.log((v0 - v_inf) / (0.0 - v_inf))


def interval(q: float, v: float, tau: float, h: float, J: float, Fv: float, Fc: float) -> tuple[float, float]:
    """The exact state after h under the held force tau, with stick/slip Coulomb friction."""
    remaining = h
    for _ in range(8):  # a few events at most per interval (stop, slide off, stop again cannot recur)
        if v == 0.0:
            if abs(tau) <= Fc:
                return q, 0.0  # sticks for the rest of the interval
            s = math.copysign(1.0, tau)
        else:
            s = math.copysign(1.0, v)
        crossing = _zero_crossing(v, tau, s, J, Fv, Fc) if v != 0.0 else math.inf
        if crossing >= remaining:
            return _slide(q, v, tau, s, J, Fv, Fc, remaining)
        q, _ = _slide(q, v, tau, s, J, Fv, Fc, crossing)
        v, remaining = 0.0, remaining - crossing
    return q, v


def axis_pd_run(t: np.ndarray, reference: np.ndarray, J: float, Fv: float, Fc: float, kp: float, kd: float,
                resolution: float, saturation: float = math.inf, drive_gain: float = 1.0,
                drive_bias: float = 0.0, drive_delay: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(true q, encoder readings, commanded τ) at the samples, from rest at q = 0; the command clipped to
    ±``saturation``; the drive applies drive_gain·(command + drive_bias) to the axis, ``drive_delay`` samples
    after the controller computed it (0 before the first command arrives)."""
    q, v = 0.0, 0.0
    period = float(t[1] - t[0])
    true, read, force = (np.empty(len(t)) for _ in range(3))
    last = None
    for k in range(len(t)):
        measured = math.floor(q / resolution + 0.5) * resolution if resolution > 0 else q
        velocity = 0.0 if last is None else (measured - last) / period
        tau = min(max(kp * (reference[k] - measured) - kd * velocity, -saturation), saturation)
        true[k], read[k], force[k] = q, measured, tau
        last = measured
        applied = force[k - drive_delay] if k >= drive_delay else 0.0
        q, v = interval(q, v, drive_gain * (applied + drive_bias), period, J, Fv, Fc)
    return true, read, force


def lagged(x: np.ndarray, samples: int) -> np.ndarray:
    """``x`` delayed by a whole number of samples along its first axis, its first value held before."""
    if samples == 0:
        return x
    return np.concatenate([np.repeat(x[:1], samples, axis=0), x[:-samples]])


def reference_motion(t: np.ndarray, amplitude: float = 0.6) -> np.ndarray:
    """A smooth reference from rest: sines at 0.7, 1.9 and 4.3 Hz under a half-second fade-in."""
    fade = np.clip(t / 0.5, 0.0, 1.0) ** 2 * (3 - 2 * np.clip(t / 0.5, 0.0, 1.0))
    return amplitude * fade * (np.sin(2 * np.pi * 0.7 * t) + 0.4 * np.sin(2 * np.pi * 1.9 * t + 1.0)
                               + 0.15 * np.sin(2 * np.pi * 4.3 * t + 2.0))


def write_axis_experiment(folder: Path, *, J: float = 0.05, Fv: float = 0.3, Fc: float = 0.4, kp: float = 20.0,
                          kd: float = 1.0, rate: float = 1000.0, seconds: float = 4.0, counts: int = 2**16,
                          force_noise: float = 0.0, seed: int = 0, saturation: float = math.inf,
                          drive: tuple[float, float] = (1.0, 0.0), force_sensor: float | None = None,
                          layer: str = "", log_delay: int = 0, drive_delay: int = 0) -> Path:
    """Write ``folder/axis.csv`` and ``folder/axis.experiment.toml`` (with its PD ``[controller]`` and the
    encoder's quantisation) of the axis under PD; ``counts`` per revolution (0: exact positions),
    ``force_noise`` the standard deviation (N·m) of white noise added to the logged force, ``saturation`` the
    command's limit (declared in the ``[controller]`` when finite). ``drive`` = (gain, bias): the force applied
    is gain·(command + bias) and the log holds the command; ``force_sensor``: the log holds that gain times the
    applied force instead (a force sensor's reading); ``layer``: TOML appended to the experiment file (its
    ``[sensors]``/``[drive]``, as the test declares them); ``log_delay``: the logged force lags the applied
    one by that many samples (a logging path's delay); ``drive_delay``: the drive applies each command that many
    samples late (the log holds the command when computed)."""
    from symbolic.data import write_columns

    t = np.arange(int(round(seconds * rate))) / rate
    r = reference_motion(t)
    resolution = 2 * math.pi / counts if counts else 0.0
    _, read, force = axis_pd_run(t, r, J, Fv, Fc, kp, kd, resolution, saturation, *drive, drive_delay=drive_delay)
    if force_sensor is not None:
        force = force_sensor * drive[0] * (force + drive[1])
    force = lagged(force, log_delay)
    logged = force + np.random.default_rng(seed).normal(0.0, force_noise, len(t)) if force_noise else force
    folder.mkdir(parents=True, exist_ok=True)
    write_columns({"t": t, "q_q": read, "tau_q": logged, "ref_q": r}, folder / "axis.csv")
    quantisation = f"quantisation = [{resolution!r}]\n" if resolution else ""
    if math.isfinite(saturation):
        quantisation += f"saturation = [{saturation!r}]\n"
    path = folder / "axis.experiment.toml"
    path.write_text('data = "axis.csv"\n[signals]\nt = "t"\nq_q = "q_q"\ntau_q = "tau_q"\nref_q = "ref_q"\n'
                    f'[controller]\nkind = "pd"\nkp = [{kp!r}]\nkd = [{kd!r}]\nreference = "ref"\n{quantisation}'
                    + layer,
                    encoding="utf-8")
    return path


SETTLE = 1.5
"""Seconds the arm of :func:`write_arm_experiment` is held at the reference's start before its log begins."""

ARM = {"l1": 0.4, "l2": 0.3, "m1": 3.0, "m2": 2.0, "c1": 0.2, "c2": 0.15, "I1": 0.04, "I2": 0.02, "Fv1": 0.8,
       "Fv2": 0.5, "g": 9.81}
"""The two-link arm of tests/models.py's ``arm`` (vertical plane, I about each link's centre of mass), with
viscous friction only: its truth here."""


def arm_terms(q: np.ndarray, v: np.ndarray, p: dict) -> tuple[np.ndarray, np.ndarray]:
    """The planar two-link arm's mass matrix and its Coriolis, centrifugal and gravity forces, written out by
    hand (angles from the horizontal, gravity down)."""
    l1, m1, m2, c1, c2, I1, I2, g = (p[k] for k in ("l1", "m1", "m2", "c1", "c2", "I1", "I2", "g"))
    cos2, sin2 = math.cos(q[1]), math.sin(q[1])
    m11 = I1 + m1 * c1**2 + I2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * cos2)
    m12 = I2 + m2 * (c2**2 + l1 * c2 * cos2)
    m22 = I2 + m2 * c2**2
    h = m2 * l1 * c2 * sin2
    bias = np.array([-h * (2 * v[0] * v[1] + v[1] ** 2), h * v[0] ** 2])
    gravity = np.array([(m1 * c1 + m2 * l1) * g * math.cos(q[0]) + m2 * c2 * g * math.cos(q[0] + q[1]),
                        m2 * c2 * g * math.cos(q[0] + q[1])])
    return np.array([[m11, m12], [m12, m22]]), bias + gravity


def arm_forward(q: np.ndarray, v: np.ndarray, tau: np.ndarray, p: dict) -> np.ndarray:
    """q̈ of the planar two-link arm (:func:`arm_terms`) with viscous friction on both joints."""
    mass, terms = arm_terms(q, v, p)
    rhs = tau - terms - np.array([p["Fv1"] * v[0], p["Fv2"] * v[1]])
    det = mass[0, 0] * mass[1, 1] - mass[0, 1] ** 2
    return np.array([mass[1, 1] * rhs[0] - mass[0, 1] * rhs[1], mass[0, 0] * rhs[1] - mass[0, 1] * rhs[0]]) / det


def write_arm_experiment(folder: Path, *, kp: tuple[float, float] = (120.0, 60.0), kd: tuple[float, float] = (8.0, 4.0),
                         rate: float = 500.0, seconds: float = 3.0, counts: int = 2**16, force_noise: float = 0.0,
                         seed: int = 0, parameters: dict | None = None,
                         drive: tuple[tuple[float, float], tuple[float, float]] = ((1.0, 0.0), (1.0, 0.0)),
                         layer: str = "", log_delay: tuple[int, int] = (0, 0),
                         position_bias: tuple[float, float] = (0.0, 0.0),
                         drive_delay: tuple[int, int] = (0, 0)) -> Path:
    """``folder/arm.csv`` and ``folder/arm.experiment.toml``: the arm under a PD loop on both joints (no
    gravity compensation), integrated by ``solve_ivp`` (DOP853, rtol 1e-11) from
    sample to sample with the force held; encoders of ``counts`` per revolution, white force noise; ``drive``
    per joint (gain, bias): the force applied is gain·(command + bias), the log holds the command; ``layer``:
    TOML appended to the experiment file; ``log_delay``: per joint, the logged force lags by that many samples;
    ``position_bias``: per joint, the encoder reads the angle plus that much (the loop and the log see it);
    ``drive_delay``: per joint, the drive applies each command that many samples late (the log holds it when
    computed)."""
    from scipy.integrate import solve_ivp

    from symbolic.data import write_columns

    p = {**ARM, **(parameters or {})}
    t = np.arange(int(round(seconds * rate))) / rate
    period = 1.0 / rate
    base = np.array([-0.6, 0.8])
    r = base + np.column_stack([reference_motion(t, 0.5), reference_motion(t + 0.37, 0.4)])
    resolution = 2 * math.pi / counts if counts else 0.0
    kp_, kd_ = np.array(kp), np.array(kd)
    # released at rest at the reference's start, the arm sags until the loop (no gravity compensation) holds
    # it: SETTLE seconds before the log starts, so that the log starts at rest as a machine's does
    settle = int(SETTLE * rate)
    r = np.vstack([np.repeat(r[:1], settle, axis=0), r])
    state = np.concatenate([base, np.zeros(2)])
    read, logged_tau = np.empty((len(r), 2)), np.empty((len(r), 2))
    last = None
    for k in range(len(r)):
        measured = np.floor(state[:2] / resolution + 0.5) * resolution if resolution else state[:2].copy()
        measured = measured + np.array(position_bias)
        velocity = np.zeros(2) if last is None else (measured - last) / period
        tau = kp_ * (r[k] - measured) - kd_ * velocity
        read[k], logged_tau[k], last = measured, tau, measured
        late = [logged_tau[k - d, j] if k >= d else 0.0 for j, d in enumerate(drive_delay)]  # each drive's latency
        applied = np.array([g * (u + b) for u, (g, b) in zip(late, drive)])
        solution = solve_ivp(lambda _, x: np.concatenate([x[2:], arm_forward(x[:2], x[2:], applied, p)]),
                             (0.0, period),
                             state, method="DOP853", rtol=1e-11, atol=1e-13)
        state = solution.y[:, -1]
    logged_tau = np.column_stack([lagged(logged_tau[:, j], d) for j, d in enumerate(log_delay)])
    r, read, logged_tau = r[settle:], read[settle:], logged_tau[settle:]
    if force_noise:
        logged_tau = logged_tau + np.random.default_rng(seed).normal(0.0, force_noise, logged_tau.shape)
    folder.mkdir(parents=True, exist_ok=True)
    write_columns({"t": t, "q_q1": read[:, 0], "q_q2": read[:, 1], "tau_q1": logged_tau[:, 0],
                   "tau_q2": logged_tau[:, 1], "ref_q1": r[:, 0], "ref_q2": r[:, 1]}, folder / "arm.csv")
    quantisation = f"quantisation = [{resolution!r}, {resolution!r}]\n" if resolution else ""
    path = folder / "arm.experiment.toml"
    path.write_text('data = "arm.csv"\n[signals]\nt = "t"\nq_q1 = "q_q1"\nq_q2 = "q_q2"\ntau_q1 = "tau_q1"\n'
                    'tau_q2 = "tau_q2"\nref_q1 = "ref_q1"\nref_q2 = "ref_q2"\n[controller]\nkind = "pd"\n'
                    f'coordinates = ["q1", "q2"]\nkp = [{kp[0]!r}, {kp[1]!r}]\nkd = [{kd[0]!r}, {kd[1]!r}]\n'
                    f'reference = "ref"\n{quantisation}' + layer, encoding="utf-8")
    return path

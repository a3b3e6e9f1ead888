"""Modes of a model linearised at rest: the plant's own (:func:`plant_modes`) and the closed loop's under an
experiment's discrete ``[controller]`` (:func:`closed_loop_modes`).

The plant is linearised about a rest position (``NumericModel.linearize``: A = ∂ẋ/∂x, B = ∂ẋ/∂τ, with
τ holding the rest position against gravity and springs; Coulomb friction has no derivative away from
q̇ = 0) and sampled with zero-order hold at the controller's period T (Φ = e^{AT}, Γ = ∫₀ᵀ e^{As} ds B).
The controller of :mod:`symbolic.simulation.controller` is linear apart from saturation and quantisation,
which are left out: it reads q_k, forms the backward-difference velocity and filters it with its taps,
and outputs ``pd``: −kp·q − kd·v, ``pid``: + ki·I, ``cascade``: kv·(−kp·q − v), ``state_feedback``:
−K·x with x the positions and velocities its ``states`` name, delayed by ``delay`` samples and
multiplied by its gain. For a state feedback this is the sampled form of eig(A − B·K): as T → 0 the
modes tend to those of the continuous loop, the backward difference and the hold delaying the
feedback by about T (the tests check both). The closed loop's eigenvalues z give s = ln(z)/T: the damped
frequency Im(s)/2π and the damping ratio −Re(s)/|s| of each oscillatory mode — what a ringing in the
data shows.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import scipy.linalg

from symbolic.derivation.dynamics import DynamicModel
from symbolic.simulation import controller as control
from symbolic.numeric import numeric_model


def plant_modes(model: DynamicModel, parameters: Mapping[str, float], position: np.ndarray | None = None) -> list[tuple[float, float]]:
    """(damped frequency in Hz, damping ratio) of every oscillatory mode of the plant alone (τ held at what
    keeps it at rest at ``position``, default 0), by frequency: the eigenvalues s of A = ∂ẋ/∂x
    (``NumericModel.linearize``), Im(s)/2π and −Re(s)/|s| for Im(s) > 0 — the same measures as
    :func:`closed_loop_modes`. Rigid-body motion (s = 0) and overdamped modes (real s) are not listed."""
    p = model.parameter_vector.updated(parameters).array()  # a name the model does not have is refused
    num = numeric_model(model)
    n = model.n
    q0 = np.zeros(n) if position is None else np.asarray(position, float)
    A, _ = num.linearize(np.concatenate([q0, np.zeros(n)]), num.bias(q0, np.zeros(n), p), p)
    s = np.linalg.eigvals(A)
    scale = max(float(np.abs(s).max(initial=0.0)), 1e-300)
    s = s[s.imag > 1e-9 * scale]
    return sorted((float(v.imag / (2 * np.pi)), float(-v.real / abs(v))) for v in s)


def closed_loop_modes(model: DynamicModel, parameters: Mapping[str, float], table: control.Controller | Mapping[str, Any],
                      period: float, position: np.ndarray | None = None,
                      source: str = "<controller>") -> list[tuple[float, float]]:
    """(damped frequency in Hz, damping ratio) of every oscillatory closed-loop mode, by frequency.

    Parameters
    ----------
    model
        The derived model.
    parameters
        Parameter values by name (the others keep the model's nominal values; a name it does not have is refused).
    table
        The experiment's controller (checked when it was loaded), or a ``[controller]`` table.
    period
        The controller's sample period T (s).
    position
        The rest position (all the model's coordinates; default 0).
    """
    values = model.parameter_vector.updated(parameters)  # a name the model does not have is refused
    p = values.array()
    coordinates = list(model.robot.generalized_coordinates)
    ctrl = table if isinstance(table, control.Controller) else control.parse(table, coordinates, model.parameter_symbols,
                                                                                 source, coordinates)
    gain = control.drive_gains(ctrl, values.by_symbol())
    nc = ctrl.size
    num = numeric_model(model)
    n = model.n
    q0 = np.zeros(n) if position is None else np.asarray(position, float)
    rest = np.concatenate([q0, np.zeros(n)])
    A, B = num.linearize(rest, num.bias(q0, np.zeros(n), p), p)
    B = B[:, :n]
    block = np.zeros((3 * n, 3 * n))
    block[:2 * n, :2 * n], block[:2 * n, 2 * n:] = A * period, B * period
    E = scipy.linalg.expm(block)
    phi, gamma = E[:2 * n, :2 * n], E[:2 * n, 2 * n:]
    rows = [coordinates.index(c) for c in ctrl.coordinates]
    sensed = [coordinates.index(c) for c in ctrl.sensors]
    ns = len(sensed)
    taps = np.asarray(ctrl.velocity_filter, float)
    m, delay = len(taps), ctrl.delay
    # state: x (2n), q_{k-1} (ns), v_b,k-1 … v_b,k-m+1 (ns each), I_{k-1} (nc), u_{k-1} … u_{k-delay} (nc each)
    # (cascade_pi: I_k and its last filtered velocity v_{k-1}, 2·nc)
    sizes = [2 * n, ns, ns * (m - 1), 2 * nc if ctrl.kind == control.CASCADE_PI else nc, nc * delay]
    offsets = np.cumsum([0] + sizes)
    size = int(offsets[-1])
    # a state feedback's x = selection · [y; v] (positions, then velocities, of the sensed coordinates)
    pick = [(0 if signal == "q" else ns) + ctrl.sensors.index(c) for signal, c in ctrl.states]

    def step(z: np.ndarray) -> np.ndarray:
        x, previous = z[:2 * n], z[offsets[1]:offsets[2]]
        history = z[offsets[2]:offsets[3]].reshape(m - 1, ns)
        integral, outputs = z[offsets[3]:offsets[4]], z[offsets[4]:].reshape(delay, nc)
        y = x[sensed]
        vb = (y - previous) / period
        v = taps[0] * vb + (taps[1:, None] * history).sum(axis=0) if m > 1 else taps[0] * vb
        if ctrl.kind == control.STATE_FEEDBACK:
            u = -ctrl.K @ np.concatenate([y, v])[pick]
        elif ctrl.kind == control.CASCADE_PI:  # the velocity error's integral acts from the next sample
            error, (i, last) = -ctrl.kp * y - v, integral.reshape(2, nc)
            u = ctrl.kv * error + ctrl.ki * i - ctrl.kd * (v - last) / period
            integral = np.concatenate([i + period * error, v])
        else:
            integral = integral - period * y
            if ctrl.kind == "cascade":
                u = ctrl.kv * (-ctrl.kp * y - v)
            else:
                u = -ctrl.kp * y - ctrl.kd * v + ctrl.ki * integral
        applied = outputs[-1] if delay else u
        tau = np.zeros(n)
        tau[rows] = gain * applied
        out = [phi @ x + gamma @ tau, y, np.concatenate([vb[None], history[:-1]]).ravel() if m > 1 else np.zeros(0),
               integral, np.concatenate([u[None], outputs[:-1]]).ravel() if delay else np.zeros(0)]
        return np.concatenate(out)

    closed = np.column_stack([step(e) for e in np.eye(size)])
    z = np.linalg.eigvals(closed)
    z = z[(np.abs(z) > 1e-12) & (z.imag > 1e-12)]
    s = np.log(z.astype(complex)) / period
    modes = sorted((float(v.imag / (2 * np.pi)), float(-v.real / abs(v))) for v in s)
    return modes

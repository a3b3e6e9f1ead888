"""The law of the machine's controller declared in an experiment's ``[controller]`` (docs/simulation.md,
"The controller", holds the table's keys, the laws and their checks).

Discrete at the log's sample period T with zero-order hold: at sample k the controller reads the position
q_m,k rounded to the sensor's resolution, filters the backward-difference velocity with the FIR
``velocity_filter``, computes u_k by its ``kind`` (``torque``: the logged force replayed; ``pd``, ``pid``,
``cascade``, ``cascade_pi``; ``state_feedback``: u_k = −K·(x_k − x_ref,k)), saturates it, delays it by ``delay`` samples, adds
the ``disturbance`` and applies τ_k = gain·(u + d_k) over [t_k, t_k+1).

:func:`controller_function` builds this step as a CasADi function, so that the closed loop runs in compiled
code. A delay of up to :data:`LINE_IN_MEMORY` samples is a shift register in the step's memory; a longer one
is a :class:`DelayLine` outside the compiled step, a ring buffer costing O(1) per sample. The table itself is
validated where the experiment is loaded, by :func:`symbolic.data.controller.parse` (re-exported here with
:class:`Controller`): that module holds the description, this one the law.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from symbolic.data import DataError, Measurements
from symbolic.data.controller import (CASCADE_PI, GAINS, KEYS, KINDS, LINE_IN_MEMORY, STATE_FEEDBACK, Controller,
                                      allowed_keys, check_delay, check_names, parse, replay)
from symbolic.errors import ModelError
from symbolic.description.reserved import RESERVED_NAMES

if TYPE_CHECKING:
    import sympy as sp

Parameters = Mapping["sp.Symbol", float] | Callable[[], Mapping["sp.Symbol", float]]
"""Parameter values by symbol, or a function giving them: called only for a gain that is an expression of the
parameters (a table of numbers needs no symbols, hence no SymPy: docs/simulation.md, "The whole command")."""

__all__ = ["CASCADE_PI", "GAINS", "KEYS", "KINDS", "LINE_IN_MEMORY", "STATE_FEEDBACK", "Controller", "DelayLine", "Inputs",
           "allowed_keys", "check_delay", "constants", "controller_function", "drive_gains", "evaluate", "inputs",
           "line_outside", "parse", "replay", "state_reference"]


# -- the signals a controller reads from the log -------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Inputs:
    """Per-sample inputs of the controller: references (samples × :attr:`Controller.reference_size`:
    for ``cascade_pi`` r, ṙ and the feedforward side by side), disturbances (samples × nc), measured
    forces (samples × n)."""

    reference: np.ndarray
    disturbance: np.ndarray
    torque: np.ndarray


def inputs(controller: Controller, measurements: Measurements, model_coordinates: Sequence[str]) -> Inputs:
    """The reference, disturbance and replayed-force signals of ``controller`` from ``measurements``.

    Raises
    ------
    DataError
        For a reference or disturbance that names a column the data lack.
    """
    samples, nc = measurements.samples, controller.size
    data = list(measurements.coordinates)
    source = controller.source
    reference = np.zeros((samples, nc))
    if controller.reference == "ref":
        if measurements.ref is None:
            columns = ", ".join(measurements.columns())
            raise DataError(source, "[controller] reference",
                            f"\"ref\" needs the columns ref_<c>, but the data have no column "
                            f"'ref_{controller.coordinates[0]}' (columns: {columns})")
        reference = measurements.ref[:, [data.index(c) for c in controller.coordinates]]
    elif controller.reference is not None:
        reference = _evaluate_all(controller.reference, measurements, "reference")
    elif controller.kind == STATE_FEEDBACK:
        reference = state_reference(controller, measurements)
    if controller.kind == CASCADE_PI:
        reference = np.hstack([reference, _reference_velocity(controller, measurements, reference),
                               _evaluate_all(controller.feedforward, measurements, "feedforward")
                               if controller.feedforward is not None else np.zeros((samples, nc))])
    disturbance = np.zeros((samples, nc))
    if controller.disturbance is not None:
        disturbance = _evaluate_all(controller.disturbance, measurements, "disturbance")
    torque = np.zeros((samples, len(model_coordinates)))
    for j, c in enumerate(data):
        torque[:, list(model_coordinates).index(c)] = measurements.tau[:, j]
    return Inputs(np.ascontiguousarray(reference), np.ascontiguousarray(disturbance), torque)


def _reference_velocity(controller: Controller, measurements: Measurements, reference: np.ndarray) -> np.ndarray:
    """ṙ of a ``cascade_pi``: its ``reference_velocity`` expressions, else the backward difference of the
    reference, (r_k − r_k−1)/T, 0 at the first sample (causal, as a drive would form it)."""
    if controller.reference_velocity is not None:
        return _evaluate_all(controller.reference_velocity, measurements, "reference_velocity")
    velocity = np.zeros_like(reference)
    velocity[1:] = np.diff(reference, axis=0) / measurements.sample_period
    return velocity


def state_reference(controller: Controller, measurements: Measurements) -> np.ndarray:
    """x_ref of a state feedback, samples × states: ``ref_<c>`` for ``q_<c>``, ``refd_<c>`` for ``qd_<c>``,
    0 where the data have no such column."""
    data = list(measurements.coordinates)
    reference = np.zeros((measurements.samples, len(controller.states)))
    for k, (signal, c) in enumerate(controller.states):
        if signal == "q" and measurements.ref is not None and c in data:
            reference[:, k] = measurements.ref[:, data.index(c)]
        elif signal == "qd" and f"refd_{c}" in measurements.extras:
            reference[:, k] = measurements.extras[f"refd_{c}"]
    return reference


def _evaluate_all(texts: Sequence[str], measurements: Measurements, name: str) -> np.ndarray:
    return np.column_stack([evaluate(text, measurements, f"[controller] {name}[{k}]")
                            for k, text in enumerate(texts)])


def evaluate(text: str, measurements: Measurements, key: str) -> np.ndarray:
    """An expression of ``t`` and the data's columns (names as in the data file), at every sample."""
    import sympy as sp

    from symbolic.description.expressions import parse_expression

    columns = measurements.columns()
    source = str(measurements.source)
    symbols = {name: sp.Symbol(name) for name in columns if name.isidentifier() and name not in RESERVED_NAMES}
    check_names(text, symbols, source, key, "t and the data's columns")
    try:
        expression = parse_expression(text, symbols, source, key)
    except ModelError as error:
        raise DataError(error.source, error.key, error.problem) from None
    used = sorted(expression.free_symbols, key=lambda s: s.name)
    function = sp.lambdify(used, expression, modules="numpy")
    with np.errstate(all="ignore"):
        values = np.broadcast_to(np.asarray(function(*[columns[s.name] for s in used]), dtype=float),
                                 (measurements.samples,)).copy()
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise DataError(source, key, f"{text!r} is {values[bad[0]]} at sample {bad[0]} (t = {measurements.t[bad[0]]:.9g} s)")
    return values


# -- the discrete controller as a CasADi function --------------------------------------------------------


def drive_gains(controller: Controller, parameters: Parameters) -> np.ndarray:
    """The output-to-force gains at ``parameters``, one per controlled coordinate (a number as it is).

    Raises
    ------
    DataError
        For a gain that is not a finite number ≥ 0 at these values.
    """
    gain = []
    for k, g in enumerate(controller.gain):
        if isinstance(g, float):  # a number (symbolic.data.controller: checked ≥ 0 when read)
            gain.append(g)
            continue
        if callable(parameters):
            parameters = parameters()
        unknown = sorted(s.name for s in g.free_symbols - set(parameters))
        if unknown:  # a gain read before a model was known (symbolic.data.controller.parse)
            raise DataError(controller.source, f"[controller] gain[{k}]",
                            f"unknown name {unknown[0]!r} in {str(g)!r} (allowed: the model's parameters: "
                            f"{', '.join(s.name for s in parameters) or 'none'})")
        value = float(g.xreplace(parameters))
        if not math.isfinite(value) or value < 0:
            raise DataError(controller.source, f"[controller] gain[{k}]",
                            f"{g} = {value:g} at the model's parameter values (allowed: ≥ 0)")
        gain.append(value)
    return np.array(gain)


def constants(controller: Controller, parameters: Parameters) -> np.ndarray:
    """The numbers :func:`controller_function` takes as its ``c`` input (gains evaluated at ``parameters``):
    kp, kd, ki, kv, gain, saturation (one per controlled coordinate each), quantisation (one per sensed
    coordinate), the velocity filter's taps, then K row by row (state feedback; empty otherwise), then
    the velocity feedforward weights (``cascade_pi``, one per coordinate; empty otherwise), then which delay each
    drive applies (:meth:`Controller.drive_weights`; empty without drive delays)."""
    return np.concatenate([controller.kp, controller.kd, controller.ki, controller.kv,
                           drive_gains(controller, parameters), controller.saturation, controller.quantisation,
                           controller.velocity_filter, controller.K.ravel(), controller.velocity_feedforward,
                           controller.drive_weights()])


def gain_index(controller: Controller, k: int) -> int:
    """Where :func:`constants` holds the drive gain of the ``k``-th controlled coordinate (after kp, kd, ki, kv)."""
    return 4 * controller.size + k


def _applied(controller: Controller, line: list, u: ca.SX, weights: ca.SX) -> ca.SX:
    """The outputs applied now (``line`` oldest first, u now): ``delay`` samples ago, or with drive delays
    coordinate k's from ``delay + j`` samples ago, j where its row of ``weights`` holds its 1
    (:meth:`Controller.drive_weights`: a number of the loop, so that one compiled loop applies any of them)."""
    if not line:
        return u
    past = [u, *reversed(line)]  # past[i]: the output of i samples ago
    if not controller.drive_slots:
        return past[controller.delay]
    slots = controller.drive_slots + 1
    return ca.vertcat(*[sum(weights[k * slots + j] * past[controller.delay + j][k] for j in range(slots))
                        for k in range(controller.size)])


# -- the delay line -------------------------------------------------------------------------------------------


def line_outside(controller: Controller) -> bool:
    """Whether ``controller``'s delay is kept in a :class:`DelayLine` (longer than :data:`LINE_IN_MEMORY`)."""
    return controller.line_length > LINE_IN_MEMORY


class DelayLine:
    """u_k applied at sample k + delay, as a ring buffer: ``delay`` rows of nc, u_k in row k mod delay.

    The output applied at sample k is u_{k−delay}, in the row where u_k goes: :meth:`applied` reads the
    rows of a run of samples, then :meth:`computed` writes the run's outputs there — O(1) per sample. Rows start at 0: no
    output before the first computed one arrives (module docstring).
    """

    def __init__(self, delay: int, size: int) -> None:
        if delay < 1:
            raise ValueError(f"a delay line needs a delay ≥ 1, got {delay}")
        self.delay = delay
        self.rows = np.zeros((delay, size))

    def applied(self, start: int, count: int) -> np.ndarray:
        """The outputs applied at samples start … start+count−1 (count × nc), count ≤ delay."""
        if count > self.delay:
            raise ValueError(f"{count} samples at once exceed the delay {self.delay}: their outputs are not known yet")
        return self.rows[(start + np.arange(count)) % self.delay]

    def computed(self, start: int, outputs: np.ndarray) -> None:
        """Store the outputs u computed at samples start … (count × nc), after :meth:`applied` read their rows."""
        self.rows[(start + np.arange(len(outputs))) % self.delay] = outputs


def _cascade_pi(r: ca.SX, measured: ca.SX, velocity: ca.SX, last_velocity: ca.SX, integral: ca.SX,
                gains: tuple[ca.SX, ca.SX, ca.SX, ca.SX], weight: ca.SX, saturation: ca.SX,
                period: float) -> tuple[ca.SX, ca.SX]:
    """The unsaturated command and the next integral of ``cascade_pi`` (docs/simulation.md):
    v_ref = kp_pos·(r − q_m) + ff_vel·ṙ, e = v_ref − v, w = kp_vel·e + ki·I_k − kd_vel·(v − v_k−1)/T + ff;
    I_k+1 = I_k + T·e (forward Euler: the integral acts from the next sample), held while the command is
    clamped and e would drive it further (clamping anti-windup). The integral returned is followed by v,
    the filtered velocity the next sample's derivative needs."""
    kp, kv, ki, kd = gains
    nc = measured.numel()
    position, rate, feedforward = r[:nc], r[nc:2 * nc], r[2 * nc:]
    error = kp * (position - measured) + weight * rate - velocity
    w = kv * error + ki * integral - kd * (velocity - last_velocity) / period + feedforward
    winding = ca.logic_and(ca.fabs(w) > saturation, error * w > 0)
    return w, ca.vertcat(ca.if_else(winding, integral, integral + period * error), velocity)


# -- the step ---------------------------------------------------------------------------------------------------


def controller_function(controller: Controller, model_coordinates: Sequence[str], period: float,
                        external: bool = False) -> ca.Function:
    """One controller sample as a CasADi function.

    ``(m, q, r, d, tau_log, c) -> (m_next, tau)``: ``m`` the memory (:meth:`Controller.memory_size`,
    zeros at the start), ``q`` the model's positions (n), ``r`` the reference (of the controlled
    coordinates, or x_ref of a state feedback: :attr:`Controller.reference_size`), ``d`` the
    disturbance of the controlled coordinates, ``tau_log`` the logged generalized forces (n, for
    ``torque``), ``c`` from :func:`constants`; ``tau`` the generalized force over the coming sample (n).

    ``external``: the delay line is the caller's (:class:`DelayLine`): ``(m, q, r, d, tau_log, c, a) ->
    (m_next, tau, u)`` with ``m`` of :meth:`Controller.memory_size` ``(line=False)``, ``a`` the output
    applied at this sample (u of ``delay`` samples ago) and ``u`` the one computed now.
    """
    nc, n, taps = controller.size, len(model_coordinates), len(controller.velocity_filter)
    names = list(model_coordinates)
    index = [names.index(c) for c in controller.coordinates]
    sensors = controller.sensors
    ns, nx = len(sensors), controller.reference_size
    length = 0 if external else controller.line_length
    memory = ca.SX.sym("m", controller.memory_size(line=not external))
    q, r, d = ca.SX.sym("q", n), ca.SX.sym("r", nx), ca.SX.sym("d", nc)
    tau_log = ca.SX.sym("tau_log", n)
    nf = len(controller.velocity_feedforward)
    drive = controller.drive_weights().size
    c = ca.SX.sym("c", 6 * nc + ns + taps + controller.K.size + nf + drive)
    kp, kd, ki, kv, gain, saturation = (c[i * nc:(i + 1) * nc] for i in range(6))
    resolution = c[6 * nc:6 * nc + ns]
    weights = c[6 * nc + ns:6 * nc + ns + taps]
    # K row by row: CasADi reshapes column-major, so the transpose of the (states × inputs) reshape
    K = ca.reshape(c[6 * nc + ns + taps:6 * nc + ns + taps + controller.K.size], nx, nc).T \
        if controller.kind == STATE_FEEDBACK else None
    feedforward_weight = c[c.numel() - drive - nf:c.numel() - drive]
    drive_weights = c[c.numel() - drive:]
    started, last = memory[0], memory[1:1 + ns]
    at = 1 + ns
    past = [memory[at + i * ns: at + (i + 1) * ns] for i in range(taps - 1)]  # v_b,k-1, v_b,k-2, ...
    at += ns * (taps - 1)
    integral = memory[at:at + nc]
    at += nc
    last_velocity = memory[at:at + nc] if controller.kind == CASCADE_PI else None  # v_k-1, for kd_velocity
    at += nc if controller.kind == CASCADE_PI else 0
    line = [memory[at + i * nc: at + (i + 1) * nc] for i in range(length)]  # oldest first

    position = ca.vertcat(*[q[names.index(s)] for s in sensors])
    # the sensor: rounding to the resolution (floor(x + 1/2): round half up, as a counter does)
    measured = ca.if_else(resolution > 0, ca.floor(position / ca.fmax(resolution, 1e-300) + 0.5) * resolution, position)
    backward = started * (measured - last) / period
    velocity = weights[0] * backward
    for i, v in enumerate(past):
        velocity += weights[i + 1] * v
    if controller.kind == STATE_FEEDBACK:
        where = {s: k for k, s in enumerate(sensors)}
        x = ca.vertcat(*[(measured if signal == "q" else velocity)[where[c]] for signal, c in controller.states])
        u, integral_next = -ca.mtimes(K, x - r), integral
    elif controller.kind == CASCADE_PI:
        u, integral_next = _cascade_pi(r, measured, velocity, last_velocity, integral, (kp, kv, ki, kd),
                                       feedforward_weight, saturation, period)
    else:
        error = r - measured
        integral_next = integral + period * error
        u = {
            "torque": ca.vertcat(*[tau_log[i] for i in index]),
            "pd": kp * error - kd * velocity,
            "pid": kp * error - kd * velocity + ki * integral_next,
            "cascade": kv * (kp * error - velocity),
        }[controller.kind]
    u = ca.fmin(ca.fmax(u, -saturation), saturation)
    a = ca.SX.sym("a", nc) if external else None
    applied = a if external else _applied(controller, line, u, drive_weights)
    force = gain * (applied + d)
    tau = ca.SX.zeros(n)
    for j, i in enumerate(index):
        tau[i] = force[j]
    next_memory = ca.vertcat(ca.SX(1), measured, *([backward] + past[:-1] if taps > 1 else []), integral_next,
                             *(line[1:] + [u] if line else []))
    if external:
        return ca.Function("controller", [memory, q, r, d, tau_log, c, a], [next_memory, tau, u],
                           ["m", "q", "r", "d", "tau_log", "c", "a"], ["m_next", "tau", "u"])
    return ca.Function("controller", [memory, q, r, d, tau_log, c], [next_memory, tau],
                       ["m", "q", "r", "d", "tau_log", "c"], ["m_next", "tau"])

"""The machine's controller, as declared in an experiment file's ``[controller]`` table.

::

    [controller]
    kind = "pd"                   # torque | pd | pid | cascade | state_feedback
    coordinates = ["q"]           # controlled coordinates (default: those of the data)
    kp = [40.0]                   # per coordinate, in the order of `coordinates`
    kd = [2.0]                    # pd, pid;  ki: pid;  kv: cascade
    gain = [1.0]                  # output -> generalized force: numbers or expressions of the model's
                                  # parameters (a single string applies to every coordinate: "gtau")
    reference = "ref"             # the data's ref_<c> columns, or one expression of t (and of the data's
                                  # columns) per coordinate: ["0.3*sin(2*pi*0.5*t)"]
    saturation = [10.0]           # limit of the controller output (before the gain)
    quantisation = [1.5708e-4]    # the position sensor's resolution (units of q per count)
    disturbance = ["pulses_N"]    # an expression of the data's columns added after saturation
    delay = 0                     # samples between measuring q_k and applying u_k
    velocity_filter = [0.5, 0.5]  # FIR taps applied to the backward-difference velocity

The controller is discrete, at the log's sample period T, with zero-order hold. At sample k it reads
the position q_m,k (the simulated position, rounded to the sensor's resolution), forms the
backward-difference velocity v_b,k = (q_m,k − q_m,k−1)/T (0 at the first sample), filters it,
v_k = Σ_i taps_i·v_b,k−i (v_b before the first sample is 0), and computes

* ``torque``: u_k = τ_measured,k (open-loop replay of the log's generalized force, gain 1 by default);
* ``pd``: u_k = kp·(r_k − q_m,k) − kd·v_k;
* ``pid``: the same + ki·I_k with I_k = I_k−1 + T·(r_k − q_m,k) (no anti-windup);
* ``cascade`` (EMPS's P/P position–velocity loop): u_k = kv·(kp·(r_k − q_m,k) − v_k);
* ``state_feedback``: u_k = −K·(x_k − x_ref,k), see below;

then u is saturated to ±saturation, delayed by ``delay`` samples (zero before the first computed
output arrives), the disturbance d_k is added and the generalized force is τ_k = gain·(u + d_k),
held over [t_k, t_k+1). Coordinates the controller does not drive get τ = 0.

State feedback (an LQR, a pole placement) names the driven coordinates ``inputs`` and the state vector
``states`` in the canonical signal names, and K has one row per input and one column per state::

    [controller]
    kind = "state_feedback"
    inputs = ["theta"]                                    # the driven coordinates (rows of K)
    states = ["q_theta", "q_alpha", "qd_theta", "qd_alpha"]  # the state vector x (columns of K)
    K = [[6.32, -1.67, 1.05, 0.30]]                       # signed; one row per input
    gain = [0.05]                 # per input; saturation, disturbance likewise
    quantisation = [1e-3, 1e-3]   # per sensed coordinate: those of `states`, in order (theta, alpha)

x_k holds, for ``q_<c>``, the measured position q_m,k of c and, for ``qd_<c>``, its filtered
backward-difference velocity v_k — the same sensor as the other kinds, for every coordinate named in
``states``; x_ref,k holds the data's ``ref_<c>`` and ``refd_<c>`` columns (0 where the data have none).
A feedforward is declared as for the other kinds: a ``disturbance`` column or expression, added
after saturation and delay.

:func:`controller_function` builds this step as a CasADi function, so that the closed loop runs in
compiled code; :func:`parse` validates the table with one-line errors naming the file and key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from symbolic.data import DataError, Measurements
from symbolic.errors import ModelError
from symbolic.description.expressions import RESERVED_NAMES, parse_expression, variable_names

STATE_FEEDBACK = "state_feedback"

KINDS = ("torque", "pd", "pid", "cascade", STATE_FEEDBACK)

GAINS = {"torque": (), "pd": ("kp", "kd"), "pid": ("kp", "kd", "ki"), "cascade": ("kp", "kv"), STATE_FEEDBACK: ()}
"""The loop gains each kind needs (all per coordinate, ≥ 0); state feedback has its matrix ``K`` instead."""

COMMON_KEYS = ("kind", "coordinates", "gain", "saturation", "quantisation", "disturbance", "delay")
LOOP_KEYS = ("reference", "velocity_filter")
STATE_FEEDBACK_KEYS = ("kind", "inputs", "states", "K", "gain", "saturation", "quantisation", "disturbance", "delay",
                       "velocity_filter")

KEYS = (*COMMON_KEYS, "kp", "kd", "ki", "kv", *LOOP_KEYS, "inputs", "states", "K")

STATE_SIGNALS = ("q", "qd")
"""The signals a state of ``states`` may name: ``q_<c>`` (position) and ``qd_<c>`` (velocity)."""


def allowed_keys(kind: str) -> tuple[str, ...]:
    """The keys a ``[controller]`` table of ``kind`` may have."""
    if kind == STATE_FEEDBACK:
        return STATE_FEEDBACK_KEYS
    return COMMON_KEYS + (GAINS[kind] + LOOP_KEYS if kind != "torque" else ())


@dataclass(frozen=True, eq=False)
class Controller:
    """A validated ``[controller]`` table (module docstring); per-coordinate arrays in the order of ``coordinates``.

    Attributes
    ----------
    kind
        One of :data:`KINDS`.
    coordinates
        The controlled (driven) coordinates: ``coordinates``, or ``inputs`` for state feedback.
    kp, kd, ki, kv
        Loop gains (zero where the kind has none).
    gain
        Output-to-force gains, as expressions of the model's parameters (numbers are constants).
    reference
        ``"ref"`` (the data's ref_<c> columns), a tuple of expressions, or ``None`` (torque, state feedback).
    saturation
        Output limits (``inf``: none).
    quantisation
        Sensor resolutions (0: none), one per coordinate of :attr:`sensors`.
    disturbance
        Expressions of the data's columns added after saturation, or ``None``.
    delay
        Samples between measuring and applying.
    velocity_filter
        FIR taps on the backward-difference velocity (``[1.0]``: none).
    source
        The experiment file, for messages.
    states
        State feedback: the state vector, ``(signal, coordinate)`` with signal ``"q"`` or ``"qd"``; else empty.
    K
        State feedback: the gain matrix, inputs × states (signed); else 0 × 0.
    """

    kind: str
    coordinates: tuple[str, ...]
    kp: np.ndarray
    kd: np.ndarray
    ki: np.ndarray
    kv: np.ndarray
    gain: tuple[sp.Expr, ...]
    reference: str | tuple[str, ...] | None
    saturation: np.ndarray
    quantisation: np.ndarray
    disturbance: tuple[str, ...] | None
    delay: int
    velocity_filter: np.ndarray
    source: str = "<controller>"
    states: tuple[tuple[str, str], ...] = ()
    K: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def size(self) -> int:
        """Number of controlled coordinates."""
        return len(self.coordinates)

    @property
    def sensors(self) -> tuple[str, ...]:
        """The coordinates whose positions the controller reads: the controlled ones, or for state feedback
        those named in ``states``, in order of first appearance."""
        if self.kind != STATE_FEEDBACK:
            return self.coordinates
        return tuple(dict.fromkeys(c for _, c in self.states))

    @property
    def reference_size(self) -> int:
        """Length of the reference input per sample: one per coordinate, or x_ref (one per state)."""
        return len(self.states) if self.kind == STATE_FEEDBACK else self.size

    def state_names(self) -> list[str]:
        """The states as written in the table (``q_<c>``, ``qd_<c>``)."""
        return [f"{signal}_{c}" for signal, c in self.states]

    def memory_size(self) -> int:
        """Length of the controller's state: started flag, last positions, past velocities, integral, delay line."""
        nc, ns = self.size, len(self.sensors)
        return 1 + ns + ns * (len(self.velocity_filter) - 1) + nc + nc * self.delay

    def structure(self) -> tuple[Any, ...]:
        """What the controller's compiled function depends on besides its numbers (:func:`constants`)."""
        return (self.kind, self.coordinates, tuple(self.states), self.delay, len(self.velocity_filter))

    def describe(self) -> str:
        """One line: kind, coordinates and the optional features in use."""
        parts = [f"{self.kind} on {', '.join(self.coordinates)}"]
        if self.kind == STATE_FEEDBACK:
            parts[0] += f" from {', '.join(self.state_names())}"
        if np.isfinite(self.saturation).any():
            parts.append(f"saturation ±{', '.join(f'{s:g}' for s in self.saturation)}")
        if self.quantisation.any():
            parts.append(f"quantisation {', '.join(f'{r:g}' for r in self.quantisation)}")
        if self.disturbance:
            parts.append(f"disturbance {', '.join(self.disturbance)}")
        if self.delay:
            parts.append(f"delay {self.delay} sample(s)")
        if len(self.velocity_filter) > 1:
            parts.append(f"velocity filter {list(map(float, self.velocity_filter))}")
        return "; ".join(parts)


def replay(coordinates: Sequence[str], source: str = "<controller>") -> Controller:
    """The open-loop ``torque`` controller on ``coordinates`` (what a log without ``[controller]`` gets)."""
    return parse({"kind": "torque", "coordinates": list(coordinates)}, coordinates, (), source)


def parse(
    table: Mapping[str, Any],
    data_coordinates: Sequence[str],
    model_parameters: Sequence[sp.Symbol],
    source: str = "<controller>",
    model_coordinates: Sequence[str] | None = None,
) -> Controller:
    """Validate a ``[controller]`` table: the one place where its keys are checked.

    Parameters
    ----------
    table
        The table as read from TOML (or a dict).
    data_coordinates
        The coordinates the data measure (q_<c> columns): a controller reads their positions.
    model_parameters
        The model's parameter symbols, which ``gain`` expressions may use.
    source
        The experiment file, for messages.
    model_coordinates
        The model's coordinates, to tell "not in the model" from "not in the data" (default: the data's).

    Raises
    ------
    DataError
        One line naming the file, ``[controller] <key>``, what is wrong and what is allowed.
    """
    if not isinstance(table, Mapping):
        raise DataError(source, "[controller]", f"expected a table, got {type(table).__name__}")
    kind = table.get("kind")
    if kind not in KINDS:
        raise DataError(source, "[controller] kind", f"expected one of {', '.join(KINDS)}, got {kind!r}")
    allowed = allowed_keys(kind)
    for key in table:
        if key not in allowed:
            what = f"not used by kind '{kind}'" if key in KEYS else "unknown key"
            raise DataError(source, f"[controller] {key}", f"{what} (allowed for '{kind}': {', '.join(allowed)})")
    model = model_coordinates or data_coordinates
    if kind == STATE_FEEDBACK:
        return _state_feedback(table, data_coordinates, model, model_parameters, source)
    coordinates = _coordinates(table, "coordinates", data_coordinates, model, source)
    nc = len(coordinates)
    per = _PerCoordinate(table, coordinates, source)
    gains = {name: per.numbers(name, required=True, minimum=0.0) for name in GAINS[kind]}
    zeros = np.zeros(nc)
    reference = _reference(table, nc, source) if kind != "torque" else None
    return Controller(
        kind=kind,
        coordinates=coordinates,
        kp=gains.get("kp", zeros),
        kd=gains.get("kd", zeros),
        ki=gains.get("ki", zeros),
        kv=gains.get("kv", zeros),
        gain=_gain(table, coordinates, model_parameters, source),
        reference=reference,
        saturation=per.numbers("saturation", default=math.inf, minimum=0.0, strict=True),
        quantisation=per.numbers("quantisation", default=0.0, minimum=0.0),
        disturbance=per.strings("disturbance"),
        delay=_delay(table, source),
        velocity_filter=_taps(table, source),
        source=source,
    )


_STATE_FEEDBACK_HELP = 'inputs = ["<c>", ...], states = ["q_<c>", "qd_<c>", ...], K = [[...], ...] one row per input'


def _state_feedback(table: Mapping[str, Any], data: Sequence[str], model: Sequence[str],
                    parameters: Sequence[sp.Symbol], source: str) -> Controller:
    """The ``state_feedback`` kind: u = −K·(x − x_ref), K inputs × states."""
    for key in ("inputs", "states", "K"):
        if key not in table:
            raise DataError(source, f"[controller] {key}", f"missing (state feedback needs inputs, states and K: "
                                                           f"{_STATE_FEEDBACK_HELP})")
    inputs = _coordinates(table, "inputs", data, model, source)
    states = _states(table["states"], data, model, source)
    per = _PerCoordinate(table, inputs, source)
    sensors = tuple(dict.fromkeys(c for _, c in states))
    sensed = _PerCoordinate(table, sensors, source, "sensed coordinate, those of states in order")
    zeros = np.zeros(len(inputs))
    return Controller(
        kind=STATE_FEEDBACK,
        coordinates=inputs,
        kp=zeros, kd=zeros, ki=zeros, kv=zeros,
        gain=_gain(table, inputs, parameters, source),
        reference=None,
        saturation=per.numbers("saturation", default=math.inf, minimum=0.0, strict=True),
        quantisation=sensed.numbers("quantisation", default=0.0, minimum=0.0),
        disturbance=per.strings("disturbance"),
        delay=_delay(table, source),
        velocity_filter=_taps(table, source),
        source=source,
        states=states,
        K=_matrix(table["K"], inputs, states, source),
    )


def _states(value: Any, data: Sequence[str], model: Sequence[str], source: str) -> tuple[tuple[str, str], ...]:
    """``states``: distinct ``q_<c>`` / ``qd_<c>`` names of measured coordinates of the model."""
    key = "[controller] states"
    allowed = f"q_<c> or qd_<c> with c one of {', '.join(model)}"
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise DataError(source, key, f"expected a non-empty list of state names ({allowed}), got {value!r}")
    if len(set(value)) != len(value):
        raise DataError(source, key, f"state listed twice in {value!r}")
    states = []
    for k, name in enumerate(value):
        signal, _, c = name.partition("_")
        if signal not in STATE_SIGNALS or not c:
            raise DataError(source, f"{key}[{k}]", f"unknown state name {name!r} (allowed: {allowed})")
        if c not in model:
            raise DataError(source, f"{key}[{k}]", f"{name!r} names coordinate {c!r}, which the model does not have "
                                                   f"(allowed: {allowed})")
        if c not in data:
            raise DataError(source, f"{key}[{k}]", f"{name!r}: coordinate {c!r} is not measured, the data have no "
                                                   f"q_{c} (measured: {', '.join(data)})")
        states.append((signal, c))
    return tuple(states)


def _matrix(value: Any, inputs: tuple[str, ...], states: tuple[tuple[str, str], ...], source: str) -> np.ndarray:
    """``K``: one row per input, one signed number per state; a flat list when there is one input."""
    rows, columns = len(inputs), len(states)
    shape = (f"{rows} row(s) (one per input: {', '.join(inputs)}) of {columns} number(s) (one per state: "
             f"{', '.join(f'{s}_{c}' for s, c in states)})")
    if rows == 1 and isinstance(value, list) and value and not isinstance(value[0], list):
        value = [value]
    if not isinstance(value, list) or len(value) != rows or not all(isinstance(r, list) for r in value):
        got = f"{len(value)} row(s)" if isinstance(value, list) else repr(value)
        raise DataError(source, "[controller] K", f"expected {shape}, got {got}")
    for i, row in enumerate(value):
        if len(row) != columns:
            raise DataError(source, f"[controller] K[{i}]", f"has {len(row)} number(s), expected {columns}: "
                                                            f"K has {shape}")
        for j, v in enumerate(row):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise DataError(source, f"[controller] K[{i}][{j}]", f"expected a finite number (signed), got {v!r}")
    return np.array(value, dtype=float).reshape(rows, columns)


def _coordinates(table: Mapping[str, Any], name: str, data: Sequence[str], model: Sequence[str],
                 source: str) -> tuple[str, ...]:
    key = f"[controller] {name}"
    if name not in table:
        return tuple(data)
    value = table[name]
    if not isinstance(value, list) or not value or not all(isinstance(c, str) for c in value):
        raise DataError(source, key, f"expected a non-empty list of coordinate names, got {value!r}")
    if len(set(value)) != len(value):
        raise DataError(source, key, f"coordinate listed twice in {value!r}")
    for c in value:
        if c not in model:
            raise DataError(source, key, f"unknown coordinate {c!r} (the model's coordinates: {', '.join(model)})")
        if c not in data:
            raise DataError(source, key, f"coordinate {c!r} is not measured: the data have no q_{c} "
                                         f"(measured: {', '.join(data)})")
    return tuple(value)


class _PerCoordinate:
    """Reads per-coordinate lists (one entry per controlled coordinate)."""

    def __init__(self, table: Mapping[str, Any], coordinates: tuple[str, ...], source: str,
                 what: str = "coordinate") -> None:
        self.table, self.coordinates, self.source, self.what = table, coordinates, source, what

    def _list(self, name: str) -> list[Any]:
        value = self.table[name]
        n = len(self.coordinates)
        if not isinstance(value, list) or len(value) != n:
            raise DataError(self.source, f"[controller] {name}",
                            f"expected a list of {n} value(s), one per {self.what} ({', '.join(self.coordinates)}), "
                            f"got {value!r}")
        return value

    def numbers(self, name: str, *, required: bool = False, default: float = 0.0, minimum: float = 0.0,
                strict: bool = False) -> np.ndarray:
        if name not in self.table:
            if required:
                raise DataError(self.source, f"[controller] {name}", "missing (a list with one number per coordinate)")
            return np.full(len(self.coordinates), default)
        out = []
        for k, v in enumerate(self._list(name)):
            key = f"[controller] {name}[{k}]"
            if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v) or (
                    math.isinf(v) and not (strict and v > 0)):
                raise DataError(self.source, key, f"expected a finite number, got {v!r}")
            if v < minimum or (strict and v <= minimum):
                bound = f"> {minimum:g}" if strict else f"≥ {minimum:g}"
                raise DataError(self.source, key, f"{v!r} is {'negative' if v < 0 else 'not allowed'} "
                                                  f"(allowed: numbers {bound})")
            out.append(float(v))
        return np.array(out)

    def strings(self, name: str) -> tuple[str, ...] | None:
        if name not in self.table:
            return None
        values = self._list(name)
        for k, v in enumerate(values):
            if not isinstance(v, str) or not v.strip():
                raise DataError(self.source, f"[controller] {name}[{k}]",
                                f"expected a column name or an expression of the data's columns, got {v!r}")
        return tuple(values)


def _reference(table: Mapping[str, Any], nc: int, source: str) -> str | tuple[str, ...]:
    key = "[controller] reference"
    if "reference" not in table:
        raise DataError(source, key, 'missing: "ref" (the data\'s ref_<c> columns) or a list of expressions of t')
    value = table["reference"]
    if value == "ref":
        return "ref"
    if isinstance(value, list) and len(value) == nc and all(isinstance(v, (str, int, float)) and not isinstance(v, bool)
                                                            for v in value):
        return tuple(str(v) for v in value)
    raise DataError(source, key, f'expected "ref" or a list of {nc} expression(s) of t, got {value!r}')


def _gain(table: Mapping[str, Any], coordinates: tuple[str, ...], parameters: Sequence[sp.Symbol],
          source: str) -> tuple[sp.Expr, ...]:
    value = table.get("gain", 1.0)
    values = [value] * len(coordinates) if isinstance(value, (str, int, float)) else value
    if not isinstance(values, list) or len(values) != len(coordinates):
        raise DataError(source, "[controller] gain", f"expected a number, a parameter name or a list of "
                                                     f"{len(coordinates)} of them, got {value!r}")
    symbols = {s.name: s for s in parameters}
    out = []
    for k, v in enumerate(values):
        key = f"[controller] gain[{k}]" if isinstance(value, list) else "[controller] gain"
        if isinstance(v, str):
            _check_names(v, symbols, source, key, "the model's parameters")
        try:
            expression = parse_expression(v, symbols, source, key)
        except ModelError as error:
            raise DataError(error.source, error.key, error.problem) from None
        if not expression.free_symbols and float(expression) < 0:
            raise DataError(source, key, f"{v!r} is negative (allowed: numbers ≥ 0 or expressions of the parameters)")
        out.append(expression)
    return tuple(out)


def _delay(table: Mapping[str, Any], source: str) -> int:
    value = table.get("delay", 0)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise DataError(source, "[controller] delay", f"expected a whole number of samples ≥ 0, got {value!r}")
    return value


def _taps(table: Mapping[str, Any], source: str) -> np.ndarray:
    value = table.get("velocity_filter", [1.0])
    if (not isinstance(value, list) or not value or len(value) > 64
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise DataError(source, "[controller] velocity_filter",
                        f"expected a list of 1 to 64 finite numbers (FIR taps, newest sample first), got {value!r}")
    return np.array(value, dtype=float)


def _check_names(text: str, symbols: Mapping[str, Any], source: str, key: str, what: str) -> None:
    """Refuse a name that is neither declared nor a constant, listing what is declared."""
    for name in variable_names(text):
        if name not in symbols:
            raise DataError(source, key, f"unknown name {name!r} in {text!r} (allowed: {what}: "
                                         f"{', '.join(symbols) or 'none'})")


# -- the signals a controller reads from the log -------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Inputs:
    """Per-sample inputs of the controller: references (samples × :attr:`Controller.reference_size`),
    disturbances (samples × nc), measured forces (samples × n)."""

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
    disturbance = np.zeros((samples, nc))
    if controller.disturbance is not None:
        disturbance = _evaluate_all(controller.disturbance, measurements, "disturbance")
    torque = np.zeros((samples, len(model_coordinates)))
    for j, c in enumerate(data):
        torque[:, list(model_coordinates).index(c)] = measurements.tau[:, j]
    return Inputs(np.ascontiguousarray(reference), np.ascontiguousarray(disturbance), torque)


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
    columns = measurements.columns()
    source = str(measurements.source)
    symbols = {name: sp.Symbol(name) for name in columns if name.isidentifier() and name not in RESERVED_NAMES}
    _check_names(text, symbols, source, key, "t and the data's columns")
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


def drive_gains(controller: Controller, parameters: Mapping[sp.Symbol, float]) -> np.ndarray:
    """The output-to-force gains at ``parameters``, one per controlled coordinate.

    Raises
    ------
    DataError
        For a gain that is not a finite number ≥ 0 at these values.
    """
    gain = []
    for k, g in enumerate(controller.gain):
        value = float(g.xreplace(parameters))
        if not math.isfinite(value) or value < 0:
            raise DataError(controller.source, f"[controller] gain[{k}]",
                            f"{g} = {value:g} at the model's parameter values (allowed: ≥ 0)")
        gain.append(value)
    return np.array(gain)


def constants(controller: Controller, parameters: Mapping[sp.Symbol, float]) -> np.ndarray:
    """The numbers :func:`controller_function` takes as its ``c`` input (gains evaluated at ``parameters``):
    kp, kd, ki, kv, gain, saturation (one per controlled coordinate each), quantisation (one per sensed
    coordinate), the velocity filter's taps, then K row by row (state feedback; empty otherwise)."""
    return np.concatenate([controller.kp, controller.kd, controller.ki, controller.kv,
                           drive_gains(controller, parameters), controller.saturation, controller.quantisation,
                           controller.velocity_filter, controller.K.ravel()])


def controller_function(controller: Controller, model_coordinates: Sequence[str], period: float) -> ca.Function:
    """One controller sample as a CasADi function.

    ``(m, q, r, d, tau_log, c) -> (m_next, tau)``: ``m`` the memory (:meth:`Controller.memory_size`,
    zeros at the start), ``q`` the model's positions (n), ``r`` the reference (of the controlled
    coordinates, or x_ref of a state feedback: :attr:`Controller.reference_size`), ``d`` the
    disturbance of the controlled coordinates, ``tau_log`` the logged generalized forces (n, for
    ``torque``), ``c`` from :func:`constants`; ``tau`` the generalized force over the coming sample (n).
    """
    nc, n, taps = controller.size, len(model_coordinates), len(controller.velocity_filter)
    names = list(model_coordinates)
    index = [names.index(c) for c in controller.coordinates]
    sensors = controller.sensors
    ns, nx = len(sensors), controller.reference_size
    memory = ca.SX.sym("m", controller.memory_size())
    q, r, d = ca.SX.sym("q", n), ca.SX.sym("r", nx), ca.SX.sym("d", nc)
    tau_log = ca.SX.sym("tau_log", n)
    c = ca.SX.sym("c", 6 * nc + ns + taps + controller.K.size)
    kp, kd, ki, kv, gain, saturation = (c[i * nc:(i + 1) * nc] for i in range(6))
    resolution = c[6 * nc:6 * nc + ns]
    weights = c[6 * nc + ns:6 * nc + ns + taps]
    # K row by row: CasADi reshapes column-major, so the transpose of the (states × inputs) reshape
    K = ca.reshape(c[6 * nc + ns + taps:], nx, nc).T if controller.kind == STATE_FEEDBACK else None
    started, last = memory[0], memory[1:1 + ns]
    at = 1 + ns
    past = [memory[at + i * ns: at + (i + 1) * ns] for i in range(taps - 1)]  # v_b,k-1, v_b,k-2, ...
    at += ns * (taps - 1)
    integral = memory[at:at + nc]
    at += nc
    line = [memory[at + i * nc: at + (i + 1) * nc] for i in range(controller.delay)]  # oldest first

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
    applied = line[0] if line else u
    force = gain * (applied + d)
    tau = ca.SX.zeros(n)
    for j, i in enumerate(index):
        tau[i] = force[j]
    next_memory = ca.vertcat(ca.SX(1), measured, *([backward] + past[:-1] if taps > 1 else []), integral_next,
                             *(line[1:] + [u] if line else []))
    return ca.Function("controller", [memory, q, r, d, tau_log, c], [next_memory, tau],
                       ["m", "q", "r", "d", "tau_log", "c"], ["m_next", "tau"])

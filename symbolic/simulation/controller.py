"""The machine's controller, as declared in an experiment file's ``[controller]`` table.

::

    [controller]
    kind = "pd"                   # torque | pd | pid | cascade
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

then u is saturated to ±saturation, delayed by ``delay`` samples (zero before the first computed
output arrives), the disturbance d_k is added and the generalized force is τ_k = gain·(u + d_k),
held over [t_k, t_k+1). Coordinates the controller does not drive get τ = 0.

:func:`controller_function` builds this step as a CasADi function, so that the closed loop runs in
compiled code; :func:`parse` validates the table with one-line errors naming the file and key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from symbolic.data import DataError, Measurements
from symbolic.errors import ModelError
from symbolic.description.expressions import RESERVED_NAMES, parse_expression, variable_names

KINDS = ("torque", "pd", "pid", "cascade")

GAINS = {"torque": (), "pd": ("kp", "kd"), "pid": ("kp", "kd", "ki"), "cascade": ("kp", "kv")}
"""The loop gains each kind needs (all per coordinate, ≥ 0)."""

COMMON_KEYS = ("kind", "coordinates", "gain", "saturation", "quantisation", "disturbance", "delay")
LOOP_KEYS = ("reference", "velocity_filter")

KEYS = (*COMMON_KEYS, "kp", "kd", "ki", "kv", *LOOP_KEYS)


def allowed_keys(kind: str) -> tuple[str, ...]:
    """The keys a ``[controller]`` table of ``kind`` may have."""
    return COMMON_KEYS + (GAINS[kind] + LOOP_KEYS if kind != "torque" else ())


@dataclass(frozen=True, eq=False)
class Controller:
    """A validated ``[controller]`` table (module docstring); per-coordinate arrays in the order of ``coordinates``.

    Attributes
    ----------
    kind
        One of :data:`KINDS`.
    coordinates
        The controlled coordinates.
    kp, kd, ki, kv
        Loop gains (zero where the kind has none).
    gain
        Output-to-force gains, as expressions of the model's parameters (numbers are constants).
    reference
        ``"ref"`` (the data's ref_<c> columns), a tuple of expressions, or ``None`` (torque).
    saturation
        Output limits (``inf``: none).
    quantisation
        Sensor resolutions (0: none).
    disturbance
        Expressions of the data's columns added after saturation, or ``None``.
    delay
        Samples between measuring and applying.
    velocity_filter
        FIR taps on the backward-difference velocity (``[1.0]``: none).
    source
        The experiment file, for messages.
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

    @property
    def size(self) -> int:
        """Number of controlled coordinates."""
        return len(self.coordinates)

    def memory_size(self) -> int:
        """Length of the controller's state: started flag, last position, past velocities, integral, delay line."""
        nc = self.size
        return 1 + nc + nc * (len(self.velocity_filter) - 1) + nc + nc * self.delay

    def describe(self) -> str:
        """One line: kind, coordinates and the optional features in use."""
        parts = [f"{self.kind} on {', '.join(self.coordinates)}"]
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
    """Validate a ``[controller]`` table.

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
    coordinates = _coordinates(table, data_coordinates, model_coordinates or data_coordinates, source)
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


def _coordinates(table: Mapping[str, Any], data: Sequence[str], model: Sequence[str], source: str) -> tuple[str, ...]:
    key = "[controller] coordinates"
    if "coordinates" not in table:
        return tuple(data)
    value = table["coordinates"]
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

    def __init__(self, table: Mapping[str, Any], coordinates: tuple[str, ...], source: str) -> None:
        self.table, self.coordinates, self.source = table, coordinates, source

    def _list(self, name: str) -> list[Any]:
        value = self.table[name]
        n = len(self.coordinates)
        if not isinstance(value, list) or len(value) != n:
            raise DataError(self.source, f"[controller] {name}",
                            f"expected a list of {n} value(s), one per coordinate ({', '.join(self.coordinates)}), "
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
    """Per-sample inputs of the controller: references and disturbances (samples × nc), measured forces (samples × n)."""

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
    disturbance = np.zeros((samples, nc))
    if controller.disturbance is not None:
        disturbance = _evaluate_all(controller.disturbance, measurements, "disturbance")
    torque = np.zeros((samples, len(model_coordinates)))
    for j, c in enumerate(data):
        torque[:, list(model_coordinates).index(c)] = measurements.tau[:, j]
    return Inputs(np.ascontiguousarray(reference), np.ascontiguousarray(disturbance), torque)


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


def constants(controller: Controller, parameters: Mapping[sp.Symbol, float]) -> np.ndarray:
    """The numbers :func:`controller_function` takes as its ``c`` input (gains evaluated at ``parameters``)."""
    gain = []
    for k, g in enumerate(controller.gain):
        value = float(g.xreplace(parameters))
        if not math.isfinite(value) or value < 0:
            raise DataError(controller.source, f"[controller] gain[{k}]",
                            f"{g} = {value:g} at the model's parameter values (allowed: ≥ 0)")
        gain.append(value)
    return np.concatenate([controller.kp, controller.kd, controller.ki, controller.kv, np.array(gain),
                           controller.saturation, controller.quantisation, controller.velocity_filter])


def controller_function(controller: Controller, model_coordinates: Sequence[str], period: float) -> ca.Function:
    """One controller sample as a CasADi function.

    ``(m, q, r, d, tau_log, c) -> (m_next, tau)``: ``m`` the memory (:meth:`Controller.memory_size`,
    zeros at the start), ``q`` the model's positions (n), ``r``, ``d`` the reference and disturbance
    of the controlled coordinates, ``tau_log`` the logged generalized forces (n, for ``torque``),
    ``c`` from :func:`constants`; ``tau`` the generalized force over the coming sample (n).
    """
    nc, n, taps = controller.size, len(model_coordinates), len(controller.velocity_filter)
    index = [list(model_coordinates).index(c) for c in controller.coordinates]
    memory = ca.SX.sym("m", controller.memory_size())
    q, r, d = ca.SX.sym("q", n), ca.SX.sym("r", nc), ca.SX.sym("d", nc)
    tau_log = ca.SX.sym("tau_log", n)
    c = ca.SX.sym("c", 7 * nc + taps)
    kp, kd, ki, kv, gain, saturation, resolution = (c[i * nc:(i + 1) * nc] for i in range(7))
    weights = c[7 * nc:]
    started, last = memory[0], memory[1:1 + nc]
    at = 1 + nc
    past = [memory[at + i * nc: at + (i + 1) * nc] for i in range(taps - 1)]  # v_b,k-1, v_b,k-2, ...
    at += nc * (taps - 1)
    integral = memory[at:at + nc]
    at += nc
    line = [memory[at + i * nc: at + (i + 1) * nc] for i in range(controller.delay)]  # oldest first

    position = ca.vertcat(*[q[i] for i in index])
    # the sensor: rounding to the resolution (floor(x + 1/2): round half up, as a counter does)
    measured = ca.if_else(resolution > 0, ca.floor(position / ca.fmax(resolution, 1e-300) + 0.5) * resolution, position)
    backward = started * (measured - last) / period
    velocity = weights[0] * backward
    for i, v in enumerate(past):
        velocity += weights[i + 1] * v
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

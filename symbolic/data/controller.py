"""The machine's controller as an experiment file declares it: the ``[controller]`` table, checked once.

This is the description (what the experiment says: kind, coordinates, gains, reference, sensor,
delay, ...; the keys and their meaning in docs/simulation.md, "The controller"); the control law that
runs it in a simulation — the discrete step as a CasADi function, the signals it reads from the log —
is :mod:`symbolic.simulation.controller`. The data layer cannot import the simulation layer, and every
command that reads an experiment (identify, diagnose, first-peak, not only simulate) must refuse a bad
table alike, so the description lives here and the law there.

:func:`parse` validates a table — keys (an unknown or misspelt one gets the allowed keys and a "did
you mean", :mod:`symbolic.data.keys`), kinds, lengths, signs, the coordinates against the model and
the data, ``reference`` and ``disturbance`` against the data's columns, ``gain`` against the model's
parameters — into a frozen :class:`Controller`. The experiment loader (:mod:`symbolic.data.experiment`)
calls it when the file is read.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from symbolic.data.errors import DataError
from symbolic.data.keys import suggestion, unknown_key
from symbolic.data.measurements import MAX_MAGNITUDE
from symbolic.description.reserved import check_magnitude, variable_names
from symbolic.errors import ModelError, shown

if TYPE_CHECKING:
    import sympy as sp

STATE_FEEDBACK = "state_feedback"
CASCADE_PI = "cascade_pi"
"""The industrial cascade: P position loop → PI velocity loop, plus a logged feedforward (docs/simulation.md)."""

KINDS = ("torque", "pd", "pid", "cascade", CASCADE_PI, STATE_FEEDBACK)

GAINS = {"torque": (), "pd": ("kp", "kd"), "pid": ("kp", "kd", "ki"), "cascade": ("kp", "kv"),
         CASCADE_PI: ("kp_position", "kp_velocity", "ki_velocity"), STATE_FEEDBACK: ()}
"""The loop gains each kind needs (all per coordinate, ≥ 0; ``kp_velocity`` > 0); state feedback has its
matrix ``K`` instead."""

CASCADE_PI_KEYS = ("kd_velocity", "velocity_feedforward", "feedforward", "reference_velocity")
"""The optional keys of ``cascade_pi`` besides the loop's: kd_velocity (a derivative on the measured velocity:
the PID velocity loop), ff_vel (the reference velocity's weight in the velocity reference), the logged
feedforward added to the command, and ṙ (default: r's backward difference)."""

COMMON_KEYS = ("kind", "coordinates", "gain", "saturation", "quantisation", "disturbance", "delay")
LOOP_KEYS = ("reference", "velocity_filter")
STATE_FEEDBACK_KEYS = ("kind", "inputs", "states", "K", "gain", "saturation", "quantisation", "disturbance", "delay",
                       "velocity_filter")

KEYS = (*COMMON_KEYS, "kp", "kd", "ki", "kv", *GAINS[CASCADE_PI], *LOOP_KEYS, *CASCADE_PI_KEYS, "inputs", "states",
        "K", "restart")

STATE_SIGNALS = ("q", "qd")
"""The signals a state of ``states`` may name: ``q_<c>`` (position) and ``qd_<c>`` (velocity)."""


REPLAY_KEYS = ("restart",)
"""The keys of ``torque`` (a replay) besides the common ones: ``restart``, the replay in windows (docs/simulation.md,
"Replay in windows")."""


def allowed_keys(kind: str) -> tuple[str, ...]:
    """The keys a ``[controller]`` table of ``kind`` may have."""
    if kind == STATE_FEEDBACK:
        return STATE_FEEDBACK_KEYS
    if kind == "torque":
        return COMMON_KEYS + REPLAY_KEYS
    extra = CASCADE_PI_KEYS if kind == CASCADE_PI else ()
    return COMMON_KEYS + GAINS[kind] + LOOP_KEYS + extra


LINE_IN_MEMORY = 32
"""The longest delay (samples) kept as a shift register in the controller's memory. Shifting costs nc·delay
copies per sample, and the compiled closed loop carries (and copies) its whole state at every sample, so a
longer delay goes to a :class:`~symbolic.simulation.controller.DelayLine` outside it. The compiled loop is then run in chunks of at most
``delay`` samples, whose outputs the line returns ``delay`` samples later: a Python call per chunk, which
the short delays, the common ones (a sample or two of computation), never pay. About 32 the two cost about
the same on a one-coordinate loop (bench/delay.py, bench/results/delay.md: within 25 % per sample at 32 and 33)."""

DRIVE_SLOTS = 8
"""Drive delays are compiled in steps of this many samples (:attr:`Controller.drive_slots`)."""


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
        Loop gains (zero where the kind has none). ``cascade_pi`` keeps kp_position in ``kp``,
        kp_velocity in ``kv``, ki_velocity in ``ki`` and kd_velocity in ``kd``.
    gain
        Output-to-force gains: a number as a float, an expression of the model's parameters as a SymPy
        expression (parsed only then: a table of numbers is read without SymPy).
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
    velocity_feedforward
        ``cascade_pi``: ff_vel per coordinate (the weight of ṙ in the velocity reference); else empty.
    feedforward
        ``cascade_pi``: expressions of the data's columns added to the command before saturation, or ``None``.
    reference_velocity
        ``cascade_pi``: expressions of the data's columns giving ṙ, or ``None`` (r's backward difference).
    drive_delays
        Samples each controlled coordinate's drive adds to ``delay`` (the experiment's ``[drive] tau_<c> delay``,
        set by :func:`symbolic.simulation.simulator.drive_layer`; empty: none). Never read from ``[controller]``.
    restart
        ``torque``: seconds between the replay's restarts from the measured state (the replay in windows), or
        ``None``: one run over the whole log.
    """

    kind: str
    coordinates: tuple[str, ...]
    kp: np.ndarray
    kd: np.ndarray
    ki: np.ndarray
    kv: np.ndarray
    gain: tuple[float | sp.Expr, ...]
    reference: str | tuple[str, ...] | None
    saturation: np.ndarray
    quantisation: np.ndarray
    disturbance: tuple[str, ...] | None
    delay: int
    velocity_filter: np.ndarray
    source: str = "<controller>"
    states: tuple[tuple[str, str], ...] = ()
    K: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    velocity_feedforward: np.ndarray = field(default_factory=lambda: np.zeros(0))
    feedforward: tuple[str, ...] | None = None
    reference_velocity: tuple[str, ...] | None = None
    drive_delays: tuple[int, ...] = ()
    restart: float | None = None

    def restart_samples(self, period: float) -> int | None:
        """Samples between the replay's restarts at a sample ``period`` (``None``: no restarts): ``restart``
        rounded to whole samples (docs/simulation.md, "Replay in windows")."""
        if self.restart is None:
            return None
        samples = round(self.restart / period)
        if samples < 2:
            raise DataError(self.source, "[controller] restart",
                            f"{self.restart:g} s is {self.restart / period:.3g} sample(s) at this log's sample period "
                            f"({period:g} s): a window needs at least 2 samples (allowed: ≥ {2 * period:g} s)")
        return samples

    @property
    def longest_delay(self) -> int:
        """Samples between measuring and applying on the latest coordinate: ``delay`` plus its drive's."""
        return self.delay + max(self.drive_delays, default=0)

    @property
    def drive_slots(self) -> int:
        """Drive delays the compiled loop can apply without compiling again (0 without drive delays): the
        longest rounded up to :data:`DRIVE_SLOTS`, within :data:`LINE_IN_MEMORY` in all. Which one a
        coordinate's drive applies is a number of the loop (:meth:`drive_weights`), not its structure: a scan
        of a drive's delay over 1–5 samples compiles one loop, not five."""
        if not self.drive_delays:
            return 0
        longest = max(self.drive_delays)
        rounded = -(-max(longest, 1) // DRIVE_SLOTS) * DRIVE_SLOTS
        return max(longest, min(rounded, LINE_IN_MEMORY - self.delay))

    @property
    def line_length(self) -> int:
        """Outputs the delay line keeps: ``delay`` plus the drives' slots."""
        return self.delay + self.drive_slots

    def drive_weights(self) -> np.ndarray:
        """One row per controlled coordinate, one column per extra delay 0 … :attr:`drive_slots`: 1 at the
        coordinate's drive delay, 0 elsewhere (row by row; empty without drive delays)."""
        if not self.drive_delays:
            return np.zeros(0)
        weights = np.zeros((self.size, self.drive_slots + 1))
        weights[np.arange(self.size), list(self.drive_delays)] = 1.0
        return weights.ravel()

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
        """Length of the reference input per sample: one per coordinate, x_ref (one per state), or for
        ``cascade_pi`` r, ṙ and the feedforward (three per coordinate, in that order)."""
        if self.kind == CASCADE_PI:
            return 3 * self.size
        return len(self.states) if self.kind == STATE_FEEDBACK else self.size

    def state_names(self) -> list[str]:
        """The states as written in the table (``q_<c>``, ``qd_<c>``)."""
        return [f"{signal}_{c}" for signal, c in self.states]

    def memory_size(self, line: bool = True) -> int:
        """Length of the controller's state: started flag, last positions, past velocities, integral (for
        ``cascade_pi`` also the last filtered velocity, for its derivative), and the delay line
        (``nc·line_length``) unless ``line`` is false (a line kept outside the state)."""
        nc, ns = self.size, len(self.sensors)
        loop = 2 * nc if self.kind == CASCADE_PI else nc
        return 1 + ns + ns * (len(self.velocity_filter) - 1) + loop + (nc * self.line_length if line else 0)

    def structure(self) -> tuple[Any, ...]:
        """What the controller's compiled function depends on besides its numbers (:func:`symbolic.simulation.controller.constants`)."""
        return (self.kind, self.coordinates, tuple(self.states), self.delay, len(self.velocity_filter),
                self.drive_slots)

    def describe(self) -> str:
        """One line: kind, coordinates and the optional features in use."""
        parts = [f"{self.kind} on {', '.join(self.coordinates)}"]
        if self.kind == STATE_FEEDBACK:
            parts[0] += f" from {', '.join(self.state_names())}"
        if np.isfinite(self.saturation).any():
            parts.append(f"saturation ±{', '.join(f'{s:g}' for s in self.saturation)}")
        if self.quantisation.any():
            parts.append(f"quantisation {', '.join(f'{r:g}' for r in self.quantisation)}")
        if self.velocity_feedforward.any():
            parts.append(f"velocity feedforward {', '.join(f'{w:g}' for w in self.velocity_feedforward)}")
        if self.feedforward:
            parts.append(f"feedforward {', '.join(self.feedforward)}")
        if self.disturbance:
            parts.append(f"disturbance {', '.join(self.disturbance)}")
        if self.delay:
            parts.append(f"delay {self.delay} sample(s)")
        if any(self.drive_delays):
            parts.append("drive delays " + ", ".join(f"{c} {d}" for c, d in zip(self.coordinates, self.drive_delays)))
        if len(self.velocity_filter) > 1:
            parts.append(f"velocity filter {list(map(float, self.velocity_filter))}")
        if self.restart is not None:
            parts.append(f"restarted from the measured state every {self.restart:g} s")
        return "; ".join(parts)


def replay(coordinates: Sequence[str], source: str = "<controller>") -> Controller:
    """The open-loop ``torque`` controller on ``coordinates`` (what a log without ``[controller]`` gets)."""
    return parse({"kind": "torque", "coordinates": list(coordinates)}, coordinates, (), source)


def parse(
    table: Mapping[str, Any],
    data_coordinates: Sequence[str],
    model_parameters: Sequence[sp.Symbol] | None = None,
    source: str = "<controller>",
    model_coordinates: Sequence[str] | None = None,
    columns: Collection[str] | None = None,
    samples: int | None = None,
) -> Controller:
    """Validate a ``[controller]`` table: the one place where it is checked (the experiment loader calls it).

    Parameters
    ----------
    table
        The table as read from TOML (or a dict).
    data_coordinates
        The coordinates the data measure (q_<c> columns): a controller reads their positions.
    model_parameters
        The model's parameter symbols, which ``gain`` expressions may use; ``None`` when no model is
        known yet: the names are then checked when the gain is evaluated with a model's values
        (:func:`symbolic.simulation.controller.drive_gains`).
    source
        The experiment file, for messages.
    model_coordinates
        The model's coordinates, to tell "not in the model" from "not in the data" (default: the data's).
    columns
        The names of the data's signals (``t``, the canonical columns, the extras): ``reference = "ref"``
        then needs the ``ref_<c>`` columns, and ``reference`` and ``disturbance`` expressions may use
        only these names. ``None``: checked when the signals are read (simulation).
    samples
        The length of the log: ``delay`` must leave the controller at least one interval to act
        (:func:`check_delay`). ``None``: checked when the controller runs (simulation).

    Raises
    ------
    DataError
        One line naming the file, ``[controller] <key>``, what is wrong and what is allowed.
    """
    if not isinstance(table, Mapping):
        raise DataError(source, "[controller]", f"expected a table, got {type(table).__name__}")
    kind = table.get("kind")
    if kind not in KINDS:
        hint = suggestion(kind, KINDS) if isinstance(kind, str) else ""
        raise DataError(source, "[controller] kind", f"expected one of {', '.join(KINDS)}, got {kind!r}{hint}")
    allowed = allowed_keys(kind)
    for key in table:
        if key not in allowed:
            what = f"not used by kind '{kind}'" if key in KEYS else "unknown key"
            raise unknown_key(source, "[controller]", key, allowed, what, allowed_for=f"'{kind}'")
    model = model_coordinates or data_coordinates
    if kind == STATE_FEEDBACK:
        controller = _state_feedback(table, data_coordinates, model, model_parameters, source)
        if columns is not None:
            _check_signals(None, controller.disturbance, controller.coordinates, columns, source)
        return check_delay(controller, samples)
    coordinates = _coordinates(table, "coordinates", data_coordinates, model, source)
    nc = len(coordinates)
    per = _PerCoordinate(table, coordinates, source)
    gains = {name: per.numbers(name, required=True, minimum=0.0, strict=name == "kp_velocity", finite=True)
             for name in GAINS[kind]}
    if kind == CASCADE_PI:  # stored where the P/P cascade keeps its gains (Controller)
        gains = {"kp": gains["kp_position"], "kv": gains["kp_velocity"], "ki": gains["ki_velocity"],
                 "kd": per.numbers("kd_velocity", minimum=0.0, finite=True)}
    zeros = np.zeros(nc)
    reference = _reference(table, nc, source) if kind != "torque" else None
    cascade = _cascade_pi(table, per) if kind == CASCADE_PI else {}
    if columns is not None:
        _check_signals(reference, per.strings("disturbance"), coordinates, columns, source,
                       {k: cascade[k] for k in ("feedforward", "reference_velocity") if k in cascade})
    return check_delay(Controller(
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
        restart=_restart(table, source),
        **cascade,
    ), samples)


def _cascade_pi(table: Mapping[str, Any], per: _PerCoordinate) -> dict[str, Any]:
    """The optional keys of ``cascade_pi`` (:data:`CASCADE_PI_KEYS`), as :class:`Controller` fields."""
    return {"velocity_feedforward": per.numbers("velocity_feedforward", minimum=0.0, finite=True),
            "feedforward": per.strings("feedforward"),
            "reference_velocity": per.strings("reference_velocity")}


_STATE_FEEDBACK_HELP = 'inputs = ["<c>", ...], states = ["q_<c>", "qd_<c>", ...], K = [[...], ...] one row per input'


def _state_feedback(table: Mapping[str, Any], data: Sequence[str], model: Sequence[str],
                    parameters: Sequence[sp.Symbol] | None, source: str) -> Controller:
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
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not abs(v) <= MAX_MAGNITUDE:
                raise DataError(source, f"[controller] K[{i}][{j}]", f"expected a finite number (signed), got "
                                                                     f"{shown(v)} (allowed: magnitudes up to {MAX_MAGNITUDE:g})")
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
                strict: bool = False, finite: bool = False) -> np.ndarray:
        """The list ``name`` as numbers ≥ ``minimum`` (> with ``strict``, which also admits +inf unless
        ``finite``)."""
        if name not in self.table:
            if required:
                raise DataError(self.source, f"[controller] {name}", "missing (a list with one number per coordinate)")
            return np.full(len(self.coordinates), default)
        out = []
        for k, v in enumerate(self._list(name)):
            key = f"[controller] {name}[{k}]"
            if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v) or (
                    math.isinf(v) and not (strict and not finite and v > 0)):
                raise DataError(self.source, key, f"expected a finite number, got {v!r}")
            if v < minimum or (strict and v <= minimum):
                bound = f"> {minimum:g}" if strict else f"≥ {minimum:g}"
                raise DataError(self.source, key, f"{v!r} is {'negative' if v < 0 else 'not allowed'} "
                                                  f"(allowed: numbers {bound})")
            if math.isfinite(v) and abs(v) > MAX_MAGNITUDE:
                raise DataError(self.source, key, f"{v:g} is beyond the magnitude {MAX_MAGNITUDE:g} of the numbers a "
                                                  "simulation can hold (allowed: numbers of magnitude at most "
                                                  f"{MAX_MAGNITUDE:g}{', or inf' if strict and not finite else ''})")
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


def _gain(table: Mapping[str, Any], coordinates: tuple[str, ...], parameters: Sequence[sp.Symbol] | None,
          source: str) -> tuple[float | sp.Expr, ...]:
    value = table.get("gain", 1.0)
    values = [value] * len(coordinates) if isinstance(value, (str, int, float)) else value
    if not isinstance(values, list) or len(values) != len(coordinates):
        raise DataError(source, "[controller] gain", f"expected a number, a parameter name or a list of "
                                                     f"{len(coordinates)} of them, got {value!r}")
    out = []
    for k, v in enumerate(values):
        key = f"[controller] gain[{k}]" if isinstance(value, list) else "[controller] gain"
        if isinstance(v, (int, float)) and not isinstance(v, bool):  # a number: checked as the parser would
            try:
                check_magnitude(v, source, key)
            except ModelError as error:
                raise DataError(error.source, error.key, error.problem) from None
            if v < 0:
                raise DataError(source, key, f"{v!r} is negative (allowed: numbers ≥ 0 or expressions of the parameters)")
            out.append(float(v) if v else 0.0)  # the parser's exact number as a float (-0.0 is 0)
            continue
        from symbolic.description.expressions import parse_expression
        from symbolic.description.robot import parameter_symbol

        if parameters is None:  # no model yet: any name, as the model's parameter symbol of that name
            symbols = {n: parameter_symbol(n) for n in (variable_names(v) if isinstance(v, str) else [])}
        else:
            symbols = {s.name: s for s in parameters}
        if isinstance(v, str):
            check_names(v, symbols, source, key, "the model's parameters")
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


def _restart(table: Mapping[str, Any], source: str) -> float | None:
    value = table.get("restart")
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= MAX_MAGNITUDE:
        raise DataError(source, "[controller] restart",
                        f"expected the seconds between the replay's restarts from the measured state, a positive "
                        f"number, got {shown(value)} (allowed: at least two sample periods)")
    return float(value)


def check_delay(controller: Controller, samples: int | None) -> Controller:
    """``controller`` if its delay leaves it a sample to act on a log of ``samples`` samples.

    The output computed at sample 0 is applied at sample ``delay`` and held over [t_delay, t_delay+1):
    with ``delay ≥ samples − 1`` no output acts within the log, and the controller is only a cost.

    Raises
    ------
    DataError
        ``[controller] delay`` of ``samples − 1`` or more, with the allowed range.
    """
    if samples is not None and controller.longest_delay > max(samples - 2, 0):
        raise DataError(controller.source, "[controller] delay",
                        f"{controller.longest_delay} samples reaches the end of the log ({samples} samples): no output "
                        f"would act within it (allowed: 0 to {max(samples - 2, 0)})")
    return controller


def _taps(table: Mapping[str, Any], source: str) -> np.ndarray:
    value = table.get("velocity_filter", [1.0])
    if (not isinstance(value, list) or not value or len(value) > 64
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) <= MAX_MAGNITUDE for v in value)):
        raise DataError(source, "[controller] velocity_filter",
                        f"expected a list of 1 to 64 finite numbers of magnitude at most {MAX_MAGNITUDE:g} (FIR taps, "
                        f"newest sample first), got {shown(value)}")
    return np.array(value, dtype=float)


def check_names(text: str, symbols: Mapping[str, Any], source: str, key: str, what: str) -> None:
    """Refuse a name that is neither declared nor a constant, listing what is declared."""
    for name in variable_names(text):
        if name not in symbols:
            raise DataError(source, key, f"unknown name {name!r} in {text!r} (allowed: {what}: "
                                         f"{', '.join(symbols) or 'none'})")


def _check_signals(reference: str | tuple[str, ...] | None, disturbance: tuple[str, ...] | None,
                   coordinates: tuple[str, ...], columns: Collection[str], source: str,
                   more: Mapping[str, tuple[str, ...] | None] | None = None) -> None:
    """The data's signals the controller reads exist: ``ref_<c>`` for ``"ref"``, the names of expressions
    (``more``: further keys of expressions, e.g. a cascade's ``feedforward``)."""
    if reference == "ref":
        for c in coordinates:
            if f"ref_{c}" not in columns:
                raise DataError(source, "[controller] reference",
                                f"\"ref\" needs the columns ref_<c>, but the data have no column 'ref_{c}' "
                                f"(columns: {', '.join(columns)})")
    readable = {name: None for name in columns}
    lists = [("reference", reference if isinstance(reference, tuple) else None), ("disturbance", disturbance),
             *(more or {}).items()]
    for name, texts in lists:
        for k, text in enumerate(texts or ()):
            check_names(text, readable, source, f"[controller] {name}[{k}]", "t and the data's columns")

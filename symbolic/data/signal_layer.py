"""The signal layer of an experiment: each sensor's and each drive input's delay, gain and bias.

An experiment file may declare, per logged signal, how what was logged relates to what the model computes
(docs/data.md, "The signal layer", the one copy of the format and of the sign conventions):

* ``[sensors]``, keys ``q_<c>``, ``qd_<c>``, ``tau_<c>``: measured(t) = gain·true(t − delay) + bias;
* ``[drive]``, keys ``tau_<c>``: the logged force (or a controller's output) is the drive's command, and the
  force applied to the machine is applied(t) = gain·(command(t − delay) + bias).

``delay`` is in samples of the log (fractional values allowed), from 0 to :data:`MAX_DELAY` and at most a
tenth of the log. A value is a number, or a table ``{ value = 0.5, free = true }`` (``{ free = true }``
starts from the neutral value: delay 0, gain 1, bias 0); a free value is applied at its starting value and
recorded in :attr:`SignalLayer.free` for an identification by the response to estimate.

:func:`apply` turns the logs into the model's signals once, when the data are loaded: a sensor's inverse,
true(t) = (measured(t + delay) − bias)/gain, and the drive's forward model; identification, simulation and
comparison then read the model's signals. A fractional shift is the 4-point (cubic) Lagrange interpolator
of :func:`shift`: exact for cubics and for integer delays, its error at most 3/128·h⁴·max|x⁗| (a sinusoid
of amplitude A: 0.0234·A·(ωh)⁴, 4e-7·A at 10 Hz sampled at 1 kHz).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from symbolic.data.errors import DataError
from symbolic.data.keys import check_keys, unknown_key
from symbolic.data.measurements import MAX_MAGNITUDE, Measurements, split_name

TABLES = ("sensors", "drive")
"""The experiment file's tables of the layer."""

SENSED = ("q", "qd", "tau")
"""The kinds of signal a ``[sensors]`` entry may name (``<kind>_<c>``)."""

FIELDS = ("delay", "gain", "bias")
"""The values of an entry."""

NEUTRAL = MappingProxyType({"delay": 0.0, "gain": 1.0, "bias": 0.0})
"""The value of a field an entry leaves out (and a free one's start without ``value``)."""

VALUE_KEYS = ("value", "free")
"""The keys of a value written as a table."""

MAX_DELAY = 1000.0
"""The largest delay in samples (1 s at 1 kHz); a delay is also at most :data:`MAX_DELAY_FRACTION` of the log."""

MAX_DELAY_FRACTION = 0.1
"""A delay leaves at least 90 % of the log's samples interpolated, not held at an end (:func:`shift`)."""

ERROR_CONSTANT = 3.0 / 128.0
"""The cubic Lagrange interpolator's error is at most this times h⁴·max|x⁗| (max over u ∈ [0, 1] of
|(u+1)u(u−1)(u−2)|/4! = (9/16)/24, at u = 1/2)."""


@dataclass(frozen=True)
class Channel:
    """One declared signal: ``table`` (``"sensors"`` or ``"drive"``), ``signal`` (``q_<c>``, ``qd_<c>``,
    ``tau_<c>``), its ``delay`` (samples), ``gain`` and ``bias``, and the names of its ``free`` fields."""

    table: str
    signal: str
    delay: float = 0.0
    gain: float = 1.0
    bias: float = 0.0
    free: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        """``q``, ``qd`` or ``tau``."""
        return (split_name(self.signal) or ("", ""))[0]

    @property
    def coordinate(self) -> str:
        """The coordinate of :attr:`signal`."""
        return (split_name(self.signal) or ("", ""))[1]


@dataclass(frozen=True)
class FreeValue:
    """A value declared free: ``table``, ``signal``, ``field`` (``delay``, ``gain`` or ``bias``) and ``start``
    (the value applied when the data were loaded)."""

    table: str
    signal: str
    field: str
    start: float


@dataclass(frozen=True, eq=False)
class SignalLayer:
    """The checked ``[sensors]`` and ``[drive]`` tables of an experiment.

    Attributes
    ----------
    sensors
        ``{signal: Channel}`` of ``[sensors]``.
    drive
        ``{tau_<c>: Channel}`` of ``[drive]``.
    logged
        The declared signals as logged (window applied), before :func:`apply` turned them into the model's:
        what an identification of the free values compares with the sensor model of a simulation.
    """

    sensors: Mapping[str, Channel] = field(default_factory=dict)
    drive: Mapping[str, Channel] = field(default_factory=dict)
    logged: Mapping[str, np.ndarray] = field(default_factory=dict, repr=False)

    def __bool__(self) -> bool:
        return bool(self.sensors or self.drive)

    @property
    def channels(self) -> tuple[Channel, ...]:
        return (*self.sensors.values(), *self.drive.values())

    @property
    def free(self) -> tuple[FreeValue, ...]:
        """The free values, in file order."""
        return tuple(FreeValue(c.table, c.signal, name, getattr(c, name)) for c in self.channels for name in c.free)

    def drive_of(self, coordinate: str) -> Channel | None:
        """The ``[drive]`` entry of ``coordinate``, or ``None``."""
        return self.drive.get(f"tau_{coordinate}")

    def slice(self, start: int, stop: int) -> SignalLayer:
        """The layer of samples ``start:stop`` (:meth:`Measurements.slice`): the logs cut alike."""
        logged = {k: _readonly(v[start:stop].copy()) for k, v in self.logged.items()}
        return SignalLayer(self.sensors, self.drive, MappingProxyType(logged))

    def sensed(self, model: Measurements) -> dict[str, np.ndarray]:
        """What each declared sensor would log of ``model``'s signals (a simulation: the model's q, qd, tau), by
        signal: :func:`sense`, to compare with :attr:`logged` (an output-error cost on the signals as logged)."""
        out = {}
        for channel in self.sensors.values():
            values = getattr(model, channel.kind)
            if values is None or channel.coordinate not in model.coordinates:
                raise DataError(str(model.source), channel.signal, f"no {channel.kind} of coordinate "
                                                                   f"{channel.coordinate!r} to sense")
            out[channel.signal] = sense(channel, values[:, model.coordinates.index(channel.coordinate)])
        return out

    def with_values(self, values: Mapping[tuple[str, str, str], float], source: str = "<signal layer>") -> SignalLayer:
        """This layer with ``values`` by ``(table, signal, field)`` (e.g. an estimate of a free value), each
        checked as in a file; the logs kept."""
        tables = {"sensors": dict(self.sensors), "drive": dict(self.drive)}
        for (table, signal, name), value in values.items():
            where = f"[{table}] {signal} {name}"
            if table not in tables or signal not in tables[table] or name not in FIELDS:
                declared = [f"({c.table}, {c.signal}, {f})" for c in self.channels for f in FIELDS]
                raise DataError(source, where, f"not a value of the layer (declared: {', '.join(declared) or 'none'})")
            number = _number(value, where, source)
            _check(name, number, where, source)
            tables[table][signal] = dataclasses.replace(tables[table][signal], **{name: number})
        return SignalLayer(MappingProxyType(tables["sensors"]), MappingProxyType(tables["drive"]), self.logged)


# -- the tables ------------------------------------------------------------------------------------------------


def parse(spec: Mapping[str, Any], source: str) -> SignalLayer:
    """The ``[sensors]`` and ``[drive]`` tables of an experiment file ``spec`` (either may be absent), checked
    for their own content; :func:`apply` checks them against the data."""
    tables = {}
    for name in TABLES:
        table = spec.get(name, {})
        if not isinstance(table, Mapping):
            raise DataError(source, f"[{name}]", f"expected a table of signals, got {type(table).__name__}")
        tables[name] = {signal: _channel(name, signal, entry, source) for signal, entry in table.items()}
    both = [s for s in tables["drive"] if s in tables["sensors"]]
    if both:
        raise DataError(source, f"[drive] {both[0]}", f"{both[0]} is also in [sensors]: the logged force is either a "
                                                      f"sensor's reading of the applied force ([sensors]) or the drive's "
                                                      f"command ([drive]), not both")
    return SignalLayer(MappingProxyType(tables["sensors"]), MappingProxyType(tables["drive"]))


def _channel(table: str, signal: str, entry: Any, source: str) -> Channel:
    where = f"[{table}] {signal}"
    kinds = SENSED if table == "sensors" else ("tau",)
    split = split_name(str(signal))
    if split is None or split[0] not in kinds:
        allowed = ", ".join(f"{k}_<c>" for k in kinds)
        what = "the drive's command is a force" if table == "drive" else "a sensor of a position, velocity or force"
        if split is not None and split[0] == "u":  # u_<c> became tau_<c> by the model's [[drive]] gain first
            what += f"; a drive signal {signal} is read as tau_{split[1]} = gain·{signal}: name tau_{split[1]}"
        raise DataError(source, where, f"not a signal of [{table}] (allowed: {allowed}, c a coordinate; {what})")
    if not isinstance(entry, Mapping):
        raise DataError(source, where, f"expected a table such as {{ delay = 0.5, gain = 1.0, bias = 0.0 }}, "
                                       f"got {entry!r}")
    if "free" in entry:
        raise DataError(source, f"{where} free", "say which value is free: e.g. delay = { value = 0.5, free = true }")
    check_keys(entry, FIELDS, source, where)
    values, free = dict(NEUTRAL), []
    for name, given in entry.items():
        values[name], is_free = _value(given, f"{where} {name}", source)
        _check(name, values[name], f"{where} {name}", source)
        if is_free:
            free.append(name)
    return Channel(table, signal, values["delay"], values["gain"], values["bias"], tuple(free))


def _value(given: Any, where: str, source: str) -> tuple[float, bool]:
    """A number, or ``{ value = number, free = bool }`` (value optional when free)."""
    if isinstance(given, Mapping):
        check_keys(given, VALUE_KEYS, source, where)
        free = given.get("free", False)
        if not isinstance(free, bool):
            raise DataError(source, f"{where} free", f"expected true or false, got {free!r}")
        if "value" not in given:
            if not free:
                raise DataError(source, where, "a table needs value = <number> unless free = true")
            return NEUTRAL[where.rsplit(" ", 1)[1]], True
        return _number(given["value"], f"{where} value", source), free
    return _number(given, where, source), False


def _number(given: Any, where: str, source: str) -> float:
    if isinstance(given, bool) or not isinstance(given, (int, float)) or not math.isfinite(given):
        raise DataError(source, where, f"expected a finite number, got {given!r}")
    if abs(given) > MAX_MAGNITUDE:
        raise DataError(source, where, f"{given:g} is beyond the magnitude {MAX_MAGNITUDE:g} of any measured value")
    return float(given)


def _check(name: str, value: float, where: str, source: str) -> None:
    if name == "gain" and value == 0:
        raise DataError(source, where, "0 (allowed: a finite non-zero number; a negative gain is a reversed sign)")
    if name == "delay" and not 0 <= value <= MAX_DELAY:
        raise DataError(source, where, f"{value:g} samples (allowed: 0 to {MAX_DELAY:g} samples of the log, fractions "
                                       f"included; a delay is a lag: measured after the fact, applied after the command)")


# -- the layer applied to the data -------------------------------------------------------------------------------


def apply(measurements: Measurements, layer: SignalLayer, source: str) -> tuple[Measurements, SignalLayer]:
    """``measurements`` with the model's signals in place of the declared logs (module docstring), and
    ``layer`` with those logs kept (:attr:`SignalLayer.logged`).

    Raises
    ------
    DataError
        For a declared signal the data do not have (the nearest one named) or a delay too long for the log.
    """
    if not layer:
        return measurements, layer
    available = {f"{kind}_{c}": (kind, j) for kind in SENSED if getattr(measurements, kind) is not None
                 for j, c in enumerate(measurements.coordinates)}
    arrays = _copies(measurements)
    logged = {}
    limit = delay_limit(measurements.samples)
    for channel in layer.channels:
        where = f"[{channel.table}] {channel.signal}"
        if channel.signal not in available:
            allowed = [s for s in available if s.startswith("tau_")] if channel.table == "drive" else list(available)
            raise unknown_key(source, f"[{channel.table}]", channel.signal, allowed, what="no such signal in the data")
        if channel.delay > limit:
            raise DataError(source, f"{where} delay", f"{channel.delay:g} samples (allowed: 0 to {limit:g}, at most "
                                                      f"{MAX_DELAY:g} and a tenth of the log's {measurements.samples} "
                                                      "samples)")
        kind, j = available[channel.signal]
        values = arrays[kind][:, j]
        logged[channel.signal] = _readonly(values.copy())
        arrays[kind][:, j] = model_signal(channel, values)
        _check_result(arrays[kind][:, j], channel, measurements, source)
    corrected = dataclasses.replace(measurements, **_frozen(arrays))
    return corrected, SignalLayer(layer.sensors, layer.drive, MappingProxyType(logged))


def delay_limit(samples: int) -> float:
    """The longest delay a log of ``samples`` allows: :data:`MAX_DELAY`, and :data:`MAX_DELAY_FRACTION` of it."""
    return min(MAX_DELAY, MAX_DELAY_FRACTION * samples)


def reapply(measurements: Measurements, layer: SignalLayer, source: str) -> Measurements:
    """``measurements`` (whose declared signals :func:`apply` made from ``layer.logged``) made again from the
    logs with ``layer``'s values (:meth:`SignalLayer.with_values`): what a fit of the free values evaluates."""
    arrays = _copies(measurements)
    for channel in layer.channels:
        if channel.signal not in layer.logged:
            raise DataError(source, f"[{channel.table}] {channel.signal}", "no log kept for it (not loaded with the layer)")
        kind, coordinate = split_name(channel.signal) or ("", "")
        j = measurements.coordinates.index(coordinate)
        arrays[kind][:, j] = model_signal(channel, layer.logged[channel.signal])
    changed: dict[str, Any] = dict(_frozen(arrays))
    if hasattr(measurements, "signal_layer"):
        changed["signal_layer"] = layer
    return dataclasses.replace(measurements, **changed)


def freed(measurements: Measurements, values: Mapping[tuple[str, str, str], float | None], source: str
          ) -> Measurements:
    """``measurements`` with the layer's values ``{(table, signal, field): start}`` declared free — a channel
    the experiment does not declare is added (its log is the signal as loaded, its other values neutral) —
    each starting at ``start`` (``None``: its value now) and the model's signals made again from the logs
    (:func:`reapply`). What a search for a missing delay, gain or bias fits (:mod:`symbolic.workflow.response`)."""
    return _declared(measurements, values, source, free=True)


def fixed(measurements: Measurements, values: Mapping[tuple[str, str, str], float], source: str) -> Measurements:
    """``measurements`` with the layer's values ``{(table, signal, field): value}`` declared at those values and
    not free (a channel the experiment does not declare is added, as by :func:`freed`): what a search scans
    where the fit cannot free a value (a drive's delay inside a feedback loop: whole samples)."""
    return _declared(measurements, values, source, free=False)


def _declared(measurements: Measurements, values: Mapping[tuple[str, str, str], float | None], source: str,
              free: bool) -> Measurements:
    layer = getattr(measurements, "signal_layer", None)
    if layer is None:
        raise DataError(source, "signal layer", "plain measurements have no signal layer; load an experiment")
    tables = {"sensors": dict(layer.sensors), "drive": dict(layer.drive)}
    logged = dict(layer.logged)
    for (table, signal, name), start in values.items():
        kind, coordinate = split_name(signal) or ("", "")
        if table not in tables or name not in FIELDS or kind not in SENSED or coordinate not in measurements.coordinates:
            raise DataError(source, f"[{table}] {signal} {name}", "not a value a signal layer can free")
        other = tables["drive" if table == "sensors" else "sensors"]
        if signal in other:
            raise DataError(source, f"[{table}] {signal}", f"{signal} is already declared in the other table")
        channel = tables[table].get(signal)
        if channel is None:
            channel = Channel(table, signal)
            j = measurements.coordinates.index(coordinate)
            logged[signal] = _readonly(np.array(getattr(measurements, kind)[:, j], dtype=float))
        if start is not None:
            _check(name, float(start), f"[{table}] {signal} {name}", source)
        freed_fields = tuple(f for f in FIELDS if f in channel.free or (free and f == name))
        tables[table][signal] = dataclasses.replace(channel, free=freed_fields,
                                                    **({name: float(start)} if start is not None else {}))
    widened = SignalLayer(MappingProxyType(tables["sensors"]), MappingProxyType(tables["drive"]),
                          MappingProxyType(logged))
    return reapply(measurements, widened, source)


def _copies(measurements: Measurements) -> dict[str, np.ndarray]:
    """Writable copies of the q, qd and tau that ``measurements`` has, by kind."""
    return {kind: np.array(getattr(measurements, kind)) for kind in SENSED if getattr(measurements, kind) is not None}


def _frozen(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``arrays``, each made read-only (a Measurements' arrays are)."""
    for values in arrays.values():
        values.setflags(write=False)
    return arrays


def _check_result(values: np.ndarray, channel: Channel, measurements: Measurements, source: str) -> None:
    """The model's signal stays a measured value (finite, magnitude at most 1e30): a gain of 1e-30 would not."""
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(~(np.abs(values) <= MAX_MAGNITUDE))
    if bad.size:
        k = int(bad[0])
        raise DataError(source, f"[{channel.table}] {channel.signal}",
                        f"gain {channel.gain:g} and bias {channel.bias:g} make the model's signal {values[k]:g} at "
                        f"sample {k} (t = {measurements.t[k]:g} s) (allowed: finite numbers of magnitude at most "
                        f"{MAX_MAGNITUDE:g})")


def _readonly(values: np.ndarray) -> np.ndarray:
    values.setflags(write=False)
    return values


def shift(x: np.ndarray, offset: float) -> np.ndarray:
    """y_k = x(t_k + offset·h) on the uniform grid of ``x``: 4-point Lagrange interpolation (module docstring).

    A stencil reaching past an end uses the end sample (the signal held there): at most ⌈|offset|⌉ + 2
    samples at the end the shift reads beyond (the last ones for an advance, the first for a delay) and one
    at the other end are so extrapolated. An integer ``offset`` is an exact shift, holding only the
    ``|offset|`` samples beyond the end.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    whole = math.floor(offset)
    u = offset - whole
    index = np.arange(n) + whole
    if u == 0:
        return x[np.clip(index, 0, n - 1)]
    taps = (-u * (u - 1) * (u - 2) / 6, (u + 1) * (u - 1) * (u - 2) / 2, -(u + 1) * u * (u - 2) / 2,
            (u + 1) * u * (u - 1) / 6)
    return sum(w * x[np.clip(index + k, 0, n - 1)] for k, w in zip((-1, 0, 1, 2), taps))


def shift_derivative(x: np.ndarray, offset: float) -> np.ndarray:
    """∂/∂offset of :func:`shift` (x, offset): the derivative of the interpolating cubic, exact, for the
    sensitivity of a fit to a delay; at a whole ``offset`` the derivative from above (u → 0⁺)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    whole = math.floor(offset)
    u = offset - whole
    index = np.arange(n) + whole
    taps = (-(3 * u**2 - 6 * u + 2) / 6, (3 * u**2 - 4 * u - 1) / 2, -(3 * u**2 - 2 * u - 2) / 2,
            (3 * u**2 - 1) / 6)
    return sum(w * x[np.clip(index + k, 0, n - 1)] for k, w in zip((-1, 0, 1, 2), taps))


def sense(channel: Channel, true: np.ndarray) -> np.ndarray:
    """What a sensor logs of the ``true`` signal: gain·true(t − delay) + bias."""
    return channel.gain * shift(true, -channel.delay) + channel.bias


def correct(channel: Channel, measured: np.ndarray) -> np.ndarray:
    """The true signal from a sensor's log: (measured(t + delay) − bias)/gain, the inverse of :func:`sense`."""
    return (shift(measured, channel.delay) - channel.bias) / channel.gain


def model_signal(channel: Channel, logged: np.ndarray) -> np.ndarray:
    """The model's signal from ``channel``'s log: a sensor's :func:`correct`, a drive's :func:`drive`."""
    return correct(channel, logged) if channel.table == "sensors" else drive(channel, logged)


def drive(channel: Channel, command: np.ndarray) -> np.ndarray:
    """The force applied for a drive ``command``: gain·(command(t − delay) + bias)."""
    return channel.gain * (shift(command, -channel.delay) + channel.bias)

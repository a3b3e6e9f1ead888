"""Measured data of one experiment: :class:`Measurements`, and the checks that build it.

Canonical signals (the data-file contract): ``t`` (time in seconds) and, for every coordinate ``c``
of the model, ``q_c`` (position) and ``tau_c`` (generalized force) — or instead of ``tau_c`` the drive
signal ``u_c`` (amperes, volts), which the model's ``[[drive]] gain`` turns into τ_c = gain·u_c
(:class:`DriveGains`) —, optionally ``qd_c`` (velocity), ``qdd_c`` (acceleration) and ``ref_c``
(reference position). Any other signal is kept as an extra (e.g. ``pulses_N``, a state feedback's
reference velocity ``refd_c``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from symbolic.data.errors import DataError

REQUIRED = ("q", "tau")
"""Per-coordinate signals every data set has (``tau`` may come from the drive signal ``u``)."""

OPTIONAL = ("qd", "qdd", "ref")
"""Per-coordinate signals a data set may have (for all coordinates or none)."""

DRIVE = "u"
"""The drive signal u_<c>: given instead of tau_<c>, converted by the model's ``[[drive]] gain``."""

KINDS = REQUIRED + OPTIONAL + (DRIVE,)

UNIFORM_TOLERANCE = 1e-3
"""Largest relative deviation of a time step from the mean step for the time to count as uniform.

EMPS's time stamps, stored in single precision, deviate by 1.6e-5 of the 1 ms step; a logger that
drops or repeats samples deviates by 100 % or more.
"""

MAX_MAGNITUDE = 1e30
"""Largest magnitude of a measured value (the bound of the numbers in model files): every sum of squares and
product the treatment and the least squares form stays finite (with :data:`MAX_RATE`, q̈ ≤ 1e48 and its
squares summed over 10⁹ samples ≤ 1e105), while time in nanoseconds since 1970 (1.7e18) and 64-bit
encoder counts (1.8e19) are far inside."""

MAX_RATE = 1e9
"""Highest sampling rate in Hz (a time step of at least 1 ns): q̈ = Δ²q/h² then stays below 1e48 for
positions up to :data:`MAX_MAGNITUDE`; no robot log comes near (EMPS and the Panda: 1 kHz)."""


def split_name(name: str) -> tuple[str, str] | None:
    """``("q", "x")`` for ``"q_x"`` and the like; ``None`` for ``t`` and extra signals.

    The prefixes ``q_ qd_ qdd_ tau_ ref_ u_`` are such that no one begins another, so the split is unique.
    """
    for kind in KINDS:
        if name.startswith(kind + "_") and len(name) > len(kind) + 1:
            return kind, name[len(kind) + 1 :]
    return None


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Measurements:
    """Uniformly sampled measurements of one experiment, arranged by the model's coordinates.

    Arrays are read-only; per-coordinate arrays are ``samples × N`` with columns in the order of
    :attr:`coordinates`.

    Attributes
    ----------
    t
        Time stamps in seconds, uniform with step :attr:`sample_period` (``samples``,).
    coordinates
        The coordinate names, in column order.
    q, tau
        Positions and generalized forces.
    qd, qdd, ref
        Measured velocities, accelerations and reference positions, or ``None`` when the data have none.
    extras
        Other signals by name (``samples``,), e.g. ``pulses_N``.
    constants
        Numbers that came with the data: the 1×1 variables of a ``.mat``/``.npz`` file (EMPS's
        ``gtau``, ``kp``, ``kv``) and an experiment's ``[constants]``.
    sample_period
        The time step in seconds (the mean step of the file's time stamps).
    source
        The file given to :func:`symbolic.data.load` (data or experiment file).
    data_file
        The data file the numbers were read from.
    resampled
        Whether the samples were interpolated onto a uniform time grid.

    What the experiment declares besides its numbers (model, treatment, controller, validation set) is
    held by the subclass :class:`symbolic.data.experiment.Experiment`, which :func:`symbolic.data.load`
    returns.
    """

    t: np.ndarray
    coordinates: tuple[str, ...]
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    ref: np.ndarray | None = None
    extras: Mapping[str, np.ndarray] = field(default_factory=dict)
    constants: Mapping[str, float] = field(default_factory=dict)
    sample_period: float = 0.0
    source: Path = Path("<arrays>")
    data_file: Path = Path("<arrays>")
    resampled: bool = False

    @property
    def samples(self) -> int:
        """Number of samples."""
        return len(self.t)

    @property
    def rate(self) -> float:
        """Sampling rate in Hz."""
        return 1.0 / self.sample_period

    def columns(self) -> dict[str, np.ndarray]:
        """All signals under their canonical names: ``t``, per coordinate q, qd, qdd, tau, ref, then extras."""
        out = {"t": self.t}
        for kind in ("q", "qd", "qdd", "tau", "ref"):
            values = getattr(self, kind)
            if values is not None:
                out.update({f"{kind}_{c}": values[:, j] for j, c in enumerate(self.coordinates)})
        out.update(self.extras)
        return out

    def slice(self, start: int, stop: int) -> Measurements:
        """Samples ``start:stop`` (every per-sample signal cut alike; of the same class, the rest kept)."""
        cut: dict[str, Any] = {"t": _readonly(self.t[start:stop])}
        for kind in ("q", "tau", "qd", "qdd", "ref"):
            values = getattr(self, kind)
            cut[kind] = None if values is None else _readonly(values[start:stop])
        extras = MappingProxyType({k: _readonly(v[start:stop]) for k, v in self.extras.items()})
        return dataclasses.replace(self, extras=extras, **cut)
    def arranged(self, coordinates: tuple[str, ...] | list[str]) -> Measurements:
        """These measurements with their columns in the order of a model's ``coordinates`` (what
        :func:`symbolic.data.load` does for a file); a :class:`DataError` names the first coordinate without
        a signal, or a signal for a coordinate the model does not have."""
        coordinates = tuple(coordinates)
        if coordinates == self.coordinates:
            return self
        extra = [c for c in self.coordinates if c not in coordinates]
        if extra:
            raise DataError(str(self.source), "coordinates", f"signal for coordinate {extra[0]!r}, which the model does not "
                                                             f"have (its coordinates: {', '.join(coordinates)})")
        missing = [c for c in coordinates if c not in self.coordinates]
        if missing:
            raise DataError(str(self.source), "coordinates", f"no signal for coordinate{'s' * (len(missing) > 1)} "
                                                             f"{', '.join(missing)} ({_contract()})")
        order = [self.coordinates.index(c) for c in coordinates]
        columns = {kind: None if getattr(self, kind) is None else _readonly(getattr(self, kind)[:, order])
                   for kind in ("q", "tau", "qd", "qdd", "ref")}
        return dataclasses.replace(self, coordinates=coordinates, **columns)

    @classmethod
    def from_arrays(
        cls,
        t: np.ndarray,
        coordinates: tuple[str, ...] | list[str],
        q: np.ndarray,
        tau: np.ndarray,
        *,
        qd: np.ndarray | None = None,
        qdd: np.ndarray | None = None,
        ref: np.ndarray | None = None,
        extras: Mapping[str, np.ndarray] | None = None,
        resample: bool = False,
    ) -> Measurements:
        """Build measurements from arrays (``samples × N`` per coordinate), with the checks of a file."""
        signals: dict[str, np.ndarray] = {"t": np.asarray(t, dtype=float).reshape(-1)}
        for kind, values in (("q", q), ("tau", tau), ("qd", qd), ("qdd", qdd), ("ref", ref)):
            if values is None:
                continue
            values = np.asarray(values, dtype=float).reshape(len(values), -1)
            if values.shape[1] != len(coordinates):
                raise DataError("<arrays>", kind, f"has {values.shape[1]} columns for {len(coordinates)} coordinates")
            signals.update({f"{kind}_{c}": values[:, j] for j, c in enumerate(coordinates)})
        signals.update({k: np.asarray(v, dtype=float).reshape(-1) for k, v in (extras or {}).items()})
        return assemble(signals, Source("<arrays>", lambda n: f"column '{n}'"), coordinates=tuple(coordinates),
                        resample=resample)


@dataclass(frozen=True)
class DriveGains:
    """The model's ``[[drive]] gain`` per coordinate, at its nominal parameter values: τ_c = gain·u_c.

    Attributes
    ----------
    gains
        Coordinate -> gain, for the coordinates whose ``[[drive]]`` has a gain.
    model
        The model's name, for messages; ``None`` when no model is known.
    """

    gains: Mapping[str, float] = field(default_factory=dict)
    model: str | None = None

    def gain(self, coordinate: str, source: str, where: str) -> float:
        """The gain of ``coordinate``, or a :class:`DataError` at ``where`` saying why there is none."""
        if coordinate in self.gains:
            return self.gains[coordinate]
        fix = f"or give tau_{coordinate}, the generalized force"
        if self.model is None:
            problem = (f"the drive signal of {coordinate!r} needs the model's [[drive]] gain (tau_{coordinate} = "
                       f"gain·u_{coordinate}) and no model is known: load it with the model (model = \"...\" in the "
                       f"experiment, or the command's MODEL), {fix}")
        else:
            problem = (f"model {self.model!r} has no [[drive]] gain for coordinate {coordinate!r} (tau_{coordinate} = "
                       f"gain·u_{coordinate}): add gain to its [[drive]] of {coordinate!r}, {fix}")
        raise DataError(source, where, problem)


@dataclass(frozen=True)
class Source:
    """Where signals come from, for error messages: the file and how to name a signal's key."""

    name: str
    where: Callable[[str], str]
    noun: str = "column"
    container: str = "columns"


def assemble(
    signals: Mapping[str, np.ndarray],
    origin: Source,
    *,
    coordinates: tuple[str, ...] | None = None,
    rate: float | None = None,
    resample: bool = False,
    window: tuple[float | None, float | None] | None = None,
    drive: DriveGains | None = None,
    model: tuple[str, ...] | None = None,
    **fields: Any,
) -> Measurements:
    """Check named signals and arrange them as :class:`Measurements`.

    Parameters
    ----------
    signals
        Canonical and extra signals by name, in order.
    origin
        The file, and how to name a signal in a message.
    coordinates
        The model's coordinates; ``None`` to take them from the ``q_<c>`` signals in order.
    model
        With ``coordinates`` ``None``: the model's coordinates, of which the data's must be some.
    rate
        Sampling rate in Hz when there is no ``t`` signal.
    resample
        Interpolate (linearly) onto a uniform grid when the time steps are not uniform.
    window
        ``(start, stop)`` in seconds (either may be ``None``): keep the samples in between.
    drive
        The model's drive gains, for ``u_<c>`` signals (τ_c = gain·u_c); without, a ``u_<c>`` is refused.
    fields
        Further :class:`Measurements` fields (source, data_file, constants).
    """
    if "t" not in signals and rate is None:
        raise DataError(origin.name, origin.container, f"missing {origin.noun} 't' ({_contract()})")
    coordinates, canonical, extras = _arrange(signals, origin, coordinates, model)
    scale = _drive_scale(signals, origin, drive or DriveGains())
    n = _common_length(signals, origin)
    if "t" in signals:
        t = signals["t"]
        _check_time(t, origin)
    else:
        t = np.arange(n) / rate
    start, stop = _window(t, window, origin)
    t = t[start:stop]
    for name, values in signals.items():
        _check_finite(name, values[start:stop], t, start, origin)
    sample_period = (t[-1] - t[0]) / (len(t) - 1)
    if "t" in signals and not sample_period >= 1.0 / MAX_RATE:
        raise DataError(origin.name, origin.where("t"), f"time step {sample_period:.3g} s is below 1 ns (allowed: "
                                                        f"sampling rates up to {MAX_RATE:g} Hz; is t in seconds?)")
    resampled = False
    if not _uniform(t, sample_period, origin, allow=resample):
        uniform = t[0] + sample_period * np.arange(len(t))
        uniform[-1] = t[-1]  # no extrapolation from rounding
        signals = {k: np.interp(uniform, t, v[start:stop]) for k, v in signals.items()}
        t, start, stop, resampled = uniform, 0, len(uniform), True

    def stack(kind: str) -> np.ndarray | None:
        if kind not in canonical:
            return None
        if kind == "tau":  # a drive signal becomes the generalized force here, after the checks of u_c itself
            return _readonly(np.column_stack([scale[c] * signals[f"{DRIVE}_{c}"][start:stop] if c in scale
                                              else signals[f"tau_{c}"][start:stop] for c in coordinates]))
        return _readonly(np.column_stack([signals[f"{kind}_{c}"][start:stop] for c in coordinates]))

    fields.setdefault("source", Path(origin.name))
    fields.setdefault("data_file", fields["source"])
    fields["constants"] = MappingProxyType(dict(fields.get("constants", {})))
    return Measurements(
        t=_readonly(t),
        coordinates=coordinates,
        q=stack("q"),
        tau=stack("tau"),
        qd=stack("qd"),
        qdd=stack("qdd"),
        ref=stack("ref"),
        extras=MappingProxyType({k: _readonly(signals[k][start:stop]) for k in extras}),
        sample_period=float(sample_period),
        resampled=resampled,
        **fields,
    )


def _arrange(
    signals: Mapping[str, np.ndarray], source: Source, coordinates: tuple[str, ...] | None,
    model: tuple[str, ...] | None = None,
) -> tuple[tuple[str, ...], set[str], list[str]]:
    """The coordinates, the per-coordinate kinds present, the extra signal names; checks completeness.

    ``coordinates`` given: exactly those; else those of the q_<c> signals, each one of ``model``'s
    coordinates when a model is given (its coordinates: the data may measure some of them)."""
    per_kind: dict[str, list[str]] = {kind: [] for kind in KINDS}
    extras = []
    for name in signals:
        split = split_name(name)
        if split is None:
            if name != "t":
                extras.append(name)
        else:
            per_kind[split[0]].append(split[1])
    model_given = coordinates is not None
    if coordinates is None:
        coordinates = tuple(per_kind["q"])
        if not coordinates:
            raise DataError(source.name, source.container, f"no position {source.noun} q_<coordinate> ({_contract()})")
    known = coordinates if model_given else model  # the coordinates a signal may name (None: any)
    for kind, names in per_kind.items():
        for c in names:
            if known is not None and c not in known:
                raise DataError(
                    source.name,
                    source.where(f"{kind}_{c}"),
                    f"signal for coordinate {c!r}, which the model does not have (its coordinates: "
                    f"{', '.join(known)})",
                )
            if c not in coordinates:  # a signal of a coordinate whose position is missing
                raise DataError(source.name, source.container, f"missing {source.noun} 'q_{c}' ({_contract()})")
    for kind in REQUIRED:
        for c in coordinates:
            if c not in per_kind[kind] and not (kind == "tau" and c in per_kind[DRIVE]):
                raise DataError(source.name, source.container, f"missing {source.noun} '{kind}_{c}' ({_contract()})")
    for c in per_kind[DRIVE]:
        if c in per_kind["tau"]:
            raise DataError(source.name, source.where(f"{DRIVE}_{c}"),
                            f"both tau_{c} and {DRIVE}_{c} are given: give the generalized force tau_{c} or the drive "
                            f"signal {DRIVE}_{c} (converted by the model's [[drive]] gain), not both")
    present = set(REQUIRED)
    for kind in OPTIONAL:
        have = [c for c in coordinates if c in per_kind[kind]]
        if have and len(have) != len(coordinates):
            lacking = next(c for c in coordinates if c not in have)
            raise DataError(
                source.name,
                source.container,
                f"missing {source.noun} '{kind}_{lacking}' while '{kind}_{have[0]}' is given: give {kind}_<c> "
                "for every coordinate or for none",
            )
        if have:
            present.add(kind)
    return coordinates, present, extras


def _contract() -> str:
    return ("required: t, and q_<c>, tau_<c> (or the drive signal u_<c>) for every coordinate c; optional: qd_<c>, "
            "qdd_<c>, ref_<c>")


def _drive_scale(signals: Mapping[str, np.ndarray], origin: Source, drive: DriveGains) -> dict[str, float]:
    """{c: the [[drive]] gain} for each drive signal u_c (τ_c = gain·u_c; _arrange checked the coordinates)."""
    scale = {}
    for name in signals:
        split = split_name(name)
        if split is not None and split[0] == DRIVE:
            scale[split[1]] = drive.gain(split[1], origin.name, origin.where(name))
    return scale


def _common_length(signals: Mapping[str, np.ndarray], source: Source) -> int:
    lengths = {name: len(values) for name, values in signals.items()}
    first = next(iter(lengths))
    for name, n in lengths.items():
        if n != lengths[first]:
            raise DataError(
                source.name,
                source.where(name),
                f"length mismatch: {n} samples, while '{first}' has {lengths[first]} (all signals must have the "
                "same number of samples)",
            )
    n = lengths[first]
    if n < 2:
        raise DataError(source.name, source.where(first), f"{n} sample(s): at least 2 are needed")
    return n


def _check_time(t: np.ndarray, source: Source) -> None:
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(~(np.abs(t) <= MAX_MAGNITUDE))
    if bad.size:
        raise DataError(source.name, source.where("t"), f"time is {t[bad[0]]:g} at sample {bad[0]} (allowed: finite "
                                                        f"numbers of magnitude at most {MAX_MAGNITUDE:g})")
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = bad[0] + 1
        raise DataError(
            source.name,
            source.where("t"),
            f"time is not increasing: {t[k - 1]:.9g} s at sample {k - 1}, then {t[k]:.9g} s at sample {k} "
            f"({bad.size} such step(s); time stamps must increase strictly)",
        )


def _window(t: np.ndarray, window: tuple[float | None, float | None] | None, source: Source) -> tuple[int, int]:
    if window is None:
        return 0, len(t)
    lo, hi = window
    start = 0 if lo is None else int(np.searchsorted(t, lo, side="left"))
    stop = len(t) if hi is None else int(np.searchsorted(t, hi, side="right"))
    if stop - start < 2:
        raise DataError(
            source.name,
            "[window]",
            f"the window {_interval(lo, hi)} holds {max(stop - start, 0)} sample(s) (at least 2 are needed); "
            f"the data span {t[0]:.9g} s to {t[-1]:.9g} s",
        )
    return start, stop


def _interval(lo: float | None, hi: float | None) -> str:
    return f"[{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}] s"


def _check_finite(name: str, values: np.ndarray, t: np.ndarray, offset: int, source: Source) -> None:
    """Refuse a value that is not finite or beyond :data:`MAX_MAGNITUDE`, naming the first and counting the others."""
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(~(np.abs(values) <= MAX_MAGNITUDE))
    if bad.size:
        k = bad[0]
        more = f" and at {bad.size - 1} more sample(s)" if bad.size > 1 else ""
        raise DataError(
            source.name,
            source.where(name),
            f"value {values[k]:g} at sample {k + offset} (t = {t[k]:.9g} s){more} (allowed: finite numbers of "
            f"magnitude at most {MAX_MAGNITUDE:g})",
        )


def _uniform(t: np.ndarray, step: float, source: Source, allow: bool) -> bool:
    """Whether every step is within :data:`UNIFORM_TOLERANCE` of ``step``; if not and not ``allow``, raise."""
    steps = np.diff(t)
    deviation = np.abs(steps - step) / step
    worst = int(np.argmax(deviation))
    if deviation[worst] <= UNIFORM_TOLERANCE:
        return True
    if allow:
        return False
    raise DataError(
        source.name,
        source.where("t"),
        f"time step varies from {duration(steps.min(), step)} to {duration(steps.max(), step)} (mean "
        f"{duration(step, step)}; the "
        f"largest deviation is at sample {worst + 1}); steps must be uniform to {UNIFORM_TOLERANCE:.1%} — resample "
        "on request: resample = true in the experiment file, or load(..., resample=True)",
    )


def check_forces(measurements: Measurements) -> None:
    """Refuse data whose forces are zero at every sample of every coordinate: every model fits them, and a
    relative error ‖τ_meas − τ_model‖/‖τ_meas‖ has nothing to measure against (a coordinate without an
    actuator, τ = 0, is fine while another has a force)."""
    if not np.any(measurements.tau):
        names = ", ".join(f"tau_{c}" for c in measurements.coordinates)
        raise DataError(str(measurements.source), names, "the forces are zero at every sample: nothing to identify "
                        "or compare with (a log without its force signal? check the tau_<c> or u_<c> mapping)")


def duration(seconds: float, like: float | None = None) -> str:
    """A time span in the unit that suits ``like`` (default: itself): ``1 ms``, ``0.9 ms``, ``2.5 s``."""
    like = seconds if like is None else like
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6), ("ns", 1e-9)):
        if abs(like) >= scale or unit == "ns":
            return f"{seconds / scale:.4g} {unit}"
    raise AssertionError("unreachable")


def isfinite_number(value: Any) -> bool:
    """Whether ``value`` is an int or float (not bool) and finite."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)

"""The choices of the data treatment (:class:`Settings`, an experiment's ``[identification]`` table) and
the treatment they resolve to for given data (:class:`Processing`).

The treatment itself — filtering, differentiation, the border, decimation — and the rules that fill in
unset choices are described in :mod:`symbolic.data.treatment` and docs/data.md ("IDIM-LS").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from symbolic.data.errors import DataError
from symbolic.data.filters import DECIMATION_ORDER, decimate, kept_indices
from symbolic.data.keys import check_keys
from symbolic.data.measurements import MAX_MAGNITUDE, MAX_RATE

BANDWIDTH_FRACTION = 50.0
"""Without a stated bandwidth, it is taken as rate / 50 (20 Hz at 1 kHz, EMPS's value)."""

SETTING_KEYS = ("bandwidth", "cutoff", "order", "decimation", "border", "filter_positions", "held_force")

MAX_ORDER = 16
"""Highest order of the positions' Butterworth filter. The zero-phase filter's impulse response lengthens
with the order while the border stays five periods of the cut-off: on a signal inside the pass band the
largest error left after the border grows from 3e-7 (order 4) to 1e-3 (order 16), 5 % (order 64) and
50–90 % (order 100) at cut-offs from 0.2 Hz to 5 Hz at 1 kHz (bench/filter_order.py), and q̈, its second
difference, amplifies it. tests/test_hostile_data.py identifies a known truth at this order; order 200
gave EMPS a mass of 0.94 kg instead of 95."""

MIN_DECIMATED = 2
"""Fewest samples decimation may leave (of those after the border)."""


@dataclass(frozen=True)
class Settings:
    """Choices of the data treatment; ``None`` means: from the experiment's ``[identification]`` table, else the rule.

    Attributes
    ----------
    bandwidth
        Bandwidth of the dynamics in Hz (Gautier's ω_dyn). Default ``rate / 50``.
    cutoff
        Cut-off of the position low-pass in Hz. Default ``5 · bandwidth``.
    order
        Order of the Butterworth filter (one pass). Default 4.
    decimation
        Decimation factor. Default ``round(0.8 · rate/2 / (2 · bandwidth))``, at least 1.
    border
        Samples dropped at each end before decimation, or ``(start, end)``. Default ``ceil(5 · rate / cutoff)``
        (2 without position filtering: the one-sided differences).
    filter_positions
        Low-pass the positions (and given velocities, accelerations). Default true.
    held_force
        The logged force is a command held over each sample period (zero-order hold: the drive signal a
        digital controller writes at t_k and keeps until t_k+1). The states at t_k are then compared with
        the force's mean over [t_k − T/2, t_k + T/2], (τ_{k−1} + τ_k)/2, instead of τ_k, which leads the
        motion by half a sample (:meth:`Processing.forces`). Default false (a sampled force, e.g. a
        measured current).
    """

    bandwidth: float | None = None
    cutoff: float | None = None
    order: int | None = None
    decimation: int | None = None
    border: int | tuple[int, int] | None = None
    filter_positions: bool | None = None
    held_force: bool | None = None

    def __post_init__(self) -> None:
        # settings built in Python get the checks of an [identification] table
        for key, value in asdict(self).items():
            if value is not None:
                _setting(key, list(value) if isinstance(value, tuple) else value, "<settings>")

    @classmethod
    def from_table(cls, table: Mapping[str, Any] | None, source: str) -> Settings:
        """The settings an experiment's ``[identification]`` table declares (the others unset), checked:
        unknown keys and values of the wrong kind are a :class:`DataError` naming ``source`` and the key."""
        if table is None:
            return cls()
        if not isinstance(table, Mapping):
            raise DataError(source, "[identification]", f"expected a table, got {type(table).__name__}")
        check_keys(table, SETTING_KEYS, source, "[identification]")
        return cls(**{key: _setting(key, value, source) for key, value in table.items()})

    def combined(self, fallback: Settings) -> Settings:
        """These settings, with the unset ones (``None``) taken from ``fallback``."""
        return Settings(**{k: v if v is not None else getattr(fallback, k) for k, v in asdict(self).items()})

    def merged(self, table: Mapping[str, Any] | None, source: str) -> Settings:
        """These settings, with the unset ones taken from an ``[identification]`` table (:meth:`from_table`)."""
        return self.combined(Settings.from_table(table, source))

    def given(self) -> dict[str, Any]:
        """The settings that are set, by key (for a report or a table)."""
        return {k: v for k, v in asdict(self).items() if v is not None}

    def rules(self, rate: float) -> tuple[float, float | None, int, tuple[int, int]]:
        """Bandwidth, cut-off (``None``: positions not filtered), order and border at ``rate`` Hz, each
        the stated value or its rule (module docstring); nothing checked against the data's length."""
        bandwidth = self.bandwidth if self.bandwidth is not None else rate / BANDWIDTH_FRACTION
        filtering = self.filter_positions if self.filter_positions is not None else True
        cutoff = self.cutoff if self.cutoff is not None else 5.0 * bandwidth
        if self.border is None:
            # five periods of the cut-off; capped where the count would not fit an integer (refused by resolve)
            border = (math.ceil(min(5.0 * rate / cutoff, 2.0**62)),) * 2 if filtering else (2, 2)
        else:
            border = (self.border, self.border) if isinstance(self.border, int) else tuple(self.border)
        order = self.order if self.order is not None else 4
        return bandwidth, cutoff if filtering else None, order, (int(border[0]), int(border[1]))

    def resolve(self, rate: float, samples: int, source: str = "<settings>") -> Processing:
        """The concrete treatment for data at ``rate`` Hz with ``samples`` samples, refused (naming the key the
        value came from, and the values allowed for these data) where it cannot be applied."""
        nyquist = rate / 2.0
        bandwidth, cutoff, order, border = self.rules(rate)
        if not bandwidth < nyquist:
            raise DataError(source, "[identification] bandwidth", f"{bandwidth:g} Hz is not below the Nyquist frequency "
                                                                  f"{nyquist:g} Hz of the data")
        given = "cutoff" if self.cutoff is not None else "bandwidth" if self.bandwidth is not None else None
        why = "" if self.cutoff is not None else " (5 × the bandwidth)"
        where = f"[identification] {given}" if given else "samples"
        if cutoff is not None and not 0 < cutoff < nyquist:
            what = f"{cutoff:g} Hz" if self.cutoff is not None else f"the cut-off {cutoff:g} Hz{why}"
            raise DataError(source, where, f"{what} is not below the Nyquist frequency {nyquist:g} Hz of the data")
        if cutoff is not None and self.border is None and 5.0 * rate / cutoff > samples / 2:
            lowest = 10.0 * rate / samples
            allowed = (f"a cut-off above {lowest:.3g} Hz, or a border" if lowest < nyquist else
                       "a border, or filter_positions = false")
            raise DataError(source, where, f"{samples} samples are too few for the border of five periods of the "
                                           f"{cutoff:g} Hz cut-off{why}, {5.0 * rate / cutoff:.3g} samples at each end "
                                           f"(allowed: {allowed})")
        if cutoff is not None and samples <= 3 * order:
            raise DataError(source, "samples", f"{samples} samples are too few for the order-{order} low-pass of the "
                                               f"positions (more than {3 * order} are needed)")
        kept = samples - border[0] - border[1]
        least = 2  # for the central differences
        if kept < least:
            raise DataError(source, "[identification] border" if self.border is not None else "samples",
                            f"{samples} samples are too few: {border[0]} + {border[1]} border samples are dropped at "
                            f"the ends and at least {least} must be left (the data need {border[0] + border[1] + least})")
        decimation, from_rule = self.decimation, self.decimation is None
        if from_rule:
            decimation = math.floor(min(0.4 * rate / (2 * bandwidth), 2.0**62) + 0.5) or 1
        if decimation > 1 and kept <= 3 * DECIMATION_ORDER:
            raise DataError(source, "samples", f"{kept} samples left after the border are too few to decimate (the "
                                               f"decimation filter needs more than {3 * DECIMATION_ORDER})")
        if math.ceil(kept / decimation) < MIN_DECIMATED:
            largest = max(1, (kept - 1) // (MIN_DECIMATED - 1))
            if from_rule:
                raise DataError(source, "[identification] bandwidth",
                                f"{bandwidth:g} Hz gives a decimation by {decimation:g} (round(0.2·rate/bandwidth)), which "
                                f"leaves fewer than {MIN_DECIMATED} of the {kept} samples after the border (allowed: a "
                                f"bandwidth above {0.2 * rate / (largest + 0.5):.3g} Hz, or a decimation)")
            raise DataError(source, "[identification] decimation",
                            f"{decimation} leaves fewer than {MIN_DECIMATED} of the {kept} samples after the border "
                            f"(allowed: 1 to {largest})")
        return Processing(
            rate=rate,
            bandwidth=bandwidth,
            cutoff=cutoff,
            order=order,
            decimation=decimation,
            border=border,
            held_force=bool(self.held_force),
        )


def _setting(key: str, value: Any, source: str) -> Any:
    where = f"[identification] {key}"
    if key in ("filter_positions", "held_force"):
        if not isinstance(value, bool):
            raise DataError(source, where, f"expected true or false, got {value!r}")
        return value
    if key == "border" and isinstance(value, list):
        if len(value) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value):
            raise DataError(source, where, f"expected a sample count or [start, end] counts, got {value!r}")
        return tuple(value)
    integer = key in ("order", "decimation", "border")
    ok = isinstance(value, int) if integer else isinstance(value, (int, float))
    if not ok or isinstance(value, bool) or not math.isfinite(value) or value < (0 if key == "border" else 1e-300):
        kind = "a non-negative integer" if key == "border" else "a positive integer" if integer else "a positive number (Hz)"
        raise DataError(source, where, f"expected {kind}, got {value!r}")
    if key == "order" and value > MAX_ORDER:
        raise DataError(source, where, f"{value} is outside 1 to {MAX_ORDER} (a higher-order filter rings past the "
                                       "border and its result drifts from the signal)")
    if key in ("bandwidth", "cutoff") and not 1.0 / MAX_MAGNITUDE <= value <= MAX_RATE:
        raise DataError(source, where, f"{value:g} Hz is outside {1.0 / MAX_MAGNITUDE:g} to {MAX_RATE:g} Hz")
    return value


@dataclass(frozen=True)
class Processing:
    """The data treatment actually applied (all defaults resolved)."""

    rate: float
    bandwidth: float
    cutoff: float | None
    order: int
    decimation: int
    border: tuple[int, int]
    held_force: bool = False

    def to_dict(self) -> dict[str, Any]:
        """Plain numbers, for JSON."""
        return {**asdict(self), "border": list(self.border)}

    def forces(self, tau: np.ndarray) -> np.ndarray:
        """The logged forces as the states at the same samples see them: unchanged, or for a held
        command its mean over the sample centred on t_k, (τ_{k−1} + τ_k)/2 (the first sample kept)."""
        tau = np.asarray(tau, dtype=float)
        if not self.held_force or len(tau) < 2:
            return tau
        return np.concatenate([tau[:1], 0.5 * (tau[1:] + tau[:-1])])

    def reduce(self, x: np.ndarray) -> np.ndarray:
        """Steps 4–5 on any signal sampled like the data (``samples × …``): border dropped, decimated.

        Applied to τ and to every regressor column alike, as :func:`symbolic.identify.processing.observe` does.
        """
        x = np.asarray(x, dtype=float)
        return decimate(x[self.border[0] : x.shape[0] - self.border[1]], self.decimation)

    def reduce_times(self, t: np.ndarray) -> np.ndarray:
        """The time stamps of the samples :meth:`reduce` keeps."""
        t = np.asarray(t, dtype=float)[self.border[0] : len(t) - self.border[1]]
        return t[kept_indices(len(t), self.decimation)]

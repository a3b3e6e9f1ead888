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

BANDWIDTH_FRACTION = 50.0
"""Without a stated bandwidth, it is taken as rate / 50 (20 Hz at 1 kHz, EMPS's value)."""

SETTING_KEYS = ("bandwidth", "cutoff", "order", "decimation", "border", "filter_positions", "held_force")


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
            border = (math.ceil(5.0 * rate / cutoff),) * 2 if filtering else (2, 2)
        else:
            border = (self.border, self.border) if isinstance(self.border, int) else tuple(self.border)
        order = self.order if self.order is not None else 4
        return bandwidth, cutoff if filtering else None, order, (int(border[0]), int(border[1]))

    def resolve(self, rate: float, samples: int, source: str = "<settings>") -> Processing:
        """The concrete treatment for data at ``rate`` Hz with ``samples`` samples."""
        nyquist = rate / 2.0
        bandwidth, cutoff, order, border = self.rules(rate)
        if cutoff is not None and not 0 < cutoff < nyquist:
            raise DataError(source, "cutoff", f"{cutoff:g} Hz is not below the Nyquist frequency {nyquist:g} Hz of the data")
        decimation = self.decimation if self.decimation is not None else max(1, math.floor(0.4 * rate / (2 * bandwidth) + 0.5))
        kept = samples - border[0] - border[1]
        # the decimation filter pads 3·8 samples; the position filter 3·order (it sees all samples)
        if kept <= (3 * DECIMATION_ORDER if decimation > 1 else 1) or samples <= 3 * order:
            raise DataError(
                source,
                "samples",
                f"{samples} samples are too few: {border[0]} + {border[1]} border samples are dropped and "
                f"decimation keeps one in {decimation}",
            )
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

        Applied to τ and to every regressor column alike, as :func:`observe` does.
        """
        x = np.asarray(x, dtype=float)
        return decimate(x[self.border[0] : x.shape[0] - self.border[1]], self.decimation)

    def reduce_times(self, t: np.ndarray) -> np.ndarray:
        """The time stamps of the samples :meth:`reduce` keeps."""
        t = np.asarray(t, dtype=float)[self.border[0] : len(t) - self.border[1]]
        return t[kept_indices(len(t), self.decimation)]

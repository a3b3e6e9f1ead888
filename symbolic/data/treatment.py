"""The data treatment shared by identification and the comparison of simulation with measurement.

Gautier 1997 ("Dynamic identification of robots with power model") and the EMPS publication's script:

1. positions low-passed by a zero-phase Butterworth filter (order 4, forward and backward) whose
   cut-off is 5 × the bandwidth of the dynamics (the bandwidth defaulting to rate / 50: 20 Hz at
   1 kHz, EMPS's value, so a 100 Hz cut-off);
2. q̇ by central differences of the filtered q, q̈ by central differences of q̇ — unless the data have
   ``qd``/``qdd`` columns, which are then used, low-passed by the same filter;
3. ``border`` samples left out at each end, where the filter and the one-sided differences distort
   (default ``ceil(5·rate/cutoff)``, five periods of the cut-off; 2 without filtering);
4. for identification, decimation of τ and of every regressor column alike
   (:meth:`Processing.reduce`; :mod:`symbolic.identify.processing` builds the system ``y = W·β``).

:class:`Settings` are the choices (``None``: from an experiment's ``[identification]`` table, else the
rule above); :meth:`Settings.resolve` turns them into the :class:`Processing` applied;
:func:`states` gives steps 1–2 and :func:`filtered_motion` the same filtering for any cut-off.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from symbolic.data.errors import DataError
from symbolic.data.filters import DECIMATION_ORDER, central_difference, decimate, kept_indices, lowpass
from symbolic.data.measurements import Measurements

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

    def merged(self, table: Mapping[str, Any] | None, source: str) -> Settings:
        """These settings, with the unset ones taken from an experiment's ``[identification]`` table."""
        if not table:
            return self
        given = {}
        for key, value in table.items():
            if key not in SETTING_KEYS:
                raise DataError(source, f"[identification] {key}", f"unknown key (allowed: {', '.join(SETTING_KEYS)})")
            given[key] = _setting(key, value, source)
        return Settings(**{k: v if v is not None else given.get(k) for k, v in asdict(self).items()})

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


@dataclass(frozen=True, eq=False)
class States:
    """Steps 1–2: positions, velocities and accelerations as IDIM-LS sees them, at every sample.

    Attributes
    ----------
    q, qd, qdd
        Filtered positions and their central differences (or the filtered measured ``qd``/``qdd``),
        ``samples × N``, before the border is dropped.
    processing
        The treatment, all defaults resolved; :meth:`Processing.reduce` applies steps 4–5.
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    processing: Processing


def states(measurements: Measurements, settings: Settings | None = None) -> States:
    """Steps 1–2 of the treatment (module docstring) on ``measurements``.

    ``settings`` override the treatment; unset fields come from the experiment's ``[identification]`` table.
    """
    source = str(measurements.source)
    settings = (settings or Settings()).merged(measurements.identification, source)
    p = settings.resolve(measurements.rate, measurements.samples, source)
    return States(*filtered_motion(measurements, p.cutoff, p.order), p)


def filtered_motion(measurements: Measurements, cutoff: float | None, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steps 1–2: q low-passed at ``cutoff`` Hz (``None``: not filtered) by a zero-phase Butterworth of
    ``order``, q̇ and q̈ by central differences (or the data's own ``qd``/``qdd``, low-passed alike)."""
    h = measurements.sample_period

    def smooth(x: np.ndarray) -> np.ndarray:
        return lowpass(x, cutoff, measurements.rate, order) if cutoff is not None else np.asarray(x, dtype=float)

    q = smooth(measurements.q)
    qd = smooth(measurements.qd) if measurements.qd is not None else central_difference(q, h)
    qdd = smooth(measurements.qdd) if measurements.qdd is not None else central_difference(qd, h)
    return q, qd, qdd

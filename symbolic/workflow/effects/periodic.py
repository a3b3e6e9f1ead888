"""Disturbances periodic in position (cogging, a screw's period) and in time (mains interference)."""

from __future__ import annotations

import math

import numpy as np

from symbolic.workflow.effects._sinusoid import Sinusoid
from symbolic.workflow.effects.base import Context, on_row, register


class Periodic(Sinusoid):
    """A disturbance periodic in position (cogging, a screw's or a gear's period): A·sin(2π·q/P + φ)."""

    own_row = True

    name, roles, axis, nonlinear, variant = "periodic", ("amplitude", "period"), "position", "period", "position"
    summary = "disturbance periodic in position (cogging, screw or gear period): amplitude·sin(2π·q/period + φ)"
    formula, regressors, written_as = 'A·sin(2π·q/P + φ)', 'sin, cos of 2π·q/P; P on a grid', '`[[force]]` with P written as a number'
    rank, units = 70, {"amplitude": "{force}", "period": "{position}"}
    OVERSAMPLING = 4
    MAX_GRID = 4000
    TOP = 0.5

    def grid(self, context, j):
        q, v = context.q[:, j], np.abs(context.qd[:, j])
        span = float(q.max() - q.min())
        fast = float(np.percentile(v, 90))
        if span <= 0 or fast <= 0:
            return None
        # at least two periods over the range travelled (else it is a spring or gravity), and no faster in
        # time than half the treatment's pass band at the usual speed (above, the states are mostly the
        # differentiated encoder noise the low-pass leaves: errors in the regressor, not in τ)
        low, high = 2.0 / span, self.TOP * context.passband / fast
        if high <= low:
            return None
        count = min(int(math.ceil((high - low) * span * self.OVERSAMPLING)) + 1, self.MAX_GRID)
        frequencies = np.linspace(low, high, count)
        return 1.0 / frequencies[::-1], max(count / self.OVERSAMPLING, 1.0)

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], list(self.sin_cos(2.0 * math.pi * q[:, j] / value).T))

    def row_columns_at(self, signals, j, value):
        return self.sin_cos(2.0 * math.pi * signals.q[:, j] / value)

    def roles_of(self, c, value, reference):
        amplitude, _ = self.polar(c)
        return {"amplitude": amplitude, "period": float(value)}

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        return self.write(editor, "periodic", coordinate, ("Ps", "Pc"), f"2*pi*{coordinate}/{float(value)!r}", c, comment)


class PeriodicTime(Sinusoid):
    """A disturbance periodic in time (mains interference, a nearby pump or fan): A·sin(2π·f·t + φ) on
    the τ side, t the data's time stamps (s), written as a ``[[force]]`` in the model file's time ``t``.
    The contract identifier is ``periodic`` (variant ``time``), as for :class:`Periodic` in position.

    The frequency grid runs from the edge of the motion's own band (:meth:`motion_band`), and at least
    :data:`CYCLES` cycles over the estimation record, to :data:`TOP` × the treatment's pass band (above,
    the decimation filter attenuates it), spaced :data:`OVERSAMPLING` times finer than the record's
    Fourier resolution 1/T. A term in time is told apart from the terms in the states that the model
    misses only where the motion gives those no power:

    * below the motion's band edge (on EMPS, whose motion holds 99 % of its velocity power below
      3.7 Hz, a "disturbance" at 0.48 Hz would explain 7 % of what friction leaves);
    * at the harmonics of a periodic motion (:meth:`motion_period`; a repeated excitation trajectory)
      only when the line stands :data:`ISOLATED` times above the neighbouring harmonics: there every
      function of q, q̇, q̈ the model misses is periodic in time too, a comb of lines (on the synthetic
      cases, lines at the 25th and 50th harmonic of a 0.1 Hz excitation, 0.1 % of τ, were significant),
      whereas mains at 50 Hz — the 500th harmonic of a 10 s excitation — is one line.

    The independent trials are the resolution cells scanned. Hence a disturbance that itself holds more
    than 1 − :data:`MOTION` of the velocity's power sets the band edge and is not searched.
    """

    own_row = True

    name, contract, variant = "periodic_time", "periodic", "time"
    roles, axis, nonlinear = ("amplitude", "frequency_hz"), "time", "frequency_hz"
    summary = "disturbance periodic in time (mains interference): amplitude·sin(2π·frequency_hz·t + φ)"
    formula, regressors, written_as = 'A·sin(2π·f·t + φ)', "sin, cos of 2π·f·t at the data's time stamps; f on a grid", '`[[force]] -(Ms*sin(2*pi*f*t) + Mc*cos(2*pi*f*t))`, f written as a number'
    rank, units = 80, {"amplitude": "{force}", "frequency_hz": "Hz"}
    CYCLES = 2.0
    TOP = 0.8
    OVERSAMPLING = 4
    MAX_GRID = 8000
    MOTION = 0.99
    """Fraction of the velocity's power (each coordinate's normalised, averaged) that sets the motion's band edge."""
    REPEATS = 0.9
    """Autocorrelation of the velocity at a lag above which the motion is taken as periodic with that period."""
    refinement = 1e-8
    """A frequency error δf turns the phase by 2π·δf·t: 1e-4 of 8 Hz is 0.2 rad over 40 s; 1e-8 is nothing."""
    LINE = 2.0
    """The best frequency must explain at least this multiple of the best one more than :data:`APART`
    resolution cells away: a disturbance at one frequency is one line in the residual; a comb of lines of
    comparable power is the residual of something repeated (pulses) or a hump, not a sinusoid."""
    APART = 2.0
    ISOLATED = 10.0
    """At a harmonic of a periodic motion the line must explain this multiple of the best of the three
    harmonics on either side (mains at 50 Hz is the 500th harmonic of a 10 s excitation)."""

    @staticmethod
    def _velocities(context: Context) -> np.ndarray | None:
        v = context.qd - context.qd.mean(axis=0)
        moving = np.sum(v * v, axis=0) > 0
        return v[:, moving] / np.sqrt(np.mean(v[:, moving] ** 2, axis=0)) if moving.any() and context.rate > 0 else None

    @classmethod
    def motion_band(cls, context: Context) -> float:
        """The frequency (Hz) below which the motion holds :data:`MOTION` of its velocity power, every
        coordinate's spectrum normalised to its own power (their units differ) and averaged."""
        v = cls._velocities(context)
        if v is None:
            return 0.0
        power = np.abs(np.fft.rfft(v, axis=0)) ** 2
        share = np.mean(power / power.sum(axis=0), axis=1)
        frequencies = np.fft.rfftfreq(len(v), 1.0 / context.rate)
        return float(frequencies[min(np.searchsorted(np.cumsum(share), cls.MOTION), len(frequencies) - 1)])

    @classmethod
    def motion_period(cls, context: Context) -> float | None:
        """The period (s) of a repeated motion: the lag of the highest normalised autocorrelation of the
        velocities (averaged over coordinates, each lag's overlap normalised) in the first run of lags
        where it exceeds :data:`REPEATS`, after it has first crossed zero and within half the record;
        ``None`` when there is none (a motion that does not repeat)."""
        v = cls._velocities(context)
        if v is None:
            return None
        n = len(v)
        spectrum = np.fft.rfft(v, 2 * n, axis=0)
        correlation = np.fft.irfft(np.abs(spectrum) ** 2, axis=0)[:n].mean(axis=1)
        correlation = correlation / (n - np.arange(n)) / (correlation[0] / n)
        negative = np.flatnonzero(correlation[: n // 2] < 0)
        if negative.size == 0:
            return None
        lags = np.arange(negative[0], n // 2)
        high = lags[correlation[lags] > cls.REPEATS]
        if high.size == 0:
            return None
        run = high[: int(np.argmax(np.diff(high) > 1)) + 1] if np.any(np.diff(high) > 1) else high
        k = int(run[np.argmax(correlation[run])])
        # a parabola through the peak and its neighbours: the period to a fraction of a sample (at the
        # 160th harmonic a whole sample's error would move the comb by a third of a resolution cell)
        left, mid, right = correlation[k - 1], correlation[k], correlation[k + 1]
        curvature = left - 2.0 * mid + right
        shift = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
        return (k + shift) / context.rate

    def _range(self, context: Context) -> tuple[float, float] | None:
        if context.duration <= 0:
            return None
        low, high = max(self.CYCLES / context.duration, self.motion_band(context)), self.TOP * context.passband
        return (low, high) if high > low else None

    def _off_harmonics(self, frequencies: np.ndarray, context: Context) -> np.ndarray:
        """Which ``frequencies`` lie more than one resolution cell from every harmonic of a periodic motion."""
        period = self.motion_period(context)
        if period is None:
            return np.ones(len(frequencies), bool)
        distance = np.abs(frequencies * period - np.round(frequencies * period)) / period
        return distance > 1.0 / context.duration

    def grid(self, context, j):
        bounds = self._range(context)
        if bounds is None:
            return None
        low, high = bounds
        count = min(int(math.ceil((high - low) * context.duration * self.OVERSAMPLING)) + 1, self.MAX_GRID)
        frequencies = np.linspace(low, high, count)
        if frequencies.size < 2:
            return None
        return frequencies, max(frequencies.size / self.OVERSAMPLING, 1.0)

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("periodic in time needs the time stamps: use columns_at")

    def columns_at(self, signals, j, value):
        return on_row(j, signals.q.shape[1], list(self.row_columns_at(signals, j, value).T))

    def row_columns_at(self, signals, j, value):
        return self.sin_cos(2.0 * math.pi * value * np.asarray(signals.t, float))

    def scan_columns(self, t, n, j, values):
        # the treatment's filters are linear and time-invariant: a sinusoid stays one of the same frequency
        # (gain and phase change: a mixing of sin and cos), up to the filters' transients at the ends.
        # Sampled at the kept times directly, the grid costs nothing next to filtering every column.
        # on coordinate j only: the compact form, values × samples × 2. A grid chunk is evenly spaced: each
        # frequency's phasor is the previous one times exp(2πi·Δf·t) (angle addition; the rounding grows by
        # one ulp a step, 1e-14 over a chunk), instead of a sine and a cosine of every sample at every value
        t = np.asarray(t, float)
        values = np.asarray(values, float)
        step = (values[-1] - values[0]) / (len(values) - 1) if len(values) > 1 else 0.0
        even = len(values) > 2 and np.allclose(np.diff(values), step, rtol=1e-9, atol=0.0)
        if not even:
            x = 2.0 * math.pi * np.outer(values, t)
            return np.stack([np.sin(x), np.cos(x)], axis=2)
        phasor = np.empty((len(values), len(t)), complex)
        phasor[0] = np.exp(2j * math.pi * values[0] * t)
        turn = np.exp(2j * math.pi * step * t)
        for k in range(1, len(values)):
            np.multiply(phasor[k - 1], turn, out=phasor[k])
        return np.stack([phasor.imag, phasor.real], axis=2)

    def roles_of(self, c, value, reference):
        amplitude, _ = self.polar(c)
        return {"amplitude": amplitude, "frequency_hz": float(value)}

    def scan_verdict(self, values, explained, context):
        best = int(np.argmax(explained))
        if explained[best] <= 0:
            return None
        apart = np.abs(values - values[best]) > self.APART / context.duration
        if apart.any():
            k = int(np.flatnonzero(apart)[np.argmax(explained[apart])])
            if explained[best] < self.LINE * explained[k]:
                return (f"not a single line: {values[k]:.4g} Hz explains {explained[k] / explained[best]:.0%} of what "
                        f"{values[best]:.4g} Hz does (a comb or a hump of the residual, not one sinusoid)")
        return self._harmonic_verdict(values, explained, best, context)

    def _harmonic_verdict(self, values, explained, best, context) -> str | None:
        """At a harmonic of a periodic motion, a line must stand :data:`ISOLATED` times above the
        neighbouring harmonics: every function of the motion's phase the model misses is a comb there."""
        if self._off_harmonics(values[best:best + 1], context)[0]:
            return None
        period = self.motion_period(context)
        k = round(values[best] * period)
        cell = 0.5 / context.duration
        neighbours = []
        for m in (k - 3, k - 2, k - 1, k + 1, k + 2, k + 3):
            near = np.abs(values - m / period) <= cell
            if m > 0 and near.any():
                neighbours.append(float(explained[near].max()))
        if neighbours and explained[best] >= self.ISOLATED * max(neighbours):
            return None
        share = max(neighbours) / explained[best] if neighbours else float("nan")
        return (f"{values[best]:.4g} Hz is the harmonic {k} of the periodic motion (period {period:.4g} s) and its "
                f"neighbouring harmonics explain up to {share:.0%} as much: a function of the motion's phase, not "
                f"told apart from the states' terms (a disturbance there must stand {self.ISOLATED:g}× above them)")

    def check(self, roles, reference, context, j):
        bounds = self._range(context)
        f = roles["frequency_hz"]
        cell = 1.0 / context.duration
        if f <= bounds[0] + cell or f >= bounds[1] - cell:
            return (f"the frequency is not located: {f:.4g} Hz lies at the edge of the range searched "
                    f"({bounds[0]:.4g}–{bounds[1]:.4g} Hz: above the motion's band, within the pass band)")
        return None

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        return self.write(editor, "periodic_time", coordinate, ("Ms", "Mc"), f"2*pi*{float(value)!r}*t", c, comment,
                          "amplitude")


register(Periodic(), PeriodicTime())

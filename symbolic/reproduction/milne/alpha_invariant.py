"""Milne et al.'s α-invariant of a command signal v(t): instantaneous (33), cycle average (34), sine (36).

    α = v̇² − v v̈                                                      Milne (33)
    ᾱ = (1/T) ∫_{t₀−T}^{t₀} (v̇² − v v̈) dt                               Milne (34)
    α = k_p² ω² (A₁² + (A_r − A₂)²)   (v = k_p(r − θ), r = A_r sin ωt)   Milne (36)

:func:`alpha_invariant` takes arrays of v, v̇, v̈; :func:`cycle_average` the samples of one period (v̈
optional: integrated by parts, (34) needs v̇ only); :func:`sine_alpha` the steady-state coefficients of
:mod:`symbolic.reproduction.milne.sine`. The derivation from the ellipse (30), and the misprint of (31):
docs/seeds.md, "Milne: the α-invariant model".
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from symbolic.data import DataError
from symbolic.reproduction.milne import SOURCE



def alpha_invariant(v: ArrayLike, vd: ArrayLike, vdd: ArrayLike) -> np.ndarray:
    """The instantaneous α-invariant α = v̇² − v v̈ (Milne (33)).

    Parameters
    ----------
    v, vd, vdd
        The signal and its first and second time derivatives (broadcastable arrays).

    Returns
    -------
    numpy.ndarray
        α, in the unit of v squared per second squared.
    """
    v, vd, vdd = (np.asarray(x, dtype=float) for x in (v, vd, vdd))
    return vd * vd - v * vdd


def cycle_average(t: ArrayLike, v: ArrayLike, vd: ArrayLike, vdd: ArrayLike | None = None, *,
                  period: float) -> float:
    """The cycle-averaged α-invariant over the last period ending at ``t[-1]`` (Milne (34)).

    The integrand is integrated by the trapezoidal rule over [t₀ − T, t₀], with the integrand linearly
    interpolated at t₀ − T when that time falls between samples. For a periodic signal sampled on a
    grid that divides the period the rule is spectrally accurate. Without ``vdd`` the integrated-by-parts
    form (2∫v̇² dt − [v v̇])/T is used, which needs only the first derivative.

    Parameters
    ----------
    t
        Increasing sample times (s), spanning at least ``period``.
    v, vd, vdd
        The signal and its derivatives at ``t`` (``vdd`` optional).
    period
        T (s), one cycle of the waveform.

    Returns
    -------
    float
        ᾱ.
    """
    t = _times(t)
    v, vd = _samples(v, t, "v"), _samples(vd, t, "vd")
    if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0):
        raise DataError(SOURCE, "period", f"must be a positive finite number of seconds, got {period!r}")
    if t[-1] - t[0] < period * (1.0 - 1e-12):
        raise DataError(SOURCE, "t", f"spans {t[-1] - t[0]:.6g} s, less than one period of {period:.6g} s")
    if vdd is None:
        integral = 2.0 * _integral(t, vd * vd, t[-1] - period)
        boundary = v * vd
        ends = boundary[-1] - float(np.interp(t[-1] - period, t, boundary))
        return (integral - ends) / period
    vdd = _samples(vdd, t, "vdd")
    return _integral(t, alpha_invariant(v, vd, vdd), t[-1] - period) / period


def sine_alpha(kp: float, omega: ArrayLike, a1: ArrayLike, a2: ArrayLike, reference_amplitude: ArrayLike) -> np.ndarray:
    """The α-invariant of the P-controller output for a sinusoidal steady state (Milne (36)).

    Parameters
    ----------
    kp
        Proportional gain k_p (command unit per rad).
    omega
        Angular frequency ω (rad/s).
    a1, a2
        Cartesian coefficients of the response θ = A₁ cos ωt + A₂ sin ωt (Milne (14)).
    reference_amplitude
        A_r of the reference r = A_r sin ωt.

    Returns
    -------
    numpy.ndarray
        α = k_p² ω² (A₁² + (A_r − A₂)²).
    """
    omega, a1, a2, ar = (np.asarray(x, dtype=float) for x in (omega, a1, a2, reference_amplitude))
    return kp * kp * omega * omega * (a1 * a1 + (ar - a2) ** 2)


def _times(t: ArrayLike) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise DataError(SOURCE, "t", f"must be a 1-D array of at least 2 times, got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise DataError(SOURCE, "t", "must be finite and strictly increasing")
    return t


def _samples(x: ArrayLike, t: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.shape != t.shape:
        raise DataError(SOURCE, name, f"has shape {x.shape}, the times {t.shape}")
    if not np.all(np.isfinite(x)):
        raise DataError(SOURCE, name, "has NaN or infinite samples")
    return x


def _integral(t: np.ndarray, y: np.ndarray, start: float) -> float:
    """∫_start^t[-1] y dt by the trapezoidal rule, y linearly interpolated at ``start``."""
    first = int(np.searchsorted(t, start, side="right"))
    first = max(first, 1)
    ts = np.concatenate(([start], t[first:]))
    ys = np.concatenate(([np.interp(start, t, y)], y[first:]))
    return float(np.trapezoid(ys, ts)) if hasattr(np, "trapezoid") else float(np.trapz(ys, ts))

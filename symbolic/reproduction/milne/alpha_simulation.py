"""Simulation of Milne et al.'s α-invariant model of one joint under a P controller (Milne (43)–(47)).

The model (43): θ̇ = Φ, Φ̇ = −C(α) Φ + β̃(α) v, α = v̇² − v v̈, v = k_p (r − θ), with C and β̃ of
:class:`~symbolic.reproduction.milne.alpha_damping.AlphaCoefficients`. Its algebraic loop
α = F(α) = v̇² − k_p v r̈ + k_p v (β̃(α) v − C(α) Φ) is solved exactly (:func:`solve_alpha`: every root of
the piecewise-linear α − F(α), the one nearest the previous α kept); Milne's iteration (44)–(46), with
its misprints corrected, is :func:`iterate_alpha`. :func:`simulate` integrates a batch of references by
classical Runge–Kutta with a fixed step, the loop solved at every stage: :func:`sine_sweep` (Milne
2.4.2) and :func:`square_wave` (2.4.3, (47) read as a reference step). The corrections, the reading of
(47) and why the exact solve: docs/seeds.md, "Milne: the α-invariant model".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from symbolic.data import DataError
from symbolic.errors import SimulationError
from symbolic.reproduction.milne.alpha_damping import AlphaCoefficients
from symbolic.reproduction.milne import SOURCE


ABSOLUTE_TOLERANCE = 1e-6
"""Milne (46): absolute stopping tolerance on α of the iteration."""

RELATIVE_TOLERANCE = 1e-3
"""Milne (46): relative stopping tolerance on α of the iteration."""


class AlphaLoopError(SimulationError):
    """The iteration (44)–(46) did not converge (|F′| ≥ 1 at the root); :func:`solve_alpha` still works."""


@dataclass(frozen=True)
class Reference:
    """A batch of reference signals r(t), one per run: sines A sin(2πft) or square waves.

    Attributes
    ----------
    kind
        ``"sine"`` or ``"square"`` (r = +A on [0, T/2), −A on [T/2, T), …).
    amplitude
        A_r per run (rad).
    frequency
        f per run (Hz).
    """

    kind: str
    amplitude: tuple[float, ...]
    frequency: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.kind not in ("sine", "square"):
            raise DataError(SOURCE, "reference kind", f"must be 'sine' or 'square', got {self.kind!r}")
        a = np.atleast_1d(np.asarray(self.amplitude, dtype=float))
        f = np.atleast_1d(np.asarray(self.frequency, dtype=float))
        if a.ndim != 1 or f.ndim != 1 or a.size == 0:
            raise DataError(SOURCE, "reference", "amplitude and frequency must be numbers or 1-D sequences")
        a, f = np.broadcast_arrays(a, f) if a.size == 1 or f.size == 1 else (a, f)
        if a.shape != f.shape:
            raise DataError(SOURCE, "reference", f"has {a.size} amplitudes and {f.size} frequencies")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(f)) and np.all(f > 0)):
            raise DataError(SOURCE, "reference", "amplitudes must be finite and frequencies positive and finite")
        object.__setattr__(self, "amplitude", tuple(float(x) for x in a))
        object.__setattr__(self, "frequency", tuple(float(x) for x in f))

    @cached_property
    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.amplitude), np.asarray(self.frequency)

    @property
    def runs(self) -> int:
        """Number of signals in the batch."""
        return len(self.amplitude)

    def signals(self, t: float, held: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r, ṙ, r̈) at time t; a square wave takes its level at ``held`` (the step's start)."""
        a, f = self._arrays
        w = 2.0 * math.pi * f
        if self.kind == "sine":
            s, c = np.sin(w * t), np.cos(w * t)
            return a * s, a * w * c, -a * w * w * s
        at = t if held is None else held
        # half periods elapsed; the small offset keeps a jump time (a multiple of h) on its new level
        half = np.floor(2.0 * f * at + 1e-9)
        level = np.where(half % 2 == 0, a, -a)
        zero = np.zeros_like(a)
        return level, zero, zero


@dataclass(frozen=True)
class AlphaResponse:
    """Simulated responses of a batch of runs, sampled every step.

    Attributes
    ----------
    t
        Times (s), shape (samples,).
    theta, phi
        Joint angle θ and velocity Φ, shape (runs, samples).
    command
        v = k_p(r − θ), shape (runs, samples).
    alpha
        α of the loop solution at each sample, shape (runs, samples).
    reference
        r at each sample, shape (runs, samples).
    """

    t: np.ndarray
    theta: np.ndarray
    phi: np.ndarray
    command: np.ndarray
    alpha: np.ndarray
    reference: np.ndarray


def loop_function(coefficients: AlphaCoefficients, kp: float, v: ArrayLike, vd: ArrayLike, rdd: ArrayLike,
                  phi: ArrayLike, alpha: ArrayLike) -> np.ndarray:
    """F(α) = v̇² − v v̈ with v̈ = k_p(r̈ − Φ̇) and Φ̇ = −C(α)Φ + β̃(α)v (Milne (43)); its fixed point is α."""
    v, vd, rdd, phi, alpha = (np.asarray(x, dtype=float) for x in (v, vd, rdd, phi, alpha))
    phid = -coefficients.damping(alpha) * phi + coefficients.torque_constant(alpha) * v
    return vd * vd - v * kp * (rdd - phid)


def solve_alpha(coefficients: AlphaCoefficients, kp: float, v: ArrayLike, vd: ArrayLike, rdd: ArrayLike,
                phi: ArrayLike, preferred: ArrayLike) -> np.ndarray:
    """The exact solution α = F(α) of the algebraic loop of Milne (43), per element.

    Parameters
    ----------
    coefficients
        C(α) and β̃(α).
    kp
        Proportional gain.
    v, vd
        Command v and its rate v̇ = k_p(ṙ − Φ).
    rdd
        r̈.
    phi
        Joint velocity Φ.
    preferred
        Where several roots exist, the one nearest this α is returned (the previous step's α).

    Returns
    -------
    numpy.ndarray
        α with α − F(α) = 0 to rounding.
    """
    v, vd, rdd, phi, preferred = np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, dtype=float))
                                                       for x in (v, vd, rdd, phi, preferred)))
    return _solve(coefficients.knots, coefficients.damping_at_knots, coefficients.torque_at_knots, kp,
                  v, vd, rdd, phi, preferred)


def _solve(knots: np.ndarray, c_k: np.ndarray, b_k: np.ndarray, kp: float, v: np.ndarray, vd: np.ndarray,
           rdd: np.ndarray, phi: np.ndarray, preferred: np.ndarray) -> np.ndarray:
    """:func:`solve_alpha` on 1-D arrays of equal length, C and β̃ given at their knots (no checks: the hot loop)."""
    f_k = (vd * vd - kp * v * rdd)[:, None] + (kp * v)[:, None] * (b_k * v[:, None] - c_k * phi[:, None])
    h_k = knots - f_k                            # α − F(α) at the knots; slope 1 outside them
    lo, hi = h_k[:, :-1], h_k[:, 1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        inner = np.where(lo * hi < 0, knots[:-1] + (knots[1:] - knots[:-1]) * lo / (lo - hi), np.nan)
    roots = np.concatenate([
        np.where(h_k[:, :1] > 0, f_k[:, :1], np.nan),      # below the first knot: α = F(knot₀) < knot₀
        np.where(h_k[:, -1:] < 0, f_k[:, -1:], np.nan),    # above the last knot
        np.where(h_k == 0, knots, np.nan),                 # on a knot
        inner,                                             # inside a linear piece
    ], axis=1)
    distance = np.abs(roots - preferred[:, None])
    distance[np.isnan(roots)] = np.inf
    return roots[np.arange(roots.shape[0]), np.argmin(distance, axis=1)]


def iterate_alpha(coefficients: AlphaCoefficients, kp: float, v: ArrayLike, vd: ArrayLike, rdd: ArrayLike,
                  phi: ArrayLike, linear: tuple[float, float], *, absolute: float = ABSOLUTE_TOLERANCE,
                  relative: float = RELATIVE_TOLERANCE, iterations: int = 100) -> tuple[np.ndarray, int]:
    """Milne's iteration (44)–(46), corrected (docs/seeds.md, "Milne: the α-invariant model"), per element.

    Parameters
    ----------
    coefficients, kp, v, vd, rdd, phi
        As :func:`solve_alpha`.
    linear
        (C_linear, β̃_linear) of the global linear model at this inertia, for the start (45).
    absolute, relative
        Stopping rule (46): |α^(i) − α^(i−1)| < max(absolute, relative·|α^(i)|) for every element.
    iterations
        N, the most iterations allowed.

    Returns
    -------
    (numpy.ndarray, int)
        α and the number of iterations taken.

    Raises
    ------
    AlphaLoopError
        When the rule (46) is not met within ``iterations``.
    """
    v, vd, rdd, phi = np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, dtype=float)) for x in (v, vd, rdd, phi)))
    previous = iterate_start(kp, v, vd, rdd, phi, linear)
    for i in range(1, iterations + 1):
        alpha = loop_function(coefficients, kp, v, vd, rdd, phi, previous)   # (44), corrected
        if np.all(np.abs(alpha - previous) < np.maximum(absolute, relative * np.abs(alpha))):
            return alpha, i
        previous = alpha
    raise AlphaLoopError(f"Milne (44)-(46): α did not converge in {iterations} iterations "
                         f"(the fixed-point map is not a contraction here); use solve_alpha")


def simulate(coefficients: AlphaCoefficients, kp: float, reference: Reference, duration: float, *,
             step: float = 1e-3, theta0: ArrayLike | None = None, phi0: ArrayLike = 0.0) -> AlphaResponse:
    """Integrate the α-invariant model (Milne (43)) under v = k_p(r − θ) for a batch of references.

    Parameters
    ----------
    coefficients
        C(α), β̃(α) (for the linear model: :meth:`AlphaCoefficients.linear`).
    kp
        Proportional gain k_p > 0.
    reference
        The references (all runs integrated together).
    duration
        Simulated time (s), a whole number of steps.
    step
        Fixed Runge–Kutta step h (s); a square wave's half period must be a whole number of steps.
    theta0, phi0
        Initial θ and Φ (default θ₀ = 0 for sines, −A_r for square waves: Milne (47)'s θ(0⁻) = −A_r).

    Returns
    -------
    AlphaResponse
    """
    count = _check_simulation(kp, reference, duration, step)
    runs = reference.runs
    if theta0 is None:
        theta0 = -np.asarray(reference.amplitude) if reference.kind == "square" else np.zeros(runs)
    theta = np.broadcast_to(np.asarray(theta0, dtype=float), (runs,)).copy()
    phi = np.broadcast_to(np.asarray(phi0, dtype=float), (runs,)).copy()
    knots, c_k, b_k = coefficients.knots, coefficients.damping_at_knots, coefficients.torque_at_knots

    def stage(t: float, held: float, th: np.ndarray, ph: np.ndarray, preferred: np.ndarray):
        """Φ̇ and the loop's α, v, r at one Runge–Kutta stage (r of a square wave held at the step's start)."""
        r, rd, rdd = reference.signals(t, held)
        v = kp * (r - th)
        alpha = _solve(knots, c_k, b_k, kp, v, kp * (rd - ph), rdd, ph, preferred)
        return -coefficients.damping(alpha) * ph + coefficients.torque_constant(alpha) * v, alpha, v, r

    out = {name: np.empty((runs, count + 1)) for name in ("theta", "phi", "command", "alpha", "reference")}
    # The first root is chosen near Milne's first approximation (44)–(45), with the model's C and β̃ at the
    # middle of its break points standing in for the linear model (from rest it is the unique root anyway).
    r0, rd0, rdd0 = reference.signals(0.0, 0.0)
    middle = float(np.mean(knots))
    preferred = iterate_start(kp, kp * (r0 - theta), kp * (rd0 - phi), rdd0, phi,
                              (float(coefficients.damping(middle)), float(coefficients.torque_constant(middle))))
    for n in range(count + 1):
        t = n * step
        k1, preferred, v, r = stage(t, t, theta, phi, preferred)
        for name, value in (("theta", theta), ("phi", phi), ("command", v), ("alpha", preferred), ("reference", r)):
            out[name][:, n] = value
        if n == count:
            break
        # classical RK4 on (θ, Φ): the θ-slopes are the stage velocities
        phi2 = phi + step / 2 * k1
        k2 = stage(t + step / 2, t, theta + step / 2 * phi, phi2, preferred)[0]
        phi3 = phi + step / 2 * k2
        k3 = stage(t + step / 2, t, theta + step / 2 * phi2, phi3, preferred)[0]
        phi4 = phi + step * k3
        k4 = stage(t + step, t, theta + step * phi3, phi4, preferred)[0]
        theta = theta + step / 6 * (phi + 2 * phi2 + 2 * phi3 + phi4)
        phi = phi + step / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return AlphaResponse(np.arange(count + 1) * step, out["theta"], out["phi"], out["command"], out["alpha"],
                         out["reference"])


def _check_simulation(kp: float, reference: Reference, duration: float, step: float) -> int:
    """The number of steps, after one-line errors for a bad gain, step or duration."""
    _check_positive(kp, "kp")
    _check_positive(step, "step")
    _check_positive(duration, "duration")
    count = round(duration / step)
    if abs(count * step - duration) > 1e-9 * duration:
        raise DataError(SOURCE, "duration", f"{duration!r} s is not a whole number of steps of {step!r} s")
    if reference.kind == "square":
        for f in reference.frequency:
            halves = 1.0 / (2.0 * f * step)
            if abs(halves - round(halves)) > 1e-9 * halves:
                raise DataError(SOURCE, "step", f"half the square wave's period ({1 / (2 * f)!r} s) "
                                f"is not a whole number of steps of {step!r} s")
    return count


def iterate_start(kp: float, v: ArrayLike, vd: ArrayLike, rdd: ArrayLike, phi: ArrayLike,
                  linear: tuple[float, float]) -> np.ndarray:
    """α^(1) of Milne (44) from the linear start (45), corrected.

    α^(1) = v̇² − v·k_p(r̈ − Φ̇_lin) with Φ̇_lin = −C_linear Φ + β̃_linear v, ``linear`` = (C_linear, β̃_linear).
    """
    v, vd, rdd, phi = (np.asarray(x, dtype=float) for x in (v, vd, rdd, phi))
    c_lin, b_lin = linear
    return vd * vd - v * kp * (rdd - (-c_lin * phi + b_lin * v))


def sine_sweep(coefficients: AlphaCoefficients, kp: float, amplitude: float | Sequence[float],
               frequencies: Sequence[float], duration: float, *, step: float = 1e-3) -> AlphaResponse:
    """Responses to r = A_r sin(2πft) for each frequency (Milne 2.4.2), integrated together from rest."""
    return simulate(coefficients, kp, Reference("sine", amplitude, tuple(frequencies)), duration, step=step)


def square_wave(coefficients: AlphaCoefficients, kp: float, amplitude: float, frequency: float, duration: float,
                *, step: float = 1e-3) -> AlphaResponse:
    """Response to a square-wave reference of ±A_r (Milne 2.4.3 and (47), read as a reference step)."""
    return simulate(coefficients, kp, Reference("square", (amplitude,), (frequency,)), duration, step=step)


def _check_positive(value: object, name: str) -> None:
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0):
        raise DataError(SOURCE, name, f"must be a positive finite number, got {value!r}")

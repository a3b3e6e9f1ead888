"""First-peak Coulomb friction identification from proportional-control step responses (Madill 5.3).

A joint P(s) = 1/(s(Js + B)) with Coulomb friction f under a proportional loop of gain K: the first
peaks y_i of steps r_i lie on y = α (r − f/K), and the slope α, the r-intercept r0 and the mean time to
the first peak t_p give f, ζ, ωn, J and B by Madill (5.6)–(5.9) (:func:`from_peaks`). :func:`identify`
finds the steps and first peaks in arrays (t, q, reference, K) and :func:`identify_experiment` in an
experiment file whose ``[controller]`` declares the loop (``kind = "pd"``, ``kp``, ``kd`` (0 for a P loop),
``gain``, ``delay``; docs/simulation.md); both return a :class:`FirstPeak` listing the steps used and
rejected. Beyond the thesis, for sampled logs: each step is measured from where the joint rests, and B
is corrected for the sampled loop's hold (a negative damping K·(½ + delay)·T) and for a ``kd`` term.
The derivation, the experiment, these corrections and the method's sensitivity: docs/seeds.md, "Madill:
first-peak friction identification".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import optimize

from symbolic.data import DataError, Measurements, load
from symbolic.simulation import controller as control
import symbolic.robots as robots

REST_SAMPLES = 20
"""Samples before a step whose median is the starting position (fewer when the previous step is shorter)."""

REST_SPREAD = 0.05
"""A step is refused when the position spreads over more than this fraction of the step in those samples
(the joint is still moving)."""

PEAK_WINDOW = 0.15
"""Half-width of the fit around the first peak, as a fraction of the time to it: the fit averages noise
and quantisation over ±0.15 t_p (:func:`_refine_peak`)."""

RISE_MARGIN = 0.02
"""The peak window is first centred where the response rises within this fraction of its highest value."""

EDGE_SAMPLES = 3
"""A maximum this close to the next step (or the end of the log) is not known to be the first peak."""


@dataclass(frozen=True)
class Chain:
    """Madill's (5.6)–(5.9): the plant from the slope, r-intercept and time to first peak at loop gain K."""

    slope: float
    intercept: float
    peak_time: float
    gain: float
    zeta: float
    omega_n: float
    J: float
    B: float
    f: float


def zeta_from_slope(alpha: float) -> float:
    """ζ from the slope α of the first peaks against the step sizes (5.8): β = −ln(α − 1), ζ = β/√(π² + β²)."""
    if not 1.0 < alpha < 2.0:
        raise ValueError(f"slope {alpha:g} is outside (1, 2): no damped overshoot")
    beta = -math.log(alpha - 1.0)
    return beta / math.sqrt(math.pi**2 + beta**2)


def slope_from_zeta(zeta: float) -> float:
    """α = 1 + exp(−ζπ/√(1 − ζ²)), the inverse of :func:`zeta_from_slope`."""
    return 1.0 + math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta**2))


def omega_from_peak_time(peak_time: float, zeta: float) -> float:
    """ωn = π/(t_p √(1 − ζ²)) (5.9)."""
    return math.pi / (peak_time * math.sqrt(1.0 - zeta**2))


def from_peaks(slope: float, intercept: float, peak_time: float, gain: float) -> Chain:
    """ζ, ωn, J, B, f from the regression's slope α, r-intercept r0 and t_p at loop gain K (5.6)–(5.9).

    Parameters
    ----------
    slope, intercept
        α and r0 of y_i = α (r_i − r0).
    peak_time
        The (mean) time from a step to its first peak, s.
    gain
        K, the loop gain: generalized force per unit position error.
    """
    zeta = zeta_from_slope(slope)
    omega = omega_from_peak_time(peak_time, zeta)
    J = gain / omega**2
    return Chain(slope, intercept, peak_time, gain, zeta, omega, J, 2.0 * zeta * math.sqrt(gain * J), gain * intercept)


@dataclass(frozen=True)
class Step:
    """One step of the log and its first peak (positions in the coordinate's unit, times in s)."""

    time: float
    size: float  # r − q_start, signed
    start: float  # q_start
    peak: float  # sign(size)·(q_peak − q_start), > 0
    peak_time: float  # from the step; NaN when the top is too flat to place the peak


@dataclass(frozen=True)
class FirstPeak:
    """The identification of one joint from its step responses.

    ``J``, ``B``, ``f`` are the plant's; ``chain`` holds Madill's (5.6)–(5.9) as printed (its ``B`` is
    the loop's damping 2ζ√(KJ)); ``hold_damping`` = K(½ + delay)T and ``derivative_damping`` = gain·kd
    are the corrections between the two: B = chain.B + hold_damping − derivative_damping.
    """

    coordinate: str
    gain: float
    steps: tuple[Step, ...]
    rejected: tuple[tuple[float, str], ...]
    chain: Chain
    hold_damping: float
    derivative_damping: float
    source: str = "<arrays>"
    notes: tuple[str, ...] = field(default=())

    @property
    def J(self) -> float:
        return self.chain.J

    @property
    def B(self) -> float:
        return self.chain.B + self.hold_damping - self.derivative_damping

    @property
    def f(self) -> float:
        return self.chain.f

    def to_dict(self) -> dict[str, Any]:
        c = self.chain
        return {
            "coordinate": self.coordinate, "source": self.source, "gain": self.gain,
            "slope": c.slope, "r_intercept": c.intercept, "peak_time": c.peak_time,
            "zeta": c.zeta, "omega_n": c.omega_n, "J": self.J, "B": self.B, "f": self.f,
            "B_loop": c.B, "hold_damping": self.hold_damping, "derivative_damping": self.derivative_damping,
            "steps": [{"time": s.time, "size": s.size, "start": s.start, "peak": s.peak,
                       "peak_time": s.peak_time if math.isfinite(s.peak_time) else None} for s in self.steps],
            "rejected": [{"time": t, "why": why} for t, why in self.rejected],
        }

    def summary(self) -> str:
        """A few lines: the steps used, the regression and the identified plant."""
        c = self.chain
        lines = [f"first-peak identification of {self.coordinate} ({self.source}), loop gain K = {self.gain:.6g}",
                 f"  {len(self.steps)} step(s) used, {len(self.rejected)} rejected"]
        lines += [f"    rejected at t = {t:.6g} s: {why}" for t, why in self.rejected]
        lines += [f"  slope α = {c.slope:.6g}, r-intercept r0 = {c.intercept:.6g}, mean t_p = {c.peak_time:.6g} s",
                  f"  ζ = {c.zeta:.6g}, ωn = {c.omega_n:.6g} rad/s",
                  f"  J = {self.J:.6g}, B = {self.B:.6g} (loop 2ζ√(KJ) = {c.B:.6g}, hold +{self.hold_damping:.3g}, "
                  f"derivative −{self.derivative_damping:.3g}), f = {self.f:.6g}"]
        return "\n".join(lines + [f"  note: {n}" for n in self.notes])


def identify(
    t: Any,
    q: Any,
    reference: Any,
    gain: float,
    *,
    coordinate: str = "q",
    derivative_gain: float = 0.0,
    delay: int = 0,
    source: str = "<arrays>",
) -> FirstPeak:
    """Find the steps of ``reference`` and the first peaks of ``q``, and identify J, B, f.

    Parameters
    ----------
    t, q, reference
        Sample times (uniform), the measured position and the piecewise-constant reference.
    gain
        K: the loop's generalized force per unit position error (gain·kp of a ``[controller]``).
    derivative_gain
        gain·kd of a derivative term on the measured velocity, subtracted from the identified damping.
    delay
        Samples between measuring and applying, on top of the one-sample hold.

    Raises
    ------
    DataError
        One line naming ``source``: no steps, fewer than two usable steps or step sizes, a slope outside
        (1, 2), a non-positive gain.
    """
    t, q, r = (np.asarray(x, dtype=float).ravel() for x in (t, q, reference))
    if not (t.size == q.size == r.size) or t.size < 3:
        raise DataError(source, coordinate, f"t, q and reference need the same length ≥ 3, got {t.size}, {q.size}, {r.size}")
    for name, x in (("t", t), ("q", q), ("reference", r)):
        if not np.all(np.isfinite(x)):
            raise DataError(source, f"{coordinate} {name}", "not finite everywhere (allowed: finite numbers)")
    if not (math.isfinite(gain) and gain > 0):
        raise DataError(source, f"{coordinate} gain", f"the loop gain K must be a number > 0, got {gain!r}")
    period = float(np.mean(np.diff(t)))
    if period <= 0:
        raise DataError(source, "t", "time is not increasing")
    usable, rejected = _find_steps(t, q, r, source, coordinate)
    if len(usable) < 2:
        reasons = "; ".join(f"t = {a:.6g} s: {why}" for a, why in rejected) or "none rejected"
        raise DataError(source, coordinate, f"{len(usable)} usable step response(s) with a first peak "
                                            f"(at least 2 of different sizes are needed; {reasons})")
    sizes = np.array([abs(s.size) for s in usable])
    peaks = np.array([s.peak for s in usable])
    if np.ptp(sizes) <= 1e-9 * sizes.max():
        raise DataError(source, coordinate, f"all {len(usable)} usable steps have the size {sizes[0]:.6g}: the "
                                            "r-intercept needs steps of at least two sizes")
    slope, offset = np.polyfit(sizes, peaks, 1)
    if not 1.0 < slope < 2.0:
        raise DataError(source, coordinate, f"the first peaks grow with slope {slope:.6g} per unit step (allowed: "
                                            "between 1 and 2, an underdamped response)")
    times = [s.peak_time for s in usable if math.isfinite(s.peak_time)]
    if not times:
        raise DataError(source, coordinate, "no step has a first peak whose time can be fitted (flat tops: is the "
                                            "joint sticking at its peaks? use larger steps)")
    chain = from_peaks(float(slope), float(-offset / slope), float(np.mean(times)), gain)
    notes = []
    if len(times) < len(usable):
        notes.append(f"{len(usable) - len(times)} step(s) with a flat top: their peaks are used, not their times")
    if chain.intercept < 0:
        notes.append("negative r-intercept: the fit implies negative friction (too few or too noisy steps?)")
    return FirstPeak(coordinate, gain, tuple(usable), tuple(rejected), chain,
                     hold_damping=gain * period * (0.5 + delay), derivative_damping=derivative_gain,
                     source=source, notes=tuple(notes))


def _find_steps(t: np.ndarray, q: np.ndarray, r: np.ndarray, source: str,
                coordinate: str) -> tuple[list[Step], list[tuple[float, str]]]:
    """The usable steps (changes of the reference) and, for the others, their time and why not."""
    scale = max(float(np.max(np.abs(r))), float(np.ptp(r)), 1e-300)
    changes = np.flatnonzero(np.abs(np.diff(r)) > 1e-12 * scale) + 1
    if changes.size == 0:
        raise DataError(source, f"{coordinate} reference", "has no step (it is constant over the log)")
    if np.any(np.diff(changes) < 2 * EDGE_SAMPLES):
        k = int(changes[np.argmax(np.diff(changes) < 2 * EDGE_SAMPLES)])
        raise DataError(source, f"{coordinate} reference", f"changes again within {2 * EDGE_SAMPLES} samples of "
                                                           f"t = {t[k]:.6g} s: not a sequence of steps")
    bounds = list(changes) + [t.size]
    steps: list[Step] = []
    rejected: list[tuple[float, str]] = []
    previous = 0
    for k, end in zip(bounds[:-1], bounds[1:]):
        outcome = _one_step(t, q, r, k, end, previous)
        previous = k
        if isinstance(outcome, Step):
            steps.append(outcome)
        else:
            rejected.append((float(t[k]), outcome))
    return steps, rejected


def _one_step(t: np.ndarray, q: np.ndarray, r: np.ndarray, k: int, end: int, previous: int) -> Step | str:
    """The step at sample k (segment k..end−1) or why it cannot be used."""
    rest = q[max(previous, k - REST_SAMPLES):k]
    if rest.size == 0:
        return "the log starts with it: no position at rest before it"
    start = float(np.median(rest))
    size = float(r[k] - start)
    if size == 0.0:
        return "the reference steps to where the joint already is"
    if np.ptp(rest) > REST_SPREAD * abs(size):
        return "the joint is still moving when the step starts"
    s = np.sign(size) * (q[k:end] - start)
    m = int(np.argmax(s))
    if m >= s.size - EDGE_SAMPLES:
        return "no first peak before the next step or the end of the log (overdamped, or the step is too short)"
    if m < EDGE_SAMPLES or s[m] <= 0:
        return "the joint does not move (the step is within the friction's dead band)"
    peak, when = _refine_peak(t[k:end] - t[k], s, m)
    return Step(float(t[k]), size, start, peak, when)


def _refine_peak(tau: np.ndarray, s: np.ndarray, m: int) -> tuple[float, float]:
    """Peak value and time by least squares over ±PEAK_WINDOW·t_p around the peak.

    At the peak the velocity is zero and changes sign, and so does the Coulomb friction: the
    acceleration jumps by 2f/J there. The model is therefore y = A − c₋(x − x₀)² before the vertex x₀
    and A − c₊(x − x₀)² after it (one vertex, two curvatures, which also absorb the envelope's decay);
    a single parabola would move the vertex towards the flatter side (by 5 % of t_p for a step of
    4 f/K). Linear in (A, c₋, c₊) for a given x₀, which is found by a bounded scalar search.

    A small step can leave the joint almost stuck at its peak (K·overshoot barely above f), so the top
    is flat on the far side and noise puts the highest sample anywhere along it: the window is centred
    first where the rise reaches within RISE_MARGIN of the highest value, then on the fitted vertex.
    The time is NaN when no maximum is fitted (the highest sample's value is kept).
    """
    centre = int(np.argmax(s >= s[m] - RISE_MARGIN * s[m]))
    peak = (float(s[m]), math.nan)
    for _ in range(3):
        fitted = _split_parabola(tau, s, max(centre, 1))
        if fitted is None:
            return peak
        peak = fitted
        centre = int(np.clip(np.searchsorted(tau, peak[1]), 1, s.size - 2))
    return peak


def _window(tau: np.ndarray, centre: int, width: float) -> slice:
    half = max(3, int(round(width * tau[centre] / (tau[1] - tau[0]))))
    return slice(max(0, centre - half), min(tau.size, centre + half + 1))


def _split_parabola(tau: np.ndarray, s: np.ndarray, centre: int) -> tuple[float, float] | None:
    window = _window(tau, centre, PEAK_WINDOW)
    x, y = tau[window] - tau[centre], s[window]

    def fit(x0: float) -> tuple[float, np.ndarray]:
        u = x - x0
        basis = np.column_stack([np.ones_like(u), -np.where(u < 0, u**2, 0.0), -np.where(u >= 0, u**2, 0.0)])
        coefficients, *_ = np.linalg.lstsq(basis, y, rcond=None)
        residual = y - basis @ coefficients
        return float(residual @ residual), coefficients

    step = tau[1] - tau[0]
    best = optimize.minimize_scalar(lambda x0: fit(x0)[0], bounds=(x[0], x[-1]), method="bounded",
                                    options={"xatol": 1e-6 * step})
    _, (A, below, above) = fit(best.x)
    if below <= 0 or above <= 0:  # not a maximum
        return None
    return float(A), float(tau[centre] + best.x)


def identify_experiment(data: str | Path | Measurements, coordinate: str | None = None) -> FirstPeak:
    """:func:`identify` on a step-response log: an experiment file (or loaded Measurements) whose
    ``[controller]`` declares ``kind = "pd"`` with ``kp`` (``kd`` may be 0), ``gain`` and ``reference``.

    The loop gain is K = gain·kp; a ``gain`` that is an expression of model parameters is evaluated at
    the nominal values of the experiment's ``model``.

    Raises
    ------
    DataError
        One line naming the file and key: no ``[controller]``, a kind other than ``pd``, a coordinate the
        controller does not drive, a symbolic gain without a model, plus those of :func:`identify`.
    """
    measurements = load(data)  # an experiment file, or measurements as they are (their controller checked once)
    source = str(measurements.source)
    ctrl = measurements.controller
    if ctrl is None:
        raise DataError(source, "[controller]", 'missing: the first-peak method needs the loop gain '
                                                '([controller] kind = "pd", kp, gain)')
    parameters = _model_parameters(measurements.model, source)
    if ctrl.kind != "pd":
        raise DataError(source, "[controller] kind", f"{ctrl.kind!r}: the first-peak method needs proportional "
                                                     'control (allowed: "pd", with kd = 0 or a derivative term)')
    if coordinate is None:
        if ctrl.size != 1:
            raise DataError(source, "[controller] coordinates", f"controls {', '.join(ctrl.coordinates)}: name the "
                                                                "coordinate to identify (allowed: one of them)")
        coordinate = ctrl.coordinates[0]
    if coordinate not in ctrl.coordinates:
        raise DataError(source, "coordinate", f"{coordinate!r} is not driven by the controller "
                                              f"(allowed: {', '.join(ctrl.coordinates)})")
    j = ctrl.coordinates.index(coordinate)
    gain = control.constants(ctrl, parameters)[4 * ctrl.size + j]  # kp, kd, ki, kv, then gain
    if ctrl.kp[j] <= 0 or gain <= 0:
        raise DataError(source, f"[controller] kp[{j}]", "the loop gain gain·kp must be > 0")
    if ctrl.kd[j] > 0 and len(ctrl.velocity_filter) > 1:
        raise DataError(source, "[controller] velocity_filter", "a filtered derivative term delays the damping "
                                                                 "it adds: the first-peak method needs kd = 0 here")
    if np.isfinite(ctrl.saturation[j]):
        _check_saturation(ctrl, measurements, j, source)
    signals = control.inputs(ctrl, measurements, measurements.coordinates)
    q = measurements.q[:, list(measurements.coordinates).index(coordinate)]
    return identify(measurements.t, q, signals.reference[:, j], float(gain * ctrl.kp[j]), coordinate=coordinate,
                    derivative_gain=float(gain * ctrl.kd[j]), delay=ctrl.delay, source=source)


def _model_parameters(model: str | None, source: str) -> dict[Any, float]:
    """The nominal parameter values of the experiment's model (none without a model)."""
    if model is None:
        return {}
    robot = robots.resolve(model, folder=Path(source).parent)  # as the experiment located it
    return dict(robot.parameter_values)


def _check_saturation(ctrl: Any, measurements: Measurements, j: int, source: str) -> None:
    """Refuse a log whose steps saturate the controller: the loop is then not linear up to the peak."""
    reference = control.inputs(ctrl, measurements, measurements.coordinates).reference[:, j]
    q = measurements.q[:, list(measurements.coordinates).index(ctrl.coordinates[j])]
    worst = float(np.max(np.abs(ctrl.kp[j] * (reference - q))))
    if worst > ctrl.saturation[j]:
        raise DataError(source, f"[controller] saturation[{j}]", f"kp·|r − q| reaches {worst:.6g} > {ctrl.saturation[j]:.6g}: "
                                                                 "the steps saturate the output (allowed: steps within "
                                                                 "the linear range)")


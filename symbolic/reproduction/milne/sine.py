"""Sinusoidal steady-state identification of one joint under proportional control (Milne et al. 2.2).

For the joint θ̈ + C θ̇ + β θ = β r, β = β̃·k_p (Milne (13)), driven by r = A_r sin ωt at known
frequencies: the steady response θ = A₁ cos ωt + A₂ sin ωt (+ offset) per frequency, by linear least
squares over whole periods (Milne (14)–(16)); C_data and β_data (19)–(20) with Milne's exclusion rule;
the global linear model (21) by least squares on (22) over all frequencies, with σ propagated from the
sine fits. (18) and (22) are used with −ωA₁C in their second row, where Milne print +ωA₁C: the
derivation, and how to record the logs, are in docs/seeds.md, "Milne: sinusoidal identification and
the inertia model".

Inputs are plain arrays (:func:`fit_sine`, :func:`steady_state_response`, :func:`local_parameters`,
:func:`global_linear_fit`) or measured logs (:func:`identify_joint`: one log per frequency with the
joint's ``q`` and ``ref`` columns, the P gain from the experiment's ``[controller]``). Bad input raises
:class:`~symbolic.data.DataError` with one line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.data import DataError, Experiment, Measurements
from symbolic.data.measurements import UNIFORM_TOLERANCE  # time steps uniform as the data layer's

MINIMUM_PERIODS = 2
"""Whole periods the steady-state window must hold (fewer cannot tell a sinusoid from a drift)."""



@dataclass(frozen=True)
class SineFit:
    """Least-squares sinusoid y ≈ a_cos·cos(ωt) + a_sin·sin(ωt) + offset over a window (Milne (14)–(15)).

    Attributes
    ----------
    frequency
        Hz.
    a_cos, a_sin, offset
        The coefficients, in the signal's unit.
    periods
        Whole periods in the window.
    start, stop
        First and last time of the window (s).
    residual_rms
        RMS of y minus the sinusoid over the window.
    """

    frequency: float
    a_cos: float
    a_sin: float
    offset: float
    periods: int
    start: float
    stop: float
    residual_rms: float

    @property
    def amplitude(self) -> float:
        """√(a_cos² + a_sin²)."""
        return math.hypot(self.a_cos, self.a_sin)

    @property
    def phase(self) -> float:
        """φ with y = amplitude·sin(ωt + φ) + offset (rad): atan2(a_cos, a_sin) (Milne (16))."""
        return math.atan2(self.a_cos, self.a_sin)


@dataclass(frozen=True)
class SteadyStateResponse:
    """A joint's steady-state response to a sinusoidal reference, in the reference's phase (Milne (14)).

    The reference is r = A_r sin(ωt') and the response θ = A₁ cos(ωt') + A₂ sin(ωt') + offset, with t'
    the time shifted so that the reference has zero phase.

    Attributes
    ----------
    frequency
        Hz.
    a1, a2
        Milne's A₁ (cos) and A₂ (sin) of the response.
    reference_amplitude
        A_r.
    offset
        Constant part of the response minus that of the reference.
    response, reference
        The raw fits of the response and of the reference.
    """

    frequency: float
    a1: float
    a2: float
    reference_amplitude: float
    offset: float
    response: SineFit | None = None
    reference: SineFit | None = None

    @property
    def omega(self) -> float:
        """2πf (rad/s)."""
        return 2.0 * math.pi * self.frequency

    @property
    def gain(self) -> float:
        """A₀/A_r: the magnitude of the closed-loop response."""
        return math.hypot(self.a1, self.a2) / self.reference_amplitude

    @property
    def phase(self) -> float:
        """φ = atan2(A₁, A₂) (rad; negative for a lagging response) (Milne (16))."""
        return math.atan2(self.a1, self.a2)


@dataclass(frozen=True)
class LocalParameters:
    """Per-frequency C_data and β_data (Milne (19)–(20)) and whether Milne's rule keeps the frequency.

    Attributes
    ----------
    frequency
        Hz.
    C, beta
        C_data(ω) (1/s) and β_data(ω) (1/s²); NaN where the denominator is zero.
    denominator
        A₁² + A₂(A₂ − A_r).
    valid
        False when A_r A₂ ≥ A₁² + A₂² (the denominator is not positive): excluded, as Milne does.
    """

    frequency: float
    C: float
    beta: float
    denominator: float
    valid: bool


@dataclass(frozen=True)
class GlobalLinearFit:
    """C_linear and β_linear of the global linear model (21) fitted by (22) over several frequencies.

    Attributes
    ----------
    C, beta
        C_linear (1/s) and β_linear (1/s²).
    sigma_C, sigma_beta
        Standard deviations from the errors of A₁, A₂ propagated through (22) (:func:`global_linear_fit`;
        NaN for one frequency without ``sigma_a``).
    covariance
        2×2 covariance of (C, β).
    frequencies
        The frequencies used (Hz).
    residual_rms
        RMS of the residual of (22).
    """

    C: float
    beta: float
    sigma_C: float
    sigma_beta: float
    covariance: np.ndarray
    frequencies: tuple[float, ...]
    residual_rms: float

    def beta_tilde(self, kp: float) -> float:
        """β̃_linear = β_linear / k_p (Milne (26))."""
        return self.beta / kp

    @property
    def natural_frequency(self) -> float:
        """:func:`natural_frequency` of β_linear (Hz): Milne's "linear resonant frequency"."""
        return natural_frequency(self.beta)


@dataclass(frozen=True)
class JointIdentification:
    """Sinusoidal identification of one joint (:func:`identify_joint`).

    Attributes
    ----------
    coordinate
        The joint.
    kp, kd
        The P gain and the derivative gain on the measurement read from ``[controller]``.
    responses
        One :class:`SteadyStateResponse` per frequency.
    local
        One :class:`LocalParameters` per frequency (C corrected for kd: C − β·kd/kp).
    linear
        The global fit (22) over the frequencies (C corrected for kd likewise).
    """

    coordinate: str
    kp: float
    kd: float
    responses: tuple[SteadyStateResponse, ...]
    local: tuple[LocalParameters, ...]
    linear: GlobalLinearFit

    @property
    def beta_tilde(self) -> float:
        """β̃_linear = β_linear/k_p (Milne (26))."""
        return self.linear.beta / self.kp


def natural_frequency(beta: float) -> float:
    """√β/(2π) in Hz: the undamped natural frequency of (13)/(21), where its phase crosses −90°.

    Milne 3.3's "linear resonant frequency of 3.4 Hz" is this for Table 9's β_linear = 445.6 (3.36 Hz);
    the magnitude peak (:func:`peak_frequency`) is lower. NaN for β ≤ 0.
    """
    return math.sqrt(beta) / (2.0 * math.pi) if beta > 0 else math.nan


def peak_frequency(C: float, beta: float) -> float:
    """Frequency of the magnitude peak of β/(β − ω² + jCω) in Hz, √(β − C²/2)/(2π); NaN when it has none."""
    squared = beta - 0.5 * C * C
    return math.sqrt(squared) / (2.0 * math.pi) if beta > 0 and squared > 0 else math.nan


def fit_sine(
    t: np.ndarray,
    y: np.ndarray,
    frequency: float,
    *,
    transient: float | None = None,
    source: str = "<arrays>",
    name: str = "y",
) -> SineFit:
    """Fit y ≈ a_cos cos(ωt) + a_sin sin(ωt) + offset over the whole periods after the transient (Milne (15)).

    Parameters
    ----------
    t, y
        Uniformly sampled time (s) and signal.
    frequency
        The known excitation frequency (Hz).
    transient
        Seconds discarded at the start; default half the record. The window is the largest number of
        whole periods that ends at the last sample and starts no earlier than ``t[0] + transient``.
    source, name
        For error messages.

    Raises
    ------
    DataError
        Non-uniform or non-increasing time, lengths that differ, a frequency that is not a positive
        number, or fewer than :data:`MINIMUM_PERIODS` whole periods after the transient.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float).reshape(-1)
    _check_frequency(frequency, source)
    _check_time(t, source)
    if y.shape != t.shape:
        raise DataError(source, name, f"{y.size} samples, while t has {t.size} (they must have the same length)")
    if not np.all(np.isfinite(y)):
        raise DataError(source, name, "holds NaN or infinity (allowed: finite numbers)")
    window, periods = _steady_window(t, frequency, transient, source)
    omega = 2.0 * math.pi * frequency
    tw, yw = t[window], y[window]
    basis = np.column_stack([np.cos(omega * tw), np.sin(omega * tw), np.ones_like(tw)])
    coefficients, *_ = np.linalg.lstsq(basis, yw, rcond=None)
    residual = yw - basis @ coefficients
    return SineFit(
        frequency=float(frequency),
        a_cos=float(coefficients[0]),
        a_sin=float(coefficients[1]),
        offset=float(coefficients[2]),
        periods=periods,
        start=float(tw[0]),
        stop=float(tw[-1]),
        residual_rms=float(np.sqrt(np.mean(residual**2))),
    )


def steady_state_response(
    t: np.ndarray,
    q: np.ndarray,
    reference: np.ndarray,
    frequency: float,
    *,
    transient: float | None = None,
    source: str = "<arrays>",
) -> SteadyStateResponse:
    """Milne's A₁, A₂, A_r of a response ``q`` to a sinusoidal ``reference`` sampled at ``t``.

    Both signals are fitted on the same window (:func:`fit_sine`); the response's coefficients are then
    rotated into the reference's phase, so the reference need not start at zero phase.

    Raises
    ------
    DataError
        As :func:`fit_sine`, and when the reference has no component at ``frequency``.
    """
    ref_fit = fit_sine(t, reference, frequency, transient=transient, source=source, name="reference")
    q_fit = fit_sine(t, q, frequency, transient=transient, source=source, name="q")
    amplitude = ref_fit.amplitude
    scale = max(float(np.max(np.abs(reference))), np.finfo(float).tiny)
    if amplitude <= 1e-9 * scale:
        raise DataError(source, "reference", f"has no component at {frequency:g} Hz (is that the frequency of the "
                                             "sine it holds?)")
    # Reference r = Ar sin(ωt + ψ): in t' = t + ψ/ω it is Ar sin(ωt'); rotate q's phasor by −ψ.
    psi = ref_fit.phase
    c, s = math.cos(psi), math.sin(psi)
    a1 = q_fit.a_cos * c - q_fit.a_sin * s
    a2 = q_fit.a_sin * c + q_fit.a_cos * s
    return SteadyStateResponse(
        frequency=float(frequency),
        a1=a1,
        a2=a2,
        reference_amplitude=amplitude,
        offset=q_fit.offset - ref_fit.offset,
        response=q_fit,
        reference=ref_fit,
    )


def local_parameters(frequency: float, a1: float, a2: float, reference_amplitude: float) -> LocalParameters:
    """C_data and β_data at one frequency (Milne (19)–(20)) and Milne's exclusion rule.

    Parameters
    ----------
    frequency
        Hz.
    a1, a2, reference_amplitude
        Milne's A₁, A₂ (response in the reference's phase) and A_r.
    """
    _check_frequency(frequency, "<arrays>")
    omega = 2.0 * math.pi * frequency
    denominator = a1 * a1 + a2 * (a2 - reference_amplitude)
    if denominator == 0.0:
        return LocalParameters(float(frequency), math.nan, math.nan, 0.0, False)
    C = -omega * reference_amplitude * a1 / denominator
    beta = omega**2 * (a1 * a1 + a2 * a2) / denominator
    return LocalParameters(float(frequency), C, beta, denominator, denominator > 0.0)


def response_parameters(response: SteadyStateResponse) -> LocalParameters:
    """:func:`local_parameters` of a :class:`SteadyStateResponse`."""
    return local_parameters(response.frequency, response.a1, response.a2, response.reference_amplitude)


def global_linear_fit(
    frequencies: Sequence[float] | np.ndarray,
    a1: Sequence[float] | np.ndarray,
    a2: Sequence[float] | np.ndarray,
    reference_amplitude: Sequence[float] | np.ndarray | float,
    *,
    sigma_a: Sequence[float] | np.ndarray | None = None,
) -> GlobalLinearFit:
    """C_linear and β_linear by least squares on the corrected (22) stacked over the frequencies.

    The estimate is Milne's: ordinary least squares on (22). Its errors come from the errors δA₁, δA₂
    of the sine fits, which enter W as well as the right-hand side: both rows of frequency k have the
    residual −(β − ω_k² + jω_k C)-weighted error, of variance s_k² = σ_A,k²·|β − ω_k² + jω_k C|² for
    independent δA₁, δA₂ of variance σ_A,k² (a least-squares sine fit over whole periods gives them so).
    The covariance is therefore the sandwich (WᵀW)⁻¹ Wᵀ diag(s²) W (WᵀW)⁻¹, not σ²(WᵀW)⁻¹: the rows at
    high frequency, where |β − ω²| is large, are noisier.

    Parameters
    ----------
    frequencies
        Hz, one per response.
    a1, a2
        Milne's A₁ and A₂ per frequency.
    reference_amplitude
        A_r per frequency (or one for all).
    sigma_a
        Standard deviation of A₁ and A₂ per frequency (from the sine fits). When omitted, one σ_A for all
        frequencies is estimated from the residual of (22): σ_A² = Σ_i (ρ_i/g_i)²/(2n − 2), g_i = |β − ω² + jωC|.

    Raises
    ------
    DataError
        Lengths that differ, a frequency that is not positive, or no frequency at all.
    """
    f = _vector(frequencies, "frequencies", None)
    if f.size == 0:
        raise DataError("<arrays>", "frequencies", "none given (the global fit (22) needs at least one frequency)")
    for value in f:
        _check_frequency(value, "<arrays>")
    A1, A2 = _vector(a1, "a1", f.size), _vector(a2, "a2", f.size)
    Ar = _vector(reference_amplitude, "reference_amplitude", f.size)
    w = 2.0 * math.pi * f
    W = np.block([[np.column_stack([w * A2, A1])], [np.column_stack([-w * A1, A2 - Ar])]])
    y = np.concatenate([A1 * w**2, A2 * w**2])
    solution, *_ = np.linalg.lstsq(W, y, rcond=None)
    C, beta = float(solution[0]), float(solution[1])
    residual = y - W @ solution
    gain = np.tile(np.abs(beta - w**2 + 1j * w * C), 2)
    dof = W.shape[0] - 2
    if sigma_a is not None:
        row_sigma = np.tile(_vector(sigma_a, "sigma_a", f.size), 2) * gain
    elif dof > 0:
        # E[ρρᵀ] = σ_A²(I − P)G²(I − P) with P the hat matrix: divide by its G⁻²-weighted trace, not by 2n − 2
        # (the high-frequency rows, noisier, have less leverage, and plain 2n − 2 would overstate σ_A).
        M = np.eye(W.shape[0]) - W @ np.linalg.pinv(W)
        expected = float(np.trace((M * gain**2) @ M / gain[:, None] ** 2))
        row_sigma = math.sqrt(float(np.sum((residual / gain) ** 2)) / expected) * gain
    else:
        row_sigma = np.full(W.shape[0], math.nan)
    bread = np.linalg.inv(W.T @ W)
    covariance = bread @ (W.T * row_sigma**2) @ W @ bread
    covariance.setflags(write=False)
    return GlobalLinearFit(
        C=C,
        beta=beta,
        sigma_C=float(math.sqrt(covariance[0, 0])),
        sigma_beta=float(math.sqrt(covariance[1, 1])),
        covariance=covariance,
        frequencies=tuple(float(x) for x in f),
        residual_rms=float(np.sqrt(np.mean(residual**2))),
    )


def _vector(values: Any, name: str, size: int | None) -> np.ndarray:
    """``values`` as a float vector of ``size`` (a scalar is repeated), or a one-line error."""
    array = np.asarray(values, dtype=float)
    if array.ndim == 0 and size is not None:
        return np.full(size, float(array))
    array = array.reshape(-1)
    if size is not None and array.size != size:
        raise DataError("<arrays>", name, f"{array.size} value(s) for {size} frequencies (one per frequency)")
    return array


def fit_responses(responses: Sequence[SteadyStateResponse], *, only_valid: bool = False) -> GlobalLinearFit:
    """:func:`global_linear_fit` over responses; with ``only_valid`` over those Milne's rule keeps."""
    chosen = [r for r in responses if not only_valid or response_parameters(r).valid]
    if not chosen:
        raise DataError("<responses>", "frequencies", "Milne's rule excludes every frequency (A_r A₂ ≥ A₁² + A₂² at all)")
    # σ_A from the residual of (22), not from the sine fits: it then includes the linear model's lack of fit.
    return global_linear_fit([r.frequency for r in chosen], [r.a1 for r in chosen], [r.a2 for r in chosen],
                             [r.reference_amplitude for r in chosen])


def identify_joint(
    logs: Sequence[Measurements],
    frequencies: Sequence[float] | None = None,
    coordinate: str | None = None,
    *,
    transient: float | None = None,
    only_valid: bool = False,
) -> JointIdentification:
    """Sinusoidal steady-state identification of one joint from one log per frequency.

    Parameters
    ----------
    logs
        Measurements (:func:`symbolic.data.load` of data or experiment files), one per frequency, each
        with the joint's ``q_<c>`` and ``ref_<c>`` columns and a ``[controller]`` of kind ``pd`` (or
        ``pid`` with ki = 0) declaring kp and kd (``kd = [0.0]`` for a P loop; the loader requires both).
    frequencies
        The reference frequency of each log (Hz). When omitted, each log's ``[constants] frequency``.
    coordinate
        The joint; may be omitted when the logs measure one coordinate.
    transient
        Seconds discarded at the start of each log (default: half of each record).
    only_valid
        Fit (22) only over the frequencies Milne's rule keeps.

    Returns
    -------
    JointIdentification
        Per-frequency responses and C_data, β_data, and the global C_linear, β_linear. With kd ≠ 0 the
        loop's damping is C + β·kd/kp (derivative on the measurement); the returned C are corrected for it.

    Raises
    ------
    DataError
        One line naming the log and what is wrong: no logs, frequencies missing or of the wrong count,
        an unknown coordinate, no reference column, no or an unsuitable ``[controller]``, or the
        errors of :func:`fit_sine`.
    """
    if not logs:
        raise DataError("<logs>", "logs", "none given (one log per frequency)")
    freqs = _frequencies(logs, frequencies)
    responses, gains = [], []
    for log, frequency in zip(logs, freqs):
        j, name = _coordinate(log, coordinate)
        if log.ref is None:
            raise DataError(str(log.source), f"ref_{name}", "missing: the reference column is needed "
                                                            "(ref_<c> in the data, or [signals] ref_<c> in the experiment)")
        gains.append(_gains(log, name))
        responses.append(steady_state_response(log.t, log.q[:, j], log.ref[:, j], frequency, transient=transient,
                                               source=str(log.source)))
    kp, kd = gains[0]
    for (other_kp, other_kd), log in zip(gains, logs):
        if (other_kp, other_kd) != (kp, kd):
            raise DataError(str(log.source), "[controller]", f"kp = {other_kp:g}, kd = {other_kd:g} differ from "
                                                             f"kp = {kp:g}, kd = {kd:g} of the first log (one loop for all)")
    local = tuple(_without_kd(response_parameters(r), kp, kd) for r in responses)
    linear = fit_responses(responses, only_valid=only_valid)
    if kd:
        linear = _linear_without_kd(linear, kp, kd)
    return JointIdentification(_coordinate(logs[0], coordinate)[1], kp, kd, tuple(responses), local, linear)


def _without_kd(p: LocalParameters, kp: float, kd: float) -> LocalParameters:
    if not kd:
        return p
    return LocalParameters(p.frequency, p.C - p.beta * kd / kp, p.beta, p.denominator, p.valid)


def _linear_without_kd(fit: GlobalLinearFit, kp: float, kd: float) -> GlobalLinearFit:
    # C = C_loop − (kd/kp)·β: a linear map of (C_loop, β), applied to the covariance as well.
    J = np.array([[1.0, -kd / kp], [0.0, 1.0]])
    covariance = J @ fit.covariance @ J.T
    covariance.setflags(write=False)
    return GlobalLinearFit(fit.C - fit.beta * kd / kp, fit.beta, float(math.sqrt(covariance[0, 0])),
                           fit.sigma_beta, covariance, fit.frequencies, fit.residual_rms)


def _frequencies(logs: Sequence[Measurements], frequencies: Sequence[float] | None) -> list[float]:
    if frequencies is None:
        found = []
        for log in logs:
            value = log.constants.get("frequency")
            if value is None:
                raise DataError(str(log.source), "frequency", "not given: pass frequencies=[...] (Hz, one per log) "
                                                              "or declare [constants] frequency = ... in the experiment")
            found.append(float(value))
        frequencies = found
    frequencies = list(frequencies)
    if len(frequencies) != len(logs):
        raise DataError("<logs>", "frequencies", f"{len(frequencies)} given for {len(logs)} log(s) (one per log)")
    for log, value in zip(logs, frequencies):
        _check_frequency(value, str(log.source))
    return [float(v) for v in frequencies]


def _coordinate(log: Measurements, coordinate: str | None) -> tuple[int, str]:
    if coordinate is None:
        if len(log.coordinates) != 1:
            raise DataError(str(log.source), "coordinate", f"not given and the log measures {len(log.coordinates)} "
                                                           f"({', '.join(log.coordinates)}): name the joint")
        return 0, log.coordinates[0]
    if coordinate not in log.coordinates:
        raise DataError(str(log.source), "coordinate", f"{coordinate!r} is not measured (measured: "
                                                       f"{', '.join(log.coordinates)})")
    return log.coordinates.index(coordinate), coordinate


def _gains(log: Measurements, coordinate: str) -> tuple[float, float]:
    """(kp, kd) of ``coordinate`` from the log's ``[controller]`` (checked when the experiment was loaded)."""
    source = str(log.source)
    ctrl = log.controller if isinstance(log, Experiment) else None
    if ctrl is None:
        raise DataError(source, "[controller]", "missing: declare kind = \"pd\" with kp (and kd) for the joint — the "
                                                "proportional gain relates β to β̃ (Milne (13))")
    if ctrl.kind not in ("pd", "pid"):
        raise DataError(source, "[controller] kind", f"{ctrl.kind!r}: the sine identification needs a proportional "
                                                     "loop (allowed: 'pd', or 'pid' with ki = 0)")
    if coordinate not in ctrl.coordinates:
        raise DataError(source, "[controller] coordinates", f"the controller does not drive {coordinate!r}")
    k = ctrl.coordinates.index(coordinate)
    kp, kd, ki = float(ctrl.kp[k]), float(ctrl.kd[k]), float(ctrl.ki[k])
    if kp <= 0:
        raise DataError(source, f"[controller] kp[{k}]", "must be > 0 (the loop is closed by the proportional gain)")
    if ki:
        raise DataError(source, f"[controller] ki[{k}]", f"{ki:g}: an integral term changes Milne (13); "
                                                         "identify with ki = 0")
    return kp, kd


def _check_frequency(frequency: Any, source: str) -> None:
    if frequency is None:
        raise DataError(source, "frequency", "not given (the known excitation frequency in Hz)")
    if isinstance(frequency, bool) or not isinstance(frequency, (int, float, np.floating, np.integer)) \
            or not math.isfinite(frequency) or frequency <= 0:
        raise DataError(source, "frequency", f"expected a positive number of Hz, got {frequency!r}")


def _check_time(t: np.ndarray, source: str) -> None:
    if t.size < 3:
        raise DataError(source, "t", f"{t.size} samples (at least 3 are needed)")
    if not np.all(np.isfinite(t)):
        raise DataError(source, "t", "holds NaN or infinity (allowed: finite numbers)")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise DataError(source, "t", f"time is not increasing at sample {k} (time stamps must increase strictly)")
    mean = float(np.mean(steps))
    deviation = np.abs(steps - mean) / mean
    worst = int(np.argmax(deviation))
    if deviation[worst] > UNIFORM_TOLERANCE:
        raise DataError(source, "t", f"time step varies from {steps.min():.4g} s to {steps.max():.4g} s (largest "
                                     f"deviation at sample {worst + 1}); steps must be uniform to "
                                     f"{UNIFORM_TOLERANCE:.1%} (resample first: symbolic.data.load(..., resample=True))")


def _steady_window(t: np.ndarray, frequency: float, transient: float | None, source: str) -> tuple[slice, int]:
    """The samples of the last whole periods after ``transient`` seconds, and their number of periods."""
    span = float(t[-1] - t[0])
    if transient is None:
        transient = 0.5 * span
    elif not isinstance(transient, (int, float)) or not math.isfinite(transient) or transient < 0:
        raise DataError(source, "transient", f"expected seconds ≥ 0, got {transient!r}")
    step = span / (t.size - 1)
    period = 1.0 / frequency
    available = span + step - transient  # each sample stands for one step of time
    periods = int(math.floor(available / period + 1e-9))
    if periods < MINIMUM_PERIODS:
        raise DataError(source, "t", f"{available:.4g} s after the {transient:.4g} s transient hold {available / period:.3g} "
                                     f"period(s) of {frequency:g} Hz; at least {MINIMUM_PERIODS} whole periods are needed "
                                     "(record longer or shorten the transient)")
    count = int(round(periods * period / step))
    count = min(count, t.size)
    return slice(t.size - count, t.size), periods

"""Identification of Milne et al.'s α-invariant damping and torque-constant model (Milne 2.3.3–2.3.5).

Input: the sinusoidal steady states of one joint under a P controller (:mod:`symbolic.reproduction.milne.sine`),
each frequency giving α_data (36), C_data (19) and β̃_data = β_data/k_p ((20), (26)); frequencies Milne's
rule excludes are dropped (:func:`alpha_data`, :func:`joint_alpha_data`). Output, at one inertia: the
torque constant (41) as the least-squares line through (α_data, β̃_data), given at the predefined ᾱ₀, ᾱ₁
(:func:`fit_torque_constant`); the tri-linear damping (38)–(39), linear least squares in C₀…C₃ for the
break points of a grid search (:func:`fit_damping`, shared by several configurations when given
several); both as one :class:`~symbolic.reproduction.milne.alpha_damping.AlphaCoefficients`
(:func:`fit_alpha_model`). Across inertias I_j: the inverted asymptotes (40), (42), 1/C_k(I_j) = C_k1·I_j,
by least squares through the origin (:func:`fit_inertia_dependence`). The method and how it reads the
paper: docs/seeds.md, "Milne: the α-invariant model".
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from symbolic.data import DataError
from symbolic.reproduction.milne.sine import JointIdentification, SteadyStateResponse, response_parameters
from symbolic.reproduction.milne.alpha_damping import AlphaCoefficients, AlphaInertiaModel
from symbolic.reproduction.milne.alpha_invariant import sine_alpha
from symbolic.reproduction.milne import SOURCE



@dataclass(frozen=True)
class AlphaData:
    """The per-frequency points of one configuration (Milne 3.3's "measured data").

    Attributes
    ----------
    frequency
        Hz, the frequencies kept by Milne's exclusion rule.
    alpha
        α_data (36).
    damping
        C_data (19) (1/s).
    torque_constant
        β̃_data = β_data/k_p (20) (rad/s² per command unit).
    excluded
        Frequencies dropped by the rule (Hz).
    """

    frequency: tuple[float, ...]
    alpha: tuple[float, ...]
    damping: tuple[float, ...]
    torque_constant: tuple[float, ...]
    excluded: tuple[float, ...]


@dataclass(frozen=True)
class DampingFit:
    """The tri-linear damping chosen by the grid search (Milne (38)–(39)).

    Attributes
    ----------
    breakpoints
        α₀ < α₁ < α₂ < α₃.
    values
        C₀…C₃ per configuration (one tuple per data set).
    sum_of_squares
        The least sum of squared residuals of C_data over all data sets.
    tried
        How many break-point quadruples were identifiable and compared.
    """

    breakpoints: tuple[float, ...]
    values: tuple[tuple[float, ...], ...]
    sum_of_squares: float
    tried: int


def alpha_data(responses: Sequence[SteadyStateResponse], kp: float) -> AlphaData:
    """α_data (36), C_data (19) and β̃_data (20) per frequency, Milne's exclusion rule applied.

    Parameters
    ----------
    responses
        Steady-state responses of one configuration (:func:`symbolic.reproduction.milne.sine.steady_state_response`).
    kp
        The P gain k_p.
    """
    _check_positive(kp, "kp")
    kept: list[tuple[float, float, float, float]] = []
    excluded: list[float] = []
    for response in responses:
        local = response_parameters(response)
        if not local.valid:
            excluded.append(response.frequency)
            continue
        alpha = float(sine_alpha(kp, response.omega, response.a1, response.a2, response.reference_amplitude))
        kept.append((response.frequency, alpha, local.C, local.beta / kp))
    if not kept:
        raise DataError(SOURCE, "responses", "no frequency passes Milne's rule (C_data, β_data positive)")
    f, a, c, b = (tuple(x) for x in zip(*kept))
    return AlphaData(f, a, c, b, tuple(excluded))


def joint_alpha_data(joint: JointIdentification) -> AlphaData:
    """:func:`alpha_data` of a joint identified from logs (:func:`symbolic.reproduction.milne.sine.identify_joint`).

    Raises
    ------
    DataError
        When the logs' controller has a derivative gain: the α-invariant model (43) and (36) assume the
        pure P law v = k_p(r − θ) of Milne (13) (k_i = k_d = 0).
    """
    if joint.kd != 0:
        raise DataError("<logs>", "[controller] kd", f"is {joint.kd:g}: the α-invariant model (Milne (13), (36), "
                        "(43)) needs a P controller (kd = 0)")
    return alpha_data(joint.responses, joint.kp)


def fit_torque_constant(alpha: ArrayLike, torque_constant: ArrayLike,
                        breakpoints: tuple[float, float]) -> tuple[float, float]:
    """β̃₀ and β̃₁ at the predefined ᾱ₀, ᾱ₁ by linear least squares (Milne (41), 2.3.5 "fitting a line").

    The fitted model is the one simulated: linear between ᾱ₀ and ᾱ₁ and held at β̃₀, β̃₁ outside (see
    :mod:`symbolic.reproduction.milne.alpha_damping`), i.e. the least-squares line through the data when all α_data
    lie in [ᾱ₀, ᾱ₁].

    Parameters
    ----------
    alpha, torque_constant
        α_data and β̃_data.
    breakpoints
        (ᾱ₀, ᾱ₁), ᾱ₀ < ᾱ₁ (Milne Table 6: 0 and 250).
    """
    a, b = _pair(alpha, torque_constant, "torque constant")
    bp = _increasing(breakpoints, 2, "torque breakpoints")
    basis = np.column_stack([np.interp(a, bp, (1.0, 0.0)), np.interp(a, bp, (0.0, 1.0))])
    solution, _, rank, _ = np.linalg.lstsq(basis, b, rcond=None)
    if rank < 2:
        raise DataError(SOURCE, "alpha", f"α_data do not determine both β̃₀ and β̃₁ (they need two distinct α, "
                        f"not both on the same side of the break points {bp})")
    return float(solution[0]), float(solution[1])


def fit_damping(alpha: Sequence[ArrayLike], damping: Sequence[ArrayLike], grid: ArrayLike) -> DampingFit:
    """The tri-linear damping of Milne (38)–(39) with break points from a grid search, shared by data sets.

    For every increasing quadruple α₀ < α₁ < α₂ < α₃ of ``grid`` (C held constant outside, see
    :mod:`symbolic.reproduction.milne.alpha_damping`), C₀…C₃ of each data set are found by linear least squares on
    the hat-function basis; quadruples for which some set's basis is rank-deficient (a C_k no data point
    determines) are skipped. The quadruple with the least total sum of squares wins; ties go to the first
    in lexicographic order.

    Parameters
    ----------
    alpha, damping
        One array of α_data and one of C_data per configuration (a single configuration: ``[a]``, ``[c]``).
    grid
        Candidate break points (V²/s²), at least four distinct values.
    """
    if len(alpha) != len(damping) or len(alpha) == 0:
        raise DataError(SOURCE, "alpha, damping", f"need one α array per C array, got {len(alpha)} and {len(damping)}")
    sets = [_pair(a, c, "damping") for a, c in zip(alpha, damping)]
    candidates = np.unique(np.asarray(grid, dtype=float))
    if candidates.ndim != 1 or candidates.size < 4 or not np.all(np.isfinite(candidates)):
        raise DataError(SOURCE, "grid", "must hold at least four distinct finite candidate break points")
    best: tuple[float, tuple[float, ...], tuple[tuple[float, ...], ...]] | None = None
    tried = 0
    eye = np.eye(4)
    for quad in itertools.combinations(candidates, 4):
        total, values = 0.0, []
        for a, c in sets:
            basis = np.column_stack([np.interp(a, quad, eye[k]) for k in range(4)])
            solution, _, rank, _ = np.linalg.lstsq(basis, c, rcond=None)
            if rank < 4:
                break
            total += float(np.sum((basis @ solution - c) ** 2))
            values.append(tuple(float(x) for x in solution))
        else:
            tried += 1
            if best is None or total < best[0] * (1 - 1e-12) - 1e-300:
                best = (total, tuple(float(x) for x in quad), tuple(values))
    if best is None:
        raise DataError(SOURCE, "grid", "no quadruple of break points has data determining all of C₀…C₃ "
                        "(spread the frequencies or amplitudes so α_data falls in every segment)")
    return DampingFit(best[1], best[2], best[0], tried)


def fit_alpha_model(data: AlphaData, grid: ArrayLike, torque_breakpoints: tuple[float, float]) -> AlphaCoefficients:
    """C(α) and β̃(α) of one configuration: :func:`fit_damping` and :func:`fit_torque_constant`."""
    damping = fit_damping([data.alpha], [data.damping], grid)
    torque = fit_torque_constant(data.alpha, data.torque_constant, torque_breakpoints)
    return AlphaCoefficients(damping.breakpoints, damping.values[0], tuple(torque_breakpoints), torque)


def fit_inertia_dependence(inertias: ArrayLike, coefficients: Sequence[AlphaCoefficients]) -> AlphaInertiaModel:
    """C_k1 and β̃_k1 of Milne (40), (42) by ordinary least squares on the inverted models.

    1/C_k(I_j) = C_k1 I_j and 1/β̃_k(I_j) = β̃_k1 I_j are lines through the origin in I, so
    C_k1 = Σ_j I_j/C_k(I_j) / Σ_j I_j² (Milne 2.3.5).

    Parameters
    ----------
    inertias
        I_j of each configuration (kg m²), e.g. the model's D[j, j] or Milne's inertia model (6).
    coefficients
        The coefficients fitted at each configuration, all with the same break points.
    """
    inertia = np.asarray(inertias, dtype=float)
    if inertia.ndim != 1 or inertia.size != len(coefficients) or inertia.size == 0:
        raise DataError(SOURCE, "inertias", f"need one inertia per coefficient set, got {inertia.size} "
                        f"and {len(coefficients)}")
    if not (np.all(np.isfinite(inertia)) and np.all(inertia > 0)):
        raise DataError(SOURCE, "inertias", "must be positive and finite")
    first = coefficients[0]
    for other in coefficients[1:]:
        if (other.damping_breakpoints != first.damping_breakpoints
                or other.torque_breakpoints != first.torque_breakpoints):
            raise DataError(SOURCE, "coefficients", "the configurations must share their break points "
                            "(fit them together with fit_damping)")
    if any(v <= 0 for c in coefficients for v in c.damping_values):
        raise DataError(SOURCE, "coefficients", "a damping value is not positive: (40) cannot be inverted")

    def through_origin(values: np.ndarray) -> tuple[float, ...]:
        inverse = 1.0 / values                               # shape (configurations, k)
        return tuple(float(x) for x in (inertia @ inverse) / float(inertia @ inertia))

    damping = np.array([c.damping_values for c in coefficients])
    torque = np.array([c.torque_values for c in coefficients])
    return AlphaInertiaModel(first.damping_breakpoints, through_origin(damping),
                             first.torque_breakpoints, through_origin(torque))


def _pair(alpha: ArrayLike, values: ArrayLike, what: str) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(alpha, dtype=float).reshape(-1)
    v = np.asarray(values, dtype=float).reshape(-1)
    if a.shape != v.shape or a.size < 2:
        raise DataError(SOURCE, f"{what} data", f"need as many α as values and at least 2, got {a.size} and {v.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(v))):
        raise DataError(SOURCE, f"{what} data", "holds NaN or infinity")
    return a, v


def _increasing(values: Sequence[float], count: int, what: str) -> tuple[float, ...]:
    try:
        out = tuple(float(x) for x in values)
    except (TypeError, ValueError):
        raise DataError(SOURCE, what, f"must be {count} numbers, got {values!r}") from None
    if len(out) != count or not all(math.isfinite(x) for x in out) or any(b <= a for a, b in zip(out, out[1:])):
        raise DataError(SOURCE, what, f"must be {count} finite, strictly increasing numbers, got {values!r}")
    return out


def _check_positive(value: object, name: str) -> None:
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0):
        raise DataError(SOURCE, name, f"must be a positive finite number, got {value!r}")

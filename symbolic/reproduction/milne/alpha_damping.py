"""Milne et al.'s α-dependent damping C(α, I) and torque constant β̃(α, I) (Milne (38)–(42)).

:class:`AlphaCoefficients` holds, at one inertia, the tri-linear damping through (α_k, C_k), k = 0…3
(Milne (38)–(39)), and the linear torque constant through (ᾱ₀, β̃₀), (ᾱ₁, β̃₁) (Milne (41)) as
piecewise-linear interpolations through (break point, value) pairs (one break point: a constant, so the
global linear model (21) is the special case), each held at its end values outside its break points.
:class:`AlphaInertiaModel` holds the asymptotic curves C_k(I) = 1/(C_k1 I), β̃_k(I) = 1/(β̃_k1 I) (Milne
(40), (42)); :meth:`AlphaInertiaModel.at` gives the coefficients at one inertia, and
:func:`joint_inertia` that inertia from a derived model. Why the end values are held (read literally,
(38) makes C = 0 and (41) β̃ negative at high α): docs/seeds.md, "Milne: the α-invariant model".
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from symbolic.data import DataError
from symbolic.derivation.dynamics import DynamicModel
from symbolic.numeric.statespace import numeric_model
from symbolic.reproduction.milne import SOURCE



@dataclass(frozen=True)
class AlphaCoefficients:
    """C(α) and β̃(α) at one inertia, piecewise linear in α, held constant outside the break points.

    Attributes
    ----------
    damping_breakpoints
        α₀ < α₁ < … (Milne (38)–(39); four for the tri-linear model), in V²/s² (the command unit squared
        per second squared).
    damping_values
        C₀, C₁, … at those α (1/s).
    torque_breakpoints
        ᾱ₀ < ᾱ₁ (Milne (41)).
    torque_values
        β̃₀, β̃₁ at those α (rad/s² per command unit).
    """

    damping_breakpoints: tuple[float, ...]
    damping_values: tuple[float, ...]
    torque_breakpoints: tuple[float, ...]
    torque_values: tuple[float, ...]

    def __post_init__(self) -> None:
        _check_curve(self.damping_breakpoints, self.damping_values, "damping", allow_zero=True)
        _check_curve(self.torque_breakpoints, self.torque_values, "torque constant", allow_zero=False)
        for name in ("damping_breakpoints", "damping_values", "torque_breakpoints", "torque_values"):
            object.__setattr__(self, name, tuple(float(x) for x in getattr(self, name)))

    @classmethod
    def linear(cls, damping: float, torque_constant: float) -> AlphaCoefficients:
        """The global linear model (Milne (21), (26)): C and β̃ independent of α."""
        return cls((0.0,), (damping,), (0.0,), (torque_constant,))

    def damping(self, alpha: ArrayLike) -> np.ndarray:
        """C(α) (Milne (38)), held at C₀ below α₀ and at the last value above the last break point."""
        return np.interp(np.asarray(alpha, dtype=float), self.damping_breakpoints, self.damping_values)

    def torque_constant(self, alpha: ArrayLike) -> np.ndarray:
        """β̃(α) (Milne (41)), held at β̃₀ below ᾱ₀ and at β̃₁ above ᾱ₁."""
        return np.interp(np.asarray(alpha, dtype=float), self.torque_breakpoints, self.torque_values)

    @cached_property
    def knots(self) -> np.ndarray:
        """All break points of C and β̃, sorted and unique: between them both are linear in α."""
        return np.unique(np.array(self.damping_breakpoints + self.torque_breakpoints))

    @cached_property
    def damping_at_knots(self) -> np.ndarray:
        """C at :attr:`knots`."""
        return self.damping(self.knots)

    @cached_property
    def torque_at_knots(self) -> np.ndarray:
        """β̃ at :attr:`knots`."""
        return self.torque_constant(self.knots)


@dataclass(frozen=True)
class AlphaInertiaModel:
    """C(α, I) and β̃(α, I) for any inertia through Milne (40) and (42).

    Attributes
    ----------
    damping_breakpoints
        α₀ < … < α₃, the same at every inertia (Milne Table 7's "α value").
    damping_inverse
        C₀₁, …, C₃₁ with C_k(I) = 1/(C_k1 I) (Milne (40); Table 7's "Value"), in s/(kg m²).
    torque_breakpoints
        ᾱ₀ < ᾱ₁ (Milne Table 6's "α value").
    torque_inverse
        β̃₀₁, β̃₁₁ with β̃_k(I) = 1/(β̃_k1 I) (Milne (42); Table 6's "Value"), in V s²/(kg m²) per rad.
    """

    damping_breakpoints: tuple[float, ...]
    damping_inverse: tuple[float, ...]
    torque_breakpoints: tuple[float, ...]
    torque_inverse: tuple[float, ...]

    def __post_init__(self) -> None:
        _check_curve(self.damping_breakpoints, self.damping_inverse, "damping inverse", allow_zero=False)
        _check_curve(self.torque_breakpoints, self.torque_inverse, "torque inverse", allow_zero=False)
        for name in ("damping_breakpoints", "damping_inverse", "torque_breakpoints", "torque_inverse"):
            object.__setattr__(self, name, tuple(float(x) for x in getattr(self, name)))

    def at(self, inertia: float) -> AlphaCoefficients:
        """The coefficients at inertia I: C_k = 1/(C_k1 I) (Milne (40)), β̃_k = 1/(β̃_k1 I) (Milne (42))."""
        if not (isinstance(inertia, (int, float)) and math.isfinite(inertia) and inertia > 0):
            raise DataError(SOURCE, "inertia", f"must be a positive finite number, got {inertia!r}")
        return AlphaCoefficients(
            self.damping_breakpoints,
            tuple(1.0 / (c * inertia) for c in self.damping_inverse),
            self.torque_breakpoints,
            tuple(1.0 / (b * inertia) for b in self.torque_inverse),
        )


def joint_inertia(model: DynamicModel, coordinate: str, q: Mapping[str, float] | Sequence[float],
                  parameters: Mapping[str, float] | None = None) -> float:
    """The inertia I of one joint at a configuration: the diagonal entry D[j, j] of the model's D(Q).

    Milne's I of (2)–(8) is the yaw-axis inertia with the other joints held still, which is D[j, j] of
    any model (for the built-in ``omni``, their (5)); (40) and (42) then give C(α, I) and β̃(α, I).

    Parameters
    ----------
    model
        A derived model (:func:`symbolic.derive`).
    coordinate
        The joint's coordinate name.
    q
        The configuration: values in the model's coordinate order, or a mapping name → value (missing
        coordinates are 0).
    parameters
        Values overriding the model's nominal parameters, by name.
    """
    names = tuple(model.robot.generalized_coordinates)
    if coordinate not in names:
        raise DataError(SOURCE, "coordinate", f"{coordinate!r} is not a coordinate of {model.robot.name} "
                        f"(allowed: {', '.join(names)})")
    if isinstance(q, Mapping):
        unknown = sorted(set(q) - set(names))
        if unknown:
            raise DataError(SOURCE, "q", f"{', '.join(map(repr, unknown))} not coordinates of {model.robot.name} "
                            f"(allowed: {', '.join(names)})")
        values = np.array([float(q.get(name, 0.0)) for name in names])
    else:
        values = np.asarray(q, dtype=float).reshape(-1)
        if values.size != len(names):
            raise DataError(SOURCE, "q", f"has {values.size} values, {model.robot.name} has {len(names)} coordinates")
    num = numeric_model(model)
    p = num.p0.copy()
    symbols = [str(sym) for sym in model.parameter_symbols]
    for name, value in (parameters or {}).items():
        if name not in symbols:
            raise DataError(SOURCE, "parameters", f"{name!r} is not a parameter of {model.robot.name}")
        p[symbols.index(name)] = float(value)
    j = names.index(coordinate)
    return float(num.inertia(values, p)[j, j])


def _check_curve(breakpoints: Sequence[float], values: Sequence[float], what: str, *, allow_zero: bool) -> None:
    """One-line errors for break points that are not strictly increasing or values that are not physical."""
    try:
        bp = np.asarray(breakpoints, dtype=float)
        vals = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise DataError(SOURCE, f"{what} break points and values", "must be sequences of numbers") from None
    if bp.ndim != 1 or bp.size == 0 or vals.shape != bp.shape:
        raise DataError(SOURCE, f"{what} break points and values",
                        f"must be two non-empty 1-D sequences of the same length, got {bp.shape} and {vals.shape}")
    if not (np.all(np.isfinite(bp)) and np.all(np.isfinite(vals))):
        raise DataError(SOURCE, f"{what} break points and values", "must be finite")
    if np.any(np.diff(bp) <= 0):
        raise DataError(SOURCE, f"{what} break points", f"must be strictly increasing, got {bp.tolist()}")
    low = vals < 0 if allow_zero else vals <= 0
    if np.any(low):
        allowed = "non-negative" if allow_zero else "positive"
        raise DataError(SOURCE, f"{what} values", f"must be {allowed}, got {vals.tolist()}")

"""Ordinary and weighted least squares of IDIM-LS, with the statistics Gautier reports (Janot et al. 2007
(3)–(7); the formulas at :func:`solve`, the procedure around them in docs/data.md, "IDIM-LS").

A parameter is flagged as poorly determined when its relative σ exceeds :data:`RELATIVE_SIGMA_THRESHOLD`
percent (Janot et al. read 10–22 % on viscous friction (Table 3) as "no significant viscous friction").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symbolic.errors import IdentificationError
from symbolic.identify.processing import Observation, Processing

RELATIVE_SIGMA_THRESHOLD = 10.0
"""Percent: a parameter whose relative standard deviation exceeds it is flagged."""


def defined(relative: float) -> float | None:
    """A relative σ for JSON: ``None`` where it is undefined (an estimate of exactly 0: 100·σ/0)."""
    return float(relative) if math.isfinite(relative) else None


def percent(relative: float) -> str:
    """A relative σ for a table: 3 significant digits, or ``—`` where it is undefined (an estimate of 0)."""
    return f"{relative:.3g}" if math.isfinite(relative) else "—"


@dataclass(frozen=True)
class ParameterEstimate:
    """One identified parameter: value, standard deviation, relative standard deviation in %, flag."""

    name: str
    value: float
    sigma: float
    relative_sigma: float
    poorly_determined: bool
    fixed: bool = False
    bound: str | None = None  # "min" or "max" when the estimate is held at that bound
    unconstrained: float | None = None  # at a bound: what the data alone give

    def to_dict(self) -> dict[str, Any]:
        """``{"value", "sigma", "relative_sigma", "poorly_determined"}`` (relative σ in %), with ``"fixed":
        true`` for a value kept as given and ``"at_bound"`` (``"min"``/``"max"``) and ``"unconstrained"``
        for an estimate held at a bound."""
        out = {
            "value": self.value,
            "sigma": self.sigma,
            "relative_sigma": defined(self.relative_sigma),
            "poorly_determined": self.poorly_determined,
        }
        if self.fixed:
            out["fixed"] = True
        if self.bound is not None:
            out["at_bound"], out["unconstrained"] = self.bound, self.unconstrained
        return out

    def flag(self) -> str:
        """What the plain-text table says after the numbers."""
        if self.fixed:
            return "  (fixed)"
        if self.bound is not None:
            return f"  (at its {self.bound}; the data alone give {self.unconstrained:.6g})"
        return "  (poorly determined)" if self.poorly_determined else ""


@dataclass(frozen=True, eq=False)
class Identification:
    """Result of IDIM-LS.

    Attributes
    ----------
    names
        Parameter names, in the order of the regressor's columns.
    values, sigmas
        β̂ and the standard deviations σ (arrays, read-only).
    covariance
        ``σ_ρ² (WᵀW)⁻¹`` of the system solved.
    method
        ``"ols"`` or ``"wls"``.
    condition_number
        cond(W) of the system solved (weighted for WLS).
    relative_error
        ``100·‖y − W·β̂‖/‖y‖`` (%), unweighted.
    residual_sigma
        σ_ρ of the system solved (for WLS, of the weighted one: about 1).
    coordinate_sigmas
        Per coordinate, σ_j of the first OLS pass (the WLS weights are their inverses).
    coordinates
        Coordinate names.
    rows
        r, rows of the stacked system.
    processing
        The data treatment applied.
    threshold
        The flagging threshold on relative σ (%).
    fixed
        Names of the columns kept at given values (moved to the side of τ; σ = 0).
    at_bound
        {name: ``"min"`` or ``"max"``} for estimates held at a bound by the bounded least squares.
    unconstrained
        {name: the unbounded estimate} for those held at a bound.
    """

    names: tuple[str, ...]
    values: np.ndarray
    sigmas: np.ndarray
    covariance: np.ndarray
    method: str
    condition_number: float
    relative_error: float
    residual_sigma: float
    coordinate_sigmas: tuple[float, ...]
    coordinates: tuple[str, ...]
    rows: int
    processing: Processing
    threshold: float = RELATIVE_SIGMA_THRESHOLD
    fixed: tuple[str, ...] = ()
    at_bound: dict[str, str] = field(default_factory=dict)
    unconstrained: dict[str, float] = field(default_factory=dict)

    @property
    def relative_sigmas(self) -> np.ndarray:
        """100·σ/|β̂| in percent (infinite for a zero estimate; 0 for a fixed value)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            relative = np.where(self.values != 0, 100.0 * self.sigmas / np.abs(self.values), np.inf)
        return np.where(self.sigmas == 0, 0.0, relative)

    @property
    def parameters(self) -> tuple[ParameterEstimate, ...]:
        """One :class:`ParameterEstimate` per parameter."""
        return tuple(
            ParameterEstimate(n, float(v), float(s), float(r), bool(r > self.threshold) and n not in self.fixed,
                              n in self.fixed, self.at_bound.get(n), self.unconstrained.get(n))
            for n, v, s, r in zip(self.names, self.values, self.sigmas, self.relative_sigmas)
        )

    @property
    def flagged(self) -> tuple[str, ...]:
        """Names of the parameters whose relative σ exceeds the threshold."""
        return tuple(p.name for p in self.parameters if p.poorly_determined)

    def __getitem__(self, name: str) -> ParameterEstimate:
        return self.parameters[self.names.index(name)]

    def predict(self, observation: Observation) -> np.ndarray:
        """``W·β̂`` arranged like ``observation.tau`` (samples × N)."""
        return observation.regressor @ self.values

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON: parameters by name, statistics, the treatment (relative values in %)."""
        return {
            "method": self.method,
            "parameters": {p.name: p.to_dict() for p in self.parameters},
            "condition_number": self.condition_number,
            "relative_error": self.relative_error,
            "residual_sigma": self.residual_sigma,
            "coordinate_sigmas": dict(zip(self.coordinates, self.coordinate_sigmas)),
            "rows": self.rows,
            "relative_sigma_threshold": self.threshold,
            "flagged": list(self.flagged),
            "fixed": list(self.fixed),
            "at_bound": dict(self.at_bound),
            "processing": self.processing.to_dict(),
        }

    def table(self) -> str:
        """A plain-text table of the estimates and statistics."""
        width = max(9, *(len(n) for n in self.names))
        lines = [f"{'parameter':<{width}}  {'value':>14}  {'sigma':>12}  {'sigma %':>8}"]
        for p in self.parameters:
            lines.append(f"{p.name:<{width}}  {p.value:>14.6g}  {p.sigma:>12.4g}  {percent(p.relative_sigma):>8s}{p.flag()}")
        lines.append(
            f"{self.method.upper()}: {self.rows} rows, cond(W) = {self.condition_number:.4g}, relative error "
            f"{self.relative_error:.4g} %"
        )
        return "\n".join(lines)




@dataclass(frozen=True, eq=False)
class Validation:
    """An identified model on another data set (cross-test).

    Attributes
    ----------
    relative_error
        ``100·‖y − W·β̂‖/‖y‖`` (%) over all coordinates.
    coordinate_errors
        The same per coordinate.
    observation
        The other data set, treated like the estimation set.
    predicted
        ``W·β̂``, samples × N.
    """

    relative_error: float
    coordinate_errors: dict[str, float]
    observation: Observation = field(repr=False)
    predicted: np.ndarray = field(repr=False)


def solve(
    observation: Observation,
    names: tuple[str, ...] | list[str],
    method: str = "wls",
    threshold: float = RELATIVE_SIGMA_THRESHOLD,
    *,
    fixed: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
) -> Identification:
    """Least-squares estimate of the parameters of ``observation``.

    For the stacked system ``y = W·β + ρ`` (``r`` rows, ``b`` parameters; Janot et al. 2007 (3)–(7)):

    * ``β̂`` minimises ``‖y − W·β‖`` (through the QR of [W y] and the SVD of its small R, :func:`_ols`;
      never through WᵀW);
    * ``σ_ρ² = ‖y − W·β̂‖² / (r − b)`` — Janot's (5) as printed lacks the square; the unbiased estimate
      of a variance needs it;
    * covariance ``C = σ_ρ² (WᵀW)⁻¹``, ``σ_i = √C_ii``, relative ``%σ_i = 100·σ_i/|β̂_i|`` (the
      absolute value, as in the EMPS script; (7) as printed has none);
    * ``cond(W)``, the 2-norm condition number ``s_max/s_min`` of the matrix solved;
    * relative error ``100·‖y − W·β̂‖/‖y‖`` in %, always of the unweighted system.

    Weighted LS (Gautier, ``method="wls"``): a first OLS gives per coordinate j
    ``σ_j² = ‖y_j − W_j·β̂‖²/(r_j − b_j)`` with ``b_j`` the rank of ``W_j``; rows of coordinate j are divided by
    ``σ_j`` and the formulas above are applied to the weighted system. With one coordinate WLS is OLS.

    (6) assumes white residuals. After parallel decimation white force noise is not white any more: the
    anti-aliasing filter passes 0.8 of the new Nyquist band, so σ_ρ² underestimates the low-frequency
    noise density that the estimates feel by κ = n·mean(|H|⁴)/|H(0)|⁴ ≈ 0.85, and σ is about 8 % too
    small (tests/test_identify.py measures it). The publication's σ carry the same bias; it is not
    corrected here (real residuals are dominated by model error, whose spectrum is unknown anyway).

    ``fixed``: {name: value} of columns kept at known values: their terms move to the side of τ,
    y − W_k·β_k = W_u·β_u, and only the others are estimated (σ = 0 for the fixed ones).
    ``bounds``: {name: (lower, upper)}; where the weighted solution leaves them, the bounded least
    squares of :func:`_bounded` replaces it.
    """
    if method not in ("ols", "wls"):
        raise ValueError(f"method must be 'ols' or 'wls', got {method!r}")
    names = tuple(names)
    y_all, W_all = observation.y, observation.W  # noqa: N806
    if not np.any(y_all):
        raise IdentificationError("the forces are zero at every sample: every parameter fits them, there is nothing to "
                                  "identify (a log without its force signal? check the tau_<c> or u_<c> mapping)")
    rows, b = W_all.shape
    if len(names) != b:
        raise ValueError(f"{len(names)} parameter names for {b} regressor columns")
    fixed = dict(fixed or {})
    if set(fixed) - set(names):
        raise ValueError(f"fixed names {sorted(set(fixed) - set(names))} are not parameters")
    held = np.array([n in fixed for n in names], bool)
    known = np.array([fixed.get(n, 0.0) for n in names], float)
    free = tuple(n for n in names if n not in fixed)
    if not free:
        raise IdentificationError("every parameter is fixed: there is nothing to identify")
    y, W = y_all - W_all[:, held] @ known[held], W_all[:, ~held]  # noqa: N806
    lower = np.array([(bounds or {}).get(n, (-np.inf, np.inf))[0] for n in free], float)
    upper = np.array([(bounds or {}).get(n, (-np.inf, np.inf))[1] for n in free], float)
    beta, _, _, sigma = _ols(y, W, free)
    n, per = len(observation.coordinates), observation.samples
    coordinate_sigmas = []
    for j in range(n):
        rows_j = slice(j * per, (j + 1) * per)
        dof = per - _rank(W[rows_j])
        e = y[rows_j] - W[rows_j] @ beta
        coordinate_sigmas.append(norm(e) / np.sqrt(dof) if dof > 0 else float("nan"))
    weights = np.ones(rows)
    usable = all(np.isfinite(s) and s > 0 for s in coordinate_sigmas)
    if method == "wls" and n > 1 and usable:
        weights = np.repeat(1.0 / np.array(coordinate_sigmas), per)
    fit = _bounded(y * weights, W * weights[:, None], free, lower, upper)
    values, covariance = known.copy(), np.zeros((b, b))
    values[~held] = fit.beta
    covariance[np.ix_(~held, ~held)] = fit.covariance
    residual = y_all - W_all @ values
    _check_finite(names, values, covariance, fit)
    return Identification(
        names=names,
        values=_readonly(values),
        sigmas=_readonly(np.sqrt(np.diag(covariance))),
        covariance=_readonly(covariance),
        method=method,
        condition_number=float(fit.condition_number),
        relative_error=float(100.0 * norm(residual) / norm(y_all)),
        residual_sigma=float(fit.sigma),
        coordinate_sigmas=tuple(coordinate_sigmas),
        coordinates=observation.coordinates,
        rows=rows,
        processing=observation.processing,
        threshold=threshold,
        fixed=tuple(n for n in names if n in fixed),
        at_bound=fit.at_bound,
        unconstrained=fit.unconstrained,
    )


def norm(x: np.ndarray) -> float:
    """‖x‖₂ without overflow or underflow of the squares: x is scaled by a power of two near its largest
    magnitude first (exact), so forces of 1e160 or 1e-160 give the norm their scale-free copy has."""
    x = np.asarray(x, dtype=float).ravel()
    largest = float(np.max(np.abs(x), initial=0.0))
    if largest == 0.0 or not np.isfinite(largest):
        return largest
    scale = math.ldexp(1.0, math.frexp(largest)[1])
    return float(np.linalg.norm(x / scale)) * scale


def _power_of_two(x: np.ndarray) -> float:
    """A power of two near ``max|x|`` (1 for zeros): dividing by it is exact."""
    largest = float(np.max(np.abs(x), initial=0.0))
    return math.ldexp(1.0, math.frexp(largest)[1]) if largest > 0 and np.isfinite(largest) else 1.0


def _check_finite(names: tuple[str, ...], values: np.ndarray, covariance: np.ndarray, fit: _Fit) -> None:
    """Refuse a solution whose estimates or statistics are not finite: a result of inf or nan is no estimate."""
    with np.errstate(invalid="ignore"):
        sigmas = np.sqrt(np.abs(np.diag(covariance)))
    bad = [n for n, v, s in zip(names, values, sigmas) if not (np.isfinite(v) and np.isfinite(s))]
    if bad or not (np.isfinite(fit.condition_number) and np.isfinite(fit.sigma)):
        shown = ", ".join(f"{n} = {values[names.index(n)]:.3g} ± {sigmas[names.index(n)]:.3g}" for n in bad[:3])
        raise IdentificationError(f"the least-squares solution is not finite ({shown or f'cond(W) = {fit.condition_number:.3g}'}): "
                                  "the data's numbers are too large or too small for double precision against the "
                                  "regressor's columns (check their units)")


class RankDeficient(IdentificationError):
    """The observation matrix is rank-deficient; ``parameters`` are the columns that cannot be separated."""

    def __init__(self, message: str, parameters: tuple[str, ...]) -> None:
        super().__init__(message)
        self.parameters = parameters

    def __reduce__(self):
        return (type(self), (str(self), self.parameters))


@dataclass(frozen=True)
class _Fit:
    beta: np.ndarray
    covariance: np.ndarray
    condition_number: float
    sigma: float
    at_bound: dict[str, str]
    unconstrained: dict[str, float]


def _bounded(y: np.ndarray, W: np.ndarray, names: tuple[str, ...], lower: np.ndarray, upper: np.ndarray) -> _Fit:  # noqa: N803
    """Least squares of ``y ≈ W·β`` with ``lower ≤ β ≤ upper``.

    Where the unbounded solution is inside the bounds it is the answer. Otherwise the bounded problem
    is solved on the triangular factor of the QR decomposition of [W y] (‖y − Wβ‖² = ‖z − Rβ‖² + ρ², so
    its size does not grow with the samples) by bounded-variable least squares
    (:func:`scipy.optimize.lsq_linear`, ``bvls``). Its solution is the unbounded least squares of the
    other parameters with the active ones held at their bounds; it is recomputed that way, so that the
    free parameters get the covariance σ_ρ²(W_fᵀW_f)⁻¹ of that fit (σ_ρ from its residual). An estimate
    held at a bound keeps the σ of the unbounded fit, what the data alone say about it, and the unbounded
    value is reported beside it (:attr:`Identification.unconstrained`).
    """
    beta, covariance, cond, sigma = _ols(y, W, names)
    if np.all((beta >= lower) & (beta <= upper)):
        return _Fit(beta, covariance, cond, sigma, {}, {})
    import scipy.optimize

    b = W.shape[1]
    R = np.linalg.qr(np.column_stack([W, y]), mode="r")  # noqa: N806
    solution = scipy.optimize.lsq_linear(R[:b, :b], R[:b, b], bounds=(lower, upper), method="bvls", tol=1e-14)
    active = solution.active_mask != 0
    if not active.any():  # the bounds were crossed by rounding only
        return _Fit(np.clip(beta, lower, upper), covariance, cond, sigma, {}, {})
    held = np.where(solution.active_mask < 0, lower, upper)
    y_rest = y - W[:, active] @ held[active]
    out_beta, out_cov = held.copy(), np.diag(np.diag(covariance))
    if (~active).any():
        beta_rest, cov_rest, cond, sigma = _ols(y_rest, W[:, ~active], tuple(n for n, a in zip(names, active) if not a))
        out_beta[~active] = beta_rest
        out_cov[np.ix_(~active, ~active)] = cov_rest
        out_cov[np.ix_(~active, active)] = out_cov[np.ix_(active, ~active)] = 0.0
    else:  # every parameter at a bound: nothing estimated, the residual is all there is
        sigma = norm(y_rest) / float(np.sqrt(len(y)))
    sides = {n: ("min" if m < 0 else "max") for n, m in zip(names, solution.active_mask) if m != 0}
    return _Fit(out_beta, out_cov, cond, sigma, sides, {n: float(v) for n, v, a in zip(names, beta, active) if a})


def _ols(y: np.ndarray, W: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, float, float]:  # noqa: N803
    """β̂, σ_ρ²(WᵀW)⁻¹, cond(W), σ_ρ.

    Through the triangular factor of the QR decomposition of [W y] (Householder, backward stable like
    the SVD of W, which it replaces: 0.09 s instead of 1.7 s for the Panda's 140 000 × 43): with
    [W y] = Q [[R, z], [0, ρ]], the LS solution solves R β = z, the residual norm is |ρ|, and the
    singular values of R are those of W, so the SVD of the small R gives cond(W), the rank test and
    (WᵀW)⁻¹ = V S⁻² Vᵀ.
    """
    rows, b = W.shape
    if rows <= b:
        raise IdentificationError(f"{rows} equations for {b} parameters: more samples are needed")
    # W and y scaled by powers of two (exact: the same digits at any scale) so that no square overflows
    w_scale, y_scale = _power_of_two(W), _power_of_two(y)
    beta, covariance, cond, sigma = _ols_scaled(y / y_scale, W / w_scale, names)
    with np.errstate(over="ignore"):
        ratio = y_scale / w_scale
        return beta * ratio, covariance * ratio**2, cond, sigma * y_scale


def _ols_scaled(y: np.ndarray, W: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, float, float]:  # noqa: N803
    """:func:`_ols` on data of moderate scale."""
    rows, b = W.shape
    R = np.linalg.qr(np.column_stack([W, y]), mode="r")  # noqa: N806
    U, s, Vt = np.linalg.svd(R[:b, :b])  # noqa: N806
    tolerance = max(rows, b) * np.finfo(float).eps * s[0]
    if s[-1] <= tolerance:
        null = Vt[-1]
        involved = tuple(names[i] for i in range(b) if abs(null[i]) > 1e-3 * np.abs(null).max())
        raise RankDeficient(
            f"the observation matrix is rank-deficient (rank {int((s > tolerance).sum())} < {b} parameters): "
            f"{', '.join(involved)} cannot be separated — use base parameters, or a more exciting trajectory",
            involved,
        )
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # a result beyond doubles: refused by solve
        beta = Vt.T @ ((U.T @ R[:b, b]) / s)
        variance = R[b, b] ** 2 / (rows - b)
        covariance = (Vt.T / s**2) @ Vt * variance
    return beta, covariance, s[0] / s[-1], float(np.sqrt(variance))


def _rank(W: np.ndarray) -> int:  # noqa: N803
    """Numerical rank of a tall ``W`` as numpy.linalg.matrix_rank defines it, from the SVD of its QR factor."""
    rows, cols = W.shape
    if rows < cols:
        return int(np.linalg.matrix_rank(W))
    s = np.linalg.svd(np.linalg.qr(W, mode="r"), compute_uv=False)
    return int((s > s.max(initial=0.0) * max(rows, cols) * np.finfo(float).eps).sum())


def _readonly(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array

"""Drift: per robot and parameter, a trend over time tested with each estimate's σ, and a change point when the
change is a step (docs/fleet.md, "Drift").

Input: per series (robot, parameter) the times t_i (days), estimates x_i and their σ_i from the logs.
Output: one :class:`Drift` per series with enough logs, ``flagged`` when it drifts.

* **Trend.** Weighted least squares x_i = a + b·(t_i − t̄) with weights 1/σ_i² (σ-aware: an estimate
  twice as uncertain counts a quarter as much). Var(b̂) = 1/Σ w_i(t_i − t̄)², scaled by the Birge ratio
  R² = χ²/(n − 2) when R > 1: when the estimates scatter more than their σ say (a log-to-log variation
  the IDIM-LS σ does not hold, e.g. temperature), the test uses the observed scatter instead.
  T = b̂/SE(b̂), p two-sided from Student's t with n − 2 degrees of freedom.
* **Step.** For every split with at least two logs on each side, the two weighted means μ₁, μ₂; the
  split of least χ² is the change point. T = (μ₂ − μ₁)/SE with SE² = (1/W₁ + 1/W₂)·max(1, χ²/(n − 2)),
  p from Student's t (n − 2), times the number of splits tried (Bonferroni over the candidate points).
* **Flag.** A series drifts when its smaller p is below α / (2·series) — Bonferroni over both tests of
  every series of the campaign, so a fleet without drift is flagged with probability at most α — and the
  change over the robot's logs is at least ``min_change`` of the level before it. When both tests pass,
  the model of smaller BIC (n·ln(χ²/n) + k·ln n, k = 2 for the trend, 3 for the step) names the kind.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from symbolic.fleet.campaign import Analysis


@dataclass(frozen=True)
class Series:
    """The estimates of one parameter of one robot over its logs, in time order."""

    robot: str
    parameter: str
    days: np.ndarray
    values: np.ndarray
    sigmas: np.ndarray
    times: tuple[str, ...]
    logs: tuple[str, ...]


@dataclass(frozen=True)
class Fit:
    """A fitted trend or step: the p-value of the change, the change and the level before it, the model's χ²."""

    p_value: float
    change: float
    before: float
    chi2: float
    scale: float
    detail: dict[str, Any] = field(default_factory=dict)

    @property
    def relative(self) -> float:
        return self.change / abs(self.before) if self.before != 0 else math.copysign(math.inf, self.change)


@dataclass(frozen=True)
class Drift:
    """The tests of one series (module docstring); ``kind`` is ``"trend"`` or ``"step"``."""

    series: Series = field(repr=False)
    trend: Fit
    step: Fit | None
    threshold: float
    flagged: bool
    kind: str

    @property
    def fit(self) -> Fit:
        return self.step if self.kind == "step" and self.step is not None else self.trend

    def to_dict(self) -> dict[str, Any]:
        fit = self.fit
        out = {"robot": self.series.robot, "parameter": self.series.parameter, "kind": self.kind,
               "flagged": self.flagged, "p_value": fit.p_value, "threshold": self.threshold, "change": fit.change,
               "relative_change": fit.relative, "level_before": fit.before, "logs": len(self.series.values),
               "first": self.series.times[0], "last": self.series.times[-1], "days": float(np.ptp(self.series.days)),
               "birge_ratio": fit.scale}
        out.update(fit.detail)
        return out


def trend(t: np.ndarray, x: np.ndarray, s: np.ndarray) -> Fit:
    """Weighted straight line and the test of its slope (module docstring)."""
    from scipy.special import stdtr  # Student's t CDF: scipy.special imports in half scipy.stats's time

    w = 1.0 / s**2
    centre = float(np.sum(w * t) / np.sum(w))
    u = t - centre
    sxx = float(np.sum(w * u**2))
    a = float(np.sum(w * x) / np.sum(w))
    b = float(np.sum(w * u * x) / sxx) if sxx > 0 else 0.0
    chi2 = float(np.sum(w * (x - a - b * u) ** 2))
    dof = len(x) - 2
    scale = max(1.0, math.sqrt(chi2 / dof)) if dof > 0 else math.inf
    se = scale / math.sqrt(sxx) if sxx > 0 else math.inf
    p = float(2 * stdtr(dof, -abs(b) / se)) if se > 0 and math.isfinite(se) and dof > 0 else 1.0
    start, end = float(t.min()), float(t.max())
    return Fit(p, b * (end - start), a + b * (start - centre), chi2, scale,
               {"slope_per_day": b, "slope_sigma": se})


def step(t: np.ndarray, x: np.ndarray, s: np.ndarray, times: Sequence[str]) -> Fit | None:
    """The best two-level split and the test of its step (module docstring); None with fewer than 4 logs."""
    from scipy.special import stdtr  # Student's t CDF: scipy.special imports in half scipy.stats's time

    n = len(x)
    if n < 4:
        return None
    w = 1.0 / s**2
    centre = float(np.sum(w * x) / np.sum(w))
    x = x - centre  # about the mean: the sums below then do not cancel
    # χ² of each split from cumulative sums (Σw, Σwx, Σwx²): O(n) for all splits, a year of daily logs included
    cw, cx, cxx = (np.concatenate([[0.0], np.cumsum(v)]) for v in (w, w * x, w * x * x))
    k = np.arange(2, n - 1)
    w1, w2 = cw[k], cw[-1] - cw[k]
    x1, x2 = cx[k], cx[-1] - cx[k]
    chi2s = (cxx[k] - x1**2 / w1) + (cxx[-1] - cxx[k] - x2**2 / w2)
    best = int(np.argmin(chi2s))
    k, w1, w2 = int(k[best]), float(w1[best]), float(w2[best])
    m1, m2, chi2 = centre + float(x1[best] / w1), centre + float(x2[best] / w2), max(float(chi2s[best]), 0.0)
    dof = n - 2
    scale = max(1.0, math.sqrt(chi2 / dof))
    se = scale * math.sqrt(1 / w1 + 1 / w2)
    splits = n - 3
    p = min(1.0, float(2 * stdtr(dof, -abs(m2 - m1) / se)) * splits)
    return Fit(p, m2 - m1, m1, chi2, scale, {"after": times[k], "before_step": times[k - 1], "level_after": m2})


def bic(chi2: float, n: int, k: int) -> float:
    return n * math.log(max(chi2, 1e-300) / n) + k * math.log(n)


def series_of(rows: Sequence[Mapping[str, Any]], origin: float) -> list[Series]:
    """The series of every (robot, parameter) from the rows that have a time and a finite estimate with σ > 0."""
    found: dict[tuple[str, str], list[tuple[float, float, float, str, str]]] = {}
    for row in rows:
        if row.get("status") != "ok" or row.get("days") is None:
            continue
        for p in row.get("parameters") or []:
            value, sigma = p.get("value"), p.get("sigma")
            if value is None or sigma is None or not (math.isfinite(value) and math.isfinite(sigma) and sigma > 0):
                continue
            found.setdefault((row["robot"], p["name"]), []).append((row["days"], value, sigma, row["time"], row["log"]))
    out = []
    for (robot, name), points in found.items():
        points.sort()
        days, values, sigmas, times, logs = zip(*points)
        out.append(Series(robot, name, np.array(days), np.array(values), np.array(sigmas), times, logs))
    return out


def drifts(series: Sequence[Series], analysis: Analysis) -> list[Drift]:
    """The tests of every series with at least ``analysis.min_logs`` logs (module docstring)."""
    tested = [s for s in series if len(s.values) >= analysis.min_logs and np.ptp(s.days) > 0]
    threshold = analysis.alpha / max(1, 2 * len(tested))
    out = []
    for s in tested:
        line = trend(s.days, s.values, s.sigmas)
        jump = step(s.days, s.values, s.sigmas, s.times)
        passes = {"trend": line.p_value < threshold and abs(line.relative) >= analysis.min_change}
        if jump is not None:
            passes["step"] = jump.p_value < threshold and abs(jump.relative) >= analysis.min_change
        if passes.get("trend") and passes.get("step"):
            n = len(s.values)
            kind = "step" if bic(jump.chi2, n, 3) < bic(line.chi2, n, 2) else "trend"
        else:
            kind = "step" if passes.get("step") else "trend"
        out.append(Drift(s, line, jump, threshold, any(passes.values()), kind))
    return out

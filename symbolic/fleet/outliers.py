"""Outliers: a robot whose parameters differ from its siblings' (robots of the same model) beyond their spread
(docs/fleet.md, "Outliers").

Input: the drift series (:mod:`symbolic.fleet.drift`) and their tests. Output: one :class:`Outlier` per
(robot, parameter) tested, ``flagged`` when it differs.

* **A robot's level.** Without a flagged drift: the weighted mean of its estimates, its standard error
  1/√Σw scaled by the Birge ratio when the logs scatter more than their σ. With a drift: the level before
  it (the trend at the robot's first log, or the step's first level), so that a robot that wears is
  reported as drifting, not as different from its siblings.
* **The test** (leave one out): the siblings' levels L_o (m ≥ 3 of them), their mean μ_o and standard
  deviation s_o (the spread between robots, measurement error included). A new sibling would fall within
  μ_o ± s_o·√(1 + 1/m) (a prediction interval); with the robot's own error, T = (L_r − μ_o) /
  √(s_o²(1 + 1/m) + SE_r²), p two-sided from Student's t with m − 1 degrees of freedom.
* **Flag** when p < α / (tests of the campaign) (Bonferroni) and |L_r − μ_o| ≥ ``min_change``·|μ_o|.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from symbolic.fleet.campaign import Analysis
from symbolic.fleet.drift import Drift, Series


@dataclass(frozen=True)
class Level:
    """A robot's level of one parameter and its standard error."""

    value: float
    sigma: float


@dataclass(frozen=True)
class Outlier:
    """The test of one robot's parameter against its siblings' (module docstring)."""

    robot: str
    model: str
    parameter: str
    level: float
    sigma: float
    siblings: float
    spread: float
    p_value: float
    threshold: float
    flagged: bool
    count: int

    @property
    def relative(self) -> float:
        difference = self.level - self.siblings
        return difference / abs(self.siblings) if self.siblings != 0 else math.copysign(math.inf, difference)

    def to_dict(self) -> dict[str, Any]:
        return {"robot": self.robot, "model": self.model, "parameter": self.parameter, "level": self.level,
                "sigma": self.sigma, "siblings_mean": self.siblings, "siblings_spread": self.spread,
                "siblings": self.count, "relative_difference": self.relative, "p_value": self.p_value,
                "threshold": self.threshold, "flagged": self.flagged}


def level(series: Series, drift: Drift | None) -> Level:
    """The robot's level (module docstring)."""
    x, s = series.values, series.sigmas
    w = 1.0 / s**2
    if drift is not None and drift.flagged:
        fit = drift.fit
        if drift.kind == "step":
            k = series.times.index(fit.detail["after"])
            return Level(fit.before, fit.scale / math.sqrt(float(w[:k].sum())))
        # the trend's value at the first log: its intercept there, a + b(t1 − t̄)
        t = series.days
        centre = float(np.sum(w * t) / np.sum(w))
        variance = 1.0 / w.sum() + (t[0] - centre) ** 2 * fit.detail["slope_sigma"] ** 2 / fit.scale**2
        return Level(fit.before, fit.scale * math.sqrt(variance))
    mean = float(np.sum(w * x) / w.sum())
    dof = len(x) - 1
    birge = math.sqrt(float(np.sum(w * (x - mean) ** 2)) / dof) if dof > 0 else 1.0
    return Level(mean, max(1.0, birge) / math.sqrt(float(w.sum())))


def outliers(series: Sequence[Series], drifts: Sequence[Drift], models: Mapping[str, str],
             analysis: Analysis) -> list[Outlier]:
    """The tests of every (robot, parameter) whose model has at least four robots with that parameter.

    ``models``: robot id → its model's digest (siblings share it)."""
    from scipy.special import stdtr  # Student's t CDF (as in drift)

    tested = {(d.series.robot, d.series.parameter): d for d in drifts}
    groups: dict[tuple[str, str], dict[str, Level]] = {}
    for s in series:
        groups.setdefault((models[s.robot], s.parameter), {})[s.robot] = level(s, tested.get((s.robot, s.parameter)))
    groups = {k: v for k, v in groups.items() if len(v) >= 4}
    count = sum(len(v) for v in groups.values())
    threshold = analysis.alpha / max(1, count)
    out = []
    for (model, parameter), levels in groups.items():
        for robot, own in levels.items():
            others = np.array([v.value for r, v in levels.items() if r != robot])
            m = len(others)
            mean, spread = float(others.mean()), float(others.std(ddof=1))
            scale = math.sqrt(spread**2 * (1 + 1 / m) + own.sigma**2)
            p = float(2 * stdtr(m - 1, -abs(own.value - mean) / scale)) if scale > 0 else (
                0.0 if own.value != mean else 1.0)
            big = abs(own.value - mean) >= analysis.min_change * abs(mean)
            out.append(Outlier(robot, model, parameter, own.value, own.sigma, mean, spread, p, threshold,
                               p < threshold and big, m))
    return out

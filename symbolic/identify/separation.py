"""Which motion would separate terms that a log cannot tell apart.

Least squares cannot separate two terms whose columns are proportional on the data — Coulomb friction
and a constant offset on an axis that moves one way only: sign(q̇) is 1 wherever the offset's column is.
Whether another motion would separate them, and which, follows from the columns themselves, for any
terms: the combination c of the columns that vanishes on the data (:func:`relation`; each column scaled
to unit norm, c the last right singular vector) is evaluated on the data's own motion changed in one
respect at a time, coordinate by coordinate (:func:`probes`):

* **reversed** — the coordinate's path run backwards, every velocity of the opposite sign: "moving in
  both directions";
* **faster** — its velocities doubled and accelerations quadrupled (the same path in half the time):
  "at other speeds";
* **shifted** — its positions moved by the range the data cover: "over a wider range of positions".

A change under which c no longer vanishes — the combination's size relative to its columns',
‖Σ c_i a_i‖ / Σ |c_i|·‖a_i‖, above :data:`SEPARATES` and ten times what it is on the data's own states
(the columns are evaluated raw, without the data treatment's filter) — names the motion
(:func:`separating_motion`). When none does, a generic motion (each coordinate two sines over at least its
range, at a later time) is tried: separating there, the advice is a richer motion of the coordinates; not
even there, the columns are the same function of the states: the relation is the model's own, no motion
separates the terms (``None``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

PROBE_SAMPLES = 400
"""States of the data kept for the probes (evenly spaced): the rank of a few columns needs no more."""
SEPARATES = 1e-3
"""A combination of the columns that vanishes on the data is broken by a motion when its relative size there
exceeds this."""
INVOLVED = 1e-3
"""A column takes part in a relation when its share of the combination (|c_i|·‖a_i‖ over the largest) exceeds this."""


@dataclass(frozen=True, eq=False)
class Motion:
    """States ``samples × N`` at times ``t`` (s), sampled at ``rate`` (Hz)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    t: np.ndarray
    rate: float

    @classmethod
    def of(cls, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, rate: float, t0: float = 0.0,
           samples: int = PROBE_SAMPLES) -> Motion:
        """At most ``samples`` evenly spaced states of a record at ``rate`` starting at ``t0``."""
        q, qd, qdd = (np.asarray(x, float).reshape(len(x), -1) for x in (q, qd, qdd))
        step = max(1, int(np.ceil(len(q) / samples)))
        keep = slice(0, None, step)
        return cls(q[keep], qd[keep], qdd[keep], t0 + np.arange(len(q))[keep] / rate, rate / step)


Columns = Callable[[Motion], np.ndarray]
"""Columns of some terms on a motion: ``samples × N × k`` (as the regressor and the effects give them)."""


def probes(motion: Motion) -> list[tuple[str, int, Motion]]:
    """(kind, coordinate index, motion): ``reversed``, ``faster`` and ``shifted`` for each coordinate, then
    ``generic`` (index −1); module docstring."""
    out = []
    span = np.ptp(motion.q, axis=0) if len(motion.q) else np.zeros(motion.q.shape[1])
    for j in range(motion.q.shape[1]):
        q, qd, qdd = motion.q.copy(), motion.qd.copy(), motion.qdd.copy()
        q[:, j], qd[:, j], qdd[:, j] = q[::-1, j], -qd[::-1, j], qdd[::-1, j]
        out.append(("reversed", j, Motion(q, qd, qdd, motion.t, motion.rate)))
        qd, qdd = motion.qd.copy(), motion.qdd.copy()
        qd[:, j] *= 2.0
        qdd[:, j] *= 4.0
        out.append(("faster", j, Motion(motion.q, qd, qdd, motion.t, motion.rate)))
        q = motion.q.copy()
        q[:, j] += max(float(span[j]), 1.0)
        out.append(("shifted", j, Motion(q, motion.qd, motion.qdd, motion.t, motion.rate)))
    out.append(("generic", -1, _generic(motion, span)))
    return out


def _generic(motion: Motion, span: np.ndarray) -> Motion:
    """Each coordinate two sines about its mean, amplitudes of at least its range (1 when it does not move),
    frequencies incommensurate between coordinates, at a time after the record's (a term in time moves on)."""
    duration = max(float(motion.t[-1] - motion.t[0]) if len(motion.t) > 1 else 1.0, 1e-3)
    t = motion.t + 1.5 * duration
    tau = (t - t[0])[:, None]
    n = motion.q.shape[1]
    a = np.maximum(span, 1.0)[None, :]
    w1 = 2 * np.pi * (1.0 + 0.37 * np.arange(n)) / duration
    w2 = 2 * np.pi * (2.3 + 0.61 * np.arange(n)) / duration
    centre = motion.q.mean(axis=0) if len(motion.q) else np.zeros(n)
    q = centre + a * np.sin(w1 * tau) + 0.5 * a * np.sin(w2 * tau + 0.3)
    qd = a * w1 * np.cos(w1 * tau) + 0.5 * a * w2 * np.cos(w2 * tau + 0.3)
    qdd = -a * w1**2 * np.sin(w1 * tau) - 0.5 * a * w2**2 * np.sin(w2 * tau + 0.3)
    return Motion(q, qd, qdd, t, motion.rate)


def relation(columns: np.ndarray) -> np.ndarray:
    """The combination c (in the columns' own scale) that comes closest to vanishing on ``columns`` (``rows ×
    k``): the last right singular vector of the columns scaled to unit norm, c_i = v_i/‖a_i‖."""
    columns = np.asarray(columns, float)
    norms = np.linalg.norm(columns, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    v = np.linalg.svd(columns / norms, full_matrices=False)[2][-1]
    return v / norms


def size(columns: np.ndarray, combination: np.ndarray) -> float:
    """‖Σ c_i a_i‖ / Σ |c_i|·‖a_i‖ of ``columns`` (``rows × k``): 0 where the combination vanishes, up to 1."""
    scale = float(np.abs(combination) @ np.linalg.norm(columns, axis=0))
    return float(np.linalg.norm(columns @ combination)) / scale if scale > 0 else 0.0


def _stacked(array: np.ndarray) -> np.ndarray:
    array = np.asarray(array, float)
    return array.reshape(-1, array.shape[-1])


def separating_motion(columns: Columns, combination: np.ndarray, motion: Motion, coordinates: Sequence[str],
                      cases: Sequence[tuple[str, int, Motion]] | None = None) -> str | None:
    """What motion would separate terms whose ``columns`` (on a motion) satisfy ``combination`` on the data,
    whose (filtered) states are ``motion``: a phrase naming it, or ``None`` when no motion does (the terms are
    the same function of the states). ``cases``: :func:`probes` of ``motion``, when the caller keeps them.
    The generic motion first: where it does not separate them, no change of the data's motion will."""
    cases = probes(motion) if cases is None else cases
    threshold = max(SEPARATES, 10.0 * size(_stacked(columns(motion)), combination))
    generic = [m for kind, _, m in cases if kind == "generic"]
    if not any(size(_stacked(columns(m)), combination) > threshold for m in generic):
        return None
    found = [(kind, j) for kind, j, m in cases if kind != "generic"
             and size(_stacked(columns(m)), combination) > threshold]
    if not found:
        return f"a richer motion of {', '.join(coordinates)} (each over a wider range, in both directions, at several speeds)"
    return "; or ".join(_phrase(kind, j, motion, coordinates[j]) for kind, j in found)


def _phrase(kind: str, j: int, motion: Motion, name: str) -> str:
    """The words for one separating change of coordinate ``j`` (with what the data do instead)."""
    v = motion.qd[:, j]
    if kind == "reversed":
        moving = v[np.abs(v) > 0]
        share = max(float(np.mean(moving > 0)), float(np.mean(moving < 0))) if moving.size else 1.0
        return f"{name} moving in both directions (the data move it one way in {100 * share:.3g} % of their samples)"
    if kind == "faster":
        return f"{name} at other speeds (the data's speed reaches {float(np.abs(v).max(initial=0.0)):.3g})"
    q = motion.q[:, j]
    return f"{name} over a wider range of positions (the data cover {float(q.min()):.4g} to {float(q.max()):.4g})"


def involved(coefficients: np.ndarray, norms: np.ndarray) -> np.ndarray:
    """Indices of the columns that take part in a combination (:data:`INVOLVED`)."""
    share = np.abs(coefficients) * norms
    return np.flatnonzero(share > INVOLVED * share.max(initial=0.0))


def parameter_label(model, reg, base, name: str, known: set) -> str:
    """A base parameter as the model file names it: the one model parameter it holds (``Fc``), else its name
    and the parameters it combines (``ZZR1 (of I1, m1, m2)``); ``known``: parameters not estimated."""
    from symbolic.identify.known import model_parameters_of

    every, _ = model_parameters_of(model, reg, base, [name], known)
    if len(every) == 1:
        return every[0]
    return f"{name} (of {', '.join(every)})" if every else name

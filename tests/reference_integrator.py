"""Closed-loop logs made without the product's simulator: truth for the output-error tests.

:func:`axis_pd_log` runs a 1-DOF axis J·q̈ = τ − Fv·q̇ − Fc·sgn(q̇) under a discrete PD loop with
zero-order hold. Between two samples τ is constant, so the motion has a closed form: while sliding in the
direction s = sgn(q̇), q̇(t) = v∞ + (q̇₀ − v∞)·e^{−t/τm} with v∞ = (τ − s·Fc)/Fv and τm = J/Fv, q its
integral. The set-valued Coulomb friction is handled as stick/slip events: a velocity reaching zero inside
an interval is located exactly (a logarithm); there the axis sticks while |τ| ≤ Fc (for the rest of the
interval, τ being held) and else slides off in the direction of τ. No step size, no smoothing: errors are
those of floating point only.

The loop is the machine's: the encoder reads q rounded to its resolution (round half up, as a counter
does), the velocity is the backward difference of the readings (0 at the first sample), u_k = kp·(r_k −
q_m,k) − kd·v_k is applied over [t_k, t_k+1). The log holds the readings and the force with added noise.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _slide(q0: float, v0: float, tau: float, s: float, J: float, Fv: float, Fc: float, t: float) -> tuple[float, float]:
    """Position and velocity after t of sliding in direction s from (q0, v0) under the constant force tau."""
    v_inf = (tau - s * Fc) / Fv
    decay = math.exp(-t * Fv / J)
    return q0 + v_inf * t + (v0 - v_inf) * J / Fv * (1.0 - decay), v_inf + (v0 - v_inf) * decay


def _zero_crossing(v0: float, tau: float, s: float, J: float, Fv: float, Fc: float) -> float:
    """Time at which sliding in direction s (s = sgn v0) brings the velocity to 0; inf if it never does."""
    v_inf = (tau - s * Fc) / Fv
    if v_inf * s >= 0:  # the asymptote is on the same side: the velocity never reaches zero
        return math.inf
    return J / Fv * math.log((v0 - v_inf) / (0.0 - v_inf))


def interval(q: float, v: float, tau: float, h: float, J: float, Fv: float, Fc: float) -> tuple[float, float]:
    """The exact state after h under the held force tau, with stick/slip Coulomb friction."""
    remaining = h
    for _ in range(8):  # a few events at most per interval (stop, slide off, stop again cannot recur)
        if v == 0.0:
            if abs(tau) <= Fc:
                return q, 0.0  # sticks for the rest of the interval
            s = math.copysign(1.0, tau)
        else:
            s = math.copysign(1.0, v)
        crossing = _zero_crossing(v, tau, s, J, Fv, Fc) if v != 0.0 else math.inf
        if crossing >= remaining:
            return _slide(q, v, tau, s, J, Fv, Fc, remaining)
        q, _ = _slide(q, v, tau, s, J, Fv, Fc, crossing)
        v, remaining = 0.0, remaining - crossing
    return q, v


def axis_pd_run(t: np.ndarray, reference: np.ndarray, J: float, Fv: float, Fc: float, kp: float, kd: float,
                resolution: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(true q, encoder readings, commanded τ) at the samples, from rest at q = 0."""
    q, v = 0.0, 0.0
    period = float(t[1] - t[0])
    true, read, force = (np.empty(len(t)) for _ in range(3))
    last = None
    for k in range(len(t)):
        measured = math.floor(q / resolution + 0.5) * resolution if resolution > 0 else q
        velocity = 0.0 if last is None else (measured - last) / period
        tau = kp * (reference[k] - measured) - kd * velocity
        true[k], read[k], force[k] = q, measured, tau
        last = measured
        q, v = interval(q, v, tau, period, J, Fv, Fc)
    return true, read, force


def reference_motion(t: np.ndarray, amplitude: float = 0.6) -> np.ndarray:
    """A smooth reference from rest: sines at 0.7, 1.9 and 4.3 Hz under a half-second fade-in."""
    fade = np.clip(t / 0.5, 0.0, 1.0) ** 2 * (3 - 2 * np.clip(t / 0.5, 0.0, 1.0))
    return amplitude * fade * (np.sin(2 * np.pi * 0.7 * t) + 0.4 * np.sin(2 * np.pi * 1.9 * t + 1.0)
                               + 0.15 * np.sin(2 * np.pi * 4.3 * t + 2.0))


def write_axis_experiment(folder: Path, *, J: float = 0.05, Fv: float = 0.3, Fc: float = 0.4, kp: float = 20.0,
                          kd: float = 1.0, rate: float = 1000.0, seconds: float = 4.0, counts: int = 2**16,
                          force_noise: float = 0.0, seed: int = 0) -> Path:
    """Write ``folder/axis.csv`` and ``folder/axis.experiment.toml`` (with its PD ``[controller]`` and the
    encoder's quantisation) of the axis under PD; ``counts`` per revolution (0: exact positions),
    ``force_noise`` the standard deviation (N·m) of white noise added to the logged force."""
    from symbolic.data import write_columns

    t = np.arange(int(round(seconds * rate))) / rate
    r = reference_motion(t)
    resolution = 2 * math.pi / counts if counts else 0.0
    _, read, force = axis_pd_run(t, r, J, Fv, Fc, kp, kd, resolution)
    logged = force + np.random.default_rng(seed).normal(0.0, force_noise, len(t)) if force_noise else force
    folder.mkdir(parents=True, exist_ok=True)
    write_columns({"t": t, "q_q": read, "tau_q": logged, "ref_q": r}, folder / "axis.csv")
    quantisation = f"quantisation = [{resolution!r}]\n" if resolution else ""
    path = folder / "axis.experiment.toml"
    path.write_text('data = "axis.csv"\n[signals]\nt = "t"\nq_q = "q_q"\ntau_q = "tau_q"\nref_q = "ref_q"\n'
                    f'[controller]\nkind = "pd"\nkp = [{kp!r}]\nkd = [{kd!r}]\nreference = "ref"\n{quantisation}',
                    encoding="utf-8")
    return path

"""A flexible-link rig logged as real rigs are, made without the product's simulator: truth for the response tests.

The plant is tests/test_state_feedback.py's rig (its equations written out there by hand: D(α), Lagrange's
right-hand side) with set-valued Coulomb friction Fc on the hub added. It is integrated by Moreau's
time-stepping at a fine step (50 per sample): each step's velocity update solves the hub's friction impulse
λ ∈ [−Fc·h, Fc·h] exactly (sticking when the free update's hub velocity is within w·Fc·h of zero, w = (D⁻¹)₁₁),
then the positions move with the new velocities (first order; at h = 20 µs its error is far below the
sensors'). No smoothing, no step-size control.

The loop is the machine's: an LQR (u = −K·(x_m − x_ref), K from tests/test_state_feedback.py's Riccati
solution on the true plant) on the hub encoder's reading (2^16 counts per revolution) and the strain
gauge's (the deflection plus white noise, read by a 12-bit converter over ±``gauge_range``), velocities as
backward differences of the readings, the command held over the sample. The log holds the readings, the
command and the reference.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from test_state_feedback import P, lqr, mass_matrix

STATES = ["q_theta", "q_alpha", "qd_theta", "qd_alpha"]


def _forces(x: np.ndarray, tau: float, p: dict) -> np.ndarray:
    """The generalised forces without the hub's Coulomb friction (test_state_feedback.rig_rhs's right-hand side)."""
    _, alpha, w, a = x
    h = p["m"] * p["r"] * p["c"]
    return np.array([tau - p["Bh"] * w + h * math.sin(alpha) * (2 * w * a + a * a),
                     -p["Ks"] * alpha - p["Ds"] * a - h * math.sin(alpha) * w * w])


def moreau_step(x: np.ndarray, tau: float, h: float, p: dict, Fc: float) -> np.ndarray:
    """One step of Moreau's time-stepping with the hub's set-valued Coulomb friction (module docstring)."""
    inverse = np.linalg.inv(mass_matrix(x[1]))
    free = x[2:] + h * inverse @ _forces(x, tau, p)
    w = inverse[0, 0]
    limit = Fc * h
    impulse = -free[0] / w if abs(free[0]) <= w * limit else -math.copysign(limit, free[0])
    v = free + inverse[:, 0] * impulse
    return np.concatenate([x[:2] + h * v, v])


def write_rig_experiment(folder: Path, *, Fc: float = 1.5e-3, seconds: float = 8.0, rate: float = 500.0,
                         counts: int = 2**16, gauge_bits: int = 12, gauge_range: float = 0.3,
                         gauge_noise: float = 1.0, substeps: int = 50, seed: int = 0) -> Path:
    """``folder/rig.csv`` and ``folder/rig.experiment.toml`` of the rig under its LQR (module docstring);
    ``gauge_noise`` in least significant bits of the gauge's converter."""
    from symbolic.data import write_columns

    p = dict(P)  # the truth of tests/test_state_feedback.py (Ks 0.26)
    K = lqr()[0]
    rng = np.random.default_rng(seed)
    period = 1.0 / rate
    t = np.arange(int(round(seconds * rate))) * period
    fade = np.clip(t / 0.5, 0.0, 1.0) ** 2
    ref = fade * (0.3 * np.sin(2 * np.pi * 0.4 * t) + 0.15 * np.sin(2 * np.pi * 1.3 * t + 0.5)
                  + 0.05 * np.sin(2 * np.pi * 3.1 * t + 1.0))
    encoder = 2 * math.pi / counts
    gauge = 2 * gauge_range / 2**gauge_bits
    x = np.zeros(4)
    previous = None
    read, command = np.empty((len(t), 2)), np.empty(len(t))
    h = period / substeps
    for k in range(len(t)):
        y = np.array([math.floor(x[0] / encoder + 0.5) * encoder,
                      math.floor((x[1] + gauge_noise * gauge * rng.normal()) / gauge + 0.5) * gauge])
        v = np.zeros(2) if previous is None else (y - previous) / period
        previous = y
        u = float(-(K @ (np.concatenate([y, v]) - [ref[k], 0.0, 0.0, 0.0])))
        read[k], command[k] = y, u
        for _ in range(substeps):
            x = moreau_step(x, u, h, p, Fc)
    folder.mkdir(parents=True, exist_ok=True)
    write_columns({"t": t, "q_theta": read[:, 0], "q_alpha": read[:, 1], "tau_theta": command,
                   "tau_alpha": np.zeros(len(t)), "ref_theta": ref, "ref_alpha": np.zeros(len(t))},
                  folder / "rig.csv")
    path = folder / "rig.experiment.toml"
    path.write_text('data = "rig.csv"\n[signals]\nt = "t"\nq_theta = "q_theta"\nq_alpha = "q_alpha"\n'
                    'tau_theta = "tau_theta"\ntau_alpha = "tau_alpha"\nref_theta = "ref_theta"\n'
                    'ref_alpha = "ref_alpha"\n[controller]\nkind = "state_feedback"\ninputs = ["theta"]\n'
                    f'states = {STATES!r}\nK = [{", ".join(repr(float(k)) for k in K)}]\n'
                    f'quantisation = [{encoder!r}, {gauge!r}]\n'.replace("'", '"'), encoding="utf-8")
    return path

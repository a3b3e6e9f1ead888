"""PUMA 560 and Panda against Pinocchio built from the same DH tables.

Tolerance: ‖ours − Pinocchio‖ ≤ 1e-9 ‖Pinocchio‖ (Frobenius/2-norm, relative), at 50 seeded random
states per robot; angles uniform in [−π, π], velocities and accelerations in [−2, 2].
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import derived
from reference_pinocchio import Reference
from symbolic.numeric import numeric_model

pin = pytest.importorskip("pinocchio")

RTOL = 1e-9
STATES = 50


def states(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(STATES):
        yield rng.uniform(-np.pi, np.pi, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)


def close(ours: np.ndarray, reference: np.ndarray) -> None:
    error = np.linalg.norm(ours - reference)
    assert error <= RTOL * np.linalg.norm(reference), f"relative error {error / np.linalg.norm(reference):.3e}"


@pytest.mark.parametrize("name", ["puma560", "panda"])
def test_dynamics_match_pinocchio(name: str) -> None:
    model = derived(name)
    num = numeric_model(model)
    ref = Reference(model.robot)
    for q, qd, qdd in states(model.n, seed=2026):
        D = num.inertia(q)
        close(D, ref.inertia(q))
        close(num.gravity(q), ref.gravity(q))
        h = num.coriolis(q, qd)
        close(h, ref.coriolis_vector(q, qd))
        C = num.coriolis_matrix(q, qd)
        close(C @ qd, ref.coriolis_vector(q, qd))
        close(C @ qd, ref.coriolis_matrix(q, qd) @ qd)
        skew = num.inertia_rate(q, qd) - 2 * C
        assert np.linalg.norm(skew + skew.T) <= RTOL * (np.linalg.norm(num.inertia_rate(q, qd)) + 2 * np.linalg.norm(C))
        tau = ref.rnea(q, qd, qdd)
        close(num.inverse_dynamics(q, qd, qdd), tau)
        close(D @ qdd + h + num.gravity(q), tau)  # Lagrangian route (D, Christoffel, g) = Newton–Euler route

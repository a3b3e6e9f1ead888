"""A rigid body's ten inertial parameters and its pseudo-inertia (Wensing, Kim & Slotine): the feasible set that
``identify --consistent`` keeps each body in (:mod:`symbolic.identify.consistent`, its log-Cholesky passes;
:mod:`symbolic.identify.conic`, its convex form)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

INERTIA_KEYS = ("xx", "xy", "xz", "yy", "yz", "zz")
"""The inertia entries in the order of the ten standard parameters."""
AXES = {"xx": (0, 0), "xy": (0, 1), "xz": (0, 2), "yy": (1, 1), "yz": (1, 2), "zz": (2, 2)}
"""Each inertia entry's place in the 3×3 matrix."""


def pseudo_inertia(mass: float, com: Sequence[float], inertia: np.ndarray) -> np.ndarray:
    """The pseudo-inertia J of a rigid body about its frame origin, from the model file's form: mass, centre
    of mass, 3×3 inertia about the centre of mass.

    The body is physically consistent exactly when (Wensing, Kim & Slotine, IEEE RA-L 3(1), 2018, (9)–(12))

        J = [[Σ, h], [hᵀ, m]],  Σ = ½·tr(I_O)·1 − I_O,  h = m·c                                    (4)

    is positive definite. With I_O = I_c + m·(cᵀc·1 − c·cᵀ) (parallel axes) the Schur complement of m is
    Σ − h·hᵀ/m = Σ_c = ½·tr(I_c)·1 − I_c, so J ≻ 0 ⇔ m > 0 and Σ_c ≻ 0: the principal moments of the inertia
    about the centre of mass are positive and each is smaller than the sum of the other two (the triangle
    inequalities). The centre of mass is free.
    """
    m, c, Ic = float(mass), np.asarray(com, float), np.asarray(inertia, float)
    standard = standard_parameters(m, c, Ic)
    return pseudo_of_standard(standard)


def standard_parameters(mass: float, com: Sequence[float], inertia: np.ndarray) -> np.ndarray:
    """Khalil's ten standard parameters [XX XY XZ YY YZ ZZ MX MY MZ M] about the frame origin (the order of
    :data:`symbolic.derivation.regressor.INERTIAL`): I_O = I_c + m(cᵀc·1 − c·cᵀ), h = m·c."""
    c = np.asarray(com, float)
    IO = np.asarray(inertia, float) + mass * (c @ c * np.eye(3) - np.outer(c, c))
    h = mass * c
    return np.array([*inertia_entries(IO), *h, mass])


def inertia_matrix(entries: Sequence[float]) -> np.ndarray:
    """The symmetric 3×3 inertia of its six entries in the order of :data:`INERTIA_KEYS` (XX XY XZ YY YZ ZZ)."""
    xx, xy, xz, yy, yz, zz = map(float, entries)
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def inertia_entries(inertia: np.ndarray) -> list[float]:
    """The six entries of a symmetric 3×3 inertia in the order of :data:`INERTIA_KEYS` (the inverse of
    :func:`inertia_matrix`)."""
    return [float(inertia[AXES[key]]) for key in INERTIA_KEYS]


def pseudo_of_standard(theta: Sequence[float]) -> np.ndarray:
    """J of (4) from the ten standard parameters (XX … M)."""
    mx, my, mz, m = map(float, theta[6:10])
    IO = inertia_matrix(theta[:6])
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(IO) * np.eye(3) - IO
    J[:3, 3] = J[3, :3] = (mx, my, mz)
    J[3, 3] = m
    return J


def body_of_standard(theta: Sequence[float]) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about the centre of mass) from the ten standard parameters (m ≠ 0):
    c = h/m, I_c = I_O − m(cᵀc·1 − c·cᵀ)."""
    m = float(theta[9])
    c = np.asarray(theta[6:9], float) / m
    return m, c, inertia_matrix(theta[:6]) - m * (c @ c * np.eye(3) - np.outer(c, c))

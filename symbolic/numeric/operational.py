"""What the hand on the end effector feels: apparent mass, stiffness and friction (Janot (18)–(20)).

For a model with an ``end_effector``, at a configuration Q:

    Φ = J D⁻¹ Jᵀ (:func:`mobility`),   Λ = Φ⁻¹ (:func:`operational_inertia`, Janot's M_op),
    m_u = uᵀu / (uᵀ Φ u) (:func:`apparent_mass`: the mass felt pushing along u),
    B_op = J̄ᵀF_vJ̄,  K_op = J̄ᵀK J̄,  F_cop = J̄ᵀF_c (:func:`handle_characteristics`),  K_tot of (19),

with Khatib's dynamically consistent inverse J̄ = D⁻¹JᵀΛ (:func:`dynamically_consistent_inverse`) in
place of Janot's J⁻¹ (equal for a square J). Computed numerically through the Cholesky factor of D, the
arithmetic of the generated ``NAME_apparent_mass`` and ``NAME_operational_inertia``; where J has rank
below 3, Λ and J̄ raise :class:`SingularConfiguration` while m_u stays finite along the directions the
point can move in. Definitions, why J̄, and the checks: docs/seeds.md, "Janot: apparent mass, stiffness
and friction at the handle"; the C status codes: docs/contracts.md, "Generated C".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.derivation.transmission import constraint_jacobian
from symbolic.description.robot import Directional
from symbolic.errors import SymbolicError
from symbolic.numeric.statespace import numeric_model

SINGULAR_RATIO = 1e-12
"""Φ is taken as singular when a pivot of its Cholesky factorisation is not above this fraction of its
trace (the generated C's test, so that both refuse the same configurations)."""


class NoEndEffector(SymbolicError, ValueError):
    """The model declares no ``[end_effector]``, so nothing is felt at a handle."""


class SingularConfiguration(SymbolicError, ValueError):
    """J D⁻¹ Jᵀ is singular here (J of rank below 3): Λ and J̄ do not exist."""


def _check(model: DynamicModel) -> None:
    if model.robot.end_effector is None:
        raise NoEndEffector(
            f"model {model.name!r} declares no [end_effector]: the apparent mass is defined at an end-effector point "
            f"(add [end_effector] frame = ..., point = [...] to the model file)"
        )


def _weights(model: DynamicModel, q, p=None) -> np.ndarray:
    """W = R⁻¹Jᵀ (N×3) with D = R Rᵀ, so that Φ = WᵀW."""
    _check(model)
    num = numeric_model(model)
    factor = np.linalg.cholesky(num.inertia(q, p))
    return _forward_substitution(factor, num.jacobian(q, p).T)


def _forward_substitution(factor: np.ndarray, b: np.ndarray) -> np.ndarray:
    """R⁻¹b for a lower-triangular R, row by row as the generated C does (so both round alike)."""
    out = np.zeros_like(b, dtype=float)
    for i in range(factor.shape[0]):
        out[i] = (b[i] - factor[i, :i] @ out[:i]) / factor[i, i]
    return out


def mobility(model: DynamicModel, q, p=None) -> np.ndarray:
    """Φ = J D⁻¹ Jᵀ (3×3, symmetric positive semi-definite): ẍ = Φ F at rest under a point force F."""
    w = _weights(model, q, p)
    return w.T @ w


def operational_inertia(model: DynamicModel, q, p=None) -> np.ndarray:
    """Λ = (J D⁻¹ Jᵀ)⁻¹ at the end effector (3×3, linear part), Janot's M_op.

    Φ = J D⁻¹ Jᵀ is factored Φ = M Mᵀ and Λ = M⁻ᵀM⁻¹, as the generated C does.

    Raises
    ------
    NoEndEffector
        The model declares no end effector.
    SingularConfiguration
        A Cholesky pivot of Φ is not above :data:`SINGULAR_RATIO` times its trace (J of rank below 3).
    """
    phi = mobility(model, q, p)
    factor = np.zeros((3, 3))
    limit = SINGULAR_RATIO * np.trace(phi)
    for j in range(3):
        pivot = phi[j, j] - factor[j, :j] @ factor[j, :j]
        if not pivot > limit:
            raise SingularConfiguration(
                f"model {model.name!r}: J D^-1 J^T is singular at q = {np.round(np.asarray(q, float), 6).tolist()} "
                f"(J has rank below 3 there); the apparent mass is infinite along some direction"
            )
        factor[j, j] = np.sqrt(pivot)
        for i in range(j + 1, 3):
            factor[i, j] = (phi[i, j] - factor[i, :j] @ factor[j, :j]) / factor[j, j]
    inverse = _forward_substitution(factor, np.eye(3))
    return inverse.T @ inverse


def apparent_mass(model: DynamicModel, q, u, p=None) -> float:
    """m_u = uᵀu / (uᵀ J D⁻¹ Jᵀ u): the mass felt along the direction ``u`` (any length), in kg.

    The point is pushed along u and left free in the other directions. ``inf`` where the point
    cannot move along u (uᵀΦu = 0: every joint motion is orthogonal to u).
    """
    u = np.asarray(u, dtype=float)
    norm2 = float(u @ u)
    if not norm2 > 0.0:
        raise ValueError(f"apparent mass: the direction u = {u.tolist()} is zero")
    wu = _weights(model, q, p) @ u
    mobility_u = float(wu @ wu)
    return norm2 / mobility_u if mobility_u > 0.0 else float("inf")


def dynamically_consistent_inverse(model: DynamicModel, q, p=None) -> np.ndarray:
    """J̄ = D⁻¹JᵀΛ (N×3): J J̄ = I, and J̄ = J⁻¹ when J is square (Khatib 1987)."""
    num = numeric_model(model)
    lam = operational_inertia(model, q, p)
    return np.linalg.solve(num.inertia(q, p), num.jacobian(q, p).T) @ lam


def least_energy_velocity(model: DynamicModel, q, xd, p=None) -> np.ndarray:
    """The joint velocity realising the point velocity ``xd`` with the least kinetic energy, J̄ẋ."""
    return dynamically_consistent_inverse(model, q, p) @ np.asarray(xd, dtype=float)


@dataclass(frozen=True)
class JointFriction:
    """Plain viscous and Coulomb friction of the [[friction]] entries over the generalized coordinates.

    f(Q̇) = viscous·Q̇ + coulomb_directions·diag(coulomb)·sign(coulomb_directionsᵀQ̇) + offsets: entry i at
    a coordinate whose velocity is a_iᵀQ̇ (a_i a unit vector, or a row of L for a constrained coordinate,
    Janot (12)) contributes a_i(F_Vi a_iᵀQ̇ + F_Ci sign(a_iᵀQ̇)).
    """

    viscous: np.ndarray  # N×N, Σ F_Vi a_i a_iᵀ
    directions: np.ndarray  # N×E, columns a_i
    coulomb: np.ndarray  # E, F_Ci


def joint_friction(model: DynamicModel, q, p=None) -> JointFriction:
    """The model's friction as :class:`JointFriction` at the parameters ``p`` (default nominal).

    Only viscous and Coulomb coefficients (Janot (15)) have a matrix form: entries with
    direction-dependent coefficients or a Stribeck term are refused (ValueError).
    """
    robot = model.robot
    values = model.parameter_vector.with_array(p).by_symbol() | dict(zip(model.coordinates, map(float, q)))
    names = [c.coordinate for c in robot.constraints]
    L = constraint_jacobian(robot).xreplace(robot.constraint_substitution)
    n = model.n
    viscous = np.zeros((n, n))
    directions, coulomb = [], []
    for entry in robot.frictions:
        if entry.stribeck is not None or any(isinstance(c, Directional) for c in (entry.viscous, entry.coulomb)):
            raise ValueError(f"model {model.name!r}: friction at {entry.coordinate} is direction-dependent or has a "
                             f"Stribeck term; only viscous and Coulomb coefficients map to the handle as matrices")
        a = np.zeros(n)
        if entry.coordinate in names:
            row = L[names.index(entry.coordinate), :]
            a[: row.shape[1]] = [float(sp.sympify(x).xreplace(values)) for x in row]
        else:
            a[robot.generalized_coordinates.index(entry.coordinate)] = 1.0
        fv = 0.0 if entry.viscous is None else float(sp.sympify(entry.viscous).xreplace(values))
        fc = 0.0 if entry.coulomb is None else float(sp.sympify(entry.coulomb).xreplace(values))
        viscous += fv * np.outer(a, a)
        directions.append(a)
        coulomb.append(fc)
    columns = np.array(directions).T if directions else np.zeros((n, 0))
    return JointFriction(viscous, columns, np.array(coulomb, dtype=float))


@dataclass(frozen=True)
class HandleCharacteristics:
    """Janot (18) at one configuration: F_op = M_op ẍ + B_op ẋ + K_op x + F_cop sign(·) + F_d.

    Attributes
    ----------
    mass : Λ = M_op (3×3, kg)
    viscous : B_op = J̄ᵀ F_v J̄ (3×3, N s/m)
    stiffness : K_op = J̄ᵀ K J̄ (3×3, N/m), None when no joint stiffness was given
    coulomb : F_cop = J̄ᵀ [a_i F_Ci] (3×E, N): column i is the force of friction entry i at the point
    coulomb_directions : Aᵀ J̄ (E×3): the sign of row i times ẋ is the sign of entry i's velocity
    """

    mass: np.ndarray
    viscous: np.ndarray
    stiffness: np.ndarray | None
    coulomb: np.ndarray
    coulomb_directions: np.ndarray

    def coulomb_force(self, direction) -> np.ndarray:
        """The dry-friction force (3, N) resisting a motion of the point along ``direction``."""
        u = np.asarray(direction, dtype=float)
        return self.coulomb @ np.sign(self.coulomb_directions @ u)

    def maximum_coulomb(self) -> float:
        """Janot's "maximum value of Coulomb friction, calculated through SVD": the largest singular value of F_cop."""
        return float(np.linalg.svd(self.coulomb, compute_uv=False)[0]) if self.coulomb.size else 0.0


def handle_characteristics(model: DynamicModel, q, p=None, joint_stiffness=None) -> HandleCharacteristics:
    """Apparent mass, viscous friction, stiffness and Coulomb friction at the end effector (Janot (18)).

    Parameters
    ----------
    joint_stiffness : N×N matrix or N vector (its diagonal) of joint stiffnesses, e.g. Janot's K_tot of
        (19) on each motorized joint; None leaves ``stiffness`` None
    """
    jbar = dynamically_consistent_inverse(model, q, p)
    friction = joint_friction(model, q, p)
    stiffness = None
    if joint_stiffness is not None:
        k = np.asarray(joint_stiffness, dtype=float)
        k = np.diag(k) if k.ndim == 1 else k
        stiffness = jbar.T @ k @ jbar
    return HandleCharacteristics(
        mass=operational_inertia(model, q, p),
        viscous=jbar.T @ friction.viscous @ jbar,
        stiffness=stiffness,
        coulomb=jbar.T @ (friction.directions * friction.coulomb),
        coulomb_directions=friction.directions.T @ jbar,
    )


def series_stiffness(*stiffnesses: float) -> float:
    """Janot (19): K_tot = 1/(1/K_T + 1/K_E), springs in series (any number)."""
    if not stiffnesses or any(not k > 0 for k in stiffnesses):
        raise ValueError(f"series stiffness needs positive stiffnesses, got {stiffnesses}")
    return 1.0 / sum(1.0 / k for k in stiffnesses)




@dataclass(frozen=True)
class WorkspaceRow:
    """The apparent mass at one configuration (nominal parameters); masses None where Λ is singular."""

    q: tuple[float, ...]
    along_axes: tuple[float, float, float]  # m_u for u = x, y, z of the base frame
    smallest: float | None  # eigenvalues of Λ, kg
    largest: float | None


WORKSPACE_SEED = 20070410
"""Seed of the configurations sampled for the report (PCG64: the same numbers on every machine)."""


def workspace_samples(model: DynamicModel, count: int, *, seed: int = WORKSPACE_SEED, span: float = np.pi / 2) -> np.ndarray:
    """``count`` configurations: Q = 0, then rigid coordinates uniform in [−span, span] rounded to 0.01 rad
    (so that a printed table states them exactly); beam modal coordinates 0."""
    _check(model)
    rigid = len(model.robot.coordinates)
    rng = np.random.default_rng(seed)
    out = np.zeros((count, model.n))
    out[1:, :rigid] = np.round(rng.uniform(-span, span, (count - 1, rigid)), 2)
    return out


def workspace_points(model: DynamicModel, count: int) -> tuple[np.ndarray, np.ndarray]:
    """End-effector positions (count × 3, base frame) and λ_min, λ_max of Λ there (count × 2; NaN where
    J loses rank), at :func:`workspace_samples`."""
    num = numeric_model(model)
    samples = workspace_samples(model, count)
    points = np.array([num.end_effector_position(q) for q in samples])
    extremes = np.full((count, 2), np.nan)
    for k, q in enumerate(samples):
        try:
            eigenvalues = np.linalg.eigvalsh(operational_inertia(model, q))
        except SingularConfiguration:
            continue
        extremes[k] = eigenvalues[0], eigenvalues[-1]
    return points, extremes


def workspace_axes(model: DynamicModel, count: int) -> np.ndarray:
    """m_u for u = x, y, z of the base frame at :func:`workspace_samples` (count × 3; ``inf`` where the point
    cannot move along u: uᵀΦu not above :data:`SINGULAR_RATIO` × trace Φ). Defined wherever the point moves
    along u, also where Λ is singular: a planar arm's m_x and m_y, whose Λ (J of rank 2) exists nowhere."""
    out = np.full((count, 3), np.inf)
    for k, q in enumerate(workspace_samples(model, count)):
        mobility_u = np.sum(_weights(model, q) ** 2, axis=0)  # uᵀΦu = |W u|² for u = e_x, e_y, e_z (apparent_mass)
        # as the singular test of Λ: a mobility at rounding level (a cos(π/2) in the geometry) is no motion
        moving = mobility_u > SINGULAR_RATIO * mobility_u.sum()
        out[k, moving] = 1.0 / mobility_u[moving]
    return out


def workspace_table(model: DynamicModel, count: int = 9) -> list[WorkspaceRow]:
    """The apparent mass along the base axes and the extreme eigenvalues of Λ at :func:`workspace_samples`."""
    rows = []
    for q in workspace_samples(model, count):
        axes = tuple(apparent_mass(model, q, e) for e in np.eye(3))
        try:
            eigenvalues = np.linalg.eigvalsh(operational_inertia(model, q))
            smallest, largest = float(eigenvalues[0]), float(eigenvalues[-1])
        except SingularConfiguration:
            smallest = largest = None
        rows.append(WorkspaceRow(tuple(float(x) for x in q), axes, smallest, largest))
    return rows


__all__ = ["HandleCharacteristics", "JointFriction", "NoEndEffector", "SINGULAR_RATIO", "SingularConfiguration",
           "WORKSPACE_SEED", "WorkspaceRow", "workspace_axes", "workspace_points", "workspace_samples", "workspace_table",
           "apparent_mass", "dynamically_consistent_inverse", "handle_characteristics", "joint_friction",
           "least_energy_velocity", "mobility", "operational_inertia", "series_stiffness"]

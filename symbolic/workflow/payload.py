"""A rigid payload on the last body of a chain: its columns (:func:`structure`), and its physical parameters
from their coefficients (:meth:`PayloadStructure.parameters`, :func:`fit`). The method, and what it finds on the
tests' arms: docs/workflow.md, "3. Name: the catalogue" (`payload`).
"""

from __future__ import annotations

import dataclasses
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.optimize
import sympy as sp

from symbolic.description.robot import Body, Robot, coordinate_symbol

INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
"""The standard parameters of a body, in the regressor's order (:mod:`symbolic.derivation.regressor`)."""
PHYSICAL = ("mass", "com_x", "com_y", "com_z", "ixx", "iyy", "izz", "ixy", "ixz", "iyz")
"""The payload's roles: mass (kg), centre of mass in F (m), inertia tensor about it in F's axes (kg·m²)."""
TYPICAL = np.array([1.0, 0.1, 0.1, 0.1, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01])
"""Scales of the physical parameters for the rank decisions (a kilogram, ten centimetres)."""
RANK = 1e-6
"""A payload combination whose part outside the model's span is below this (columns of unit norm) is in the model."""
DETERMINED = 1e-6
"""A physical parameter is determined when its component in the fit Jacobian's null space is below this."""
PRIOR = 1e-6
"""Weight of the pull towards c = 0, I_c = 0 relative to γ: it decides only what γ leaves free."""
STATES = 300
"""Random states for the span decision (each gives N rows)."""

_STRUCTURES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class PayloadStructure:
    """A payload on ``frame`` of a model: its columns and how their coefficients give its parameters.

    Attributes
    ----------
    frame
        The frame it is fixed to.
    coordinate
        The last generalized coordinate that moves the frame (the candidate is tested, and reported, there).
    A
        r × 10: the coefficients of the columns, γ = A·π.
    rigid
        Whether the data determine a rigid body (mass, centre of mass and inertia) or a point mass only.
    determined
        For each of :data:`PHYSICAL`, whether γ determines it.
    reason
        Why no payload can be told apart on this frame (``None`` when one can).
    """

    frame: str
    coordinate: str
    A: np.ndarray = dataclasses.field(repr=False)
    rigid: bool
    determined: tuple[bool, ...]
    reason: str | None
    evaluate: Callable[..., np.ndarray] = dataclasses.field(repr=False)
    transform: np.ndarray = dataclasses.field(repr=False)

    @property
    def size(self) -> int:
        return self.A.shape[0]

    def columns(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Z = Y_π·D⁻¹·V at the states: ``samples × N × r``."""
        return self.evaluate(q, qd, qdd) @ self.transform

    def parameters(self, gamma: np.ndarray, start: np.ndarray | None = None) -> dict[str, float | None]:
        """The payload's roles from the coefficients ``gamma`` (:func:`fit`, as a rigid body or a point mass as
        :attr:`rigid` says); ``None`` where not determined."""
        x = fit(self.A, np.asarray(gamma, float), self.rigid, start)
        return {name: (float(v) if ok else None) for name, v, ok in zip(PHYSICAL, x, self.determined)}


def standard(x: np.ndarray) -> np.ndarray:
    """π = (XX, XY, XZ, YY, YZ, ZZ, MX, MY, MZ, M), the ten standard parameters about the frame's origin in its
    axes (Khalil & Dombre 14.2), from (m, c, I_c entries xx, yy, zz, xy, xz, yz): M = m, (MX, MY, MZ) = m·c,
    J_O = I_c + m·(cᵀc·E − c·cᵀ) (the parallel-axis theorem)."""
    m, c = x[0], x[1:4]
    xx, yy, zz, xy, xz, yz = x[4:10]
    inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    J = inertia + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2], *(m * c), m])


def _jacobian(A: np.ndarray, x: np.ndarray, active: np.ndarray) -> np.ndarray:
    """∂(A·π)/∂x on the active parameters, by central differences, scaled by :data:`TYPICAL`."""
    columns = []
    for k in np.flatnonzero(active):
        step = 1e-6 * TYPICAL[k]
        up, down = x.copy(), x.copy()
        up[k] += step
        down[k] -= step
        columns.append(A @ (standard(up) - standard(down)) / (2 * step) * TYPICAL[k])
    return np.column_stack(columns)


def _determined(J: np.ndarray) -> np.ndarray:
    """Which columns of J lie outside its null space (the parameters the fit determines)."""
    _, s, Vt = np.linalg.svd(J)
    rank = int(np.sum(s > 1e-8 * s.max(initial=0.0)))
    null = Vt[rank:]
    return np.array([not null.size or np.linalg.norm(null[:, k]) < DETERMINED for k in range(J.shape[1])])


def fit(A: np.ndarray, gamma: np.ndarray, rigid: bool, start: np.ndarray | None = None) -> np.ndarray:
    """(m, c, I_c) minimising ‖A·π(m, c, I_c) − γ‖ with a weak pull of c and I_c towards 0 for what γ leaves free
    (I_c = 0 unless ``rigid``). γ's components are torques at random states, one scale for all."""
    active = np.ones(10, bool) if rigid else np.arange(10) < 4
    scale = max(float(np.linalg.norm(gamma)), 1e-300)
    x0 = np.zeros(10)
    if start is not None:
        x0[active] = np.asarray(start, float)[active]
    else:
        x0[0] = _mass_guess(A, gamma)

    def residual(z: np.ndarray) -> np.ndarray:
        x = np.zeros(10)
        x[active] = z * TYPICAL[active]
        pull = PRIOR * scale * z[1:]  # not on the mass
        return np.concatenate([A @ standard(x) - gamma, pull])

    z = scipy.optimize.least_squares(residual, x0[active] / TYPICAL[active], method="lm", xtol=1e-15, ftol=1e-15,
                                     gtol=1e-15, max_nfev=2000).x
    x = np.zeros(10)
    x[active] = z * TYPICAL[active]
    return x


def _mass_guess(A: np.ndarray, gamma: np.ndarray) -> float:
    """A start for the mass: the M component of the least-norm π with A·π = γ, or 1 kg when it is not positive."""
    pi = np.linalg.lstsq(A, gamma, rcond=None)[0]
    return float(pi[9]) if pi[9] > 0 else 1.0


def chain_ends(robot: Robot) -> dict[str, str]:
    """{last coordinate: frame} of each chain's end: the frames no other frame hangs from, each reported on
    the last generalized coordinate that moves it (the deepest such frame per coordinate); the model's
    ``[end_effector]`` frame takes the place of its chain's end."""
    order = list(robot.generalized_coordinates)
    parents = {f.name: f.parent for f in robot.frames}
    leaves = [f.name for f in robot.frames if f.name not in set(parents.values())]
    if robot.end_effector is not None:
        leaves = [robot.end_effector.frame] + [f for f in leaves if f != robot.end_effector.frame]

    def depth(frame: str) -> int:
        count = 0
        while frame in parents:
            frame, count = parents[frame], count + 1
        return count

    out: dict[str, str] = {}
    for frame in leaves:
        moving = moving_coordinates(robot, frame)
        if not moving:
            continue
        last = max(moving, key=order.index)
        keep = out.get(last)
        if keep is None or (keep != getattr(robot.end_effector, "frame", None) and depth(frame) > depth(keep)):
            out[last] = frame
    return out


def moving_coordinates(robot: Robot, frame: str) -> list[str]:
    """The generalized coordinates in the DH entries of ``frame`` and its ancestors."""
    by_name = {f.name: f for f in robot.frames}
    symbols = {coordinate_symbol(c): c for c in robot.generalized_coordinates}
    substitution = robot.constraint_substitution
    found: set[str] = set()
    while frame in by_name:
        f = by_name[frame]
        for key in ("theta", "d"):
            free = sp.sympify(getattr(f, key)).xreplace(substitution).free_symbols
            found |= {symbols[s] for s in free if s in symbols}
        frame = f.parent
    return sorted(found, key=list(robot.generalized_coordinates).index)


def structure(model: Any, frame: str, coordinate: str, terms: Any = None) -> PayloadStructure:
    """The :class:`PayloadStructure` of a payload on ``frame`` of ``model`` against the free columns of
    ``terms`` (:class:`symbolic.workflow.terms.ModelTerms`, the model's terms as the search fits them;
    ``None``: every parameter free). A parameter kept at its value (``fixed = true``, ``--fix``) is not free:
    its columns are known and span nothing a payload could hide in. Once per model, frame and free set.

    A payload fixed to the frame adds to τ the generalized force of a rigid body, linear in π (:func:`standard`).
    Only the part of its columns Y_π that the model's free parameters do not span can be told apart from a
    change of those parameters: at :data:`STATES` random states (as :mod:`symbolic.numeric.base_parameters`
    finds base parameters) Y_π's columns, each scaled to unit norm (D), are projected off the span of the
    model's free base columns, and the right singular vectors V of what is left, singular values above
    :data:`RANK`, give the effect's columns Z = Y_π·D⁻¹·V and their coefficients γ = A·π, A = Vᵀ·D. The rest
    of π moves the model's own parameters (a payload on a link whose inertial parameters are free only
    changes them: no column is left and the payload is "in the model"). The payload is a rigid body when
    (m, c, I_c) then determine the mass and more than a point mass would, else a point mass (I_c = 0); a
    parameter is determined when it lies outside the null space of the fit's Jacobian (:func:`_determined`,
    as :mod:`symbolic.identify.consistent` decides it)."""
    if terms is None:
        from symbolic.workflow.terms import model_terms

        terms = model_terms(model)
    cache = _STRUCTURES.setdefault(model, {})
    key = (frame, terms.fixed, np.asarray(terms.free, bool).tobytes())
    if key not in cache:
        cache[key] = _structure(model, frame, coordinate, terms)
    return cache[key]


def _structure(model: Any, frame: str, coordinate: str, terms: Any) -> PayloadStructure:
    from symbolic.codegen.functions import compile_vectorized
    from symbolic.derivation.regressor import regressor
    from symbolic.description.validation import validate

    robot = model.robot
    lone = validate(dataclasses.replace(robot, name=f"{robot.name}_payload", bodies=(Body("payload", frame, 1),),
                                        frictions=(), drives=(), forces=(), beams=(), validated=False))
    reg = regressor(lone)  # the body's ten standard parameters, in INERTIAL order
    n = model.n
    # the point is fixed in its frame: a beam's modal coordinates (not in ``lone``) do not move it, their rows stay 0
    rows = [list(robot.generalized_coordinates).index(c) for c in lone.generalized_coordinates]
    Y = sp.zeros(n, len(reg.theta))
    for k, row in enumerate(rows):
        Y[row, :] = reg.Y[k, :]
    raw = compile_vectorized(reg.sub, [model.coordinates, model.velocities, model.accelerations, model.parameter_symbols],
                             Y, (n, len(reg.theta)))
    p = np.array([model.parameters[s] for s in model.parameter_symbols], float)

    def evaluate(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return raw(q, qd, qdd, p)

    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-np.pi, np.pi, (STATES, n)), rng.uniform(-3, 3, (STATES, n)), rng.uniform(-10, 10, (STATES, n))
    W = evaluate(q, qd, qdd).reshape(STATES * n, -1)
    t = rng.uniform(0.0, 10.0, STATES) if getattr(terms.regressor, "time_varying", False) else None
    F = terms.regressor(q, qd, qdd, t=t)[:, :, terms.free].reshape(STATES * n, -1)
    norms = np.linalg.norm(W, axis=0)
    acting = norms > 1e-8 * norms.max(initial=0.0)
    scaled = np.zeros_like(W)
    scaled[:, acting] = W[:, acting] / norms[acting]
    if F.shape[1]:
        Q = np.linalg.qr(F / np.maximum(np.linalg.norm(F, axis=0), 1e-300))[0]
        scaled = scaled - Q @ (Q.T @ scaled)
    _, s, Vt = np.linalg.svd(scaled, full_matrices=False)
    V = Vt[s > RANK].T  # 10 × r
    inverse = np.zeros(10)
    inverse[acting] = 1.0 / norms[acting]
    transform = inverse[:, None] * V
    A = V.T * np.where(acting, norms, 0.0)[None, :]
    generic = np.array([1.0, 0.05, 0.04, 0.03, 0.01, 0.012, 0.008, 0.001, 0.002, 0.0015])
    if V.shape[1] == 0:
        return PayloadStructure(frame, coordinate, A, False, (False,) * 10,
                                "the model's free parameters already hold it (a payload there only changes them)",
                                evaluate, transform)
    point = _determined(_jacobian(A, generic, np.arange(10) < 4))
    body = _determined(_jacobian(A, generic, np.ones(10, bool)))
    rigid = bool(body[0] and body[4:].any())
    determined = tuple(bool(v) for v in body) if rigid else tuple(bool(v) for v in point) + (False,) * 6
    reason = None if determined[0] else ("its mass is not separable from the model's free parameters (a payload "
                                         "there changes them)")
    return PayloadStructure(frame, coordinate, A, rigid, determined, reason, evaluate, transform)


def physical_inertia(roles: dict[str, float | None]) -> dict[str, float]:
    """The inertia tensor to write for a rigid payload: the determined entries, negative principal moments
    clipped to 0 (positive semidefinite), and the undetermined diagonal entries (which the data do not
    see) raised together by the least amount that satisfies the triangle inequality of the principal
    moments (a physical body); undetermined products of inertia are 0."""
    keys = ("xx", "yy", "zz", "xy", "xz", "yz")
    value = {k: roles.get(f"i{k}") for k in keys}
    free = [i for i, k in enumerate(("xx", "yy", "zz")) if value[k] is None]

    def tensor(extra: float) -> np.ndarray:
        v = {k: (0.0 if value[k] is None else float(value[k])) for k in keys}
        T = np.array([[v["xx"], v["xy"], v["xz"]], [v["xy"], v["yy"], v["yz"]], [v["xz"], v["yz"], v["zz"]]])
        T[free, free] += extra
        w, U = np.linalg.eigh(T)
        return (U * np.clip(w, 0.0, None)) @ U.T

    def violation(T: np.ndarray) -> float:
        a, b, c = np.linalg.eigvalsh(T)
        return c - a - b

    T = tensor(0.0)
    if free and violation(T) > 1e-12 * max(np.abs(T).max(), 1e-300):
        high = max(float(np.trace(T)), 1e-300)
        while violation(tensor(high)) > 0:
            high *= 2.0
        low = 0.0
        for _ in range(60):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if violation(tensor(middle)) > 0 else (low, middle)
        T = tensor(high)
    return {"xx": T[0, 0], "yy": T[1, 1], "zz": T[2, 2], "xy": T[0, 1], "xz": T[0, 2], "yz": T[1, 2]}

"""Build a Pinocchio model from a serial DH robot spec, independently of symbolic's derivation.

Only the spec's numbers are shared (DH rows, masses, centres of mass, inertias, gravity); the
kinematics and dynamics come from Pinocchio's SE3 algebra and algorithms (crba, rnea,
computeGeneralizedGravity, computeCoriolisMatrix).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

try:
    import pinocchio as pin
except ImportError:  # the reference checks skip where Pinocchio (pip install pin, in [dev]) is absent
    pin = None

from symbolic.description.robot import Robot


def require_pinocchio() -> None:
    """Skip the calling test where Pinocchio is not installed."""
    if pin is None:
        pytest.skip("Pinocchio is not installed: pip install pin (it comes with pip install -e '.[dev]')")


def _rot_x(alpha: float) -> pin.SE3:
    return pin.SE3(pin.utils.rotate("x", alpha), np.zeros(3))


def _rot_z(theta: float) -> pin.SE3:
    return pin.SE3(pin.utils.rotate("z", theta), np.zeros(3))


def _trans(x: float, y: float, z: float) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array([x, y, z]))


def _value(expr: sp.Expr, values) -> float:
    return float(expr.xreplace(values))


def build(robot: Robot) -> pin.Model:
    """A Pinocchio model with one revolute-z joint per frame (θ = q + constant, everything else fixed)."""
    require_pinocchio()
    values = robot.parameter_values
    coords = robot.coordinate_symbols
    model = pin.Model()
    model.gravity.linear = np.array([_value(g, values) for g in robot.gravity])
    joint_of: dict[str, int] = {"base": 0}
    post_of: dict[str, pin.SE3] = {"base": pin.SE3.Identity()}
    for index, frame in enumerate(robot.frames):
        (q,) = [c for c in coords if frame.theta.has(c)]
        offset = _value(frame.theta - q, values)
        assert not any(getattr(frame, k).has(*coords) for k in ("d", "a", "alpha"))
        d, a, alpha = (_value(getattr(frame, k), values) for k in ("d", "a", "alpha"))
        if robot.convention == "standard":
            pre, post = _rot_z(offset), _trans(0, 0, d) * _trans(a, 0, 0) * _rot_x(alpha)
        else:
            pre, post = _rot_x(alpha) * _trans(a, 0, 0) * _rot_z(offset), _trans(0, 0, d)
        placement = post_of[frame.parent] * pre
        assert coords.index(q) == index, "reference builder expects frames in coordinate order"
        joint_of[frame.name] = model.addJoint(joint_of[frame.parent], pin.JointModelRZ(), placement, f"j_{frame.name}")
        post_of[frame.name] = post
    for body in robot.bodies:
        i = body.inertia
        inertia = np.array(
            [[i["xx"], i["xy"], i["xz"]], [i["xy"], i["yy"], i["yz"]], [i["xz"], i["yz"], i["zz"]]], dtype=object
        )
        inertia = np.vectorize(lambda e: _value(sp.sympify(e), values))(inertia).astype(float)
        com = np.array([_value(c, values) for c in body.com])
        Y = pin.Inertia(_value(body.mass, values), com, inertia)
        model.appendBodyToJoint(joint_of[body.frame], Y, post_of[body.frame])
    return model


class Reference:
    """Pinocchio's answers for a robot at a state."""

    def __init__(self, robot: Robot) -> None:
        require_pinocchio()
        self.model = build(robot)
        self.data = self.model.createData()

    def inertia(self, q) -> np.ndarray:
        M = pin.crba(self.model, self.data, np.asarray(q, float)).copy()
        return np.triu(M) + np.triu(M, 1).T

    def gravity(self, q) -> np.ndarray:
        return pin.computeGeneralizedGravity(self.model, self.data, np.asarray(q, float)).copy()

    def rnea(self, q, qd, qdd) -> np.ndarray:
        return pin.rnea(self.model, self.data, *(np.asarray(x, float) for x in (q, qd, qdd))).copy()

    def coriolis_vector(self, q, qd) -> np.ndarray:
        return self.rnea(q, qd, np.zeros(len(q))) - self.gravity(q)

    def coriolis_matrix(self, q, qd) -> np.ndarray:
        return pin.computeCoriolisMatrix(self.model, self.data, np.asarray(q, float), np.asarray(qd, float)).copy()

    def rnea_derivatives(self, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
        """∂τ/∂q, ∂τ/∂q̇ by ``computeRNEADerivatives`` (Carpentier & Mansard, RSS 2018)."""
        dq, dqd, _ = pin.computeRNEADerivatives(self.model, self.data, *(np.asarray(x, float) for x in (q, qd, qdd)))
        return dq.copy(), dqd.copy()

    def aba_derivatives(self, q, qd, tau) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ = D⁻¹ by ``computeABADerivatives`` (D⁻¹ symmetrised from its upper triangle)."""
        dq, dqd, minv = pin.computeABADerivatives(self.model, self.data, *(np.asarray(x, float) for x in (q, qd, tau)))
        return dq.copy(), dqd.copy(), np.triu(minv) + np.triu(minv, 1).T


class UrdfReference:
    """Pinocchio's answers for a URDF file (``buildModelFromUrdf``, mimic joints as mimics), in the order
    and the names of ``coordinates`` (symbolic's coordinates, named after the URDF joints).

    Continuous joints take (cos q, sin q) in Pinocchio's configuration; a mimic joint has no velocity of
    its own there, as it has none in symbolic (a constrained coordinate).
    """

    def __init__(self, path, coordinates, xml: str | None = None, mimic: bool = True, model: pin.Model | None = None) -> None:
        """``mimic=False`` builds mimic joints as independent ones (their velocity 0 here): Pinocchio's
        joint-torque regressor does not support mimic joints. ``model``: a Pinocchio model built otherwise."""
        require_pinocchio()
        if model is None:
            model = pin.buildModelFromXML(xml, mimic=mimic) if xml is not None else pin.buildModelFromUrdf(str(path), mimic=mimic)
        self.model = model
        self.data = self.model.createData()
        names = list(self.model.names)
        joints = [self.model.joints[names.index(c)] for c in coordinates]
        assert self.model.nv == len(coordinates) or not mimic, (self.model.nv, coordinates)
        self.index = [j.idx_v for j in joints]

    def configuration(self, q) -> np.ndarray:
        v = np.zeros(self.model.nv)
        v[self.index] = q
        out = pin.neutral(self.model)
        for j in self.model.joints[1:]:
            if j.nv == 1 and j.nq == 2:
                out[j.idx_q:j.idx_q + 2] = np.cos(v[j.idx_v]), np.sin(v[j.idx_v])
            elif j.nv == 1:
                out[j.idx_q] = v[j.idx_v]
        return out

    def tangent(self, x) -> np.ndarray:
        v = np.zeros(self.model.nv)
        v[self.index] = x
        return v

    def ours(self, x) -> np.ndarray:
        return np.asarray(x)[self.index]

    def inertia(self, q) -> np.ndarray:
        M = pin.crba(self.model, self.data, self.configuration(q)).copy()
        M = np.triu(M) + np.triu(M, 1).T
        return M[np.ix_(self.index, self.index)]

    def gravity(self, q) -> np.ndarray:
        return self.ours(pin.computeGeneralizedGravity(self.model, self.data, self.configuration(q)))

    def rnea(self, q, qd, qdd) -> np.ndarray:
        return self.ours(pin.rnea(self.model, self.data, self.configuration(q), self.tangent(qd), self.tangent(qdd)))

    def coriolis_vector(self, q, qd) -> np.ndarray:
        return self.rnea(q, qd, np.zeros(len(q))) - self.gravity(q)

    def rnea_derivatives(self, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
        """∂τ/∂q, ∂τ/∂q̇ by ``computeRNEADerivatives``, rows and columns in symbolic's order (joints with one
        velocity: the tangent of a continuous joint is its angle)."""
        dq, dqd, _ = pin.computeRNEADerivatives(self.model, self.data, self.configuration(q), self.tangent(qd), self.tangent(qdd))
        block = np.ix_(self.index, self.index)
        return dq[block].copy(), dqd[block].copy()

    def aba_derivatives(self, q, qd, tau) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """∂q̈/∂q, ∂q̈/∂q̇, ∂q̈/∂τ = D⁻¹ by ``computeABADerivatives`` (a model without mimic joints: every velocity
        is one of symbolic's), in symbolic's order; D⁻¹ symmetrised from its upper triangle."""
        assert self.model.nv == len(self.index), "ABA derivatives of a model whose velocities are all symbolic's"
        dq, dqd, minv = pin.computeABADerivatives(self.model, self.data, self.configuration(q), self.tangent(qd), self.tangent(tau))
        block = np.ix_(self.index, self.index)
        return dq[block].copy(), dqd[block].copy(), (np.triu(minv) + np.triu(minv, 1).T)[block]

    def regressor(self, q, qd, qdd) -> np.ndarray:
        """Pinocchio's joint-torque regressor: 10 columns per joint body (m, m·c, I about the joint origin:
        xx, xy, yy, xz, yz, zz), rows in symbolic's order."""
        Y = pin.computeJointTorqueRegressor(self.model, self.data, self.configuration(q), self.tangent(qd), self.tangent(qdd))
        return Y[self.index]

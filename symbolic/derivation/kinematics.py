"""Frame kinematics: DH transforms, R and d per frame, J^v and J^Ω (Madill 3.4–3.6).

Each frame's motion relative to its parent is the DH joint: a rotation θ about and a
translation d along the joint axis, whose rates are linear in Q̇ because θ and d are expressions
of the coordinates (θ̇ = Σ_k ∂θ/∂Q_k Q̇_k). Jacobians are accumulated recursively in each
frame's own coordinates — the body-frame angular Jacobian is exactly Madill's J^Ω of (3.52),
Ω = Rᵀω = J^Ω Q̇, and J^v = ∂d/∂Q of (3.53) is R times the body-frame linear Jacobian — so no
product of rotation matrices is ever differentiated and sin² + cos² never needs simplifying.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from symbolic.description.robot import BASE, Robot
from symbolic.derivation.subexpressions import Subexpressions

Vec = sp.Matrix
ZERO3 = sp.ImmutableMatrix.zeros(3, 1)
E_X = sp.ImmutableMatrix([1, 0, 0])
E_Z = sp.ImmutableMatrix([0, 0, 1])


def dh_transform(convention: str, theta: sp.Expr, d: sp.Expr, a: sp.Expr, alpha: sp.Expr) -> sp.Matrix:
    """Homogeneous transform of one DH row.

    Standard: ``A(θ,d,a,α) = Rz(θ)·Tz(d)·Tx(a)·Rx(α)`` (Madill's A, section 3.13).
    Modified (Khalil–Kleinfinger, Craig): ``Rx(α)·Tx(a)·Rz(θ)·Tz(d)`` (Janot Table 1).
    """
    ct, st, ca, sa = sp.cos(theta), sp.sin(theta), sp.cos(alpha), sp.sin(alpha)
    if convention == "standard":
        return sp.Matrix(
            [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]]
        )
    if convention == "modified":
        return sp.Matrix([[ct, -st, 0, a], [ca * st, ca * ct, -sa, -sa * d], [sa * st, sa * ct, ca, ca * d], [0, 0, 0, 1]])
    raise ValueError(f"unknown DH convention {convention!r}")


def skew(v: sp.Matrix) -> sp.Matrix:
    """S(v) with S(v)x = v × x (Madill Appendix D)."""
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def unskew(m: sp.Matrix) -> sp.Matrix:
    """S⁻¹(A) = [a32, a13, a21]ᵀ for a skew-symmetric A (Madill (3.51))."""
    return sp.Matrix([m[2, 1], m[0, 2], m[1, 0]])


def cross(u: sp.Matrix, v: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]])


def _rz(c: sp.Expr, s: sp.Expr, x: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([c * x[0] - s * x[1], s * x[0] + c * x[1], x[2]])


def _rx(c: sp.Expr, s: sp.Expr, x: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([x[0], c * x[1] - s * x[2], s * x[1] + c * x[2]])


def _ry(c: sp.Expr, s: sp.Expr, x: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([c * x[0] + s * x[2], x[1], -s * x[0] + c * x[2]])


_ELEMENTARY = {"x": _rx, "y": _ry, "z": _rz}
_PLANE = {"z": (0, 1, 2), "x": (1, 2, 0), "y": (2, 0, 1)}
"""Axis -> (i, j, k): the rotation turns e_i towards e_j about e_k."""


def _elementary_matrix(axis: str, c: sp.Expr, s: sp.Expr) -> sp.Matrix:
    i, j, k = _PLANE[axis]
    r = sp.zeros(3, 3)
    r[i, i], r[i, j], r[j, i], r[j, j], r[k, k] = c, -s, s, c, 1
    return r


def _rotate_sym(m: sp.Matrix, c: sp.Expr, s: sp.Expr, axis: str, add) -> sp.Matrix:
    """R M Rᵀ for an elementary rotation R about ``axis`` ("x", "y" or "z") by (cos, sin) = (c, s).

    In the rotation plane (i, j) with k the axis: with C₂ = c² − s², S₂ = 2cs, d = (M_ii − M_jj)/2,
    t = d C₂ − M_ij S₂: M'_ii = (M_ii + M_jj)/2 + t, M'_jj = M_ii + M_jj − M'_ii, M'_ij = d S₂ + M_ij C₂,
    M'_ik = c M_ik − s M_jk, M'_jk = s M_ik + c M_jk (18 operations instead of about 40).
    """
    if c.is_Number and s.is_Number:
        r = _elementary_matrix(axis, c, s)
        return (r * m * r.T).applyfunc(add)
    i, j, k = _PLANE[axis]
    c2, s2 = add(c * c - s * s), add(2 * c * s)
    total = add(m[i, i] + m[j, j])
    d = add((m[i, i] - m[j, j]) / 2)
    t = add(d * c2 - m[i, j] * s2)
    out = sp.zeros(3, 3)
    out[i, i] = add(total / 2 + t)
    out[j, j] = add(total - out[i, i])
    out[i, j] = out[j, i] = add(d * s2 + m[i, j] * c2)
    out[i, k] = out[k, i] = add(c * m[i, k] - s * m[j, k])
    out[j, k] = out[k, j] = add(s * m[i, k] + c * m[j, k])
    out[k, k] = m[k, k]
    return out


@dataclass
class FrameKinematics:
    """Kinematic quantities of one frame, in intermediates of a shared :class:`Subexpressions`.

    Attributes
    ----------
    theta_rate, d_rate
        ∂θ/∂Q_k and ∂d/∂Q_k for the coordinates the frame's DH row depends on.
    theta_twist, d_twist
        (angular, linear) velocity of the frame relative to its parent, in frame coordinates,
        per unit θ̇ and per unit ḋ.
    p_child
        Vector from the parent's origin to this origin, in this frame's coordinates.
    JO, JL
        Body-frame angular (Madill's J^Ω, (3.52)) and origin-velocity Jacobians, by coordinate.
    R, origin
        Orientation and origin in the base frame (Madill's R and d, (3.42)).
    """

    name: str
    parent: str
    convention: str
    theta: sp.Expr
    d: sp.Expr
    a: sp.Expr
    alpha: sp.Expr
    cos_theta: sp.Expr
    sin_theta: sp.Expr
    cos_alpha: sp.Expr
    sin_alpha: sp.Expr
    theta_rate: dict[sp.Symbol, sp.Expr] = field(default_factory=dict)
    d_rate: dict[sp.Symbol, sp.Expr] = field(default_factory=dict)
    theta_twist: tuple[sp.Matrix, sp.Matrix] = (ZERO3, ZERO3)
    d_twist: tuple[sp.Matrix, sp.Matrix] = (ZERO3, ZERO3)
    theta_sq_accel: sp.Matrix = field(default=ZERO3)
    p_child: sp.Matrix = field(default=ZERO3)
    p_parent: sp.Matrix = field(default=ZERO3)
    JO: dict[sp.Symbol, sp.Matrix] = field(default_factory=dict)
    JL: dict[sp.Symbol, sp.Matrix] = field(default_factory=dict)
    R: sp.Matrix = field(default_factory=lambda: sp.eye(3))
    origin: sp.Matrix = field(default=ZERO3)

    @property
    def coordinates(self) -> list[sp.Symbol]:
        """Coordinates moving this frame relative to its parent, in a stable order."""
        return sorted(set(self.theta_rate) | set(self.d_rate), key=sp.default_sort_key)

    def to_child(self, x: sp.Matrix) -> sp.Matrix:
        """Rᵀx: a parent-frame vector in this frame's coordinates."""
        if self.convention == "standard":
            return _rx(self.cos_alpha, -self.sin_alpha, _rz(self.cos_theta, -self.sin_theta, x))
        return _rz(self.cos_theta, -self.sin_theta, _rx(self.cos_alpha, -self.sin_alpha, x))

    def to_parent(self, x: sp.Matrix) -> sp.Matrix:
        """Rx: a vector in this frame's coordinates in the parent's."""
        if self.convention == "standard":
            return _rz(self.cos_theta, self.sin_theta, _rx(self.cos_alpha, self.sin_alpha, x))
        return _rx(self.cos_alpha, self.sin_alpha, _rz(self.cos_theta, self.sin_theta, x))

    @property
    def shift_in_child(self) -> bool:
        """Whether translations are cheaper in child coordinates.

        Standard DH has a constant offset in the child frame, p_child = (a, d sα, d cα); modified DH in
        the parent frame, p_parent = (a, −d sα, d cα). Shifting where the offset is constant (and
        sparse) avoids products with sin θ, cos θ.
        """
        return self.convention == "standard"

    def motion_to_child(self, w: sp.Matrix, v: sp.Matrix, add) -> tuple[sp.Matrix, sp.Matrix]:
        """A parent motion (ω, velocity of the parent origin) at this origin, in this frame: (Rᵀω, Rᵀ(v + ω × p))."""
        if self.shift_in_child:
            w_c = self.to_child(w).applyfunc(add)
            return w_c, (self.to_child(v) + cross(w_c, self.p_child)).applyfunc(add)
        return self.to_child(w).applyfunc(add), self.to_child((v + cross(w, self.p_parent)).applyfunc(add)).applyfunc(add)

    def force_to_parent(self, n: sp.Matrix, f: sp.Matrix, add) -> tuple[sp.Matrix, sp.Matrix]:
        """A wrench (moment about this origin, force) as seen at the parent origin, in parent axes."""
        if self.shift_in_child:
            n_shifted = (n + cross(self.p_child, f)).applyfunc(add)
            return self.to_parent(n_shifted).applyfunc(add), self.to_parent(f).applyfunc(add)
        f_p = self.to_parent(f).applyfunc(add)
        return (self.to_parent(n) + cross(self.p_parent, f_p)).applyfunc(add), f_p

    def rotate_symmetric_to_parent(self, m: sp.Matrix, add) -> sp.Matrix:
        """R M Rᵀ for a symmetric M, one elementary rotation at a time."""
        if self.convention == "standard":
            return _rotate_sym(_rotate_sym(m, self.cos_alpha, self.sin_alpha, "x", add), self.cos_theta, self.sin_theta, "z", add)
        return _rotate_sym(_rotate_sym(m, self.cos_theta, self.sin_theta, "z", add), self.cos_alpha, self.sin_alpha, "x", add)

    def local_rotation(self) -> sp.Matrix:
        cols = [self.to_parent(sp.Matrix([int(i == j) for j in range(3)])) for i in range(3)]
        return sp.Matrix.hstack(*cols)

    def joint_twist(self, q: sp.Symbol) -> tuple[sp.Matrix, sp.Matrix]:
        """(angular, linear) relative velocity per unit Q̇_q, in this frame's coordinates."""
        wt, vt = self.theta_twist
        wd, vd = self.d_twist
        kt, kd = self.theta_rate.get(q, 0), self.d_rate.get(q, 0)
        return wt * kt + wd * kd, vt * kt + vd * kd


def origin_rotation(rpy: tuple[sp.Expr, sp.Expr, sp.Expr]) -> sp.Matrix:
    """URDF's fixed-axis roll, pitch, yaw: Rot(rpy) = Rz(yaw)·Ry(pitch)·Rx(roll) (URDF spec, <origin>).

    Entries that are constant numbers but not rational (cos 0.3) are evaluated once here, in 30 digits
    rounded to a double's 17, so that programs do not recompute them; exact angles (pi/2) stay exact.
    """
    r, p, y = rpy
    m = _elementary_matrix("z", sp.cos(y), sp.sin(y)) * _elementary_matrix("y", sp.cos(p), sp.sin(p))
    m = m * _elementary_matrix("x", sp.cos(r), sp.sin(r))
    return m.applyfunc(lambda e: sp.Float(e.evalf(30), 17) if e.is_number and not e.is_Rational else e)


def axis_rotation(u: sp.Matrix, c: sp.Expr, s: sp.Expr) -> sp.Matrix:
    """Rotation by (cos, sin) = (c, s) about the unit axis u (Rodrigues: c E + s S(u) + (1 − c) u uᵀ)."""
    return c * sp.eye(3) + s * skew(u) + (1 - c) * u * u.T


@dataclass
class JointFrameKinematics(FrameKinematics):
    """A general frame (URDF joint): ``T = [C, xyz]·Rot(u, θ)·Trans(u d)`` with C = Rot(rpy) constant.

    The child origin lies on the joint axis, so (as in modified DH) the offset is constant in the
    parent's axes, p_parent = xyz + C u d, and the joint's twist is (u, 0) per θ̇ and (0, u) per ḋ in the
    frame's own axes. Rotations are applied as products with C (sparse for right angles: free) and the
    elementary joint rotation about ±x, ±y or ±z (4 products), or Rodrigues' formula for another axis.
    """

    axis: sp.Matrix = field(default=E_Z)
    constant: sp.Matrix = field(default_factory=lambda: sp.eye(3))
    joint_axis: str | None = "z"
    joint_sign: int = 1
    add: object = None

    def _joint(self, x: sp.Matrix, sign: int) -> sp.Matrix:
        """Rot(u, ±θ) x."""
        c, s = self.cos_theta, sign * self.sin_theta
        if self.theta == 0:
            return sp.Matrix(x)
        if self.joint_axis is not None:
            return _ELEMENTARY[self.joint_axis](c, self.joint_sign * s, x)
        u = self.axis
        ux = self.add((u.T * x)[0])
        return (c * x + s * cross(u, x) + (1 - c) * ux * u).applyfunc(self.add)

    def to_child(self, x: sp.Matrix) -> sp.Matrix:
        """Rᵀx = Rot(u, θ)ᵀ Cᵀ x."""
        return self._joint((self.constant.T * x).applyfunc(self.add), -1)

    def to_parent(self, x: sp.Matrix) -> sp.Matrix:
        """Rx = C Rot(u, θ) x."""
        return self.constant * self._joint(x, 1).applyfunc(self.add)

    @property
    def shift_in_child(self) -> bool:
        return False

    def rotate_symmetric_to_parent(self, m: sp.Matrix, add) -> sp.Matrix:
        """C Rot(u, θ) M Rot(u, θ)ᵀ Cᵀ, the upper triangle computed and mirrored (symmetric by construction)."""
        if self.theta != 0:
            if self.joint_axis is not None:
                m = _rotate_sym(m, self.cos_theta, self.joint_sign * self.sin_theta, self.joint_axis, add)
            else:
                r = axis_rotation(self.axis, self.cos_theta, self.sin_theta)
                m = _symmetric_product(r, m, add)
        if self.constant != sp.eye(3):
            m = _symmetric_product(self.constant, m, add)
        return m


def _symmetric_product(r: sp.Matrix, m: sp.Matrix, add) -> sp.Matrix:
    """R M Rᵀ for a symmetric M: R M once, then the upper triangle of (R M) Rᵀ, mirrored."""
    rm = (r * m).applyfunc(add)
    out = sp.zeros(3, 3)
    for i in range(3):
        for j in range(i, 3):
            out[i, j] = out[j, i] = add((rm[i, :] * r[j, :].T)[0])
    return out


def joint_axis_name(u: sp.Matrix) -> tuple[str | None, int]:
    """("x", "y" or "z", ±1) when u = ±e_k, else (None, 1)."""
    for name, k in (("x", 0), ("y", 1), ("z", 2)):
        if all(u[i] == 0 for i in range(3) if i != k) and u[k] in (1, -1):
            return name, int(u[k])
    return None, 1


class Kinematics:
    """Kinematics of all frames of a robot, with constraint expressions substituted.

    Parameters
    ----------
    robot
        The validated robot.
    sub
        Registry receiving the intermediate expressions.
    """

    def __init__(self, robot: Robot, sub: Subexpressions) -> None:
        self.robot = robot
        self.sub = sub
        self.coordinates = robot.coordinate_symbols
        self.frames: dict[str, FrameKinematics] = {}
        constraint = robot.constraint_substitution
        for f in robot.frames:
            values = {k: getattr(f, k).xreplace(constraint) for k in ("theta", "d", "a", "alpha")}
            if f.joint is not None:
                self.frames[f.name] = self._joint_frame(f.name, f.parent, f.joint, values["theta"], values["d"])
            else:
                self.frames[f.name] = self._frame(f.name, f.parent, **values)

    def _joint_frame(self, name: str, parent: str, joint, theta: sp.Expr, d: sp.Expr) -> JointFrameKinematics:
        """A general frame (:class:`JointFrameKinematics`)."""
        add = self.sub.add
        u = sp.ImmutableMatrix(joint.axis)
        axis_name, sign = joint_axis_name(u)
        constant = origin_rotation(joint.rpy).applyfunc(add)
        fk = JointFrameKinematics(
            name=name, parent=parent, convention="joint", theta=theta, d=d, a=sp.Integer(0), alpha=sp.Integer(0),
            cos_theta=add(sp.cos(theta)), sin_theta=add(sp.sin(theta)), cos_alpha=sp.Integer(1), sin_alpha=sp.Integer(0),
            axis=u, constant=constant, joint_axis=axis_name, joint_sign=sign, add=add,
        )
        for q in self.coordinates:
            if theta.has(q):
                fk.theta_rate[q] = add(sp.diff(theta, q))
            if d.has(q):
                fk.d_rate[q] = add(sp.diff(d, q))
        fk.theta_twist = (u, ZERO3)
        fk.d_twist = (ZERO3, u)
        fk.theta_sq_accel = ZERO3
        fk.p_parent = (sp.Matrix(joint.xyz) + constant * u * d).applyfunc(add)
        fk.p_child = fk.to_child(fk.p_parent).applyfunc(add)
        self._jacobians(fk)
        self._placement(fk)
        return fk

    def _frame(self, name: str, parent: str, theta: sp.Expr, d: sp.Expr, a: sp.Expr, alpha: sp.Expr) -> FrameKinematics:
        add = self.sub.add
        fk = FrameKinematics(
            name=name,
            parent=parent,
            convention=self.robot.convention,
            theta=theta,
            d=d,
            a=a,
            alpha=alpha,
            cos_theta=add(sp.cos(theta)),
            sin_theta=add(sp.sin(theta)),
            cos_alpha=add(sp.cos(alpha)),
            sin_alpha=add(sp.sin(alpha)),
        )
        for q in self.coordinates:
            if theta.has(q):
                fk.theta_rate[q] = add(sp.diff(theta, q))
            if d.has(q):
                fk.d_rate[q] = add(sp.diff(d, q))
        ca, sa, ct, st = fk.cos_alpha, fk.sin_alpha, fk.cos_theta, fk.sin_theta
        if fk.convention == "standard":
            u = sp.Matrix([0, sa, ca])
            w = sp.Matrix([0, ca, -sa])
            fk.theta_twist = (u, w * a)
            fk.d_twist = (ZERO3, u)
            fk.theta_sq_accel = -a * E_X
            fk.p_child = sp.Matrix([a, d * sa, d * ca]).applyfunc(add)
            fk.p_parent = sp.Matrix([a * ct, a * st, d]).applyfunc(add)
        else:
            fk.theta_twist = (E_Z, ZERO3)
            fk.d_twist = (ZERO3, E_Z)
            fk.p_child = sp.Matrix([a * ct, -a * st, d]).applyfunc(add)
            fk.p_parent = sp.Matrix([a, -sa * d, ca * d]).applyfunc(add)
        self._jacobians(fk)
        self._placement(fk)
        return fk

    def parent(self, fk: FrameKinematics) -> FrameKinematics | None:
        return None if fk.parent == BASE else self.frames[fk.parent]

    def _jacobians(self, fk: FrameKinematics) -> None:
        """Body Jacobians by recursion: J_f = X_{f←p} J_p + S_f (columns by coordinate)."""
        parent = self.parent(fk)
        add = self.sub.add
        columns = set(fk.coordinates) | (set(parent.JO) if parent else set())
        for q in sorted(columns, key=sp.default_sort_key):
            w_rel, v_rel = fk.joint_twist(q)
            if parent is not None and q in parent.JO:
                w_p, v_p = fk.motion_to_child(parent.JO[q], parent.JL[q], add)
            else:
                w_p, v_p = ZERO3, ZERO3
            fk.JO[q] = (w_p + w_rel).applyfunc(add)
            fk.JL[q] = (v_p + v_rel).applyfunc(add)

    def _placement(self, fk: FrameKinematics) -> None:
        parent = self.parent(fk)
        add = self.sub.add
        local = fk.local_rotation()
        if parent is None:
            fk.R = local.applyfunc(add)
            fk.origin = fk.p_parent
        else:
            fk.R = (parent.R * local).applyfunc(add)
            fk.origin = (parent.origin + parent.R * fk.p_parent).applyfunc(add)

    # -- public quantities ---------------------------------------------------------------
    def rotation(self, frame: str) -> sp.Matrix:
        """R of (3.42): orientation of ``frame`` in the base frame."""
        return sp.eye(3) if frame == BASE else self.frames[frame].R

    def translation(self, frame: str) -> sp.Matrix:
        """d of (3.42): origin of ``frame`` in the base frame."""
        return sp.zeros(3, 1) if frame == BASE else self.frames[frame].origin

    def transform(self, frame: str) -> sp.Matrix:
        """The homogeneous transform H_0^frame of (3.42)."""
        return sp.Matrix.vstack(sp.Matrix.hstack(self.rotation(frame), self.translation(frame)), sp.Matrix([[0, 0, 0, 1]]))

    def _columns(self, table: dict[sp.Symbol, sp.Matrix]) -> sp.Matrix:
        return sp.Matrix.hstack(*[table.get(q, ZERO3) for q in self.coordinates])

    def jacobian_omega(self, frame: str) -> sp.Matrix:
        """J^Ω of (3.52): Ω = Rᵀω = J^Ω Q̇, angular velocity in frame coordinates (3×N)."""
        if frame == BASE:
            return sp.zeros(3, len(self.coordinates))
        return self._columns(self.frames[frame].JO)

    def jacobian_linear_body(self, frame: str) -> sp.Matrix:
        """Rᵀ ḋ = (Rᵀ J^v) Q̇: velocity of the frame origin in frame coordinates (3×N)."""
        if frame == BASE:
            return sp.zeros(3, len(self.coordinates))
        return self._columns(self.frames[frame].JL)

    def jacobian_v(self, frame: str) -> sp.Matrix:
        """J^v = ∂d/∂Q of (3.53), in base coordinates (3×N)."""
        return (self.rotation(frame) * self.jacobian_linear_body(frame)).applyfunc(self.sub.add)

    def point_jacobian(self, frame: str, point: sp.Matrix) -> sp.Matrix:
        """J = J^v − R S(p) J^Ω of (3.56) for a point p fixed in ``frame`` (rigid: no modes)."""
        body = self.jacobian_linear_body(frame) - skew(point) * self.jacobian_omega(frame)
        return (self.rotation(frame) * body).applyfunc(self.sub.add)

    def point_position(self, frame: str, point: sp.Matrix) -> sp.Matrix:
        """p₀ = R p + d of (3.43) for a point p fixed in ``frame``."""
        return (self.rotation(frame) * point + self.translation(frame)).applyfunc(self.sub.add)

    def end_effector_jacobian(self) -> sp.Matrix:
        """Jacobian of the model's end-effector point (3.57); τ = JᵀF maps a base-frame force (3.58)."""
        ee = self.robot.end_effector
        if ee is None:
            raise ValueError(f"model {self.robot.name!r} declares no end_effector")
        return self.point_jacobian(ee.frame, sp.Matrix(ee.point))

    def generalized_force(self, force: sp.Matrix) -> sp.Matrix:
        """τ = JᵀF of (3.58) for a base-frame force F at the end-effector point."""
        return self.end_effector_jacobian().T * force


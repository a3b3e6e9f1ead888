"""The inertia matrix D(Q) from the bodies' kinetic energy (Madill 3.7, 3.9.1).

K = ½ Q̇ᵀ D(Q) Q̇ with K = Σ_b ½ V_bᵀ M_b V_b, V_b = J_b Q̇ the body's spatial velocity and M_b its
spatial inertia at its frame's origin. Grouping the bodies of each subtree into a composite
inertia I^c_f (as in the composite-rigid-body algorithm) gives

    D = Σ_f [ S_fᵀ I^c_f S_f + S_fᵀ I^c_f Jp_f + Jp_fᵀ I^c_f S_f ],

where S_f is frame f's own joint motion (6×N, columns of the coordinates in its DH row) and
Jp_f = J_f − S_f the part of its Jacobian inherited from the parent. Each pair is summed once into
the upper triangle, so D = Dᵀ holds by construction, not by simplification.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from symbolic.derivation.kinematics import FrameKinematics, Kinematics, cross
from symbolic.description.robot import BASE, Body
from symbolic.derivation.subexpressions import Subexpressions


@dataclass
class SpatialInertia:
    """Mass m, first moment h = m·c and rotational inertia I_o about the frame origin (frame axes)."""

    mass: sp.Expr
    moment: sp.Matrix
    rotational: sp.Matrix

    @staticmethod
    def zero() -> SpatialInertia:
        return SpatialInertia(sp.Integer(0), sp.zeros(3, 1), sp.zeros(3, 3))

    @staticmethod
    def of_body(body: Body) -> SpatialInertia:
        """Parallel-axis theorem: I_o = I_c + m (cᵀc E − c cᵀ)."""
        c = sp.Matrix(body.com)
        m = body.mass
        return SpatialInertia(m, m * c, body.inertia_tensor + m * ((c.T * c)[0] * sp.eye(3) - c * c.T))

    @staticmethod
    def total(items: list[SpatialInertia]) -> SpatialInertia:
        """The sum of ``items``, each entry one sum of its terms (adding one at a time re-sorts the growing
        sum at every step: quadratic in the bodies of a frame, links merged through fixed joints)."""
        if not items:
            return SpatialInertia.zero()
        if len(items) == 1:
            return items[0]
        return SpatialInertia(sp.Add(*(i.mass for i in items)), entrywise_sum([i.moment for i in items]),
                              entrywise_sum([i.rotational for i in items]))

    def __add__(self, other: SpatialInertia) -> SpatialInertia:
        return SpatialInertia(self.mass + other.mass, self.moment + other.moment, self.rotational + other.rotational)

    def is_zero(self) -> bool:
        return self.mass == 0 and self.moment.is_zero_matrix and self.rotational.is_zero_matrix

    def registered(self, sub: Subexpressions) -> SpatialInertia:
        rot = self.rotational.applyfunc(sub.add)
        return SpatialInertia(sub.add(self.mass), self.moment.applyfunc(sub.add), rot)

    def apply(self, w: sp.Matrix, v: sp.Matrix) -> tuple[sp.Matrix, sp.Matrix]:
        """Momentum of velocity (ω, v): (I_o ω + h × v, m v + ω × h)."""
        return self.rotational * w + cross(self.moment, v), self.mass * v + cross(w, self.moment)

    def shifted(self, p: sp.Matrix, add) -> SpatialInertia:
        """The same bodies about the point −p (a frame whose origin is at −p from ours): same axes.

        With r' = p + r: h' = h + m p, I' = I_o + m(pᵀp E − p pᵀ) + 2(pᵀh) E − p hᵀ − h pᵀ.
        """
        h, m = self.moment, self.mass
        pp = add((p.T * p)[0])
        ph = add((p.T * h)[0])
        rotational = self.rotational + (m * pp + 2 * ph) * sp.eye(3) - m * p * p.T - p * h.T - h * p.T
        return SpatialInertia(m, (h + m * p).applyfunc(add), rotational.applyfunc(add))

    def rotated(self, fk: FrameKinematics, add) -> SpatialInertia:
        """The same inertia in the parent's axes (about the same point)."""
        return SpatialInertia(self.mass, fk.to_parent(self.moment).applyfunc(add), fk.rotate_symmetric_to_parent(self.rotational, add))

    def to_parent(self, fk: FrameKinematics, add) -> SpatialInertia:
        """The same inertia about the parent's origin, in the parent's axes (shift where the offset is constant)."""
        if fk.shift_in_child:
            return self.shifted(fk.p_child, add).rotated(fk, add)
        return self.rotated(fk, add).shifted(fk.p_parent, add)


def composite_inertias(kin: Kinematics) -> dict[str, SpatialInertia]:
    """I^c_f: inertia of every body in the subtree of frame f, at f's origin in f's axes."""
    sub = kin.sub
    parts: dict[str, list[SpatialInertia]] = {name: [] for name in kin.frames}
    parts[BASE] = []
    for body in kin.robot.bodies:
        parts[body.frame].append(SpatialInertia.of_body(body))
    composite: dict[str, SpatialInertia] = {}
    for name in reversed(list(kin.frames)):
        fk = kin.frames[name]
        composite[name] = SpatialInertia.total(parts[name]).registered(sub)
        if fk.parent != BASE and not composite[name].is_zero():
            parts[fk.parent].append(composite[name].to_parent(fk, sub.add))
    return {name: composite[name] for name in kin.frames}


def entrywise_sum(matrices: list[sp.Matrix]) -> sp.Matrix:
    """Σ ``matrices`` (not empty), each entry one :class:`sympy.Add` of its terms."""
    rows, cols = matrices[0].shape
    return sp.Matrix(rows, cols, lambda i, j: sp.Add(*(m[i, j] for m in matrices)))


def inertia_matrix(kin: Kinematics, composite: dict[str, SpatialInertia] | None = None) -> sp.Matrix:
    """D(Q) (N×N, symmetric by construction) in intermediates of ``kin.sub``.

    Composite-rigid-body form: for each frame f and coordinate k moving it, the momentum
    F = I^c_f S_f[:,k] is carried to every ancestor g by force transforms, and S_g[:,l]ᵀF adds to
    d_kl (Featherstone's CRBA, generalised to DH rows driven by several coordinates).
    """
    composite = composite if composite is not None else composite_inertias(kin)
    coords = list(kin.coordinates)
    index = {q: i for i, q in enumerate(coords)}
    terms: dict[tuple[int, int], list[sp.Expr]] = {}
    add = kin.sub.add

    def accumulate(i: int, j: int, value: sp.Expr) -> None:
        terms.setdefault((min(i, j), max(i, j)), []).append(value)

    def project(fk: FrameKinematics, q: sp.Symbol, n: sp.Matrix, f: sp.Matrix) -> sp.Expr:
        w, v = fk.joint_twist(q)
        return add((w.T * n + v.T * f)[0])

    for name, fk in kin.frames.items():
        inertia = composite[name]
        if inertia.is_zero():
            continue
        own = fk.coordinates
        for a, qa in enumerate(own):
            n, f = (x.applyfunc(add) for x in inertia.apply(*fk.joint_twist(qa)))
            for qb in own[a:]:
                accumulate(index[qa], index[qb], project(fk, qb, n, f))
            child = fk
            while child.parent != BASE:
                n, f = child.force_to_parent(n, f, add)
                child = kin.frames[child.parent]
                for qj in child.coordinates:
                    value = project(child, qj, n, f)
                    accumulate(index[qa], index[qj], 2 * value if qa == qj else value)
    size = len(coords)
    D = sp.zeros(size, size)
    for (i, j), parts in terms.items():
        D[i, j] = D[j, i] = sp.Add(*parts)
    return D

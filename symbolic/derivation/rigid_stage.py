"""The rigid part of a derivation, shared by the descriptions that have the same skeleton.

Everything :func:`symbolic.derivation.dynamics.derive` computes before friction and applied forces —
kinematics, D(Q) with the beams' D_f (Madill (3.76)) and the rotors, ∂D/∂Q, the Christoffel symbols
(Madill (3.81)), the Coriolis terms, gravity and potential energy, strain, and the Newton–Euler τ — depends on
the :data:`~symbolic.description.robot.SKELETON` fields of the robot only: not on its name, its parameters'
values, nor its friction and ``[[force]]`` entries. A model patched by ``symbolic diagnose`` (friction or a
force added, identified values written) has its original's skeleton: its derivation continues from the rigid
part already computed (0.9 s of the Panda's 1.2 s) instead of redoing it.

The stage is kept per process (the last :data:`KEPT`) and in the cache folder (:mod:`symbolic.cache`) under the
skeleton's digest. Each derivation continues on a private copy of the stage's intermediates (the stage itself
is never extended), so its intermediates are numbered as in a derivation from scratch: the generated code is
the same whether the stage was computed or reused.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import sympy as sp

from symbolic import cache
from symbolic.derivation import christoffel as ch
from symbolic.derivation.drives import rotor_inertia
from symbolic.derivation.gravity import gravity_forces, potential_energy
from symbolic.derivation.inertia import composite_inertias, inertia_matrix
from symbolic.derivation.kinematics import Kinematics
from symbolic.derivation.newton_euler import inverse_dynamics
from symbolic.derivation.products import sympy_reducer
from symbolic.derivation.subexpressions import Subexpressions
from symbolic.description.robot import Robot, acceleration_symbol, coordinate_symbol, skeleton_digest, velocity_symbol

log = logging.getLogger("symbolic.derivation.dynamics")  # one logger for the derivation's progress
T = TypeVar("T")
S = TypeVar("S")

KEPT = 8
"""Stages kept in this process (a diagnosis needs its model's rigid stage and rigid regressor, rarely a second
skeleton's)."""

_KEPT: OrderedDict[tuple[str, str], Any] = OrderedDict()


@dataclass
class RigidForms:
    """The parts of :class:`symbolic.derivation.dynamics.ReducedForms` that the rigid stage computes (described
    there), in intermediates of a derivation's registry."""

    D: sp.Matrix
    dD: list[sp.Matrix]
    christoffel: sp.Matrix
    coriolis: sp.Matrix
    coriolis_matrix: sp.Matrix
    gravity: sp.Matrix
    potential: sp.Expr
    coriolis_ne: sp.Matrix
    stiffness: sp.Matrix
    strain: sp.Expr


@dataclass
class RigidStage(RigidForms):
    """The rigid forms with their intermediates registry :attr:`sub`, the kinematics, and ``tau_body`` =
    D·Q̈ + Coriolis + g + k, τ without friction and applied forces."""

    sub: Subexpressions
    kin: Kinematics
    tau_body: sp.Matrix

    def private(self, robot: Robot) -> RigidStage:
        """A copy for ``robot`` to extend: its own intermediates registry and kinematics bound to it."""
        sub = self.sub.copy()
        kin = copy.copy(self.kin)
        kin.robot, kin.sub, kin.frames = robot, sub, dict(self.kin.frames)
        matrices = {f.name: getattr(self, f.name).copy() for f in dataclasses.fields(self)
                    if isinstance(getattr(self, f.name), sp.MatrixBase)}  # SymPy's matrices are mutable
        return dataclasses.replace(self, sub=sub, kin=kin, dD=[m.copy() for m in self.dD], **matrices)


class Steps:
    """The timed steps of a derivation: ``steps(name, function)`` runs one, records its seconds in
    :attr:`timings` and logs it (INFO where it is felt, DEBUG else) with the size of :attr:`sub`."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.timings: dict[str, float] = {}
        self.sub: Subexpressions | None = None

    def __call__(self, name: str, function: Callable[[], T]) -> T:
        start = time.perf_counter()
        result = function()
        self.timings[name] = time.perf_counter() - start
        level = logging.INFO if self.timings[name] > 0.5 else logging.DEBUG  # progress only where it is felt
        log.log(level, "%s: %s done in %.2f s (%d intermediates)", self.name, name, self.timings[name],
                len(self.sub) if self.sub is not None else 0)
        return result


def rigid_stage(robot: Robot, step: Steps) -> RigidStage:
    """The rigid stage of validated ``robot``: reused (this process, then the cache folder) or computed with
    ``step`` (which times and logs each step); a private copy in every case, whose registry ``step.sub`` is."""
    mine = reused("rigid stage", robot, lambda: _compute(robot, step)).private(robot)
    step.sub = mine.sub
    return mine


def reused(kind: str, robot: Robot, compute: Callable[[], S]) -> S:
    """The stage ``kind`` of ``robot``'s skeleton (:func:`~symbolic.description.robot.skeleton_digest`): kept
    in this process (the last :data:`KEPT`), else read from the cache folder, else ``compute()`` (and saved).
    The caller extends a private copy of it, never the stage itself."""
    key = (kind, skeleton_digest(robot))
    stage = _KEPT.get(key)
    if stage is None:
        start = time.perf_counter()
        found = cache.load(kind, key[1], {"robot": robot}.__getitem__)
        if found is not None:
            stage = found[0]
            log.debug("%s: %s read from the cache in %.2f s", robot.name, kind, time.perf_counter() - start)
    else:
        log.debug("%s: %s reused (same frames, bodies and drives as an earlier derivation)", robot.name, kind)
    if stage is None:
        stage = compute()
        cache.save(kind, key[1], stage, lambda obj: "robot" if obj is robot else None, sympy_reducer)
    _KEPT[key] = stage
    _KEPT.move_to_end(key)
    while len(_KEPT) > KEPT:
        _KEPT.popitem(last=False)
    return stage


def _compute(robot: Robot, step: Steps) -> RigidStage:
    from symbolic.derivation.flexible import beam_energy

    names = robot.generalized_coordinates
    q = tuple(coordinate_symbol(c) for c in names)
    qd = tuple(velocity_symbol(c) for c in names)
    qdd = tuple(acceleration_symbol(c) for c in names)
    rigid = robot.coordinate_symbols
    n, m = len(q), len(rigid)
    sub = step.sub = Subexpressions(q + qd + qdd)
    kin = step("kinematics", lambda: Kinematics(robot, sub))
    composite = step("composite inertias", lambda: composite_inertias(kin))
    D_rigid = step("inertia matrix", lambda: inertia_matrix(kin, composite))
    beams = step("flexible beams", lambda: [beam_energy(kin, beam, q) for beam in robot.beams])
    D = sp.zeros(n, n)
    D[:m, :m] = D_rigid
    for energy in beams:
        D += energy.inertia
    D = D.applyfunc(sub.add) if beams else D
    rotors = rotor_inertia(robot)
    for i in range(n):
        if rotors[i, i] != 0:
            D[i, i] = sub.add(D[i, i] + rotors[i, i])
    dD = step("dD/dQ", lambda: ch.inertia_derivatives(D, q, sub))
    C = step("christoffel", lambda: ch.christoffel_symbols(dD, sub))
    cmat = step("coriolis matrix", lambda: ch.coriolis_matrix(C, qd))
    coriolis = step("coriolis", lambda: ch.coriolis_vector(C, qd, cmat))  # its rows, times Q̇
    zero = {x: sp.Integer(0) for x in rigid}
    g_rigid = step("gravity", lambda: gravity_forces(kin))
    potential = step("potential", lambda: potential_energy(kin))
    gravity = sp.zeros(n, 1)
    gravity[:m, 0] = g_rigid
    strain = sp.Integer(0)
    for energy in beams:
        potential = potential + energy.gravity_potential
        strain = strain + energy.strain
        gravity += sp.Matrix([sub.add(sub.diff(energy.gravity_potential, x)) for x in q])
    potential = sub.add(potential)
    strain = sub.add(strain)
    stiffness = sp.Matrix([sub.add(sub.diff(strain, x)) for x in q])
    if beams:
        coriolis_ne = coriolis
        tau_body = D * sp.Matrix(qdd) + coriolis + gravity + stiffness
    else:
        tau_body = step(
            "newton-euler",
            lambda: inverse_dynamics(kin, dict(zip(rigid, qd)), dict(zip(rigid, qdd)), gravity=True),
        ) + rotors * sp.Matrix(qdd)
        coriolis_ne = step("newton-euler coriolis", lambda: inverse_dynamics(kin, dict(zip(rigid, qd)), zero, gravity=False))
    return RigidStage(D=D, dD=dD, christoffel=C, coriolis=coriolis, coriolis_matrix=cmat, gravity=gravity,
                      potential=potential, coriolis_ne=coriolis_ne, stiffness=stiffness, strain=strain, sub=sub, kin=kin,
                      tau_body=tau_body)

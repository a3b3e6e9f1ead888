"""``joint_elasticity``: a joint's transmission is a spring between the motor and the link, read from two encoders.

Where a joint logs its motor-side position (the loop's encoder, ``q_<c>``, in link units) and a link-side one
behind the transmission (the extra signal ``ql_<c>``, docs/data.md), the deflection δ = q − q_l is measured.
Spong's reduced model of an elastic joint splits the joint's equation in two (Spong 1987; a rigid transmission
is its limit k → ∞):

    τ = J_m·q̈ + Fv·q̇ + Fc·sgn(q̇) + b + k·δ + d·δ̇          (the motor side: rotor and gear)
    k·δ + d·δ̇ = the link's own dynamics at q_l                  (the link side)

The motor side holds no model of the link at all: the transmitted torque k·δ + d·δ̇ carries it. So on the
motor side's equation alone, with the deflection measured, k and d are linear and separable from the rotor's
inertia, friction and a constant b (an offset of the force or a zero of the encoders). The rigid model's row
is the sum of the two sides, in which k never appears: no column of the inverse dynamics can name it, and the
equation-error search does not try.

The judge is the held-out data: the motor side with δ and δ̇ must explain the held-out force better than the
motor side without them by the search's effect size (the same 10 % of the coordinate's residual power), k must be
positive and 5 σ from zero, J_m positive and at most 95 % of the joint's whole inertia (the motor side's fitted
without the spring: the link the spring carries has the rest), and the motor side with the spring must predict
the held-out force at least as well as the whole rigid model's row (else the deflection columns absorb something
else: a scale error of the link encoder, say). On a rigid joint the two encoders differ by their resolutions: δ is noise, the
motor side without the link's dynamics stays far worse than the rigid row, and nothing is named.

Without a link-side encoder the motor's encoder alone still shows the link ringing on the spring. The link's
equation at the motor's position q (the link's is q_l = q − δ), to first order in δ, is

    D_jj·δ̈ + (d + B_jj)·δ̇ + (k + A_jj)·δ = T_j                 (T_j: the rigid link's torque at q, q̇, q̈)

and every row i of the rigid model, evaluated at the motor's position, misses the link's lag behind it:

    τ_i − τ_i,rigid(q, q̇, q̈) = −(D_ij·δ̈ + A_ij·δ + B_ij·δ̇),   A = ∂τ/∂q_j, B = ∂τ/∂q̇_j (the link's side of τ)

(on the joint's own row this is k·δ + d·δ̇ − T_j: the spring carries the link's torque late). So δ is the link's
torque filtered by its mode, G = 1/(s² + 2ζω·s + ω²) with ω² = k/D̄ and 2ζω = d/D̄ (D̄ the link's mean inertia about
the joint), corrected to first order for the pose's variation (:func:`deflection`), and the column is that reaction
on every row, linear in the load J_L (≈ D̄) for a given (ω, ζ), which a grid finds as ``flexible_mode`` finds its
mode; two more columns carry the link's free motion from the record's start (:func:`free_responses`). On a
single joint whose weight does not change, this is ``flexible_mode``'s column (a second mass L(s)·q̈ on the
coordinate, the rigid q̈ absorbing the rest); on a later joint of a chain the link's reaction on the joints before it
is what tells the transmission from a load on any one of them. From one encoder a transmission's elasticity and a
load on a compliant coupling give the same response on a single coordinate; where the model declares a motor on the
joint (a ``[[drive]]`` with a rotor inertia), the search offers the link behind it as :class:`OneEncoder`, named
``joint_elasticity`` with the spring's stiffness k = J_L·ω² and damping d = 2ζω·J_L, and ``flexible_mode`` is not
offered there.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from symbolic.data.treatment import Settings, states
from symbolic.derivation.drives import rotor_inertia as reflected_rotors
from symbolic.derivation.products import Product
from symbolic.description.names import coefficient_name
from symbolic.description.units import coordinate_kind
from symbolic.workflow.effects.base import joint_frame, register
from symbolic.workflow.effects.flexible_mode import FlexibleMode, coupling, mode_denominator, motor_declared
from symbolic.workflow.statistics import MIN_SIGMAS
from symbolic.workflow.terms import relative_gap

SUMMARIES = {"joint_elasticity": "an elastic transmission between motor and link: k·δ + d·δ̇ (from two encoders, ql_<c>)",
             "backlash": "a dead band in an elastic transmission, with its width (from two encoders, ql_<c>)"}
"""What ``diagnose --help`` and ``--list-effects`` say of the two-encoder test (read from this text, not imported)."""

ROLES = {"joint_elasticity": {"stiffness": "{force}/{position}", "damping": "{force}·s/{position}",
                              "motor_inertia": "{inertia}"},
         "backlash": {"width": "{position}"}}
"""What each names, with units (``--list-effects``)."""

LINK_PREFIX = "ql_"
"""The extra signal of a coordinate's link-side position (``ql_<c>``, in the coordinate's units)."""

LINK_SHARE = 0.05
"""The link's share of the joint's inertia (J − J_m)/J must reach this: a spring that carries the link carries its
inertia. A link encoder with a scale error on a rigid joint makes δ ∝ q, which a "spring" fits like gravity while
J_m stays the whole joint's (a 1 % scale error left 1.2 % to the link in the tests); a geared wrist whose rotor
dominates still leaves its link more than this."""

COLUMNS = ("motor_inertia", "viscous", "coulomb", "offset", "stiffness", "damping")
"""The motor side's coefficients, in the order of its columns (module docstring)."""

ELASTIC_ROW = ("two encoders show its transmission elastic (joint_elasticity): its row is the motor side's, "
               "whose deflection carries the link")
"""Why the equation-error search tries nothing on a coordinate whose elasticity is named (the Context's ``elastic``)."""


@dataclass(frozen=True)
class Elasticity:
    """One coordinate's test (module docstring): the motor side's fit and the held-out errors.

    Attributes
    ----------
    coordinate
        The coordinate (its ``ql_<c>`` logged).
    values, sigmas
        The motor side's coefficients by :data:`COLUMNS` and their standard errors (estimation data); ``values``
        also holds ``joint_inertia``, the motor side's inertia fitted without the spring (the whole joint's).
    errors
        Held-out force error (% of the force's power, root): ``rigid`` (the model's row), ``motor_side``
        (without the spring), ``elastic`` (with it).
    gain
        Held-out share of the motor side's residual power the spring removes.
    deflection_rms
        RMS of the measured deflection δ = q − q_l over the estimation data.
    named
        Whether the elasticity is named; ``reason``: why not.
    """

    coordinate: str
    values: Mapping[str, float]
    sigmas: Mapping[str, float]
    errors: Mapping[str, float]
    gain: float
    deflection_rms: float
    named: bool
    reason: str | None
    predicted: Mapping[str, np.ndarray] = dataclasses.field(default_factory=dict, repr=False)
    """The motor side's force with the spring, per data set (``estimation``, ``validation``; reduced samples)."""
    design: tuple[np.ndarray, ...] = dataclasses.field(default=(), repr=False)
    """The motor side's columns and force, estimation then held out (for :meth:`held_out_error_with`)."""
    deflection: np.ndarray | None = dataclasses.field(default=None, repr=False)
    """The measured deflection δ on the estimation data, reduced like τ (for the report's figure)."""
    backlash: Mapping[str, Any] | None = None
    """The dead band's test where the spring is named (:func:`_backlash`): ``width``, ``centre`` (of the logged
    deflection: the encoders' zeros differ by it), ``gain`` and ``named``/``reason``; ``None`` when not tried. When
    named, ``values`` are the spring's in contact."""

    @property
    def band(self) -> Mapping[str, Any] | None:
        """The dead band when one is named (:attr:`backlash`), else ``None``."""
        return self.backlash if self.backlash is not None and self.backlash["named"] else None

    def transmission(self) -> tuple[np.ndarray, np.ndarray]:
        """(δ, the spring's torque as measured) on the estimation data: the force less every other term of the
        motor side as fitted, against the deflection (the report's figure)."""
        x, y = self.design[0], self.design[1]
        c = np.array([self.values[k] for k in COLUMNS])
        others = [i for i in range(len(COLUMNS)) if COLUMNS[i] != "stiffness"]
        return self.deflection, y - x[:, others] @ c[others]

    def spring(self, delta: np.ndarray) -> np.ndarray:
        """The fitted spring's torque at deflections ``delta``: k·δ, or with a dead band k·(x ∓ b/2) outside
        |x| ≤ b/2, x = δ − centre."""
        k, band = self.values["stiffness"], self.band
        if band is None:
            return k * delta
        x = delta - band["centre"]
        return np.where(np.abs(x) > band["width"] / 2, k * (x - np.sign(x) * band["width"] / 2), 0.0)

    def held_out_error_with(self, role: str, value: float) -> float:
        """The held-out error (%) of the motor side with ``role``'s coefficient held at ``value`` and the others
        fitted again on the estimation data."""
        x, y, xh, yh = self.design
        k = COLUMNS.index(role)
        others = [i for i in range(len(COLUMNS)) if i != k]
        c, _ = _fit(x[:, others], y - value * x[:, k])
        return relative_gap(yh, xh[:, others] @ c + value * xh[:, k])

    def frequency_hz(self, joint_inertia: float) -> float | None:
        """The link's mode with the motor held, √(k/J_l)/2π, J_l = ``joint_inertia`` − J_m (None if J_l ≤ 0): on one
        joint the link's own; in a chain a guide (the motor side's inertia without the spring is the joint's as the
        motion saw it)."""
        link = joint_inertia - self.values["motor_inertia"]
        return math.sqrt(self.values["stiffness"] / link) / (2 * math.pi) if link > 0 and self.values["stiffness"] > 0 \
            else None

    def to_dict(self) -> dict[str, Any]:
        return {"effect": "joint_elasticity", "coordinate": self.coordinate, "named": self.named,
                "reason": self.reason, "values": dict(self.values), "sigmas": dict(self.sigmas),
                "held_out_error_percent": dict(self.errors), "gain": self.gain,
                "deflection_rms": self.deflection_rms,
                "link_mode_hz": self.frequency_hz(self.values["joint_inertia"]),
                "backlash": None if self.backlash is None else dict(self.backlash)}


def logged_links(measurements: Any) -> list[str]:
    """The coordinates of ``measurements`` whose link-side position ``ql_<c>`` is logged."""
    return [c for c in measurements.coordinates if LINK_PREFIX + c in measurements.extras]


@dataclass(frozen=True)
class _Motion:
    """One data set's motor side at every sample (before the treatment's reduction) and its reduced force."""

    qdd: np.ndarray
    qd: np.ndarray
    delta: np.ndarray
    delta_d: np.ndarray
    reduce: Any
    tau: np.ndarray

    def columns(self, band: float = 0.0, centre: float = 0.0) -> np.ndarray:
        """The motor side's columns (:data:`COLUMNS`), reduced like τ. With a dead band of width ``band`` about
        ``centre`` (backlash), the spring and the damper act in contact only: k·(x ∓ band/2) and d·δ̇ where
        |x| = |δ − centre| > band/2, nothing inside."""
        if band <= 0.0:
            spring, damper = self.delta, self.delta_d
        else:
            x = self.delta - centre
            contact = np.abs(x) > 0.5 * band
            spring, damper = np.where(contact, x - np.sign(x) * 0.5 * band, 0.0), np.where(contact, self.delta_d, 0.0)
        return self.reduce(np.column_stack([self.qdd, self.qd, np.sign(self.qd), np.ones_like(self.qd), spring, damper]))


def _motion(data: Any, j: int, settings: Settings | None) -> _Motion:
    """The motor side of coordinate ``j``: the motor's and the link's positions through the same treatment (both
    differentiated alike, so that δ̇ is the difference of their velocities)."""
    positions = dataclasses.replace(data.measurements, qd=None, qdd=None)
    motor = states(positions, settings)
    link = states(linked(positions, [positions.coordinates[j]]), settings)
    return _Motion(motor.qdd[:, j], motor.qd[:, j], motor.q[:, j] - link.q[:, j], motor.qd[:, j] - link.qd[:, j],
                   data.states.processing.reduce, np.asarray(data.tau)[:, j])


def _fit(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares with the columns scaled; coefficients and their standard errors."""
    scale = np.linalg.norm(x, axis=0)
    scale[scale == 0] = 1.0
    solution, *_ = np.linalg.lstsq(x / scale, y, rcond=None)
    residual = y - (x / scale) @ solution
    dof = max(len(y) - x.shape[1], 1)
    covariance = np.linalg.pinv((x / scale).T @ (x / scale)) * float(residual @ residual) / dof
    return solution / scale, np.sqrt(np.clip(np.diag(covariance), 0.0, None)) / scale


def test_all(robot: Any, sets: Mapping[str, Any], rigid_held: np.ndarray, min_gain: float,
             settings: Settings | None = None) -> list[Elasticity]:
    """:func:`test` on every coordinate whose link-side position is logged in the estimation and the held-out data
    (not named where the model cannot hold the elasticity: :func:`applicable`); ``rigid_held``: the rigid model's
    held-out force, ``samples × N``."""
    estimation, held = sets["estimation"], sets["validation"]
    out = []
    for c in logged_links(estimation.measurements):
        if c not in logged_links(held.measurements):  # a validation file without the link encoder: nothing to judge on
            continue
        found = test(sets, c, rigid_held[:, estimation.coordinates.index(c)], min_gain, settings)
        why = applicable(robot, c)
        out.append(found if why is None or not found.named else dataclasses.replace(found, named=False, reason=why))
    return out


def test(sets: Mapping[str, Any], coordinate: str, rigid_held: np.ndarray, min_gain: float,
         settings: Settings | None = None) -> Elasticity:
    """Test ``coordinate``'s transmission (module docstring) on the estimation and held-out data sets;
    ``rigid_held``: the rigid model's prediction of the held-out force on that coordinate (reduced samples).
    Where the spring is named, a dead band in it (:func:`_backlash`) is tested against it."""
    estimation, held = sets["estimation"], sets["validation"]
    j = estimation.coordinates.index(coordinate)
    motion, motion_held = _motion(estimation, j, settings), _motion(held, j, settings)
    x, y, xh, yh = motion.columns(), motion.tau, motion_held.columns(), motion_held.tau
    rigid_columns = [0, 1, 2, 3]
    c0, _ = _fit(x[:, rigid_columns], y)
    c, sigma = _fit(x, y)
    e0 = float(np.sum((yh - xh[:, rigid_columns] @ c0) ** 2))
    e1 = float(np.sum((yh - xh @ c) ** 2))
    gain = 1.0 - e1 / e0 if e0 > 0 else 0.0
    errors = {"rigid": relative_gap(yh, rigid_held), "motor_side": relative_gap(yh, xh[:, rigid_columns] @ c0),
              "elastic": relative_gap(yh, xh @ c)}
    values = {**dict(zip(COLUMNS, map(float, c))), "joint_inertia": float(c0[0])}
    sigmas = dict(zip(COLUMNS, map(float, sigma)))
    reason = _reason(values, sigmas, errors, gain, min_gain)
    found = Elasticity(coordinate, values, sigmas, errors, gain, float(np.sqrt(np.mean(x[:, 4] ** 2))),
                       reason is None, reason, {"estimation": x @ c, "validation": xh @ c}, (x, y, xh, yh),
                       motion.reduce(motion.delta[:, None])[:, 0])
    return _backlash(found, motion, motion_held, min_gain) if found.named else found


BACKLASH_GRID = 25
"""Points per axis of the dead band's grid: its width from 0 to 90 % of the deflection's range, its centre over the
deflection's 2–98 % quantiles; the best point is refined by a simplex search."""


def _backlash(found: Elasticity, motion: _Motion, held: _Motion, min_gain: float) -> Elasticity:
    """``found`` with a dead band in its spring when one is named: the band's width and centre fitted on the
    estimation data (a grid, then a simplex search), named when the band removes at least ``min_gain`` of the
    spring's held-out residual power, its stiffness is positive and the width lies inside the range searched."""
    import scipy.optimize

    y, yh = motion.tau, held.tau
    low, high = np.quantile(motion.delta, [0.02, 0.98])
    span = high - low

    def cost(point: np.ndarray) -> float:
        band, centre = float(point[0]), float(point[1])
        if band < 0.0:
            return math.inf
        x = motion.columns(band, centre)
        c, _ = _fit(x, y)
        return float(np.sum((y - x @ c) ** 2))

    grid = [(b, m) for b in np.linspace(0.0, 0.9 * span, BACKLASH_GRID) for m in np.linspace(low, high, BACKLASH_GRID)]
    start = min(grid, key=lambda point: cost(np.array(point)))
    best = scipy.optimize.minimize(cost, np.array(start), method="Nelder-Mead",
                                   options={"xatol": 1e-4 * span, "fatol": 1e-12, "maxiter": 400}).x
    band, centre = max(float(best[0]), 0.0), float(best[1])
    x, xh = motion.columns(band, centre), held.columns(band, centre)
    c, sigma = _fit(x, y)
    spring_power = float(np.sum((yh - found.predicted["validation"]) ** 2))
    gain = 1.0 - float(np.sum((yh - xh @ c) ** 2)) / spring_power if spring_power > 0 else 0.0
    why = None
    if not gain >= min_gain:
        why = f"a dead band removes {100 * gain:.3g} % of the spring's held-out residual power (< {100 * min_gain:g} %)"
    elif not c[4] > 0:
        why = f"the stiffness in contact {c[4]:.4g} is not positive"
    elif not band < 0.85 * span:
        why = f"the band's width {band:.4g} reaches the edge of the range searched (90 % of the deflection's)"
    backlash = {"width": band, "centre": centre, "gain": gain, "named": why is None, "reason": why}
    if why is not None:
        return dataclasses.replace(found, backlash=backlash)
    values = {**found.values, **dict(zip(COLUMNS, map(float, c)))}
    errors = {**found.errors, "elastic": relative_gap(yh, xh @ c)}
    return dataclasses.replace(found, values=values, sigmas=dict(zip(COLUMNS, map(float, sigma))), errors=errors,
                               predicted={"estimation": x @ c, "validation": xh @ c},
                               design=(x, y, xh, yh), backlash=backlash)


def _reason(values: Mapping[str, float], sigmas: Mapping[str, float], errors: Mapping[str, float], gain: float,
            min_gain: float) -> str | None:
    """Why the elasticity is not named (module docstring), or ``None``."""
    k, sk = values["stiffness"], sigmas["stiffness"]
    if not gain >= min_gain:
        return (f"the deflection explains {100 * gain:.3g} % of the motor side's held-out residual power "
                f"(< {100 * min_gain:g} %)")
    if not (k > 0 and k >= MIN_SIGMAS * sk):
        return f"the stiffness {k:.4g} ± {sk:.2g} is not positive and {MIN_SIGMAS:g} σ from zero"
    if not values["motor_inertia"] > 0:
        return f"the motor side's inertia {values['motor_inertia']:.4g} is not positive"
    whole = values["joint_inertia"]
    if not whole - values["motor_inertia"] >= LINK_SHARE * abs(whole):
        return (f"the motor side keeps {values['motor_inertia']:.4g} of the joint's {whole:.4g} inertia: less than "
                f"{100 * LINK_SHARE:g} % is left to the link the spring would carry (a scale or zero error of the "
                "link encoder, not a transmission)")
    if not errors["elastic"] <= errors["rigid"]:
        return (f"the elastic motor side predicts the held-out force worse ({errors['elastic']:.4g} %) than the "
                f"rigid model ({errors['rigid']:.4g} %): the deflection absorbs something else")
    return None


def linked(measurements: Any, coordinates: Sequence[str]) -> Any:
    """``measurements`` with the positions of ``coordinates`` read from their link-side encoders (``ql_<c>``), and
    a measured velocity or acceleration of theirs replaced by the link position's central differences (the link's
    own were not logged)."""
    columns = [measurements.coordinates.index(c) for c in coordinates]
    q = np.array(measurements.q, dtype=float)
    for j, c in zip(columns, coordinates):
        q[:, j] = np.asarray(measurements.extras[LINK_PREFIX + c], dtype=float)
    changes: dict[str, Any] = {"q": q}
    for name, order in (("qd", 1), ("qdd", 2)):
        given = getattr(measurements, name)
        if given is not None:
            x = np.array(given, dtype=float)
            x[:, columns] = _differentiated(q[:, columns], measurements.sample_period, order)
            changes[name] = x
    return dataclasses.replace(measurements, **changes)


def _differentiated(x: np.ndarray, step: float, order: int) -> np.ndarray:
    """``x`` (samples × k) differentiated ``order`` times by central differences (the treatment's)."""
    from symbolic.data.filters import central_difference

    for _ in range(order):
        x = central_difference(x, step)
    return x


def with_deflections(measurements: Any, found: Sequence[Elasticity]) -> Any:
    """``measurements`` (motor-side positions) with the patched model's deflection coordinates added, as
    :func:`experiment_lines` maps them: ``<c>_flex`` = ql_<c> − q_<c> (+ a dead band's centre), no force, its
    reference its own reading; for the simulated path of a diagnosis (the loop reads the motors)."""
    m = measurements
    extra = []
    for e in found:
        shift = 0.0 if e.band is None else e.band["centre"]
        j = m.coordinates.index(e.coordinate)
        extra.append(np.asarray(m.extras[LINK_PREFIX + e.coordinate], dtype=float) - np.asarray(m.q)[:, j] + shift)
    flex = np.column_stack(extra)
    changes: dict[str, Any] = {"coordinates": (*m.coordinates, *(f"{e.coordinate}_flex" for e in found)),
                               "q": np.hstack([m.q, flex]), "tau": np.hstack([m.tau, np.zeros_like(flex)])}
    if m.qd is not None:
        changes["qd"] = np.hstack([m.qd, _differentiated(flex, m.sample_period, 1)])
    if m.qdd is not None:
        changes["qdd"] = np.hstack([m.qdd, _differentiated(flex, m.sample_period, 2)])
    if m.ref is not None:
        changes["ref"] = np.hstack([m.ref, flex])
    return dataclasses.replace(m, **changes)


def linked_sets(sets: Mapping[str, Any], coordinates: Sequence[str], settings: Settings | None = None) -> dict[str, Any]:
    """The data sets of a diagnosis treated again with :func:`linked` positions: once a joint is named elastic, the
    links' equations (every other row) see where its link is, not where its motor is. The forces stay the logged
    ones (replacing an elastic row's by the torque its transmission passes, so that its rigid row reads as Spong's
    link side, left the arm's joint 1 with a larger residual, 0.57 % against 0.47 %: tried and dropped)."""
    from symbolic.workflow.dataset import treat

    def again(data: Any) -> Any:
        record = None if data.record is None else again(data.record)
        return dataclasses.replace(treat(linked(data.measurements, coordinates), data.role, settings), record=record,
                                   start=data.start)

    return {role: again(data) for role, data in sets.items()}


def applicable(robot: Any, coordinate: str) -> str | None:
    """Why the model cannot hold ``coordinate``'s elasticity (no frame turns or slides with it alone), or ``None``."""
    return None if joint_frame(robot, coordinate) is not None else f"no frame moves with {coordinate} alone"


def patch(editor: Any, robot: Any, c: str, v: Mapping[str, float], band: Mapping[str, Any] | None,
          comment: str) -> tuple[dict[str, float], str]:
    """Write the elastic joint into the model file (Spong's model): the coordinate stays the motor side (its
    drive's rotor inertia becomes J_m), a new coordinate ``<c>_flex`` = q_l − q (the link's angle minus the
    motor's, = −δ) is added to the joint's DH θ (or d), so that the link and everything after it hang on
    q + q_flex, and a ``[[force]]`` −k·q_flex − d·q̇_flex acts on it; ``v`` holds ``stiffness``, ``damping`` and
    ``motor_inertia``, ``band`` a dead band (:attr:`Elasticity.band`) or ``None``. Returns the parameters written
    and the new coordinate's name."""
    frame = joint_frame(robot, c)
    if frame is None:
        raise ValueError(applicable(robot, c))
    ratio = next((float(d.ratio) for d in robot.drives if d.coordinate == c and not getattr(d.ratio, "free_symbols", ())),
                 1.0)
    k = editor.parameter(coefficient_name("k", f"{c}_joint"), v["stiffness"], comment + "; the transmission's stiffness")
    damping = max(v["damping"], 0.0)
    d = editor.parameter(coefficient_name("d", f"{c}_joint"), damping, comment + "; the transmission's damping")
    rotor = editor.parameter(coefficient_name("Ia", c), v["motor_inertia"] / ratio**2,
                             comment + f"; the rotor's inertia (J_m = Ia·ratio² = {v['motor_inertia']:.6g} at the joint)")
    editor.set_drive(c, "rotor_inertia", rotor, comment)
    flex = editor.coordinate(f"{c}_flex", comment + "; the link's position minus the motor's")
    key = "theta" if coordinate_kind(robot, c) == "revolute" else "d"
    editor.set_frame_dh(frame.name, key, f"{editor.frame_dh(frame.name)[key]} + {flex}", comment + "; the link turns with "
                        "the motor plus the deflection")
    written = coupling(editor, f"transmission_{c}", c, flex, k, d, None if band is None else band["width"], comment)
    return {k: v["stiffness"], d: damping, rotor: v["motor_inertia"] / ratio**2, **written}, flex


def motor_roles(robot: Any, coordinate: str) -> dict[str, str]:
    """``{parameter: "viscous" | "coulomb"}``: the model file's friction on the coordinate where its ``[[friction]]``
    viscous or Coulomb coefficient is one parameter of ``[parameters]``."""
    names = {p.name for p in robot.parameters}
    out = {}
    for friction in robot.frictions:
        if friction.coordinate == coordinate:
            for role in ("viscous", "coulomb"):
                symbol = getattr(friction, role, None)
                if symbol is not None and getattr(symbol, "is_Symbol", False) and symbol.name in names:
                    out[symbol.name] = role
    return out


def motor_values(robot: Any, found: Elasticity) -> dict[str, float]:
    """The model file's friction parameters on the joint (:func:`motor_roles`) at the motor side's values. The
    rigid fit's values are skewed there (the link's dynamics it cannot hold leak into them); the motor side
    holds them exactly."""
    return {name: found.values[role] for name, role in motor_roles(robot, found.coordinate).items()}


def motor_corrections(robot: Any, found: Elasticity, min_gain: float) -> list[dict[str, Any]]:
    """The model file's friction values on the joint that its motor side moves beyond 3σ and 10 % and that predict
    the held-out force worse by at least ``min_gain`` of its residual power (the corrections' rule of
    :mod:`symbolic.workflow.corrections`, read from the motor side's fit, in its words)."""
    from symbolic.workflow.corrections import RELATIVE, SIGMAS, Value, sentence

    nominal = {p.name: float(p.value) for p in robot.parameters}
    out = []
    for name, role in motor_roles(robot, found.coordinate).items():
        v = Value(name, nominal[name], found.values[role], found.sigmas[role], column=-1, scale=1.0)
        moved = abs(v.value - v.nominal)
        if not (moved > SIGMAS * v.sigma and moved > RELATIVE * abs(v.nominal)):
            continue
        at_file, with_value = found.held_out_error_with(role, v.nominal), found.errors["elastic"]
        gain = 1.0 - (with_value / at_file) ** 2 if at_file > 0 else 0.0
        if gain < min_gain:
            continue
        out.append({"parameter": name, "nominal": v.nominal, "value": v.value, "sigma": v.sigma,
                    "relative_change": v.relative_change,
                    "evidence": {"sigmas": moved / v.sigma if v.sigma else None, "held_out_gap": with_value,
                                 "held_out_gap_at_nominal": at_file, "held_out_gain": gain, "kind": "friction",
                                 "from": f"the motor side of {found.coordinate} (two encoders)"},
                    "summary": sentence(v, "friction")})
    return out


def experiment_lines(found: Elasticity, reference: bool = False) -> list[str]:
    """The [signals] lines that give the patched model's new coordinate from the two encoders (its force is 0);
    with a dead band, its centre is the encoders' zero difference and moves to the deflection's mapping.
    ``reference``: the log has ``ref_<c>`` columns, which the data contract wants for every coordinate or none; the
    deflection's is its own reading (no loop drives it: the controller's coordinates are the motors')."""
    c, band = found.coordinate, found.band
    shift = "" if band is None else f" {'-' if band['centre'] < 0 else '+'} {abs(band['centre']):.6g}"
    deflection = f"{LINK_PREFIX}{c} - q_{c}{shift}"
    lines = ["[signals]", f'q_{c}_flex = "{deflection}"', f'tau_{c}_flex = "0"']
    return lines + ([f'ref_{c}_flex = "{deflection}"'] if reference else [])


class OneEncoder(FlexibleMode):
    """``joint_elasticity`` from the motor's encoder alone (module docstring): the link's inertia J_L rings behind
    the joint's motor on a spring k and damper d, found by its ringing as ``flexible_mode`` finds a second mass —
    the same grid and checks, the column the link's reaction on every row (module docstring) — on a coordinate whose
    model declares a motor. Roles: the spring's
    ``stiffness`` k = J_L·ω² and ``damping`` d = 2ζω·J_L at the link's own mode (ω, ζ: the link's frequency and
    damping ratio with the motor held), and the ringing as the data show it (``frequency_hz``, ``damping_ratio``:
    the closed-loop mode of the patched model under the data's ``[controller]``, as ``flexible_mode`` reports it).
    Written as Spong's joint (:meth:`patch`): the file's link — its inertia, its weight and its couplings to the
    other joints — behind the spring."""

    name, contract, variant = "joint_elasticity_one_encoder", "joint_elasticity", "one_encoder"
    rank = 120
    roles = ("stiffness", "damping", "frequency_hz", "damping_ratio")
    summary = "an elastic transmission between motor and link seen by the motor encoder alone: the link rings on k, d"
    formula = "−(D_ij·δ̈ + A_ij·δ + B_ij·δ̇) on every row i, δ = G(s)·T_j/D̄ (the link on the spring k = J_L·ω², d = 2ζω·J_L)"
    regressors = "the link's reaction to its deflection, δ its torque T_j filtered by its mode (first order in the pose); (ω, ζ) on a grid; the free motion from the start"
    written_as = "Spong's joint: `<q>_flex` added to the joint's DH (the file's link turns with q + `<q>_flex`), `[[force]]` −k·x − d·ẋ, the rotor's inertia the motor side's"
    roles_note = "k and d at the link's own mode; the ringing, closed loop"
    units = {"stiffness": "{force}/{position}", "damping": "{force}·s/{position}", "frequency_hz": "Hz",
             "damping_ratio": ""}

    own_row = False  # the link's acceleration reacts on every joint before it (D_ij·δ̈)

    def applicable(self, context, j):
        c = context.coordinates[j]
        if not motor_declared(context.robot, c):
            return f"no motor declared on {c} (a [[drive]] with a rotor inertia): a second mass there is a flexible_mode"
        if context.model is None:
            return "needs the derived model (the link's torque behind the transmission)"
        return self.holds(context, j)

    def columns_at(self, signals, j, value):
        """The link's reaction on every row i, −(D_ij·δ̈ + A_ij·δ + B_ij·δ̇)/D̄ (module docstring, "From the motor encoder
        alone"), δ the deflection behind joint j to first order in the pose's variation (:func:`deflection`): linear in
        the load J_L = D̄, the link's mean inertia about the joint; then the same reaction to the link's two free
        motions from the record's start (:func:`free_responses`), whose coefficients are the record's unknown
        initial deflection and its rate."""
        if signals.model is None:
            raise TypeError(f"{self.label()} needs the derived model: Signals.model")
        if signals.record is not None:  # the deflection at the first sample is what the motion before left
            whole = self.columns_at(signals.record, j, value)
            return whole[signals.start:signals.start + len(signals.t)]
        link = _link_side(signals, j)
        return np.stack([-(link.inertia * acceleration[:, None] + link.stiffness * delta[:, None]
                           + link.damping * rate[:, None]) / link.mean
                         for delta, rate, acceleration in self.motions(link, value, signals.rate)], axis=2)

    def motions(self, link: LinkSide, value: Any, rate: float) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(δ, δ̇, δ̈) of each motion of the link whose reaction is a column: the deflection driven by the link's torque
        (:func:`deflection`) and the two free motions from the record's start (:func:`free_responses`)."""
        return [deflection(link, value, rate), *free_responses(value, rate, len(link.torque))]

    def roles_of(self, c, value, reference):
        roles = super().roles_of(c, value, reference)
        w = 2.0 * math.pi * roles["frequency_hz"]
        roles = {**roles, "stiffness": roles["load"] * w * w, "damping": 2.0 * roles["damping_ratio"] * w * roles["load"]}
        # the coefficient of the joint's own q̈ holds the link where no other row sees the link's inertia (one
        # coordinate): the motor's is what the link leaves. In a chain it is the rotor's alone (the link's inertia
        # about a later joint also acts on the joints before it), and what is left is negative: the patch then keeps
        # the file's rotor inertia.
        if reference is not None and reference - roles["load"] > 0:
            roles["motor_inertia"] = reference - roles["load"]
        return roles

    def patch(self, editor, context, j, roles, c, value, comment):
        """Spong's joint, as two encoders write it (:func:`patch`): the link and everything after it on
        q + ``<q>_flex``, the spring and damper on ``<q>_flex``, the motor's inertia the coordinate's own where the
        fit gives it (one coordinate), else the file's rotor inertia. The link keeps the file's inertia and weight."""
        coordinate = context.coordinates[j]
        motor = roles.get("motor_inertia")
        if motor is None or not motor > 0:
            motor = rotor_inertia(context.robot, coordinate)
        spring = {"stiffness": roles["stiffness"], "damping": roles["damping"], "motor_inertia": motor}
        written, _ = patch(editor, context.robot, coordinate, spring, self.band(roles), comment)
        return written

    def band(self, roles) -> Mapping[str, Any] | None:
        """The dead band :meth:`patch` writes in the spring (:attr:`Elasticity.band`'s form), ``None``: a spring."""
        return None

    LINK_RANGE = (0.5, 2.0)
    """The ringing inertia J_L must lie within these factors of the link's inertia about the joint in the model
    file: a transmission carries the whole link. Where the motion barely excites the link's mode the data fix
    J_L/ω² alone (the term (J_L/ω²)·d⁴q/dt⁴ of a stiff spring), and a fit far below the mode with a fraction of the
    link's inertia matches it as well: on the geared joint of the tests without Coulomb friction (whose
    stick-slip rings the link), k 4000 N·m/rad came out as 15 on a load of 0.007 of the link's 0.15."""

    def check(self, roles, reference, context, j):
        return super().check(roles, reference, context, j) or self._link_check(roles, context, j)

    def _link_check(self, roles, context, j) -> str | None:
        """Why the inertia ringing on the spring is not the link's (:attr:`LINK_RANGE`), or ``None``."""
        link = link_inertia(context.model, context.coordinates[j], np.mean(context.q, axis=0), context.coordinates)
        low, high = self.LINK_RANGE
        if link is not None and link > 0 and not low <= roles["load"] / link <= high:
            return (f"the inertia ringing on the spring, {roles['load']:.4g}, is {roles['load'] / link:.3g}× the link's "
                    f"inertia about the joint in the model file ({link:.4g}; allowed {low:g}–{high:g}×): a "
                    "transmission carries the whole link (the link's mode is not excited enough to separate its "
                    "frequency from its inertia)")
        return None

    def as_measured(self, patched, parameters, context, j, roles, controller, period):
        measured, extra = super().as_measured(patched, parameters, context, j, roles, controller, period)
        return {**measured, "stiffness": roles["stiffness"], "damping": roles["damping"]}, extra


def _link_terms(model: Any) -> Any:
    """D less the rotors' reflected inertia, and the bias less friction, as one vectorised function of (Q, Q̇[, t], p):
    the link's side of every joint at the motor's position (:func:`_link_side`)."""
    from symbolic.codegen.functions import compile_vectorized

    n = model.n
    inertia = model.reduced.D - reflected_rotors(model.robot)
    outputs = [*inertia, *(model.reduced.bias - model.reduced.friction)]
    arguments = [list(model.coordinates), list(model.velocities), *([[model.time]] if model.time_varying else []),
                 list(model.parameter_symbols)]
    function = compile_vectorized(model.sub, arguments, outputs, (n * n + n,))
    values = np.array([float(model.parameters[s]) for s in model.parameter_symbols])
    return function, values


LINK_TERMS = Product("the link side of each joint, vectorised", _link_terms)

@dataclass(frozen=True)
class LinkSide:
    """The link behind joint j, at the measured (motor) positions and the model file's values (:func:`_link_side`):
    the link's torque T_j = Σ_m (D − R)_jm·q̈_m + b_j (R the rotors' reflected inertia, b the bias without friction:
    the link's Coriolis, gravity and forces), and on each of the data's rows i the coefficients of the link's
    deflection δ = q_j − q_l in τ_i: D_ij (its acceleration), A_ij = ∂τ_i/∂q_j and B_ij = ∂τ_i/∂q̇_j (the link's
    pose and velocity are the motor's less δ), ``samples × N``; ``own`` D_jj per sample and ``mean`` its mean."""

    torque: np.ndarray
    inertia: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    own: np.ndarray
    mean: float
    index: int
    """The data's row of the joint itself."""

    @functools.cached_property
    def driving(self) -> np.ndarray:
        """T_j, D_jj, A_jj and B_jj side by side (``samples × 4``, contiguous): what drives the link's deflection
        in :func:`~symbolic.workflow.effects.backlash.rattle`, gathered once (a scan integrates some hundred values
        of one link; a frozen dataclass still takes the cached value in its ``__dict__``)."""
        own = self.index
        return np.ascontiguousarray(np.column_stack([self.torque, self.own, self.stiffness[:, own], self.damping[:, own]]))

    @functools.cached_property
    def free(self) -> bool:
        """Whether the link is a free unit load: D_jj = 1 at every sample, A_jj = B_jj = 0 and ``mean`` 1 (the load
        of :class:`~symbolic.workflow.effects.backlash.LoadBacklash`), which :func:`~symbolic.workflow.effects.backlash.rattle`
        integrates without those terms."""
        driving = self.driving
        return self.mean == 1.0 and bool(np.all(driving[:, 1] == 1.0)) and not driving[:, 2:].any()


_LINK_SIDES: "weakref.WeakKeyDictionary[Any, dict[int, LinkSide]]" = weakref.WeakKeyDictionary()
"""The link sides per signals and coordinate: a grid scan asks for them at every value."""

STEP = 1e-6
"""Central-difference step (rad, m; rad/s, m/s) of A and B: the columns are a fit's, not exact quantities."""


def _link_side(signals: Any, j: int) -> LinkSide:
    """The :class:`LinkSide` of the data's coordinate ``j`` (the coordinates the data lack at 0)."""
    cached = _LINK_SIDES.setdefault(signals, {})
    if j in cached:
        return cached[j]
    model = signals.model
    function, values = model.products.get(LINK_TERMS)
    n, names = model.n, list(model.robot.generalized_coordinates)
    columns = [names.index(c) for c in signals.coordinates]
    q, qd, qdd = (np.zeros((len(signals.t), n)) for _ in range(3))
    for k, m in enumerate(columns):
        q[:, m], qd[:, m], qdd[:, m] = signals.q[:, k], signals.qd[:, k], signals.qdd[:, k]
    time = [signals.t[:, None]] if model.time_varying else []

    def forces(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = function(q, qd, *time, values)
        inertia = out[:, :n * n].reshape(-1, n, n)
        return np.einsum("sim,sm->si", inertia, qdd) + out[:, n * n:], inertia

    row = columns[j]
    tau, inertia = forces(q, qd)
    shift = np.zeros(n)
    shift[row] = STEP
    stiffness = (forces(q + shift, qd)[0] - forces(q - shift, qd)[0]) / (2 * STEP)
    damping = (forces(q, qd + shift)[0] - forces(q, qd - shift)[0]) / (2 * STEP)
    own = inertia[:, row, row]
    cached[j] = LinkSide(tau[:, row], inertia[:, columns, row], stiffness[:, columns], damping[:, columns], own,
                         float(np.mean(own)), j)
    return cached[j]


def deflection(link: LinkSide, value: tuple[float, float], rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """δ, δ̇, δ̈ of the link behind the joint (Spong's link equation at the motor's position, to first order in δ):
    D_jj·δ̈ + (d + B_jj)·δ̇ + (k + A_jj)·δ = T_j with ω² = k/D̄, 2ζω = d/D̄ (``value`` = (ω/2π, ζ)). The part that
    does not vary with the pose, δ₀ = G[T_j/D̄], G = 1/(s² + 2ζω·s + ω²), and its first-order correction
    δ₁ = −G[((D_jj − D̄)·δ̈₀ + A_jj·δ₀ + B_jj·δ̇₀)/D̄] (the link's weight and speed stiffen or soften the spring with
    the pose: on the tests' arm, from the motor encoders, δ is 1.65 % RMS from the link encoder's without it, 0.086 %
    with it, after the record's first 2 s); each filter at rest on its first input."""
    filtered = _filters(value, rate)
    d0, v0, a0 = filtered(link.torque / link.mean, True)
    d1, v1, a1 = filtered(((link.own - link.mean) * a0 + link.stiffness[:, link.index] * d0
                           + link.damping[:, link.index] * v0) / link.mean, True)
    return d0 - d1, v0 - v1, a0 - a1


def free_responses(value: tuple[float, float], rate: float, samples: int) -> list[tuple[np.ndarray, ...]]:
    """(δ, δ̇, δ̈) of the link's two free motions (the homogeneous solutions of G: a deflection and a deflection rate
    at the first sample that the forcing before the record left): a record that starts in motion starts the link
    ringing in a way its filtered first samples do not tell — on the tests' arm, whose record starts with the
    loop's kick, the forced response alone missed δ̈ by 50 % over the first second, 0.5 % after 2 s."""
    filtered = _filters(value, rate)
    out = []
    for k in range(2):
        impulse = np.zeros(samples)
        impulse[k] = 1.0
        out.append(tuple(filtered(impulse, False)))
    return out


def _filters(value: tuple[float, float], rate: float) -> Any:
    """``filtered(x, at_rest) -> [G·x, s·G·x, s²·G·x]``, G = 1/(s² + 2ζω·s + ω²) by the bilinear transform prewarped
    at ω (``value`` = (ω/2π, ζ)); ``at_rest``: the filters start at rest on x[0], else from zero."""
    import scipy.signal

    a, K, _ = mode_denominator(*value, rate)
    numerators = [b / a[0] for b in (np.array([1.0, 2.0, 1.0]), K * np.array([1.0, 0.0, -1.0]),
                                      K * K * np.array([1.0, -2.0, 1.0]))]
    a = a / a[0]

    def filtered(x: np.ndarray, at_rest: bool) -> list[np.ndarray]:
        return [scipy.signal.lfilter(b, a, x, zi=scipy.signal.lfilter_zi(b, a) * x[0])[0] if at_rest
                else scipy.signal.lfilter(b, a, x) for b in numerators]

    return filtered


def link_inertia(model: Any, coordinate: str, position: np.ndarray, coordinates: Sequence[str]) -> float | None:
    """The link's inertia about ``coordinate``'s joint in the model file: D's diagonal entry at ``position`` (the
    data's coordinates in ``coordinates`` order; the model's others at 0) less the rotor's Ia·ratio², at the
    file's values; ``None`` without a model."""
    if model is None:
        return None
    names = list(model.robot.generalized_coordinates)
    at = {symbol: sp.Float(value) for symbol, value in model.parameters.items()}
    at.update({symbol: sp.Float(0) for symbol in model.coordinates})
    at.update({model.coordinates[names.index(c)]: sp.Float(float(x)) for c, x in zip(coordinates, position) if c in names})
    k = names.index(coordinate)
    return float((model.D[k, k] - reflected_rotors(model.robot)[k, k]).xreplace(at))


def rotor_inertia(robot: Any, coordinate: str) -> float:
    """The rotor's inertia at ``coordinate``'s joint in the model file, Ia·ratio² at the file's values (0 without one)."""
    k = robot.generalized_coordinates.index(coordinate)
    return float(reflected_rotors(robot)[k, k].xreplace({s: sp.Float(v) for s, v in robot.parameter_values.items()}))


register(OneEncoder())

"""``backlash`` from the motor's encoder alone: a dead band in an elastic transmission, found by the link's rattle.

The two encoders' test (:mod:`symbolic.workflow.effects.joint_elasticity`, "Backlash") measures the deflection and
fits the band on it. From the motor's encoder alone the deflection δ = q − q_l is not measured, but the link's
equation at the motor's position still gives it (Spong's reduced model, the link's side, with the transmitted torque
of a dead band of whole width b: nothing inside |δ| ≤ b/2, spring and damper in contact)::

    D_jj·δ̈ + B_jj·δ̇ + A_jj·δ + [|δ| > b/2]·(k·(δ − b/2·sgn δ) + d·δ̇) = T_j

with T_j the rigid link's torque at the motor's q, q̇, q̈ and A, B, D the link's side of the rigid model
(:class:`~symbolic.workflow.effects.joint_elasticity.LinkSide`). It is not linear in δ, so no filter gives δ: it is
integrated over the record (:func:`rattle`, symplectic Euler at a few sub-steps a sample, the logged signals
interpolated linearly between samples, from rest against the first sample's torque), per value of the grid
(ω, ζ, b), k = D̄·ω² and d = 2ζω·D̄ (D̄ the link's mean inertia about the joint). Every row i of the rigid model then
misses the link's reaction −(D_ij·δ̈ + A_ij·δ + B_ij·δ̇), as in the linear case: the column, linear in the load J_L
(≈ D̄) for a given (ω, ζ, b). The search compares it with the linear spring (``joint_elasticity``, one encoder)
on the same coordinate; each excludes the other.

A rigid joint has no such rattle, and a spring without a band fits as well with b → 0: the band's width must lie
inside the range searched (then the linear spring, one parameter fewer, is the one named); like a resonance, the
rattle must show in the residual's spectrum near its contact frequency or explain most of the whole residual
(:meth:`~symbolic.workflow.effects.flexible_mode.FlexibleMode.check_residual`).

What the motor's encoder tells is the width. A lightly damped link rattling in its band is chaotic: δ integrated from
the motor's filtered motion cannot follow the ringing after each impact, and a damped contact fits its mean — the
contact's k and d come out as effective values (docs/workflow.md, "Backlash from the motor encoder alone").
"""

from __future__ import annotations

import ctypes
import math
import weakref
from collections.abc import Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from symbolic.workflow.effects.base import on_row, register
from symbolic.workflow.effects.flexible_mode import FlexibleMode, second_mass
from symbolic.workflow.effects.joint_elasticity import LinkSide, OneEncoder


class Backlash(OneEncoder):
    """``backlash`` from the motor's encoder alone (module docstring). Roles: the band's whole ``width`` b, the
    spring's ``stiffness`` k = J_L·ω² and ``damping`` d = 2ζω·J_L in contact; written as Spong's joint with the
    dead band, as two encoders write it (:func:`~symbolic.workflow.effects.joint_elasticity.patch`)."""

    name, contract, variant = "backlash_one_encoder", "backlash", "one_encoder"
    rank = 121
    roles = ("width", "stiffness", "damping")
    nonlinear = "contact frequency, damping ratio and width"
    summary = "a dead band between motor and link seen by the motor encoder alone: the link rattles in it"
    formula = "−(D_ij·δ̈ + A_ij·δ + B_ij·δ̇) on every row i, δ the link's deflection in a dead band of width b (integrated)"
    regressors = "the link's reaction to its deflection, δ integrated from its torque T_j through the band and the spring; (ω, ζ, b) on a grid"
    written_as = "Spong's joint with the dead band: `<q>_flex` added to the joint's DH, `[[force]]` −(k·(x ∓ b/2) + d·ẋ) in contact, 0 inside"
    roles_note = "the spring's in contact"
    units = {"width": "{position}", "stiffness": "{force}/{position}", "damping": "{force}·s/{position}"}
    excludes = ("joint_elasticity_one_encoder",)

    DAMPING = (0.1, 0.3)
    """Damping ratios of the grid in contact (the linear spring's span, coarser: the grid has a third axis)."""
    SPACING = 1.25
    """Ratio of neighbouring grid frequencies in contact (the simplex search refines between them)."""
    WIDTHS = tuple(float(x) for x in np.geomspace(1e-4, 1e-1, 8))
    """Widths of the grid as fractions of the coordinate's range of motion (its 2–98 % quantiles): from a gear's
    tenth of a milliradian on a joint turning a radian, to a tenth of the motion (the tests' joint turns 0.4 rad:
    4e-5 to 0.04 rad)."""

    MIN_COUNTS = 4.0
    """A band must span at least this many of the log's position steps (an encoder's counts): a loop that feeds back
    a quantised position hunts about it by a count or two, which the rattle's column fits (the tests' axis and arm
    under PD with 12- and 14-bit encoders and nothing missing: bands of 0.2–2.2 counts named before this rule)."""

    def grid(self, context, j):
        frequencies = self.frequencies(context)
        span = float(np.subtract(*np.quantile(context.q[:, j], [0.98, 0.02])))
        if frequencies is None or not span > 0:
            return None
        rows = np.array([(f, z, w * span) for f in frequencies for z in self.DAMPING for w in self.WIDTHS])
        return rows, float(len(rows))

    def motions(self, link, value, rate):
        """The link's one motion: δ from :func:`rattle` at ``value`` = (contact frequency in Hz, ζ, b) (the linear
        spring's column, :meth:`OneEncoder.columns_at`, with it)."""
        return [rattle(link, value, rate)]

    def roles_of(self, c, value, reference):
        return {"width": float(value[2]), **super().roles_of(c, value, reference)}

    def band(self, roles):
        return {"width": roles["width"], "centre": 0.0}

    def check(self, roles, reference, context, j):
        return self._located(roles, context, j) or self._link_check(roles, context, j)

    def _located(self, roles, context, j) -> str | None:
        """Why the band is not one (a load that is not positive, a contact frequency or width at the edge of the grid's
        box), or ``None``. The damping ratio may lie at its edge: the contact's damping is an effective value
        (module docstring), fitted to the rattle's mean where its ringing cannot be followed."""
        if roles["load"] <= 0:
            return f"load inertia {roles['load']:.4g} is not positive (no link rattles so)"
        step = context.position_step[j] if context.position_step else 0.0
        if roles["width"] < self.MIN_COUNTS * step:
            return (f"the band's width {roles['width']:.4g} is {roles['width'] / step:.3g} of the log's position steps "
                    f"({step:.4g}; at least {self.MIN_COUNTS:g} needed): a loop hunting about its quantised reading "
                    "rattles so")
        rows = self.grid(context, j)[0]
        located = [("contact frequency", roles["frequency_hz"], rows[:, 0]), ("width", roles["width"], rows[:, 2])]
        for what, value, axis in located:
            if not (1 + self.EDGE) * axis.min() < value < (1 - self.EDGE) * axis.max():
                spring = " — a spring without a band" if what == "width" and value <= (1 + self.EDGE) * axis.min() else ""
                return (f"the dead band is not located: its {what} {value:.4g} lies at the edge of the range searched "
                        f"({axis.min():.4g}–{axis.max():.4g}){spring}")
        return None

    def as_measured(self, patched, parameters, context, j, roles, controller, period):
        return ({key: roles[key] for key in self.roles},
                {"contact_frequency_hz": roles["frequency_hz"], "contact_damping_ratio": roles["damping_ratio"],
                 "ringing": "a dead band: no linear mode at rest inside it"})


class LoadBacklash(Backlash):
    """``backlash`` of a second mass (a load on a coupling with a dead band) where the model declares no motor on
    the coordinate (``flexible_mode``'s case, which it excludes): the load J_L, unknown to the model file, is driven
    through the band by the coordinate's own acceleration, δ̈ + [|δ| > b/2]·(ω²·(δ ∓ b/2) + 2ζω·δ̇) = q̈ (the link's
    equation of the module docstring divided by J_L, without weight or couplings), and the coordinate supplies
    J_L·(q̈ − δ̈) besides the model: the column −δ̈ on its own row (the model's q̈ absorbs J_L·q̈). Written as
    ``flexible_mode``'s second mass with the band in its coupling
    (:func:`~symbolic.workflow.effects.flexible_mode.second_mass`)."""

    name, variant = "backlash_second_mass", "second_mass"
    rank = 122
    summary = "a dead band between the coordinate and a load the model does not hold: the load rattles in it"
    formula = "−J_L·δ̈ on q's row, δ̈ + [|δ| > b/2]·(ω²·(δ ∓ b/2) + 2ζω·δ̇) = q̈ (integrated)"
    regressors = "the load's deflection integrated from q̈ through the band and the coupling; (ω, ζ, b) on a grid"
    written_as = "a second mass as `flexible_mode` writes it, its coupling −(k·(x ∓ b/2) + d·ẋ) in contact, 0 inside"
    excludes = ("flexible_mode",)
    own_row = True

    def applicable(self, context, j):
        return FlexibleMode.applicable(self, context, j)

    def columns_at(self, signals, j, value):
        return on_row(j, signals.qdd.shape[1], [self.row_columns_at(signals, j, value)[:, 0]])

    def row_columns_at(self, signals, j, value):
        """−δ̈ of the load (``samples × 1``), δ from :func:`rattle` driven by the coordinate's q̈ alone."""
        if signals.record is not None:  # the load's state at the first sample is what the motion before left
            whole = self.row_columns_at(signals.record, j, value)
            return whole[signals.start:signals.start + len(signals.t)]
        return -rattle(_load(signals, j), value, signals.rate)[2][:, None]

    def roles_of(self, c, value, reference):
        roles = super().roles_of(c, value, None)  # no motor: the coordinate's own inertia is the model's
        return roles

    def check(self, roles, reference, context, j):
        problem = self._located(roles, context, j)
        if problem is None and reference is not None and len(context.coordinates) == 1 and reference <= 0:
            return f"the inertia left on the coordinate's own side, {reference:.4g}, is not positive"
        return problem

    def patch(self, editor, context, j, roles, c, value, comment):
        return second_mass(editor, context, j, roles["load"], roles["stiffness"], roles["damping"], comment,
                           band=roles["width"])


_LOADS: "weakref.WeakKeyDictionary[Any, dict[int, LinkSide]]" = weakref.WeakKeyDictionary()
"""The loads of :class:`LoadBacklash` per signals and coordinate: a scan integrates some hundred values of one."""


def _load(signals: Any, j: int) -> LinkSide:
    """The load of :class:`LoadBacklash` on coordinate ``j`` as a :class:`LinkSide` driven by q̈_j alone (unit
    inertia, no stiffness or damping of its own), made once per signals (its :attr:`LinkSide.driving` with it)."""
    loads = _LOADS.setdefault(signals, {})
    if j not in loads:
        acceleration = signals.qdd[:, j]
        ones, zeros = np.ones((len(acceleration), 1)), np.zeros((len(acceleration), 1))
        loads[j] = LinkSide(acceleration, ones, zeros, zeros, ones[:, 0], 1.0, 0)
    return loads[j]


def rattle(link: LinkSide, value: tuple[float, float, float], rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """δ, δ̇, δ̈ of the link behind the joint in a dead band (module docstring) at ``value`` = (contact frequency in Hz,
    ζ, whole width b), k = D̄·ω², d = 2ζω·D̄: symplectic Euler with :func:`substeps` steps a sample, the link's torque
    and coefficients interpolated linearly between samples, from rest against the first sample's torque. Compiled
    C (:data:`SOURCE`, called through ctypes) where a compiler is found, else the same loop in Python."""
    frequency, damping, width = value
    w = 2.0 * math.pi * frequency
    inputs = link.driving
    parameters = np.array([w * w, 2.0 * damping * w, 0.5 * width, link.mean])
    first = link.torque[0] / (link.mean * w * w)
    start = first + math.copysign(0.5 * width, first) if first else 0.0
    out = np.empty((len(inputs), 3))
    run = (_compiled_free() if link.free else None) or _compiled() or _loop
    run(inputs, parameters, substeps(w, rate), 1.0 / rate, start, out)
    return out[:, 0], out[:, 1], out[:, 2]


def substeps(w: float, rate: float) -> int:
    """Sub-steps a sample so that ω·h stays below 0.2 (symplectic Euler's phase error under 0.2 %)."""
    return max(1, math.ceil(w / rate / 0.2))


SOURCE = """\
#include <math.h>
static double acceleration(double x, double v, const double *u, const double *p) {
    double excess = fabs(x) - p[2];
    double band = excess > 0.0 ? p[3] * (p[0] * copysign(excess, x) + p[1] * v) : 0.0;
    return (u[0] - u[3] * v - u[2] * x - band) / u[1];
}
void symbolic_rattle(long samples, const double *inputs, const double *p, long steps, double h, double start,
                     double *out) {
    double x = start, v = 0.0, u[4];
    for (long k = 0; k < samples; ++k) {
        const double *a = inputs + 4 * k, *b = inputs + 4 * (k + 1 < samples ? k + 1 : k);
        out[3 * k] = x;
        out[3 * k + 1] = v;
        out[3 * k + 2] = acceleration(x, v, a, p);
        for (long s = 0; s < steps; ++s) {
            double f = (double)s / (double)steps;
            for (int i = 0; i < 4; ++i) u[i] = a[i] + (b[i] - a[i]) * f;
            v += h / steps * acceleration(x, v, u, p);
            x += h / steps * v;
        }
    }
}
static double free_acceleration(double x, double v, double u, const double *p) {
    double excess = fabs(x) - p[2];
    double band = excess > 0.0 ? p[3] * (p[0] * copysign(excess, x) + p[1] * v) : 0.0;
    return u - band;
}
void symbolic_rattle_free(long samples, const double *inputs, const double *p, long steps, double h, double start,
                          double *out) {
    double x = start, v = 0.0;
    for (long k = 0; k < samples; ++k) {
        const double *a = inputs + 4 * k, *b = inputs + 4 * (k + 1 < samples ? k + 1 : k);
        out[3 * k] = x;
        out[3 * k + 1] = v;
        out[3 * k + 2] = free_acceleration(x, v, a[0], p);
        for (long s = 0; s < steps; ++s) {
            double f = (double)s / (double)steps;
            v += h / steps * free_acceleration(x, v, a[0] + (b[0] - a[0]) * f, p);
            x += h / steps * v;
        }
    }
}
"""
"""The integration of :func:`rattle` as a C loop over the samples; ``symbolic_rattle_free`` the same for a free
load (:attr:`~symbolic.workflow.effects.joint_elasticity.LinkSide.free`: unit inertia, no stiffness or damping of its
own), without the terms that are then 0 and the division by 1: the same numbers (but the sign of a zero), a third
less time (the division is most of the loop's latency)."""


@lru_cache(maxsize=None)
def _library() -> Any:
    """:data:`SOURCE` compiled and loaded, or ``None`` without a compiler."""
    from symbolic.codegen.compiled import load_library

    return load_library(SOURCE, "rattle", ctypes.CDLL)


@lru_cache(maxsize=None)
def _compiled_free() -> Any:
    """The C loop of :data:`SOURCE` for a free load (``symbolic_rattle_free``), as :func:`_compiled`'s."""
    return None if _library() is None else _runner(_library().symbolic_rattle_free)


@lru_cache(maxsize=None)
def _compiled() -> Any:
    """The C loop of :data:`SOURCE` as ``(inputs, parameters, steps, h, start, out) -> None``, or ``None`` without a
    compiler."""
    return None if _library() is None else _runner(_library().symbolic_rattle)


def _runner(function: Any) -> Any:
    """``function`` of :data:`SOURCE` (its arguments typed) as ``(inputs, parameters, steps, h, start, out) -> None``."""
    function.restype = None
    function.argtypes = [ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_long, ctypes.c_double,
                         ctypes.c_double, ctypes.c_void_p]

    def run(inputs: np.ndarray, parameters: np.ndarray, steps: int, h: float, start: float, out: np.ndarray) -> None:
        function(len(inputs), inputs.ctypes.data, parameters.ctypes.data, steps, h, start, out.ctypes.data)

    return run


def _loop(inputs: np.ndarray, parameters: np.ndarray, steps: int, h: float, start: float, out: np.ndarray) -> None:
    """:data:`SOURCE`'s loop in Python (no compiler: slower, the same numbers to rounding)."""
    w2, c, half, mean = (float(x) for x in parameters)

    def acceleration(x: float, v: float, u: Sequence[float]) -> float:
        excess = abs(x) - half
        band = mean * (w2 * math.copysign(excess, x) + c * v) if excess > 0.0 else 0.0
        return (u[0] - u[3] * v - u[2] * x - band) / u[1]

    x, v, n = start, 0.0, len(inputs)
    rows = inputs.tolist()
    for k in range(n):
        a, b = rows[k], rows[min(k + 1, n - 1)]
        out[k] = (x, v, acceleration(x, v, a))
        for s in range(steps):
            f = s / steps
            v += h / steps * acceleration(x, v, [ai + (bi - ai) * f for ai, bi in zip(a, b)])
            x += h / steps * v


register(Backlash(), LoadBacklash())

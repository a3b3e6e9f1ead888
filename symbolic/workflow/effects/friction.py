"""Friction the model lacks or has wrong: Coulomb, viscous, offset, their direction dependence, a Stribeck rise."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from symbolic.description.names import STRIBECK_STEM, coefficient_name, friction_stem
from symbolic.description.robot import Directional
from symbolic.workflow.effects.base import Context, Effect, Roles, on_row, register


def _nonnegative(roles: Roles, *names: str) -> str | None:
    bad = [f"{n} = {roles[n]:.4g}" for n in names if roles[n] is not None and roles[n] < 0]
    return f"negative {', '.join(bad)} (friction opposes motion)" if bad else None


class _FrictionTerm(Effect):
    """A friction coefficient missing from the model: ``key`` of the coordinate's [[friction]] table."""

    key: ClassVar[str]

    def applicable(self, context: Context, j: int) -> str | None:
        c = context.coordinates[j]
        for f in context.robot.frictions:
            if f.coordinate == c and isinstance(getattr(f, self.key), Directional):
                return f"the model's {self.key} friction on {c} is direction-dependent"
        return None

    def reference_column(self, q, qd, qdd, j):
        return self.columns(q, qd, qdd, j, None)[:, :, 0]  # a coefficient written inline (fixed) is added to

    def roles_of(self, c: np.ndarray, value: float | None, reference: float | None) -> Roles:
        return {self.roles[0]: float(c[0])}

    def check(self, roles, reference, context, j):
        total = dict(roles)
        total[self.roles[0]] = roles[self.roles[0]] + (reference or 0.0)
        return _nonnegative(total, self.roles[0])

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        name = editor.parameter(coefficient_name(friction_stem(self.key), coordinate), roles[self.roles[0]], comment)
        old = editor.friction_value(coordinate, self.key)
        editor.set_friction(coordinate, self.key, name if old is None else f"{old} + {name}", comment)
        return {name: roles[self.roles[0]]}


class Coulomb(_FrictionTerm):
    name, roles, key = "coulomb", ("coulomb",), "coulomb"
    summary = "Coulomb friction Fc·sign(q̇)"
    formula, regressors, written_as = 'Fc·sign(q̇)', 'sign(q̇)', '`[[friction]] coulomb`'
    rank, units = 10, {"coulomb": "{force}"}

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.sign(qd[:, j])])


class Viscous(_FrictionTerm):
    name, roles, key = "viscous", ("viscous",), "viscous"
    summary = "viscous friction Fv·q̇"
    formula, regressors, written_as = 'Fv·q̇', 'q̇', '`[[friction]] viscous`'
    rank, units = 20, {"viscous": "{force}·s/{position}"}
    together = ("coulomb",)  # the friction a model without any lacks: both at once, as one hypothesis

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [qd[:, j]])


class Offset(_FrictionTerm):
    name, roles, key = "offset", ("offset",), "offset"
    summary = "constant generalized force (drive offset, unmodelled constant load)"
    formula, regressors, written_as = 'constant', '1', '`[[friction]] offset`'
    rank, units = 30, {"offset": "{force}"}

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.ones(len(q))])

    def reference_column(self, q, qd, qdd, j):
        return None

    def check(self, roles, reference, context, j):
        return None


class _Asymmetric(Effect):
    """Direction dependence of a friction coefficient the model has: ``positive``/``negative`` are the
    total coefficients for q̇ > 0 and q̇ < 0; the column is the half-difference's."""

    roles = ("positive", "negative")
    key: ClassVar[str]

    def applicable(self, context, j):
        c = context.coordinates[j]
        for f in context.robot.frictions:
            if f.coordinate == c and f.stribeck is not None and self.key == "coulomb":
                return f"the model's Coulomb friction on {c} has a Stribeck rise"
        return None

    def reference_column(self, q, qd, qdd, j):
        v = qd[:, j]
        return on_row(j, q.shape[1], [v if self.key == "viscous" else np.sign(v)])[:, :, 0]

    def roles_of(self, c, value, reference):
        return {"positive": reference + float(c[0]), "negative": reference - float(c[0])}

    def check(self, roles, reference, context, j):
        return _nonnegative(roles, "positive", "negative")

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        positive, negative = (editor.parameter(coefficient_name(friction_stem(self.key, d), coordinate), roles[d], comment)
                              for d in ("positive", "negative"))
        editor.set_friction(coordinate, self.key, {"positive": positive, "negative": negative}, comment)
        return {positive: roles["positive"], negative: roles["negative"]}


class AsymmetricViscous(_Asymmetric):
    name, refines, key = "asymmetric_viscous", "viscous", "viscous"
    summary = "direction-dependent viscous friction Fv⁺·q̇ (q̇ > 0), Fv⁻·q̇ (q̇ < 0)"
    formula, regressors, written_as = 'Fv⁺·q̇ (q̇>0), Fv⁻·q̇ (q̇<0)', "\\|q̇\\| beside the model's q̇", '`viscous = { positive, negative }`'
    roles_note = 'totals'
    rank, guide = 90, "slope"
    units = {"positive": "{force}·s/{position}", "negative": "{force}·s/{position}"}
    symbols = {"positive": "Fv⁺", "negative": "Fv⁻"}

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.abs(qd[:, j])])


class AsymmetricCoulomb(_Asymmetric):
    name, refines, key = "asymmetric_coulomb", "coulomb", "coulomb"
    summary = "direction-dependent Coulomb friction Fc⁺ (q̇ > 0), −Fc⁻ (q̇ < 0)"
    formula, regressors, written_as = 'Fc⁺ (q̇>0), −Fc⁻ (q̇<0)', "1 beside the model's sign(q̇)", '`coulomb = { positive, negative }`'
    roles_note = 'totals'
    rank, guide = 100, "level"
    units = {"positive": "{force}", "negative": "{force}"}
    symbols = {"positive": "Fc⁺", "negative": "Fc⁻"}
    excludes = ("stribeck",)  # both change the Coulomb level near zero speed: one explains what the other would

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.ones(len(q))])


class Stribeck(Effect):
    """(Fc + (Fs − Fc)·exp(−(q̇/vs)²))·sign(q̇): the column exp(−(q̇/vs)²)·sign(q̇) with coefficient Fs − Fc."""

    own_row = True

    name, roles, refines, nonlinear = "stribeck", ("static", "velocity"), "coulomb", "velocity"
    summary = "Stribeck rise of the Coulomb level at low speed: static level Fs, velocity scale vs"
    formula, regressors, written_as = '(Fc + (Fs−Fc)·e^{−(q̇/vs)²})·sign(q̇)', 'e^{−(q̇/vs)²}·sign(q̇); vs on a grid', '`stribeck = { static, velocity }`'
    rank, units = 110, {"static": "{force}", "velocity": "{position}/s"}
    GRID = 32

    def applicable(self, context, j):
        c = context.coordinates[j]
        for f in context.robot.frictions:
            if f.coordinate == c and f.stribeck is not None:
                return f"the model already has a Stribeck term on {c}"
        return None

    def grid(self, context, j):
        v = np.abs(context.qd[:, j])
        top = float(v.max())
        if top <= 0:
            return None
        # Not below the speed the axis passes through between two kept samples at its reversals: a
        # narrower rise would rest on one or two samples per reversal, where the velocity estimate and
        # its sign are least reliable (a sign that flips a sample early or late looks like a Stribeck
        # term of vanishing width). Not above 30 % of the largest speed: a wider exponential is a smooth
        # function of q̇ that viscous friction already describes.
        near = v < 0.05 * np.percentile(v, 95)
        step = float(np.median(np.abs(context.qdd[near, j]))) * context.kept_period if near.any() else 0.0
        low, high = max(0.003 * top, 2.0 * step), 0.3 * top
        if high <= low:
            return None
        return np.geomspace(low, high, self.GRID), 2.0 * math.log10(high / low)

    def columns(self, q, qd, qdd, j, value):
        v = qd[:, j]
        return on_row(j, q.shape[1], [np.exp(-((v / value) ** 2)) * np.sign(v)])

    def reference_column(self, q, qd, qdd, j):
        return on_row(j, q.shape[1], [np.sign(qd[:, j])])[:, :, 0]

    def roles_of(self, c, value, reference):
        return {"static": reference + float(c[0]), "velocity": float(value)}

    def check(self, roles, reference, context, j):
        if roles["static"] <= reference:
            return f"static level {roles['static']:.4g} is not above the Coulomb level {reference:.4g}"
        return _nonnegative(roles, "static")

    def null_values(self, written):
        # absent at a static level equal to the Coulomb level, which is another effect's value: not written here
        return {}

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        static = editor.parameter(coefficient_name(STRIBECK_STEM, coordinate), roles["static"], comment)
        velocity = editor.parameter(coefficient_name("vs", coordinate), roles["velocity"], comment)
        editor.set_friction(coordinate, "stribeck", {"static": static, "velocity": velocity}, comment)
        return {static: roles["static"], velocity: roles["velocity"]}


register(Coulomb(), Viscous(), Offset(), AsymmetricViscous(), AsymmetricCoulomb(), Stribeck())

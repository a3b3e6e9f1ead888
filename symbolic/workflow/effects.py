"""The catalogue of physical effects the workflow can name, and the registry a user adds to.

Each effect is a named, parametrised term that a model file can hold. It says

* on which coordinates it can act (:meth:`Effect.applicable`);
* its columns: the term is ``columns(q, q̇, q̈) · c`` on the τ side (what the actuators must supply in
  addition), linear in the coefficients ``c``; an effect with one nonlinear parameter (a Stribeck
  velocity, a period) gives a grid of values for it (:meth:`Effect.grid`), and the search fits ``c``
  at each value and refines the best;
* its parameters under the role names of the JSON contract (:meth:`Effect.roles_of`), whether they
  are physical (:meth:`Effect.check`), and how it is written into the model file (:meth:`Effect.patch`:
  ``[[friction]]``, ``[[force]]`` or ``[[drive]]`` entries and new ``[parameters]``).

A *refinement* (``refines = "viscous"`` or ``"coulomb"``) changes a friction term the model already has
on that coordinate (direction dependence, a Stribeck rise); it receives that term's current coefficient
as ``reference`` and is a candidate only when the model (or an accepted effect) has that term.

Adding an effect: subclass :class:`Effect`, set ``name``, ``roles``, ``summary``, ``axis``; implement
``columns``, ``roles_of`` and ``patch`` (and ``applicable``, ``grid``, ``check`` where needed); then
``register(MyEffect())``. The search and the report use only this interface.

Variants: two catalogue entries may be variants of one contract identifier (``periodic`` in position
and in time). Each has its own registry key ``name`` (``periodic``, ``periodic_time``); ``contract``
names the identifier the JSON reports (:attr:`Effect.identifier`) and ``variant`` which one it is (the
JSON's ``variant``, the report's "periodic (in time)"). :func:`select` resolves a user's names: a
registry key, or a contract identifier meaning all its variants (``--effects periodic``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import sympy as sp

from symbolic.data.controller import Controller
from symbolic.description.robot import Directional, Robot, coordinate_symbol
from symbolic.description.units import coordinate_kind
from symbolic.workflow.payload import PHYSICAL, chain_ends, physical_inertia, structure

if TYPE_CHECKING:
    from symbolic.derivation.dynamics import DynamicModel
    from symbolic.workflow.patch import Editor

Roles = dict[str, float | None]


@dataclass(frozen=True, eq=False)
class Context:
    """What an effect may know: the model's robot, its coordinates and what kind each is, and the
    estimation data's filtered states at every sample (``samples × N``)."""

    robot: Robot
    coordinates: tuple[str, ...]
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    passband: float
    """Highest frequency (Hz) that the treatment keeps: the decimation filter's pass band."""
    kept_period: float
    """Time between two kept (decimated) samples (s)."""
    duration: float = 0.0
    """Time span of the estimation data (s), first to last sample."""
    rate: float = 0.0
    """Sampling rate of ``q``, ``qd``, ``qdd`` (Hz)."""
    model: Any = None
    """The derived model (:class:`symbolic.derivation.dynamics.DynamicModel`), for an effect whose columns
    depend on the model's own span (a payload)."""
    unactuated: frozenset[str] = frozenset()
    """Coordinates whose force is zero throughout the data (no actuator: a homogeneous equation)."""
    terms: Any = None
    """The model's terms as the search fits them (:class:`symbolic.workflow.terms.ModelTerms`): which base
    columns are free (a parameter kept at its value, ``fixed = true`` or ``--fix``, is not); ``None``: all."""

    def kind(self, coordinate: str) -> str:
        """``"revolute"`` (the coordinate is in a DH θ), ``"prismatic"`` (in a d) or ``"modal"``
        (:func:`symbolic.description.units.coordinate_kind`)."""
        return coordinate_kind(self.robot, coordinate)


@dataclass(frozen=True, eq=False)
class Signals:
    """The filtered states of one data set at every sample (before the border is dropped and the data
    decimated), their time stamps and the sampling rate: what :meth:`Effect.columns_at` may use."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    t: np.ndarray
    rate: float
    robot: Robot | None = None
    """The model's robot (for an effect whose columns need the geometry, e.g. a payload)."""
    record: Signals | None = None
    """When these samples continue a contiguous record (the held-out tail of the estimation data): the
    whole record's signals, filtered as one; an effect with memory (a filter) runs through it and keeps
    samples ``start`` to ``start + len(t)``, so that its state at the first sample is that of the motion
    before. ``None`` otherwise (a separate data set: its start is a guess)."""
    start: int = 0


def on_row(j: int, n: int, columns: list[np.ndarray]) -> np.ndarray:
    """``samples × n × k``: the given per-sample columns acting on coordinate ``j`` only."""
    out = np.zeros((len(columns[0]), n, len(columns)))
    for k, column in enumerate(columns):
        out[:, j, k] = column
    return out


class Effect:
    """Base class of catalogue entries (module docstring)."""

    name: ClassVar[str]
    roles: ClassVar[tuple[str, ...]]
    summary: ClassVar[str]
    axis: ClassVar[str] = "velocity"
    """The state the effect is a function of, for the report's figure: position, velocity, acceleration
    or time (a filtered term, which is a function of none of them alone)."""
    refines: ClassVar[str | None] = None
    contract: ClassVar[str | None] = None
    """The contract identifier when it differs from ``name`` (a variant; module docstring)."""
    variant: ClassVar[str | None] = None
    """Which variant of its contract identifier the effect is (``"position"``, ``"time"``), or ``None``."""
    nonlinear: ClassVar[str | None] = None
    """The role of the nonlinear parameter, if the effect has one (its grid comes from :meth:`grid`)."""
    refinement: ClassVar[float] = 1e-4
    """Relative precision to which a single nonlinear parameter is refined between its grid neighbours."""
    optional: ClassVar[tuple[int, ...]] = ()
    """Columns that the model may already hold (e.g. a spring's constant when there is an offset)."""
    groupable: ClassVar[bool] = True
    """Whether the search also offers the effect on every coordinate (or a named group) as one grouped
    hypothesis (docs/workflow.md, "Grouped hypotheses"); only effects without a nonlinear parameter whose
    columns act on their own coordinate are grouped."""
    own_row: ClassVar[bool] = False
    """Whether its columns on coordinate ``j`` act on ``j``'s row alone (built with :func:`on_row`): the search
    then does not look for the rows they act on (it scans every other row of every column otherwise)."""

    @property
    def identifier(self) -> str:
        """The contract identifier (the JSON's ``effect``): ``contract``, else ``name``."""
        return self.contract or self.name

    def label(self) -> str:
        """How the report names it: the identifier, with the variant (``periodic (in time)``)."""
        return self.identifier if self.variant is None else f"{self.identifier} (in {self.variant})"

    def applicable(self, context: Context, j: int) -> str | None:
        """``None`` when the effect can act on coordinate ``j``, else the reason why not."""
        return None

    def grid(self, context: Context, j: int) -> tuple[np.ndarray, float] | None:
        """For a nonlinear effect: the values of its nonlinear parameter to scan (increasing) and the
        number of independent trials they amount to (for the multiple-testing correction). An effect
        with several nonlinear parameters returns a ``values × parameters`` array (positive values; the
        best row is refined by a simplex search in their logarithms, within the grid's box) and its
        ``columns`` receive a tuple."""
        return None

    def columns(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, j: int, value: float | None) -> np.ndarray:
        """The effect's columns, ``samples × N × k``, at states ``samples × N``."""
        raise NotImplementedError

    def columns_at(self, signals: Signals, j: int, value: float | tuple[float, ...] | None) -> np.ndarray:
        """The effect's columns from the signals (``samples × N × k``). The default calls :meth:`columns`;
        an effect that needs time or the sampling rate (a filter, a time-periodic term) overrides this."""
        return self.columns(signals.q, signals.qd, signals.qdd, j, value)

    def scan_columns(self, t: np.ndarray, n: int, j: int, values: Sequence[float]) -> list[np.ndarray] | np.ndarray | None:
        """For scanning a single nonlinear parameter's grid: the columns at the kept (decimated) times
        ``t`` directly (``samples × n × k`` per value: a list, or one ``values × samples × n × k`` array; or,
        for columns that act on coordinate ``j`` alone, the compact ``values × samples × k`` array), when that is cheaper than treating
        :meth:`columns_at`'s and spans the same columns up to an invertible mixing (the scan compares only
        the power they explain, in the grid and in its refinement; the value found is then fitted with the
        treated columns). ``None``: no shortcut."""
        return None

    def scan_verdict(self, values: np.ndarray, explained: np.ndarray, context: Context) -> str | None:
        """After a single nonlinear parameter's grid is scanned (``explained``: the residual power each
        grid value explains): why the best value is not the effect's, judged on the whole scan, or
        ``None``. Default: nothing to say."""
        return None

    def setting(self, context: Context, j: int) -> Any:
        """For an effect without a nonlinear parameter: what fixes its form on coordinate ``j`` (a payload's
        frame and columns), passed as ``value`` to :meth:`columns_at`, :meth:`roles_of` and :meth:`patch`.
        Default ``None``."""
        return None

    def describe(self, value: Any) -> dict[str, Any]:
        """Evidence about the effect's form for the report and the JSON (at ``value``: its nonlinear
        parameter or :meth:`setting`). Default: nothing."""
        return {}

    def reference_column(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, j: int) -> np.ndarray | None:
        """The column (``samples × N``) of the model's term whose current coefficient the effect needs
        (``reference``: e.g. the Coulomb level a Stribeck rise starts from), or ``None``."""
        return None

    def roles_of(self, c: np.ndarray, value: float | None, reference: float | None) -> Roles:
        """Parameters by role from the coefficients ``c`` (NaN for an absorbed optional column)."""
        raise NotImplementedError

    def check(self, roles: Roles, reference: float | None, context: Context, j: int) -> str | None:
        """``None`` when the parameters are physical, else why not (then the effect is not accepted)."""
        return None

    def patch(self, editor: Editor, context: Context, j: int, roles: Roles, c: np.ndarray, value: float | None,
              comment: str) -> dict[str, float]:
        """Write the effect on coordinate ``j`` into the model file; return the parameters written."""
        raise NotImplementedError

    def check_residual(self, roles: Roles, frequency: np.ndarray, psd: np.ndarray, share: float) -> str | None:
        """``None`` when the residual the effect is fitted to shows what it claims, else why not; ``frequency``
        and ``psd`` are the Welch spectrum of that residual on the effect's coordinate, ``share`` the part
        of the whole (stacked) residual's power the effect explains. Default: nothing to check (a resonance
        overrides this: it must ring)."""
        return None

    def as_measured(self, patched: DynamicModel, parameters: Mapping[str, float], context: Context, j: int,
                    roles: Roles, controller: Controller | None, period: float) -> tuple[Roles, dict[str, Any]]:
        """The roles as the data show them, given the patched model (``parameters``: its values) and the
        data's ``[controller]`` (checked when loaded; ``None`` when none is declared), and evidence to add.
        Default: unchanged.
        A resonance overrides this: what the data show is the closed-loop mode, not the load's own."""
        return roles, {}


def _nonnegative(roles: Roles, *names: str) -> str | None:
    bad = [f"{n} = {roles[n]:.4g}" for n in names if roles[n] is not None and roles[n] < 0]
    return f"negative {', '.join(bad)} (friction opposes motion)" if bad else None


class _FrictionTerm(Effect):
    """A friction coefficient missing from the model: ``key`` of the coordinate's [[friction]] table."""

    key: ClassVar[str]
    stem: ClassVar[str]

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
        name = editor.parameter(f"{self.stem}_{coordinate}", roles[self.roles[0]], comment)
        old = editor.friction_value(coordinate, self.key)
        editor.set_friction(coordinate, self.key, name if old is None else f"{old} + {name}", comment)
        return {name: roles[self.roles[0]]}


class Coulomb(_FrictionTerm):
    name, roles, key, stem = "coulomb", ("coulomb",), "coulomb", "Fc"
    summary = "Coulomb friction Fc·sign(q̇)"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.sign(qd[:, j])])


class Viscous(_FrictionTerm):
    name, roles, key, stem = "viscous", ("viscous",), "viscous", "Fv"
    summary = "viscous friction Fv·q̇"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [qd[:, j]])


class Offset(_FrictionTerm):
    name, roles, key, stem = "offset", ("offset",), "offset", "offset"
    summary = "constant generalized force (drive offset, unmodelled constant load)"

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
    stems: ClassVar[tuple[str, str]]

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
        positive = editor.parameter(f"{self.stems[0]}_{coordinate}", roles["positive"], comment)
        negative = editor.parameter(f"{self.stems[1]}_{coordinate}", roles["negative"], comment)
        editor.set_friction(coordinate, self.key, {"positive": positive, "negative": negative}, comment)
        return {positive: roles["positive"], negative: roles["negative"]}


class AsymmetricViscous(_Asymmetric):
    name, refines, key, stems = "asymmetric_viscous", "viscous", "viscous", ("Fvp", "Fvn")
    summary = "direction-dependent viscous friction Fv⁺·q̇ (q̇ > 0), Fv⁻·q̇ (q̇ < 0)"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.abs(qd[:, j])])


class AsymmetricCoulomb(_Asymmetric):
    name, refines, key, stems = "asymmetric_coulomb", "coulomb", "coulomb", ("Fcp", "Fcn")
    summary = "direction-dependent Coulomb friction Fc⁺ (q̇ > 0), −Fc⁻ (q̇ < 0)"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.ones(len(q))])


class Stribeck(Effect):
    """(Fc + (Fs − Fc)·exp(−(q̇/vs)²))·sign(q̇): the column exp(−(q̇/vs)²)·sign(q̇) with coefficient Fs − Fc."""

    own_row = True

    name, roles, refines, nonlinear = "stribeck", ("static", "velocity"), "coulomb", "velocity"
    summary = "Stribeck rise of the Coulomb level at low speed: static level Fs, velocity scale vs"
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

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        static = editor.parameter(f"Fs_{coordinate}", roles["static"], comment)
        velocity = editor.parameter(f"vs_{coordinate}", roles["velocity"], comment)
        editor.set_friction(coordinate, "stribeck", {"static": static, "velocity": velocity}, comment)
        return {static: roles["static"], velocity: roles["velocity"]}


class Spring(Effect):
    """Elastic return to a rest position: the force on the system −k·(q − q0), τ side k·q − k·q0."""

    name, roles, axis, optional = "spring", ("stiffness", "rest_position"), "position", (1,)
    summary = "elastic return to a rest position (a cable, a gas spring): −k·(q − q0)"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [q[:, j], np.ones(len(q))])

    def roles_of(self, c, value, reference):
        k = float(c[0])
        rest = None if np.isnan(c[1]) or k == 0 else float(-c[1] / k)
        return {"stiffness": k, "rest_position": rest}

    def check(self, roles, reference, context, j):
        return None if roles["stiffness"] > 0 else f"stiffness {roles['stiffness']:.4g} is not positive"

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        k = editor.parameter(f"k_{coordinate}", roles["stiffness"], comment)
        if roles["rest_position"] is None:
            editor.add_force(f"spring_{coordinate}", coordinate, f"-{k}*{coordinate}",
                             comment + "; its rest position is not separable from the offset on this coordinate")
            return {k: roles["stiffness"]}
        q0 = editor.parameter(f"q0_{coordinate}", roles["rest_position"], comment)
        editor.add_force(f"spring_{coordinate}", coordinate, f"-{k}*({coordinate} - {q0})", comment)
        return {k: roles["stiffness"], q0: roles["rest_position"]}


class _Sinusoid(Effect):
    """A term a·sin(x) + b·cos(x) = A·sin(x + φ), A = √(a² + b²), φ = atan2(b, a)."""

    @staticmethod
    def polar(c: np.ndarray) -> tuple[float, float]:
        return float(math.hypot(c[0], c[1])), float(math.atan2(c[1], c[0]))

    @staticmethod
    def write(editor: Editor, force: str, coordinate: str, stems: tuple[str, str], x: str, c: np.ndarray,
              comment: str, role: str | None = None) -> dict[str, float]:
        """The term as a ``[[force]]`` −(a·sin(x) + b·cos(x)) on ``coordinate`` with new parameters
        ``<stem>_<coordinate>`` (a, b = c; with ``role``, each commented as role·cos/sin(phase))."""
        notes = (f"; {role}·cos(phase)", f"; {role}·sin(phase)") if role else ("", "")
        a = editor.parameter(f"{stems[0]}_{coordinate}", float(c[0]), comment + notes[0])
        b = editor.parameter(f"{stems[1]}_{coordinate}", float(c[1]), comment + notes[1])
        editor.add_force(f"{force}_{coordinate}", coordinate, f"-({a}*sin({x}) + {b}*cos({x}))", comment)
        return {a: float(c[0]), b: float(c[1])}


class Gravity(_Sinusoid):
    """An unbalanced or missing mass moment about a revolute coordinate: moment·sin(q + phase) on the τ side."""

    name, roles, axis = "gravity", ("moment", "phase"), "position"
    summary = "unbalanced or missing mass moment m·g·l about a revolute coordinate: moment·sin(q + phase)"

    def applicable(self, context, j):
        kind = context.kind(context.coordinates[j])
        return None if kind == "revolute" else f"{context.coordinates[j]} is {kind}, not revolute"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [np.sin(q[:, j]), np.cos(q[:, j])])

    def roles_of(self, c, value, reference):
        moment, phase = self.polar(c)
        return {"moment": moment, "phase": phase}

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        return self.write(editor, "gravity", coordinate, ("Gs", "Gc"), coordinate, c, comment, "moment")


class Periodic(_Sinusoid):
    """A disturbance periodic in position (cogging, a screw's or a gear's period): A·sin(2π·q/P + φ)."""

    own_row = True

    name, roles, axis, nonlinear, variant = "periodic", ("amplitude", "period"), "position", "period", "position"
    summary = "disturbance periodic in position (cogging, screw or gear period): amplitude·sin(2π·q/period + φ)"
    OVERSAMPLING = 4
    MAX_GRID = 4000
    TOP = 0.5

    def grid(self, context, j):
        q, v = context.q[:, j], np.abs(context.qd[:, j])
        span = float(q.max() - q.min())
        fast = float(np.percentile(v, 90))
        if span <= 0 or fast <= 0:
            return None
        # at least two periods over the range travelled (else it is a spring or gravity), and no faster in
        # time than half the treatment's pass band at the usual speed (above, the states are mostly the
        # differentiated encoder noise the low-pass leaves: errors in the regressor, not in τ)
        low, high = 2.0 / span, self.TOP * context.passband / fast
        if high <= low:
            return None
        count = min(int(math.ceil((high - low) * span * self.OVERSAMPLING)) + 1, self.MAX_GRID)
        frequencies = np.linspace(low, high, count)
        return 1.0 / frequencies[::-1], max(count / self.OVERSAMPLING, 1.0)

    def columns(self, q, qd, qdd, j, value):
        x = 2.0 * math.pi * q[:, j] / value
        return on_row(j, q.shape[1], [np.sin(x), np.cos(x)])

    def roles_of(self, c, value, reference):
        amplitude, _ = self.polar(c)
        return {"amplitude": amplitude, "period": float(value)}

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        return self.write(editor, "periodic", coordinate, ("Ps", "Pc"), f"2*pi*{coordinate}/{float(value)!r}", c, comment)


class PeriodicTime(_Sinusoid):
    """A disturbance periodic in time (mains interference, a nearby pump or fan): A·sin(2π·f·t + φ) on
    the τ side, t the data's time stamps (s), written as a ``[[force]]`` in the model file's time ``t``.
    The contract identifier is ``periodic`` (variant ``time``), as for :class:`Periodic` in position.

    The frequency grid runs from the edge of the motion's own band (:meth:`motion_band`), and at least
    :data:`CYCLES` cycles over the estimation record, to :data:`TOP` × the treatment's pass band (above,
    the decimation filter attenuates it), spaced :data:`OVERSAMPLING` times finer than the record's
    Fourier resolution 1/T. A term in time is told apart from the terms in the states that the model
    misses only where the motion gives those no power:

    * below the motion's band edge (on EMPS, whose motion holds 99 % of its velocity power below
      3.7 Hz, a "disturbance" at 0.48 Hz would explain 7 % of what friction leaves);
    * at the harmonics of a periodic motion (:meth:`motion_period`; a repeated excitation trajectory)
      only when the line stands :data:`ISOLATED` times above the neighbouring harmonics: there every
      function of q, q̇, q̈ the model misses is periodic in time too, a comb of lines (on the synthetic
      cases, lines at the 25th and 50th harmonic of a 0.1 Hz excitation, 0.1 % of τ, were significant),
      whereas mains at 50 Hz — the 500th harmonic of a 10 s excitation — is one line.

    The independent trials are the resolution cells scanned. Hence a disturbance that itself holds more
    than 1 − :data:`MOTION` of the velocity's power sets the band edge and is not searched.
    """

    name, contract, variant = "periodic_time", "periodic", "time"
    roles, axis, nonlinear = ("amplitude", "frequency_hz"), "time", "frequency_hz"
    summary = "disturbance periodic in time (mains interference): amplitude·sin(2π·frequency_hz·t + φ)"
    CYCLES = 2.0
    TOP = 0.8
    OVERSAMPLING = 4
    MAX_GRID = 8000
    MOTION = 0.99
    """Fraction of the velocity's power (each coordinate's normalised, averaged) that sets the motion's band edge."""
    REPEATS = 0.9
    """Autocorrelation of the velocity at a lag above which the motion is taken as periodic with that period."""
    refinement = 1e-8
    """A frequency error δf turns the phase by 2π·δf·t: 1e-4 of 8 Hz is 0.2 rad over 40 s; 1e-8 is nothing."""
    LINE = 2.0
    """The best frequency must explain at least this multiple of the best one more than :data:`APART`
    resolution cells away: a disturbance at one frequency is one line in the residual; a comb of lines of
    comparable power is the residual of something repeated (pulses) or a hump, not a sinusoid."""
    APART = 2.0
    ISOLATED = 10.0
    """At a harmonic of a periodic motion the line must explain this multiple of the best of the three
    harmonics on either side (mains at 50 Hz is the 500th harmonic of a 10 s excitation)."""

    @staticmethod
    def _velocities(context: Context) -> np.ndarray | None:
        v = context.qd - context.qd.mean(axis=0)
        moving = np.sum(v * v, axis=0) > 0
        return v[:, moving] / np.sqrt(np.mean(v[:, moving] ** 2, axis=0)) if moving.any() and context.rate > 0 else None

    @classmethod
    def motion_band(cls, context: Context) -> float:
        """The frequency (Hz) below which the motion holds :data:`MOTION` of its velocity power, every
        coordinate's spectrum normalised to its own power (their units differ) and averaged."""
        v = cls._velocities(context)
        if v is None:
            return 0.0
        power = np.abs(np.fft.rfft(v, axis=0)) ** 2
        share = np.mean(power / power.sum(axis=0), axis=1)
        frequencies = np.fft.rfftfreq(len(v), 1.0 / context.rate)
        return float(frequencies[min(np.searchsorted(np.cumsum(share), cls.MOTION), len(frequencies) - 1)])

    @classmethod
    def motion_period(cls, context: Context) -> float | None:
        """The period (s) of a repeated motion: the lag of the highest normalised autocorrelation of the
        velocities (averaged over coordinates, each lag's overlap normalised) in the first run of lags
        where it exceeds :data:`REPEATS`, after it has first crossed zero and within half the record;
        ``None`` when there is none (a motion that does not repeat)."""
        v = cls._velocities(context)
        if v is None:
            return None
        n = len(v)
        spectrum = np.fft.rfft(v, 2 * n, axis=0)
        correlation = np.fft.irfft(np.abs(spectrum) ** 2, axis=0)[:n].mean(axis=1)
        correlation = correlation / (n - np.arange(n)) / (correlation[0] / n)
        negative = np.flatnonzero(correlation[: n // 2] < 0)
        if negative.size == 0:
            return None
        lags = np.arange(negative[0], n // 2)
        high = lags[correlation[lags] > cls.REPEATS]
        if high.size == 0:
            return None
        run = high[: int(np.argmax(np.diff(high) > 1)) + 1] if np.any(np.diff(high) > 1) else high
        k = int(run[np.argmax(correlation[run])])
        # a parabola through the peak and its neighbours: the period to a fraction of a sample (at the
        # 160th harmonic a whole sample's error would move the comb by a third of a resolution cell)
        left, mid, right = correlation[k - 1], correlation[k], correlation[k + 1]
        curvature = left - 2.0 * mid + right
        shift = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
        return (k + shift) / context.rate

    def _range(self, context: Context) -> tuple[float, float] | None:
        if context.duration <= 0:
            return None
        low, high = max(self.CYCLES / context.duration, self.motion_band(context)), self.TOP * context.passband
        return (low, high) if high > low else None

    def _off_harmonics(self, frequencies: np.ndarray, context: Context) -> np.ndarray:
        """Which ``frequencies`` lie more than one resolution cell from every harmonic of a periodic motion."""
        period = self.motion_period(context)
        if period is None:
            return np.ones(len(frequencies), bool)
        distance = np.abs(frequencies * period - np.round(frequencies * period)) / period
        return distance > 1.0 / context.duration

    def grid(self, context, j):
        bounds = self._range(context)
        if bounds is None:
            return None
        low, high = bounds
        count = min(int(math.ceil((high - low) * context.duration * self.OVERSAMPLING)) + 1, self.MAX_GRID)
        frequencies = np.linspace(low, high, count)
        if frequencies.size < 2:
            return None
        return frequencies, max(frequencies.size / self.OVERSAMPLING, 1.0)

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("periodic in time needs the time stamps: use columns_at")

    def columns_at(self, signals, j, value):
        x = 2.0 * math.pi * value * np.asarray(signals.t, float)
        return on_row(j, signals.q.shape[1], [np.sin(x), np.cos(x)])

    def scan_columns(self, t, n, j, values):
        # the treatment's filters are linear and time-invariant: a sinusoid stays one of the same frequency
        # (gain and phase change: a mixing of sin and cos), up to the filters' transients at the ends.
        # Sampled at the kept times directly, the grid costs nothing next to filtering every column.
        # on coordinate j only: the compact form, values × samples × 2. A grid chunk is evenly spaced: each
        # frequency's phasor is the previous one times exp(2πi·Δf·t) (angle addition; the rounding grows by
        # one ulp a step, 1e-14 over a chunk), instead of a sine and a cosine of every sample at every value
        t = np.asarray(t, float)
        values = np.asarray(values, float)
        step = (values[-1] - values[0]) / (len(values) - 1) if len(values) > 1 else 0.0
        even = len(values) > 2 and np.allclose(np.diff(values), step, rtol=1e-9, atol=0.0)
        if not even:
            x = 2.0 * math.pi * np.outer(values, t)
            return np.stack([np.sin(x), np.cos(x)], axis=2)
        phasor = np.empty((len(values), len(t)), complex)
        phasor[0] = np.exp(2j * math.pi * values[0] * t)
        turn = np.exp(2j * math.pi * step * t)
        for k in range(1, len(values)):
            np.multiply(phasor[k - 1], turn, out=phasor[k])
        return np.stack([phasor.imag, phasor.real], axis=2)

    def roles_of(self, c, value, reference):
        amplitude, _ = self.polar(c)
        return {"amplitude": amplitude, "frequency_hz": float(value)}

    def scan_verdict(self, values, explained, context):
        best = int(np.argmax(explained))
        if explained[best] <= 0:
            return None
        apart = np.abs(values - values[best]) > self.APART / context.duration
        if apart.any():
            k = int(np.flatnonzero(apart)[np.argmax(explained[apart])])
            if explained[best] < self.LINE * explained[k]:
                return (f"not a single line: {values[k]:.4g} Hz explains {explained[k] / explained[best]:.0%} of what "
                        f"{values[best]:.4g} Hz does (a comb or a hump of the residual, not one sinusoid)")
        return self._harmonic_verdict(values, explained, best, context)

    def _harmonic_verdict(self, values, explained, best, context) -> str | None:
        """At a harmonic of a periodic motion, a line must stand :data:`ISOLATED` times above the
        neighbouring harmonics: every function of the motion's phase the model misses is a comb there."""
        if self._off_harmonics(values[best:best + 1], context)[0]:
            return None
        period = self.motion_period(context)
        k = round(values[best] * period)
        cell = 0.5 / context.duration
        neighbours = []
        for m in (k - 3, k - 2, k - 1, k + 1, k + 2, k + 3):
            near = np.abs(values - m / period) <= cell
            if m > 0 and near.any():
                neighbours.append(float(explained[near].max()))
        if neighbours and explained[best] >= self.ISOLATED * max(neighbours):
            return None
        share = max(neighbours) / explained[best] if neighbours else float("nan")
        return (f"{values[best]:.4g} Hz is the harmonic {k} of the periodic motion (period {period:.4g} s) and its "
                f"neighbouring harmonics explain up to {share:.0%} as much: a function of the motion's phase, not "
                f"told apart from the states' terms (a disturbance there must stand {self.ISOLATED:g}× above them)")

    def check(self, roles, reference, context, j):
        bounds = self._range(context)
        f = roles["frequency_hz"]
        cell = 1.0 / context.duration
        if f <= bounds[0] + cell or f >= bounds[1] - cell:
            return (f"the frequency is not located: {f:.4g} Hz lies at the edge of the range searched "
                    f"({bounds[0]:.4g}–{bounds[1]:.4g} Hz: above the motion's band, within the pass band)")
        return None

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        return self.write(editor, "periodic_time", coordinate, ("Ms", "Mc"), f"2*pi*{float(value)!r}*t", c, comment,
                          "amplitude")


class Inertia(Effect):
    """An inertia error on one coordinate: ΔI·q̈ on its own row, written as a drive's rotor inertia."""

    name, roles, axis = "inertia", ("inertia",), "acceleration"
    summary = "inertia error on one coordinate (a rotor, a coupling): ΔI·q̈, as a [[drive]] rotor inertia"

    def applicable(self, context, j):
        c = context.coordinates[j]
        if c in context.unactuated:
            # the equation's scale is held at one of its parameters (workflow/terms.py, hold_scales): an inertia
            # term on it only moves that scale again, and fits the errors-in-variables of its twice
            # differentiated positions (0.04 % of the link's inertia, p = 1e-47, on the flexible rig)
            return f"{c} has no actuator (τ = 0): an inertia on its equation only rescales it"
        return None if c in context.robot.coordinates else f"{c} is a modal coordinate"

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [qdd[:, j]])

    def roles_of(self, c, value, reference):
        return {"inertia": float(c[0])}

    def check(self, roles, reference, context, j):
        rotor, ratio = _drive(context, j)
        if rotor * ratio**2 + roles["inertia"] >= 0:
            return None
        return f"an inertia change of {roles['inertia']:.4g} would make the rotor inertia on {context.coordinates[j]} negative"

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        _, ratio = _drive(context, j)
        name = editor.parameter(f"Ia_{coordinate}", roles["inertia"] / ratio**2, comment)
        old = editor.drive_value(coordinate, "rotor_inertia")
        editor.set_drive(coordinate, "rotor_inertia", name if old is None else f"{old} + {name}", comment)
        return {name: roles["inertia"] / ratio**2}


class FlexibleMode(Effect):
    """An unmodelled resonance: a load elastically coupled to coordinate q (a compliant transmission, a
    flexible link's first mode). With the coordinate measured (collocated), the load of inertia J_L on
    a spring k and damper c moves as q_L = L(s)·q with L = (2ζω·s + ω²)/(s² + 2ζω·s + ω²), ω² = k/J_L,
    2ζω = c/J_L, and the actuator must supply J_L·q̈_L in addition to the rest of the model: the column
    is the acceleration q̈ filtered by L (linear in J_L for given ω, ζ; the coordinate's own inertia in
    the model becomes the motor side's). ω and ζ are scanned on a grid and refined.

    Roles: ``frequency_hz`` and ``damping_ratio`` of the ringing as the data show it — the patched
    model's closed-loop mode under the data's ``[controller]`` (:mod:`symbolic.workflow.modes`), nearest
    to the load's own frequency; without a controller, the load's mode with the coordinate held
    (ω, ζ). Written as a second mass: a new coordinate ``<q>_flex`` (the load's deflection), a frame
    turning (or sliding) with q plus it, a body of inertia (mass) J_L, and a ``[[force]]`` −k·x − c·ẋ on it.

    The column acts on coordinate q's row only: exact when no other coordinate moves the load's axis (a
    one-axis machine, the first joint of a chain); on a later joint the load's inertia also reacts on the
    joints before it, which the column leaves out (the patched model holds it in full).
    """

    own_row = True

    name, roles, axis, nonlinear = "flexible_mode", ("frequency_hz", "damping_ratio"), "time", "frequency and damping"
    summary = "unmodelled resonance: a load on a compliant coupling (second mass), ringing at frequency_hz"
    DAMPING = (0.01, 0.03, 0.08, 0.2)
    """Damping ratios of the grid; the grid's box caps the refinement at 0.2: a resonance that rings (a
    peak of half-power width ≤ 40 % of its frequency). Wider, the column is a smooth lag of the
    acceleration, which a drive's bandwidth or a filter explains as well (EMPS)."""
    TOP = 0.8
    """Highest load frequency, as a fraction of the treatment's pass band (the decimation filter's edge)."""
    SPACING = 1.03
    """Ratio of neighbouring grid frequencies (a mode of ζ = 0.01 is 2 % wide at half power)."""
    LOWEST_HZ = 1.0

    def applicable(self, context, j):
        c = context.coordinates[j]
        kind = context.kind(c)
        if kind == "modal":
            return f"{c} is a modal coordinate"
        return None if _joint_frame(context.robot, c) is not None else f"no frame moves with {c} alone"

    def grid(self, context, j):
        # from LOWEST_HZ (slower is a spring, gravity or the loop itself) to TOP × the treatment's pass band
        low, high = self.LOWEST_HZ, self.TOP * context.passband
        if high <= low:
            return None
        frequencies = np.exp(np.arange(math.log(low), math.log(high), math.log(self.SPACING)))
        rows = np.array([(f, z) for f in frequencies for z in self.DAMPING])
        return rows, float(len(rows))

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("flexible_mode needs the sampling rate: use columns_at")

    def columns_at(self, signals, j, value):
        import scipy.signal

        frequency, damping = value
        if signals.record is not None:  # the load's state at the first sample is what the motion before left
            whole = self.columns_at(signals.record, j, value)
            return whole[signals.start:signals.start + len(signals.t)]
        w = 2.0 * math.pi * frequency
        # bilinear transform s = K(z − 1)/(z + 1), K prewarped so that the resonance stays at ω
        K = w / math.tan(w / (2.0 * signals.rate))
        c1, c0 = 2.0 * damping * w * K, w * w
        a = np.array([K * K + c1 + c0, 2.0 * (c0 - K * K), K * K - c1 + c0])
        b = np.array([c1 + c0, 2.0 * c0, c0 - c1]) / a[0]
        a = a / a[0]
        x = signals.qdd[:, j]
        # the filter at rest on x[0] (what scipy.signal.lfilter_zi gives, without its linear solve): L has unit
        # gain at DC, so in the transposed direct form the states for a constant input 1 are b2 − a2 and
        # b1 − a1 + (b2 − a2)
        rest = b[2] - a[2]
        load, _ = scipy.signal.lfilter(b, a, x, zi=np.array([b[1] - a[1] + rest, rest]) * x[0])
        return on_row(j, signals.qdd.shape[1], [load])

    def roles_of(self, c, value, reference):
        return {"frequency_hz": float(value[0]), "damping_ratio": float(value[1]), "load": float(c[0])}

    def reference_column(self, q, qd, qdd, j):
        return on_row(j, q.shape[1], [qdd[:, j]])[:, :, 0]  # the coordinate's own inertia, when the model has it alone

    EDGE = 0.02
    """A fit within this relative distance of the searched box's edge is not located (it would go further)."""

    def check(self, roles, reference, context, j):
        if roles["load"] <= 0:
            return f"load inertia {roles['load']:.4g} is not positive (no second mass rings so)"
        f, z, top = roles["frequency_hz"], roles["damping_ratio"], self.TOP * context.passband
        if f >= (1 - self.EDGE) * top or f <= (1 + self.EDGE) * self.LOWEST_HZ or z >= (1 - self.EDGE) * max(self.DAMPING) \
                or z <= (1 + self.EDGE) * min(self.DAMPING):
            return (f"the resonance is not located: {f:.4g} Hz, ζ = {z:.3g} lies at the edge of the range searched "
                    f"({self.LOWEST_HZ:g}–{top:.4g} Hz, ζ {min(self.DAMPING):g}–{max(self.DAMPING):g})")
        # on a single coordinate the column q̈ alone is the whole inertia the model gives it
        if reference is not None and len(context.coordinates) == 1 and reference <= 0:
            return f"the inertia left on the coordinate's own side, {reference:.4g}, is not positive"
        return None

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        frequency, damping = value
        w = 2.0 * math.pi * frequency
        load = roles["load"]
        revolute = context.kind(coordinate) == "revolute"
        written = {}
        name = editor.parameter(f"J_{coordinate}_load" if revolute else f"m_{coordinate}_load", load, comment + "; the load")
        k = editor.parameter(f"k_{coordinate}_load", load * w * w, comment + "; coupling stiffness")
        d = editor.parameter(f"d_{coordinate}_load", 2.0 * damping * w * load, comment + "; coupling damping")
        written = {name: load, k: load * w * w, d: 2.0 * damping * w * load}
        flex = editor.coordinate(f"{coordinate}_flex", comment + "; the load's deflection")
        frame = _joint_frame(context.robot, coordinate)
        dh = editor.frame_dh(frame.name)
        if context.robot.convention != "modified":  # standard DH: the joint turns about the parent's z
            dh.update(a="0", alpha="0")
        key = "theta" if revolute else "d"
        dh[key] = f"{dh[key]} + {flex}"
        target = editor.add_frame(f"{frame.name}_load", frame.parent, dh, comment)
        if revolute:
            # a thin disc about the joint axis (the triangle inequality holds; only zz acts on q)
            editor.add_body(f"{frame.name}_load", target, "0", {"xx": f"{name}/2", "yy": f"{name}/2", "zz": name}, comment)
        else:
            editor.add_body(f"{frame.name}_load", target, name, None, comment)
        editor.add_force(f"coupling_{coordinate}", flex, f"-{k}*{flex} - {d}*qd_{flex}", comment)
        return written

    PEAK_BAND = 1.3
    """A ringing must show as a spectral peak of the residual within this factor of the load's frequency
    (the closed-loop mode the data show lies near it: the flexible cases ring 1–15 % above it)."""
    DOMINANT = 0.5
    """A resonance explaining at least this share of the whole (stacked) residual is its dominant content and
    needs no peak above a floor that a coarse encoder raises (fits of the loop's reaction to quantisation
    explained at most 32 % in the null data sets; the search passes the stacked share, docs/workflow.md)."""

    def check_residual(self, roles, frequency, psd, share):
        from symbolic.workflow.where import PEAK_RATIO, peaks

        f = roles["frequency_hz"]
        if share >= self.DOMINANT:
            return None
        near = [p for p in peaks(frequency, psd, count=len(psd)) if f / self.PEAK_BAND <= p["frequency_hz"] <= f * self.PEAK_BAND]
        if near:
            return None
        return (f"no ringing: the residual's spectrum has no peak {PEAK_RATIO:g}× above its median level within "
                f"{f / self.PEAK_BAND:.3g}–{f * self.PEAK_BAND:.3g} Hz (a filtered acceleration then fits the "
                "loop's reaction to measurement errors, not a resonance)")

    def as_measured(self, patched, parameters, context, j, roles, controller, period):
        from symbolic.workflow.modes import closed_loop_modes

        own = {"load_frequency_hz": roles["frequency_hz"], "load_damping_ratio": roles["damping_ratio"]}
        if controller is None:
            w = roles["frequency_hz"]
            damped = {"frequency_hz": w * math.sqrt(max(1.0 - roles["damping_ratio"] ** 2, 0.0)),
                      "damping_ratio": roles["damping_ratio"]}
            return damped, {**own, "ringing": "no [controller] declared: the load's mode with the coordinate held"}
        rest = np.zeros(patched.n)
        names = list(patched.robot.generalized_coordinates)
        for k, c in enumerate(context.coordinates):
            rest[names.index(c)] = float(np.mean(context.q[:, k]))
        modes = closed_loop_modes(patched, parameters, controller, period, rest)
        if not modes:
            return {"frequency_hz": None, "damping_ratio": None}, {**own, "ringing": "no oscillatory closed-loop mode"}
        f, z = min(modes, key=lambda m: abs(math.log(max(m[0], 1e-12) / roles["frequency_hz"])))
        return {"frequency_hz": f, "damping_ratio": z}, {**own, "ringing": "closed-loop mode of the patched model",
                                                          "closed_loop_modes": [list(m) for m in modes]}


class Payload(Effect):
    """A rigid payload on the last body of a chain (a tool, a load; :mod:`symbolic.workflow.payload`): its
    weight and inertia forces on every coordinate, linear in its standard parameters, of which the
    combinations the model's own free parameters do not span are the columns. Tested once per chain, on
    the last coordinate that moves the chain's end (the one reported); roles: mass, centre of mass in
    the frame and, when the data determine it, the inertia about the centre of mass (else a point mass)."""

    name, roles, axis = "payload", PHYSICAL, "acceleration"
    summary = "a rigid payload on the last body of a chain (a tool, a load): mass, centre of mass, inertia"
    groupable = False  # one payload acts on every coordinate already

    def applicable(self, context, j):
        if context.model is None:
            return "needs the derived model"
        ends = chain_ends(context.robot)
        coordinate = context.coordinates[j]
        if coordinate not in ends:
            return ("a payload acts at the end of a chain: tested once per chain, on "
                    + (", ".join(ends) if ends else "no coordinate (no frame moves)"))
        return structure(context.model, ends[coordinate], coordinate, context.terms).reason

    def setting(self, context, j):
        coordinate = context.coordinates[j]
        return structure(context.model, chain_ends(context.robot)[coordinate], coordinate, context.terms)

    def columns_at(self, signals, j, value):
        return value.columns(signals.q, signals.qd, signals.qdd)

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("payload needs the model's geometry: use columns_at")

    def roles_of(self, c, value, reference):
        return value.parameters(c)

    def check(self, roles, reference, context, j):
        return None if roles["mass"] is not None and roles["mass"] > 0 else f"mass {roles['mass']:.4g} is not positive"

    def describe(self, value):
        return {"payload": {"frame": value.frame, "model": "rigid body" if value.rigid else "point mass",
                            "combinations": value.size}}

    def patch(self, editor, context, j, roles, c, value, comment):
        written = {}
        mass = editor.parameter("m_payload", roles["mass"], comment + "; mass")
        written[mass] = roles["mass"]
        com = []
        for axis in "xyz":
            v = roles[f"com_{axis}"]
            if v is None:
                com.append("0")
                continue
            name = editor.parameter(f"c_payload_{axis}", v, f"{comment}; centre of mass, {axis} in frame {value.frame}")
            written[name] = v
            com.append(name)
        inertia = None
        if value.rigid:
            inertia = {}
            for key, v in physical_inertia(roles).items():
                name = editor.parameter(f"I_payload_{key}", v, f"{comment}; inertia about the centre of mass, {key}")
                written[name] = v
                inertia[key] = name
        editor.add_body("payload", value.frame, mass, inertia, comment
                        + ("" if value.rigid else "; a point mass: the data do not separate its own inertia"),
                        com=com)
        return written


def _expression_text(value: Any) -> str:
    return str(value)


def _joint_frame(robot: Robot, coordinate: str):
    """The frame whose DH θ (revolute) or d (prismatic) is the coordinate plus constants, or ``None``."""
    symbol = coordinate_symbol(coordinate)
    for frame in robot.frames:
        for key in ("theta", "d"):
            expression = sp.sympify(getattr(frame, key))
            if symbol in expression.free_symbols and sp.diff(expression, symbol) == 1 and \
                    not (expression - symbol).free_symbols & {coordinate_symbol(c) for c in robot.generalized_coordinates}:
                return frame
    return None


def _drive(context: Context, j: int) -> tuple[float, float]:
    """Nominal rotor inertia and ratio of the coordinate's [[drive]] (0 and 1 without one)."""
    values = context.robot.parameter_values
    for d in context.robot.drives:
        if d.coordinate == context.coordinates[j]:
            return float(sp.sympify(d.rotor_inertia).xreplace(values)), float(sp.sympify(d.ratio).xreplace(values))
    return 0.0, 1.0


EFFECTS: dict[str, Effect] = {}
"""The catalogue, by name, in the order the search tries them (ties are broken by this order last)."""

NOT_SUPPORTED: dict[str, str] = {}
"""Contract identifiers not implemented yet, with the reason (listed in the report and the JSON)."""


def register(effect: Effect) -> Effect:
    """Add ``effect`` to the catalogue (its ``name`` must be new)."""
    for attribute in ("name", "roles", "summary"):
        if not hasattr(effect, attribute):
            raise TypeError(f"an effect needs a class attribute {attribute!r}")
    if effect.name in EFFECTS:
        raise ValueError(f"effect {effect.name!r} is already in the catalogue")
    EFFECTS[effect.name] = effect
    return effect


def select(names: Sequence[str], effects: Mapping[str, Effect] | None = None) -> list[Effect]:
    """The effects ``names`` mean, in catalogue order: a registry key, or a contract identifier standing
    for all its variants (``periodic``: in position and in time). Raises ``KeyError`` naming the unknown."""
    effects = EFFECTS if effects is None else effects
    unknown = sorted(n for n in set(names) if n not in effects and all(e.identifier != n for e in effects.values()))
    if unknown:
        raise KeyError(unknown)
    wanted = set(names)
    return [e for key, e in effects.items() if key in wanted or e.identifier in wanted]


for _effect in (Coulomb(), Viscous(), Offset(), Spring(), Gravity(), Inertia(), Periodic(), PeriodicTime(),
                AsymmetricViscous(), AsymmetricCoulomb(), Stribeck(), FlexibleMode(), Payload()):
    register(_effect)


def catalogue(names: Mapping[str, Effect] | None = None) -> list[dict[str, object]]:
    """The catalogue as plain data (for the report and the JSON)."""
    effects = EFFECTS if names is None else names
    return [{"effect": e.identifier, **({"key": e.name, "variant": e.variant} if e.variant else {}),
             "roles": list(e.roles), "summary": e.summary, "refines": e.refines}
            for e in effects.values()]

"""The base of the effect catalogue: what an effect is (:class:`Effect`), what it may know of the data
(:class:`Context`, :class:`Signals`), the registry (:data:`EFFECTS`, :func:`register`, :func:`select`) and the
conformance check every registered effect passes (:func:`check_effect`). docs/workflow.md, "Adding an effect".
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import sympy as sp

from symbolic.data.controller import Controller
from symbolic.description.robot import Robot, coordinate_symbol
from symbolic.description.units import coordinate_kind

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
    elastic: frozenset[str] = frozenset()
    """Coordinates whose transmission two encoders show elastic (``joint_elasticity`` named,
    :mod:`symbolic.workflow.effects.joint_elasticity`): their rows are the motor side's, which no effect of
    the catalogue acts on."""
    position_step: tuple[float, ...] = ()
    """The logged positions' quantum per coordinate (:func:`symbolic.workflow.dataset.position_steps`: an encoder's
    count, or the log's rounding), 0 where the log shows none; empty when unknown."""

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
    model: Any = None
    """The derived model (:class:`symbolic.derivation.dynamics.DynamicModel`), for an effect whose columns need its
    numbers (the link behind an elastic transmission); ``None`` when the caller has none."""
    coordinates: tuple[str, ...] = ()
    """The model's coordinates that ``q``'s columns hold, in order (with :attr:`model`)."""


def variant_words(variant: str) -> str:
    """A variant as the report writes it: ``in position``, ``in time`` (periodic), ``one encoder``."""
    return f"in {variant}" if variant in ("position", "time") else variant.replace("_", " ")


def labelled(identifier: str, variant: str | None) -> str:
    """An effect's name in the report: ``periodic (in time)``, ``joint_elasticity (one encoder)``, ``coulomb``."""
    return identifier if variant is None else f"{identifier} ({variant_words(variant)})"


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
    rank: ClassVar[int] = 1000
    """Place in the catalogue: the search tries effects in increasing rank (ties by name), and breaks ties
    between equally good candidates by this order last. The built-in effects take 10–130."""
    units: ClassVar[Mapping[str, str]] = {}
    """Unit of each role, written in the coordinate's units (``{force}``, ``{position}``; composed by
    :meth:`~symbolic.description.units.CoordinateUnits.compose`: a viscous coefficient ``{force}·s/{position}``
    is N·m·s/rad on a revolute coordinate); ``""`` for a number without unit. Every role has an entry."""
    symbols: ClassVar[Mapping[str, str]] = {}
    """How the report writes a role when not by its name (``Fv⁺`` for ``positive``)."""
    excludes: ClassVar[tuple[str, ...]] = ()
    """Registry keys of effects not accepted on a coordinate where this one was (either way round:
    :func:`excluded` makes the relation symmetric)."""
    together: ClassVar[tuple[str, ...]] = ()
    """Registry keys offered with this effect as one grouped hypothesis as well (viscous with coulomb:
    docs/workflow.md, "Grouped hypotheses")."""
    repeatable: ClassVar[bool] = False
    """Whether the effect may be accepted twice on one coordinate (each time with its own nonlinear value)."""
    formula: ClassVar[str] = ""
    """The τ-side term, as docs/workflow.md's table and ``--list-effects`` write it (default: the summary)."""
    regressors: ClassVar[str] = ""
    """Its columns in words (the table's "columns")."""
    written_as: ClassVar[str] = ""
    """How the patch writes it into the model file (the table's "model file")."""
    roles_note: ClassVar[str] = ""
    """What the table says of the roles beyond their names and units."""
    guide: ClassVar[str | None] = None
    """How the report's figure draws a direction-dependent pair of coefficients: ``"slope"`` (two lines
    through 0) or ``"level"`` (two levels); ``None``: no guides."""

    @property
    def identifier(self) -> str:
        """The contract identifier (the JSON's ``effect``): ``contract``, else ``name``."""
        return self.contract or self.name

    def label(self) -> str:
        """How the report names it: the identifier, with the variant (``periodic (in time)``)."""
        return labelled(self.identifier, self.variant)

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

    def row_columns_at(self, signals: Signals, j: int, value: float | tuple[float, ...] | None) -> np.ndarray:
        """For an :attr:`own_row` effect: :meth:`columns_at`'s columns on coordinate ``j``'s row, ``samples × k``.
        The search asks for these (the other rows are zero); an effect whose grid is long overrides it to spare
        building and zeroing an array N times as wide for every value (on the Panda a tenth of the search's time)."""
        return self.columns_at(signals, j, value)[:, j, :]

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

    def evidence(self, coefficients: np.ndarray) -> dict[str, Any]:
        """Evidence read from the final fit's coefficients (all of them, absorbed optional ones included),
        for the report and the JSON. Default: nothing (a sinusoid gives its phase)."""
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

    def null_values(self, written: Mapping[str, float]) -> dict[str, float]:
        """The values of the parameters :meth:`patch` wrote (``written``) at which the effect is absent: what
        "nothing missing" means when its finding is judged again (:mod:`symbolic.workflow.stand_ins`). Default:
        every one 0 (a coefficient, a mass, an added inertia)."""
        return {name: 0.0 for name in written}

    def check_residual(self, roles: Roles, frequency: np.ndarray, psd: np.ndarray, share: float,
                       floor: np.ndarray | None = None) -> str | None:
        """``None`` when the residual the effect is fitted to shows what it claims, else why not; ``frequency``
        and ``psd`` are the Welch spectrum of that residual on the effect's coordinate, ``share`` the part
        of the whole (stacked) residual's power the effect explains, ``floor`` the part of ``psd`` the encoders'
        rounding accounts for (:func:`~symbolic.workflow.where.quantisation_floor`; ``None``: none). Default:
        nothing to check (a resonance overrides this: it must ring)."""
        return None

    def as_measured(self, patched: DynamicModel, parameters: Mapping[str, float], context: Context, j: int,
                    roles: Roles, controller: Controller | None, period: float) -> tuple[Roles, dict[str, Any]]:
        """The roles as the data show them, given the patched model (``parameters``: its values) and the
        data's ``[controller]`` (checked when loaded; ``None`` when none is declared), and evidence to add.
        Default: unchanged.
        A resonance overrides this: what the data show is the closed-loop mode, not the load's own."""
        return roles, {}


def joint_frame(robot: Robot, coordinate: str):
    """The frame whose DH θ (revolute) or d (prismatic) is the coordinate plus constants, or ``None``."""
    symbol = coordinate_symbol(coordinate)
    for frame in robot.frames:
        for key in ("theta", "d"):
            expression = sp.sympify(getattr(frame, key))
            if symbol in expression.free_symbols and sp.diff(expression, symbol) == 1 and \
                    not (expression - symbol).free_symbols & {coordinate_symbol(c) for c in robot.generalized_coordinates}:
                return frame
    return None


def drive_of(context: Context, j: int) -> tuple[float, float]:
    """Nominal rotor inertia and ratio of the coordinate's [[drive]] (0 and 1 without one)."""
    values = context.robot.parameter_values
    for d in context.robot.drives:
        if d.coordinate == context.coordinates[j]:
            return float(sp.sympify(d.rotor_inertia).xreplace(values)), float(sp.sympify(d.ratio).xreplace(values))
    return 0.0, 1.0


EFFECTS: dict[str, Effect] = {}
"""The catalogue, by registry key, in the order the search tries them (by :attr:`Effect.rank`, then name)."""

NOT_SUPPORTED: dict[str, str] = {}
"""Contract identifiers not implemented yet, with the reason (listed in the report and the JSON)."""


def register(*effects: Effect) -> Effect:
    """Add ``effects`` to the catalogue (each ``name`` new; :func:`check_effect` must pass); returns the last.

    An effect module of this package calls it at its end; a user's code may call it too, for an effect kept
    outside the package."""
    for effect in effects:
        problems = check_effect(effect)
        if problems:
            raise TypeError(f"effect {type(effect).__name__}: " + "; ".join(problems))
        if effect.name in EFFECTS:
            raise ValueError(f"effect {effect.name!r} is already in the catalogue")
        EFFECTS[effect.name] = effect
    ordered = sorted(EFFECTS.values(), key=lambda e: (e.rank, e.name))
    EFFECTS.clear()
    EFFECTS.update((e.name, e) for e in ordered)
    return effects[-1]


def select(names: Sequence[str], effects: Mapping[str, Effect] | None = None) -> list[Effect]:
    """The effects ``names`` mean, in catalogue order: a registry key, or a contract identifier standing
    for all its variants (``periodic``: in position and in time). Raises ``KeyError`` naming the unknown."""
    effects = EFFECTS if effects is None else effects
    unknown = sorted(n for n in set(names) if n not in effects and all(e.identifier != n for e in effects.values()))
    if unknown:
        raise KeyError(unknown)
    wanted = set(names)
    return [e for key, e in effects.items() if key in wanted or e.identifier in wanted]


def excluded(effect: Effect, effects: Iterable[Effect] | None = None) -> set[str]:
    """Names of the effects among ``effects`` (default: the catalogue) that exclude ``effect`` or that it
    excludes (:attr:`Effect.excludes`; the relation is symmetric, whichever side declares it)."""
    effects = EFFECTS.values() if effects is None else effects
    return set(effect.excludes) | {e.name for e in effects if effect.name in e.excludes}


def groups(effects: Sequence[Effect]) -> list[tuple[str, ...]]:
    """The multi-effect grouped hypotheses among ``effects`` (:attr:`Effect.together`, all members present),
    in their order."""
    present = {e.name for e in effects}
    return [(e.name, *e.together) for e in effects if e.together and all(n in present for n in e.together)]


def catalogue(names: Mapping[str, Effect] | None = None) -> list[dict[str, object]]:
    """The catalogue as plain data (for the report and the JSON)."""
    effects = EFFECTS if names is None else names
    return [{"effect": e.identifier, **({"key": e.name, "variant": e.variant} if e.variant else {}),
             "roles": list(e.roles), "summary": e.summary, "refines": e.refines}
            for e in effects.values()]


def _unit_text(unit: str) -> str:
    """A role's unit for the listing, in words where it follows the coordinate (force, position)."""
    return unit.replace("{force}", "force").replace("{position}", "position")


def _roles_text(effect: Effect) -> str:
    return ", ".join(f"{r} ({_unit_text(effect.units[r])})" if effect.units.get(r) else r for r in effect.roles)


def listing(effects: Mapping[str, Effect] | None = None) -> list[str]:
    """One line per effect: registry key, term, parameters with their units, what it refines and excludes
    (``symbolic diagnose --list-effects``)."""
    effects = EFFECTS if effects is None else effects
    width = max(map(len, effects), default=0)
    lines = []
    for key, e in effects.items():
        extra = [f"refines {e.refines}"] if e.refines else []
        clash = sorted(excluded(e, effects.values()))
        extra += [f"excludes {', '.join(clash)}"] if clash else []
        extra += [f"also with {', '.join(e.together)}"] if e.together else []
        lines.append(f"{key:{width}s}  {e.formula or e.summary}  [{_roles_text(e)}]" + (f"  ({'; '.join(extra)})" if extra else ""))
    return lines


def markdown_table(effects: Mapping[str, Effect] | None = None) -> str:
    """docs/workflow.md's catalogue table, from the registry (a test checks the page holds exactly this)."""
    effects = EFFECTS if effects is None else effects
    rows = ["| effect | τ-side term | columns | roles | model file |", "|---|---|---|---|---|"]
    for key, e in effects.items():
        name = f"`{e.identifier}` ({variant_words(e.variant)}; key `{key}`)" if e.variant else f"`{key}`"
        roles = ", ".join(f"`{r}`" + (f" ({_unit_text(e.units[r])})" if e.units.get(r) else "") for r in e.roles)
        roles += f" ({e.roles_note})" if e.roles_note else ""
        rows.append(f"| {name} | {e.formula or e.summary} | {e.regressors} | {roles} | {e.written_as} |")
    return "\n".join(rows) + "\n"


AXES = ("position", "velocity", "acceleration", "time")


def check_effect(effect: Effect) -> list[str]:
    """What an effect lacks to take part in the search, the report and the docs (empty: nothing).

    The declarations only: names, roles with their units, the axis, what it refines and excludes. What its
    columns and roles do on data is checked for every registered effect by tests/test_effects.py."""
    problems = []
    for attribute in ("name", "roles", "summary"):
        if not getattr(effect, attribute, None):
            problems.append(f"needs a class attribute {attribute!r}")
    if problems:
        return problems
    if not effect.name.isidentifier() or effect.name != effect.name.lower():
        problems.append(f"name {effect.name!r} is not a lower-case identifier")
    missing = [r for r in effect.roles if r not in effect.units]
    if missing:
        problems.append(f"units has no entry for role(s) {missing} (\"\" for a number without unit)")
    extra = sorted(set(effect.units) - set(effect.roles))
    if extra:
        problems.append(f"units names what is not a role: {extra}")
    if effect.axis not in AXES:
        problems.append(f"axis {effect.axis!r} is not one of {', '.join(AXES)}")
    if effect.refines not in (None, "viscous", "coulomb"):
        problems.append(f"refines {effect.refines!r}: a refinement changes the model's viscous or coulomb term")
    if effect.guide not in (None, "slope", "level") or (effect.guide and set(effect.roles) != {"positive", "negative"}):
        problems.append("guide is 'slope' or 'level', for an effect with roles positive and negative")
    return problems

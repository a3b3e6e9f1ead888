"""Immutable, validated descriptions of a robot (the spec layer).

A :class:`Robot` holds coordinates, parameters with nominal values, a tree of frames given by
Denavit–Hartenberg parameters, rigid bodies and point masses, closed-loop constraints and the
gravity vector. It is built either from a TOML model file (:mod:`symbolic.description.modelfile`) or directly
in Python; both routes validate on construction, so a ``Robot`` that exists is a usable one.

Expressions may be given as strings (parsed by :func:`symbolic.description.expressions.parse_expression`,
never evaluated), numbers, or SymPy expressions built by the caller.
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sp

from symbolic.description.parameters import ParameterVector
from symbolic.errors import ModelError

IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
MODEL_NAME = re.compile(r"^[a-z][a-z0-9_]*$")
FRAME_NAME = re.compile(r"^[A-Za-z0-9_']+$")
CONVENTIONS = ("standard", "modified")
INERTIA_KEYS = ("xx", "yy", "zz", "xy", "xz", "yz")
DH_KEYS = ("theta", "d", "a", "alpha")
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
"""Joint types of a frame given as a URDF joint is (:class:`Joint`)."""
LIMIT_KEYS = ("lower", "upper", "velocity", "effort")
BOUNDARIES = ("clamped-free",)
"""Beam boundary conditions whose mode shapes :mod:`symbolic.derivation.mode_shapes` provides."""
BASE = "base"
C_KEYWORDS = frozenset(
    """auto break case char const continue default do double else enum extern float for goto if inline int long
    register restrict return short signed sizeof static struct switch typedef union unsigned void volatile while
    _Bool _Complex _Imaginary bool true false main NULL""".split()
)
"""Names a model may not have: the model name prefixes every C identifier generated for it."""

ExprLike = str | int | float | sp.Expr


def coordinate_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of generalized coordinate ``name``."""
    return sp.Symbol(name, real=True)


def velocity_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of the velocity of coordinate ``name`` (``<name>_dot``)."""
    return sp.Symbol(f"{name}_dot", real=True)


def acceleration_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of the acceleration of coordinate ``name`` (``<name>_ddot``)."""
    return sp.Symbol(f"{name}_ddot", real=True)


def velocity_name(name: str) -> str:
    """How model files and data columns write the velocity of coordinate ``name``: ``qd_<name>``."""
    return f"qd_{name}"


TIME_NAME = "t"
"""The reserved name of time (seconds) in model files: allowed in ``[[force]]`` expressions only."""

TIME = sp.Symbol(TIME_NAME, real=True)
"""The SymPy symbol of time in derived expressions (a time-varying model's forces hold it)."""


def parameter_symbol(name: str) -> sp.Symbol:
    """The SymPy symbol of parameter ``name``."""
    return sp.Symbol(name, real=True)


@dataclass(frozen=True)
class Parameter:
    """A model parameter: a symbol with a nominal value, unit and description.

    ``fixed``: identification keeps the value (a known mass, an inertia from CAD); ``minimum`` and
    ``maximum`` (the model file's ``min``/``max``) bound what identification may return. The value
    itself must lie within the bounds.
    """

    name: str
    value: float
    unit: str = ""
    description: str = ""
    fixed: bool = False
    minimum: float | None = None
    maximum: float | None = None

    @property
    def symbol(self) -> sp.Symbol:
        return parameter_symbol(self.name)


@dataclass(frozen=True)
class Joint:
    """A frame placed as a URDF joint places its child link (docs/model-format.md, "General frames").

    ``T = Trans(xyz)·Rot(rpy)·Rot(axis, θ)·Trans(axis·d)``: the constant origin (``rpy`` are fixed-axis
    roll, pitch, yaw, ``Rot(rpy) = Rz(yaw)·Ry(pitch)·Rx(roll)`` as in URDF), then the joint's motion about or
    along ``axis`` (in the frame's own axes). The joint variable is the frame's ``theta`` for
    ``revolute``/``continuous`` joints and its ``d`` for ``prismatic`` ones; a ``fixed`` joint has neither.
    ``limits`` holds the URDF limits that were given (lower, upper, velocity, effort), kept for reports.
    """

    type: str = "revolute"
    axis: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 1)
    xyz: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 0)
    rpy: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 0)
    limits: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Frame:
    """A frame placed relative to ``parent`` by Denavit–Hartenberg parameters, or as a URDF joint.

    Standard convention: ``T = Rz(theta)·Tz(d)·Tx(a)·Rx(alpha)`` (Madill's A(θ,d,a,α), Table 3.1).
    Modified (Khalil–Kleinfinger / Craig): ``T = Rx(alpha)·Tx(a)·Rz(theta)·Tz(d)`` (Janot Table 1:
    alpha = α_j, a = d_j, theta = θ_j, d = r_j). With ``joint`` (a :class:`Joint`) the frame is a general
    one: ``theta`` turns it about the joint axis, ``d`` moves it along, ``a`` and ``alpha`` are 0, and the
    robot's DH convention does not apply to it.
    """

    name: str
    parent: str
    theta: ExprLike = 0
    d: ExprLike = 0
    a: ExprLike = 0
    alpha: ExprLike = 0
    joint: Joint | None = None


@dataclass(frozen=True)
class Body:
    """A rigid body attached to a frame (a point mass when the inertia is omitted).

    ``com`` is the centre of mass in frame coordinates; ``inertia`` maps xx, yy, zz, xy, xz, yz to
    the entries of the inertia tensor about the centre of mass in frame axes (xy is the tensor's
    (x, y) entry, i.e. −∫xy dm).
    """

    name: str
    frame: str
    mass: ExprLike
    com: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 0)
    inertia: Mapping[str, ExprLike] | None = None

    @property
    def inertia_tensor(self) -> sp.Matrix:
        """The 3×3 inertia tensor about the centre of mass, in frame axes (validated bodies only)."""
        i = self.inertia
        return sp.Matrix([[i["xx"], i["xy"], i["xz"]], [i["xy"], i["yy"], i["yz"]], [i["xz"], i["yz"], i["zz"]]])


@dataclass(frozen=True)
class Constraint:
    """A closed-loop constraint solved explicitly: ``coordinate = expression`` of the others.

    The constrained coordinate is not a generalized coordinate; it may appear in DH expressions
    and is substituted before derivation (Janot (8)–(11)).
    """

    coordinate: str
    expression: ExprLike


@dataclass(frozen=True)
class Beam:
    """An Euler–Bernoulli beam clamped to ``frame``, undeformed along its x axis (Madill 3.4).

    ``EI_v``/``EI_w`` are the bending stiffnesses for deflection along frame y (v) and z (w);
    ``modes_v``/``modes_w`` the numbers of assumed modes; ``tip_mass`` an optional point payload at
    x = length. Modal coordinates ``<name>_nu<i>`` and ``<name>_eta<i>`` are appended to the
    generalized coordinates.
    """

    name: str
    frame: str
    length: ExprLike
    density: ExprLike
    EI_v: ExprLike
    EI_w: ExprLike
    modes_v: int = 1
    modes_w: int = 1
    boundary: str = "clamped-free"
    tip_mass: ExprLike | None = None

    @property
    def nu(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_nu{i}" for i in range(1, self.modes_v + 1))

    @property
    def eta(self) -> tuple[str, ...]:
        return tuple(f"{self.name}_eta{i}" for i in range(1, self.modes_w + 1))


@dataclass(frozen=True)
class Directional:
    """A coefficient that differs with the direction of motion: ``positive`` for q̇ > 0, ``negative`` for q̇ < 0."""

    positive: ExprLike
    negative: ExprLike


@dataclass(frozen=True)
class Stribeck:
    """Stribeck effect: the Coulomb level rises to ``static`` at rest, decaying with velocity scale ``velocity``.

    The Coulomb part becomes (Fc + (Fs − Fc)·exp(−(q̇/vs)²))·sign(q̇).
    """

    static: ExprLike
    velocity: ExprLike


Coefficient = ExprLike | Directional


@dataclass(frozen=True)
class Friction:
    """Friction on one coordinate, opposing its motion (Janot (15); docs/model-format.md, "Friction").

    f = Fv·q̇ + Fc·sign(q̇) + offset, with direction-dependent Fv, Fc as :class:`Directional` and an
    optional :class:`Stribeck` rise of the Coulomb level. ``coordinate`` may be a generalized or a
    constrained (passive) coordinate; friction on a constrained one reaches the generalized
    coordinates through Lᵀ of Janot (12).
    """

    coordinate: str
    viscous: Coefficient | None = None
    coulomb: Coefficient | None = None
    offset: ExprLike | None = None
    stribeck: Stribeck | None = None


@dataclass(frozen=True)
class Drive:
    """An actuator on a coordinate: motor angle = ``ratio``·q, rotor inertia ``rotor_inertia``.

    The rotor adds Ia·ratio² to D[q, q]; ``gain`` converts the measured drive signal (volts,
    amperes) into the generalized force at the coordinate (used by identification and simulation).
    """

    coordinate: str
    ratio: ExprLike = 1
    rotor_inertia: ExprLike = 0
    gain: ExprLike | None = None


@dataclass(frozen=True)
class Force:
    """A generalized force exerted ON the system at ``coordinate``: an expression of coordinates,
    velocities (written ``qd_<coordinate>``), parameters and time ``t`` (s), e.g. a cable spring
    ``-k1*(q1 - q10)`` or a mains disturbance ``-(a*sin(2*pi*50*t) + b*cos(2*pi*50*t))``."""

    name: str
    coordinate: str
    expression: ExprLike


@dataclass(frozen=True)
class EndEffector:
    """A point fixed in a frame whose Jacobian J maps Q̇ to its velocity (Madill (3.57))."""

    frame: str
    point: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, 0)


@dataclass(frozen=True)
class Robot:
    """A validated, immutable robot description.

    After construction every expression field holds a SymPy expression in the symbols of
    :attr:`coordinates`, constrained coordinates and :attr:`parameters`; frames are ordered
    parents first.
    """

    name: str
    coordinates: tuple[str, ...]
    parameters: tuple[Parameter, ...] = ()
    frames: tuple[Frame, ...] = ()
    bodies: tuple[Body, ...] = ()
    constraints: tuple[Constraint, ...] = ()
    beams: tuple[Beam, ...] = ()
    gravity: tuple[ExprLike, ExprLike, ExprLike] = (0, 0, "-9.81")
    convention: str = "standard"
    description: str = ""
    end_effector: EndEffector | None = None
    frictions: tuple[Friction, ...] = ()
    drives: tuple[Drive, ...] = ()
    forces: tuple[Force, ...] = ()
    source: str = field(default="<python>", compare=False)
    keys: Mapping[str, str] = field(default_factory=dict, compare=False, repr=False)
    """Optional map from an internal location to the file's own key spelling (for messages)."""
    validated: bool = field(default=False, compare=False, repr=False)
    """Set by :func:`symbolic.description.validation.validate` on the copy it returns; never by hand."""

    # -- symbols -------------------------------------------------------------------------
    @property
    def coordinate_symbols(self) -> tuple[sp.Symbol, ...]:
        """The rigid (frame) coordinates."""
        return tuple(coordinate_symbol(c) for c in self.coordinates)

    @property
    def generalized_coordinates(self) -> tuple[str, ...]:
        """Q: the coordinates, then every beam's modal coordinates ν, η (Madill (3.55))."""
        modal = tuple(name for b in self.beams for name in b.nu + b.eta)
        return tuple(self.coordinates) + modal

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(p.symbol for p in self.parameters)

    @property
    def parameter_values(self) -> dict[sp.Symbol, float]:
        return {p.symbol: p.value for p in self.parameters}

    @property
    def parameter_vector(self) -> ParameterVector:
        """The nominal values as a :class:`~symbolic.description.parameters.ParameterVector` (names ↔ symbols ↔ array)."""
        return ParameterVector.nominal(self)

    @property
    def time_varying(self) -> bool:
        """Whether a ``[[force]]`` expression holds time :data:`TIME` (the equations of motion then do)."""
        return any(isinstance(f.expression, sp.Basic) and TIME in f.expression.free_symbols for f in self.forces)

    @property
    def constrained_coordinates(self) -> tuple[str, ...]:
        return tuple(c.coordinate for c in self.constraints)

    @property
    def constraint_substitution(self) -> dict[sp.Symbol, sp.Expr]:
        """Constrained coordinate -> its expression in the generalized coordinates."""
        return {coordinate_symbol(c.coordinate): c.expression for c in self.constraints}

    def frame(self, name: str) -> Frame:
        for f in self.frames:
            if f.name == name:
                return f
        raise KeyError(name)


def digest(robot: Robot) -> str:
    """SHA-256 of everything that describes ``robot``: every compared field, expressions by ``srepr``.

    Equal descriptions give the same digest in any process (no hash of a Python object enters it); any
    change of an entry, a value or an expression gives another. What is derived from a robot is a function
    of its description, so this is the key of the derived products kept on disk (:mod:`symbolic.cache`);
    the source path, the file's key spellings, comments and layout do not enter.
    """
    return hashlib.sha256(_canonical(robot).encode()).hexdigest()


SKELETON = ("coordinates", "frames", "bodies", "constraints", "beams", "gravity", "convention", "end_effector", "drives")
"""The fields of a :class:`Robot` that its rigid part (kinematics, D(Q), Christoffel symbols, gravity, the
Newton–Euler τ) depends on: neither its name, parameters and their values, friction nor applied forces."""


def skeleton_digest(robot: Robot) -> str:
    """SHA-256 of the :data:`SKELETON` fields of ``robot`` (as :func:`digest` describes them): equal for a
    model and its patched copy that adds friction, forces or parameters, or changes values."""
    text = ",".join(f"{name}={_canonical(getattr(robot, name))}" for name in SKELETON)
    return hashlib.sha256(f"skeleton({text})".encode()).hexdigest()


def _canonical(value: object) -> str:
    """A text that determines ``value`` (a dataclass of the description, an expression, a container, a number)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        inner = ",".join(f"{f.name}={_canonical(getattr(value, f.name))}" for f in dataclasses.fields(value) if f.compare)
        return f"{type(value).__name__}({inner})"
    if isinstance(value, sp.Basic):
        return sp.srepr(value)
    if isinstance(value, Mapping):
        return "{" + ",".join(f"{_canonical(k)}:{_canonical(v)}" for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))) + "}"
    if isinstance(value, (tuple, list)):
        return "(" + ",".join(_canonical(v) for v in value) + ")"
    if isinstance(value, float):
        return float.hex(value)
    if value is None or isinstance(value, (str, int, bool)):
        return repr(value)
    raise TypeError(f"digest: cannot describe a {type(value).__name__}")  # a new kind of field: describe it here

"""Forward simulation of a model against a measured log, driven the way the machine was driven.

:func:`simulate` integrates Q̈ = D(Q)⁻¹(τ − (I⊗Q̇ᵀ)CQ̇ − g − k − f + Q) (the model's one composition:
rigid or flexible, with friction, drives and forces) over the time span of a log, with the
experiment's discrete controller (:mod:`symbolic.simulation.controller`) closing the loop at the log's
sample period T with zero-order hold, and returns the trajectory at the log's time stamps in the
canonical columns (t, q_c, qd_c, qdd_c, tau_c), so that it can be compared sample by sample
(:mod:`symbolic.simulation.comparison`).

How it integrates — the right-hand side in CasADi from the same straight-line program as the generated
code, compiled and mapped over the samples; friction's sign smoothed as tanh(v/ε); m = ⌈T·ρ⌉ fixed RK4
sub-steps per sample (ρ the spectral radius of ∂ẋ/∂x at rest; fewer where every velocity is clear of the sign's
steep part, linearly implicit ones where a joint is held by its friction) or SciPy's stiff methods on request; the
initial state from the first samples — and why, with the measured effects of each choice, is
docs/simulation.md ("Integration").
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from symbolic.data import DataError, Experiment, Measurements, load
from symbolic.description.numbers import RobotNumbers
from symbolic.errors import SimulationError
from symbolic.simulation import controller as control
from symbolic.codegen.compiled import compile_casadi
from symbolic.simulation.comparison import Comparison, compare, treatment

if TYPE_CHECKING:  # SymPy, the derivation and its products are imported where a model is derived, not here:
    import sympy as sp  # a warm `symbolic simulate` reads a SimulationModel from the cache folder without them

    from symbolic.derivation.dynamics import DynamicModel
    from symbolic.derivation.products import Product

LOG = logging.getLogger(__name__)

METHODS = ("rk4", "Radau", "BDF", "LSODA")

CALM_WHEN = 4
"""Where RK4 needs this many times the sub-steps it would need without friction's smoothed sign (a light joint
with Coulomb friction: hundreds a sample), a sample in which every velocity stays clear of zero takes the fewer
(:func:`stepping`): the sign's steep part, |v| ≲ ε, is where the model is stiff, and such a sample never enters it."""

CALM_MARGIN = 20.0
"""A sample is calm when every |q̇_j| − 2T|q̈_j| at its start exceeds this many ε: the velocity cannot reach the
smoothed sign's steep part within the sample (sech²(20) ≈ 2e-17: the friction's slope there is nothing), even if
the acceleration doubles over it."""

SOFT_FRICTION_VELOCITY = 1e6
"""ε at which the spectral radius without friction's smoothed sign is measured (tanh(v/ε) is then flat)."""

FRICTION_VELOCITY = 1e-4
"""Default ε of the smoothed sign tanh(v/ε), in coordinate units per second (m/s, rad/s)."""

STEP_BOUND = 1.0
"""Sub-steps are chosen so that h·ρ ≤ STEP_BOUND (ρ: spectral radius of ∂ẋ/∂x), well inside RK4's stability
region (:data:`RK4_IMAGINARY_BOUND`, :data:`RK4_REAL_BOUND`)."""
RK4_IMAGINARY_BOUND = 2.0 * math.sqrt(2.0)
"""|R(iy)| = 1 for RK4's stability function R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 at y = 2√2 ≈ 2.83."""
MAX_SUBSTEPS = 10_000
"""Most RK4 sub-steps per sample: beyond, a log of 25 000 samples (EMPS's) would take minutes to hours; a
model that stiff needs a stiff method (``method="Radau"``, ``"BDF"``)."""


class Diverged(DataError, SimulationError):
    """The simulated state became infinite or NaN (or could not start: D(Q) singular at the initial state).

    A :class:`DataError` of the log (``key`` ``"simulation"``) and a :class:`SimulationError`; ``time`` (s)
    and ``coordinate`` say where it first did, so that a caller (``diagnose --simulate``) can report it and
    fall back to the inverse model."""

    def __init__(self, source: str, time: float, coordinate: str, problem: str) -> None:
        self.time, self.coordinate = time, coordinate
        super().__init__(source, "simulation", f"the simulation diverged at t = {time:.6g} s on coordinate "
                                               f"{coordinate}: {problem}")

    def __reduce__(self):
        return (_diverged, (self.source, self.key, self.problem, self.time, self.coordinate))


def _diverged(source: str, key: str, problem: str, time: float, coordinate: str) -> Diverged:
    error = Diverged.__new__(Diverged)
    DataError.__init__(error, source, key, problem)
    error.time, error.coordinate = time, coordinate
    return error


RK4_REAL_BOUND = float(-min(r.real for r in np.roots([1 / 24, 1 / 6, 1 / 2, 1, 0]) if abs(r.imag) < 1e-12 and r.real < 0))
"""R(x) = 1 on the negative real axis at x ≈ −2.785: RK4 is stable for real λ with h·|λ| up to this."""


@dataclass(frozen=True, eq=False)
class Simulation:
    """A simulated log and what it was made from.

    Attributes
    ----------
    measured
        The log.
    simulated
        The simulation at the log's time stamps: every coordinate of the model (the data's first,
        in the model's order) with q, qd, qdd and tau.
    controller
        The controller that drove it.
    method
        ``"rk4"`` or a ``solve_ivp`` method.
    substeps
        RK4 sub-steps per sample (1 for ``solve_ivp``).
    spectral_radius
        ρ of ∂ẋ/∂x at the initial state, in 1/s (what chose the sub-steps).
    friction_velocity
        ε of the smoothed sign.
    parameters
        The parameter values used, by name.
    compiled
        Whether the closed loop ran as compiled machine code (else CasADi's virtual machine).
    model_name
        The model's name.
    timings
        Seconds spent building the functions, compiling, and integrating.
    """

    measured: Measurements
    simulated: Measurements
    controller: control.Controller
    method: str
    substeps: int
    spectral_radius: float
    friction_velocity: float
    parameters: Mapping[str, float]
    compiled: bool
    model_name: str
    timings: Mapping[str, float] = field(default_factory=dict)
    calm_substeps: int = 0
    """RK4 sub-steps of a calm sample (:func:`stepping`; 0: every sample takes :attr:`substeps`)."""

    def compare(self, window: float = 1.0) -> Comparison:
        """Per coordinate and signal: relative error, RMS, worst window (:func:`symbolic.simulation.comparison.compare`)."""
        return compare(self.measured, self.simulated, window=window)

    def to_dict(self, comparison: Comparison | None = None) -> dict[str, Any]:
        """The run's settings and, given a comparison, its statistics (``relative_error`` in %), for JSON."""
        out: dict[str, Any] = {
            "model": self.model_name,
            "data": str(self.measured.source),
            "samples": self.measured.samples,
            "controller": self.controller.describe(),
            "method": self.method,
            "substeps": self.substeps,
            "calm_substeps": self.calm_substeps,
            "spectral_radius": self.spectral_radius,
            "friction_velocity": self.friction_velocity,
            "compiled": self.compiled,
            "timings": dict(self.timings),
        }
        if comparison is not None:
            out.update(comparison.to_dict())
        return out

    def summary(self) -> str:
        """Lines saying what was simulated and how."""
        calm = f", {self.calm_substeps} in a sample whose velocities stay clear of zero" if self.calm_substeps else ""
        how = (f"RK4, {self.substeps} sub-step(s) per sample{calm} (spectral radius {self.spectral_radius:.4g} 1/s)"
               if self.method == "rk4" else f"solve_ivp {self.method}")
        return "\n".join([
            f"model {self.model_name}: {self.measured.samples} samples at {self.measured.rate:g} Hz from "
            f"{self.measured.source}",
            f"  controller: {self.controller.describe()}",
            f"  integration: {how}; friction sign tanh(v/{self.friction_velocity:g}); "
            f"{'compiled' if self.compiled else 'CasADi virtual machine'}; "
            f"{self.timings.get('integrate', 0.0):.2f} s",
        ])

    def write(self, folder: str | Path) -> Path:
        """Write ``folder/simulated.csv`` (canonical columns t, q_c, qd_c, qdd_c, tau_c) and, beside it,
        ``folder/simulated.experiment.toml`` (:meth:`experiment_text`: how to read it), each atomically;
        returns the data file's path.

        The force τ_c at t_k is the controller's output held over [t_k, t_k+1) (zero-order hold); qd_c and
        qdd_c are the state at t_k and the acceleration just after it, with τ_k acting (docs/simulation.md,
        "What it writes")."""
        from symbolic.data import write
        from symbolic.writing import replacing

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        data = write(self.simulated, folder / DATA_NAME)
        with replacing(folder / EXPERIMENT_NAME) as temporary:
            temporary.write_text(self.experiment_text(), encoding="utf-8")
        return data

    def experiment_text(self) -> str:
        """The experiment file written beside ``simulated.csv``: its positions and forces, read as a measured
        log is (velocity and acceleration by central differences of the positions), with ``held_force = true``
        — the states at t_k then see the force's mean over the sample, (τ_k−1 + τ_k)/2, the force that moved
        them — and the measured log's other ``[identification]`` settings (the bandwidth of its motion).
        Read with its own qd_c and qdd_c columns instead (``simulated.csv`` given as data), τ_k is the force
        of those states as it stands and nothing is declared."""
        names = self.simulated.coordinates
        signals = ["t", *(f"q_{c}" for c in names), *(f"tau_{c}" for c in names)]
        given = self.measured.settings.given() if isinstance(self.measured, Experiment) else {}
        settings = {**{k: v for k, v in given.items() if k != "held_force"}, "held_force": True}
        return "\n".join([
            f"# How to read {DATA_NAME}, written with it by symbolic simulate ({self.model_name}, from "
            f"{Path(str(self.measured.source)).name}).",
            "# tau_<c> at t_k is the controller's output held over [t_k, t_k+1) (zero-order hold); qd_<c> and",
            "# qdd_<c> are the state at t_k and the acceleration just after it, with tau_k acting. Read from the",
            "# positions (velocity and acceleration by central differences, as a measured log is), the states at",
            "# t_k see the force's mean over the sample: held_force = true. Read with its qd/qdd columns (the csv",
            "# given as data), tau_k is the force of those states as it stands: nothing to declare.",
            f"data = {_toml(DATA_NAME)}",
            "",
            "[signals]",
            *(f"{_toml(name)} = {_toml(name)}" for name in signals),
            "",
            "[identification]",
            *(f"{key} = {_toml(value)}" for key, value in settings.items()),
            "",
        ])


def simulate(
    model: DynamicModel | SimulationModel,
    data: Measurements | str | Path,
    *,
    controller: Mapping[str, Any] | control.Controller | None = None,
    parameters: Mapping[str, float] | None = None,
    method: str = "rk4",
    substeps: int | None = None,
    friction_velocity: float = FRICTION_VELOCITY,
    initial: tuple[Any, Any] | None = None,
    compiled: bool | None = None,
    rtol: float = 1e-8,
    atol: float = 1e-10,
) -> Simulation:
    """Simulate ``model`` over the time span of a log, driven by the experiment's controller.

    Parameters
    ----------
    model
        The derived model (:func:`symbolic.derive`), or what a simulation reads of it (:class:`SimulationModel`:
        :func:`cached_model` reads one from the cache folder without SymPy).
    data
        Measurements or an experiment (:func:`symbolic.data.load`), or a data or experiment file, loaded
        for ``model`` (its drive gains for ``u_<c>`` columns); the data's coordinates must be
        coordinates of the model.
    controller
        A ``[controller]`` table (or a checked :class:`~symbolic.data.controller.Controller`); default:
        the experiment's ``[controller]``, else the replay of the measured forces (``torque``).
    parameters
        Parameter values by name replacing the model's nominal ones.
    method
        ``"rk4"`` (fixed step, default) or ``"Radau"``, ``"BDF"``, ``"LSODA"`` (``solve_ivp``).
    substeps
        RK4 sub-steps per sample; default from the spectral radius (module docstring).
    friction_velocity
        ε of the smoothed sign tanh(v/ε), > 0.
    initial
        ``(q0, qd0)`` over all the model's coordinates, replacing the initial state from the data.
    compiled
        Compile the closed loop with the C compiler (default: when one is found); ``False``: CasADi's
        virtual machine.
    rtol, atol
        Tolerances of ``solve_ivp``.

    Raises
    ------
    DataError
        For a log, controller table or option that cannot be simulated (one line: file, key, problem).
    """
    model = simulation_model(model)
    measurements = data if isinstance(data, Measurements) else load(data, model=model.robot)
    source = str(measurements.source)
    names = tuple(model.robot.generalized_coordinates)
    _check_options(method, substeps, friction_velocity, source)
    _check_data(measurements, names, model.robot.name)
    p = _parameters(model, parameters, source)
    ctrl = control.check_delay(_controller(controller, measurements, model, names), measurements.samples)
    signals = control.inputs(ctrl, measurements, names)
    ctrl, signals = drive_layer(ctrl, signals, measurements, lambda: model.by_symbol(p))
    sensed = position_sensors(ctrl, measurements, names)
    started = time.perf_counter()
    plant = model.plant
    x0 = _initial_state(model, measurements, p, initial)
    m, calm, radius = stepping(plant, x0, p, friction_velocity, float(measurements.t[0]), measurements.sample_period,
                               names, source, substeps)
    if method == "rk4" and m > MAX_SUBSTEPS:
        raise SimulationError(f"the model needs {m:.3g} RK4 sub-steps per sample of "
                              f"{measurements.sample_period:.3g} s (spectral radius {radius:.4g} 1/s; allowed: up to "
                              f"{MAX_SUBSTEPS}): simulate it with a stiff method (--method Radau or BDF)")
    if substeps and measurements.sample_period / substeps * radius > RK4_REAL_BOUND:
        LOG.warning("%d sub-step(s) of %.3g s: h·ρ = %.2f exceeds RK4's stability bound %.3f (ρ = %.4g 1/s)",
                    substeps, measurements.sample_period / substeps, measurements.sample_period / substeps * radius,
                    RK4_REAL_BOUND, radius)
    c = control.constants(ctrl, lambda: model.by_symbol(p))
    timings = {"build": time.perf_counter() - started}
    args = (ctrl, plant, measurements, signals, x0, p, c, friction_velocity)
    windows = restarts(ctrl, measurements, names)
    if method == "rk4":
        outputs, used_compiled = _run_fixed_step(*args, m, names, compiled, timings, sensed, calm, windows)
    elif windows is not None:
        raise DataError(source, "[controller] restart", f"the replay in windows runs with method 'rk4' only "
                                                          f"(got {method!r}): leave out restart, or the method")
    else:
        outputs, used_compiled, m, calm = _run_solve_ivp(*args, names, method, rtol, atol, sensed), False, 1, 0
        timings["integrate"] = time.perf_counter() - started - timings["build"]
    simulated = _trajectory(measurements, names, outputs)
    return Simulation(measurements, simulated, ctrl, method, m, radius, friction_velocity,
                      model.by_name(p), used_compiled,
                      model.robot.name, timings, calm)


DATA_NAME = "simulated.csv"
"""The data file :meth:`Simulation.write` writes."""
EXPERIMENT_NAME = "simulated.experiment.toml"
"""The experiment file written beside it: how to read it (:meth:`Simulation.experiment_text`)."""


def _toml(value: Any) -> str:
    """A TOML value: a bool, a number (repr, exact), a string (JSON's quoting is TOML's basic string) or a list."""
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, (int, float)):
        return repr(value)
    return json.dumps(str(value))


def _check_options(method: str, substeps: int | None, friction_velocity: float, source: str) -> None:
    if method not in METHODS:
        raise DataError(source, "method", f"unknown integration method {method!r} (allowed: {', '.join(METHODS)})")
    if substeps is not None and (isinstance(substeps, bool) or not isinstance(substeps, int) or not
                                 1 <= substeps <= MAX_SUBSTEPS):
        raise DataError(source, "substeps", f"expected a whole number from 1 to {MAX_SUBSTEPS}, got {substeps!r}")
    if not (isinstance(friction_velocity, (int, float)) and math.isfinite(friction_velocity) and friction_velocity > 0):
        raise DataError(source, "friction_velocity", f"expected a velocity > 0, got {friction_velocity!r}")


def _check_data(measurements: Measurements, names: tuple[str, ...], model: str) -> None:
    source = str(measurements.source)
    if measurements.samples < 2:
        raise DataError(source, "samples", f"{measurements.samples} sample(s): a simulation needs at least 2")
    for c in measurements.coordinates:
        if c not in names:
            raise DataError(source, f"q_{c}", f"coordinate {c!r} of the data is not a coordinate of model "
                                              f"{model!r} (its coordinates: {', '.join(names)})")


def _parameters(model: DynamicModel | SimulationModel, values: Mapping[str, float] | None, source: str) -> np.ndarray:
    """The array p: the model's nominal values with ``values`` (by name) in their place."""
    model = simulation_model(model)
    names = model.robot.parameter_names
    for name, value in (values or {}).items():
        if name not in names:
            raise DataError(source, "parameters", f"unknown parameter {name!r} (the model's: {', '.join(names)})")
        if not math.isfinite(float(value)):
            raise DataError(source, f"parameters {name}", f"expected a finite number, got {value!r}")
    p = np.array(model.robot.parameter_values, dtype=float)
    for name, value in (values or {}).items():
        p[names.index(name)] = float(value)
    return p


def _controller(given: Any, measurements: Measurements, model: DynamicModel | SimulationModel,
                names: tuple[str, ...]) -> control.Controller:
    """The controller given (a table is checked as an experiment file's would be), else the experiment's
    (checked when it was loaded), else the replay of the measured forces."""
    if isinstance(given, control.Controller):
        return given
    source = str(measurements.source)
    if given is not None:
        return control.parse(given, measurements.coordinates, model.parameter_symbols, source, names,
                             measurements.columns())
    if isinstance(measurements, Experiment) and measurements.controller is not None:
        return measurements.controller
    LOG.info("%s has no [controller]: the measured forces are replayed (kind = \"torque\")", source)
    return control.replay(measurements.coordinates, source)


# -- the plant in CasADi ---------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Plant:
    """CasADi functions of a model with the smoothed sign: ``rhs(x, tau, p, eps, t) -> ẋ`` and
    ``bias(q, qd, p, eps, t) -> τ at Q̈ = 0``, x = [Q; Q̇], t the time (s; used by a time-varying model's
    [[force]] entries only, ignored otherwise)."""

    n: int
    rhs: ca.Function
    bias: ca.Function
    mass: ca.Function
    """D(q, p), the inertia matrix: the linearly implicit sub-steps' matrix (:func:`_linearly_implicit_sample`)."""
    closed_loops: dict = field(default_factory=dict, repr=False)
    """The closed loops built on this plant (compiled chunks), by controller structure (:func:`_closed_loop`)."""
    @functools.cached_property
    def state_jacobian(self) -> ca.Function:
        """A(x, τ, p, ε, t) = ∂ẋ/∂x, built once per plant in this process (the output-error fit asks for ρ at every
        trial step: building it each time cost 30 ms for the Panda)."""
        x, tau = ca.SX.sym("x", 2 * self.n), ca.SX.sym("tau", self.n)
        p, eps, t = ca.SX.sym("p", self.rhs.size1_in(2)), ca.SX.sym("eps"), ca.SX.sym("t")
        return ca.Function("A", [x, tau, p, eps, t], [ca.jacobian(self.rhs(x, tau, p, eps, t), x)])

    @functools.cached_property
    def signed(self) -> list[int]:
        """The coordinates whose force holds friction's smoothed sign (depends on ε, structurally): the only ones
        whose velocity near zero makes the model stiff, so the only ones a calm sample's test reads."""
        q, v, t, eps = ca.SX.sym("q", self.n), ca.SX.sym("v", self.n), ca.SX.sym("t"), ca.SX.sym("eps")
        p = ca.SX.sym("p", self.bias.size1_in(2))
        pattern = ca.jacobian(self.bias(q, v, p, eps, t), eps).sparsity()
        return [i for i in range(self.n) if pattern.has_nz(i, 0)]

    def __reduce__(self) -> tuple:
        # pickled for the cache folder without the closed loops of this process (their libraries are
        # files of their own there); CasADi functions pickle through their serialisation
        return Plant, (self.n, self.rhs, self.bias, self.mass)

    @functools.cached_property
    def linearised(self) -> ca.Function:
        """``(x, p, eps, t) -> (D, B, K)``: the inertia matrix, B = ∂bias/∂q̇ at x (friction's smoothed sign, the
        Coriolis terms) and K = ∂bias/∂q at rest (gravity, springs, the elastic forces): ∂q̈/∂x ≈ −D⁻¹[K B]
        without the terms of ∂D/∂q, for the linearly implicit sub-steps (:func:`_linearly_implicit_sample`)."""
        n = self.n
        x, p, eps, t = ca.SX.sym("x", 2 * n), ca.SX.sym("p", self.rhs.size1_in(2)), ca.SX.sym("eps"), ca.SX.sym("t")
        q, qd = x[:n], x[n:]
        B = ca.jacobian(self.bias(q, qd, p, eps, t), qd)
        K = ca.jacobian(self.bias(q, ca.SX.zeros(n), p, eps, t), q)
        return ca.Function("linearised", [x, p, eps, t], [self.mass(q, p), B, K])


def _plant(model: DynamicModel) -> Plant:
    return model.products.get(plant_product())


@functools.cache
def plant_product() -> Product[Plant]:
    """The CasADi plant of a model as the model's product, kept in the cache folder: translating the SymPy
    expressions into CasADi is most of what a warm simulation would otherwise redo (its compiled closed loops are
    libraries on disk, named by their C source). The CasADi version is part of the name, hence of the entry's key:
    a serialised CasADi function is read back only by the version that wrote it. Made on first use: a
    :class:`~symbolic.derivation.products.Product` comes with SymPy."""
    from symbolic.derivation.products import Product

    return Product(f"simulation plant with its inertia matrix (CasADi {ca.__version__})", _build_plant, persist=True)


def _build_plant(model: DynamicModel) -> Plant:
    from symbolic.codegen.casadi import cholesky_solve, program_to_sx

    n = model.n
    q, qd, tau = ca.SX.sym("q", n), ca.SX.sym("qd", n), ca.SX.sym("tau", n)
    p, eps, t = ca.SX.sym("p", len(model.parameter_symbols)), ca.SX.sym("eps"), ca.SX.sym("t")
    smooth = {"sign": lambda v: ca.tanh(v / eps)}

    def translate(outputs: sp.Matrix, groups: list, values: list) -> ca.SX:
        return program_to_sx(model.sub, outputs, groups, values, smooth)

    symbols = [model.coordinates, model.velocities, model.parameter_symbols, (model.time,)]
    D = ca.reshape(translate(model.reduced.D, [symbols[0], symbols[2]], [q, p]), n, n).T
    bias = translate(model.reduced.bias, symbols, [q, qd, p, t])
    qdd = cholesky_solve(D, tau - bias)
    rhs = ca.Function("rhs", [ca.vertcat(q, qd), tau, p, eps, t], [ca.vertcat(qd, qdd)], ["x", "tau", "p", "eps", "t"],
                      ["xdot"])
    return Plant(n, rhs, ca.Function("bias", [q, qd, p, eps, t], [bias], ["q", "qd", "p", "eps", "t"], ["bias"]),
                 ca.Function("mass", [q, p], [D], ["q", "p"], ["D"]))


# -- what a simulation reads of a model, kept apart from its expressions ------------------------------------


@dataclass(frozen=True, eq=False)
class SimulationModel:
    """What a simulation reads of a derived model: the description's names and numbers
    (:class:`~symbolic.description.numbers.RobotNumbers`) and the CasADi plant — no SymPy.

    Made from a :class:`~symbolic.derivation.dynamics.DynamicModel` (:meth:`of`, the plant then built or read
    as the model's product :func:`plant_product`), or read from the cache folder by :func:`cached_model`, so that a warm
    ``symbolic simulate`` neither parses the model file nor imports SymPy. What only the derivation can answer (a
    flexible model's initial sag, a controller gain that names parameters) is taken from it on first use
    (:meth:`dynamic`, :attr:`parameter_symbols`: derived or read from the cache folder as ``symbolic.derive``
    would)."""

    robot: RobotNumbers
    _plant: list = field(default_factory=list, repr=False)
    _dynamic: list = field(default_factory=list, repr=False)

    @classmethod
    def of(cls, model: DynamicModel, locator: tuple[str, str | None, str | None] | None = None) -> SimulationModel:
        """The simulation model of ``model`` (``locator``: how to read its description again,
        :class:`~symbolic.description.numbers.RobotNumbers`)."""
        return cls(RobotNumbers.of(model.robot, locator or (str(model.robot.source), None, None)), [], [model])

    def __reduce__(self) -> tuple:
        # the numbers and the plant; the derived model is this process's own
        return SimulationModel, (self.robot, [self.plant])

    @property
    def plant(self) -> Plant:
        """The CasADi plant (:func:`plant_product`)."""
        if not self._plant:
            self._plant.append(_plant(self.dynamic()))
        return self._plant[0]

    @property
    def n(self) -> int:
        return len(self.robot.generalized_coordinates)

    @property
    def parameter_symbols(self) -> tuple[sp.Symbol, ...]:
        return self.robot.parameter_symbols

    def dynamic(self) -> DynamicModel:
        """The derived model (derived on first use when this was read from the cache folder)."""
        if not self._dynamic:
            from symbolic.derivation.dynamics import derive

            self._dynamic.append(derive(self.robot.robot()))
        return self._dynamic[0]

    def by_name(self, p: np.ndarray) -> dict[str, float]:
        """``{name: value}`` of the parameter array ``p``, in model-file order."""
        return {name: float(v) for name, v in zip(self.robot.parameter_names, p)}

    def by_symbol(self, p: np.ndarray) -> dict[sp.Symbol, float]:
        """``{symbol: value}`` of the parameter array ``p`` (reads the description: SymPy)."""
        return {s: float(v) for s, v in zip(self.parameter_symbols, p)}


def simulation_model(model: DynamicModel | SimulationModel) -> SimulationModel:
    """``model`` as a :class:`SimulationModel`."""
    return model if isinstance(model, SimulationModel) else SimulationModel.of(model)


SIMULATION_MODEL = f"simulation model (CasADi {ca.__version__})"
"""The kind of a :class:`SimulationModel`'s entry in the cache folder (the CasADi version in it: see :func:`plant_product`)."""


def model_file_key(found: Path, root: str | None, tip: str | None) -> str | None:
    """The key of a :class:`SimulationModel` entry: SHA-256 of the model file's name as given, its bytes, and the
    chain chosen in a URDF (everything its description is read from, docs/architecture.md "Derived products and
    the cache"); ``None`` when the file cannot be read."""
    import hashlib
    import json

    try:
        content = found.read_bytes()
    except OSError:
        return None
    return hashlib.sha256(json.dumps([str(found), root, tip, hashlib.sha256(content).hexdigest()]).encode()).hexdigest()


def cached_model(name_or_path: str | Path, root: str | None = None, tip: str | None = None) -> SimulationModel:
    """The simulation model of MODEL (a model file or a built-in robot's name, :func:`symbolic.robots.resolve`):
    read from the cache folder, else derived (the derivation itself read from the cache folder when it is there,
    as ``symbolic.derive`` does), its plant built and the whole kept for the next time.

    The entry is keyed by the model file (:func:`model_file_key`) under the cache's stamp (package sources,
    Python, SymPy, NumPy; CasADi in its kind), so that a changed file or parameter value is never read from an
    entry of the old one. A hit imports neither SymPy nor the derivation; the warnings reading the file gave
    (:class:`~symbolic.errors.ModelWarning`) are kept in the entry and given again.
    """
    from symbolic import cache, robots

    started = time.perf_counter()
    found = robots.locate(name_or_path)
    chain = found.suffix.lower() == ".urdf" or (root is None and tip is None)  # else resolve() says why not
    key = model_file_key(found, root, tip) if chain else None
    entry = cache.load(SIMULATION_MODEL, key) if key is not None else None
    if entry is not None and isinstance(entry[0], tuple) and len(entry[0]) == 2 \
            and isinstance(entry[0][0], SimulationModel):
        model, said = entry[0]
        LOG.info("%s: its numbers and CasADi plant read from the cache in %.2f s", model.robot.name,
                 time.perf_counter() - started)
        for category, message in said:  # what reading the model file said, said again
            warnings.warn(message, category, stacklevel=2)
        return model
    from symbolic.derivation.dynamics import derive
    from symbolic.errors import ModelWarning

    with warnings.catch_warnings(record=True) as caught:  # the filters in force: what would be shown
        robot = robots.resolve(name_or_path, root, tip)
        model = SimulationModel.of(derive(robot), (str(found), root, tip))
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    said = tuple((w.category, str(w.message)) for w in caught if issubclass(w.category, ModelWarning))
    model.plant  # built (or read) before it is kept  # noqa: B018
    if key is not None and model_file_key(found, root, tip) == key:  # the file did not change meanwhile
        cache.save(SIMULATION_MODEL, key, (model, said))
    return model


def stepping(plant: Plant, x0: np.ndarray, p: np.ndarray, eps: float, t0: float, period: float,
             names: tuple[str, ...], source: str, substeps: int | None = None) -> tuple[int, int, float]:
    """(RK4 sub-steps per sample, sub-steps of a calm sample or 0, ρ): h·ρ ≤ :data:`STEP_BOUND`; where that is
    :data:`CALM_WHEN` times the sub-steps of the model with friction's sign flat (ρ_soft, at ε =
    :data:`SOFT_FRICTION_VELOCITY`), a calm sample — every velocity clear of the sign's steep part over it
    (:data:`CALM_MARGIN`) — takes those instead, the others all of them (:func:`sample_function`).
    ``substeps`` given: that many in every sample."""
    radius = _spectral_radius(plant, x0, p, eps, t0, names, source)
    if substeps:
        return substeps, 0, radius
    m = substeps_for(period, radius)
    if m < CALM_WHEN:
        return m, 0, radius
    calm = substeps_for(period, _spectral_radius(plant, x0, p, max(eps, SOFT_FRICTION_VELOCITY), t0, names, source))
    return (m, calm, radius) if CALM_WHEN * calm <= m else (m, 0, radius)


def steps_stable(plant: Plant, x0: np.ndarray, p: np.ndarray, eps: float, t0: float, period: float,
                 substeps: int, calm: int = 0) -> bool:
    """Whether ``substeps`` RK4 sub-steps per sample (and ``calm`` in a calm sample) keep h·ρ within RK4's
    stability bound (:data:`RK4_REAL_BOUND`) at ``p``, ρ measured as :func:`stepping` measures it (ρ_soft for
    the calm ones); ``False`` where ρ is not finite.

    Sub-steps chosen at one p and kept for others (an output-error fit: the simulation differentiated is one
    function of θ) can leave that region: the smoothed sign's rate Fc/(M·ε) grows as a mass falls. The simulated
    state may stay finite there — tanh(v/ε) saturates, and the instability throws v out of the steep part — but
    each pass through it multiplies the sensitivities (docs/simulation.md, "Calm samples")."""
    try:
        radius = _spectral_radius(plant, x0, p, eps, t0)
        soft = _spectral_radius(plant, x0, p, max(eps, SOFT_FRICTION_VELOCITY), t0) if calm else 0.0
    except Diverged:
        return False
    return period / substeps * radius <= RK4_REAL_BOUND and (not calm or period / calm * soft <= RK4_REAL_BOUND)


def substeps_for(period: float, radius: float) -> int:
    """RK4 sub-steps per sample of ``period`` so that h·ρ ≤ :data:`STEP_BOUND` (``radius`` = ρ)."""
    return max(1, math.ceil(min(period * radius / STEP_BOUND, 2.0**62)))


def _spectral_radius(plant: Plant, x0: np.ndarray, p: np.ndarray, eps: float, t0: float,
                     names: tuple[str, ...] = (), source: str = "<arrays>") -> float:
    """ρ of A = ∂ẋ/∂x at the initial position and time t0, Q̇ = 0, τ = bias (held at rest): see the
    module docstring. :class:`Diverged` at t0 when A is not finite (D(Q) singular there)."""
    n = plant.n
    rest = np.concatenate([x0[:n], np.zeros(n)])
    hold = np.asarray(plant.bias(rest[:n], rest[n:], p, eps, t0)).ravel()
    A = np.asarray(plant.state_jacobian(rest, hold, p, eps, t0))
    rows = np.flatnonzero(~np.isfinite(A).all(axis=1))
    if rows.size:
        coordinate = names[rows[0] % n] if names else str(rows[0] % n)
        raise Diverged(source, t0, coordinate, "the model cannot be integrated from the initial state: D(Q) is "
                                               "singular or not positive definite there with these parameter values "
                                               "(a mass or inertia of zero?)")
    return float(np.max(np.abs(np.linalg.eigvals(A))))


# -- the experiment's [drive] in a feedback loop -----------------------------------------------------------


def drive_layer(ctrl: control.Controller, signals: control.Inputs, measurements: Measurements,
                 parameters: control.Parameters) -> tuple[control.Controller, control.Inputs]:
    """``ctrl`` and its inputs with the experiment's ``[drive]`` (docs/data.md, "The signal layer"): the force
    applied is g·(τ_ctrl(t − d) + b) for the controller's output τ_ctrl = gain·(u + disturbance), so the loop's
    gain becomes g·gain, its delay delay + d (whole samples: each coordinate's is
    :attr:`~symbolic.data.controller.Controller.drive_delays`; beyond the controller's memory one delay for
    every coordinate joins the loop's own)
    and b/gain joins the disturbance, itself delayed by d. A replayed force (``torque``) is the logged command,
    which :func:`symbolic.data.load` already turned into the applied force."""
    layer = measurements.signal_layer if isinstance(measurements, Experiment) else None
    if layer is None or not layer.drive or ctrl.kind == "torque":
        return ctrl, signals
    source = str(measurements.source)
    channels = [layer.drive_of(c) for c in ctrl.coordinates]
    for channel in layer.drive.values():
        if channel.coordinate not in ctrl.coordinates:
            raise DataError(source, f"[drive] {channel.signal}", f"coordinate {channel.coordinate!r} is not driven by "
                                                                 f"the [controller] (its coordinates: "
                                                                 f"{', '.join(ctrl.coordinates)})")
    shifts = [0.0 if ch is None else ch.delay for ch in channels]
    if any(d != int(d) or d < 0 for d in shifts):
        raise DataError(source, "[drive] delay", f"delays of {', '.join(f'{d:g}' for d in shifts)} samples on the "
                                                 "coordinates of a feedback [controller] (allowed there: whole numbers "
                                                 "of samples ≥ 0, the drive's latency in the loop; fractional delays "
                                                 "apply to a replayed force)")
    shifts = [int(d) for d in shifts]
    # within the controller's memory a drive's delay is a number of the compiled loop (Controller.drive_slots);
    # beyond it one delay for all joins the loop's, kept in a DelayLine
    common = min(shifts) if ctrl.delay + max(shifts) > control.LINE_IN_MEMORY else 0
    own = tuple(d - common for d in shifts)
    if any(own) and ctrl.delay + max(shifts) > control.LINE_IN_MEMORY:
        raise DataError(source, "[drive] delay", f"drive delays of {', '.join(map(str, shifts))} samples besides the "
                                                 f"loop's {ctrl.delay} (allowed: differing delays up to "
                                                 f"{control.LINE_IN_MEMORY} samples in all; one delay for every "
                                                 "coordinate otherwise)")
    before = control.drive_gains(ctrl, parameters)
    disturbance = signals.disturbance.copy()
    for k, ch in enumerate(channels):
        if ch is not None and ch.bias != 0:
            if before[k] == 0:
                raise DataError(source, f"[drive] {ch.signal} bias", "the [controller] gain of the coordinate is 0: a "
                                                                     "drive bias needs a non-zero loop gain")
            disturbance[:, k] += ch.bias / before[k]
    for k, shift in enumerate(shifts):  # the disturbance joins the command before the drive: late with it
        if shift:
            disturbance[:, k] = np.concatenate([np.repeat(disturbance[:1, k], shift), disturbance[:-shift, k]])
    import sympy as sp

    gain = tuple(g if ch is None else sp.Float(ch.gain) * g for g, ch in zip(ctrl.gain, channels))
    ctrl = dataclasses.replace(ctrl, gain=gain, delay=ctrl.delay + common, drive_delays=own if any(own) else ())
    ctrl = control.check_delay(ctrl, measurements.samples)
    return ctrl, dataclasses.replace(signals, disturbance=np.ascontiguousarray(disturbance))


@dataclass(frozen=True)
class PositionSensors:
    """The position sensors a feedback controller reads, one per coordinate of the model (docs/data.md, "The
    signal layer"): q_m,k = gain·q(t_k − delay) + bias, the delay (samples) by linear interpolation between
    the positions at the two samples around it — causal, so that the loop can run it, with an error of at
    most h²/8·max|q̈| — from a history of the last :attr:`depth` positions, held at the initial one before
    the log."""

    gains: tuple[float, ...]
    biases: tuple[float, ...]
    delays: tuple[float, ...]

    @property
    def depth(self) -> int:
        """Past positions kept: ⌊delay⌋ + 1 for the longest delay, 0 without one."""
        return max((math.floor(d) + 1 for d in self.delays if d > 0), default=0)

    def read(self, history: list) -> Any:
        """q_m from ``history`` = [q_k, q_k−1, …, q_k−depth] (NumPy vectors or CasADi expressions)."""
        rows = []
        for j, (g, b, d) in enumerate(zip(self.gains, self.biases, self.delays)):
            whole, u = math.floor(d), d - math.floor(d)
            value = history[whole][j] if u == 0 else (1 - u) * history[whole][j] + u * history[whole + 1][j]
            rows.append(g * value + b)
        return rows


def position_sensors(ctrl: control.Controller, measurements: Measurements,
                     names: tuple[str, ...]) -> PositionSensors | None:
    """The experiment's ``[sensors] q_<c>`` (gain 1, bias 0, delay 0 where none is declared) through which a
    feedback controller reads the simulated positions, as the machine's read the sensor; ``None`` without
    any, or for a replayed force (no controller reads anything)."""
    layer = measurements.signal_layer if isinstance(measurements, Experiment) else None
    channels = [] if layer is None or ctrl.kind == "torque" else [layer.sensors.get(f"q_{c}") for c in names]
    if not any(channels):
        return None
    return PositionSensors(tuple(1.0 if ch is None else ch.gain for ch in channels),
                           tuple(0.0 if ch is None else ch.bias for ch in channels),
                           tuple(0.0 if ch is None else ch.delay for ch in channels))


# -- initial state -----------------------------------------------------------------------------------------


def _initial_state(model: DynamicModel | SimulationModel, measurements: Measurements, p: np.ndarray,
                   initial: Any) -> np.ndarray:
    model = simulation_model(model)
    names = list(model.robot.generalized_coordinates)
    n = len(names)
    if initial is not None:
        q0, qd0 = (np.asarray(v, dtype=float).reshape(-1) for v in initial)
        if q0.shape != (n,) or qd0.shape != (n,) or not (np.isfinite(q0).all() and np.isfinite(qd0).all()):
            raise DataError(str(measurements.source), "initial",
                            f"expected finite (q0, qd0) with {n} values each ({', '.join(names)})")
        return np.concatenate([q0, qd0])
    x0 = np.zeros(2 * n)
    velocity = initial_velocity(measurements)
    for j, c in enumerate(measurements.coordinates):
        x0[names.index(c)] = measurements.q[0, j]
        x0[n + names.index(c)] = velocity[j]
    if model.robot.beams:
        from symbolic.numeric.statics import residual_imbalance

        rigid = len(model.robot.coordinates)
        sag = residual_imbalance(model.dynamic(), x0[:rigid], model.by_name(p))
        for name, value in sag.modal.items():
            if name not in measurements.coordinates:
                x0[names.index(name)] = value
    return x0


@dataclass(frozen=True)
class Restarts:
    """The replay in windows (docs/simulation.md, "Replay in windows"): at every ``every``-th sample after the first,
    the measured coordinates' positions and velocities (rows ``rows`` of x) are set to the measured ones,
    ``states[i]`` at window i's first sample (row 0, the initial state's, unused); the model's other coordinates
    (a beam's modes) go on from the simulated state."""

    every: int
    rows: np.ndarray
    states: np.ndarray

    def state(self, window: int, z: np.ndarray) -> np.ndarray:
        """The loop state ``z`` with window ``window``'s measured state set in."""
        z = z.copy()
        z[self.rows] = self.states[window]
        return z


def restarts(ctrl: control.Controller, measurements: Measurements, names: tuple[str, ...]) -> Restarts | None:
    """The restarts of ``ctrl``'s replay in windows on ``measurements`` (``None``: one run over the whole log): the
    measured positions and the velocities of :func:`velocity_at` at each window's first sample."""
    every = ctrl.restart_samples(measurements.sample_period)
    if every is None:
        return None
    n = len(names)
    columns = [names.index(c) for c in measurements.coordinates]
    starts = range(0, measurements.samples, every)
    states = np.array([np.concatenate([measurements.q[k], velocity_at(measurements, k)]) for k in starts])
    return Restarts(every, np.array(columns + [n + j for j in columns]), states)


def segments(samples: int, chunk: int, every: int | None) -> list[tuple[int, int, int | None]]:
    """(first sample, length, window restarted there or ``None``) of the blocks a loop runs a log in: at most
    ``chunk`` samples, none across a restart (every ``every`` samples after the first; ``None``: none)."""
    out, start = [], 0
    while start < samples:
        end = min(samples, start + chunk)
        window = None
        if every is not None:
            end = min(end, (start // every + 1) * every)
            window = start // every if start % every == 0 and start else None
        out.append((start, end - start, window))
        start = end
    return out


def block_length(length: int, start: int, size: int, samples: int) -> int:
    """The compiled length to run a block of ``size`` samples from ``start`` on: ``length``, or the block's own
    where it is shorter and not the log's last (a window's tail, whose last state the next window needs: a padded
    block returns none, :class:`Chunked`)."""
    return size if size < length and start + size < samples else length


def velocity_at(measurements: Measurements, k: int) -> np.ndarray:
    """Q̇ at sample ``k``: :func:`initial_velocity` at the first; elsewhere the data's ``qd`` there, else the slope
    at t_k of a least-squares parabola through the positions within half of :func:`initial_velocity`'s width on
    either side (centred: no edge bias)."""
    if k == 0:
        return initial_velocity(measurements)
    if measurements.qd is not None:
        return np.asarray(measurements.qd[k], dtype=float)
    half = max(1, _velocity_width(measurements) // 2)
    lo, hi = max(0, k - half), min(measurements.samples, k + half + 1)
    t = measurements.t[lo:hi] - measurements.t[k]
    if hi - lo < 3:
        return (measurements.q[hi - 1] - measurements.q[lo]) / (t[-1] - t[0])
    basis = np.column_stack([np.ones(hi - lo), t, t**2])
    return np.linalg.lstsq(basis, measurements.q[lo:hi], rcond=None)[0][1]


def _velocity_width(measurements: Measurements) -> int:
    """Samples of :func:`initial_velocity`'s parabola: one period of the comparison's cut-off, plus one."""
    how = treatment(measurements)
    width = math.ceil(measurements.rate / how.cutoff) + 1 if how.cutoff is not None else 3
    return min(max(3, width), measurements.samples)


def initial_velocity(measurements: Measurements) -> np.ndarray:
    """Q̇ at the first sample: the data's ``qd`` there, else the slope at t_0 of a least-squares parabola
    through the first W positions, W = ⌈rate/cutoff⌉ + 1 samples (one period of the comparison's cut-off;
    at least 3). A zero-phase filter's derivative is biased at the edge by about q̈·(the filter's
    delay); the parabola absorbs the initial acceleration."""
    if measurements.qd is not None:
        return np.asarray(measurements.qd[0], dtype=float)
    width = _velocity_width(measurements)
    t = measurements.t[:width] - measurements.t[0]
    if width < 3:
        return (measurements.q[1] - measurements.q[0]) / (t[1] - t[0])
    basis = np.column_stack([np.ones(width), t, t**2])
    coefficients = np.linalg.lstsq(basis, measurements.q[:width], rcond=None)[0]
    return coefficients[1]


# -- fixed step: the closed loop as one mapped CasADi function ------------------------------------------------


def sample_function(ctrl: control.Controller, plant: Plant, names: tuple[str, ...], period: float,
                    substeps: int, external: bool = False,
                    sensed: PositionSensors | None = None, calm: int = 0) -> ca.Function:
    """One sample of the closed loop: ``(z, w, p, c, eps) -> (z_next, y)``.

    z = [x; controller memory], w = [reference (x_ref of a state feedback); disturbance; logged τ; t_k] of
    the sample, y = [q; q̇; q̈; τ] at t_k (q̈ with τ_k applied), z_next after ``substeps`` RK4 steps of
    period/substeps (each at its own times, for a model whose forces depend on time) — or, with ``calm`` > 0,
    ``calm`` steps of period/calm where the sample is calm (:func:`stepping`): a conditional in the generated code,
    which runs one branch only, and whose sensitivities are the branch's.

    ``external``: the delay line is the caller's (:class:`~symbolic.simulation.controller.DelayLine`): w
    ends with the output applied at the sample and y with the output computed there.

    ``sensed``: the position sensors (:class:`PositionSensors`) through which the controller reads q; z then
    ends with the last ``sensed.depth`` positions, newest first.
    """
    n, memory = plant.n, ctrl.memory_size(line=not external)
    depth = 0 if sensed is None else sensed.depth
    nc, nr = ctrl.size, ctrl.reference_size
    step_controller = control.controller_function(ctrl, names, period, external)
    P, E = ca.MX.sym("p", plant.rhs.size1_in(2)), ca.MX.sym("eps")
    Z, W = ca.MX.sym("z", 2 * n + memory + depth * n), ca.MX.sym("w", nr + nc + n + 1 + (nc if external else 0))
    C = ca.MX.sym("c", step_controller.size1_in(5))
    x, m = Z[: 2 * n], Z[2 * n:2 * n + memory]
    history = [x[:n], *(Z[2 * n + memory + i * n:2 * n + memory + (i + 1) * n] for i in range(depth))]
    position = x[:n] if sensed is None else ca.vertcat(*sensed.read(history))
    read = (m, position, W[:nr], W[nr:nr + nc], W[nr + nc:nr + nc + n], C)
    t_k = W[nr + nc + n]
    if external:
        m_next, tau, u = step_controller(*read, W[nr + nc + n + 1:])
    else:
        (m_next, tau), u = step_controller(*read), ca.MX(0, 1)
    xdot = plant.rhs(x, tau, P, E, t_k)
    signed = plant.signed if calm else []
    if signed:
        v, a = x[n:][signed], xdot[n:][signed]
        clear = ca.mmin(ca.fabs(v) - 2 * period * ca.fabs(a)) > CALM_MARGIN * E
        stiff = _stiff_sample(plant, period, substeps, calm) if substeps >= IMPLICIT_WORTH * IMPLICIT_PER_CALM * calm \
            else _rk4_sample(plant, period, substeps)
        x_next = ca.Function.conditional("sample", [stiff], _rk4_sample(plant, period, calm))(
            clear, x, xdot, tau, P, E, t_k)  # index 0 (not clear): a stiff sample; 1: the calm sub-steps
    else:
        x_next = _rk4_sample(plant, period, substeps)(x, xdot, tau, P, E, t_k)
    return ca.Function("closed_loop_sample", [Z, W, P, C, E], [ca.vertcat(x_next, m_next, *history[:depth]),
                                                                 ca.vertcat(x, xdot[n:], tau, u)],
                       ["z", "w", "p", "c", "eps"], ["z_next", "y"])


def _rk4_sample(plant: Plant, period: float, substeps: int) -> ca.Function:
    """``(x, ẋ(x), tau, p, eps, t_k) -> x after one sample``: ``substeps`` RK4 steps of period/substeps, the first
    stage given (the sample shares it with y's q̈: one evaluation of five saved)."""
    n, h = plant.n, period / substeps
    X, T, K1 = ca.MX.sym("x", 2 * n), ca.MX.sym("tau", n), ca.MX.sym("k1", 2 * n)
    P, E, S = ca.MX.sym("p", plant.rhs.size1_in(2)), ca.MX.sym("eps"), ca.MX.sym("t")
    k2 = plant.rhs(X + h / 2 * K1, T, P, E, S + h / 2)
    k3 = plant.rhs(X + h / 2 * k2, T, P, E, S + h / 2)
    k4 = plant.rhs(X + h * k3, T, P, E, S + h)
    rk4_after = ca.Function("rk4_stages", [X, K1, T, P, E, S], [X + h / 6 * (K1 + 2 * k2 + 2 * k3 + k4)])
    rk4 = ca.Function("rk4", [X, T, P, E, S], [rk4_after(X, plant.rhs(X, T, P, E, S), T, P, E, S)])
    x_first = rk4_after(X, K1, T, P, E, S)
    x_next = x_first if substeps == 1 else \
        _repeat(rk4, substeps - 1, x_first, T, P, E, starts=S + h * ca.DM(range(1, substeps)).T)
    return ca.Function(f"rk4_sample_{substeps}", [X, K1, T, P, E, S], [x_next])


IMPLICIT_PER_CALM = 32
"""Linearly implicit sub-steps a stiff sample tries first, per sub-step of a calm sample (:func:`_stiff_sample`)."""

IMPLICIT_WORTH = 8
"""A stiff sample tries the implicit sub-steps only where RK4 takes at least this many times as many (m ≥
8·32·m_soft): each costs about three evaluations of the dynamics and a solve, and its code a few seconds more of
the compiler per closed loop (the 6-axis arm of tests/workflow_cases.py: 5.6 → 8.4 s for its first simulation
from an empty cache), which a run of fewer RK4 sub-steps does not win back."""

IMPLICIT_TOLERANCE = 1.0
"""A stiff sample keeps its linearly implicit sub-steps where every velocity's local error estimate is within
this many ε (the smoothed sign's velocity scale, below which the model does not define friction's force); else it
takes all the RK4 sub-steps (:func:`_stiff_sample`)."""

ROS2_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)
"""γ of ROS2 (Verwer et al. 1999, eq. 2.3): L-stable, second order whatever the matrix J of its linear systems."""


def _linearly_implicit_sample(plant: Plant, period: float, substeps: int) -> ca.Function:
    """``(x, ẋ(x), tau, p, eps, t_k) -> (x after one sample, largest velocity error estimate)``: ``substeps``
    steps of ROS2 (Verwer, Spee, Blom, Hundsdorfer 1999, eq. 2.3), W·k₁ = f(x), W·k₂ = f(x + h·k₁) − 2k₁,
    x⁺ = x + h(3k₁ + k₂)/2, W = I − γhJ. J = [[0, I], [−D⁻¹K, −D⁻¹B]] (:attr:`Plant.linearised`): the sign's
    steep damper and the springs are in it, the terms of ∂D/∂q are not — ROS2 is a W-method, second order for
    any J, and stable where J holds the stiff part. W·[a; b] = [r₁; r₂] is solved as
    (D + γhB + γ²h²K)·b = D·r₂ − γhK·r₁, a = r₁ + γh·b. The error estimate of a step is the velocity part of
    x⁺ − (x + h·k₁) = h(k₁ + k₂)/2 (its embedded first-order solution)."""
    n, h = plant.n, period / substeps
    g = ROS2_GAMMA * h
    X, T, K1 = ca.SX.sym("x", 2 * n), ca.SX.sym("tau", n), ca.SX.sym("k1", 2 * n)
    P, E, S, R = ca.SX.sym("p", plant.rhs.size1_in(2)), ca.SX.sym("eps"), ca.SX.sym("t"), ca.SX.sym("r")
    D, B, K = plant.linearised(X, P, E, S)
    W = D + g * B + g * g * K

    def solve(r: ca.SX) -> ca.SX:
        b = ca.solve(W, ca.mtimes(D, r[n:]) - g * ca.mtimes(K, r[:n]))
        return ca.vertcat(r[:n] + g * b, b)

    k1 = solve(K1)
    k2 = solve(plant.rhs(X + h * k1, T, P, E, S + h) - 2 * k1)
    error = ca.mmax(ca.fabs(h / 2 * (k1 + k2)[n:]))
    XR = ca.vertcat(X, R)  # the state and the largest error so far
    after = ca.Function("ros2_stages", [XR, K1, T, P, E, S], [ca.vertcat(X + h / 2 * (3 * k1 + k2), ca.fmax(R, error))])
    step = ca.Function("ros2", [XR, T, P, E, S], [after(XR, plant.rhs(X, T, P, E, S), T, P, E, S)])
    x, k, tau, p, eps, t = (ca.MX.sym(name, v.sparsity()) for name, v in zip(("x", "k1", "tau", "p", "eps", "t"),
                                                                           (X, K1, T, P, E, S)))
    first = after(ca.vertcat(x, 0), k, tau, p, eps, t)
    last = first if substeps == 1 else \
        _repeat(step, substeps - 1, first, tau, p, eps, starts=t + h * ca.DM(range(1, substeps)).T)
    return ca.Function(f"ros2_sample_{substeps}", [x, k, tau, p, eps, t], [last[:2 * n], last[2 * n]])


def _stiff_sample(plant: Plant, period: float, substeps: int, calm: int) -> ca.Function:
    """A sample that is not calm (:func:`sample_function`): :data:`IMPLICIT_PER_CALM`·``calm`` linearly implicit
    sub-steps (:func:`_linearly_implicit_sample`), kept where their error estimate is within
    :data:`IMPLICIT_TOLERANCE`·ε, else ``substeps`` RK4 sub-steps (a conditional: one branch runs). Where a
    velocity sits in the sign's steep part — a joint held by its friction — the implicit steps follow the
    stiff damper's equilibrium (the creep velocity) that RK4 resolves with hundreds of steps; where it crosses
    or leaves it, their estimate is large and RK4 takes the sample."""
    implicit, rk4 = _linearly_implicit_sample(plant, period, IMPLICIT_PER_CALM * calm), _rk4_sample(plant, period, substeps)
    inputs = [ca.MX.sym(rk4.name_in(i), rk4.sparsity_in(i)) for i in range(rk4.n_in())]
    x_implicit, error = implicit(*inputs)
    y = ca.MX.sym("y", 2 * plant.n)
    keep, redo = ca.Function("keep", [y, *inputs], [y]), ca.Function("redo", [y, *inputs], [rk4(*inputs)])
    x_next = ca.Function.conditional("stiff", [redo], keep)(error <= IMPLICIT_TOLERANCE * inputs[4], x_implicit,
                                                            *inputs)
    return ca.Function(f"stiff_sample_{substeps}", inputs, [x_next])


def _repeat(step: ca.Function, count: int, x: ca.MX, *args: ca.MX, starts: ca.MX) -> ca.MX:
    """``count`` applications of ``step(x, *args, start_i)``, ``starts`` the ``1 × count`` start times of the
    steps: a loop in the generated code (``fold``), not an unrolled copy."""
    if count == 1:
        return step(x, *args, starts[0])
    return step.fold(count)(x, *[ca.repmat(a, 1, count) for a in args], starts)


CHUNK = 1024
"""Samples per call of a compiled chunk (:class:`Chunked`): CasADi builds a mapaccum in a time that grows faster
than linearly with its length (0.03 s for 1000 samples, 0.7 s for 10 000), so long logs are run in chunks."""


@dataclass(eq=False)
class Chunked:
    """A sample function ``(z, w, *args) -> (z_next, y)`` run over a block of samples by one call: its ``mapaccum``
    compiled as a whole — a loop in C over the sample's code. Calling a compiled sample function from CasADi's
    virtual machine once per sample (its mapaccum over a library) cost more than the sample itself (the 7-DOF Panda
    under PD: 6 µs a sample of 11; bench/simulate.py). Blocks of :data:`CHUNK` samples; a shorter block is padded
    with its last column to the length compiled (:meth:`length` of the log: one length per loop and log), and
    what the padding computes is dropped."""

    sample: ca.Function
    compiled: bool | None
    _functions: dict = field(default_factory=dict, repr=False)
    is_compiled: bool = False

    @staticmethod
    def length(samples: int) -> int:
        """The compiled length for a log of ``samples``: the first of 64, 256 and :data:`CHUNK` that holds it, else
        :data:`CHUNK` (few lengths, so few libraries to compile: each is a compiler run of a second or so)."""
        return next((n for n in (64, 256) if samples <= n), CHUNK)

    def function(self, length: int) -> ca.Function:
        if length not in self._functions:
            function = self._blocks(length)
            fast = compile_casadi(function) if self.compiled is not False else None
            if self.compiled and fast is None:
                LOG.warning("no working C compiler: the simulation runs in CasADi's virtual machine")
            self.is_compiled = fast is not None
            self._functions[length] = fast or function
        return self._functions[length]

    def _blocks(self, length: int) -> ca.Function:
        """``(z, w, *args) -> (z_last, y)`` over ``length`` samples, ``w`` one column a sample and the other inputs
        the sample's own (not repeated: converting them to ``length`` columns, and every state back to NumPy, cost
        a fifth of the run)."""
        sample = self.sample
        names = [sample.name_in(i) for i in range(sample.n_in())]
        inputs = [ca.MX.sym(name, sample.sparsity_in(i)) for i, name in enumerate(names)]
        inputs[1] = ca.MX.sym(names[1], sample.size1_in(1), length)
        states, y = sample.mapaccum(sample.name(), length)(*inputs)
        return ca.Function(sample.name(), inputs, [states[:, -1], y], names, ["z_last", "y"])

    def __call__(self, length: int, z: np.ndarray, w: np.ndarray, *args: Any) -> tuple[np.ndarray | None, np.ndarray]:
        """(z after the block's last sample, y of each sample as columns) of the block ``w`` (one column a sample,
        at most ``length``) by the function compiled for ``length`` samples; z is ``None`` after a padded block
        (a log's last)."""
        size = w.shape[1]
        if size < length:
            w = np.hstack([w, np.repeat(w[:, -1:], length - size, axis=1)])
        last, y = self.function(length)(z, np.ascontiguousarray(w), *args)
        return (np.asarray(last).ravel() if size == length else None), np.asarray(y)[:, :size]


def _closed_loop(ctrl: control.Controller, plant: Plant, names: tuple[str, ...], period: float, substeps: int,
                 compiled: bool | None, sensed: PositionSensors | None = None, calm: int = 0) -> Chunked:
    """The closed loop's samples in compiled chunks, built once per plant, controller structure and position sensors."""
    external = control.line_outside(ctrl)
    key = (ctrl.structure(), external, names, period, substeps, compiled, sensed, calm)
    cache = plant.closed_loops
    if key not in cache:
        cache[key] = Chunked(sample_function(ctrl, plant, names, period, substeps, external, sensed, calm), compiled)
    return cache[key]


def loop_state(x0: np.ndarray, memory: int, sensed: PositionSensors | None) -> np.ndarray:
    """The first z of :func:`sample_function`: x₀, the controller's ``memory`` zeroed, and the position
    sensors' history held at the initial position."""
    depth = 0 if sensed is None else sensed.depth
    return np.concatenate([x0, np.zeros(memory), np.tile(x0[:len(x0) // 2], depth)])


def loop_inputs(signals: control.Inputs, measurements: Measurements) -> np.ndarray:
    """w of :func:`sample_function` over the log, one column per sample: reference, disturbance, logged τ, t_k."""
    return np.hstack([signals.reference, signals.disturbance, signals.torque, measurements.t[:, None]]).T


def _run_fixed_step(ctrl: control.Controller, plant: Plant, measurements: Measurements, signals: control.Inputs,
                    x0: np.ndarray, p: np.ndarray, c: np.ndarray, eps: float, substeps: int, names: tuple[str, ...],
                    compiled: bool | None, timings: dict[str, float],
                    sensed: PositionSensors | None = None, calm: int = 0,
                    windows: Restarts | None = None) -> tuple[np.ndarray, bool]:
    started = time.perf_counter()
    loop = _closed_loop(ctrl, plant, names, measurements.sample_period, substeps, compiled, sensed, calm)
    line = control.DelayLine(ctrl.delay, ctrl.size) if control.line_outside(ctrl) else None
    # with a delay line, a chunk's applied outputs were computed at least `delay` samples before it
    chunk = CHUNK if line is None else min(CHUNK, ctrl.delay)
    length = loop.length(measurements.samples) if line is None else chunk
    if windows is not None:
        chunk = length = min(chunk, windows.every)
    loop.function(length)
    timings["compile"] = time.perf_counter() - started
    started = time.perf_counter()
    z = loop_state(x0, ctrl.memory_size(line=line is None), sensed)
    w = loop_inputs(signals, measurements)
    outputs = []
    n4 = 4 * plant.n
    for start, size, window in segments(measurements.samples, chunk, None if windows is None else windows.every):
        if window is not None:
            z = windows.state(window, z)
        inputs = w[:, start:start + size]
        if line is not None:
            inputs = np.vstack([inputs, line.applied(start, size).T])
        z, y = loop(block_length(length, start, size, measurements.samples), z, inputs, p, c, eps)
        if line is not None:
            line.computed(start, y[n4:].T)
        outputs.append(y[:n4])
    timings["integrate"] = time.perf_counter() - started
    return np.hstack(outputs).T, loop.is_compiled


# -- solve_ivp from sample to sample -----------------------------------------------------------------------------


def _run_solve_ivp(ctrl: control.Controller, plant: Plant, measurements: Measurements, signals: control.Inputs,
                   x0: np.ndarray, p: np.ndarray, c: np.ndarray, eps: float, names: tuple[str, ...], method: str,
                   rtol: float, atol: float, sensed: PositionSensors | None = None) -> np.ndarray:
    from scipy.integrate import solve_ivp

    n = plant.n
    period = measurements.sample_period
    line = control.DelayLine(ctrl.delay, ctrl.size) if control.line_outside(ctrl) else None
    step_controller = control.controller_function(ctrl, names, period, external=line is not None)
    x, tau, t = ca.SX.sym("x", 2 * n), ca.SX.sym("tau", n), ca.SX.sym("t")
    xdot = plant.rhs(x, tau, p, eps, t)
    rhs = ca.Function("f", [x, tau, t], [xdot])
    jac = ca.Function("J", [x, tau, t], [ca.jacobian(xdot, x)])
    memory = np.zeros(ctrl.memory_size(line=line is None))
    state = x0.copy()
    out = np.full((measurements.samples, 4 * n), np.nan)
    history = [x0[:n].copy() for _ in range(0 if sensed is None else sensed.depth + 1)]
    for k in range(measurements.samples):
        if sensed is not None:
            history = [state[:n].copy(), *history[:-1]]
        position = state[:n] if sensed is None else np.asarray(sensed.read(history), dtype=float)
        read = (memory, position, signals.reference[k], signals.disturbance[k], signals.torque[k], c)
        if line is None:
            memory_next, tau_k = step_controller(*read)
        else:
            memory_next, tau_k, u_k = step_controller(*read, line.applied(k, 1)[0])
            line.computed(k, np.asarray(u_k).reshape(1, -1))
        tau_k, t_k = np.asarray(tau_k).ravel(), float(measurements.t[k])
        derivative = np.asarray(rhs(state, tau_k, t_k)).ravel()
        out[k] = np.concatenate([state, derivative[n:], tau_k])
        memory = np.asarray(memory_next).ravel()
        if not np.isfinite(out[k]).all():
            break  # reported by _trajectory with the time and the coordinate
        try:
            solution = solve_ivp(lambda t, s: np.asarray(rhs(s, tau_k, t_k + t)).ravel(), (0.0, period), state,
                                 method=method, rtol=rtol, atol=atol, jac=lambda t, s: np.asarray(jac(s, tau_k, t_k + t)))
        except (np.linalg.LinAlgError, ValueError):  # a state or Jacobian that is not finite any more
            out[k + 1:] = np.nan
            break
        if not solution.success:
            raise DataError(str(measurements.source), "method",
                            f"{method} failed at t = {measurements.t[k]:.6g} s: {solution.message}")
        state = solution.y[:, -1]
    return out


def _trajectory(measurements: Measurements, names: tuple[str, ...], y: np.ndarray) -> Measurements:
    """The simulated samples as measurements: the data's coordinates first, then the model's others."""
    n = len(names)
    order = list(measurements.coordinates) + [c for c in names if c not in measurements.coordinates]
    index = [names.index(c) for c in order]
    q, qd, qdd, tau = (y[:, k * n:(k + 1) * n][:, index] for k in range(4))
    bad = np.flatnonzero(~np.isfinite(y).all(axis=1))
    if bad.size:
        column = int(np.flatnonzero(~np.isfinite(y[bad[0]]))[0])
        raise Diverged(str(measurements.source), float(measurements.t[bad[0]]), names[column % n],
                       "the state is no longer finite (an unstable closed loop, or too few sub-steps: give more)")
    return Measurements.from_arrays(measurements.t, order, q, tau, qd=qd, qdd=qdd)

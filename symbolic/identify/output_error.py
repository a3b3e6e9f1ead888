"""Output-error identification of a model file's parameters in the machine's own closed loop (DIDIM).

Gautier, Janot, Vandanjon, "A new closed-loop output error method for parameter identification of robot
dynamics" (IEEE TCST 2013): starting from the IDIM-LS solution, the parameters θ minimise the error
between the measured signals and those of the *simulated closed loop* — the model driven by the
experiment's ``[controller]`` (torque replay, PD, PID, cascade, state feedback) along the log's reference,
exactly as :func:`symbolic.simulation.simulate` runs it. The signals compared (``signals``):

* ``"force"`` (DIDIM proper): the simulated controller output τ_sim(θ) against the logged force τ;
* ``"position"``: q_sim(θ) against the measured q (the only choice under torque replay, where τ_sim = τ);
* ``"both"``: both, each weighted by ``weights`` (force, position).

Each coordinate's residual is divided by its RMS at the start (the IDIM-LS solution's simulation), so that
the cost is unit-free and each signal and coordinate counts as its own error level allows — IDIM-LS's
weighted least squares weighs coordinates so — then multiplied by the signal's weight. (Divided by the
measured signal's spread instead, EMPS's force error of 4.5 % would outweigh its position error of 0.002 %
2000-fold, and "both" would be "force".)

The minimisation is Levenberg–Marquardt (Marquardt's scaling diag(JᵀJ)) on θ/|θ₀|, bounded by the model
file's ``min``/``max`` and the signs of the parameters' roles (:func:`symbolic.identify.known.parameter_bounds`,
a step is projected onto them). Its Jacobian is *exact*: the discrete variational equations of the very
simulation run — one sample of the closed loop z_{k+1} = F(z_k, w_k, θ), y_k = G(z_k, w_k, θ) is
differentiated by CasADi's forward mode, S_{k+1} = ∂F/∂z·S_k + ∂F/∂θ, ∂y_k/∂θ = ∂G/∂z·S_k + ∂G/∂θ, and
that augmented sample is mapped over the log and compiled as the simulation itself is. Its RK4 sub-steps (and a
calm sample's) are chosen at the start and kept, so that it is one function of θ, until a trial step leaves their
stability region (:meth:`ClosedLoop.stable`): a lighter mass raises the smoothed sign's rate Fc/(M·ε), and there
the state may stay finite while each pass through the sign's steep part multiplies the sensitivities, without
bound (docs/simulation.md, "Calm samples"). The trial is then simulated with them chosen again there, never
fewer, and the fit goes on with that finer loop if the step is taken (:func:`levenberg_marquardt`). Where the loop is
not smooth: friction's sign is simulated as tanh(v/ε), and the sensitivity is that of the smoothed
simulation (large but finite within ε of zero velocity); a saturation's clip has derivative 0 where it
holds (a saturated sample's force does not depend on θ); a sensor's quantiser, a staircase whose derivative
is 0 between its steps (the simulated force would not depend on θ at all), counts as the identity in the
sensitivities — the sample is differentiated with the quantisation left out, at the quantised simulation's
state — its mean slope over a step.

The experiment's signal layer (:mod:`symbolic.data.signal_layer`) is in the loop as ``simulate`` puts it
(``[drive]`` on the controller's output, ``[sensors] q_<c>`` read by the controller); a declared signal is
compared as logged (the sensor model of the simulation, or the command the simulated force implies), and
its free values are fitted after the parameters (:class:`SignalValue`): a drive gain through the loop's
constants, a drive bias and a replayed force's values through the loop's inputs, a position sensor's bias
through the reference and the initial state, a force sensor's values on the comparison only — all with
exact derivatives (docs/data.md, "Output error"). Under a quantising controller a free position bias is added
to the quantised reading through the reference (an index offset on the counted position), where a fixed one is
quantised with the position: the two readings differ by less than one count.

Parameters fitted: the model-file parameters IDIM-LS determines (those ``identify --out`` writes), minus
``fixed = true`` and ``fix``; the others keep their model-file values. σ per parameter from the Jacobian at
the optimum, σ² = RSS/(m − p)·diag((JᵀJ)⁻¹), m residuals and p parameters. Output-error residuals are
strongly coloured (a model error or a slowly drifting position shows over many samples), so these σ are a
lower bound of the real spread; read them as IDIM-LS's, for comparison (docs/data.md, "Output error").
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg

from symbolic.data import DataError, Measurements, load, signal_layer
from symbolic.data.signal_layer import FreeValue, SignalLayer
from symbolic.derivation.dynamics import DynamicModel
from symbolic.errors import IdentificationError
from symbolic.identify.known import fixed_symbols, parameter_bounds
from symbolic.identify.least_squares import defined, percent
from symbolic.simulation import controller as control
from symbolic.simulation import simulator as sim

LOG = logging.getLogger(__name__)

SIGNALS = ("force", "position", "both")
MAX_ITERATIONS = 30
STEP_TOLERANCE = 1e-7
"""Converged when the largest accepted step, relative to each parameter's scale, is below this."""
COST_TOLERANCE = 1e-10
"""... or when the cost falls (or the linearised model predicts it would fall) by less than this, relatively."""
SIGMA_TOLERANCE = 1e-3
"""... or when the Gauss–Newton step is below this many standard deviations of every estimate."""
FLAT_SIGMA = 1.0
"""When no step lowers the cost (a cost with steps: a quantised sensor, whose readings jump a count at other
samples when θ moves) but the Gauss–Newton step is below this many σ, the fit has converged within its
precision: a step smaller than the estimates' standard deviations is not significant."""
MAX_DAMPING = 1e10
"""Marquardt's λ beyond which the search stops: no step lowers the cost (a step too small to matter)."""


@dataclass(frozen=True)
class FittedParameter:
    """One parameter of the output-error fit: value, σ, relative σ (%), the start (IDIM-LS), a bound held."""

    name: str
    value: float
    sigma: float
    relative_sigma: float
    start: float
    bound: str | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"value": self.value, "sigma": self.sigma, "relative_sigma": defined(self.relative_sigma),
                               "start": self.start}
        if self.bound is not None:
            out["at_bound"] = self.bound
        return out


@dataclass(frozen=True, eq=False)
class OutputErrorFit:
    """What :func:`output_error` found.

    Attributes
    ----------
    parameters
        The fitted parameters by name.
    converged
        Whether a convergence test held; else ``message`` says why it stopped.
    errors_start, errors
        Relative errors (%) per signal and coordinate, 100·‖measured − simulated‖/‖measured − mean‖, at
        the start and at the end.
    """

    model_name: str
    signals: str
    weights: tuple[float, float]
    parameters: dict[str, FittedParameter]
    converged: bool
    message: str
    iterations: int
    cost_start: float
    cost: float
    errors_start: dict[str, dict[str, float]]
    errors: dict[str, dict[str, float]]
    fixed: dict[str, float] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    start_method: str = "IDIM-LS solution"
    signal_values: dict[str, FittedParameter] = field(default_factory=dict)
    residual: np.ndarray | None = field(default=None, repr=False)
    """The weighted residual at the end, ``samples × compared columns`` (its colour: the σ above assume it white)."""
    held: dict[str, float] = field(default_factory=dict)
    """Parameters not fitted and held at these values instead of the model's (``output_error(held=...)``)."""

    def values(self) -> dict[str, float]:
        """{model parameter: fitted value}, for writing back into the model file."""
        return {name: p.value for name, p in self.parameters.items()}

    def to_dict(self) -> dict[str, Any]:
        """The JSON of ``symbolic identify --method didim --json``."""
        return {
            "model": self.model_name, "method": "didim", "start": self.start_method, "signals": self.signals,
            "weights": {"force": self.weights[0], "position": self.weights[1]},
            "parameters": {n: p.to_dict() for n, p in self.parameters.items()}, "fixed": dict(self.fixed),
            "converged": self.converged, "message": self.message, "iterations": self.iterations,
            "cost_start": self.cost_start, "cost": self.cost,
            "relative_error_start": self.errors_start, "relative_error": self.errors, "timings": dict(self.timings),
            "signal_layer": {n: p.to_dict() for n, p in self.signal_values.items()},
        }

    def table(self) -> str:
        """The parameters beside their start, the errors before and after, and how it stopped."""
        lines = [f"output error (DIDIM) on {self.signals}"
                 + (f" (weights force {self.weights[0]:g}, position {self.weights[1]:g})" if self.signals == "both" else "")
                 + f", from the {self.start_method}: {self.iterations} iteration(s), "
                 + ("converged" if self.converged else "NOT converged") + f": {self.message}",
                 f"{'parameter':<16}  {'identified':>14}  {'sigma':>12}  {'sigma %':>8}  {'start':>14}"]
        for p in (*self.parameters.values(), *self.signal_values.values()):
            bound = f"  (at its {p.bound})" if p.bound else ""
            lines.append(f"{p.name:<16}  {p.value:>14.6g}  {p.sigma:>12.4g}  {percent(p.relative_sigma):>8s}  "
                         f"{p.start:>14.6g}{bound}")
        if self.signal_values:
            lines.append("the signal layer's free values above are not written anywhere: copy them into the "
                         "experiment file's [sensors]/[drive] (docs/data.md, \"Output error\")")
        for signal, per in self.errors.items():
            for c, value in per.items():
                lines.append(f"relative error of {signal} {c}: {self.errors_start[signal][c]:.4g} % at the start, "
                             f"{value:.4g} % fitted")
        combined = [p.name for p in self.parameters.values() if not math.isfinite(p.sigma)]
        if combined:
            lines.append(f"σ = ∞: {', '.join(combined)} — the response determines them only in combinations (their "
                         "values are one of many that simulate alike)")
        if self.fixed:
            lines.append("kept at their values (fixed): " + ", ".join(f"{n} = {v:.6g}" for n, v in self.fixed.items()))
        lines.append("σ from the Jacobian, RSS/(m−p)·(JᵀJ)⁻¹: the residuals of an output error are coloured, so σ is "
                     "a lower bound of the spread")
        return "\n".join(lines)


# -- the simulation and its sensitivities --------------------------------------------------------------------


def sensitivity_function(ctrl: control.Controller, plant: sim.Plant, names: tuple[str, ...], period: float,
                         substeps: int, free: Sequence[int], quantised: bool = False,
                         sensed: sim.PositionSensors | None = None, signal_count: int = 0,
                         calm: int = 0) -> ca.Function:
    """One sample of the closed loop with its forward sensitivities to the parameters ``free`` (indices of p).

    ``(za, w, p, c, eps) -> (za_next, ya)`` with za = [z; vec(S)], S = ∂z/∂θ (column-major), and
    ya = [y; vec(∂y/∂θ)], z and y those of :func:`symbolic.simulation.simulator.sample_function` (with the
    position sensors ``sensed``): the discrete variational equation of the simulated sample, by CasADi's
    forward mode (``jtimes``).

    ``quantised``: the function takes one more input, ``c_smooth``, the controller's constants without its
    sensors' quantisation, and differentiates the sample there, at the simulated (quantised) state: the
    staircase's derivative is 0 between its steps (the force would not depend on θ at all) and its mean slope
    is 1, so the sensor counts as the identity in the sensitivities (module docstring). With ``calm`` sub-steps,
    the branch differentiated is the one the unquantised sample's own calm test takes: an accurate, stable
    simulation of the sample differentiated either way (docs/simulation.md, "Calm samples").

    ``signal_count``: θ ends with that many values of the experiment's signal layer, which act on the loop
    through its inputs and constants only: w then ends with ∂w/∂θ_s (column-major, nw × signal_count) and the
    function takes a last input ``dc``, ∂c/∂θ_s (nc × signal_count), the seeds of those directions."""
    F = sim.sample_function(ctrl, plant, names, period, substeps, sensed=sensed, calm=calm)
    nz, ny, npar, kp = F.size1_in(0), F.size1_out(1), F.size1_in(2), len(free)
    ks = signal_count
    k = kp + ks
    nw, nc = F.size1_in(1), F.size1_in(3)
    Z, S = ca.MX.sym("z", nz), ca.MX.sym("s", nz * k)
    W, P, C, E = ca.MX.sym("w", nw), ca.MX.sym("p", npar), ca.MX.sym("c", nc), ca.MX.sym("eps")
    DW, DC = ca.MX.sym("dw", nw * ks), ca.MX.sym("dc", nc * ks)
    theta = ca.MX.sym("theta", kp)
    select = ca.DM.zeros(npar, kp)
    for j, i in enumerate(free):
        select[i, j] = 1.0
    smooth = ca.MX.sym("c_smooth", nc) if quantised else C
    z_next, y = F(Z, W, P + ca.mtimes(select, theta), smooth, E)
    seeds = ca.vertcat(ca.reshape(S, nz, k), ca.horzcat(ca.DM.eye(kp), ca.DM.zeros(kp, ks)))
    arguments = ca.vertcat(Z, theta)
    if ks:  # the signal values' directions: through w and the constants (the quantisation-free ones)
        seeds = ca.vertcat(seeds, ca.horzcat(ca.DM.zeros(nw, kp), ca.reshape(DW, nw, ks)),
                           ca.horzcat(ca.DM.zeros(nc, kp), ca.reshape(DC, nc, ks)))
        arguments = ca.vertcat(arguments, W, smooth)
    derivative = ca.jtimes(ca.vertcat(z_next, y), arguments, seeds)  # (nz + ny) × k: k forward directions
    derivative = ca.substitute(derivative, theta, ca.DM.zeros(kp))
    if quantised:
        z_next, y = F(Z, W, P, C, E)  # the values: the loop as simulated, its sensor quantised
    else:
        z_next, y = ca.substitute([z_next, y], [theta], [ca.DM.zeros(kp)])
    inputs = [ca.vertcat(Z, S), ca.vertcat(W, DW) if ks else W, P, C, E, *([smooth] if quantised else []),
              *([DC] if ks else [])]
    return ca.Function("closed_loop_sensitivity", inputs,
                       [ca.vertcat(z_next, ca.reshape(derivative[:nz, :], nz * k, 1)),
                        ca.vertcat(y, ca.reshape(derivative[nz:, :], ny * k, 1))],
                       ["za", "w", "p", "c", "eps", *(["c_smooth"] if quantised else []), *(["dc"] if ks else [])],
                       ["za_next", "ya"])


@dataclass(frozen=True)
class SignalValue:
    """A free value of the experiment's signal layer fitted with the parameters: ``free`` as the experiment
    records it, ``name`` as reported (``[drive] tau_q gain``), its ``bounds``."""

    free: FreeValue
    name: str
    bounds: tuple[float, float]

    @property
    def key(self) -> tuple[str, str, str]:
        return (self.free.table, self.free.signal, self.free.field)


@dataclass(eq=False)
class ClosedLoop:
    """The experiment's closed loop ready to run at any θ: the simulation's settings fixed once (sub-steps,
    initial state, controller constants, the signal layer's fixed values), with or without sensitivities.
    θ is the model parameters ``free`` followed by the layer's free values ``signal_values``."""

    model: DynamicModel
    measurements: Measurements
    ctrl: control.Controller
    plant: sim.Plant
    names: tuple[str, ...]
    free: tuple[int, ...]
    p0: np.ndarray
    x0: np.ndarray
    c: np.ndarray
    c_smooth: np.ndarray | None
    w: np.ndarray
    substeps: int
    eps: float
    compiled: bool | None
    sensed: sim.PositionSensors | None = None
    layer: SignalLayer | None = None
    signal_values: tuple[SignalValue, ...] = ()
    before: np.ndarray | None = None  # the controller's own drive gains, before the [drive] gains
    initial_given: bool = False
    calm: int = 0
    """RK4 sub-steps of a calm sample (:func:`symbolic.simulation.simulator.stepping`; 0: all take ``substeps``)."""
    substeps_given: bool = False
    """The sub-steps were given (``substeps=``), not chosen: they are never chosen again (:meth:`restepped`)."""
    windows: sim.Restarts | None = None
    """The replay's restarts from the measured state (``[controller] restart``; ``None``: one run)."""
    _functions: dict = field(default_factory=dict)

    def function(self, sensitivities: bool) -> sim.Chunked:
        """The loop's samples, with or without sensitivities, in compiled chunks of the log's length
        (:class:`~symbolic.simulation.simulator.Chunked`)."""
        if sensitivities not in self._functions:
            if sensitivities:
                f = sensitivity_function(self.ctrl, self.plant, self.names, self.measurements.sample_period,
                                         self.substeps, self.free, self.c_smooth is not None, self.sensed,
                                         len(self.signal_values), self.calm)
                self._functions[True] = sim.Chunked(f, self.compiled)
            else:
                self._functions[False] = sim._closed_loop(self.ctrl, self.plant, self.names,
                                                          self.measurements.sample_period, self.substeps,
                                                          self.compiled, self.sensed, self.calm)
        return self._functions[sensitivities]

    def stable(self, theta: np.ndarray) -> bool:
        """Whether the loop's sub-steps are within RK4's stability bound at θ
        (:func:`symbolic.simulation.simulator.steps_stable`): where they are not, the simulation run is not the
        model's, and its sensitivities grow without bound (module docstring)."""
        return sim.steps_stable(self.plant, self.initial_state(theta), self.parameters(theta), self.eps,
                                float(self.measurements.t[0]), self.measurements.sample_period, self.substeps,
                                self.calm)

    def stable_at(self, theta: np.ndarray) -> ClosedLoop | None:
        """The loop to simulate θ on: this one where its sub-steps are stable there (:meth:`stable`), else
        :meth:`restepped` (stable by construction: chosen at θ, never fewer), ``None`` where neither is."""
        return self if self.stable(theta) else self.restepped(theta)

    def restepped(self, theta: np.ndarray) -> ClosedLoop | None:
        """The loop with its sub-steps chosen again at θ as :func:`closed_loop` chose them at the start, never
        fewer than now (so stable wherever the loop was): for a step to θ where they are not (:meth:`stable`).
        ``None`` where they were given, or θ needs more than :data:`~symbolic.simulation.simulator.MAX_SUBSTEPS`
        or cannot be simulated (D(Q) singular)."""
        if self.substeps_given:
            return None
        try:
            m, calm, _ = sim.stepping(self.plant, self.initial_state(theta), self.parameters(theta), self.eps,
                                      float(self.measurements.t[0]), self.measurements.sample_period, self.names,
                                      str(self.measurements.source))
        except sim.Diverged:
            return None
        if m > sim.MAX_SUBSTEPS:
            return None
        return dataclasses.replace(self, substeps=max(m, self.substeps), calm=max(calm, self.calm) if calm else 0,
                                   _functions={})

    def parameters(self, theta: np.ndarray) -> np.ndarray:
        p = self.p0.copy()
        p[list(self.free)] = theta[:len(self.free)]
        return p

    def layer_at(self, theta: np.ndarray) -> SignalLayer | None:
        """The signal layer with the free values of θ."""
        if not self.signal_values:
            return self.layer
        values = theta[len(self.free):]
        return self.layer.with_values({v.key: float(x) for v, x in zip(self.signal_values, values)},
                                      str(self.measurements.source))

    def inputs(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray,
                                                 np.ndarray, np.ndarray]:
        """(w, c, c_smooth, ∂w/∂θ_s, ∂c/∂θ_s, ∂z₀/∂θ_s) at the signal values of θ: each value acts on the loop
        through an input row, a drive gain or the initial state, exactly (module docstring)."""
        ks, n = len(self.signal_values), self.plant.n
        w, c = self.w.copy(), self.c.copy()
        smooth = None if self.c_smooth is None else self.c_smooth.copy()
        dw, dc = np.zeros((ks,) + w.shape), np.zeros((ks, len(c)))
        dz0 = np.zeros((ks, len(self.x0)))
        if not ks:
            return w, c, smooth, dw, dc, dz0
        layer, start = self.layer_at(theta), self.layer
        nc, nr = self.ctrl.size, self.ctrl.reference_size
        for i, value in enumerate(self.signal_values):
            table, signal, name = value.key
            channel = (layer.drive if table == "drive" else layer.sensors)[signal]
            first = (start.drive if table == "drive" else start.sensors)[signal]
            j = self.names.index(channel.coordinate)
            logged = np.asarray(layer.logged[signal], float)
            if table == "drive" and self.ctrl.kind != "torque":
                k = self.ctrl.coordinates.index(channel.coordinate)
                slot = control.gain_index(self.ctrl, k)
                if name == "gain":
                    for constants in (c, smooth) if smooth is not None else (c,):
                        constants[slot] = channel.gain * self.before[k]
                    dc[i, slot] = self.before[k]
                else:  # bias: b/gain joins the disturbance (simulator.drive_layer)
                    w[nr + k] += (channel.bias - first.bias) / self.before[k]
                    dw[i, nr + k] = 1.0 / self.before[k]
            elif channel.kind == "tau" and self.ctrl.kind == "torque":  # the replayed force is made of the log
                row = nr + nc + j
                w[row] = signal_layer.model_signal(channel, logged)
                if table == "drive":
                    shifted = signal_layer.shift(logged, -channel.delay)
                    dw[i, row] = {"gain": shifted + channel.bias, "bias": np.full(len(logged), channel.gain),
                                  "delay": -channel.gain * signal_layer.shift_derivative(logged, -channel.delay)
                                  }[name]
                else:
                    shifted = signal_layer.shift(logged, channel.delay)
                    dw[i, row] = {"gain": -(shifted - channel.bias) / channel.gain**2,
                                  "bias": np.full(len(logged), -1.0 / channel.gain),
                                  "delay": signal_layer.shift_derivative(logged, channel.delay) / channel.gain}[name]
            elif channel.kind == "q":  # a position sensor's bias: the initial state, and the loop's reading
                if not self.initial_given:  # x₀ is the first corrected position (:meth:`initial_state`)
                    dz0[i, j] = -1.0 / channel.gain
                if self.ctrl.kind != "torque":
                    row = self._reference_row(channel.coordinate)
                    # r − (q_m + δ) = (r − δ) − q_m: every kind reads its position through r − q_m
                    w[row] -= channel.bias - first.bias
                    dw[i, row] = -1.0
        return w, c, smooth, dw, dc, dz0

    def restart_state(self, theta: np.ndarray, window: int) -> np.ndarray:
        """The measured state set in at ``window``'s first sample (:class:`~symbolic.simulation.simulator.Restarts`),
        its positions read through the position sensors' free biases of θ as :meth:`initial_state`'s."""
        x = self.windows.states[window].copy()
        k = window * self.windows.every
        layer = self.layer_at(theta)
        for value in self.signal_values:
            table, signal, name = value.key
            channel = layer.sensors.get(signal) if table == "sensors" else None
            if channel is not None and channel.kind == "q":
                row = list(self.windows.rows).index(self.names.index(channel.coordinate))
                x[row] = signal_layer.correct(channel, layer.logged[signal])[k]
        return x

    def _restarted(self, z: np.ndarray, theta: np.ndarray, window: int, dz0: np.ndarray | None) -> np.ndarray:
        """``z`` (with its sensitivities S after it where ``dz0`` is given) at ``window``'s restart: the measured
        rows set to :meth:`restart_state`, their sensitivities to those of the measured state — zero for the
        model's parameters, ``dz0``'s for the position sensors' free values."""
        rows = self.windows.rows
        z = z.copy()
        nz = len(z) if dz0 is None else len(z) // (1 + len(theta))
        z[rows] = self.restart_state(theta, window)
        if dz0 is not None:
            k, ks = len(theta), len(self.signal_values)
            S = z[nz:].reshape(k, nz)  # one direction after the other
            S[:, rows] = 0.0
            S[k - ks:, rows] = dz0[:, rows]
        return z

    def _reference_row(self, coordinate: str) -> int:
        if self.ctrl.kind == control.STATE_FEEDBACK:
            return list(self.ctrl.states).index(("q", coordinate))
        return self.ctrl.coordinates.index(coordinate)

    def initial_state(self, theta: np.ndarray) -> np.ndarray:
        """x₀ with the position sensors' free biases of θ (the first corrected position moves with them)."""
        x0 = self.x0.copy()
        if self.initial_given:
            return x0
        layer = self.layer_at(theta)
        for value in self.signal_values:
            table, signal, name = value.key
            channel = layer.sensors.get(signal) if table == "sensors" else None
            if channel is not None and channel.kind == "q":
                x0[self.names.index(channel.coordinate)] = signal_layer.correct(channel, layer.logged[signal])[0]
        return x0

    def run(self, theta: np.ndarray, sensitivities: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """y (samples × 4n: q, q̇, q̈, τ over the model's coordinates) and, with ``sensitivities``, ∂y/∂θ
        (samples × 4n × k); NaN rows where the simulation diverged."""
        k = len(theta)
        if self.comparison_only:  # θ acts on the comparison alone: one simulation serves every θ
            if "y" not in self._functions:
                self._functions["y"] = self._simulate(theta, False)[0]
            y = self._functions["y"]
            return y, (np.zeros(y.shape + (k,)) if sensitivities else None)
        return self._simulate(theta, sensitivities)

    @property
    def comparison_only(self) -> bool:
        """Whether θ is only force sensors' values of a feedback loop: they change what the simulated force is
        compared with (:class:`_Residuals`), never the simulation."""
        return (not self.free and bool(self.signal_values) and self.ctrl.kind != "torque"
                and all(v.free.table == "sensors" and v.free.signal.startswith("tau_") for v in self.signal_values))

    def _simulate(self, theta: np.ndarray, sensitivities: bool) -> tuple[np.ndarray, np.ndarray | None]:
        function = self.function(sensitivities)
        n, k, ks = self.plant.n, len(theta), len(self.signal_values)
        memory = self.ctrl.memory_size()
        depth = 0 if self.sensed is None else self.sensed.depth
        w, c, smooth, dw, dc, dz0 = self.inputs(theta)
        z = sim.loop_state(self.initial_state(theta), memory, self.sensed)
        if sensitivities:
            s0 = np.zeros((k, len(z)))
            s0[k - ks:, :2 * n] = dz0
            for d in range(depth):  # the positions' history starts at the initial position
                s0[k - ks:, 2 * n + memory + d * n:2 * n + memory + (d + 1) * n] = dz0[:, :n]
            z = np.concatenate([z, s0.ravel()])  # column-major S: one direction after the other
            if ks:
                w = np.vstack([w, dw.reshape(ks * w.shape[0], -1)])
        p = self.parameters(theta)
        outputs = []
        samples = self.measurements.samples
        every = None if self.windows is None else self.windows.every
        chunk = sim.CHUNK if every is None else min(sim.CHUNK, every)
        length = function.length(samples) if every is None else chunk
        extra = [smooth] if sensitivities and smooth is not None else []
        if sensitivities and ks:
            extra.append(dc.ravel())  # column-major nc × ks
        for start, size, window in sim.segments(samples, chunk, every):
            if window is not None:
                z = self._restarted(z, theta, window, dz0 if sensitivities else None)
            z, y = function(sim.block_length(length, start, size, samples), z, w[:, start:start + size], p, c,
                            self.eps, *extra)
            outputs.append(y)
            if z is not None and not np.isfinite(z).all():
                outputs.append(np.full((outputs[-1].shape[0], samples - start - size), np.nan))
                break
        y = np.hstack(outputs).T
        ny = 4 * n
        if not sensitivities:
            return y[:, :ny], None
        return y[:, :ny], y[:, ny:].reshape(samples, k, ny).transpose(0, 2, 1)


def closed_loop(model: DynamicModel, measurements: Measurements, free: Sequence[str], *,
                parameters: Mapping[str, float] | None = None, friction_velocity: float = sim.FRICTION_VELOCITY,
                substeps: int | None = None, compiled: bool | None = None, initial: Any = None,
                signal_values: Sequence[FreeValue] = ()) -> ClosedLoop:
    """The closed loop of ``measurements``' experiment (its ``[controller]``, else torque replay) for
    :func:`output_error`: sub-steps chosen as :func:`~symbolic.simulation.simulate` chooses them at
    ``parameters`` and kept, so that the simulation differentiated is one function of θ (until the fit steps
    where they are unstable: :meth:`ClosedLoop.restepped`); the
    experiment's ``[drive]`` and position ``[sensors]`` in the loop as :func:`~symbolic.simulation.simulate`
    puts them, and ``signal_values`` (free values of the layer) fitted after the parameters."""
    source = str(measurements.source)
    names = tuple(model.robot.generalized_coordinates)
    sim._check_options("rk4", substeps, friction_velocity, source)
    sim._check_data(measurements, names, model.robot.name)
    p = sim._parameters(model, parameters, source)
    ctrl = control.check_delay(sim._controller(None, measurements, model, names), measurements.samples)
    in_gains = sorted({s.name for g in ctrl.gain for s in getattr(g, "free_symbols", ())} & set(free))  # numbers: floats
    if in_gains:  # the controller's constants are evaluated once: a gain cannot follow θ
        raise IdentificationError(f"{source}: [controller] gain: {', '.join(in_gains)} would be fitted but sets the "
                                  f"controller's drive gain, which the output-error fit keeps at its start value: keep "
                                  f"it at its value (--fix {','.join(in_gains)})")
    signals = control.inputs(ctrl, measurements, names)
    values = model.parameter_vector.with_array(p).by_symbol()
    before = control.drive_gains(ctrl, values)
    ctrl, signals = sim.drive_layer(ctrl, signals, measurements, values)
    sensed = sim.position_sensors(ctrl, measurements, names)
    if control.line_outside(ctrl):
        raise DataError(source, "controller", f"a delay of {ctrl.delay} samples (more than {control.LINE_IN_MEMORY}) "
                                              "is not supported by the output-error identification yet "
                                              f"(allowed: up to {control.LINE_IN_MEMORY})")
    layer = getattr(measurements, "signal_layer", None)
    fitted = tuple(_signal_value(v, ctrl, measurements) for v in signal_values)
    plant = sim._plant(model)
    x0 = sim._initial_state(model, measurements, p, initial)
    m, calm, radius = sim.stepping(plant, x0, p, friction_velocity, float(measurements.t[0]),
                                   measurements.sample_period, names, source, substeps)
    if m > sim.MAX_SUBSTEPS:
        raise IdentificationError(f"the model needs {m:.3g} RK4 sub-steps per sample (spectral radius {radius:.4g} "
                                  f"1/s): too stiff for the output-error identification's fixed-step simulation")
    c = control.constants(ctrl, values)
    smooth = None
    if np.any(ctrl.quantisation > 0):
        smooth = control.constants(dataclasses.replace(ctrl, quantisation=np.zeros_like(ctrl.quantisation)), values)
    w = sim.loop_inputs(signals, measurements)
    index = [model.parameter_vector.names.index(name) for name in free]
    return ClosedLoop(model, measurements, ctrl, plant, names, tuple(index), p, x0, c, smooth, np.ascontiguousarray(w), m,
                      friction_velocity, compiled, sensed, layer, fitted, before, initial is not None, calm,
                      substeps_given=substeps is not None, windows=sim.restarts(ctrl, measurements, names))


def _signal_value(value: FreeValue, ctrl: control.Controller, measurements: Measurements) -> SignalValue:
    """``value`` checked for a fit: the ones the loop or the comparison can follow exactly (module docstring)."""
    source = str(measurements.source)
    where = f"[{value.table}] {value.signal} {value.field}"
    kind = value.signal.split("_", 1)[0]
    feedback = ctrl.kind != "torque"
    unsupported = None
    if kind == "qd":
        unsupported = "a velocity sensor's values (the output error compares forces and positions)"
    elif value.table == "drive" and feedback and value.field == "delay":
        unsupported = ("a free drive delay in a feedback loop (the loop's delay is whole samples; declare it fixed, "
                       "e.g. delay = 1)")
    elif kind == "q" and value.field != "bias":
        unsupported = "a position sensor's free gain or delay (its bias may be free)"
    if unsupported:
        raise DataError(source, where, f"declared free, but the output-error fit cannot estimate {unsupported} yet "
                                       "(allowed free: [drive] gain and bias, and delay under torque replay; "
                                       "[sensors] tau_<c> gain, bias and delay; [sensors] q_<c> bias)")
    bounds = {"gain": (1e-9, math.inf) if value.start > 0 else (-math.inf, -1e-9), "bias": (-math.inf, math.inf),
              "delay": (0.0, signal_layer.delay_limit(measurements.samples))}[value.field]
    return SignalValue(value, where, bounds)


# -- the fit ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Residuals:
    """Which columns of y are compared with which measured signal, and their weights. A signal the
    experiment's layer declares is compared as logged: the sensor model of the simulation (gain·y(t − delay)
    + bias) against the sensor's log, the drive's command (y/gain − bias) against the logged command — so
    that a free gain scales the simulation's side, never the cost (the corrected data divided by a gain
    would shrink the residual with it)."""

    columns: list[int]
    measured: np.ndarray  # samples × len(columns)
    scale: np.ndarray  # weight / (std of each measured column, or its residual's RMS at the start)
    labels: list[tuple[str, str]]  # (signal, coordinate)
    weights: np.ndarray  # the signal's weight of each column
    spread: np.ndarray  # the standard deviation of each measured column
    channels: list[tuple[str, str] | None] = field(default_factory=list)  # (table, signal) of a declared one
    index: dict[tuple[str, str, str], int] = field(default_factory=dict)  # a free value's place in θ

    def model(self, y: np.ndarray, dy: np.ndarray | None, layer: SignalLayer | None
              ) -> tuple[np.ndarray, np.ndarray | None]:
        """The simulated side of each column and its derivative w.r.t. θ (the layer's values included)."""
        out = y[:, self.columns].copy()
        d = None if dy is None else dy[:, self.columns, :].copy()
        for j, declared in enumerate(self.channels):
            if declared is None:
                continue
            table, signal = declared
            ch = (layer.drive if table == "drive" else layer.sensors)[signal]
            base = y[:, self.columns[j]]
            place = {f: self.index.get((table, signal, f)) for f in signal_layer.FIELDS}
            if table == "drive":  # the command that makes the simulated force: y = g·(command + b)
                out[:, j] = base / ch.gain - ch.bias
                if d is not None:
                    d[:, j, :] /= ch.gain
                    if place["gain"] is not None:
                        d[:, j, place["gain"]] -= base / ch.gain**2
                    if place["bias"] is not None:
                        d[:, j, place["bias"]] -= 1.0
                continue
            out[:, j] = signal_layer.sense(ch, base)
            if d is not None:
                for i in range(d.shape[2]):
                    d[:, j, i] = ch.gain * signal_layer.shift(d[:, j, i], -ch.delay)
                if place["gain"] is not None:
                    d[:, j, place["gain"]] += signal_layer.shift(base, -ch.delay)
                if place["bias"] is not None:
                    d[:, j, place["bias"]] += 1.0
                if place["delay"] is not None:
                    d[:, j, place["delay"]] -= ch.gain * signal_layer.shift_derivative(base, -ch.delay)
        return out, d

    def weighted_at(self, y: np.ndarray, layer: SignalLayer | None = None) -> _Residuals:
        """The same comparison with each column's weight divided by its residual's RMS at ``y`` (the start),
        instead of the measured signal's spread: each signal and coordinate then counts as its own noise
        level allows, as IDIM-LS's weighted least squares weighs coordinates."""
        rms = np.sqrt(np.mean((self.measured - self.model(y, None, layer)[0]) ** 2, axis=0))
        return dataclasses.replace(self, scale=self.weights / np.maximum(rms, 1e-9 * self.spread))

    def of(self, y: np.ndarray, layer: SignalLayer | None = None) -> np.ndarray:
        return ((self.measured - self.model(y, None, layer)[0]) * self.scale).ravel()

    def jacobian(self, y: np.ndarray, dy: np.ndarray, layer: SignalLayer | None = None) -> np.ndarray:
        d = self.model(y, dy, layer)[1]
        return -(d * self.scale[None, :, None]).reshape(-1, dy.shape[2])

    def errors(self, y: np.ndarray, layer: SignalLayer | None = None, start: int = 0) -> dict[str, dict[str, float]]:
        """100·‖measured − simulated‖/‖measured − mean‖ per signal and coordinate over samples ``start:``."""
        out: dict[str, dict[str, float]] = {}
        simulated = self.model(y, None, layer)[0][start:]
        measured = self.measured[start:]
        for j, (signal, c) in enumerate(self.labels):
            centred = measured[:, j] - measured[:, j].mean()
            size = float(np.linalg.norm(centred))
            e = float(np.linalg.norm(measured[:, j] - simulated[:, j]))
            out.setdefault(signal, {})[c] = 100.0 * e / size if size > 0 else float("nan")
        return out


def _residuals(measurements: Measurements, names: tuple[str, ...], signals: str, weights: tuple[float, float],
               ctrl: control.Controller, loop: ClosedLoop | None = None) -> _Residuals:
    n = len(names)
    source = str(measurements.source)
    chosen = {"force": ("force",), "position": ("position",), "both": ("force", "position")}[signals]
    if "force" in chosen and ctrl.kind == "torque":
        raise DataError(source, "controller", "the forces are replayed (kind = \"torque\", or no [controller]): the "
                                              "simulated force is the logged one, so an output error on the force "
                                              "measures nothing; compare positions (--signals position) or declare "
                                              "the machine's [controller]")
    layer = None if loop is None else loop.layer
    columns, measured, spreads, labels, channels, weight_of = [], [], [], [], [], []
    for signal in chosen:
        weight = weights[0] if signal == "force" else weights[1]
        data = measurements.tau if signal == "force" else measurements.q
        for j, c in enumerate(measurements.coordinates):
            if signal == "force" and c not in ctrl.coordinates:
                continue
            name = f"{'tau' if signal == 'force' else 'q'}_{c}"
            declared, values = None, np.asarray(data[:, j], float)
            if layer and name in layer.logged and (name in layer.sensors or ctrl.kind != "torque"):
                declared = ("sensors" if name in layer.sensors else "drive", name)
                values = np.asarray(layer.logged[name], float)
                if declared[0] == "drive":  # the command, at the time it is applied
                    values = signal_layer.shift(values, -layer.drive[name].delay)
            spread = float(np.std(values))
            if spread == 0:
                continue  # a constant signal (a coordinate without actuator: τ = 0) carries no comparison
            columns.append(names.index(c) + (3 * n if signal == "force" else 0))
            measured.append(values)
            spreads.append(spread)
            weight_of.append(weight)
            labels.append((signal, c))
            channels.append(declared)
    if not columns:
        raise DataError(source, "signals", f"no measured {signals} signal varies: nothing to compare")
    index = {} if loop is None else {v.key: len(loop.free) + i for i, v in enumerate(loop.signal_values)}
    return _Residuals(columns, np.column_stack(measured), np.array(weight_of) / np.array(spreads), labels,
                      np.array(weight_of), np.array(spreads), channels, index)


def output_error(
    model: DynamicModel,
    data: str | Path | Measurements,
    *,
    experiment: str | Path | None = None,
    start: Mapping[str, float] | None = None,
    signals: str = "force",
    weights: tuple[float, float] = (1.0, 1.0),
    fix: Sequence[str] = (),
    consistent: bool = False,
    max_iterations: int = MAX_ITERATIONS,
    friction_velocity: float = sim.FRICTION_VELOCITY,
    substeps: int | None = None,
    compiled: bool | None = None,
    initial: tuple[Any, Any] | None = None,
    tolerance: float = SIGMA_TOLERANCE,
    evaluate_if_nothing_free: bool = False,
    held: Mapping[str, float] | None = None,
) -> OutputErrorFit:
    """Fit ``model``'s parameters by the output error of its closed loop on ``data`` (module docstring).

    Parameters
    ----------
    model
        The derived model.
    data
        An experiment file with its ``[controller]`` (or measurements / a data file: torque replay).
    experiment
        Experiment file for a data file.
    start
        Start values by name (the parameters fitted); default: the IDIM-LS solution of ``data``
        (:func:`symbolic.identify.model.identify_model`, with ``fix`` and ``consistent``).
    signals
        ``"force"`` (DIDIM), ``"position"`` or ``"both"``.
    weights
        (force, position) weights of ``"both"``.
    fix
        Parameters kept at their values besides ``fixed = true`` ones.
    max_iterations
        Levenberg–Marquardt iterations before stopping unconverged.
    held
        Parameters not fitted, held at these values instead of the model's (a search that fits one coordinate's
        values at the others' fitted ones).
    evaluate_if_nothing_free
        With nothing to fit (``start`` empty, no free signal value): the loop evaluated once at the values given
        instead of the error (a search's candidate whose values are all held: a delay line's length scanned).
    tolerance
        Converged when the Gauss–Newton step is below this many standard deviations of every estimate
        (:data:`SIGMA_TOLERANCE`; a search that only compares fits may stop sooner).
    friction_velocity, substeps, compiled, initial
        As :func:`symbolic.simulation.simulate`'s: ``initial`` = (q0, q̇0) over the model's coordinates replaces
        the initial state estimated from the first samples (whose velocity, from a parabola through the
        first positions, is what offsets a noise-free fit when the log starts in motion).
    """
    if signals not in SIGNALS:
        raise DataError(str(getattr(data, "source", data)), "signals",
                        f"unknown signals {signals!r} (allowed: {', '.join(SIGNALS)})")
    if not all(isinstance(w, (int, float)) and math.isfinite(w) and w >= 0 for w in weights) or not any(weights):
        raise DataError(str(getattr(data, "source", data)), "weights",
                        f"expected two finite weights ≥ 0, not both 0 (force, position), got {weights!r}")
    if isinstance(max_iterations, bool) or not isinstance(max_iterations, int) or max_iterations < 1:
        raise DataError(str(getattr(data, "source", data)), "max_iterations",
                        f"expected a whole number ≥ 1, got {max_iterations!r}")
    started = time.perf_counter()
    # from given values the data may lack a coordinate the simulation starts at rest and compares nowhere (a
    # second mass's deflection the patched model of a diagnosis adds); IDIM-LS's start needs them all
    coordinates = model.robot.generalized_coordinates if start is None else None
    try:
        measurements = load(data, coordinates, model=model.robot, experiment=experiment)
    except DataError as error:
        measurements = _lacking(model, data, experiment, error)
        coordinates = None
    fixed = fixed_symbols(model, fix)
    start_method = "given values"
    if start is None and coordinates is None:  # no IDIM-LS without every coordinate: the file's values
        start = _seen_parameters(model, measurements, fixed, signals, weights, friction_velocity, substeps, compiled,
                                 initial)
        missing = [c for c in model.robot.generalized_coordinates if c not in measurements.coordinates]
        start_method = (f"model file's values (the data do not measure {', '.join(missing)}: no IDIM-LS); those "
                        "the response sees fitted, the others held")
    if start is None:
        from symbolic.identify.model import identify_model

        idim = identify_model(model, measurements, fix=fix, consistent=consistent)
        # consistent: every parameter entering θ, also those only combinations determine (σ = ∞ at the end)
        start = {n: p.value for n, p in idim.parameters.items() if consistent or math.isfinite(p.sigma)}
        start_method = "IDIM-LS solution" + (" (consistent)" if consistent else "")
    fixed_names = {s.name for s in fixed}
    start = {n: float(v) for n, v in start.items() if n not in fixed_names}
    names = list(start)
    held = {n: float(v) for n, v in (held or {}).items() if n not in start}
    layer = getattr(measurements, "signal_layer", None)
    if not start and not (layer and layer.free) and not evaluate_if_nothing_free:
        raise IdentificationError(f"model {model.name}: no parameter to fit by output error (IDIM-LS determines none "
                                  "directly and alone; try --consistent, or free parameters kept fixed)")
    loop = closed_loop(model, measurements, names, parameters={**held, **start}, friction_velocity=friction_velocity,
                       substeps=substeps, compiled=compiled, initial=initial,
                       signal_values=layer.free if layer else ())
    residuals = _residuals(measurements, loop.names, signals, weights, loop.ctrl, loop)
    bounds = parameter_bounds(model)
    symbols = {s.name: s for s in model.parameter_symbols}
    lower = np.array([bounds.get(symbols[n], (-np.inf, np.inf))[0] for n in names]
                     + [v.bounds[0] for v in loop.signal_values])
    upper = np.array([bounds.get(symbols[n], (-np.inf, np.inf))[1] for n in names]
                     + [v.bounds[1] for v in loop.signal_values])
    theta0 = np.clip(np.array([start[n] for n in names] + [v.free.start for v in loop.signal_values]), lower, upper)
    first, _ = loop.run(theta0, sensitivities=False)
    if not np.isfinite(first).all():
        raise IdentificationError("the closed loop diverges at the start values: an output-error fit needs a start "
                                  "whose simulation stays finite")
    residuals = residuals.weighted_at(first, loop.layer_at(theta0))
    timings = {"setup": time.perf_counter() - started}
    if theta0.size:
        result = levenberg_marquardt(loop, residuals, theta0, lower, upper, max_iterations, timings, tolerance)
    else:  # nothing free: the loop at the values given
        r0 = residuals.of(first, loop.layer_at(theta0))
        result = (theta0, np.zeros((r0.size, 0)), r0, first, first, 0, True, "nothing free: evaluated once",
                  float(r0 @ r0))
    theta, J, r, y0, y, iterations, converged, message, cost0 = result
    scale = np.where(theta0 != 0, np.abs(theta0), 1.0)
    sigma = _sigmas(J * scale, float(r @ r)) * scale if theta.size else np.zeros(0)
    fitted, values = {}, {}
    for j, name in enumerate([*names, *(v.name for v in loop.signal_values)]):
        bound = "min" if theta[j] == lower[j] and np.isfinite(lower[j]) else (
            "max" if theta[j] == upper[j] and np.isfinite(upper[j]) else None)
        relative = 100.0 * sigma[j] / abs(theta[j]) if theta[j] != 0 else float("inf")
        (fitted if j < len(names) else values)[name] = FittedParameter(name, float(theta[j]), float(sigma[j]),
                                                                        relative, float(theta0[j]), bound)
    timings["total"] = time.perf_counter() - started
    return OutputErrorFit(model.name, signals, (float(weights[0]), float(weights[1])), fitted, converged, message,
                          iterations, cost0, float(r @ r), residuals.errors(y0, loop.layer_at(theta0)),
                          residuals.errors(y, loop.layer_at(theta)),
                          {s.name: float(model.parameters[s]) for s in model.parameter_symbols if s in fixed},
                          timings, start_method, values, r.reshape(measurements.samples, -1), held)


SEEN = 1e-3
"""A parameter is fitted from the model file's values (no IDIM-LS start) when its column of the start's
sensitivity matrix, scaled to a relative change of the parameter, keeps at least this fraction of the
strongest column's size after the columns before it in the pivoted order are projected out (column-pivoted QR):
what the response sees only in combination with the others, or barely, is held at the file's value."""


def _lacking(model: DynamicModel, data: str | Path | Measurements, experiment: str | Path | None,
             error: DataError) -> Measurements:
    """The data with the coordinates they measure, where they lack some of ``model``'s; else ``error`` (the
    data are unusable for another reason)."""
    try:
        loaded = load(data, None, model=model.robot, experiment=experiment)
    except DataError:
        raise error from None
    if all(c in loaded.coordinates for c in model.robot.generalized_coordinates):
        raise error
    return loaded


def _seen_parameters(model: DynamicModel, measurements: Measurements, fixed: Any, signals: str,
                     weights: tuple[float, float], friction_velocity: float, substeps: int | None,
                     compiled: bool | None, initial: tuple[Any, Any] | None) -> dict[str, float]:
    """The model file's values of the parameters the response sees (:data:`SEEN`), by the start's sensitivities
    (one simulation with every free parameter's)."""
    values = {s.name: float(model.parameters[s]) for s in model.parameter_symbols if s not in fixed}
    names = list(values)
    if not names:
        return {}
    loop = closed_loop(model, measurements, names, parameters=values, friction_velocity=friction_velocity,
                       substeps=substeps, compiled=compiled, initial=initial)
    theta = np.array([values[n] for n in names])
    y, dy = loop.run(theta, sensitivities=True)
    if not np.isfinite(y).all():
        raise IdentificationError("the closed loop diverges at the model file's values: an output-error fit needs "
                                  "a start whose simulation stays finite")
    residuals = _residuals(measurements, loop.names, signals, weights, loop.ctrl, loop).weighted_at(y)
    J = residuals.jacobian(y, dy) * np.where(theta != 0, np.abs(theta), 1.0)
    _, R, order = scipy.linalg.qr(J, mode="economic", pivoting=True)
    size = np.abs(np.diag(R))
    kept = sorted(order[:len(size)][size > SEEN * max(size.max(initial=0.0), 1e-300)])
    return {names[k]: values[names[k]] for k in kept}


def simulation_errors(model: DynamicModel, measurements: Measurements, fit: OutputErrorFit | None = None, *,
                      signals: str = "both", weights: tuple[float, float] = (1.0, 1.0),
                      friction_velocity: float = sim.FRICTION_VELOCITY, start: int = 0) -> dict[str, dict[str, float]]:
    """Relative errors (%) per signal and coordinate, 100·‖measured − simulated‖/‖measured − mean‖, of
    ``model``'s closed loop on ``measurements`` (other data than the fit's: held out) with ``fit``'s values —
    its parameters, and its signal values on the same free values of ``measurements``' layer — or, without
    ``fit``, with the model's own values and the layer as it is; compared from sample ``start`` on (the held-out
    tail of a record simulated from the record's start: a loop started mid-motion would begin with memory the
    machine's controller did not have — a last reading, an integral — and a transient the machine did not run)."""
    y, loop, theta = simulated(model, measurements, fit, friction_velocity=friction_velocity)
    residuals = _residuals(measurements, loop.names, signals, weights, loop.ctrl, loop)
    return residuals.errors(y, loop.layer_at(theta), start)


def simulated(model: DynamicModel, measurements: Measurements, fit: OutputErrorFit | None = None, *,
              friction_velocity: float = sim.FRICTION_VELOCITY, held: Mapping[str, float] | None = None
              ) -> tuple[np.ndarray, ClosedLoop, np.ndarray]:
    """(y, the loop, θ): the closed loop of :func:`simulation_errors` run once, y = samples × 4n (q, q̇, q̈, τ
    over the model's coordinates); ``held``: parameter values in place of the model's (a fit's own held ones
    are used without it)."""
    layer = getattr(measurements, "signal_layer", None)
    names = list(fit.parameters) if fit is not None else []
    values = {n: p.value for n, p in fit.parameters.items()} if fit is not None else None
    held = {**(fit.held if fit is not None else {}), **(held or {})}
    free = layer.free if layer and fit is not None else ()
    loop = closed_loop(model, measurements, names, parameters={**held, **(values or {})} or None,
                       friction_velocity=friction_velocity, signal_values=free)
    theta = np.array([values[n] for n in names] + [fit.signal_values[v.name].value for v in loop.signal_values]
                     if fit is not None else [], dtype=float)
    y, _ = loop.run(theta, sensitivities=False)
    if not np.isfinite(y).all():
        raise IdentificationError(f"{measurements.source}: the closed loop diverges with the fitted values")
    return y, loop, theta


RANK_TOLERANCE = 1e-9
"""Singular values of the (column-scaled) Jacobian below this fraction of the largest span directions the
data do not determine: parameters only combinations of which the response sees (a multi-joint arm's
inertial parameters)."""


def _sigmas(J: np.ndarray, cost: float) -> np.ndarray:
    """σ² = cost/(m − r)·diag((JᵀJ)⁺) (r the rank of J), σ = ∞ for a parameter with a component along a
    direction J does not see (it is determined only in combination with others)."""
    m, k = J.shape
    norms = np.linalg.norm(J, axis=0)
    seen = norms > 0
    # columns of unit norm: the rank and the unseen directions do not depend on the parameters' units
    _, singular, Vt = np.linalg.svd(J[:, seen] / norms[seen], full_matrices=False)
    kept = singular > RANK_TOLERANCE * max(singular.max(initial=0.0), 1e-300)
    variance = cost / max(m - int(kept.sum()), 1)
    sigma = np.full(k, np.inf)
    sigma[seen] = np.sqrt(variance * np.sum((Vt[kept].T / singular[kept]) ** 2, axis=1)) / norms[seen]
    undetermined = np.flatnonzero(seen)[np.abs(Vt[~kept]).max(axis=0, initial=0.0) > 1e-6]
    sigma[undetermined] = np.inf
    return sigma


def _in_sigmas(step: np.ndarray, J: np.ndarray, cost: float) -> float:
    """max_i |step_i|/σ_i over the parameters the data determine (:func:`_sigmas`): how far a step goes in
    units of the estimates' standard deviations (inf when none is determined)."""
    sigma = _sigmas(J, cost)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(step) / sigma
    ratio = ratio[np.isfinite(sigma)]
    return float(ratio.max()) if ratio.size else math.inf


def levenberg_marquardt(loop: ClosedLoop, residuals: _Residuals, theta0: np.ndarray, lower: np.ndarray,
                        upper: np.ndarray, max_iterations: int, timings: dict[str, float],
                        tolerance: float = SIGMA_TOLERANCE):
    """Marquardt's damped Gauss–Newton on θ/scale with steps projected onto the bounds; converged (among the
    other tests) when the Gauss–Newton step is below ``tolerance`` σ of every estimate. A trial step to θ where
    the loop's sub-steps are unstable (:meth:`ClosedLoop.stable`) is simulated with them chosen again there
    (:meth:`ClosedLoop.restepped`), and the finer loop is kept from there if the step is taken: its cost is
    compared with the current one on the coarser loop — two stable simulations of the model, apart by their
    integration errors — and a step not taken leaves the loop as it was (the response search's wild trial steps
    would otherwise make every later simulation dearer). Where they cannot be chosen again (given, or too many),
    the step is refused as one into a diverging simulation.

    Returns (θ, J, r, y at θ₀, y at θ, iterations, converged, message, cost at θ₀); J and r at θ."""
    scale = np.where(theta0 != 0, np.abs(theta0), 1.0)

    def evaluate(theta: np.ndarray, sensitivities: bool = True, on: ClosedLoop | None = None):
        """(y, r, J·scale) at θ on the loop (or ``on``: a loop stable at θ, :meth:`ClosedLoop.stable_at`), J only
        with ``sensitivities`` (a trial step needs its cost alone: about 1/(p + 1) of the work); ``None`` when the
        simulation diverges."""
        on = on or loop
        begun = time.perf_counter()
        y, dy = on.run(theta, sensitivities)
        timings.setdefault("evaluations", 0.0)
        timings["evaluations"] += time.perf_counter() - begun
        timings["evaluation" if sensitivities else "simulation"] = time.perf_counter() - begun
        if not np.isfinite(y).all() or (dy is not None and not np.isfinite(dy).all()):
            return None
        layer = on.layer_at(theta)
        return y, residuals.of(y, layer), None if dy is None else residuals.jacobian(y, dy, layer) * scale

    start = loop.stable_at(theta0)  # unstable there: sub-steps given, or chosen at a start since clipped onto the bounds
    if start is None and loop.substeps_given:
        raise IdentificationError(f"the {loop.substeps} RK4 sub-step(s) per sample given are outside RK4's "
                                  "stability region at the start values: give more, or let them be chosen")
    loop = start or loop
    first = evaluate(theta0) if start is not None else None
    if first is None:
        raise IdentificationError("the closed loop diverges at the start values: an output-error fit needs a start "
                                  "whose simulation stays finite")
    y0, r, J = first
    theta, y, cost0 = theta0.copy(), y0, float(r @ r)
    cost, damping = cost0, 1e-3
    for iteration in range(1, max_iterations + 1):
        g, H = J.T @ r, J.T @ J
        diagonal = np.maximum(np.diag(H), 1e-12 * max(np.diag(H).max(), 1e-300))
        # the undamped Gauss-Newton step, projected: if even it predicts no decrease, θ is a minimum
        newton = np.clip(theta + np.linalg.lstsq(J, -r, rcond=None)[0] * scale, lower, upper)
        newton_step = (newton - theta) / scale
        within = _in_sigmas(newton_step, J, cost)
        if (cost - float(np.sum((r + J @ newton_step) ** 2)) <= COST_TOLERANCE * cost
                or np.max(np.abs(newton_step)) < STEP_TOLERANCE or within < tolerance):
            return (theta, J / scale, r, y0, y, iteration - 1, True,
                    f"the Gauss-Newton step is {within:.2g} σ at most: a minimum", cost0)
        while True:
            try:
                delta = -np.linalg.solve(H + damping * np.diag(diagonal), g)
            except np.linalg.LinAlgError:
                delta = np.zeros_like(g)
            trial = np.clip(theta + delta * scale, lower, upper)
            step = (trial - theta) / scale
            # where the kept sub-steps are unstable the trial runs on a finer loop, kept only if the step is taken
            on = loop.stable_at(trial)
            evaluated = None if on is None else evaluate(trial, sensitivities=False, on=on)
            new_cost = float(evaluated[1] @ evaluated[1]) if evaluated is not None else math.inf
            if new_cost < cost:
                evaluated = evaluate(trial, on=on)
                if evaluated is not None:
                    if on is not loop:
                        LOG.info("output error: %d RK4 sub-steps a sample (%d when calm) unstable at a step taken: "
                                 "%d (%d) from there", loop.substeps, loop.calm, on.substeps, on.calm)
                    loop = on
                    break
                new_cost = math.inf
            damping *= 4.0
            if within < FLAT_SIGMA:
                return (theta, J / scale, r, y0, y, iteration, True,
                        f"no step lowers the cost and the Gauss-Newton step is {within:.2g} σ at most: a minimum "
                        "within the steps of the simulated cost (a quantised sensor)", cost0)
            if damping > MAX_DAMPING:
                return (theta, J / scale, r, y0, y, iteration, False,
                        f"stopped: the step became too small to lower the cost (λ > {MAX_DAMPING:g})", cost0)
        y, r, J = evaluated
        decrease = (cost - new_cost) / cost if cost > 0 else 0.0
        theta, cost, damping = trial, new_cost, max(damping / 3.0, 1e-9)
        if decrease < COST_TOLERANCE or np.max(np.abs(step)) < STEP_TOLERANCE:
            return theta, J / scale, r, y0, y, iteration, True, "the cost and the step stopped changing", cost0
    return (theta, J / scale, r, y0, y, max_iterations, False,
            f"stopped after {max_iterations} iterations (the maximum) before convergence", cost0)

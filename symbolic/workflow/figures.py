"""PNG figures of a diagnosis (matplotlib, imported only here and only when figures are asked for).

* ``residual_<c>.png``: the residual against time before and after, and against velocity;
* ``effect_<k>_<effect>_<c>.png``: for each found effect, the partial residual against the state the effect
  depends on, with the fitted term drawn over it. An effect that refines a term of the model
  (direction-dependent viscous or Coulomb friction, a Stribeck rise) reports the total coefficients
  (Fv⁺ and Fv⁻, not their difference from the model's Fv): the model's own term, as fitted with the effect,
  is added to both, so that the slopes and levels seen are the printed ones;
* ``spectrum_<c>.png``: Welch spectra of the residual before and after, found peaks marked;
* ``transmission_<c>.png``: for a joint named elastic from two encoders, the torque through its transmission
  against its deflection, with the fitted spring (and dead band).

Every axis carries its unit, from the model's coordinates (rad or m, N·m or N:
:mod:`symbolic.description.units`) and the data's time (s); every mark has a legend entry; the fitted
curve's entry gives the effect's parameters as the report prints them, with their units.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from symbolic.description.units import CoordinateUnits, coordinate_units
from symbolic.plotting import MatplotlibMissing, figure_class, png_bytes
from symbolic.workflow.effects import Effect
from symbolic.workflow.result import Diagnosis
from symbolic.workflow.where import spectrum

__all__ = ["MatplotlibMissing", "draw", "figures"]

AXIS_SIGNAL = {"position": "position", "velocity": "velocity", "acceleration": "acceleration", "time": "time"}


def draw(d: Diagnosis) -> dict[str, bytes]:
    """The figures as PNG bytes by file name (written with the report, all at once)."""
    return {name: png_bytes(figure, dpi=100) for name, figure in figures(d).items()}


def figures(d: Diagnosis) -> dict[str, Any]:
    """The matplotlib figures :func:`draw` renders, by file name (in the order written)."""
    Figure = figure_class()
    est = d.sets["estimation"]
    units = coordinate_units(d.model.robot)
    before = est.tau - d.before.predicted["estimation"]
    after = est.tau - d.after.predicted["estimation"]
    out: dict[str, Any] = {}
    rate = 1.0 / float(np.mean(np.diff(est.t)))
    for j, c in enumerate(est.coordinates):
        u = units[c]
        out[f"residual_{c}.png"] = _residual(Figure(figsize=(9, 6)), est, before[:, j], after[:, j], j, c, u)
        peaks = [p["frequency_hz"] for p in d.where_before["coordinates"][c]["spectrum"]["peaks"]]
        out[f"spectrum_{c}.png"] = _spectrum(Figure(figsize=(9, 4)), before[:, j], after[:, j], rate, peaks, c, u)
    for k, effect in enumerate(effect_curves(d), start=1):
        figure = Figure(figsize=(9, 4.5))
        _effect(figure, d, effect["accepted"], effect["found"], effect["points"], effect["curve"], effect["refined"],
                units[effect["coordinate"]])
        out[f"effect_{k}_{effect['accepted'].effect.name}_{effect['coordinate']}.png"] = figure
    for e in d.elasticity:
        if e.named and e.deflection is not None:
            out[f"transmission_{e.coordinate}.png"] = _transmission(Figure(figsize=(9, 4.5)), e, units[e.coordinate])
    return out


def effect_curves(d: Diagnosis) -> list[dict[str, Any]]:
    """Per accepted effect (in the order found): ``accepted``, ``found``, ``coordinate``, ``axis``, ``x`` (the state
    it is drawn against), ``points`` (final residual + the fitted term, and the model's refined term) and ``curve``
    (the fitted law, or the treated term), ``refined`` (module docstring). The PNG and the HTML report draw these."""
    est = d.sets["estimation"]
    design = d.search.final
    final = est.tau - design.predicted("estimation")
    finals = d.search.final_effects() if d.search.accepted else []
    start = len(d.search.terms.free_names)
    out = []
    for k, (a, found) in enumerate(zip(d.search.accepted, d.found), start=1):
        width = a.columns["estimation"].shape[2]
        values = design.identification.values[start:start + width]
        start += width
        j, c = a.candidate.j, a.candidate.coordinate
        term = (a.columns["estimation"] @ values)[:, j]  # as fitted: the effect's columns treated like τ
        curve = _law(a, est, values)
        reference = finals[k - 1]["reference"]
        refined = bool(a.effect.refines) and reference is not None
        if refined:  # the model's term the effect refines, as fitted with it
            column = a.effect.reference_column(est.states.q, est.states.qd, est.states.qdd, j)
            term = term + reference * est.reduce(column)[:, j]
            law = a.effect.reference_column(est.q, est.qd, est.qdd, j)
            curve = None if curve is None else curve + reference * law[:, j]
        axis = a.effect.axis
        x = np.asarray(est.t) if axis == "time" else {"position": est.q, "velocity": est.qd, "acceleration": est.qdd}[axis][:, j]
        out.append({"accepted": a, "found": found, "coordinate": c, "axis": axis, "x": x, "points": final[:, j] + term,
                    "curve": term if curve is None else curve, "refined": refined})
    return out


def _transmission(fig: Any, e: Any, u: CoordinateUnits) -> Any:
    """The spring's torque as the two encoders measure it (the motor side's force less its other terms) against
    the deflection, with the fitted law: a line through the origin, or with backlash a dead band."""
    delta, measured = e.transmission()
    grid = np.linspace(delta.min(), delta.max(), 400)
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(delta, measured, ".", ms=2, label="measured: τ − J_m·q̈ − Fv·q̇ − Fc·sgn(q̇) − b − d·δ̇")
    band = e.band
    law = f"k = {e.values['stiffness']:.4g} {u.unit('force')}/{u.position}" + \
        (f", dead band {band['width']:.3g} {u.position}" if band else "")
    ax.plot(grid, e.spring(grid), "-", lw=1.2, label=f"fitted: {law}")
    ax.set_xlabel(u.label("position", f"deflection δ = q − q_l of {e.coordinate}"))
    ax.set_ylabel(u.label("force", "torque through the transmission"))
    ax.set_title(f"Joint elasticity on {e.coordinate} (two encoders), estimation data")
    ax.legend(loc="upper left")
    fig.tight_layout()
    return fig


def _law(a: Any, est: Any, values: np.ndarray) -> np.ndarray | None:
    """The fitted term as a function of the state it is drawn against (a smooth curve; the treated columns
    of a nonlinear term, filtered and decimated, scatter about it), or ``None`` when the term is not a
    function of that state alone (a filter, time, several coordinates): then the treated term is drawn."""
    effect = a.effect
    if effect.axis not in ("position", "velocity") or type(effect).columns_at is not Effect.columns_at:
        return None
    j = a.candidate.j
    columns = effect.columns(est.q, est.qd, est.qdd, j, a.candidate.value)[:, :, list(a.candidate.kept)]
    return (columns @ values)[:, j]


def _residual(fig: Any, est: Any, before: np.ndarray, after: np.ndarray, j: int, c: str, u: CoordinateUnits) -> Any:
    top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    top.plot(est.t, before, lw=0.6, label="nominal model (re-identified)")
    top.plot(est.t, after, lw=0.6, label="patched model")
    top.set_xlabel("t (s)")
    top.set_ylabel(u.label("force", f"τ_meas − τ_model on {c}"))
    top.set_title(f"Residual on coordinate {c}" + (f" ({u.kind})" if u.kind else "") + ", estimation data")
    top.legend(loc="upper right")
    bottom.plot(est.qd[:, j], before, ".", ms=1.5, label="nominal model (re-identified)")
    bottom.plot(est.qd[:, j], after, ".", ms=1.5, label="patched model")
    bottom.set_xlabel(u.label("velocity", f"velocity of {c}"))
    bottom.set_ylabel(u.label("force", f"τ_meas − τ_model on {c}"))
    bottom.legend(loc="upper right")
    fig.tight_layout()
    return fig


def _spectrum(fig: Any, before: np.ndarray, after: np.ndarray, rate: float, peaks: list[float], c: str,
              u: CoordinateUnits) -> Any:
    ax = fig.add_subplot(1, 1, 1)
    ax.set_yscale("log")
    drawn = False
    for label, r in (("nominal model (re-identified)", before), ("patched model", after)):
        f, psd = spectrum(r, rate)
        shown = psd > 0  # a residual that is zero (a coordinate without force, fitted exactly) has no log level
        if shown.any():
            ax.plot(f[shown], psd[shown], lw=0.8, label=label)
            drawn = True
        else:
            ax.plot([], [], lw=0.8, label=f"{label}: zero residual (nothing to draw)")
    if not drawn:  # a log axis without a positive value has no range: matplotlib would warn and guess one
        ax.set_yscale("linear")
    for k, peak in enumerate(peaks):
        ax.axvline(peak, color="k", lw=0.5, ls="--",
                   label=("peak of the nominal model's residual: " + ", ".join(f"{p:.3g}" for p in peaks) + " Hz")
                   if k == 0 else None)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"PSD of τ_meas − τ_model on {c}" + (f" (({u.force})²/Hz)" if u.force else ""))
    ax.set_title(f"Residual spectrum on coordinate {c} (Welch), estimation data")
    ax.legend(loc="upper right")
    fig.tight_layout()
    return fig


def _effect(fig: Any, d: Diagnosis, a: Any, found: Any, points: np.ndarray, curve: np.ndarray, refined: bool,
            u: CoordinateUnits) -> Any:
    """The partial residual of accepted effect ``a`` (``points``) against its state, the fitted ``curve`` over
    it; ``refined``: both hold the model's own term that the effect refines."""
    est = d.sets["estimation"]
    j, c = a.candidate.j, a.candidate.coordinate
    axis = a.effect.axis
    x = np.asarray(est.t) if axis == "time" else {"position": est.q, "velocity": est.qd, "acceleration": est.qdd}[axis][:, j]
    order = np.argsort(x, kind="stable")
    ax = fig.add_subplot(1, 1, 1)
    what = f"the model's {a.effect.refines} term and " if refined else ""
    ax.plot(x, points, ".", ms=1.5, color="0.5", label=f"data: final residual + {what}the fitted effect")
    ax.plot(x[order], curve[order], lw=1.2, color="C3", label=f"fitted {found.label()}: {_parameters(a.effect, found, u)}")
    if refined and a.effect.guide:
        _guides(ax, a.effect, x, found, u)
    ax.set_xlabel("t (s)" if axis == "time" else u.label(AXIS_SIGNAL[axis], f"{axis} of {c}"))
    force = f"{a.effect.refines} friction" if refined else "generalized force of the effect"
    ax.set_ylabel(u.label("force", f"{force} on {c}"))
    ax.set_title(f"{found.label()} on {c}" + (f" ({u.kind})" if u.kind else "") + ", estimation data")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


def _guides(ax: Any, effect: Effect, x: np.ndarray, found: Any, u: CoordinateUnits) -> None:
    """The printed direction-dependent coefficients drawn as what they are, across every velocity seen (the
    data follow each on its own side): lines of slope Fv⁺ and Fv⁻ through 0, or the levels Fc⁺ and −Fc⁻."""
    unit = u.compose(effect.units["positive"])
    span = np.array([min(float(x.min()), 0.0), max(float(x.max()), 0.0)])
    for role, colour in (("positive", "C0"), ("negative", "C2")):
        value = found.parameters.get(role)
        if value is None:
            continue
        symbol = effect.symbols.get(role, role)
        where = " (q̇ > 0)" if role == "positive" else " (q̇ < 0)"
        if effect.guide == "slope":
            ax.plot(span, value * span, ls=":", lw=1.2, color=colour,
                    label=f"slope {symbol} = {value:.4g}" + (f" {unit}" if unit else "") + where)
        else:
            level = value if role == "positive" else -value
            ax.plot(span, [level, level], ls=":", lw=1.2, color=colour,
                    label=f"level {'' if role == 'positive' else '−'}{symbol} = {level:.4g}" + (f" {unit}" if unit else "") + where)


def _parameters(effect: Effect, found: Any, u: CoordinateUnits) -> str:
    """The effect's parameters as the report prints them (final fit), with their units."""
    parts = []
    for role, value in found.parameters.items():
        if value is None:
            continue
        unit = u.compose(effect.units.get(role, ""))
        parts.append(f"{effect.symbols.get(role, role)} = {value:.4g}" + (f" {unit}" if unit else ""))
    return ", ".join(parts)

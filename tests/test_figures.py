"""Figures readable alone: units from the model on every axis, coordinate names, a legend entry for every mark,
and the direction-dependent viscous effect drawn with the slopes the report prints.

The matplotlib Figure objects are inspected (axis labels, legend entries, the data of the drawn lines), not
pixels. The models carry their kind in their frames: a cart (prismatic x: m, N) carrying a pendulum
(revolute th: rad, N·m), so that each figure must tell the two apart.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

to_rgba = pytest.importorskip("matplotlib.colors", reason="the figures need matplotlib: pip install -e '.[plot]'").to_rgba

import models
import symbolic
import workflow_cases as cases
from symbolic.data import Measurements
from symbolic.description.units import UNKNOWN, CoordinateUnits, coordinate_kind, coordinate_units
from symbolic.identify import figures as identify_figures
from symbolic.identify.model import identify_model
from symbolic.simulation import figures as simulation_figures
from symbolic.simulation import simulate
from symbolic.workflow import diagnose
from symbolic.workflow import figures as workflow_figures
from conftest import derived

EXPECTED = {"x": ("prismatic", "m", "m/s", "m/s²", "N"), "th": ("revolute", "rad", "rad/s", "rad/s²", "N·m")}


@pytest.fixture(scope="module")
def cart() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.loads(models.cart_pendulum(), "cart_pendulum"))


@pytest.fixture(scope="module")
def log(cart: symbolic.DynamicModel) -> Measurements:
    """Both coordinates moving (a few sines), the force of the model's inverse dynamics."""
    num = symbolic.numeric_model(cart)
    t = np.arange(0, 8, 2e-3)
    w = 2 * np.pi * np.array([0.3, 0.7, 1.1])
    q = np.column_stack([0.2 * np.sin(np.outer(t, w)) @ [1, 0.5, 0.3], 0.8 * np.cos(np.outer(t, w)) @ [0.6, 0.4, 0.3]])
    qd = np.column_stack([0.2 * np.cos(np.outer(t, w)) @ (w * [1, 0.5, 0.3]),
                          -0.8 * np.sin(np.outer(t, w)) @ (w * [0.6, 0.4, 0.3])])
    qdd = np.column_stack([-0.2 * np.sin(np.outer(t, w)) @ (w**2 * [1, 0.5, 0.3]),
                           -0.8 * np.cos(np.outer(t, w)) @ (w**2 * [0.6, 0.4, 0.3])])
    tau = np.array([num.inverse_dynamics(a, b, c) for a, b, c in zip(q, qd, qdd)])
    return Measurements.from_arrays(t, ["x", "th"], q, tau)


def style(artist) -> tuple:
    """What tells two marks apart to a reader: kind, colour, line style, marker."""
    if hasattr(artist, "get_linestyle") and hasattr(artist, "get_marker"):
        marker = artist.get_marker() if artist.get_marker() not in (None, "None", "") else None
        return ("line", to_rgba(artist.get_color()), artist.get_linestyle() if marker is None else None, marker)
    return ("patch", to_rgba(artist.get_facecolor()))


def unexplained(ax) -> list:
    """The marks of ``ax`` (lines, spans) with no legend entry of their look."""
    legend = ax.get_legend()
    assert legend is not None, ax.get_ylabel()
    keys = {style(h) for h in legend.legend_handles}
    return [m for m in [*ax.lines, *ax.patches] if style(m) not in keys]


def legend_texts(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


# -- units from the model --------------------------------------------------------------------------------------


def test_coordinate_kinds_from_the_frames(cart: symbolic.DynamicModel) -> None:
    units = coordinate_units(cart.robot)
    for c, (kind, position, velocity, acceleration, force) in EXPECTED.items():
        u = units[c]
        assert (u.kind, u.position, u.velocity, u.acceleration, u.force) == (kind, position, velocity, acceleration, force)
    assert units["th"].compose("{force}·s/{position}") == "N·m·s/rad"
    assert units["x"].compose("{force}·s/{position}") == "N·s/m"
    assert units["x"].compose("{force}/{position}") == "N/m" and units["x"].compose("kg") == "kg"
    assert UNKNOWN.compose("{force}") == "" and UNKNOWN.label("force", "τ") == "τ"


def test_modal_and_constrained_coordinates() -> None:
    """A beam's modal coordinates (m^(3/2), work-conjugate force N·m^(−1/2)); the five-bar's closed loop: its
    coordinates turn joints directly or through the constraint, all revolute."""
    link = derived("single_flexible_link").robot
    modal = [c for c in link.generalized_coordinates if c not in link.coordinates]
    assert modal and all(coordinate_kind(link, c) == "modal" for c in modal)
    assert coordinate_units(link)[modal[0]].position == "m^(3/2)"
    assert coordinate_units(link)[modal[0]].force == "N·m^(−1/2)"
    fivebar = derived("fivebar").robot
    assert {coordinate_kind(fivebar, c) for c in fivebar.coordinates} == {"revolute"}
    assert coordinate_kind(derived("emps").robot, "q") == "prismatic"
    with pytest.raises(KeyError):
        coordinate_kind(fivebar, "nope")


# -- simulation ------------------------------------------------------------------------------------------------


def test_simulation_figures_name_coordinates_and_units(cart: symbolic.DynamicModel, log: Measurements,
                                                       tmp_path: Path) -> None:
    comparison = simulate(cart, log).compare()
    assert comparison.kept.start > 0  # the filter border is left out: its grey bands must be explained
    units = coordinate_units(cart.robot)
    drawn = simulation_figures.figures(comparison, "cart", units)
    assert list(drawn) == ["simulation_x.png", "simulation_error_x.png", "simulation_th.png", "simulation_error_th.png"]
    for name, figure in drawn.items():
        c = "th" if name.endswith("_th.png") else "x"
        kind, position, velocity, acceleration, force = EXPECTED[c]
        axes = figure.axes
        error = "error" in name
        words = [f"{s} error of {c}" if error else f"{s} of {c}" for s in ("position", "velocity", "acceleration", "force")]
        assert [ax.get_ylabel() for ax in axes] == [f"{w} ({u})" for w, u in zip(words, (position, velocity, acceleration, force))]
        assert axes[-1].get_xlabel() == "t (s)"
        for ax in axes:
            assert not unexplained(ax), (name, ax.get_ylabel(), legend_texts(ax))
            assert "not compared (filter border)" in legend_texts(ax)
        if error:
            assert any(t.startswith("worst 1 s window (RMS ") and t.endswith(f" {force})") for t in legend_texts(axes[-1]))
    written = simulation_figures.draw(comparison, tmp_path, "cart", units)
    assert [p.name for p in written] == list(drawn)


def test_simulation_figures_without_units_name_the_quantity(cart: symbolic.DynamicModel, log: Measurements) -> None:
    drawn = simulation_figures.figures(simulate(cart, log).compare())
    assert drawn["simulation_th.png"].axes[0].get_ylabel() == "position of th"


# -- identification ---------------------------------------------------------------------------------------------


def test_identification_figures_have_force_units(cart: symbolic.DynamicModel, log: Measurements) -> None:
    result = identify_model(cart, log)
    drawn = identify_figures.figures(result.identification, result.observation, result.validation,
                                     coordinate_units(cart.robot))
    assert list(drawn) == ["identification_x.png", "identification_th.png"]
    for c in ("x", "th"):
        top, bottom = drawn[f"identification_{c}.png"].axes
        force = EXPECTED[c][4]
        assert top.get_ylabel() == f"generalized force τ_{c} ({force})"
        assert bottom.get_ylabel() == f"residual ({force})" and bottom.get_xlabel() == "t (s)"
        assert legend_texts(top)[0] == f"measured τ_{c}" and legend_texts(bottom) == ["measured − predicted"]
        for ax in (top, bottom):
            assert not unexplained(ax)


# -- diagnosis -----------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def asymmetric(tmp_path_factory: pytest.TempPathFactory):
    """The rotary axis whose viscous friction is 0.2 N·m·s/rad forwards and 0.4 backwards, diagnosed with a
    symmetric model."""
    truth = models.axis(parameters="Fvp = 0.2\nFvn = 0.4\nFc = 0.4\n",
                        friction='viscous = { positive = "Fvp", negative = "Fvn" }\ncoulomb = "Fc"')
    folder = tmp_path_factory.mktemp("asymmetric")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return diagnose(cases.model_file(folder, models.axis()), cases.measurements(truth, 2, 0.01), figures=False)


def test_asymmetric_viscous_figure_shows_the_printed_slopes(asymmetric) -> None:
    """The fitted curve's slope on each side is the printed Fv⁺ and Fv⁻ (the model's own viscous term added
    back: the effect's column alone has slopes ±(Fv⁺ − Fv⁻)/2), and the printed values are the truth's."""
    (found,) = asymmetric.found
    assert found.effect == "asymmetric_viscous"
    drawn = workflow_figures.figures(asymmetric)
    assert list(drawn) == ["residual_q.png", "spectrum_q.png", "effect_1_asymmetric_viscous_q.png"]
    (ax,) = drawn["effect_1_asymmetric_viscous_q.png"].axes
    assert ax.get_xlabel() == "velocity of q (rad/s)" and ax.get_ylabel() == "viscous friction on q (N·m)"
    texts = legend_texts(ax)
    positive, negative = found.parameters["positive"], found.parameters["negative"]
    assert f"slope Fv⁺ = {positive:.4g} N·m·s/rad (q̇ > 0)" in texts
    assert f"slope Fv⁻ = {negative:.4g} N·m·s/rad (q̇ < 0)" in texts
    assert any(t.startswith("fitted asymmetric_viscous: Fv⁺ = ") for t in texts)
    assert not unexplained(ax)
    fitted = next(line for line in ax.lines if line.get_label().startswith("fitted"))
    v, f = fitted.get_xdata(), fitted.get_ydata()
    away = 0.2 * max(v.max(), -v.min())  # clear of the smoothing of |q̇| at the reversal
    right, left = v > away, v < -away
    assert np.polyfit(v[right], f[right], 1)[0] == pytest.approx(positive, rel=0.02)
    assert np.polyfit(v[left], f[left], 1)[0] == pytest.approx(negative, rel=0.02)
    assert positive == pytest.approx(0.2, rel=0.05) and negative == pytest.approx(0.4, rel=0.05)
    data = next(line for line in ax.lines if line.get_label().startswith("data"))
    x, y = data.get_xdata(), data.get_ydata()
    assert np.polyfit(x[x > away], y[x > away], 1)[0] == pytest.approx(positive, rel=0.05)


def test_diagnosis_residual_and_spectrum_figures_explain_every_mark(asymmetric) -> None:
    drawn = workflow_figures.figures(asymmetric)
    top, bottom = drawn["residual_q.png"].axes
    assert top.get_xlabel() == "t (s)" and top.get_ylabel() == "τ_meas − τ_model on q (N·m)"
    assert bottom.get_xlabel() == "velocity of q (rad/s)"
    (spectrum,) = drawn["spectrum_q.png"].axes
    assert spectrum.get_xlabel() == "frequency (Hz)" and spectrum.get_ylabel().endswith("((N·m)²/Hz)")
    peaks = asymmetric.where_before["coordinates"]["q"]["spectrum"]["peaks"]
    assert peaks  # the dashed lines are there, and explained
    assert any(t.startswith("peak of the nominal model's residual: ") for t in legend_texts(spectrum))
    for ax in (top, bottom, spectrum):
        assert not unexplained(ax), legend_texts(ax)
    assert sorted(workflow_figures.draw(asymmetric)) == sorted(drawn)


def test_role_units_are_the_coordinates_units() -> None:
    """The units an effect declares for its roles (every role has one: tests/test_effects.py) are written in the
    coordinate's units: an inertia on a revolute coordinate is N·m·s²/rad."""
    from symbolic.workflow import EFFECTS

    revolute = CoordinateUnits.of_kind("revolute")
    assert revolute.compose(EFFECTS["inertia"].units["inertia"]) == "N·m·s²/rad"

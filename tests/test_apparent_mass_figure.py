"""``symbolic generate --figures``: the apparent mass over the workspace as a PNG linked from the report."""

from __future__ import annotations

import importlib.util
import warnings

import numpy as np
import pytest

import symbolic
from symbolic.cli import main
from symbolic.export import render
from symbolic.export.apparent_mass_figure import workspace_points
from symbolic.numeric import numeric_model
from symbolic.numeric.operational import workspace_samples

matplotlib = pytest.importorskip("matplotlib")


def _model(name: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return symbolic.derive(symbolic.robots.load(name))


def test_positions_move_as_the_jacobian_says() -> None:
    """The plotted end-effector positions: their central difference in each coordinate equals the
    end-effector Jacobian (3.57), derived separately, to 1e-7 (h = 1e-5 rad)."""
    model = _model("puma560")
    points, extremes = workspace_points(model, 5)
    assert points.shape == (5, 3) and extremes.shape == (5, 2)
    ok = np.isfinite(extremes).all(axis=1)
    assert (extremes[ok, 0] <= extremes[ok, 1]).all() and (extremes[ok] > 0).all()
    q = workspace_samples(model, 5)[3]
    jacobian = numeric_model(model).jacobian(q, None)
    h = 1e-5
    for j in range(model.n):
        step = np.zeros(model.n)
        step[j] = h
        ahead = _position(model, q + step)
        behind = _position(model, q - step)
        np.testing.assert_allclose((ahead - behind) / (2 * h), jacobian[:, j], atol=1e-7)


def _position(model, q) -> np.ndarray:
    return numeric_model(model).end_effector_position(q)


def test_report_links_a_deterministic_png() -> None:
    model = _model("omni")
    first = render(model, ["report"], figures=True)
    second = render(model, ["report"], figures=True)
    png = first["omni_apparent_mass.png"]
    assert png.startswith(b"\x89PNG\r\n\x1a\n") and png == second["omni_apparent_mass.png"]
    assert "![apparent mass over the workspace](omni_apparent_mass.png)" in first["omni.md"].decode()
    plain = render(model, ["report"])
    assert set(plain) == {"omni.md"} and "apparent_mass.png" not in plain["omni.md"].decode()


def test_no_end_effector_no_figure() -> None:
    assert set(render(_model("emps"), ["report"], figures=True)) == {"emps.md"}


def test_cli_without_matplotlib_refuses_before_writing(tmp_path, monkeypatch, capsys) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "matplotlib" else real(name, *a))
    assert main(["-q", "generate", "omni", "--out", str(tmp_path / "out"), "--figures"]) == 2
    assert "matplotlib" in capsys.readouterr().err and not (tmp_path / "out").exists()


# -- a planar arm: Λ exists nowhere (J is 3×2), the figure shows m_x and m_y (issue 39) ---------------------

def _loaded(text: str, name: str):
    return symbolic.derive(symbolic.loads(text, f"<{name}>"))


def test_planar_arm_figure_plots_the_axes_it_moves_along() -> None:
    """A two-link arm in the x–y plane: λ of Λ is NaN at every configuration; the panels are m_x and m_y
    (no blank panel: each has finite, positive masses), equal to apparent_mass along x and y, on the x–y plane."""
    from models import arm

    from symbolic.export.apparent_mass_figure import panels
    from symbolic.numeric.operational import apparent_mass

    model = _loaded(arm(end_effector=True), "arm")
    _, extremes = workspace_points(model, 20)
    assert not np.isfinite(extremes).any()  # the cause: no Λ anywhere
    shown, title = panels(model, 20)
    assert [p.title.split(":")[0] for p in shown] == ["m_x", "m_y"] and "rank below 3" in title
    q = workspace_samples(model, 20)
    for k, panel in enumerate(shown):
        assert (panel.xlabel, panel.ylabel) == ("x [m]", "y [m]")
        finite = np.isfinite(panel.values)
        assert finite.sum() >= 18 and (panel.values[finite] > 0).all(), panel.values
        assert np.isfinite(panel.x).all() and np.isfinite(panel.y).all()
        np.testing.assert_allclose(panel.values[5], apparent_mass(model, q[5], np.eye(3)[k]), rtol=1e-12)


def test_rank_three_figure_is_the_eigenvalues() -> None:
    from symbolic.export.apparent_mass_figure import panels

    shown, _ = panels(_model("omni"), 20)
    assert len(shown) == 4 and shown[0].title.startswith("λ_min") and all(np.isfinite(p.values).any() for p in shown)


def test_cli_planar_arm_writes_and_links_the_figure(tmp_path) -> None:
    from models import arm

    path = tmp_path / "arm.toml"
    path.write_text(arm(end_effector=True), encoding="utf-8")
    assert main(["-q", "generate", str(path), "--out", str(tmp_path / "out"), "--targets", "report", "--figures"]) == 0
    assert (tmp_path / "out" / "arm_apparent_mass.png").read_bytes().startswith(b"\x89PNG")
    report = (tmp_path / "out" / "arm.md").read_text(encoding="utf-8")
    assert "(arm_apparent_mass.png)" in report and "the apparent mass along each axis the point moves along" in report


STILL = """name = "still"
coordinates = ["q"]
gravity = ["0", "-9.81", "0"]
[[frame]]
name = "1"
parent = "base"
dh = { theta = "q", d = "0", a = "0", alpha = "0" }
[[body]]
name = "disc"
frame = "1"
mass = "1"
inertia = { zz = "0.01" }
[end_effector]
frame = "1"
point = ["0", "0", "0"]
"""


def test_end_effector_on_the_axis_no_figure_and_why() -> None:
    """The end effector on the joint's axis never moves (J = 0): no figure, no link, a warning saying why."""
    with pytest.warns(symbolic.ModelWarning, match="moves along no axis"):
        files = render(_loaded(STILL, "still"), ["report"], figures=True)
    assert set(files) == {"still.md"} and "apparent_mass.png" not in files["still.md"].decode()

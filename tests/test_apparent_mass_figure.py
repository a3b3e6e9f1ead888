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

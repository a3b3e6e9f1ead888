"""``symbolic identify`` says which model parameters the data do not determine alone, and what to do (issue 39).

On a planar two-link arm m1, m2, c1, c2, I1 and I2 enter only combinations of base parameters (ZZR1 =
ZZ1 − 0.16·M1 − 0.16·M2, ...): identification gives the base parameters and the friction coefficients, and
left the inertial parameters out without a word. Now one line names them and the remedies (``--consistent``,
``--fix``); the JSON lists them under ``undetermined``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from models import arm

import symbolic
from symbolic.cli import main
from symbolic.data import Measurements
from symbolic.numeric import numeric_model

INERTIAL = ["m1", "m2", "c1", "c2", "I1", "I2"]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The arm's model file and a log of its inverse dynamics along two sines per joint (noise-free)."""
    folder = tmp_path_factory.mktemp("arm")
    model_path = folder / "arm.toml"
    model_path.write_text(arm(), encoding="utf-8")
    model = symbolic.derive(symbolic.load(model_path))
    t = np.arange(0.0, 10.0, 1.0 / 200.0)
    w = 2 * np.pi * np.array([[0.1, 0.23], [0.17, 0.31]])  # per joint, two frequencies
    q = np.sin(t[:, None] * w[:, 0]) + 0.5 * np.sin(t[:, None] * w[:, 1])
    qd = w[:, 0] * np.cos(t[:, None] * w[:, 0]) + 0.5 * w[:, 1] * np.cos(t[:, None] * w[:, 1])
    qdd = -w[:, 0] ** 2 * np.sin(t[:, None] * w[:, 0]) - 0.5 * w[:, 1] ** 2 * np.sin(t[:, None] * w[:, 1])
    num = numeric_model(model)
    tau = np.array([num.inverse_dynamics(q[k], qd[k], qdd[k]) for k in range(len(t))])
    data = folder / "log.csv"
    symbolic.data.write(Measurements.from_arrays(t, model.robot.generalized_coordinates, q, tau, qd=qd, qdd=qdd), data)
    return model_path, data


def test_cli_names_what_it_leaves_out_and_the_remedy(files, capsys) -> None:
    model, data = files
    assert main(["-q", "identify", str(model), str(data)]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("not identified:")]
    assert len(lines) == 1, lines
    assert lines[0].startswith("not identified: " + ", ".join(INERTIAL) + " enter only combinations")
    assert "--consistent" in lines[0] and "--fix" in lines[0]


def test_json_lists_them(files, capsys) -> None:
    model, data = files
    assert main(["-q", "identify", str(model), str(data), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["undetermined"] == INERTIAL and not set(INERTIAL) & set(out["parameters"])


def test_fixing_the_masses_determines_the_inertias(files, capsys) -> None:
    """With the masses and centres of mass fixed, I1 and I2 are base parameters alone: nothing is left out."""
    model, data = files
    assert main(["-q", "identify", str(model), str(data), "--fix", "m1,m2,c1,c2"]) == 0
    text = capsys.readouterr().out
    assert "not identified" not in text and "not determined alone" not in text
    assert main(["-q", "identify", str(model), str(data), "--fix", "m1,m2,c1,c2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["undetermined"] == [] and out["parameters"]["I1"]["value"] == pytest.approx(0.04, rel=1e-6)


def test_consistent_gives_them_and_says_they_are_not_determined_alone(files, capsys) -> None:
    model, data = files
    assert main(["-q", "identify", str(model), str(data), "--consistent"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("not determined alone")]
    assert len(lines) == 1 and ", ".join(INERTIAL) in lines[0] and "--fix" in lines[0], lines

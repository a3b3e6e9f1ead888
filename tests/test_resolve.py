"""One reading of "a model name or path" (:func:`symbolic.robots.resolve`, docs/contracts.md).

A name is read alike on the command line, in an experiment file (relative to its folder) and by
``diagnose``: a model file first (a ``.toml``/``.urdf`` name or an existing file), else a built-in robot,
else an error naming the built-in robots with the nearest; a folder named like a built-in is not a model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import symbolic
from symbolic import robots
from symbolic.cli import resolve as cli_resolve
from symbolic.data import DataError
from symbolic.errors import ModelError
from symbolic.workflow.diagnosis import _derived


def experiment(folder: Path, model: str) -> Path:
    """An experiment file in ``folder`` with ``model`` and a small canonical CSV beside it."""
    t = np.arange(0.0, 0.1, 0.01)
    (folder / "log.csv").write_text("t,q_q,tau_q\n" + "".join(f"{x:.2f},{x:.2f},1.0\n" for x in t), encoding="utf-8")
    path = folder / "run.experiment.toml"
    path.write_text(f'data = "log.csv"\nmodel = "{model}"\n', encoding="utf-8")
    return path


def test_a_name_in_an_experiment_and_on_the_command_line_resolve_alike(tmp_path: Path, monkeypatch) -> None:
    """A file named ``emps`` beside the experiment (and in the current folder) is that file in both; the
    experiment read the built-in robot before, whatever its folder held."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "emps").write_text(robots.path("emps").read_text().replace('name = "emps"', 'name = "mine"'), encoding="utf-8")
    assert cli_resolve("emps").name == "mine"
    assert symbolic.data.load(experiment(tmp_path, "emps")).model == str(tmp_path / "emps")
    assert _derived("emps").name == "mine"
    elsewhere = tmp_path / "other"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    (elsewhere / "emps").mkdir()  # a folder (an output folder, say) is not a model file
    assert cli_resolve("emps").name == "emps" and _derived("emps").name == "emps"
    assert symbolic.data.load(experiment(elsewhere, "emps")).model == "emps"


def test_a_misspelt_name_is_told_the_nearest_everywhere(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ModelError, match="no such model file or built-in robot .*did you mean 'emps'"):
        cli_resolve("emsp")
    with pytest.raises(ModelError, match="did you mean 'emps'"):
        _derived("emsp")
    # read when the experiment is read, not when (if ever) the model is needed
    with pytest.raises(DataError, match=r"run.experiment.toml: model: no model file .* and no built-in robot 'emsp' "
                                        r"\(built-in: .*\); did you mean 'emps'\?"):
        symbolic.data.load(experiment(tmp_path, "emsp"))


def test_precedence_and_chains() -> None:
    assert robots.locate("panda") == robots.path("panda")
    assert robots.locate("panda.toml") == Path("panda.toml")  # a model-file name is a file, found or not
    with pytest.raises(ModelError, match="panda.toml: file: cannot read model file"):
        robots.resolve("panda.toml")
    with pytest.raises(ModelError, match="emps: --root/--tip: choose a chain only in a URDF file"):
        robots.resolve("emps", root="base")

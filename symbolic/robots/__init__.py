"""Built-in robots, shipped as model files next to this module.

``symbolic.robots.names()`` lists them; ``symbolic.robots.load(name)`` returns the validated
:class:`~symbolic.description.Robot`; ``symbolic.robots.path(name)`` the model file (to copy and edit).
Example experiment files (``NAME.experiment.toml``, read by :func:`symbolic.data.load`) sit beside
the models: ``examples()`` lists them and ``example_path(name)`` gives one.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the listing (names, paths) does not import SymPy: the command line's first line comes sooner
    from symbolic.description.robot import Robot


EXPERIMENT_SUFFIX = ".experiment.toml"

__all__ = ["EXPERIMENT_SUFFIX", "example_path", "examples", "load", "names", "path"]


def names() -> list[str]:
    """Names of the built-in robots, sorted (experiment files are not robots)."""
    return sorted(
        p.name[: -len(".toml")]
        for p in resources.files(__name__).iterdir()
        if p.name.endswith(".toml") and not p.name.endswith(EXPERIMENT_SUFFIX)
    )


def examples() -> list[str]:
    """Names of the example experiment files (``NAME.experiment.toml``), sorted."""
    return sorted(
        p.name[: -len(EXPERIMENT_SUFFIX)] for p in resources.files(__name__).iterdir() if p.name.endswith(EXPERIMENT_SUFFIX)
    )


def example_path(name: str) -> Path:
    """The example experiment file ``name`` (e.g. ``"emps_estimation"``)."""
    if name not in examples():
        raise KeyError(f"no example experiment {name!r} (available: {', '.join(examples())})")
    return Path(str(resources.files(__name__).joinpath(f"{name}{EXPERIMENT_SUFFIX}")))


def path(name: str) -> Path:
    """The model file of built-in robot ``name``."""
    if name not in names():
        raise KeyError(f"no built-in robot {name!r} (available: {', '.join(names())})")
    return Path(str(resources.files(__name__).joinpath(f"{name}.toml")))


def load(name: str) -> Robot:
    """Load built-in robot ``name``."""
    from symbolic.description.modelfile import load as load_file

    return load_file(path(name))

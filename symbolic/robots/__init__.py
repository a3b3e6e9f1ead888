"""Built-in robots, shipped as model files next to this module, and the one reading of "a model name or path".

``symbolic.robots.names()`` lists them; ``symbolic.robots.load(name)`` returns the validated
:class:`~symbolic.description.Robot`; ``symbolic.robots.path(name)`` the model file (to copy and edit).
Example experiment files (``NAME.experiment.toml``, read by :func:`symbolic.data.load`) sit beside
the models: ``examples()`` lists them and ``example_path(name)`` gives one.

Every place that takes a model as a name or a path — the command line's MODEL, an experiment file's and a
campaign's ``model``, :func:`symbolic.workflow.diagnose` — reads it by :func:`resolve` (:func:`locate` for
the file), with one precedence:

1. a :class:`~pathlib.Path`, a name ending in ``.toml`` or ``.urdf``, or an existing file is a model file (a
   folder named like a built-in robot, an output folder ``emps/``, is not);
2. else the name of a built-in robot;
3. else a :class:`~symbolic.errors.ModelError` listing the built-in robots, with the nearest as "did you mean".

A path is relative to the current directory; a file that names a model (an experiment, a campaign) gives
``folder``, its own directory.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the listing (names, paths) does not import SymPy: the command line's first line comes sooner
    from symbolic.description.robot import Robot


EXPERIMENT_SUFFIX = ".experiment.toml"
MODEL_SUFFIXES = (".toml", ".urdf")
"""The suffixes of model files: a name ending in one is a file, never a built-in robot's name."""

__all__ = ["EXPERIMENT_SUFFIX", "MODEL_SUFFIXES", "example_path", "examples", "load", "locate", "names", "path", "resolve"]


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


def locate(name_or_path: str | Path, folder: str | Path | None = None) -> Path:
    """The model file ``name_or_path`` stands for, by the precedence of the module docstring: the file
    (relative to ``folder`` when given and the path is relative), else the built-in robot's file.

    Raises
    ------
    ModelError
        When it is neither a model file nor a built-in robot's name: the built-in robots, and the nearest
        as "did you mean".
    """
    from symbolic.errors import ModelError, suggestion

    given = Path(name_or_path)
    candidate = given if folder is None or given.is_absolute() else Path(folder) / given
    if isinstance(name_or_path, Path) or given.suffix.lower() in MODEL_SUFFIXES or candidate.is_file():
        return candidate
    name, built_in = str(name_or_path), names()
    if name in built_in:
        return path(name)
    if candidate.exists():  # not a file and no built-in of this name (a folder): the model file's reader says why
        return candidate
    what = ("no such model file or built-in robot" if folder is None
            else f"no model file {str(candidate)!r} and no built-in robot {name!r}")
    raise ModelError(name, "file", f"{what} (built-in: {', '.join(built_in)}){suggestion(name.lower(), built_in)}")


def resolve(name_or_path: str | Path, root: str | None = None, tip: str | None = None,
            folder: str | Path | None = None) -> Robot:
    """The validated robot ``name_or_path`` stands for (:func:`locate`: a model file, else a built-in robot).

    ``root``/``tip`` choose a chain of a URDF model (:func:`symbolic.description.urdf.load`); a TOML model or
    a built-in robot refuses them.

    Raises
    ------
    ModelError
        For a name that is neither (:func:`locate`), a chain asked of a TOML model, or an invalid model file.
    """
    from symbolic.description.modelfile import load as load_file
    from symbolic.errors import ModelError

    found = locate(name_or_path, folder)
    if found.suffix.lower() != ".urdf" and (root is not None or tip is not None):
        raise ModelError(str(name_or_path), "--root/--tip", "choose a chain only in a URDF file (a .urdf model)")
    return load_file(found, root=root, tip=tip)

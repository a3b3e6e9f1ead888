"""Built-in robots, shipped as model files next to this module.

``symbolic.robots.names()`` lists them; ``symbolic.robots.load(name)`` returns the validated
:class:`~symbolic.spec.Robot`; ``symbolic.robots.path(name)`` the model file (to copy and edit).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from symbolic.spec.robot import Robot


def names() -> list[str]:
    """Names of the built-in robots, sorted."""
    return sorted(p.name[: -len(".toml")] for p in resources.files(__name__).iterdir() if p.name.endswith(".toml"))


def path(name: str) -> Path:
    """The model file of built-in robot ``name``."""
    if name not in names():
        raise KeyError(f"no built-in robot {name!r} (available: {', '.join(names())})")
    return Path(str(resources.files(__name__).joinpath(f"{name}.toml")))


def load(name: str) -> Robot:
    """Load built-in robot ``name``."""
    from symbolic.spec.modelfile import load as load_file

    return load_file(path(name))

"""Errors raised for bad model input.

Every message names where the problem is (file and key), what is wrong and, where it helps,
what is allowed, so that a user can fix a model file without reading our source.
"""

from __future__ import annotations


class ModelError(ValueError):
    """A model description (TOML file or Python spec) is invalid.

    Parameters
    ----------
    source
        The model file's path, or ``"<python>"`` for a spec built in Python.
    key
        Where in the model the problem is, e.g. ``"[[frame]] 'c3' dh.theta"``.
    problem
        What is wrong and what is allowed.
    """

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source = source
        self.key = key
        self.problem = problem
        super().__init__(f"{source}: {key}: {problem}")


class ModelWarning(UserWarning):
    """A model is usable but physically suspicious (e.g. an inertia violating the triangle inequality)."""

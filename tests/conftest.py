"""Shared fixtures: built-in robots derived once per test session; a cache folder of the session's own."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import warnings
from functools import lru_cache

import pytest

# The suite (and the commands it runs in subprocesses, which inherit the environment) keeps derivations
# and compiled libraries in a folder of its own, removed at the end: never in the user's ~/.cache/symbolic.
# Set before anything is derived; each pytest-xdist worker has its own.
CACHE_FOLDER = tempfile.mkdtemp(prefix="symbolic-tests-cache-")
os.environ["SYMBOLIC_CACHE_DIR"] = CACHE_FOLDER
os.environ.pop("SYMBOLIC_NO_CACHE", None)
atexit.register(shutil.rmtree, CACHE_FOLDER, ignore_errors=True)

import symbolic  # noqa: E402  (after the cache folder is set)


@lru_cache(maxsize=None)
def derived(name: str) -> symbolic.DynamicModel:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return symbolic.derive(symbolic.robots.load(name))


@pytest.fixture(scope="session")
def fivebar() -> symbolic.DynamicModel:
    return derived("fivebar")


@pytest.fixture(scope="session")
def puma() -> symbolic.DynamicModel:
    return derived("puma560")


@pytest.fixture(scope="session")
def panda() -> symbolic.DynamicModel:
    return derived("panda")


def pytest_addoption(parser) -> None:
    parser.addoption("--update-golden", action="store_true", help="rewrite tests/golden/ from the current templates")


@pytest.fixture
def update_golden(request) -> bool:
    return request.config.getoption("--update-golden")

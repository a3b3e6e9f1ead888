"""Shared fixtures: built-in robots derived once per test session."""

from __future__ import annotations

import warnings
from functools import lru_cache

import pytest

import symbolic


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

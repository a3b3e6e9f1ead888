"""The error raised for bad measured data and experiment files (defined with the others in :mod:`symbolic.errors`)."""

from __future__ import annotations

from symbolic.errors import DataError

__all__ = ["DataError"]

"""The ``[excitation]`` table of an experiment file: what an excitation design may do and what the log will see.

``symbolic excite`` (:mod:`symbolic.identify.excitation`) reads it; every other command accepts an experiment
file that has one and checks it the same way (one loader, one set of messages)::

    [excitation]
    rate = 1000.0                                   # Hz: the sample rate of the log to be recorded
    position = { q1 = [-2.8, 2.8], q2 = [-1.7, 1.7] }   # rad or m: lower and upper bound per coordinate
    velocity = { q1 = 2.1, q2 = 2.1 }               # |q̇| bound per coordinate
    acceleration = 10.0                             # one number: the same bound for every coordinate
    torque = { q1 = 87.0, q2 = 87.0 }               # |τ| bound (the generalized force) per coordinate
    force_noise = { q1 = 0.5, q2 = 0.5 }            # σ of the force measurement noise, per sample
    resolution = 1e-5                               # encoder resolution (quantisation step) of the positions

Each entry is a number (every coordinate) or a table by coordinate; ``position`` takes ``[lower, upper]``.
``inf`` (TOML's own) declares a bound absent on purpose. Coordinates the model does not have are refused.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from symbolic.data.errors import DataError
from symbolic.data.keys import check_keys, suggestion

KINDS = ("position", "velocity", "acceleration", "torque")
"""The limits a design respects, in this order."""
NOISE = ("force_noise", "resolution")
"""The noise a prediction of σ needs."""
KEYS = ("rate", *KINDS, *NOISE)


@dataclass(frozen=True)
class ExcitationTable:
    """The ``[excitation]`` table as declared: ``{kind: {coordinate: value}}`` (position: ``(lower, upper)``),
    and the log's sample rate (``None`` when not declared)."""

    values: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    rate: float | None = None


def parse(table: Any, coordinates: Sequence[str], source: str) -> ExcitationTable:
    """Check an ``[excitation]`` table (module docstring) against the model's ``coordinates``.

    Raises
    ------
    DataError
        One line naming the file, ``[excitation] <key>``, what is wrong and what is allowed.
    """
    if not isinstance(table, Mapping):
        raise DataError(source, "[excitation]", f"expected a table, got {type(table).__name__}")
    check_keys(table, KEYS, source, "[excitation]")
    rate = table.get("rate")
    if rate is not None and not (_number(rate) and math.isfinite(rate) and rate > 0):
        raise DataError(source, "[excitation] rate", f"expected a sample rate in Hz > 0, got {rate!r}")
    values = {kind: _per_coordinate(table[kind], kind, coordinates, source) for kind in KINDS + NOISE if kind in table}
    return ExcitationTable(values, None if rate is None else float(rate))


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _per_coordinate(entry: Any, kind: str, coordinates: Sequence[str], source: str) -> dict[str, Any]:
    if not isinstance(entry, Mapping):
        return {c: checked_value(entry, kind, f"[excitation] {kind}", source) for c in coordinates}
    out = {}
    for c, v in entry.items():
        if c not in coordinates:
            raise DataError(source, f"[excitation] {kind}.{c}", f"unknown coordinate (the model's: "
                                                                 f"{', '.join(coordinates)}){suggestion(c, coordinates)}")
        out[c] = checked_value(v, kind, f"[excitation] {kind}.{c}", source)
    return out


def checked_value(v: Any, kind: str, where: str, source: str) -> Any:
    """One entry of ``kind``: a position's ``(lower, upper)``, a limit > 0 (inf: none) or a noise level ≥ 0 (finite),
    as floats; also the check of the command line's values (``where``/``source``: the option).

    Raises
    ------
    DataError
        Naming ``source`` and ``where``, what is allowed and what was given.
    """
    if kind == "position":
        if not (isinstance(v, (list, tuple)) and len(v) == 2 and all(_number(x) and not math.isnan(x) for x in v)
                and v[0] < v[1]):
            raise DataError(source, where, f"expected [lower, upper] with lower < upper, got {v!r}")
        return (float(v[0]), float(v[1]))
    if kind in NOISE:  # a noise level: 0 (none) or more, never inf (σ = inf would weigh every sample 0)
        if not (_number(v) and math.isfinite(v) and v >= 0):
            raise DataError(source, where, f"expected a finite number >= 0, got {v!r}")
    elif not (_number(v) and not math.isnan(v) and v > 0):  # a limit: inf declares none
        raise DataError(source, where, f"expected a bound > 0 (inf: none), got {v!r}")
    return float(v)

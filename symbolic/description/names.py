"""The names of identified coefficients: one rule for the regressor's θ, identify, diagnose and the exports.

docs/model-format.md, "Names of identified coefficients", states the rule; :func:`coefficient_names`
applies it to the regressor's θ and :func:`coefficient_name` gives the name an effect of ``symbolic
diagnose`` writes into the model file, so that a coefficient found by diagnose is named alike in the
patched file and in ``identify``'s output.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import sympy as sp

FRICTION_STEMS = {"viscous": "Fv", "coulomb": "Fc", "offset": "offset"}
"""The stem of each [[friction]] coefficient (key of the table → stem)."""
DIRECTION_SUFFIXES = {"positive": "p", "negative": "n"}
"""What a direction-dependent coefficient adds to its stem: ``Fvp``/``Fvn``, ``Fcp``/``Fcn``."""
STRIBECK_STEM = "Fs"
"""The static level of a Stribeck rise."""
ROTOR_STEM = "Ia"
"""A drive's rotor inertia at its coordinate, Ia·ratio²."""


def friction_stem(key: str, direction: str | None = None) -> str:
    """The stem of [[friction]] ``key`` (``viscous``, ``coulomb``, ``offset``), with ``direction``
    (``positive``/``negative``) for a direction-dependent coefficient: ``Fv``, ``Fcp``, ``offset``."""
    return FRICTION_STEMS[key] + ("" if direction is None else DIRECTION_SUFFIXES[direction])


def coefficient_name(stem: str, coordinate: str) -> str:
    """``<stem>_<coordinate>`` (``Fc_q``, ``Fvp_q2``, ``Ia_q1``), characters outside ``[A-Za-z0-9_]`` as ``_``."""
    return re.sub(r"[^A-Za-z0-9_]", "_", f"{stem}_{coordinate}")


def unique(name: str, taken: Collection[str]) -> str:
    """``name``, or ``name_2``, ``name_3``, ... the first that is not in ``taken``."""
    if name not in taken:
        return name
    k = 2
    while f"{name}_{k}" in taken:
        k += 1
    return f"{name}_{k}"


@dataclass(frozen=True)
class Coefficient:
    """One θ to name.

    Attributes
    ----------
    proposed
        Its name when it does not take a parameter's: ``<stem>_<coordinate>`` (:func:`coefficient_name`),
        Khalil's ``XX1``, ``<force>:<monomial>``.
    value
        θ as an expression of the model file's parameters.
    own
        Whether θ takes the name of the one parameter it equals (friction, drive, force coefficients);
        the inertial and beam parameters, sums over a frame's bodies, keep their kind-and-frame names.
    """

    proposed: str
    value: sp.Expr
    own: bool = True


def coefficient_names(coefficients: Sequence[Coefficient], parameters: Sequence[sp.Symbol]) -> tuple[str, ...]:
    """The names of ``coefficients`` (docs/model-format.md, "Names of identified coefficients").

    A coefficient that may own a name and whose value is exactly one model parameter that no other
    coefficient equals takes that parameter's name. Every other coefficient takes its proposed name,
    made unique (:func:`unique`) against the names already given and against every model parameter
    other than its own value, so that no θ is named like a parameter of another quantity. Names are
    given in order: first the parameters' own, then the proposed ones in the coefficients' order.
    """
    known = set(parameters)
    exact = [c.value if c.own and isinstance(c.value, sp.Symbol) and c.value in known else None for c in coefficients]
    counts = Counter(e for e in exact if e is not None)
    names: list[str | None] = [e.name if e is not None and counts[e] == 1 else None for e in exact]
    taken = {n for n in names if n is not None}
    by_name = {p.name: p for p in parameters}
    for k, coefficient in enumerate(coefficients):
        if names[k] is None:
            others = {n for n, p in by_name.items() if p != coefficient.value}
            names[k] = unique(coefficient.proposed, taken | others)
            taken.add(names[k])
    return tuple(names)

"""The base of the effects written as a sinusoid a·sin(x) + b·cos(x) (gravity, periodic): no effect of its own."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from symbolic.description.names import coefficient_name
from symbolic.workflow.effects.base import Effect

if TYPE_CHECKING:
    from symbolic.workflow.patch import Editor


class Sinusoid(Effect):
    """A term a·sin(x) + b·cos(x) = A·sin(x + φ), A = √(a² + b²), φ = atan2(b, a)."""

    def evidence(self, coefficients: np.ndarray) -> dict[str, Any]:
        """The phase φ = atan2(b, a) of the fitted a·sin(x) + b·cos(x), in radians."""
        return {"phase_rad": float(np.arctan2(coefficients[1], coefficients[0]))}

    @staticmethod
    def sin_cos(x: np.ndarray) -> np.ndarray:
        """The columns sin(x), cos(x) of angles ``x``: ``samples × 2`` (each column contiguous)."""
        return np.stack([np.sin(x), np.cos(x)], axis=0).T

    @staticmethod
    def polar(c: np.ndarray) -> tuple[float, float]:
        return float(math.hypot(c[0], c[1])), float(math.atan2(c[1], c[0]))

    @staticmethod
    def write(editor: Editor, force: str, coordinate: str, stems: tuple[str, str], x: str, c: np.ndarray,
              comment: str, role: str | None = None) -> dict[str, float]:
        """The term as a ``[[force]]`` −(a·sin(x) + b·cos(x)) on ``coordinate`` with new parameters
        ``<stem>_<coordinate>`` (:func:`~symbolic.description.names.coefficient_name`; a, b = c; with ``role``,
        each commented as role·cos/sin(phase))."""
        notes = (f"; {role}·cos(phase)", f"; {role}·sin(phase)") if role else ("", "")
        a = editor.parameter(coefficient_name(stems[0], coordinate), float(c[0]), comment + notes[0])
        b = editor.parameter(coefficient_name(stems[1], coordinate), float(c[1]), comment + notes[1])
        editor.add_force(f"{force}_{coordinate}", coordinate, f"-({a}*sin({x}) + {b}*cos({x}))", comment)
        return {a: float(c[0]), b: float(c[1])}

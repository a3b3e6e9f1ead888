"""Values of a model's parameters: one place that converts names ↔ symbols ↔ arrays.

Every numerical function of a model takes its parameters as one array ``p`` in the order of
``[parameters]`` in the model file (``Robot.parameter_symbols``; docs/contracts.md). Callers hold them
as an array, as ``{name: value}`` (the command line, a diagnosis, a patched model file) or as
``{symbol: value}`` (substitution into SymPy expressions). A :class:`ParameterVector` is such an array
tied to its symbols, so that each conversion is written once, and a name that the model does not have
is refused instead of being ignored.

>>> import sympy as sp
>>> p = ParameterVector((sp.Symbol("m", real=True), sp.Symbol("l", real=True)), (2.0, 0.5))
>>> p.updated({"l": 0.7}).by_name()
{'m': 2.0, 'l': 0.7}
>>> float(p["m"]), p.index("l"), p.array().tolist()
(2.0, 1, [2.0, 0.5])
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from symbolic.errors import ModelError

Key = str | sp.Symbol


@dataclass(frozen=True, eq=False)
class ParameterVector:
    """Parameter values in model-file order, addressable by position, name or symbol.

    Attributes
    ----------
    symbols
        The parameter symbols, in model-file order.
    values
        Their values (a read-only float array of the same length).
    source
        The model file (for error messages).
    """

    symbols: tuple[sp.Symbol, ...]
    values: np.ndarray
    source: str = "<python>"
    _index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        values = np.array(self.values, dtype=float).reshape(-1)
        if values.shape != (len(self.symbols),):
            raise ValueError(f"{len(self.symbols)} parameter values expected (one per symbol), got {np.shape(self.values)}")
        values.flags.writeable = False
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "symbols", tuple(self.symbols))
        object.__setattr__(self, "_index", {s.name: k for k, s in enumerate(self.symbols)})

    @classmethod
    def nominal(cls, robot) -> ParameterVector:
        """The values written in ``robot``'s model file (a :class:`~symbolic.description.robot.Robot`)."""
        return cls(robot.parameter_symbols, [p.value for p in robot.parameters], robot.source)

    # -- reading ---------------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.symbols)

    def __len__(self) -> int:
        return len(self.symbols)

    def __iter__(self) -> Iterator[float]:
        return iter(self.values)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        return self.values if dtype is None else self.values.astype(dtype)

    def index(self, key: Key) -> int:
        """Position of the parameter named ``key`` (a name or a symbol)."""
        name = key.name if isinstance(key, sp.Symbol) else key
        if name not in self._index:
            raise ModelError(self.source, "[parameters]", f"no parameter {name!r} (the model's: {', '.join(self.names) or 'none'})")
        return self._index[name]

    def __getitem__(self, key: Key) -> float:
        return float(self.values[self.index(key)])

    def array(self) -> np.ndarray:
        """A writable copy of the values."""
        return self.values.copy()

    def by_name(self) -> dict[str, float]:
        """``{name: value}`` in model-file order."""
        return {s.name: float(v) for s, v in zip(self.symbols, self.values)}

    def by_symbol(self) -> dict[sp.Symbol, float]:
        """``{symbol: value}`` in model-file order (for ``xreplace``)."""
        return {s: float(v) for s, v in zip(self.symbols, self.values)}

    # -- new values ------------------------------------------------------------------------------------
    def updated(self, values: Mapping[Key, float]) -> ParameterVector:
        """These values with some replaced (by name or symbol); a name the model does not have is refused."""
        out = self.array()
        for key, value in values.items():
            out[self.index(key)] = float(value)
        return ParameterVector(self.symbols, out, self.source)

    def coerce(self, values: Sequence[float] | np.ndarray | None) -> np.ndarray:
        """``values`` as a float array of all the parameters in order (length checked); these values for ``None``."""
        if values is None:
            return self.values
        array = np.asarray(values, dtype=float)
        if array.shape != self.values.shape:
            raise ValueError(f"{len(self)} parameter values expected ({', '.join(self.names)}), got shape {array.shape}")
        return array

    def with_array(self, values: Sequence[float] | np.ndarray | None) -> ParameterVector:
        """The same parameters at ``values`` (all of them, in order); ``None`` keeps these."""
        return self if values is None else ParameterVector(self.symbols, self.coerce(values), self.source)


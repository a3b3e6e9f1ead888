"""Code generation: derived SymPy expressions turned into programs and machine code.

Straight-line programs of the exported functions (:mod:`.program`, :mod:`.exported`), NumPy callables built
from them (:mod:`.functions`), CasADi functions (:mod:`.casadi`), the C printer and the C sources
(:mod:`.c_printer`, :mod:`.c_source`, :mod:`.naming`), one program as a C loop over samples
(:mod:`.c_batch`), compilation into cached shared libraries (:mod:`.compiled`) and their loaders
(:mod:`.compiled_regressor`), and the jinja2 environment (:mod:`.templates`). Nothing here writes the
user's files: :mod:`symbolic.export` does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from symbolic.codegen.functions import compile_function  # noqa: F401

__all__ = ["compile_function"]


def __getattr__(name: str) -> object:
    """``compile_function`` on first use: the modules that need no SymPy (:mod:`.compiled`, loading a cached
    library) are imported without it."""
    if name == "compile_function":
        from symbolic.codegen.functions import compile_function

        globals()[name] = compile_function
        return compile_function
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

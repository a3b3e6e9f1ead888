"""CasADi functions, NAME_<function>.casadi, and their loader NAME_casadi.py (docs/contracts.md, "Generated CasADi")."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from symbolic.derivation.dynamics import DynamicModel

SUMMARY = "CasADi functions (NAME_<function>.casadi) and a Python loader (NAME_casadi.py)"


def render(model: DynamicModel, head: str, figures: bool) -> dict[str, bytes]:
    from symbolic.codegen.casadi import casadi_functions
    from symbolic.codegen.templates import render as render_template

    functions = casadi_functions(model)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:  # casadi serialises to a file only
        for name, function in functions.items():
            path = Path(tmp) / f"{model.name}_{name}.casadi"
            function.save(str(path))
            out[path.name] = path.read_bytes()
    loader = render_template(
        "loader.py.j2",
        banner=head,
        name=model.name,
        functions=list(functions),
        coordinates=list(model.robot.generalized_coordinates),
        parameters=[{"name": p.name, "value": repr(p.value)} for p in model.robot.parameters],
    )
    out[f"{model.name}_casadi.py"] = loader.encode()
    return out

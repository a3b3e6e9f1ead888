"""The reviewer's report ``NAME.md`` (docs/contracts.md, "Generated report"): Markdown with LaTeX that GitHub renders.

Entries are shown in the compact form of :mod:`symbolic.derivation.simplify` (Madill (4.10) style) when they
are short enough to read; longer ones are summarised by their operation count in the generated C.
"""

from __future__ import annotations

import sympy as sp

from symbolic.derivation.dynamics import DynamicModel
from symbolic.codegen.templates import render
from symbolic.derivation.simplify import compact

MAX_INTERMEDIATES = 24
"""Entries needing more intermediate definitions than this are not expanded for the report
(expanding and collecting them takes seconds each and the result is too long to read)."""
MAX_OPERATIONS = 150
SMALL_MODEL = 3
"""Models with at most this many coordinates get every entry compacted (fast, and what reviewers check)."""


def coordinate_latex(model: DynamicModel) -> dict[str, str]:
    """LaTeX of each generalized coordinate; beam modal coordinates as ν_i^(beam), η_i^(beam) (Madill (3.37)–(3.38))."""
    out = {c: sp.latex(sp.Symbol(c)) for c in model.robot.coordinates}
    for beam in model.robot.beams:
        label = beam.name.replace("_", r"\_")
        for i, c in enumerate(beam.nu, 1):
            out[c] = rf"\nu_{{{i}}}^{{(\mathrm{{{label}}})}}"
        for i, c in enumerate(beam.eta, 1):
            out[c] = rf"\eta_{{{i}}}^{{(\mathrm{{{label}}})}}"
    return out


def _latex_names(model: DynamicModel) -> dict[sp.Symbol, str]:
    latex = coordinate_latex(model)
    names = {}
    for c, q, qd, qdd in zip(model.robot.generalized_coordinates, model.coordinates, model.velocities, model.accelerations):
        base = latex[c]
        names[q] = base
        names[qd] = rf"\dot{{{base}}}"
        names[qdd] = rf"\ddot{{{base}}}"
    return names


def _entry(model: DynamicModel, expr: sp.Expr, variables, names) -> str | None:
    """LaTeX of the compact form, or None when the entry is too long to review by eye."""
    if model.n > SMALL_MODEL and len(model.sub.program([expr])) > MAX_INTERMEDIATES:
        return None
    form = compact(model.sub.expand(expr), variables)
    if sp.count_ops(form) > MAX_OPERATIONS:
        return None
    return _latex(form, names)


def _latex(expr: sp.Expr, names=None) -> str:
    """LaTeX with every Float shown as the double nearest to it (17 significant digits), as in the C.

    The derivation carries the modal constants at 50 digits (symbolic.derivation.mode_shapes); they are
    rounded here once, like the C printer does, instead of being printed with all their digits.
    """
    doubles = {f: sp.Float(float(f), 17) for f in expr.atoms(sp.Float)}
    return sp.latex(expr.xreplace(doubles), symbol_names=names)


def _conditions(analysis, names) -> list[dict]:
    out = []
    for c in analysis.conditions:
        check = c.check(analysis.values)
        if check.holds:
            status = "holds"
        else:
            status = f"fails by {check.value:.4g} {c.unit}".rstrip()
            if c.feasible is False:
                status += " (met only with a parameter at 0 or of the opposite sign to its nominal value)"
        out.append({"kind": c.kind, "name": c.name, "latex": _latex(c.expression, names), "status": status})
    return out


def _mass(value: float | None) -> str:
    """4 significant digits: far above the last-bit differences of libm and LAPACK between machines."""
    if value is None:
        return "singular"
    return "∞" if value == float("inf") else f"{value:.4g}"


def _apparent_mass(model: DynamicModel) -> dict | None:
    """The workspace table of :func:`symbolic.numeric.operational.workspace_table` (None without an end effector)."""
    if model.robot.end_effector is None:
        return None
    from symbolic.numeric.operational import workspace_table

    ee = model.robot.end_effector
    rows = workspace_table(model)
    rigid = len(model.robot.coordinates)
    return {
        "frame": ee.frame,
        "point": ", ".join(sp.latex(sp.sympify(x)) for x in ee.point),
        "coordinates": [coordinate_latex(model)[c] for c in model.robot.coordinates],
        "flexible": rigid < model.n,
        "rows": [
            {"q": [f"{x:.2f}" for x in r.q[:rigid]], "axes": [_mass(m) for m in r.along_axes],
             "smallest": _mass(r.smallest), "largest": _mass(r.largest)}
            for r in rows
        ],
    }


def _accuracy(accuracy) -> dict:
    """The single-precision section's table: each function's worst error and, above NOTED, where it occurred."""
    from symbolic.codegen.c_accuracy import NOTED, UNMEASURED

    def worst(e) -> str:
        if e.states == 0:
            return f"not measured ({UNMEASURED})"
        return "0 (the output is zero)" if e.worst is None else f"{e.worst:.1e}"

    rows = [{"name": e.name, "worst": worst(e), "where": e.where()} for e in accuracy.errors]
    return {"states": accuracy.states, "seed": accuracy.seed, "noted": f"{NOTED:g}", "errors": rows}


def report_markdown(
    model: DynamicModel, banner: str, operations: dict[str, tuple[int, int]], version: str, analysis=None,
    figure: str | None = None, accuracy=None,
) -> str:
    """The reviewer's report NAME.md.

    ``operations`` maps each C function to (operations, angles); ``analysis`` is the
    :func:`~symbolic.derivation.analysis.decoupling` result to list (None: the section says how to get it);
    ``accuracy`` the :class:`~symbolic.codegen.c_accuracy.FloatAccuracy` of the single-precision C (None: the
    report of a double generation, without that section).
    """
    r = model.reduced
    names = _latex_names(model)
    q = list(model.coordinates)
    n = model.n
    inertia = [
        {"i": i, "j": j, "latex": _entry(model, r.D[i, j], q, names)} for i in range(n) for j in range(i, n)
    ]
    qv = q + list(model.velocities)
    coriolis = [{"k": k, "latex": _entry(model, r.coriolis[k], qv, names)} for k in range(n)]
    christoffel = []
    for k in range(n):
        for i in range(n):
            for j in range(i, n):
                e = r.christoffel[k * n + i, j]
                if e != 0 and n <= SMALL_MODEL:
                    latex = _entry(model, e, q, names)
                    if latex != "0":
                        christoffel.append({"i": i, "j": j, "k": k, "latex": latex})
    gravity = [{"k": k, "latex": _entry(model, r.gravity[k], q, names)} for k in range(n)]
    context = {
        "banner": banner,
        "version": version,
        "robot": model.robot,
        "n": n,
        "coordinates": [{"index": i, "name": c, "latex": coordinate_latex(model)[c]} for i, c in enumerate(model.robot.generalized_coordinates)],
        "parameters": [
            {"name": p.name, "latex": sp.latex(sp.Symbol(p.name)), "value": repr(p.value), "unit": p.unit, "description": p.description}
            for p in model.robot.parameters
        ],
        "inertia": inertia,
        "coriolis": coriolis,
        "christoffel": christoffel,
        "christoffel_count": sum(1 for e in r.christoffel if e != 0),
        "gravity": gravity,
        "potential": _entry(model, r.potential, q, names),
        "beams": [{"name": b.name, "frame": b.frame, "modes_v": b.modes_v, "modes_w": b.modes_w, "tip": b.tip_mass is not None} for b in model.robot.beams],
        "stiffness": [{"k": k, "latex": _entry(model, r.stiffness[k], q, names)} for k in range(n) if r.stiffness[k] != 0],
        "strain": _entry(model, r.strain, q, names) if r.strain != 0 else None,
        "operations": [{"name": k, "ops": v[0], "angles": v[1]} for k, v in operations.items()],
        "conditions": _conditions(analysis, names) if analysis is not None else None,
        "friction": [{"k": k, "latex": _entry(model, r.friction[k], qv, names)} for k in range(n) if r.friction[k] != 0],
        "applied": [{"k": k, "latex": _entry(model, r.applied[k], qv, names)} for k in range(n) if r.applied[k] != 0],
        "forces": [{"name": f.name, "coordinate": sp.latex(sp.Symbol(f.coordinate))} for f in model.robot.forces],
        "drives": [
            {"coordinate": sp.latex(sp.Symbol(d.coordinate)), "ratio": sp.latex(d.ratio), "rotor_inertia": sp.latex(d.rotor_inertia),
             "gain": "—" if d.gain is None else f"${sp.latex(d.gain)}$"}
            for d in model.robot.drives
        ],
        "constraints": [{"coordinate": c.coordinate, "latex": sp.latex(c.expression)} for c in model.robot.constraints],
        "apparent_mass": _apparent_mass(model),
        "apparent_mass_figure": figure,
        "accuracy": _accuracy(accuracy) if accuracy is not None else None,
    }
    return render("report.md.j2", **context)

"""Every registered effect passes the same conformance checks (in the manner of scikit-learn's
``parametrize_with_checks``): what holds for one effect of the catalogue holds for all, and for one a user drops
into symbolic/workflow/effects/ (docs/workflow.md, "Adding an effect"), with no table keyed by effect names.

On the two-link arm of tests/models.py (viscous and Coulomb friction on both joints, so that refinements have
their reference term) moved along smooth random trajectories, for every coordinate the effect applies to and at
the ends and the middle of its grid: declarations complete (:func:`check_effect`), columns of the documented shape
and finite, zero off their own row when it says so, roles by name from coefficients, a verdict that is ``None`` or
a reason, and a patch that leaves a model file that loads.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import models
import symbolic
import symbolic.data
import workflow_cases as cases
from doc_examples import example_module, package_with
from symbolic.workflow.effects import (EFFECTS, Context, Effect, Signals, check_effect, excluded, groups,
                                       markdown_table, register)
from symbolic.workflow.effects.base import Effect as BaseEffect
from symbolic.workflow.patch import Editor

ROOT = Path(__file__).resolve().parents[1]
RATE, SAMPLES = 200.0, 4000


def arm_context() -> tuple[str, Context, Signals]:
    # joint 2 with a motor (a rotor inertia): the effects offered only on a motor's joint are checked there
    text = models.arm(parameters=models.ARM_PARAMETERS + "Jm2 = 0.01\n",
                      extra='[[drive]]\ncoordinate = "q2"\nratio = 1\nrotor_inertia = "Jm2"\n')
    robot = symbolic.loads(text, "arm.toml")
    rng = np.random.default_rng(7)
    t = np.arange(SAMPLES) / RATE
    n = len(robot.generalized_coordinates)
    q = np.stack([sum(rng.uniform(0.1, 0.6) * np.sin(2 * np.pi * f * t + rng.uniform(0, 6)) for f in (0.2, 0.45, 1.1))
                  for _ in range(n)], axis=1)
    qd = np.gradient(q, 1 / RATE, axis=0)
    qdd = np.gradient(qd, 1 / RATE, axis=0)
    model = symbolic.derive(robot)  # for the effects whose columns need the model's numbers (the link behind a drive)
    coordinates = tuple(robot.generalized_coordinates)
    context = Context(robot, coordinates, q, qd, qdd, passband=40.0, kept_period=1 / RATE, duration=float(t[-1]),
                      rate=RATE, model=model)
    return text, context, Signals(q, qd, qdd, t, RATE, robot, model=model, coordinates=coordinates)


TEXT, CONTEXT, SIGNALS = arm_context()


def values_to_try(effect: Effect, j: int) -> list:
    """The grid's ends and two values in its middle for a nonlinear effect (a grid of several parameters varies
    the last fastest: the second middle row differs in it), else its setting."""
    if effect.nonlinear is None:
        return [effect.setting(CONTEXT, j)]
    grid = effect.grid(CONTEXT, j)
    if grid is None:
        return []
    values = grid[0]
    rows = [values[0], values[len(values) // 2], values[len(values) // 2 + 1], values[-1]]
    return [tuple(float(x) for x in row) if np.ndim(row) else float(row) for row in rows]


def conformance_failures(effect: Effect) -> list[str]:
    """What the effect does that the search, the report or the patch cannot take (empty: nothing)."""
    failures = list(check_effect(effect))
    tried = 0
    for j, coordinate in enumerate(CONTEXT.coordinates):
        reason = effect.applicable(CONTEXT, j)
        if reason is not None:
            if not isinstance(reason, str) or not reason:
                failures.append(f"applicable on {coordinate}: None or a reason, not {reason!r}")
            continue
        for value in values_to_try(effect, j):
            tried += 1
            where = f"{coordinate} at {value!r}"
            columns = effect.columns_at(SIGNALS, j, value)
            if columns.ndim != 3 or columns.shape[:2] != (SAMPLES, len(CONTEXT.coordinates)) or columns.shape[2] < 1:
                failures.append(f"{where}: columns of shape {columns.shape}, not samples × N × k")
                continue
            if not np.all(np.isfinite(columns)):
                failures.append(f"{where}: columns not finite")
            if effect.own_row and np.any(np.delete(columns, j, axis=1)):
                failures.append(f"{where}: own_row, yet its columns act on other coordinates")
            reference = 0.3 if effect.refines else None
            c = np.full(columns.shape[2], 0.1)  # below the reference: physical refinements
            roles = effect.roles_of(c, value, reference)
            if not set(effect.roles) <= set(roles):
                failures.append(f"{where}: roles_of gives {sorted(roles)}, not every role of {effect.roles}")
                continue
            verdict = effect.check(roles, reference, CONTEXT, j)
            if verdict is not None:
                if not (isinstance(verdict, str) and verdict):
                    failures.append(f"{where}: check gives {verdict!r}, not None or a reason")
                continue  # only accepted (physical) effects are written
            failures += patch_failures(effect, j, roles, c, value, where)
    if tried == 0 and effect.name not in {"payload"}:  # the payload needs the search's terms (tests/test_payload*.py)
        failures.append("applies to no coordinate of the two-link arm at any value: nothing was checked")
    return failures


def patch_failures(effect: Effect, j: int, roles: dict, c: np.ndarray, value, where: str) -> list[str]:
    editor = Editor(TEXT, CONTEXT.robot, "arm.toml")
    written = effect.patch(editor, CONTEXT, j, roles, c, value, "conformance")
    if not written or not all(isinstance(k, str) and np.isfinite(v) for k, v in written.items()):
        return [f"{where}: patch returns {written!r}, not the parameters it wrote"]
    try:
        patched = symbolic.loads(editor.text(), "arm.toml")
    except symbolic.SymbolicError as error:
        return [f"{where}: the patched model file does not load: {error}"]
    missing = set(written) - {p.name for p in patched.parameters}
    return [f"{where}: patch names {sorted(missing)}, which the patched file does not hold"] if missing else []


@pytest.mark.parametrize("name", list(EFFECTS))
def test_every_registered_effect_conforms(name: str) -> None:
    assert conformance_failures(EFFECTS[name]) == []


@pytest.mark.parametrize("name", [name for name, effect in EFFECTS.items() if effect.own_row])
def test_an_own_row_effect_s_row_columns_are_its_columns_on_that_row(name: str) -> None:
    """What the search treats (:meth:`Effect.row_columns_at`) is exactly :meth:`Effect.columns_at`'s row ``j``, on a
    record's continuation too (a filtered column runs through the record)."""
    effect = EFFECTS[name]
    start = SAMPLES // 2
    tail = Signals(*(x[start:] for x in (SIGNALS.q, SIGNALS.qd, SIGNALS.qdd, SIGNALS.t)), RATE, SIGNALS.robot, SIGNALS,
                   start, SIGNALS.model, SIGNALS.coordinates)
    checked = 0
    for j in range(len(CONTEXT.coordinates)):
        if effect.applicable(CONTEXT, j) is not None:
            continue
        for value in values_to_try(effect, j):
            for signals in (SIGNALS, tail):
                assert np.array_equal(effect.row_columns_at(signals, j, value), effect.columns_at(signals, j, value)[:, j, :])
                checked += 1
    assert checked


def test_the_checks_catch_what_they_look_for() -> None:
    """An effect without units, with a misdeclared row or unloadable patch is reported, not passed."""

    class Careless(BaseEffect):
        name, roles, summary, own_row = "careless", ("drag",), "q̇|q̇| drag", True

        def columns(self, q, qd, qdd, j, value):
            return np.repeat((qd[:, j] * np.abs(qd[:, j]))[:, None, None], q.shape[1], axis=1)

        def roles_of(self, c, value, reference):
            return {"drag": float(c[0])}

        def patch(self, editor, context, j, roles, c, value, comment):
            return {"Fd_q1": roles["drag"]}  # says it wrote a parameter it never wrote

    failures = conformance_failures(Careless())
    assert any("units has no entry for role(s) ['drag']" in f for f in failures)
    assert any("own_row, yet its columns act on other coordinates" in f for f in failures)
    assert any("patch names ['Fd_q1']" in f for f in failures)
    with pytest.raises(TypeError, match="units has no entry"):
        register(Careless())
    assert "careless" not in EFFECTS


def test_catalogue_order_exclusions_and_groups_come_from_the_effects() -> None:
    ranks = [e.rank for e in EFFECTS.values()]
    assert ranks == sorted(ranks)
    for name, effect in EFFECTS.items():
        for other in excluded(effect):
            assert name in excluded(EFFECTS[other])  # symmetric, whichever side declares it
    assert excluded(EFFECTS["stribeck"]) == {"asymmetric_coulomb"}
    assert groups(list(EFFECTS.values())) == [("viscous", "coulomb")]
    assert groups([EFFECTS["viscous"]]) == []


def test_the_help_reads_the_registry_s_summaries_from_the_effect_files() -> None:
    """``diagnose --help`` reads the effect files' text, not the registry (SymPy and NumPy would make it slow):
    the two readings agree, keys, summaries and order."""
    from symbolic.workflow.effect_summaries import summaries

    assert list(summaries().items()) == [(k, e.summary) for k, e in EFFECTS.items()]


def test_the_docs_table_is_the_registry() -> None:
    text = (ROOT / "docs/workflow.md").read_text()
    table = re.search(r"<!-- the catalogue, generated from the registry.*?-->\n(.*?)<!-- end of the catalogue -->", text, re.S)
    assert table, "docs/workflow.md lost its generated catalogue table"
    assert table.group(1) == markdown_table(), "docs/workflow.md's table differs from the registry: paste markdown_table()"


@pytest.mark.slow
def test_the_documented_example_effect_is_all_it_takes(tmp_path: Path) -> None:
    """The example file, dropped alone into a copy of the package, is listed by --list-effects and found by
    ``diagnose --effects quadratic_drag`` on an axis whose drag the model lacks (truth Fq = 0.4)."""
    path, source = example_module("docs/workflow.md", "symbolic/workflow/effects")
    run = package_with(tmp_path, path, source)

    assert re.search(r"^  quadratic_drag +drag growing", run("diagnose", "--help").stdout, re.M)
    listed = run("diagnose", "--list-effects")
    assert listed.returncode == 0, listed.stderr
    assert re.search(r"^quadratic_drag +Fq·q̇·abs\(q̇\) +\[drag \(force·s²/position²\)\]$", listed.stdout, re.M)
    drag = '[[force]]\nname = "drag"\ncoordinate = "q"\nexpression = "-Fq*qd_q*abs(qd_q)"\n'
    truth = models.axis(parameters="Fv = 0.3\nFc = 0.4\nFq = 0.4\n", extra=drag)
    symbolic.data.write(cases.measurements(truth, 2, 0.01), tmp_path / "log.csv")  # the canonical columns
    cases.model_file(tmp_path, models.axis())
    done = run("-q", "diagnose", "model.toml", "log.csv", "--effects", "quadratic_drag", "--out", "out", "--json")
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout)["found"]
    assert [(f["effect"], f["coordinate"]) for f in found] == [("quadratic_drag", "q")]
    assert found[0]["parameters"]["drag"] == pytest.approx(0.4, rel=0.05)
    assert "-Fq_q*qd_q*abs(qd_q)" in (tmp_path / json.loads(done.stdout)["patched_model"]).read_text()

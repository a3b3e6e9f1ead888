"""Derivation at scale (issue 38, item 6): the large-program path of code generation.

Programs above :data:`symbolic.codegen.program.LARGE_PROGRAM` definitions share only repeated subtrees and are
renamed without re-sorting (docs/architecture.md, "Programs of large models"). Checked here: that path computes
what SymPy's full elimination computes, its text does not depend on the hash seed, and the C of a long serial
chain (tests/models.py, ``serial_chain``), compiled with the strict flags, agrees with Pinocchio. Timings are
bench/derivation.py's ("Derivation at scale"), never asserted here.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import symbolic
import symbolic.export as export
from symbolic.codegen.exported import function_specs, input_symbols
from symbolic.codegen.program import LARGE_PROGRAM, build_program, count_operations, program_size

import models
from c_library import CModel, compile_shared
from reference_pinocchio import Reference, require_pinocchio

ROOT = Path(__file__).resolve().parents[1]


def _evaluate(program, arguments, values):
    """The outputs of ``program`` at ``values`` (one array per group of ``arguments``), by its statements in order."""
    function = sp.lambdify([list(a) for a in arguments], list(program.outputs), modules="math",
                           cse=lambda exprs: (list(program.statements), exprs))
    return np.array(function(*[list(v) for v in values]), dtype=float)


def test_large_path_computes_what_the_full_elimination_computes():
    model = symbolic.derive(symbolic.loads(models.serial_chain(3, spatial=True), "spatial3"))
    symbols = input_symbols(model)
    rng = np.random.default_rng(38)
    state = {"q": rng.uniform(-2, 2, 3), "qd": rng.uniform(-2, 2, 3), "qdd": rng.uniform(-2, 2, 3), "tau": np.zeros(3),
             "p": np.array(list(model.parameters.values()), dtype=float)}
    for spec in function_specs(model):
        arguments = [symbols[a] for a in spec.inputs]
        values = [state[a] for a in spec.inputs]
        full = build_program(spec.sub or model.sub, spec.expressions, large=False)
        large = build_program(spec.sub or model.sub, spec.expressions, large=True)
        assert large.large and not full.large
        expected, found = _evaluate(full, arguments, values), _evaluate(large, arguments, values)
        assert np.allclose(found, expected, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(expected).max(initial=0))), spec.name


def test_count_operations_is_sympys_count():
    """The integer count printed in the C comments and the report equals ``sympy.count_ops`` statement by statement,
    on both paths' programs."""
    model = symbolic.derive(symbolic.loads(models.serial_chain(3, spatial=True), "spatial3"))
    for spec in function_specs(model):
        for large in (False, True):
            program = build_program(spec.sub or model.sub, spec.expressions, large=large)
            for expr in [e for _, e in program.statements] + list(program.outputs):
                assert count_operations(expr) == sp.count_ops(expr), (spec.name, expr)
    for expr in (sp.Integer(0), sp.Rational(-3, 4), sp.Symbol("x") / sp.Symbol("y") - sp.exp(sp.Symbol("z")) ** 2,
                 -sp.Symbol("x") - sp.Symbol("y"), sp.Max(sp.Symbol("x"), 1, sp.Symbol("y"))):
        assert count_operations(expr) == sp.count_ops(expr), expr


@pytest.mark.filterwarnings("ignore:.*violate the triangle inequality:symbolic.errors.ModelWarning")  # PUMA's link 3, as published
def test_builtin_robots_stay_below_the_threshold():
    """The built-in robots' generated files come from the full elimination (generated/ unchanged)."""
    for name in ("panda", "puma560"):
        model = symbolic.derive(symbolic.robots.load(name))
        assert max(program_size(s.sub or model.sub, s.expressions) for s in function_specs(model)) <= LARGE_PROGRAM


CHILD = r"""
import hashlib, sys, warnings
warnings.simplefilter("ignore")
sys.path.insert(0, sys.argv[1])
import models, symbolic, symbolic.export as export
import symbolic.codegen.exported as exported
exported.LARGE_PROGRAM = 0  # every program of this small chain takes the large-program path
model = symbolic.derive(symbolic.loads(models.serial_chain(3, spatial=True), "spatial3"))
files = export.render(model, ["c"])
print(hashlib.sha256(files["spatial3.c"]).hexdigest())
"""


def test_large_path_text_does_not_depend_on_the_hash_seed(tmp_path):
    digests = set()
    for seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": seed, "SYMBOLIC_CACHE_DIR": str(tmp_path / seed)}
        out = subprocess.run([sys.executable, "-c", CHILD, str(ROOT / "tests")], capture_output=True, text=True, check=True,
                             env=env, cwd=ROOT)
        digests.add(out.stdout.strip().splitlines()[-1])
    assert len(digests) == 1


def _check_against_pinocchio(text: str, name: str, tmp_path: Path) -> None:
    require_pinocchio()
    robot = symbolic.loads(text, name)
    model = symbolic.derive(robot)
    sizes = [program_size(s.sub or model.sub, s.expressions) for s in function_specs(model)]
    assert max(sizes) > LARGE_PROGRAM  # the chain is large: its C comes from the large-program path
    export.c(model, tmp_path)
    library = compile_shared(tmp_path / f"{name}.c", tmp_path / f"lib{name}.so")
    c = CModel(library, name, model.n, len(robot.parameters))
    reference = Reference(robot)
    rng = np.random.default_rng(6)
    for _ in range(5):
        q, qd, qdd = (rng.uniform(-np.pi, np.pi, model.n) for _ in range(3))
        for found, expected in ((c.inverse_dynamics(q, qd, qdd, c.defaults), reference.rnea(q, qd, qdd)),
                                (c.inertia(q, c.defaults), reference.inertia(q)),
                                (c.gravity(q, c.defaults), reference.gravity(q))):
            assert np.linalg.norm(found - expected) <= 1e-9 * np.linalg.norm(expected)


@pytest.mark.slow
@pytest.mark.parametrize("spatial, n", [(False, 20), (True, 12)], ids=["planar20", "spatial12"])
def test_long_chain_c_matches_pinocchio(spatial, n, tmp_path):
    """τ, D and g of the generated C (strict flags, ctypes) against Pinocchio's rnea, crba and gravity, 1e-9 relative."""
    kind = "spatial" if spatial else "planar"
    _check_against_pinocchio(models.serial_chain(n, spatial=spatial), f"{kind}{n}", tmp_path)

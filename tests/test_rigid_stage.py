"""A model that adds friction, forces or parameters to another (a diagnosis's patched model) continues its
derivation from the other's rigid stage (symbolic.derivation.rigid_stage): the same model, the same
intermediates in the same order, hence the same generated code, as a derivation from scratch."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

import symbolic
from symbolic import robots
from symbolic.derivation import regressor as regressor_module
from symbolic.derivation import rigid_stage
from symbolic.description import loads
from symbolic.description.robot import skeleton_digest

PATCH = '''
[[friction]]
coordinate = "q2"
viscous = "Fv2"
coulomb = "Fc2"

[[force]]
name = "spring_q1"
coordinate = "q1"
expression = "-k1*q1"
'''


def patched_text(values: bool = True) -> str:
    """The Panda with friction and a spring added, new parameters, and (``values``) a changed mass."""
    text = robots.path("panda").read_text()
    text = text.replace("[parameters]\n", "[parameters]\nFv2 = { value = 0.5 }\nFc2 = { value = 0.3 }\nk1 = { value = 2.0 }\n", 1)
    if values:
        text, count = re.subn(r"(m1\s*=\s*\{\s*value\s*=\s*)[0-9.eE+-]+", r"\g<1>4.5", text, count=1)
        assert count == 1
    return text.replace('name = "panda"', 'name = "panda_patched"', 1) + PATCH


def test_the_skeleton_ignores_name_values_friction_and_forces() -> None:
    original, patched = robots.load("panda"), loads(patched_text(), "patched.toml")
    assert skeleton_digest(original) == skeleton_digest(patched)
    assert 'zz = "Izz7"' in robots.path("panda").read_text()
    heavier = loads(robots.path("panda").read_text().replace('zz = "Izz7"', 'zz = "2*Izz7"', 1), "other.toml")
    assert skeleton_digest(heavier) != skeleton_digest(original)


def derive_fresh_in_a_new_process(text: str, tmp_path: Path) -> list[str]:
    """The patched model derived from scratch (no cache, no earlier derivation): its program and outputs."""
    path = tmp_path / "patched.toml"
    path.write_text(text)
    code = ("import sys, symbolic; from symbolic.description import load; m = symbolic.derive(load(sys.argv[1]));"
            "print(repr([(str(s), str(m.sub.definition[s])) for s in m.sub.symbols]));"
            "print(repr([str(x) for x in list(m.reduced.tau) + list(m.reduced.bias) + list(m.reduced.D)]));"
            "r = m.regressor(); print(repr((r.names, r.kinds, [str(e) for e in r.theta_expressions], [str(y) for y in r.Y],"
            "[(str(s), str(r.sub.definition[s])) for s in r.sub.symbols])))")
    result = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=300,
                            env={**__import__("os").environ, "SYMBOLIC_NO_CACHE": "1"})
    assert result.returncode == 0, result.stderr
    return result.stdout.splitlines()


def test_a_patched_model_continues_from_the_rigid_stage_with_the_same_result(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "1")
    rigid_stage._KEPT.clear()
    symbolic.derive(robots.load("panda")).regressor()
    assert [kind for kind, _ in rigid_stage._KEPT] == ["rigid stage", "rigid regressor"]
    computed = []
    monkeypatch.setattr(rigid_stage, "_compute", lambda *a: computed.append(a) or pytest.fail("rigid stage recomputed"))
    monkeypatch.setattr(regressor_module, "_rigid_block", lambda *a: computed.append(a) or pytest.fail("rigid block recomputed"))
    model = symbolic.derive(loads(patched_text(), "patched.toml"))
    assert not computed and model.name == "panda_patched"
    r = model.regressor()
    assert [kind for kind, _ in rigid_stage._KEPT] == ["rigid stage", "rigid regressor"]
    staged = [repr([(str(s), str(model.sub.definition[s])) for s in model.sub.symbols]),
              repr([str(x) for x in list(model.reduced.tau) + list(model.reduced.bias) + list(model.reduced.D)]),
              repr((r.names, r.kinds, [str(e) for e in r.theta_expressions], [str(y) for y in r.Y],
                    [(str(s), str(r.sub.definition[s])) for s in r.sub.symbols]))]
    assert staged == derive_fresh_in_a_new_process(patched_text(), tmp_path)
    # the stage itself was not extended by the patched derivation, and the model's kinematics are its own
    stage = rigid_stage._KEPT[("rigid stage", skeleton_digest(model.robot))]
    assert len(stage.sub) < len(model.sub) and model.kinematics.sub is model.sub
    assert model.kinematics.robot is model.robot


def test_the_patched_model_is_right_numerically(monkeypatch) -> None:
    """τ of the staged patched model = τ of the original + the added friction and spring, at a random state;
    its regressor times its θ is that τ (Khalil & Dombre 14.2)."""
    import numpy as np

    monkeypatch.setenv("SYMBOLIC_NO_CACHE", "1")
    rigid_stage._KEPT.clear()
    original = symbolic.derive(robots.load("panda"))
    patched = symbolic.derive(loads(patched_text(values=False), "patched.toml"))
    rng = np.random.default_rng(5)
    state = {}
    for c in original.robot.generalized_coordinates:
        for suffix in ("", "_dot", "_ddot"):
            state[c + suffix] = rng.uniform(-1, 1)

    def tau(model):
        values = {s: model.robot.parameter_values[s] for s in model.robot.parameter_symbols}
        values |= {s: state[s.name] for e in model.reduced.tau for s in model.sub.expand(e).free_symbols if s.name in state}
        return np.array([float(model.sub.expand(e).xreplace(values)) for e in model.reduced.tau])
    expected = tau(original)
    expected[1] += 0.5 * state["q2_dot"] + 0.3 * np.sign(state["q2_dot"])
    expected[0] += 2.0 * state["q1"]
    assert np.allclose(tau(patched), expected, rtol=1e-12, atol=1e-12)
    r = patched.regressor()
    values = {s: patched.robot.parameter_values[s] for s in patched.robot.parameter_symbols}
    theta = np.array([float(e.xreplace(values)) for e in r.theta_expressions])
    values |= {s: state[s.name] for s in r.expand().free_symbols if s.name in state}
    Y = np.array(r.expand().xreplace(values).evalf(), dtype=float)
    assert np.allclose(Y @ theta, expected, rtol=1e-12, atol=1e-10)

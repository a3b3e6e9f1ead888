"""One name per coefficient (docs/model-format.md, "Names of identified coefficients").

* The rule itself (:func:`symbolic.description.names.coefficient_names`): a coefficient that is exactly one
  parameter keeps its name, unless that parameter is the whole value of several; the others are
  ``<stem>_<coordinate>``, never named like a parameter of another quantity.
* The regressor applies it: EMPS's θ are the model file's ``Fv``, ``Fc``, ``offset``; a shared Coulomb level,
  a collision, a reflected rotor inertia and the directional and Stribeck coefficients on a two-link arm.
* What diagnose writes for an effect is the name the regressor gives the coefficient in the patched model.
"""

from __future__ import annotations

import sympy as sp
from models import arm

import symbolic
from symbolic import robots
from symbolic.derivation.regressor import regressor
from symbolic.description.names import Coefficient, coefficient_name, coefficient_names, friction_stem, unique
from symbolic.workflow.effects import EFFECTS
from symbolic.workflow.patch import Editor


def test_the_rule_on_its_own() -> None:
    Fc, Fv, k, q0, Fc_q = sp.symbols("Fc Fv k q0 Fc_q", real=True)
    names = coefficient_names([Coefficient("Fc_q1", Fc), Coefficient("Fc_q2", Fc),  # one Fc for two joints
                               Coefficient("Fv_q1", Fv),  # exactly one parameter: its name
                               Coefficient("Fc_q", Fc + Fc_q),  # named like a parameter of another quantity
                               Coefficient("spring:k*q0", k * q0), Coefficient("spring:k", k),
                               Coefficient("M1", Fv, own=False)],  # Khalil's name kept, Fv taken by θ 3
                              [Fc, Fv, k, q0, Fc_q])
    assert names == ("Fc_q1", "Fc_q2", "Fv", "Fc_q_2", "spring:k*q0", "k", "M1")
    assert coefficient_name(friction_stem("coulomb", "positive"), "q2") == "Fcp_q2"
    assert unique("Fc_q", {"Fc_q", "Fc_q_2"}) == "Fc_q_3"


def test_emps_theta_are_the_model_file_parameters() -> None:
    """EMPS's Coulomb level is ``Fc`` in the model file, in θ and in the committed C export (generated/)."""
    reg = regressor(robots.load("emps"))
    assert reg.names[-3:] == ("Fv", "Fc", "offset")
    assert [str(e) for e in reg.theta_expressions[-3:]] == ["Fv", "Fc", "offset"]
    header = (robots.path("emps").parents[2] / "generated" / "emps" / "emps.c").read_text()
    assert '"M_carriage", "Fv", "Fc", "offset" };' in header


def test_shared_collision_reflected_directional_and_stribeck() -> None:
    text = arm(parameters="Fv1 = 0.8\nFc = 0.5\nFv2 = 0.3\nFv_q2 = 0.2\nIa = 0.01\nFvp = 0.4\nFvn = 0.5\nFs = 0.9\n",
               friction1='viscous = { positive = "Fvp", negative = "2*Fvn" }\ncoulomb = "Fc"\n'
                         'stribeck = { static = "Fs + Fc", velocity = "0.1" }',
               friction2='viscous = "2*Fv2"\ncoulomb = "Fc"\noffset = "Fv_q2"',
               extra='[[drive]]\ncoordinate = "q1"\nratio = "3"\nrotor_inertia = "Ia"\n')
    reg = regressor(symbolic.loads(text, "arm.toml"))
    named = {n: str(e) for n, e, kind in zip(reg.names, reg.theta_expressions, reg.kinds) if kind != "inertial"}
    assert named == {"Ia_q1": "9*Ia", "Fvp": "Fvp", "Fvn_q1": "2*Fvn", "Fc_q1": "Fc", "Fs_q1": "Fc + Fs",
                     "Fv_q2_2": "2*Fv2", "Fc_q2": "Fc", "Fv_q2": "Fv_q2"}


def test_what_diagnose_writes_is_the_name_identify_gives() -> None:
    """Each friction, inertia and spring effect patched into a model without it: its new parameters are θ of
    the patched model under their own names (a found Coulomb level is ``Fc_q`` in both)."""
    base = arm(parameters="Fv1 = 0.8\n", friction1='viscous = "Fv1"', friction2='offset = "0"')
    robot = symbolic.loads(base, "arm.toml")
    context = type("Context", (), {"coordinates": robot.generalized_coordinates, "robot": robot})()
    for name, roles in (("coulomb", {"coulomb": 0.3}), ("viscous", {"viscous": 0.2}), ("offset", {"offset": 0.1}),
                        ("asymmetric_viscous", {"positive": 0.3, "negative": 0.4}),
                        ("stribeck", {"static": 0.5, "velocity": 0.02}), ("inertia", {"inertia": 0.01}),
                        ("spring", {"stiffness": 2.0, "rest_position": None})):
        effect = EFFECTS[name]
        editor = Editor(base, robot, "arm.toml")
        written = effect.patch(editor, context, 1, roles, None, None, "test")
        patched = regressor(symbolic.loads(editor.text(), "patched.toml"))
        theta = {n for n, e in zip(patched.names, patched.theta_expressions) if isinstance(e, sp.Symbol)}
        expected = {n for n in written if n != "vs_q2"}  # the Stribeck velocity is geometry of Y, not θ
        assert expected <= theta, (name, written, patched.names)
        assert all(n.endswith("_q2") for n in written), written

"""The discrepancy workflow (symbolic.workflow, ``symbolic diagnose``) on self-made hidden truth and EMPS.

Synthetic cases (tests/workflow_cases.py): the data come from a truth model *with* an effect, the
workflow gets the model *without* it. For each catalogue effect, on a 1-DOF rotary axis and on a 2-DOF
arm (effect on one joint; the other must stay clean): the workflow names exactly that effect on that
coordinate, recovers its parameters within 15 %, writes a patched model file that loads and derives,
and the held-out gap falls by at least half. Null cases (nothing missing) over seeds and noise
levels: nothing is named. Two effects at once: both named. The flexible single link's first bending
mode, missing from its rigid counterpart: named as flexible_mode with the ringing's frequency. EMPS (shared data): the stages of the
publication, and the pulse set's 23–25 Hz residual read as a lead of the logged force (with its hidden-truth
counterpart: a synthetic axis logged with its held command).
"""

from __future__ import annotations

import dataclasses
import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import symbolic
import workflow_cases as cases
from shared_data import emps  # noqa: F401  (fixture)
from symbolic.cli import main
from symbolic.data import Controller
from symbolic.identify.model import identify_model
from symbolic import robots
from symbolic.workflow import EFFECTS, NOT_SUPPORTED, Effect, diagnose, register
from symbolic.workflow.dataset import load_sets, split
from symbolic.workflow.effects import FlexibleMode, on_row, select
from symbolic.workflow.report import markdown
from symbolic.workflow.terms import fit_nominal, model_terms, relative_gap
from workflow_cases import ARM_FRICTION1, ARM_FRICTION2, ARM_PARAMETERS

TOLERANCE = 0.15
AXIS_F = 'viscous = "Fv"\ncoulomb = "Fc"'
AXIS_P = "Fv = 0.3\nFc = 0.4\n"


def force(name: str, coordinate: str, expression: str) -> str:
    return f'[[force]]\nname = "{name}"\ncoordinate = "{coordinate}"\nexpression = "{expression}"\n'


def run(tmp_path: Path, model: str, truth: str, seed: int = 1, noise: float = 0.01, **options):
    data = cases.measurements(truth, seed, noise)
    path = cases.model_file(tmp_path, model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return diagnose(path, data, out=tmp_path / "out", figures=False, **options)


def run_on(tmp_path: Path, model: str, data, **options):
    """The workflow on given measurements (the model written to a file first)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        return diagnose(cases.model_file(tmp_path, model), data, out=tmp_path / "out", figures=False, **options)


def check(d, effect: str, coordinate: str, truth: dict[str, float], same_fit: bool = True,
          variant: str | None = None) -> None:
    """Exactly ``effect`` on ``coordinate`` (of ``variant``: periodic in position or in time), its roles
    within 15 %, the patched file loads and derives and reproduces the search's fit (``same_fit=False``:
    fits at least as well — a payload's mass frees link parameters written inline, which the patched
    model then re-identifies), and the held-out gap at least halves."""
    assert [(f.effect, f.coordinate) for f in d.found] == [(effect, coordinate)], [(f.effect, f.coordinate) for f in d.found]
    found = d.found[0]
    assert found.variant == variant, found.variant
    for role, value in truth.items():
        assert found.parameters[role] == pytest.approx(value, rel=TOLERANCE), (role, found.parameters)
    patched = symbolic.derive(symbolic.load(d.patched_path))
    assert set(found.model_parameters) <= {p.name for p in patched.robot.parameters}
    assert d.after.gap["validation"] <= 0.5 * d.before.gap["validation"], (d.before.gap, d.after.gap)
    final = d.search.final.predicted("estimation")
    searched = relative_gap(d.sets["estimation"].tau, final)
    if same_fit:
        assert d.after.gap["estimation"] == pytest.approx(searched, rel=1e-6)
    else:
        assert d.after.gap["estimation"] <= searched * (1 + 1e-9)


# -- the catalogue on a 1-DOF axis --------------------------------------------------------------------

AXIS_CASES = {
    "coulomb": (cases.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), cases.axis(), "q", {"coulomb": 0.4}),
    "viscous": (cases.axis(parameters="Fc = 0.4\n", friction='coulomb = "Fc"'), cases.axis(), "q", {"viscous": 0.3}),
    "offset": (cases.axis(), cases.axis(parameters=AXIS_P + "off = -0.25\n", friction=AXIS_F + '\noffset = "off"'),
               "q", {"offset": -0.25}),
    "asymmetric_viscous": (cases.axis(), cases.axis(parameters="Fvp = 0.2\nFvn = 0.4\nFc = 0.4\n",
                                                    friction='viscous = { positive = "Fvp", negative = "Fvn" }\ncoulomb = "Fc"'),
                           "q", {"positive": 0.2, "negative": 0.4}),
    "stribeck": (cases.axis(), cases.axis(parameters=AXIS_P + "Fs = 0.8\nvs = 0.15\n",
                                          friction=AXIS_F + '\nstribeck = { static = "Fs", velocity = "vs" }'),
                 "q", {"static": 0.8, "velocity": 0.15}),
    "spring": (cases.axis(), cases.axis(parameters=AXIS_P + "k = 0.6\nq0 = 0.3\n", extra=force("cable", "q", "-k*(q - q0)")),
               "q", {"stiffness": 0.6, "rest_position": 0.3}),
    "gravity": (cases.axis(), cases.axis(parameters=AXIS_P + "G = 0.5\nphi = 0.7\n", extra=force("tilt", "q", "-G*sin(q + phi)")),
                "q", {"moment": 0.5, "phase": 0.7}),
    "inertia": (cases.axis(inertia="0.05"), cases.axis(inertia="0.065"), "q", {"inertia": 0.015}),
    "periodic": (cases.axis(), cases.axis(parameters=AXIS_P + "A = 0.15\n", extra=force("cogging", "q", "-A*sin(2*pi*q/0.2 + 0.4)")),
                 "q", {"amplitude": 0.15, "period": 0.2}),
}


VARIANTS = {"periodic": "position"}
"""The variant each case's effect is named as (cogging: periodic in position, not in time)."""


def test_coulomb_on_an_axis(tmp_path: Path) -> None:
    model, truth, coordinate, roles = AXIS_CASES["coulomb"]
    check(run(tmp_path, model, truth), "coulomb", coordinate, roles)


@pytest.mark.slow
@pytest.mark.parametrize("effect", [e for e in AXIS_CASES if e != "coulomb"])
def test_each_effect_on_an_axis(tmp_path: Path, effect: str) -> None:
    model, truth, coordinate, roles = AXIS_CASES[effect]
    check(run(tmp_path, model, truth, seed=2), effect, coordinate, roles, variant=VARIANTS.get(effect))


@pytest.mark.slow
def test_asymmetric_coulomb_ties_with_an_offset(tmp_path: Path) -> None:
    """With Coulomb friction in the model, direction-dependent Coulomb levels are the same as an offset
    (sign(q̇) and 1 span [q̇ > 0] and [q̇ < 0]): the offset (one parameter) is named and asymmetric_coulomb
    reported as the tie, with the truth's levels."""
    truth = cases.axis(parameters="Fv = 0.3\nFcp = 0.3\nFcn = 0.5\n", friction='viscous = "Fv"\ncoulomb = { positive = "Fcp", negative = "Fcn" }')
    d = run(tmp_path, cases.axis(), truth, seed=3)
    check(d, "offset", "q", {"offset": (0.3 - 0.5) / 2})
    (tie,) = [a for a in d.found[0].evidence["alternatives"] if a["effect"] == "asymmetric_coulomb"]
    assert tie["parameters"]["positive"] == pytest.approx(0.3, rel=TOLERANCE)
    assert tie["parameters"]["negative"] == pytest.approx(0.5, rel=TOLERANCE)


# -- the catalogue on a 2-DOF arm: one joint has the effect, the other stays clean ---------------------

ARM_CASES = {
    "coulomb": (cases.arm(friction2='viscous = "Fv2"'), cases.arm(), "q2", {"coulomb": 0.4}),
    "viscous": (cases.arm(friction1='coulomb = "Fc1"'), cases.arm(), "q1", {"viscous": 0.8}),
    "offset": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "off1 = 2.0\n", friction1=ARM_FRICTION1 + '\noffset = "off1"'),
               "q1", {"offset": 2.0}),
    "asymmetric_viscous": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "Fvp2 = 0.2\nFvn2 = 0.8\n",
                                                  friction2='viscous = { positive = "Fvp2", negative = "Fvn2" }\ncoulomb = "Fc2"'),
                           "q2", {"positive": 0.2, "negative": 0.8}),
    "stribeck": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "Fs2 = 0.9\nvs2 = 0.15\n",
                                        friction2=ARM_FRICTION2 + '\nstribeck = { static = "Fs2", velocity = "vs2" }'),
                 "q2", {"static": 0.9, "velocity": 0.15}),
    "spring": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "k = 1.5\nq0 = 0.3\n", extra=force("cable", "q2", "-k*(q2 - q0)")),
               "q2", {"stiffness": 1.5, "rest_position": 0.3}),
    "gravity": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "G = 0.8\nphi = 0.7\n", extra=force("unbalance", "q2", "-G*sin(q2 + phi)")),
                "q2", {"moment": 0.8, "phase": 0.7}),
    "inertia": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "Ia = 0.03\n",
                                       extra='[[drive]]\ncoordinate = "q2"\nratio = "2"\nrotor_inertia = "Ia"\n'),
                "q2", {"inertia": 0.12}),
    "periodic": (cases.arm(), cases.arm(parameters=ARM_PARAMETERS + "A = 0.3\n", extra=force("cogging", "q2", "-A*sin(2*pi*q2/0.2 + 0.4)")),
                 "q2", {"amplitude": 0.3, "period": 0.2}),
}


@pytest.mark.slow
@pytest.mark.parametrize("effect", list(ARM_CASES))
def test_each_effect_on_one_joint_of_an_arm(tmp_path: Path, effect: str) -> None:
    model, truth, coordinate, roles = ARM_CASES[effect]
    d = run(tmp_path, model, truth, seed=4)
    check(d, effect, coordinate, roles, variant=VARIANTS.get(effect))
    other = "q1" if coordinate == "q2" else "q2"
    assert d.after.detail["validation"][other] <= 1.01 * d.before.detail["validation"][other]


# -- nothing missing, two effects at once ------------------------------------------------------------

def test_nothing_missing_names_nothing(tmp_path: Path) -> None:
    d = run(tmp_path, cases.axis(), cases.axis(), seed=7, noise=0.02)
    assert d.found == ()
    assert d.to_dict()["found"] == []
    assert d.after.gap == pytest.approx(d.before.gap, rel=1e-9)


def test_a_log_without_noise_names_nothing_at_the_treatments_floor(tmp_path: Path) -> None:
    """The arm under PD integrated by tests/reference_integrator.py (DOP853, rtol 1e-11), no quantisation and no
    force noise, nothing missing: the residual (1 % of the force, the treatment's and the Coulomb smoothing's
    own) repeats on the held-out data, so an offset and a resonance on q1 passed the relative rules while
    removing 0.008 % of q1's force spread. Refused by size (statistics.MIN_FORCE_SHARE, 0.1 %); nothing named."""
    from reference_integrator import write_arm_experiment
    import models

    experiment = write_arm_experiment(tmp_path, counts=0, force_noise=0.0, seconds=6.0)
    model = tmp_path / "arm.toml"
    model.write_text(models.arm(), encoding="utf-8")
    d = diagnose(str(model), str(experiment), out=tmp_path / "out", figures=False)
    assert d.found == ()
    refused = [c for r in d.search.rounds for c in r.candidates if any(f.startswith("size:") for f in c.failed)]
    assert any(c.coordinate == "q1" and len(c.failed) == 1 for c in refused)  # passed everything else


@pytest.mark.slow
def test_no_false_discoveries_over_seeds_and_noise(tmp_path: Path) -> None:
    """9 axis data sets (3 seeds × 0.5, 2, 5 % noise) and 4 arm data sets (2 seeds × 1, 3 %), closed loop:
    nothing named (more seeds: make bench)."""
    named = []
    for seed in range(11, 14):
        for noise in (0.005, 0.02, 0.05):
            d = run(tmp_path / f"a{seed}{noise}", cases.axis(), cases.axis(), seed=seed, noise=noise)
            named += [(seed, noise, f.effect, f.coordinate) for f in d.found]
    for seed in range(11, 13):
        for noise in (0.01, 0.03):
            d = run(tmp_path / f"b{seed}{noise}", cases.arm(), cases.arm(), seed=seed, noise=noise)
            named += [(seed, noise, f.effect, f.coordinate) for f in d.found]
    assert named == []


@pytest.mark.slow
@pytest.mark.parametrize("bits, seed", [(14, 3), (16, 3), (16, 5), (18, 3)])
def test_coarser_encoders_name_nothing(tmp_path: Path, bits: int, seed: int) -> None:
    """The arm with 14- to 18-bit encoders (the suite's cases have 20 bits): the quantisation, fed back
    through the PD loop, makes the logged force partly a filter of the position error, which a resonance
    fits to a significant part of the residual. The 16- and 18-bit seeds each named a flexible_mode that
    removed 1-3 % of the held-out residual power before the effect-size threshold of
    statistics.MIN_HELD_OUT_GAIN; the 14-bit seed named five effects, the first a 2.7 Hz "resonance"
    removing 28 %, before a resonance had to ring (FlexibleMode.check_residual). Nothing is named."""
    data = cases.measurements(cases.arm(), seed, 0.01, resolution=2 * np.pi / 2**bits)
    d = run_on(tmp_path, cases.arm(), data)
    assert [(f.effect, f.coordinate) for f in d.found] == []


@pytest.mark.slow
def test_a_dominant_resonance_is_found_with_a_14_bit_encoder(tmp_path: Path) -> None:
    """The 8 Hz load of test_flexible_mode_on_an_axis behind a 14-bit encoder: the quantisation raises the
    residual's spectral floor so that the ringing stands only ≈ 5× above its median (no peak by the 10×
    rule), but the resonance explains most of the residual, which is what a dominant effect needs."""
    truth = cases.with_load(cases.axis(), "q", "rotor", FLEX["load"], FLEX["frequency"], FLEX["damping"])
    data = cases.measurements(truth, 1, 0.01, resolution=2 * np.pi / 2**14, measured=("q",), pulses=0.5)
    d = run_on(tmp_path, cases.axis(), data)
    assert [(f.effect, f.coordinate) for f in d.found] == [("flexible_mode", "q")]
    assert d.found[0].evidence["load_frequency_hz"] == pytest.approx(FLEX["frequency"], rel=0.03)
    assert d.found[0].evidence["load"] == pytest.approx(FLEX["load"], rel=TOLERANCE)
    # the quantisation's own floor stays: the gap falls by less than half, its power by more than half
    assert (d.after.gap["validation"] / d.before.gap["validation"]) ** 2 <= 0.5


@pytest.mark.slow
def test_two_effects_on_an_axis(tmp_path: Path) -> None:
    truth = cases.axis(parameters=AXIS_P + "k = 0.6\nq0 = 0.3\n", extra=force("cable", "q", "-k*(q - q0)"))
    d = run(tmp_path, cases.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), truth, seed=5)
    found = {f.effect: f for f in d.found}
    assert set(found) == {"coulomb", "spring"}
    assert found["coulomb"].parameters["coulomb"] == pytest.approx(0.4, rel=TOLERANCE)
    assert found["spring"].parameters["stiffness"] == pytest.approx(0.6, rel=TOLERANCE)
    assert found["spring"].parameters["rest_position"] == pytest.approx(0.3, rel=TOLERANCE)
    assert d.after.gap["validation"] <= 0.5 * d.before.gap["validation"]
    symbolic.derive(symbolic.load(d.patched_path))


@pytest.mark.slow
def test_two_effects_on_two_joints(tmp_path: Path) -> None:
    truth = cases.arm(parameters=ARM_PARAMETERS + "G = 0.8\nphi = 0.7\n", extra=force("unbalance", "q2", "-G*sin(q2 + phi)"))
    d = run(tmp_path, cases.arm(friction1='viscous = "Fv1"'), truth, seed=6)
    assert sorted((f.effect, f.coordinate) for f in d.found) == [("coulomb", "q1"), ("gravity", "q2")]
    values = {f.effect: f.parameters for f in d.found}
    assert values["coulomb"]["coulomb"] == pytest.approx(0.6, rel=TOLERANCE)
    assert values["gravity"]["moment"] == pytest.approx(0.8, rel=TOLERANCE)
    assert d.after.gap["validation"] <= 0.5 * d.before.gap["validation"]


# -- a disturbance periodic in time (mains interference) -----------------------------------------------

MAINS_HZ = 8.35
"""Hz: the cases' data (500 Hz, bandwidth 10 Hz, decimation by 10) keep up to 20 Hz; the search scans
up to 0.8 of that. Not within a resolution cell (1/32 Hz for 32 s of estimation data) of a harmonic of the excitation's
0.1 Hz fundamental: the search skips those."""


def mains(coordinate: str, frequency: float = MAINS_HZ) -> str:
    return force("mains", coordinate, f"-A*sin(2*pi*{frequency}*t + 0.4)")


def check_mains(d, coordinate: str, amplitude: float, frequency: float) -> None:
    """Named periodic in time, amplitude within 15 %, frequency within 3 %, written as a [[force]] in t."""
    check(d, "periodic", coordinate, {"amplitude": amplitude}, variant="time")
    found = d.found[0]
    assert found.parameters["frequency_hz"] == pytest.approx(frequency, rel=0.03)
    assert set(found.parameters) == {"amplitude", "frequency_hz"}
    assert found.evidence["phase_rad"] == pytest.approx(0.4, abs=0.15)
    (entry,) = d.to_dict()["found"]
    assert (entry["effect"], entry["variant"]) == ("periodic", "time")
    patched = symbolic.derive(symbolic.load(d.patched_path))
    assert patched.time_varying and not d.model.time_varying
    assert "periodic (in time) on" in markdown(d)


@pytest.mark.slow
def test_periodic_in_time_on_an_axis(tmp_path: Path) -> None:
    """0.05 N·m at 8.35 Hz: about 10 % of the axis's rms force, and a ripple of 0.02 rad/s in its speed
    (larger disturbances make the axis dither through its reversals, where Coulomb friction then
    switches with the disturbance and the fitted frequency drifts)."""
    truth = cases.axis(parameters=AXIS_P + "A = 0.05\n", extra=mains("q"))
    check_mains(run(tmp_path, cases.axis(), truth, seed=2), "q", 0.05, MAINS_HZ)


@pytest.mark.slow
def test_mains_at_50_hz_with_a_widened_treatment(tmp_path: Path) -> None:
    """Mains proper: 0.05 N·m at 50 Hz on the axis logged at 1 kHz. 50 Hz is the 500th harmonic of the
    excitation's 0.1 Hz: a lone line there is a disturbance (the motion's own lines form a comb). The
    default treatment keeps up to 40 Hz and filters it out of τ and the regressor alike (nothing to see);
    [identification] bandwidth = 40 keeps up to 80 Hz and the line is named."""
    from symbolic.data.treatment import Settings

    truth = cases.axis(parameters=AXIS_P + "A = 0.05\n", extra=mains("q", 50.0))
    data = cases.measurements(truth, 2, 0.01, rate=1000.0)
    assert run_on(tmp_path / "default", cases.axis(), data).found == ()
    d = run_on(tmp_path, cases.axis(), data, settings=Settings(bandwidth=40.0))
    check_mains(d, "q", 0.05, 50.0)


@pytest.mark.slow
def test_periodic_in_time_on_one_joint_of_an_arm(tmp_path: Path) -> None:
    """0.05 N·m at 5.35 Hz on the second joint, force noise 0.2 % (at 1 % the noise is most of the gap the
    disturbance leaves); the first joint stays clean."""
    truth = cases.arm(parameters=ARM_PARAMETERS + "A = 0.05\n", extra=mains("q2", 5.35))
    d = run(tmp_path, cases.arm(), truth, seed=4, noise=0.002)
    check_mains(d, "q2", 0.05, 5.35)
    assert d.after.detail["validation"]["q1"] <= 1.01 * d.before.detail["validation"]["q1"]


@pytest.mark.slow
def test_periodic_in_time_patched_model_is_simulated(tmp_path: Path) -> None:
    """The simulated path (``--simulate``): the nominal and the patched model (a [[force]] in t) run in the
    logged loop, feedforward included; the simulated force gap falls by at least half with the disturbance. (The
    search judged on the response is left out: tests/test_response.py holds it; here its candidates' fits simulated
    the smoothed Coulomb friction for 100 s.)"""
    truth = cases.axis(parameters=AXIS_P + "A = 0.05\n", extra=mains("q"))
    data = cases.measurements(truth, 2, 0.01, logged_feedforward=True)
    d = run_on(tmp_path, cases.axis(), data, simulate=True, response=False)
    assert [(f.effect, f.variant) for f in d.found] == [("periodic", "time")]
    assert d.to_dict()["path"] == "simulated"
    assert d.after.gap["validation"] <= 0.5 * d.before.gap["validation"], (d.before.gap, d.after.gap)


# -- the parts ---------------------------------------------------------------------------------------

def test_catalogue_holds_the_contract_identifiers() -> None:
    implemented = {"coulomb", "viscous", "offset", "asymmetric_viscous", "asymmetric_coulomb", "stribeck", "spring",
                   "gravity", "inertia", "periodic", "flexible_mode", "payload"}
    assert implemented <= set(EFFECTS)
    assert NOT_SUPPORTED == {}
    contract = {"coulomb": {"coulomb"}, "viscous": {"viscous"}, "offset": {"offset"},
                "asymmetric_viscous": {"positive", "negative"}, "asymmetric_coulomb": {"positive", "negative"},
                "stribeck": {"static", "velocity"}, "spring": {"stiffness", "rest_position"},
                "gravity": {"moment", "phase"}, "inertia": {"inertia"}, "periodic": {"amplitude", "period"},
                "periodic_time": {"amplitude", "frequency_hz"},
                "flexible_mode": {"frequency_hz", "damping_ratio"},
                "payload": {"mass", "com_x", "com_y", "com_z", "ixx", "iyy", "izz", "ixy", "ixz", "iyz"}}
    for name, roles in contract.items():
        assert set(EFFECTS[name].roles) == roles, name
    # two variants of the contract's periodic: in position (cogging) and in time (mains)
    periodic = {(e.name, e.identifier, e.variant) for e in EFFECTS.values() if e.identifier == "periodic"}
    assert periodic == {("periodic", "periodic", "position"), ("periodic_time", "periodic", "time")}
    assert [e.name for e in select(["periodic"])] == ["periodic", "periodic_time"]
    assert [e.name for e in select(["periodic_time", "coulomb"])] == ["coulomb", "periodic_time"]
    with pytest.raises(KeyError, match="cogging"):
        select(["periodic", "cogging"])


def test_cli_effects_takes_keys_and_contract_identifiers(capsys) -> None:
    """``--effects`` accepts registry keys and contract identifiers (``periodic``: both variants); an
    unknown name is one line and status 2, before any file is read."""
    assert main(["diagnose", "missing.toml", "missing.csv", "--out", "o", "--effects", "periodic,cogging"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --effects: unknown effect(s) ['cogging']") and err.count("\n") == 1
    assert "periodic_time" in err


class Cubic(Effect):
    """A user's effect: drag growing with the cube of the speed, c·q̇³ (as a [[force]])."""

    name, roles, summary = "cubic_damping", ("coefficient",), "drag c·q̇³"
    units = {"coefficient": "{force}·s³/{position}³"}  # every role says its unit (register checks it)

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [qd[:, j] ** 3])

    def roles_of(self, c, value, reference):
        return {"coefficient": float(c[0])}

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        name = editor.parameter(f"c3_{coordinate}", roles["coefficient"], comment)
        editor.add_force(f"drag_{coordinate}", coordinate, f"-{name}*qd_{coordinate}**3", comment)
        return {name: roles["coefficient"]}


def test_a_user_effect_is_searched_without_touching_the_search(tmp_path: Path) -> None:
    truth = cases.axis(parameters=AXIS_P + "c3 = 0.05\n", extra=force("drag", "q", "-c3*qd_q**3"))
    d = run(tmp_path, cases.axis(), truth, effects=[*EFFECTS.values(), Cubic()])
    check(d, "cubic_damping", "q", {"coefficient": 0.05})
    assert "-c3_q*qd_q**3" in d.patched_path.read_text()
    register(Cubic())
    try:
        assert "cubic_damping" in EFFECTS
        with pytest.raises(ValueError, match="already"):
            register(Cubic())
    finally:
        del EFFECTS["cubic_damping"]


def test_nominal_gap_is_the_identification_error(tmp_path: Path) -> None:
    """The gap of step 1 is ``symbolic identify``'s relative error and cross-test error when nothing is
    written inline, on the estimation part and the held-out last fifth."""
    data = cases.measurements(cases.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'), 3, 0.02)
    path = cases.model_file(tmp_path, cases.axis())
    model = symbolic.derive(symbolic.load(path))
    first, last = split(data)
    reference = identify_model(model, first, validation=last)
    estimation, held, _ = load_sets(("q",), data)
    fit = fit_nominal(model_terms(model), estimation)
    assert relative_gap(estimation.tau, fit.predict(estimation)) == pytest.approx(reference.identification.relative_error, rel=1e-10)
    assert relative_gap(held.tau, fit.predict(held)) == pytest.approx(reference.validation.relative_error, rel=1e-10)
    assert fit.parameters["Fc"].value == pytest.approx(reference.parameters["Fc"].value, rel=1e-10)


def test_numbers_written_inline_stay_fixed(tmp_path: Path) -> None:
    """An inertia written inline is not re-identified (its base parameter is fixed), a [parameters] one is."""
    model = symbolic.derive(symbolic.loads(cases.axis(inertia="0.05"), "<x>"))
    terms = model_terms(model)
    assert dict(zip(terms.names, terms.free))["ZZ_rotor"] is np.False_
    data = cases.measurements(cases.axis(inertia="0.08"), 2, 0.0)
    estimation, _, _ = load_sets(("q",), data)
    fit = fit_nominal(terms, estimation)
    assert fit.beta[list(terms.names).index("ZZ_rotor")] == 0.05


def test_patched_file_keeps_the_original_and_says_what_was_found(tmp_path: Path) -> None:
    model, truth, _, _ = AXIS_CASES["coulomb"]
    d = run(tmp_path, model, truth)
    text = d.patched_path.read_text()
    assert text.startswith("# A rotary axis about a vertical axis")
    assert 'coulomb = "Fc_q" # symbolic diagnose: coulomb on q' in text
    assert "# symbolic diagnose found coulomb on q" in text and "F-test p" in text and "held-out" in text
    assert not re.search(r"\b(19|20)\d\d-\d\d-\d\d\b", text)  # no dates
    assert symbolic.load(d.patched_path).parameters[-1].name == "Fc_q"
    # the patched model's identification names the coefficient as the file does (docs/model-format.md)
    assert "Fc_q" in symbolic.derive(symbolic.load(d.patched_path)).regressor().names


def test_cli_diagnose_prints_the_contract(tmp_path: Path, capsys) -> None:
    model, truth, _, _ = AXIS_CASES["coulomb"]
    data = tmp_path / "log.csv"
    symbolic.data.write(cases.measurements(truth, 1, 0.01), data)
    path = cases.model_file(tmp_path, model)
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        assert main(["-q", "diagnose", str(path), str(data), "--out", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) >= {"model", "found", "gap_before", "gap_after", "gap_detail", "patched_model"}
    assert result["model"] == "axis"
    (found,) = result["found"]
    assert set(found) == {"effect", "coordinate", "parameters", "model_parameters", "evidence"}
    assert found["effect"] == "coulomb" and found["coordinate"] == "q"
    assert found["parameters"]["coulomb"] == pytest.approx(0.4, rel=TOLERANCE)
    assert found["model_parameters"] == {"Fc_q": pytest.approx(found["parameters"]["coulomb"])}
    assert set(result["gap_before"]) == {"estimation", "validation"}
    assert result["gap_detail"]["before"]["estimation"]["force"]["q"] == pytest.approx(result["gap_before"]["estimation"])
    assert Path(result["patched_model"]) == out / "axis_patched.toml"
    assert (out / "report.md").read_text().startswith("# Diagnosis of `axis`")


def test_cli_diagnose_bad_input_is_one_line(tmp_path: Path, capsys) -> None:
    assert main(["-q", "diagnose", "emps", str(tmp_path / "missing.csv"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "missing.csv" in err
    assert not (tmp_path / "o").exists()


def test_a_simulated_path_plugs_in(tmp_path: Path) -> None:
    """A ``simulate`` callable replaces the inverse model's prediction in the gap (here a stand-in that
    returns the measured forces plus a known error: the gap is that error's)."""
    model, truth, _, _ = AXIS_CASES["coulomb"]
    calls = []

    def simulate(m, p, measurements):
        calls.append(m.name)
        return np.asarray(measurements.tau) * 1.1

    d = run(tmp_path, model, truth, simulate=simulate)
    assert d.before.gap["estimation"] == pytest.approx(10.0, rel=1e-9)
    assert d.to_dict()["path"] == "simulated" and len(calls) == 4


def test_a_simulated_path_with_motion_gives_position_and_velocity_gaps(tmp_path: Path) -> None:
    """A simulated path that also returns q and q̇ (SimulatedSignals) fills gap_detail's position and
    velocity: a stand-in off by exactly 1 % in q and 2 % in q̇ gives those percentages."""
    from symbolic.simulation.comparison import measured_motion
    from symbolic.workflow import SimulatedSignals

    model, truth, _, _ = AXIS_CASES["coulomb"]

    def simulate(m, p, measurements):
        qd = measured_motion(measurements).qd
        return SimulatedSignals(np.asarray(measurements.tau), 1.01 * np.asarray(measurements.q), 0.98 * qd)

    detail = run(tmp_path, model, truth, simulate=simulate).to_dict()["gap_detail"]
    for when in ("before", "after"):
        for role in ("estimation", "validation"):  # a held-out tail: simulated and differentiated through its record
            assert detail[when][role]["position"]["q"] == pytest.approx(1.0, rel=1e-9)
            assert detail[when][role]["velocity"]["q"] == pytest.approx(2.0, rel=1e-9)
    assert detail["note"] is None


def test_the_held_out_tail_is_simulated_from_its_records_start(tmp_path: Path) -> None:
    """Without --validate the held-out data are the record's last fifth: the simulated path runs the whole record
    (a loop started mid-motion has an integral and a last reading the machine did not have, and kicks) and the gap
    is the tail's. A stand-in off by 10 % from the record's 10th sample on, 30 % before: the held-out gap is 10 %."""
    model, truth, _, _ = AXIS_CASES["coulomb"]
    lengths = []

    def simulate(m, p, measurements):
        lengths.append(measurements.samples)
        tau = np.asarray(measurements.tau, float)
        return tau * np.where(np.arange(len(tau)) < 10, 1.3, 1.1)[:, None]

    d = run(tmp_path, model, truth, simulate=simulate)
    total = d.sets["estimation"].measurements.samples + d.sets["validation"].measurements.samples
    assert set(lengths) == {d.sets["estimation"].measurements.samples, total}
    assert d.before.gap["validation"] == pytest.approx(10.0, rel=1e-9)


def test_the_simulated_path_needs_a_controller(tmp_path: Path) -> None:
    model, truth, _, _ = AXIS_CASES["coulomb"]
    data = dataclasses.replace(cases.measurements(truth, 1, 0.01), controller=None)
    with pytest.raises(symbolic.DataError, match=r"\[controller\]: the simulated path needs"):
        diagnose(cases.model_file(tmp_path, model), data, figures=False, simulate=True)


# -- EMPS (shared data) --------------------------------------------------------------------------------

def emps_model(tmp_path: Path, drop: tuple[str, ...]) -> Path:
    text = "\n".join(line for line in robots.path("emps").read_text().splitlines() if line.strip() not in drop) + "\n"
    return cases.model_file(tmp_path, text, "emps.toml")


def emps_diagnose(model, **options):
    """The estimation set, the pulse set held out, the force taken as logged (held_force = false) as the
    publication takes it, so that its stages are reproduced; undeclared, the diagnosis finds the logged
    drive voltage held over each sample and treats it (test_emps_pulse_set_force_is_found_to_be_a_held_command)."""
    from symbolic.data.treatment import Settings

    return diagnose(model, robots.example_path("emps_estimation"), validation=robots.example_path("emps_pulses"),
                    figures=False, settings=Settings(held_force=False), **options)


@pytest.mark.slow
def test_emps_symmetric_stage_names_coulomb_and_offset(tmp_path: Path, emps: Path) -> None:  # noqa: F811
    """From M + Fv, with the symmetric effects (no refinement), the publication's first model: Coulomb
    friction ≈ 20.4 N and an offset ≈ −3.16 N; the force error falls to ≈ 4.1 %."""
    model = emps_model(tmp_path, ('coulomb = "Fc"', 'offset = "offset"'))
    d = emps_diagnose(model, effects=[e for e in EFFECTS.values() if e.refines is None])
    assert [f.effect for f in d.found] == ["coulomb", "offset"]
    values = {f.effect: f.parameters for f in d.found}
    assert values["coulomb"]["coulomb"] == pytest.approx(20.39, abs=0.3)
    assert values["offset"]["offset"] == pytest.approx(-3.165, abs=0.1)
    assert d.after.gap["estimation"] == pytest.approx(4.08, abs=0.15)


@pytest.mark.slow
def test_emps_published_model_names_the_direction_dependence(tmp_path: Path, emps: Path) -> None:  # noqa: F811
    """From the published symmetric model: asymmetric viscous friction (Fv+ 166.7, Fv− 240.4); the
    relative force error falls from ≈ 4.1 % to ≈ 3.1 % as in the publication; the offset is corrected."""
    d = emps_diagnose(robots.path("emps"), out=tmp_path / "out")
    assert [f.effect for f in d.found] == ["asymmetric_viscous"]
    roles = d.found[0].parameters
    assert roles["positive"] == pytest.approx(166.7, rel=0.02)
    assert roles["negative"] == pytest.approx(240.4, rel=0.02)
    assert d.before.gap["estimation"] == pytest.approx(4.08, abs=0.15)
    assert d.after.gap["estimation"] == pytest.approx(3.11, abs=0.15)
    assert d.after.gap["validation"] < d.before.gap["validation"]
    patched = symbolic.load(d.patched_path)
    assert patched.frictions[0].viscous.positive.name == "Fvp_q"
    # the offset the symmetric model needed is a wrong value now: the publication's direction-dependent model
    # has (Fc⁺ − Fc⁻)/2 = −0.25 N; Fv, replaced by Fv±, is removed, and both are reported (issue 21 §2)
    (correction,) = d.corrections
    assert correction["parameter"] == "offset" and correction["nominal"] == pytest.approx(-3.1648)
    assert correction["value"] == pytest.approx(-0.25, abs=0.1) and correction["evidence"]["sigmas"] > 3
    changes = {c["parameter"]: c for c in d.changes}
    assert changes["Fv"]["status"] == "removed" and changes["offset"]["correction"]
    assert {"M", "Fc"} <= {name for name, c in changes.items() if c["status"] == "re-identified"}
    assert d.modes is None  # no elastic coordinate


@pytest.mark.slow
def test_emps_full_catalogue_from_m_fv(tmp_path: Path, emps: Path) -> None:  # noqa: F811
    """From M + Fv with the whole catalogue, Coulomb friction and then the direction-dependent viscous
    friction: it explains more than the offset, which is then no longer significant (the publication's
    offset is the symmetric model's reading of the mean of the direction-dependent viscous friction)."""
    model = emps_model(tmp_path, ('coulomb = "Fc"', 'offset = "offset"'))
    d = emps_diagnose(model, out=tmp_path / "out")
    assert [f.effect for f in d.found] == ["coulomb", "asymmetric_viscous"]
    rounds = d.search.rounds
    offset = [c for c in rounds[1].candidates if c.effect.name == "offset"][0]
    assert offset.roles["offset"] == pytest.approx(-3.17, abs=0.1)  # what an offset would have been
    assert d.after.gap["estimation"] == pytest.approx(3.1, abs=0.15)
    symbolic.derive(symbolic.load(d.patched_path))


@pytest.mark.slow
def test_emps_simulated_path(tmp_path: Path, emps: Path) -> None:  # noqa: F811
    """``--simulate``: the gap is the simulated controller output's (the experiment's cascade loop, the
    pulse set driven by its own); the search is the same, and the simulated force error falls too."""
    d = emps_diagnose(robots.path("emps"), simulate=True)
    assert [f.effect for f in d.found] == ["asymmetric_viscous"] and d.to_dict()["path"] == "simulated"
    assert d.before.gap["estimation"] == pytest.approx(4.45, abs=0.3)  # symbolic simulate: 4.5 % (published 5.85 %)
    assert d.after.gap["estimation"] < d.before.gap["estimation"] - 0.5
    assert d.after.gap["validation"] < d.before.gap["validation"]
    # the motion follows the measurement closely (symbolic simulate: position 0.001 %, velocity 0.12 %)
    detail = d.to_dict()["gap_detail"]["before"]["estimation"]
    assert 0 < detail["position"]["q"] < 0.01 and 0 < detail["velocity"]["q"] < 1.0


# -- flexible_mode: a resonance the model lacks, named with the ringing's frequency ----------------------

def closed_loop(A: np.ndarray, B: np.ndarray, rows: list[int], controller: Controller, period: float,
                own: float) -> tuple[float, float]:
    """Damped frequency (Hz) and damping ratio of the closed-loop mode nearest ``own`` (rad/s) of the plant
    ẋ = A·x + B·τ (x = [q, q̇]) under the experiment's PD ``controller`` on coordinates ``rows`` (its 2-tap
    velocity filter, no delay, unit gain), sampled with zero-order hold at ``period``: the test's own
    discrete closed loop, independent of the workflow's (symbolic/workflow/modes.py)."""
    import scipy.signal

    # the loop written out below is this one: refuse any other rather than model it wrongly
    assert controller.kind == "pd" and controller.size == len(rows) and controller.delay == 0, controller.describe()
    assert len(controller.velocity_filter) == 2 and all(g == 1 for g in controller.gain), controller.describe()
    n, m = A.shape[0], len(rows)
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, np.eye(n), np.zeros((n, B.shape[1]))), period, "zoh")
    kp, kd, (a, b) = controller.kp, controller.kd, controller.velocity_filter
    # state: x (n), q_{k-1} (m), v_{k-1} (m); u_k = −kp·q_k − kd·(a·v_k + b·v_{k−1}), v_k = (q_k − q_{k−1})/T
    size = n + 2 * m
    G = np.zeros((m, size))  # u_k as a function of the state
    for i, r in enumerate(rows):
        G[i, r] = -kp[i] - kd[i] * a / period
        G[i, n + i] = kd[i] * a / period
        G[i, n + m + i] = -kd[i] * b
    M = np.zeros((size, size))
    M[:n, :n] = Ad
    M[:n] += Bd[:, rows] @ G
    for i, r in enumerate(rows):
        M[n + i, r] = 1.0
        M[n + m + i, r], M[n + m + i, n + i] = 1 / period, -1 / period
    s = np.log(np.linalg.eigvals(M).astype(complex)) / period
    s = s[s.imag > 1e-9]
    best = s[np.argmin(np.abs(np.log(np.abs(s) / own)))]
    return float(best.imag / (2 * np.pi)), float(-best.real / abs(best))


def ringing(J: float, load: float, k: float, c: float, viscous: float, controller: Controller,
            period: float) -> tuple[float, float]:
    """The closed-loop ringing of a motor of inertia ``J`` with a load on a spring ``k`` and damper ``c``
    (coordinates: motor angle q, deflection x; the load turns at q + x), written out by hand."""
    D = np.array([[J + load, load], [load, load]])
    K, C = np.diag([0.0, k]), np.diag([viscous, c])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(D, K), -np.linalg.solve(D, C)]])
    B = np.vstack([np.zeros((2, 2)), np.linalg.inv(D)])
    return closed_loop(A, B, [0], controller, period, np.sqrt(k / load))


FLEX = {"load": 0.03, "frequency": 8.0, "damping": 0.05}


@pytest.mark.slow
def test_flexible_mode_on_an_axis(tmp_path: Path) -> None:
    """A load on a compliant coupling (8 Hz with the motor held, ζ = 0.05), excited by pulses on the drive:
    flexible_mode is named on q with the closed-loop ringing's frequency (3 %) and damping (15 %), the
    load's own mode and inertia are recovered, and the patched model's closed-loop mode is the ringing's."""
    truth = cases.with_load(cases.axis(), "q", "rotor", FLEX["load"], FLEX["frequency"], FLEX["damping"])
    data = cases.measurements(truth, 3, 0.01, measured=("q",), pulses=0.5)
    w = 2 * np.pi * FLEX["frequency"]
    k, c = FLEX["load"] * w**2, 2 * FLEX["damping"] * w * FLEX["load"]
    frequency, damping = ringing(0.05, FLEX["load"], k, c, 0.3, data.controller, data.sample_period)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", symbolic.ModelWarning)
        d = diagnose(cases.model_file(tmp_path, cases.axis()), data, out=tmp_path / "out", figures=False)
    check(d, "flexible_mode", "q", {})
    found = d.found[0]
    assert found.parameters["frequency_hz"] == pytest.approx(frequency, rel=0.03), (found.parameters, frequency)
    assert found.parameters["damping_ratio"] == pytest.approx(damping, rel=TOLERANCE), (found.parameters, damping)
    assert found.evidence["load_frequency_hz"] == pytest.approx(FLEX["frequency"], rel=0.03)
    assert found.evidence["load_damping_ratio"] == pytest.approx(FLEX["damping"], rel=TOLERANCE)
    assert found.evidence["load"] == pytest.approx(FLEX["load"], rel=TOLERANCE)
    patched = symbolic.load(d.patched_path)
    assert patched.generalized_coordinates == ("q", "q_flex")
    values = {p.name: p.value for p in patched.parameters}
    assert values["J"] == pytest.approx(0.05, rel=TOLERANCE)
    again = ringing(values["J"], values["J_q_load"], values["k_q_load"], values["d_q_load"], values["Fv"],
                    data.controller, data.sample_period)
    assert again[0] == pytest.approx(frequency, rel=0.03)


# -- payload: a point mass missing at the end effector ---------------------------------------------------

def fixed_arm(extra: str = "", end_effector: bool = True) -> str:
    """The two-link arm with an end effector at the tip of link 2 (unless ``end_effector=False``) and link
    2's inertial parameters written inline (fixed): with them free, a payload at the tip is in the model's
    span (it only changes them)."""
    tip = '[end_effector]\nframe = "2"\npoint = ["0", "0", "0"]\n' if end_effector else ""
    text = cases.arm(extra=tip + extra)
    for old, new in (('mass = "m2"', 'mass = "2.0"'), ('com = ["c2 - 0.3", "0", "0"]', 'com = ["-0.15", "0", "0"]'),
                     ('inertia = { zz = "I2" }', 'inertia = { zz = "0.02" }')):
        assert old in text
        text = text.replace(old, new)
    return text


@pytest.mark.slow
def test_payload_on_an_arm(tmp_path: Path) -> None:
    truth = fixed_arm('\n[[body]]\nname = "tool"\nframe = "2"\nmass = "0.5"\n')
    d = run(tmp_path, fixed_arm(), truth, seed=4)
    check(d, "payload", "q2", {"mass": 0.5}, same_fit=False)
    patched = symbolic.load(d.patched_path)
    (tool,) = [b for b in patched.bodies if b.name == "payload"]
    assert tool.frame == "2" and str(tool.mass) == "m_payload"
    for c in ("q1", "q2"):  # the weight and inertia of a tip mass act on both joints: both gaps fall
        assert d.after.detail["validation"][c] < 0.5 * d.before.detail["validation"][c]


@pytest.mark.slow
def test_payload_without_an_end_effector(tmp_path: Path) -> None:
    """Issue 21 §5: 0.15 kg at the tip of the arm, the model without [end_effector]. The payload is a rigid
    body on the chain's last body (frame 2); with link 1's parameters free, three combinations of its
    standard parameters are left, which give its mass and its centre of mass in the plane when its own
    inertia is taken as zero (a point mass). Named instead of `inertia` terms; the mass within 3σ of the
    truth and 5 %; the held-out gap falls to within 10 % of the true model's own (identified the same way)."""
    tool = '\n[[body]]\nname = "tool"\nframe = "2"\nmass = "0.15"\n'
    model, truth = fixed_arm(end_effector=False), fixed_arm(tool, end_effector=False)
    d = run(tmp_path, model, truth)
    assert [(f.effect, f.coordinate) for f in d.found] == [("payload", "q2")], [(f.effect, f.coordinate) for f in d.found]
    found = d.found[0]
    mass, sigma = found.parameters["mass"], found.sigmas["mass"]
    assert abs(mass - 0.15) <= 3 * sigma and mass == pytest.approx(0.15, rel=0.05), (mass, sigma)
    assert found.evidence["payload"]["frame"] == "2" and found.evidence["payload"]["model"] == "point mass"
    assert found.parameters["com_z"] is None and all(found.parameters[k] is None for k in ("ixx", "iyy", "izz"))
    for axis in ("com_x", "com_y"):  # the truth's mass sits at the frame's origin
        assert abs(found.parameters[axis]) <= 3 * found.sigmas[axis] + 1e-3, (axis, found.parameters, found.sigmas)
    true = symbolic.derive(symbolic.loads(truth, "<truth>"))
    fit = fit_nominal(model_terms(true), d.sets["estimation"])
    floor = relative_gap(d.sets["validation"].tau, fit.predict(d.sets["validation"]))
    assert d.after.gap["validation"] <= 1.1 * floor, (d.before.gap, d.after.gap, floor)
    patched = symbolic.load(d.patched_path)
    (body,) = [b for b in patched.bodies if b.name == "payload"]
    assert body.frame == "2" and (body.inertia is None or all(v == 0 for v in body.inertia.values()))


@pytest.mark.slow
def test_payload_in_the_span_of_free_link_parameters_is_not_a_candidate(tmp_path: Path) -> None:
    """With link 2's mass, centre of mass and inertia free, a payload on its frame changes only them (and
    the link-2 first moment MY2, which no parameter moves, does not give its mass): the model already
    holds it (a candidate there would be a false discovery)."""
    text = cases.arm(extra='[end_effector]\nframe = "2"\npoint = ["0", "0", "0"]\n')
    d = run(tmp_path, text, text, seed=8)
    assert d.found == ()
    (candidate,) = [c for c in d.search.rounds[0].candidates if c.effect.name == "payload" and c.coordinate == "q2"]
    # no column is left (the model holds it), or what is left does not separate the payload's mass
    assert candidate.status in ("in the model", "not applicable"), candidate.status
    assert "free parameters" in candidate.reason or "already holds it" in candidate.reason, candidate.reason


@pytest.mark.slow
def test_flexible_mode_on_one_joint_of_an_arm(tmp_path: Path) -> None:
    """A load of 0.2 kg·m² on a compliant coupling at joint 1 (8 Hz with the joint held, ζ = 0.05), pulses
    on both drives: flexible_mode named on q1 only, q2 stays clean; the ringing against the truth's
    closed loop linearised at the data's mean position."""
    from symbolic.numeric import numeric_model

    truth = cases.with_load(cases.arm(), "q1", "1", 0.2, FLEX["frequency"], FLEX["damping"])
    data = cases.measurements(truth, 4, 0.01, measured=("q1", "q2"), pulses=3.0)
    d = run_on(tmp_path, cases.arm(), data)
    check(d, "flexible_mode", "q1", {})
    found = d.found[0]
    assert found.evidence["load"] == pytest.approx(0.2, rel=TOLERANCE)
    assert found.evidence["load_frequency_hz"] == pytest.approx(FLEX["frequency"], rel=0.03)
    assert found.evidence["load_damping_ratio"] == pytest.approx(FLEX["damping"], rel=TOLERANCE)
    model = symbolic.derive(symbolic.loads(truth, "<truth>"))
    num = numeric_model(model)
    rest = np.concatenate([d.sets["estimation"].q.mean(axis=0), [0.0]])
    A, B = num.linearize(np.concatenate([rest, np.zeros(3)]), num.bias(rest, np.zeros(3)))
    frequency, damping = closed_loop(A, B[:, :3], [0, 1], data.controller, data.sample_period,
                                     2 * np.pi * FLEX["frequency"])
    assert found.parameters["frequency_hz"] == pytest.approx(frequency, rel=0.03), (found.parameters, frequency)
    assert found.parameters["damping_ratio"] == pytest.approx(damping, rel=TOLERANCE), (found.parameters, damping)
    assert d.after.detail["validation"]["q2"] <= 1.01 * d.before.detail["validation"]["q2"]


@pytest.mark.slow
def test_emps_pulse_set_resonance_is_not_a_collocated_second_mass(emps: Path) -> None:  # noqa: F811
    """The pulse set as the data (its last fifth held out): the residual's 23–33 Hz hump is tested as
    flexible_mode and fitted best near 28 Hz, but only by a negative load (a lead of the logged force
    over the motion, not a second mass ringing behind a coupling), so it is rejected as non-physical and
    direction-dependent viscous friction is what is named. The force is taken as logged (declared): the lead
    is the subject."""
    from symbolic.data.treatment import Settings

    d = diagnose(robots.path("emps"), robots.example_path("emps_pulses"), figures=False,
                 settings=Settings(held_force=False))
    assert [f.effect for f in d.found] == ["asymmetric_viscous"]
    assert d.after.gap["validation"] < d.before.gap["validation"]
    (flexible,) = [c for c in d.search.rounds[0].candidates if c.effect.name == "flexible_mode"]
    assert 20.0 < flexible.roles["frequency_hz"] < 35.0 and flexible.roles["load"] < 0
    assert flexible.share > 0.2 and flexible.p_value < flexible.trials * 1e-6
    assert any("not positive" in reason for reason in flexible.failed)


class ForceLead(Effect):
    """A lag of the real force behind the logged one, τ_logged = (1 + T·s)·τ, to first order: the column
    q⃛ with coefficient M·T (the model's inertia times the lag). Not a model element (a drive's dynamics or
    the timing of a held command, which a model file cannot hold): this test's own effect, writing nothing."""

    name, roles, axis, summary = "force_lead", ("lead",), "time", "the logged force leads the force acting: a·q⃛"

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("force_lead needs the sampling rate: use columns_at")

    def columns_at(self, signals, j, value):
        from symbolic.data.filters import central_difference

        return on_row(j, signals.qdd.shape[1], [central_difference(signals.qdd[:, j], 1.0 / signals.rate)])

    def roles_of(self, c, value, reference):
        return {"lead": float(c[0])}

    def patch(self, editor, context, j, roles, c, value, comment):
        return {}


@pytest.mark.slow
def test_a_logged_held_command_looks_like_a_negative_load(tmp_path: Path) -> None:
    """Hidden truth for the EMPS reading: a rigid axis (nothing missing) whose log holds the held command
    itself, which leads the force acting over the sample by half a sample (1 ms at 500 Hz), with pulses.
    flexible_mode's best fit is a significant resonance at the damping cap with a negative load — the
    EMPS pulse set's signature — and the physical check is what keeps it from being named; offered the
    force lead, the workflow names it with a lag of the order of the half sample (seeds 1–5: 0.9–2.1 ms;
    the jerk of a 4 Hz loop under 0.5 N·m pulses determines it loosely). The force is declared as logged
    (held_force = false): undeclared, the diagnosis would find the held command and treat it (below)."""
    from symbolic.data.treatment import Settings

    data = cases.measurements(cases.axis(), 1, 0.01, measured=("q",), pulses=0.5, held=True)
    d = run_on(tmp_path, cases.axis(), data, settings=Settings(held_force=False))
    assert d.found == ()
    (flexible,) = [c for c in d.search.rounds[0].candidates if c.effect.name == "flexible_mode"]
    assert flexible.roles["load"] < 0 and flexible.roles["damping_ratio"] == pytest.approx(max(FlexibleMode.DAMPING))
    assert flexible.p_value < 1e-3 / flexible.trials and [r for r in flexible.failed if r.startswith("physical")]
    d = run_on(tmp_path, cases.axis(), data, effects=[*EFFECTS.values(), ForceLead()], settings=Settings(held_force=False))
    assert [f.effect for f in d.found] == ["force_lead"]
    fit = d.search.final.identification
    half = 0.5 * data.sample_period
    assert 0.4 * half < d.found[0].parameters["lead"] / dict(zip(fit.names, fit.values))["ZZ_rotor"] < 2.5 * half


def test_a_held_command_is_reported_as_the_data_and_centring_it_is_exact(tmp_path: Path) -> None:
    """The rigid axis logged as its held command (nothing missing): diagnose names no effect and reports
    the data finding ``held_force``; declared, the treatment turns the held log into exactly the log of
    the force's mean over each sample (the harness's default log, noise-free here), and nothing is
    reported then."""
    from symbolic.data.treatment import Settings
    from symbolic.workflow.dataset import treat

    data = cases.measurements(cases.axis(), 1, 0.01, measured=("q",), pulses=0.5, held=True)
    d = run_on(tmp_path, cases.axis(), data)
    out = d.to_dict()
    assert out["found"] == [] and [f["finding"] for f in out["data_findings"]] == ["held_force"]
    finding = out["data_findings"][0]
    assert finding["gap_validation"]["held_force"] < finding["gap_validation"]["as_logged"]
    assert "held_force" in markdown(d)
    declared = run_on(tmp_path / "declared", cases.axis(), data, settings=Settings(held_force=True))
    assert declared.to_dict()["data_findings"] == [] and declared.found == ()
    held = cases.measurements(cases.axis(), 2, 0.0, measured=("q",), pulses=0.5, held=True, seconds=10.0)
    centred = cases.measurements(cases.axis(), 2, 0.0, measured=("q",), pulses=0.5, seconds=10.0)
    a, b = treat(held, "estimation", Settings(held_force=True)), treat(centred, "estimation")
    assert np.allclose(a.tau, b.tau, rtol=0, atol=1e-12 * np.abs(b.tau).max())


def test_nothing_held_is_reported_on_a_sampled_force(tmp_path: Path) -> None:
    d = run(tmp_path, cases.axis(), cases.axis(), seed=8, noise=0.01)
    assert d.to_dict()["data_findings"] == []


@pytest.mark.slow
def test_emps_pulse_set_force_is_found_to_be_a_held_command(emps: Path) -> None:  # noqa: F811
    """EMPS's vir is the controller's output held over each 1 ms sample: undeclared, diagnose finds it on the
    nominal model (it removes more than the search's effect size of the held-out residual power) and again on
    the patched model, treats the force as held and says so, and names no flexibility; its result is the
    declared diagnosis' (no finding left there), whose nominal gap is the smaller one the finding predicted."""
    from symbolic.data.treatment import Settings
    from symbolic.workflow.statistics import MIN_HELD_OUT_GAIN

    d = diagnose(robots.path("emps"), robots.example_path("emps_pulses"), figures=False)
    (finding,) = d.to_dict()["data_findings"]
    assert finding["finding"] == "held_force" and finding["removed_share"] >= MIN_HELD_OUT_GAIN
    assert finding["treated"] and finding["patched"]["removed_share"] >= MIN_HELD_OUT_GAIN
    assert "treated as held_force = true" in finding["note"]
    assert "flexible_mode" not in [f.effect for f in d.found]
    declared = diagnose(robots.path("emps"), robots.example_path("emps_pulses"), figures=False,
                        settings=Settings(held_force=True))
    assert declared.to_dict()["data_findings"] == []
    # the gap before holds the offset, a correction, at the file's −3.1648 where the finding's nominal fit
    # identifies it (docs/workflow.md §5): a hair above the gap the finding predicted (4.2590 % against 4.2582 %)
    assert [c["parameter"] for c in declared.corrections] == ["offset"]
    predicted = finding["gap_validation"]["held_force"]
    assert 0 <= declared.before.gap["validation"] - predicted < 1e-3 * predicted
    assert [(f.effect, f.parameters) for f in d.found] == [(f.effect, f.parameters) for f in declared.found]
    assert d.after.gap == declared.after.gap


@pytest.mark.slow
def test_emps_pulse_set_peak_is_a_lead_of_the_logged_force(emps: Path) -> None:  # noqa: F811
    """The pulse set's 23–25 Hz residual peak is the motion's own jerk (the closed loop's ≈ 20 Hz mode excited by
    the pulses, weighted by frequency) seen through a lead of the logged force over the force acting, not a
    flexibility (bench/emps_resonance.py: a non-collocated compliance fits only overdamped, ζ ≥ 0.6). Offered
    a first-order force lead beside the catalogue, the workflow names it first; its lag is positive and
    shorter than the 1 ms sample period (a held command leads the force it produces by half a sample; a
    current loop adds a fraction of a millisecond); with it the collocated resonance is no longer
    significant, and the residual has no spectral peak left in the band. The force is taken as logged
    (declared): the lead is the subject."""
    from symbolic.data.treatment import Settings
    from symbolic.workflow.where import localise

    d = diagnose(robots.path("emps"), robots.example_path("emps_pulses"), figures=False,
                 effects=[*EFFECTS.values(), ForceLead()], settings=Settings(held_force=False))
    assert [f.effect for f in d.found][0] == "force_lead" and "flexible_mode" not in [f.effect for f in d.found]
    fit = d.search.final.identification
    mass = dict(zip(fit.names, fit.values))["M_carriage"]
    lag = d.found[0].parameters["lead"] / mass
    assert 70.0 < mass < 120.0 and 0.0 < lag < 1e-3, (mass, lag)
    later = [c for r in d.search.rounds[1:] for c in r.candidates if c.effect.name == "flexible_mode" and c.status == "tested"]
    assert later and all(any(reason.startswith("significance") for reason in c.failed) for c in later)

    def band_peaks(where: dict) -> list[dict]:
        return [p for p in where["coordinates"]["q"]["spectrum"]["peaks"] if 15.0 <= p["frequency_hz"] <= 35.0]

    assert band_peaks(d.where_before), d.where_before["coordinates"]["q"]["spectrum"]
    final = localise(d.sets["estimation"], d.search.final.predicted("estimation"))
    assert not band_peaks(final), final["coordinates"]["q"]["spectrum"]


@pytest.mark.slow
def test_a_resonance_and_coulomb_friction_at_once(tmp_path: Path) -> None:
    """The flexible axis of test_flexible_mode_on_an_axis, its model lacking Coulomb friction too: both named."""
    truth = cases.with_load(cases.axis(), "q", "rotor", FLEX["load"], FLEX["frequency"], FLEX["damping"])
    d = run_on(tmp_path, cases.axis(parameters="Fv = 0.3\n", friction='viscous = "Fv"'),
               cases.measurements(truth, 5, 0.01, measured=("q",), pulses=0.5))
    found = {f.effect: f for f in d.found}
    assert set(found) == {"coulomb", "flexible_mode"}, list(found)
    assert found["coulomb"].parameters["coulomb"] == pytest.approx(0.4, rel=TOLERANCE)
    assert found["flexible_mode"].evidence["load_frequency_hz"] == pytest.approx(FLEX["frequency"], rel=0.03)
    assert d.after.gap["validation"] <= 0.5 * d.before.gap["validation"]


# -- the flexible single link: its first bending mode, missing from the rigid model ------------------------

LINK = {"tip_mass": 1.0, "damper": 30.0, "pulses": 2.0}


def cantilever_mode(l: float, rho: float, EI: float, tip: float) -> tuple[float, float]:
    """First bending mode of a clamped-free Euler–Bernoulli beam with a point mass at its tip, the clamp
    held (the hub locked): frequency (Hz) from the characteristic equation 1 + cos λ cosh λ
    + μλ(cos λ sinh λ − sin λ cosh λ) = 0 (μ = tip / (ρl), λ = βl), and the hub-side inertia of the mode,
    (∫ρxφ dx + tip·l·φ(l))² / (∫ρφ² dx + tip·φ(l)²): what a rigid hub feels of it through the clamp."""
    import scipy.optimize

    mu = tip / (rho * l)

    def characteristic(x: float) -> float:
        return 1 + np.cos(x) * np.cosh(x) + mu * x * (np.cos(x) * np.sinh(x) - np.sin(x) * np.cosh(x))

    lam = scipy.optimize.brentq(characteristic, 1e-3, 1.875104)  # the root without a tip mass bounds it
    beta = lam / l
    sigma = (np.cosh(lam) + np.cos(lam)) / (np.sinh(lam) + np.sin(lam))  # zero moment at the tip
    x = np.linspace(0.0, l, 20001)
    phi = np.cosh(beta * x) - np.cos(beta * x) - sigma * (np.sinh(beta * x) - np.sin(beta * x))
    coupling = rho * np.trapezoid(x * phi, x) + tip * l * phi[-1]
    mass = rho * np.trapezoid(phi**2, x) + tip * phi[-1] ** 2
    return float(lam**2 * np.sqrt(EI / (rho * l**4)) / (2 * np.pi)), float(coupling**2 / mass)


@pytest.mark.slow
def test_flexible_mode_of_the_flexible_single_link(tmp_path: Path) -> None:
    """Data from the flexible single link (Madill's beam on its hub, a 1 kg tip mass, a damper on the first
    modal coordinate), simulated in closed loop under a PD on the hub with pulses on the drive; the workflow
    gets the rigid counterpart (hub, beam and tip mass as one body of the same inertia): flexible_mode is
    named on q0, the ringing's closed-loop frequency within 3 % and damping within 15 % of the truth's own
    closed loop (its linearisation under the same discrete PD, hub encoder only), the mode with the hub
    held and its hub-side inertia against the beam's characteristic equation (3 %, 15 %), and the held-out
    gap at least halves."""
    from symbolic.numeric import numeric_model

    values = {p.name: float(p.value) for p in symbolic.load(robots.path("single_flexible_link")).parameters}
    l, rho, EI, hub = values["l"], values["rho"], values["EIv"], values["I_h"]
    tip = LINK["tip_mass"]
    truth = cases.flexible_link(tip, LINK["damper"])
    data = cases.measurements(truth, 1, 0.01, measured=("q0",), pulses=LINK["pulses"])
    d = run_on(tmp_path, cases.rigid_link(hub + rho * l**3 / 3 + tip * l**2), data)
    check(d, "flexible_mode", "q0", {})
    found = d.found[0]
    held, load = cantilever_mode(l, rho, EI, tip)
    assert found.evidence["load_frequency_hz"] == pytest.approx(held, rel=0.03), (found.evidence, held)
    assert found.evidence["load"] == pytest.approx(load, rel=TOLERANCE), (found.evidence, load)
    # the ringing: the truth linearised at rest (the vertical mode, uncoupled at rest, left out: it does not
    # show on the hub), closed by the data's PD loop
    model = symbolic.derive(symbolic.loads(truth, "<truth>"))
    num, n = numeric_model(model), model.n
    rest = np.zeros(n)
    A, B = num.linearize(np.zeros(2 * n), num.bias(rest, np.zeros(n)))
    names = list(model.robot.generalized_coordinates)
    keep = [k for k, c in enumerate(names) if c != "link_eta1"]
    rows, other = keep + [n + k for k in keep], [names.index("link_eta1"), n + names.index("link_eta1")]
    assert np.allclose(A[np.ix_(rows, other)], 0) and np.allclose(A[np.ix_(other, rows)], 0)
    frequency, damping = closed_loop(A[np.ix_(rows, rows)], B[np.ix_(rows, keep)], [0], data.controller,
                                     data.sample_period, 2 * np.pi * held)
    assert found.parameters["frequency_hz"] == pytest.approx(frequency, rel=0.03), (found.parameters, frequency)
    assert found.parameters["damping_ratio"] == pytest.approx(damping, rel=TOLERANCE), (found.parameters, damping)
    assert symbolic.load(d.patched_path).generalized_coordinates == ("q0", "q0_flex")


def test_the_flexible_link_without_its_deflection_is_refused(tmp_path: Path) -> None:
    """Given the flexible model and a log without its modal coordinates, the workflow stops with the data's
    one-line error: IDIM-LS needs every coordinate's q̈, and a beam's deflection must be logged (docs/data.md,
    "Flexible links")."""
    data = cases.measurements(cases.axis(), 1, 0.01, seconds=2.0)
    data = dataclasses.replace(data, coordinates=("q0",))
    with pytest.raises(symbolic.DataError, match=r"coordinates: no signal for coordinates link_nu1, link_nu2, link_eta1"):
        run_on(tmp_path, cases.flexible_link(1.0, 30.0), data)
    assert not (tmp_path / "out").exists()


# -- the flexible link itself, its deflection logged ----------------------------------------------------

def rig_data(seed: int = 1):
    """The planar rig (workflow_cases.planar_flexible_link) in its PD loop with 0.1 N·m pulses on the hub,
    1 % force noise; the log holds the hub angle (20-bit encoder) and the modal coordinate, unactuated, as
    a root strain gauge gives it (docs/data.md), with 0.1 % noise."""
    return cases.measurements(cases.planar_flexible_link(), seed, 0.01, measured=("q0",), pulses=0.1,
                              unactuated=("link_nu1",), deflection_noise=1e-3)


def test_flexible_link_that_is_the_truth_names_nothing(tmp_path: Path) -> None:
    d = run_on(tmp_path, cases.planar_flexible_link(), rig_data())
    assert d.found == (), [(f.effect, f.coordinate) for f in d.found]
    assert d.after.gap == d.before.gap and d.before.gap["validation"] < 1.0
    assert symbolic.load(d.patched_path).beams[0].modes_w == 0


def test_missing_structural_damping_is_named_on_the_modal_coordinate(tmp_path: Path) -> None:
    """The beam's damper (c_b·ν̇ on the modal coordinate) left out of the model: viscous friction on link_nu1
    with the damper's value (3.3 N·s/m^(1/2)·…, the units of the modal force); the held-out gap falls to the
    truth's (seeds 1, 2, 5, 6 name it; seed 4 names a flexible_mode on q0 at 8.54 Hz instead, seed 3 too
    with the vertical mode modelled)."""
    d = run_on(tmp_path, cases.planar_flexible_link(damped=False), rig_data())
    assert [(f.effect, f.coordinate) for f in d.found] == [("viscous", "link_nu1")], [(f.effect, f.coordinate) for f in d.found]
    assert d.found[0].parameters["viscous"] == pytest.approx(3.3, rel=0.1), d.found[0].parameters
    assert d.after.gap["validation"] < 0.7 * d.before.gap["validation"], (d.before.gap, d.after.gap)
    patched = symbolic.derive(symbolic.load(d.patched_path))
    assert [f.coordinate for f in patched.robot.frictions] == ["q0", "link_nu1"]


def test_missing_hub_friction_is_named_beside_the_beam(tmp_path: Path) -> None:
    model = cases.planar_flexible_link().replace('[[friction]]\ncoordinate = "q0"\nviscous = "Fv"\n', "")
    d = run_on(tmp_path, model, rig_data())
    check(d, "viscous", "q0", {"viscous": 0.5})

"""Excitation design (symbolic excite, symbolic.identify.excitation): constraints, exact gradients, the
information matrix against identify's own regressor, improvement over its start and a naive sine, predicted σ
against a Monte-Carlo of identify on noisy simulated logs, and the errors of bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

import models
import symbolic
from shared_data import emps  # noqa: F401  (fixture)
from symbolic.cli import main
from symbolic.data import Measurements
from symbolic.errors import IdentificationError
from symbolic.identify import excitation as ex
from symbolic.identify.excitation_noise import Noise, equivalent_noise, predict, treatment
from symbolic.identify.excitation_report import Declared, excite, read_declarations, reference_samples, report
from symbolic.identify.model import base_regressor, identify_model, model_base

LIMITS = {"position": {"q1": (-1.5, 1.5), "q2": (-2.0, 2.0)}, "velocity": {"q1": 2.0, "q2": 2.5},
          "acceleration": {"q1": 8.0, "q2": 10.0}, "torque": {"q1": 20.0, "q2": 8.0}}
NOISE = {"force_noise": {"q1": 0.2, "q2": 0.1}, "resolution": {"q1": 0.0, "q2": 0.0}}
RATE = 1000.0  # the Monte-Carlo log: 400 decimated rows per coordinate (docs/data.md, "Predicted σ")
EXPERIMENT = """[excitation]
rate = 200.0
position = { q1 = [-1.5, 1.5], q2 = [-2.0, 2.0] }
velocity = { q1 = 2.0, q2 = 2.5 }
acceleration = { q1 = 8.0, q2 = 10.0 }
torque = { q1 = 20.0, q2 = 8.0 }
force_noise = { q1 = 0.2, q2 = 0.1 }
"""


@pytest.fixture(scope="module")
def arm() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.loads(models.arm(), "arm"))


@pytest.fixture(scope="module")
def smooth_arm() -> symbolic.DynamicModel:
    """The arm with viscous friction only: a regressor differentiable everywhere (no sign(q̇))."""
    text = models.arm(parameters="Fv1 = 0.8\nFv2 = 0.5\n", friction1='viscous = "Fv1"', friction2='viscous = "Fv2"')
    return symbolic.derive(symbolic.loads(text, "arm"))


@pytest.fixture(scope="module")
def designed(arm):
    """One design of the arm: 4 s, 3 harmonics, 2 starts (seeded), the declared noise's weights."""
    declared = Declared("test", ex_table(), symbolic.data.Settings())
    return excite(arm, declared, 4.0, harmonics=3, starts=2, seed=3)


def ex_table():
    from symbolic.data.excitation import ExcitationTable

    return ExcitationTable({**LIMITS, **NOISE}, RATE)


def test_rest_is_exact_for_any_coefficients() -> None:
    rng = np.random.default_rng(0)
    for harmonics in (2, 3, 5):
        z = rng.standard_normal(2 * (2 * harmonics - 1))
        trajectory = ex.FourierTrajectory.from_free(("a", "b"), 3.0, harmonics, z)
        q, qd, qdd = trajectory.evaluate(np.array([0.0, 3.0]))
        assert np.abs(qd).max() < 1e-13 and np.abs(qdd).max() < 1e-12
        assert np.allclose(q[0], q[1], atol=1e-12)  # periodic
        assert np.allclose(trajectory.a.sum(axis=1), 0, atol=1e-14)


def test_design_respects_the_limits_on_a_fine_grid(arm, designed) -> None:
    design = designed.design
    t = np.linspace(0.0, 4.0, 40_001)
    q, qd, qdd = design.trajectory.evaluate(t)
    tau = base_regressor(arm)(q, qd, qdd) @ model_base(arm)[1].values  # identify's regressor, not the CasADi one
    names = ("q1", "q2")
    for i, c in enumerate(names):
        lower, upper = LIMITS["position"][c]
        assert lower - 1e-9 <= q[:, i].min() and q[:, i].max() <= upper + 1e-9
        assert np.abs(qd[:, i]).max() <= LIMITS["velocity"][c] * (1 + 1e-6)
        assert np.abs(qdd[:, i]).max() <= LIMITS["acceleration"][c] * (1 + 1e-6)
        assert np.abs(tau[:, i]).max() <= LIMITS["torque"][c] * (1 + 1e-6)
    start = design.trajectory.evaluate(np.array([0.0, 4.0]))
    assert np.abs(start[1]).max() < 1e-12 and np.abs(start[2]).max() < 1e-12  # at rest at both ends, exactly
    assert max(v.max() for v in design.worst.values()) > 0.9  # the design uses its room


def test_design_improves_on_its_start_and_on_a_naive_sine(arm, designed) -> None:
    design = designed.design
    assert design.value < design.start_value - 5.0  # −log det of M per grid point: det grew by e^5 at least
    naive = naive_sine(arm, 4.0)
    sigma = designed.predicted.noise
    t, q, qd, qdd = reference_samples(naive, RATE)
    sine = predict(arm, "sine", q, qd, qdd, sigma, 4.0, treatment(RATE, len(t)))
    assert designed.predicted.log_det > sine.log_det + 5.0
    assert designed.predicted.condition_number < sine.condition_number


def naive_sine(model, period: float) -> ex.FourierTrajectory:
    """One sine per coordinate at the fundamental, joint 2 at twice the frequency, as large as the limits allow."""
    limits = ex.resolve_limits(model, ("test", LIMITS))
    regressor = ex.casadi_regressor(model)
    amplitude = np.array([1.0, 1.0])
    for _ in range(60):
        a = np.zeros((2, 2))
        a[0, 0], a[1, 1] = amplitude[0], amplitude[1]
        trajectory = ex.FourierTrajectory(("q1", "q2"), period, np.zeros(2), a, np.zeros((2, 2)))
        ratios = ex.violation(regressor, trajectory, limits, np.linspace(0, period, 4000))
        worst = np.max(np.vstack(list(ratios.values())), axis=0)
        if worst.max() <= 1.0:
            return trajectory
        amplitude = amplitude / np.maximum(worst, 1.0) * 0.999
    raise AssertionError("no naive sine inside the limits")


def _gradient_and_central_differences(problem) -> tuple[np.ndarray, np.ndarray]:
    """The design's criterion gradient at a random start, and its central differences (steps 1e-5 relative)."""
    z = ex.random_start(np.random.default_rng(1), problem)
    h = 1e-5 * np.maximum(1.0, np.abs(z))
    finite = np.array([(problem.value(z + h[i] * e) - problem.value(z - h[i] * e)) / (2 * h[i])
                       for i, e in enumerate(np.eye(len(z)))])
    return problem.gradient(z), finite


@pytest.mark.parametrize("criterion", ["d", "a", "condition", "dc"])
def test_gradient_against_central_differences(smooth_arm, criterion) -> None:
    limits = ex.resolve_limits(smooth_arm, ("test", LIMITS))
    regressor = ex.casadi_regressor(smooth_arm)
    problem = ex.Problem(regressor, limits, 3.0, 3, np.linspace(0, 3.0, 60, endpoint=False), np.array([1.0, 4.0]),
                         criterion)
    gradient, finite = _gradient_and_central_differences(problem)
    assert np.linalg.norm(gradient - finite) <= 1e-6 * np.linalg.norm(finite)


def test_soft_condition_bounds_the_log_condition_number_with_its_gradient() -> None:
    """log cond ≤ soft_condition ≤ log cond + (log b)/p on random information matrices (well and badly
    conditioned, a double extreme eigenvalue included), and its gradient against central differences."""
    from symbolic.identify.excitation_criteria import SOFTNESS, soft_condition

    rng = np.random.default_rng(5)
    for spread in (0.5, 4.0):
        V = np.linalg.qr(rng.standard_normal((9, 9)))[0]  # noqa: N806
        values = np.exp(spread * rng.standard_normal(9))
        values[1] = values[0] = values.max()  # a double largest eigenvalue: where ½ log λ_max/λ_min has no gradient
        M = (V * values) @ V.T  # noqa: N806
        value, gradient = soft_condition(M)
        exact = 0.5 * np.log(values.max() / values.min())
        assert exact <= value <= exact + np.log(9) / SOFTNESS
        E = rng.standard_normal((9, 9))  # noqa: N806
        E = 1e-6 * (E + E.T) * values.min()  # noqa: N806
        finite = (soft_condition(M + E)[0] - soft_condition(M - E)[0]) / 2
        assert finite == pytest.approx(np.sum(gradient * E), rel=1e-6)


def test_information_matrix_equals_identify_regressor(arm) -> None:
    rng = np.random.default_rng(2)
    q, qd, qdd = rng.uniform(-2, 2, (3, 300, 2))
    weights = np.array([0.7, 3.0])
    ours = ex.information_matrix(ex.casadi_regressor(arm), q, qd, qdd, weights)
    Y = base_regressor(arm)(q, qd, qdd)  # noqa: N806
    theirs = np.einsum("kjp,j,kjr->pr", Y, weights, Y)
    assert np.abs(ours - theirs).max() <= 1e-9 * np.abs(theirs).max()


def test_predicted_sigma_agrees_with_monte_carlo_of_identify(arm, designed) -> None:
    """Noisy logs of the design (τ = Wβ at the reference plus white force noise of the declared σ per coordinate),
    each identified by identify_model: the spread of the estimates against the predicted σ."""
    t, q, qd, qdd = designed.samples()
    _, base = model_base(arm)
    tau = base_regressor(arm)(q, qd, qdd) @ base.values
    sigma = np.array([NOISE["force_noise"]["q1"], NOISE["force_noise"]["q2"]])
    rng = np.random.default_rng(5)
    estimates = []
    for _ in range(150):
        noisy = tau + rng.standard_normal(tau.shape) * sigma
        log = Measurements.from_arrays(t, ("q1", "q2"), q, noisy)
        estimates.append(identify_model(arm, log, method="wls").identification.values)
    spread = np.std(np.array(estimates), axis=0, ddof=1)
    predicted = designed.predicted
    checked = 0
    for k, name in enumerate(predicted.names):
        if predicted.relative[k] < 50.0:
            assert abs(spread[k] / predicted.sigmas[k] - 1.0) < 0.2, (name, spread[k], predicted.sigmas[k])
            checked += 1
    assert checked >= 6


def test_quantisation_enters_through_the_inertia(arm) -> None:
    noise = Noise(("q1", "q2"), np.array([0.1, 0.1]), np.array([1e-4, 0.0]), 1000.0)
    p = treatment(1000.0, 4001)
    quantised = equivalent_noise(arm, noise, p, [np.zeros(2)])
    plain = equivalent_noise(arm, Noise(("q1", "q2"), noise.force, np.zeros(2), 1000.0), p, [np.zeros(2)])
    assert np.all(quantised > plain) and np.allclose(plain, 0.1)


def test_model_file_limits_are_read(tmp_path) -> None:
    model = symbolic.derive(symbolic.loads(models.general_frames(), "g"))
    found = ex.model_file_limits(model)
    assert found["position"]["q1"] == (-3.0, 3.0)
    with pytest.raises(IdentificationError, match=r"no position limit for coordinates q2, q3, q4.*--position q2=-1.0:1.0"):
        ex.resolve_limits(model)


# -- the command line --------------------------------------------------------------------------------------


@pytest.fixture()
def files(tmp_path):
    (tmp_path / "arm.toml").write_text(models.arm())
    (tmp_path / "exp.toml").write_text(EXPERIMENT)
    return tmp_path


def test_command_writes_the_folder_and_simulate_reads_it(files, capsys) -> None:
    out = files / "design"
    t = np.arange(1000) / 200.0  # an existing log: a slow sine on each joint, identify's canonical columns
    q = np.column_stack([0.8 * np.sin(2 * np.pi * 0.3 * t), 1.0 * np.sin(2 * np.pi * 0.5 * t)])
    np.savetxt(files / "old.csv", np.column_stack([t, q, np.sin(t), np.cos(t)]), delimiter=",",
               header="t,q_q1,q_q2,tau_q1,tau_q2", comments="")
    code = main(["-q", "excite", str(files / "arm.toml"), "--experiment", str(files / "exp.toml"), "--duration", "3",
                 "--harmonics", "2", "--starts", "1", "--out", str(out), "--compare", str(files / "old.csv"), "--json"])
    assert code == 0, capsys.readouterr().err
    result = json.loads(capsys.readouterr().out)
    assert result["design"]["criterion"] == "d"
    assert result["compare"]["label"] == "log old.csv" and set(result["compare"]["parameters"]) == set(result["predicted"]["parameters"])
    assert "σ % log old.csv" in (out / "report.md").read_text()
    header = (out / "trajectory.csv").read_text().splitlines()[1]
    assert header == "t,ref_q1,ref_q2,qd_q1,qd_q2,qdd_q1,qdd_q2"
    assert {"report.md", "excitation.json", "trajectory.experiment.toml"} <= {p.name for p in out.iterdir()}
    loaded = symbolic.data.load(out / "trajectory.experiment.toml", model=symbolic.loads(models.arm(), "arm"))
    assert loaded.ref is not None and loaded.samples == 601


@pytest.mark.parametrize("options, message", [
    (["--velocity", "q3=2"], "--velocity: coordinate: unknown coordinate 'q3' (the model's: q1, q2)"),
    (["--duration", "0"], "--duration: the reference's period T must be a time > 0 s, got 0.0"),
    (["--harmonics", "1"], "--harmonics: at least 2 harmonics"),
    (["--criterion", "e"], "--criterion: unknown criterion 'e' (allowed: d, a, condition, dc)"),
])
def test_bad_options_are_one_line_and_write_nothing(files, capsys, options, message) -> None:
    out = files / "design"
    argv = ["-q", "excite", str(files / "arm.toml"), "--experiment", str(files / "exp.toml"), "--duration", "3",
            "--out", str(out), *options]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_missing_limits_are_named(files, capsys) -> None:
    out = files / "design"
    assert main(["-q", "excite", str(files / "arm.toml"), "--duration", "3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no position limit for coordinates q1, q2: declare it in the experiment's [excitation] table" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()
    (files / "partial.toml").write_text(EXPERIMENT.replace("acceleration = { q1 = 8.0, q2 = 10.0 }\n",
                                                           "acceleration = { q1 = 8.0 }\n"))
    assert main(["-q", "excite", str(files / "arm.toml"), "--experiment", str(files / "partial.toml"), "--duration",
                 "3", "--out", str(out)]) == 2
    assert "no acceleration limit for coordinate q2" in capsys.readouterr().err and not out.exists()


def test_unknown_coordinate_in_the_experiment_is_refused(files) -> None:
    (files / "bad.toml").write_text(EXPERIMENT.replace("torque = { q1", "torque = { q9 = 1.0, q1"))
    with pytest.raises(symbolic.data.DataError, match=r"\[excitation\] torque.q9: unknown coordinate"):
        read_declarations(files / "bad.toml", ("q1", "q2"))


CONTROLLER = """
[controller]
kind = "pd"
kp = [150.0, 60.0]
kd = [8.0, 3.0]
reference = "ref"
saturation = [{s1}, 80.0]
"""


@pytest.mark.slow  # the closed loop is compiled (about 10 s in a fresh cache)
def test_the_design_is_checked_in_the_loop_and_simulate_reads_it(files, capsys) -> None:
    """Torque limits far away (the kinematic limits bind): the PD loop's force stays below them and its outputs
    below their saturation."""
    (files / "loop.toml").write_text(EXPERIMENT + CONTROLLER.format(s1=150.0))
    out = files / "design"
    assert main(["-q", "excite", str(files / "arm.toml"), "--experiment", str(files / "loop.toml"), "--duration", "3",
                 "--harmonics", "2", "--starts", "1", "--torque", "q1=200,q2=100", "--out", str(out), "--json"]) == 0
    loop = json.loads(capsys.readouterr().out)["loop"]
    assert not loop["refused"] and loop["coordinates"]["q1"]["peak_torque"] <= 150.0
    assert 0 < loop["coordinates"]["q1"]["tracking_max"] < 1.0
    assert "[controller]" in (out / "trajectory.experiment.toml").read_text()
    assert main(["-q", "simulate", str(files / "arm.toml"), str(out / "trajectory.experiment.toml"), "--json"]) == 0


@pytest.mark.slow
def test_a_design_that_saturates_in_the_loop_is_refused(files, capsys) -> None:
    (files / "loop.toml").write_text(EXPERIMENT + CONTROLLER.format(s1=10.0))
    out = files / "design"
    assert main(["-q", "excite", str(files / "arm.toml"), "--experiment", str(files / "loop.toml"), "--duration", "3",
                 "--harmonics", "2", "--starts", "1", "--torque", "q1=200,q2=100", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "the design saturates in the loop of the experiment's [controller] (pd on q1, q2" in err
    assert "q1 peak |τ| 10 reaches the controller's output limit 10 (|gain|·saturation)" in err and "--torque q1=9.5" in err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


def test_constraint_jacobian_against_casadi_ad(arm) -> None:
    """The Jacobian assembled from the structure equals CasADi's AD of the same constraints, dense and as the
    sparse matrix IPOPT is given."""
    import casadi as ca

    limits = ex.resolve_limits(arm, ("test", LIMITS))
    regressor = ex.casadi_regressor(arm)
    grid = np.linspace(0, 3.0, 40, endpoint=False)
    problem = ex.Problem(regressor, limits, 3.0, 3, grid, np.ones(2), "d")
    z = ex.random_start(np.random.default_rng(4), problem)
    ours = problem.constraints.jacobian(z)
    x = ca.MX.sym("z", len(z))
    C = ca.mtimes(ca.DM(ex.rest_null_space(3)), ca.reshape(x, 5, 2))  # noqa: N806
    states = [ca.mtimes(ca.DM(m), C) for m in ex.basis(grid, 3.0, 3)]
    tau = regressor.torque.map(len(grid))(*(s.T for s in states)).T
    g = ca.vertcat(*(ca.vec(v) for v in (*states, tau)))
    reference = np.asarray(ca.Function("J", [x], [ca.jacobian(g, x)])(z))
    assert np.abs(ours - reference).max() <= 1e-10 * np.abs(reference).max()
    given = ex._ConstraintJacobian("J", problem.constraints)(z, problem.constraints(z))  # what IPOPT gets: sparse
    assert np.abs(np.asarray(ca.densify(given)) - reference).max() <= 1e-10 * np.abs(reference).max()
    assert np.allclose(np.asarray(problem.constraints(z)).ravel(), np.asarray(ca.Function("g", [x], [g])(z)).ravel())


def test_a_start_over_a_limit_is_scaled_inside(arm) -> None:
    """The last resort of a start still over a limit after its re-solves (excitation._shrink): a random reference
    whose amplitudes are made 2 % larger than its tightest limit allows ends inside every limit on the verification
    grid, scaled by less than 1, its offsets unchanged."""
    # no torque limit: the arm's τ is mostly gravity's, which scaling the amplitudes does not bring within a limit
    limits = ex.resolve_limits(arm, ("test", {**LIMITS, "torque": {"q1": np.inf, "q2": np.inf}}))
    grid = np.linspace(0, 3.0, 60, endpoint=False)
    problem = ex.Problem(ex.casadi_regressor(arm), limits, 3.0, 3, grid, np.ones(2), "d")
    fine = np.linspace(0, 3.0, ex.FINER * len(grid), endpoint=False)

    def worst_ratio(free: np.ndarray) -> float:
        return max(float(v.max()) for v in ex.violation(problem.exact, problem.trajectory(free), limits, fine).values())

    z = ex.random_start(np.random.default_rng(6), problem).reshape(2, -1)
    z[:, 1:] *= 1.02 / worst_ratio(z.ravel())
    before = worst_ratio(z.ravel())
    shrunk, worst, _, scale = ex._shrink(problem, z.ravel(), fine)
    after = worst_ratio(shrunk)
    assert before > 1.0 + ex.TOLERANCE
    assert after == pytest.approx(worst) and after <= 1.0 + ex.TOLERANCE
    assert scale < 1.0
    np.testing.assert_array_equal(shrunk.reshape(2, -1)[:, 0], z[:, 0])


def test_the_same_seed_gives_the_same_design(arm) -> None:
    limits = ex.resolve_limits(arm, ("test", LIMITS))
    first, second = (ex.design(arm, limits, 2.0, harmonics=2, starts=2, seed=7) for _ in range(2))
    assert np.array_equal(first.trajectory.a, second.trajectory.a) and np.array_equal(first.trajectory.b, second.trajectory.b)
    other = ex.design(arm, limits, 2.0, harmonics=2, starts=1, seed=8)
    assert not np.array_equal(first.trajectory.a, other.trajectory.a)


def test_the_shipped_panda_declarations_are_complete() -> None:
    from symbolic.robots import example_path

    names = tuple(f"q{i}" for i in range(1, 8))
    declared = read_declarations(example_path("panda_excitation"), names)
    for kind in ("position", "velocity", "acceleration", "torque", "force_noise", "resolution"):
        assert set(declared.table.values[kind]) == set(names), kind
    assert declared.table.rate == 1000.0


def test_the_shipped_puma_declarations_are_corkes_joint_limits() -> None:
    """Position limits: the Robotics Toolbox for Python's Puma560 qlim in degrees (±160, ±110, ±135, ±266, ±100,
    ±266), converted here independently; every other limit and the noise declared for every joint."""
    from symbolic.robots import example_path

    names = tuple(f"q{i}" for i in range(1, 7))
    declared = read_declarations(example_path("puma560_excitation"), names)
    degrees = [160, 110, 135, 266, 100, 266]
    for name, limit in zip(names, degrees):
        lower, upper = declared.table.values["position"][name]
        assert lower == pytest.approx(-np.deg2rad(limit), abs=1e-6) and upper == pytest.approx(np.deg2rad(limit), abs=1e-6)
    for kind in ("velocity", "acceleration", "torque", "force_noise", "resolution"):
        assert set(declared.table.values[kind]) == set(names), kind


def test_every_command_reads_an_experiment_with_an_excitation_table(files) -> None:
    """The loader accepts [excitation] beside the data (checked the same way) and refuses a bad one."""
    t = np.arange(50) / 100.0
    rows = np.column_stack([t, 0.1 * np.sin(t), 0.2 * np.cos(t), np.sin(3 * t), np.cos(2 * t)])
    np.savetxt(files / "log.csv", rows, delimiter=",", header="t,q_q1,q_q2,tau_q1,tau_q2", comments="")
    (files / "run.toml").write_text('data = "log.csv"\n' + EXPERIMENT)
    robot = symbolic.loads(models.arm(), "arm")
    assert symbolic.data.load(files / "run.toml", model=robot).samples == 50
    (files / "bad.toml").write_text('data = "log.csv"\n' + EXPERIMENT.replace("acceleration = {", "acceleration = { q7 = 1.0,"))
    with pytest.raises(symbolic.data.DataError, match=r"\[excitation\] acceleration.q7: unknown coordinate"):
        symbolic.data.load(files / "bad.toml", model=robot)


def test_an_unreadable_compare_log_is_refused_before_the_design(files, capsys) -> None:
    out = files / "design"
    assert main(["-q", "excite", str(files / "arm.toml"), "--experiment", str(files / "exp.toml"), "--duration", "3",
                 "--compare", str(files / "missing.csv"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "missing.csv" in err and len(err.strip().splitlines()) == 1 and not out.exists()


def test_noise_must_be_finite() -> None:
    """A force noise or resolution of inf is no noise level (σ = inf makes every weight 0): refused with the key."""
    from symbolic.data.errors import DataError
    from symbolic.data.excitation import parse

    for key in ("force_noise", "resolution"):
        with pytest.raises(DataError, match=rf"exp.toml.*\[excitation\] {key}.q1.*a finite number >= 0, got inf"):
            parse({key: {"q1": float("inf")}}, ("q1", "q2"), "exp.toml")
    assert parse({"torque": float("inf")}, ("q1", "q2"), "exp.toml").values["torque"] == {"q1": np.inf, "q2": np.inf}


def test_a_one_sided_position_limit_is_verified(arm) -> None:
    """position = [lower, inf]: a reference going below the lower bound has a ratio above 1 (it was 0: the
    verification saw no limit), one above it a ratio at most 1."""
    limits = ex.resolve_limits(arm, ("test", {**LIMITS, "position": {"q1": (0.0, np.inf), "q2": (-np.inf, 0.5)}}))
    regressor = ex.casadi_regressor(arm)
    t = np.linspace(0.0, 2.0, 50, endpoint=False)
    a = np.array([[0.3, -0.3], [0.2, -0.2]])
    inside = ex.FourierTrajectory(limits.coordinates, 2.0, np.array([1.0, -1.0]), a, np.zeros((2, 2)))
    outside = ex.FourierTrajectory(limits.coordinates, 2.0, np.array([0.01, 0.49]), a, np.zeros((2, 2)))
    assert ex.violation(regressor, inside, limits, t)["position"].max() <= 1.0
    assert np.all(ex.violation(regressor, outside, limits, t)["position"] > 1.0)


def test_the_experiments_own_rate_is_checked(files) -> None:
    """Without [excitation] rate, the experiment's top-level rate is used, checked as the loader checks it."""
    (files / "rate.toml").write_text('rate = "fast"\n' + EXPERIMENT.replace("rate = 200.0\n", ""))
    with pytest.raises(symbolic.data.DataError, match=r"rate.toml.*rate.*expected a sampling rate in Hz"):
        read_declarations(files / "rate.toml", ("q1", "q2"))
    (files / "rate.toml").write_text("rate = 500.0\n" + EXPERIMENT.replace("rate = 200.0\n", ""))
    assert read_declarations(files / "rate.toml", ("q1", "q2")).table.rate == 500.0


def test_velocity_and_acceleration_are_the_derivatives_of_the_position() -> None:
    """basis's q̇ and q̈ against central differences of its q (the module's formulas are not reused)."""
    trajectory = ex.FourierTrajectory.from_free(("a", "b"), 2.5, 4, np.random.default_rng(6).standard_normal(14))
    t, h = np.linspace(0.1, 2.4, 37), 1e-5
    q, qd, qdd = trajectory.evaluate(t)
    (q_minus, qd_minus, _), (q_plus, qd_plus, _) = trajectory.evaluate(t - h), trajectory.evaluate(t + h)
    np.testing.assert_allclose((q_plus - q_minus) / (2 * h), qd, rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose((qd_plus - qd_minus) / (2 * h), qdd, rtol=1e-7, atol=1e-6)


def test_the_loop_table_is_a_markdown_table_saying_why_a_coordinate_refuses() -> None:
    """Every row has the header's number of cells (a "|τ|" in the header split it into two), and the last
    column tells saturation from a force over its limit."""
    from symbolic.identify.excitation_loop import LoopCheck

    check = LoopCheck(("q1", "q2", "q3"), np.ones(3), np.ones(3), np.array([5.0, 20.0, 1.0]), np.full(3, 10.0),
                      np.array([True, False, False]), "pd", np.array([5.0, np.inf, np.inf]))
    rows = [line for line in check.table() if line.startswith("|")]
    assert len({line.count("|") for line in rows}) == 1
    assert [line.rsplit("|", 2)[1].strip() for line in rows[2:]] == ["saturated", "over the limit", "no"]


# -- EMPS: Coulomb friction and offset, which the one-way start of the estimation log cannot separate ----------


@pytest.fixture(scope="module")
def emps_model() -> symbolic.DynamicModel:
    return symbolic.derive(symbolic.robots.load("emps"))


def emps_design(model):
    """The 10 s design of the shipped EMPS declarations (its envelope, noise and cascade loop), compared with
    the first 3 s of the estimation log (the carriage moving one way)."""
    from symbolic.robots import example_path

    declared = read_declarations(example_path("emps_excitation"), ("q",))
    return excite(model, declared, 10.0, seed=0, compare=example_path("emps_one_way")), declared


def test_emps_one_way_log_is_refused_and_the_design_separates_coulomb_and_offset(emps, emps_model) -> None:
    """identify refuses Fc and offset on the one-way log (rank-deficient); the design's predicted σ of both
    is finite and small, the log's infinite; and the design stays inside the log's envelope and the drive."""
    from symbolic.robots import example_path

    with pytest.raises(IdentificationError, match=r"rank-deficient.*Fc, offset cannot be separated"):
        identify_model(emps_model, example_path("emps_one_way"))
    result, _ = emps_design(emps_model)
    names = list(result.predicted.names)
    for name in ("Fc", "offset"):
        k = names.index(name)
        assert result.predicted.relative[k] < 5.0, (name, result.predicted.relative[k])
        assert not np.isfinite(result.compare.relative[k])
    assert not np.isfinite(result.compare.log_det) and np.isfinite(result.predicted.log_det)
    assert np.all(np.isfinite(result.compare.relative[[names.index("M_carriage"), names.index("Fv")]]))
    assert result.loop is not None and not result.loop.refused
    t = np.linspace(0.0, 10.0, 100_001)
    q, qd, qdd = result.design.trajectory.evaluate(t)
    assert 0.0 - 1e-9 <= q.min() and q.max() <= 0.245 + 1e-9
    assert np.abs(qd).max() <= 0.128 * (1 + 1e-6) and np.abs(qdd).max() <= 1.33 * (1 + 1e-6)
    assert np.mean(qd > 0) > 0.2 and np.mean(qd < 0) > 0.2  # both directions: what separates the two


@pytest.mark.slow  # the cascade loop is compiled (about 10 s in a fresh cache), 200 identifications
def test_emps_design_in_its_loop_gives_fc_and_offset_within_their_predicted_sigma(emps, emps_model) -> None:
    """The design run through the EMPS cascade loop (the model at its nominal values, the controller's own
    saturation), its logged force given white noise of the declared σ and its positions quantised to the declared
    resolution, 200 times, each identified by identify_model with the experiment's treatment: the spread of every
    base parameter agrees with the predicted σ within 20 %, Fc and offset are unbiased to a fraction of it, and
    about 68 % of the estimates fall within ±σ of the true value (a normal's share)."""
    from symbolic.data import Experiment
    from symbolic.simulation import simulate

    result, declared = emps_design(emps_model)
    t, q, qd, _ = reference_samples(result.design.trajectory, 1000.0)
    log = Measurements.from_arrays(t, ("q",), q, np.zeros_like(q), ref=q, extras={"refd_q": qd[:, 0]})
    run = simulate(emps_model, Experiment.of(log, controller=dict(declared.controller))).simulated
    rng = np.random.default_rng(11)
    noise = declared.table.values["force_noise"]["q"]
    resolution = declared.table.values["resolution"]["q"]
    estimates = []
    for _ in range(200):
        measured = Measurements.from_arrays(run.t, ("q",), np.round(run.q / resolution) * resolution,
                                            run.tau + rng.standard_normal(run.tau.shape) * noise)
        estimates.append(identify_model(emps_model, measured, settings=declared.settings).identification.values)
    estimates = np.array(estimates)
    predicted = result.predicted
    truth = np.array([95.1089, 203.5034, 20.3935, -3.1648])  # the model file's values, which the loop simulates
    spread = estimates.std(axis=0, ddof=1)
    assert np.all(np.abs(spread / predicted.sigmas - 1.0) < 0.2), spread / predicted.sigmas
    for name in ("Fc", "offset"):
        k = predicted.names.index(name)
        assert abs(estimates[:, k].mean() - truth[k]) < 0.5 * predicted.sigmas[k]
        assert 0.55 < np.mean(np.abs(estimates[:, k] - truth[k]) < predicted.sigmas[k]) < 0.8


def test_a_peak_between_verification_points_is_found(arm) -> None:
    """q̇ = cos(ω t) sampled half a step off its peaks: the grid alone sees cos(ωh/2) (1.2e-3 short of the peak
    here); the refinement finds the peak, 1, to 1e-7 (closed form)."""
    limits = ex.resolve_limits(arm, ("test", {**LIMITS, "velocity": {"q1": 1.0, "q2": 1.0}}))
    a = np.array([[1.0, 0.0], [0.0, 0.0]])
    trajectory = ex.FourierTrajectory(("q1", "q2"), 2.0, np.zeros(2), a, np.zeros((2, 2)))
    h = 2.0 / 64
    t = (np.arange(64) + 0.5) * h
    assert np.abs(trajectory.evaluate(t)[1][:, 0]).max() < 1.0 - 1e-3
    assert abs(ex.violation(ex.casadi_regressor(arm), trajectory, limits, t)["velocity"][0] - 1.0) < 1e-7


def test_sigma_of_a_singular_information_matrix() -> None:
    """Columns x, y, 1, 1 (the last two the same, as Coulomb friction and an offset on a one-way axis): the two
    equal columns get σ = ∞, x and y the σ of the least squares on x, y, 1 alone (the same column space)."""
    from symbolic.identify.excitation_noise import covariance_sigmas

    rng = np.random.default_rng(3)
    x, y = rng.standard_normal((2, 500))
    W = np.column_stack([x, y, np.ones(500), np.ones(500)])  # noqa: N806
    sigmas = covariance_sigmas(W.T @ W)
    reduced = np.sqrt(np.diag(np.linalg.inv(W[:, :3].T @ W[:, :3])))
    np.testing.assert_allclose(sigmas[:2], reduced[:2], rtol=1e-9)
    assert np.all(np.isinf(sigmas[2:]))
    np.testing.assert_allclose(covariance_sigmas(W[:, :3].T @ W[:, :3]), reduced, rtol=1e-12)


# -- --separate A,B: Ds-optimality for a pair the data cannot tell apart ----------------------------------------


def test_ds_criterion_is_the_log_det_of_the_pairs_covariance_block() -> None:
    """−log det of the Schur complement = log det (M⁻¹)_ss (the pair's covariance block), and its gradient
    against central differences."""
    from symbolic.identify.excitation_criteria import ds_optimal

    rng = np.random.default_rng(8)
    A = rng.standard_normal((6, 6))  # noqa: N806
    M = A @ A.T + 0.5 * np.eye(6)  # noqa: N806
    value, gradient = ds_optimal([1, 4])(M)
    assert value == pytest.approx(np.linalg.slogdet(np.linalg.inv(M)[np.ix_([1, 4], [1, 4])])[1], rel=1e-12)
    h = 1e-6
    for i, j in ((0, 0), (1, 4), (2, 3), (4, 4)):
        E = np.zeros((6, 6))  # noqa: N806
        E[i, j] = E[j, i] = h
        finite = (ds_optimal([1, 4])(M + E)[0] - ds_optimal([1, 4])(M - E)[0]) / (2 * h)
        assert finite == pytest.approx(np.sum(gradient * E) / h, rel=1e-6, abs=1e-9)


def test_separate_gradient_against_central_differences(smooth_arm) -> None:
    limits = ex.resolve_limits(smooth_arm, ("test", LIMITS))
    problem = ex.Problem(ex.casadi_regressor(smooth_arm), limits, 3.0, 3, np.linspace(0, 3.0, 60, endpoint=False),
                         np.array([1.0, 4.0]), "ds", separate=(1, 3))
    gradient, finite = _gradient_and_central_differences(problem)
    assert np.linalg.norm(gradient - finite) <= 1e-6 * np.linalg.norm(finite)


def one_way_emps_log(model) -> Measurements:
    """A synthetic EMPS log that moves one way (q̇ ≥ 0.02 m/s, two sines on a ramp), τ = Wβ + 1 N noise: Coulomb
    friction and the offset are the same column on it."""
    t = np.arange(0.0, 3.0, 1e-3)
    w = 2 * np.pi * 0.7
    q = 0.01 + 0.05 * t + 0.01 * np.sin(w * t)
    qd, qdd = 0.05 + 0.01 * w * np.cos(w * t), -0.01 * w**2 * np.sin(w * t)
    tau = base_regressor(model)(q[:, None], qd[:, None], qdd[:, None]) @ model_base(model)[1].values
    return Measurements.from_arrays(t, ("q",), q[:, None], tau + np.random.default_rng(2).normal(0, 1.0, tau.shape))


def test_separate_designs_for_the_pair_on_a_one_way_axis(emps_model) -> None:
    """EMPS's model with the shipped limits, compared with a synthetic one-way log (no shared data needed): there
    the pair is not separable (σ ∞, no correlation); the design gives both a finite σ and a correlation well below
    0.9 — checked against the correlation of identify's estimates over 150 noisy logs of the design's reference."""
    from symbolic.robots import example_path

    declared = read_declarations(example_path("emps_excitation"), ("q",))
    declared = Declared(declared.source, declared.table, declared.settings)  # no loop: the pair alone
    log = one_way_emps_log(emps_model)
    result = excite(emps_model, declared, 10.0, seed=0, starts=2, separate=("Fc", "offset"), compare=log)
    pair = result.separation()
    assert pair["parameters"] == ["Fc", "offset"] and result.design.criterion == "ds"
    assert pair["compare"]["sigma"] == [None, None] and pair["compare"]["correlation"] is None
    assert all(s is not None and np.isfinite(s) for s in pair["design"]["sigma"])
    rho = pair["design"]["correlation"]
    assert abs(rho) < 0.5
    t, q, qd, qdd = result.samples()
    tau = base_regressor(emps_model)(q, qd, qdd) @ model_base(emps_model)[1].values
    rng = np.random.default_rng(4)
    sigma = declared.table.values["force_noise"]["q"]
    estimates = np.array([identify_model(emps_model, Measurements.from_arrays(t, ("q",), q, tau + rng.normal(0, sigma, tau.shape)),
                                         settings=declared.settings).identification.values for _ in range(150)])
    i, j = (result.predicted.names.index(n) for n in ("Fc", "offset"))
    measured = np.corrcoef(estimates[:, i], estimates[:, j])[0, 1]
    assert abs(measured - rho) < 0.25 and abs(measured) < 0.5, (measured, rho)
    spread = estimates[:, [i, j]].std(axis=0, ddof=1)
    np.testing.assert_allclose(spread, pair["design"]["sigma"], rtol=0.2)
    assert "## Separating Fc and offset" in report(result, [], [])
    # the D-optimal design of the same limits: the pair comes out worse (Ds is the pair's own optimum)
    plain = excite(emps_model, declared, 10.0, seed=0, starts=2)
    assert np.prod(result.predicted.sigmas[[i, j]]) < np.prod(plain.predicted.sigmas[[i, j]])


def test_separate_names_model_and_base_parameters(emps_model) -> None:
    from symbolic.identify.excitation_report import separation_indices

    assert separation_indices(emps_model, ["M", "Fv"]) == (("M", 0), ("Fv", 1))
    assert separation_indices(emps_model, ["M_carriage", "offset"]) == (("M_carriage", 0), ("offset", 3))
    with pytest.raises(symbolic.data.DataError, match="M,M_carriage: the same base parameter M_carriage twice"):
        separation_indices(emps_model, ["M", "M_carriage"])


@pytest.mark.parametrize("value, message", [
    ("Fc,ofset", "--separate: ofset: unknown parameter (allowed: base parameters of emps: M_carriage, Fv, Fc, offset; "
                 "model parameters alone in one: M, Fv, Fc, offset); did you mean 'offset'?"),
    ("Fc", "--separate: Fc: expected two parameter names A,B"),
])
def test_separate_bad_names_are_one_line_and_write_nothing(tmp_path, capsys, value, message) -> None:
    from symbolic.robots import example_path

    out = tmp_path / "design"
    assert main(["-q", "excite", "emps", "--experiment", str(example_path("emps_excitation")), "--duration", "10",
                 "--out", str(out), "--separate", value]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"error: {message}" and not out.exists()


def test_separate_and_criterion_together_are_refused(tmp_path, capsys) -> None:
    assert main(["-q", "excite", "emps", "--duration", "10", "--out", str(tmp_path / "d"), "--separate", "Fc,offset",
                 "--criterion", "a"]) == 2
    err = capsys.readouterr().err
    assert "--criterion: not with --separate" in err and len(err.strip().splitlines()) == 1


# -- against Gaz et al.'s exciting trajectory on the Panda ---------------------------------------------------------


@pytest.mark.slow  # one design of 20 s, 5 harmonics × 7 joints: about 2 min without friction, 5 min with it
@pytest.mark.parametrize("friction", [False, True], ids=["panda", "panda_with_friction"])
def test_the_panda_design_beats_gaz_on_both_det_and_condition_number(friction) -> None:
    """The built-in Panda (and with Gaz et al.'s viscous and Coulomb friction on every joint): the 20 s `dc` design
    within Franka's published limits has a larger det M and a smaller condition number than Gaz et al.'s exciting
    trajectory (as commanded, tests/shared_data.py) predicted with the same noise and treatment. The D-optimal
    design alone loses the condition number, the condition-number design alone det M, with friction
    (docs/data.md, "Excitation design")."""
    from shared_data import panda_commanded
    from symbolic.identify.excitation_report import predict_log
    from symbolic.robots import example_path

    t, q, _, _ = panda_commanded()
    robot = symbolic.loads(models.panda_with_friction(), "panda_friction") if friction else symbolic.robots.load("panda")
    model = symbolic.derive(robot)
    declared = read_declarations(example_path("panda_excitation"), model.robot.generalized_coordinates)
    result = excite(model, declared, 20.0, criterion="dc", starts=1)
    gaz = predict_log(model, Measurements.from_arrays(t, model.robot.generalized_coordinates, q, np.zeros_like(q)),
                      result.noise, declared.settings)  # the torques do not enter M
    print(f"{model.name}: log det M {result.predicted.log_det:.1f} against Gaz et al.'s {gaz.log_det:.1f}, cond "
          f"{result.predicted.condition_number:.1f} against {gaz.condition_number:.1f} ({result.design.seconds:.0f} s)")
    assert max(float(v.max()) for v in result.design.worst.values()) <= 1.0 + ex.TOLERANCE
    assert result.predicted.log_det > gaz.log_det
    assert result.predicted.condition_number < gaz.condition_number

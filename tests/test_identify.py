"""IDIM-LS (symbolic.identify): EMPS against its publication, and self-made truth.

EMPS references: Janot, Gautier, Brunot, "Data Set and Reference Models of EMPS" (2019), as quoted in
../shared/data/emps/README.md and in issue 11. Synthetic data: a two-joint arm whose regressor is
written by hand below, driven along a Fourier-series trajectory (Swevers' excitation) with known
parameters.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from shared_data import emps  # noqa: F401  (fixture)
from symbolic import data, identify
from symbolic.data import DataError, Experiment, Measurements
from symbolic.identify import IdentificationError, Settings
from symbolic import robots

# ---------------------------------------------------------------------------------------------- EMPS

EMPS_NAMES = ["M", "Fv", "Fc", "offset"]
DIRECTIONAL_NAMES = ["M", "Fv+", "Fv-", "Fc+", "Fc-"]


def emps_regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """τ = M q̈ + Fv q̇ + Fc sign(q̇) + offset."""
    return np.stack([qdd, qd, np.sign(qd), np.ones_like(qd)], axis=-1)


def directional_regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Friction by direction, no offset (it would be collinear with the two Coulomb columns)."""
    up, down = (qd > 0).astype(float), (qd < 0).astype(float)
    return np.stack([qdd, qd * up, qd * down, up, -down], axis=-1)


def emps_sets() -> tuple[Measurements, Measurements]:
    return (
        data.load(robots.example_path("emps_estimation"), coordinates=["q"]),
        data.load(robots.example_path("emps_pulses"), coordinates=["q"]),
    )


def test_emps_reproduces_the_published_identification(emps: Path) -> None:
    estimation, cross = emps_sets()
    result = identify.identify(estimation, emps_regressor, EMPS_NAMES)
    p = result.processing
    assert (p.cutoff, p.order, p.decimation, p.border) == (100.0, 4, 10, (50, 50))  # the publication's treatment
    published = {"M": (95.11, 0.3), "Fv": (203.5, 2.0), "Fc": (20.39, 0.3), "offset": (-3.165, 0.05)}
    for name, (value, tolerance) in published.items():
        assert result[name].value == pytest.approx(value, abs=tolerance), name
    published_relative_sigma = {"M": 0.11, "Fv": 0.56, "Fc": 0.50, "offset": 1.40}
    for name, value in published_relative_sigma.items():
        assert result[name].relative_sigma == pytest.approx(value, rel=0.1), name
    assert result.flagged == ()
    assert result.relative_error == pytest.approx(4.08, abs=0.15)
    assert result.condition_number == pytest.approx(26, abs=0.5)
    assert identify.cross_validate(result, cross, emps_regressor).relative_error == pytest.approx(5.98, abs=0.2)


def test_emps_direction_dependent_friction(emps: Path) -> None:
    estimation, _ = emps_sets()
    result = identify.identify(estimation, directional_regressor, DIRECTIONAL_NAMES)
    published = {"Fv+": (166.71, 2.0), "Fv-": (240.42, 2.0), "Fc+": (20.14, 0.3), "Fc-": (20.63, 0.3)}
    for name, (value, tolerance) in published.items():
        assert result[name].value == pytest.approx(value, abs=tolerance), name
    assert result.relative_error == pytest.approx(3.11, abs=0.15)


def test_emps_with_the_publications_border_matches_its_printed_digits(emps: Path) -> None:
    """The published script drops 49 samples at the start only (MATLAB's q_f(50:N)) and none at the end.

    With that one difference from our default, every printed digit of the publication is reproduced,
    which checks the filter, difference and decimation conventions sample for sample.
    """
    estimation, cross = emps_sets()
    script = Settings(border=(49, 0))
    result = identify.identify(estimation, emps_regressor, EMPS_NAMES, script)
    printed = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "offset": -3.1648}
    for name, value in printed.items():
        assert result[name].value == pytest.approx(value, abs=0.5e-4), name
    for name, value in {"M": 0.11, "Fv": 0.56, "Fc": 0.50, "offset": 1.40}.items():
        assert result[name].relative_sigma == pytest.approx(value, abs=0.005), name
    assert result.condition_number == pytest.approx(25.99, abs=0.005)
    assert result.relative_error == pytest.approx(4.08, abs=0.005)
    assert identify.cross_validate(result, cross, emps_regressor, script).relative_error == pytest.approx(5.98, abs=0.005)
    directional = identify.identify(estimation, directional_regressor, DIRECTIONAL_NAMES, script)
    for name, value in {"Fv+": 166.71, "Fv-": 240.42, "Fc+": 20.14, "Fc-": 20.63}.items():
        assert directional[name].value == pytest.approx(value, abs=0.005), name
    assert directional.relative_error == pytest.approx(3.11, abs=0.005)


def test_emps_run_writes_a_report(emps: Path, tmp_path: Path) -> None:
    report = identify.run(
        robots.example_path("emps_estimation"),
        emps_regressor,
        EMPS_NAMES,
        ["q"],
        validation=robots.example_path("emps_pulses"),
        figures=tmp_path / "figures",
    )
    out = json.loads(json.dumps(report.to_dict()))
    assert set(out["parameters"]) == set(EMPS_NAMES)
    assert out["validation_relative_error"] == pytest.approx(report.validation.relative_error)
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert report.figures == () and "matplotlib is not installed" in report.notes[0]
    else:
        names = sorted(p.name for p in report.figures)
        assert names == ["identification_q.png", "validation_q.png"]
        first = [p.read_bytes() for p in sorted(report.figures)]
        again = identify.run(robots.example_path("emps_estimation"), emps_regressor, EMPS_NAMES, ["q"],
                             validation=robots.example_path("emps_pulses"), figures=tmp_path / "figures")
        assert [p.read_bytes() for p in sorted(again.figures)] == first


# ---------------------------------------------------------------------------------------------- synthetic truth

G = 9.81
ARM_NAMES = ["ZZ1R", "ZZ2", "MXl", "MX1R", "MX2", "Fv1", "Fv2", "Fc1", "Fc2"]
ARM_TRUE = np.array([2.1, 0.35, 0.42, 3.3, 1.1, 0.8, 0.5, 1.5, 0.9])


def arm_regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """A planar two-joint arm in a vertical plane, base parameters of Khalil & Dombre's form.

    τ1 = ZZ1R q̈1 + ZZ2 (q̈1+q̈2) + MXl (c2(2q̈1+q̈2) − s2(2q̇1q̇2+q̇2²)) + g(MX1R c1 + MX2 c12) + Fv1 q̇1 + Fc1 sign q̇1
    τ2 = ZZ2 (q̈1+q̈2) + MXl (c2 q̈1 + s2 q̇1²) + g MX2 c12 + Fv2 q̇2 + Fc2 sign q̇2
    """
    c1, c2, s2, c12 = np.cos(q[:, 0]), np.cos(q[:, 1]), np.sin(q[:, 1]), np.cos(q[:, 0] + q[:, 1])
    a1, a2 = qdd[:, 0], qdd[:, 1]
    v1, v2 = qd[:, 0], qd[:, 1]
    zero = np.zeros_like(c1)
    row1 = [a1, a1 + a2, c2 * (2 * a1 + a2) - s2 * (2 * v1 * v2 + v2**2), G * c1, G * c12, v1, zero, np.sign(v1), zero]
    row2 = [zero, a1 + a2, c2 * a1 + s2 * v1**2, zero, G * c12, zero, v2, zero, np.sign(v2)]
    return np.stack([np.stack(row1, axis=-1), np.stack(row2, axis=-1)], axis=1)


def fourier_trajectory(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ (exact) of a 5-harmonic Fourier series per joint, base frequency 0.1 Hz (Swevers' form)."""
    w = 2 * np.pi * 0.1
    a = np.array([[0.6, -0.3, 0.2, 0.1, -0.15], [-0.5, 0.4, 0.25, -0.2, 0.1]])
    b = np.array([[0.2, 0.35, -0.1, 0.15, 0.05], [0.3, -0.2, 0.15, 0.1, -0.12]])
    q0 = np.array([0.3, -0.6])
    q, qd, qdd = (np.tile(q0, (len(t), 1)).astype(float), np.zeros((len(t), 2)), np.zeros((len(t), 2)))
    for harmonic in range(1, 6):
        wl = w * harmonic
        s, c = np.sin(wl * t)[:, None], np.cos(wl * t)[:, None]
        al, bl = a[:, harmonic - 1], b[:, harmonic - 1]
        q += (al / wl) * s - (bl / wl) * c
        qd += al * c + bl * s
        qdd += -al * wl * s + bl * wl * c
    return q, qd, qdd


def arm_data(rate: float = 1000.0, duration: float = 20.0, noise: tuple[float, float] = (0.0, 0.0),
             derivatives: bool = False, seed: int = 0) -> Measurements:
    t = np.arange(round(duration * rate) + 1) / rate
    q, qd, qdd = fourier_trajectory(t)
    tau = arm_regressor(q, qd, qdd) @ ARM_TRUE
    tau += np.random.default_rng(seed).normal(size=tau.shape) * np.array(noise)
    if derivatives:
        return Measurements.from_arrays(t, ["q1", "q2"], q, tau, qd=qd, qdd=qdd)
    return Measurements.from_arrays(t, ["q1", "q2"], q, tau)


def relative_errors(result: identify.Identification) -> np.ndarray:
    return np.abs(result.values - ARM_TRUE) / np.abs(ARM_TRUE)


def test_noise_free_with_exact_derivatives_recovers_to_rounding() -> None:
    result = identify.identify(arm_data(derivatives=True), arm_regressor, ARM_NAMES)
    assert relative_errors(result).max() < 1e-8
    assert result.relative_error < 1e-8


def test_noise_free_positions_only_is_limited_by_central_differences() -> None:
    """Without q̇, q̈ columns, the error is the differences' truncation, (ωh)²/6 and (ωh)²/3: it scales as h²."""
    settings = Settings(bandwidth=5.0)  # the same filters at both rates
    fine = relative_errors(identify.identify(arm_data(rate=1000.0), arm_regressor, ARM_NAMES, settings))
    coarse = relative_errors(identify.identify(arm_data(rate=500.0), arm_regressor, ARM_NAMES, settings))
    w, h = 2 * np.pi * 0.5, 1e-3  # highest harmonic, finer step
    assert fine.max() < 10 * (w * h) ** 2 / 3  # a few times the acceleration's truncation error at most
    assert 3.0 < np.median(coarse / fine) < 5.0


def test_noisy_forces_recovered_within_three_sigma_and_weighted_per_coordinate() -> None:
    noise = (0.2, 0.05)
    result = identify.identify(arm_data(noise=noise, seed=3), arm_regressor, ARM_NAMES)
    assert result.method == "wls"
    assert np.all(np.abs(result.values - ARM_TRUE) < 3 * result.sigmas)
    # the per-coordinate σ of the first pass follow the noise levels (after the decimation low-pass)
    ratio = result.coordinate_sigmas[0] / result.coordinate_sigmas[1]
    assert ratio == pytest.approx(noise[0] / noise[1], rel=0.1)
    assert result.residual_sigma == pytest.approx(1.0, rel=0.1)  # weighted residuals have unit variance
    ols = identify.identify(arm_data(noise=noise, seed=3), arm_regressor, ARM_NAMES, method="ols")
    assert np.all(np.abs(ols.values - ARM_TRUE) < 3 * ols.sigmas)
    assert np.prod(result.sigmas / ols.sigmas) < 1  # weighting pays: a smaller uncertainty volume


@pytest.mark.slow
def test_sigma_over_noise_realisations_matches_theory() -> None:
    """Standardised errors z = (β̂ − β)/σ̂ over 200 draws of white force noise.

    (6) assumes white residuals. After parallel decimation they are not: the anti-aliasing filter passes
    only 0.8 of the new Nyquist band, so the residual variance underestimates the low-frequency noise
    density that the estimates feel, by κ = n·mean(|H|⁴)/|H(0)|⁴ over the band (0.85 for n = 10), and
    E[z²] = 1/κ ≈ 1.18 instead of 1. The decimation filter is linear, so noise is decimated alone and
    added to one treated data set.
    """
    import scipy.signal

    clean = arm_data()
    observation = identify.observe(clean, arm_regressor, len(ARM_NAMES))
    p = observation.processing
    keep = slice(p.border[0], clean.samples - p.border[1])
    rng = np.random.default_rng(11)
    z = []
    for _ in range(200):
        noise = rng.normal(size=clean.tau.shape) * np.array([0.2, 0.05])
        noisy = dataclasses.replace(observation, tau=observation.tau + data.filters.decimate(noise[keep], p.decimation))
        result = identify.solve(noisy, ARM_NAMES)
        z.append((result.values - ARM_TRUE) / result.sigmas)
    z = np.array(z)
    sos = scipy.signal.cheby1(8, 0.05, 0.8 / p.decimation, output="sos")
    gain = np.abs(scipy.signal.sosfreqz(sos, worN=100_000)[1]) ** 4
    kappa = p.decimation * gain.mean() / gain[0]
    assert kappa == pytest.approx(0.85, abs=0.01)
    assert np.mean(z**2) == pytest.approx(1 / kappa, abs=0.1)
    assert np.mean(np.abs(z) < 3) > 0.98


# ---------------------------------------------------------------------------------------------- settings, errors


def test_default_treatment_follows_the_rate() -> None:
    p = Settings().resolve(rate=500.0, samples=10_000)
    assert (p.bandwidth, p.cutoff, p.decimation, p.border) == (10.0, 50.0, 10, (50, 50))
    p = Settings(bandwidth=2.0, border=(3, 4)).resolve(rate=1000.0, samples=10_000)
    assert (p.cutoff, p.decimation, p.border) == (10.0, 100, (3, 4))
    assert Settings(filter_positions=False).resolve(1000.0, 1000).border == (2, 2)


def test_experiment_identification_table(tmp_path: Path) -> None:
    measurements = arm_data(duration=5.0)
    table = {"bandwidth": 4.0, "decimation": 5}
    source = str(tmp_path / "x.experiment.toml")
    with_table = Experiment.of(dataclasses.replace(measurements, source=Path(source)),
                               settings=Settings.from_table(table, source))
    p = identify.observe(with_table, arm_regressor, len(ARM_NAMES)).processing
    assert (p.cutoff, p.decimation) == (20.0, 5)
    p = identify.observe(with_table, arm_regressor, len(ARM_NAMES), Settings(decimation=2)).processing
    assert p.decimation == 2  # the call's settings win
    # the table is checked where the experiment is read; the treatment then refuses what the data cannot take
    for bad, message in [({"cut": 1.0}, "[identification] cut: unknown key"),
                         ({"cutoff": -1.0}, "[identification] cutoff: expected a positive number"),
                         ({"order": 2.5}, "[identification] order: expected a positive integer")]:
        with pytest.raises(DataError, match=message.replace("[", r"\[").replace("]", r"\]")):
            Settings.from_table(bad, source)
    broken = Experiment.of(with_table, settings=Settings.from_table({"cutoff": 900.0}, source))
    with pytest.raises(DataError, match="cutoff: 900 Hz is not below the Nyquist frequency 500 Hz"):
        identify.observe(broken, arm_regressor, len(ARM_NAMES))


def test_too_few_samples() -> None:
    with pytest.raises(DataError, match="too few"):
        identify.identify(arm_data(duration=0.1), arm_regressor, ARM_NAMES)


def test_rank_deficient_regressor_names_the_parameters() -> None:
    def doubled(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        y = arm_regressor(q, qd, qdd)
        return np.concatenate([y, y[:, :, 5:6]], axis=2)  # Fv1 twice

    with pytest.raises(IdentificationError, match=r"rank-deficient \(rank 9 < 10 parameters\): Fv1, Fv1 again cannot be separated"):
        identify.identify(arm_data(duration=5.0), doubled, [*ARM_NAMES, "Fv1 again"])


def test_regressor_of_the_wrong_shape() -> None:
    with pytest.raises(ValueError, match=r"shape \(5001, 2, 9\), expected \(5001, 2, 8\)"):
        identify.identify(arm_data(duration=5.0), arm_regressor, ARM_NAMES[:-1])


def test_result_to_dict_and_table() -> None:
    result = identify.identify(arm_data(noise=(0.2, 0.05), duration=5.0), arm_regressor, ARM_NAMES)
    out = json.loads(json.dumps(result.to_dict()))
    assert list(out["parameters"]) == ARM_NAMES
    assert out["parameters"]["Fc2"]["relative_sigma"] == pytest.approx(100 * result["Fc2"].sigma / abs(result["Fc2"].value))
    assert out["processing"]["decimation"] == 10 and out["method"] == "wls"
    assert set(out["coordinate_sigmas"]) == {"q1", "q2"}
    assert result.table().splitlines()[0].split() == ["parameter", "value", "sigma", "sigma", "%"]


def test_large_relative_sigma_is_flagged() -> None:
    def with_useless(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        y = arm_regressor(q, qd, qdd)
        tiny = 1e-4 * np.random.default_rng(99).normal(size=y.shape[:2] + (1,))  # a barely excited column
        return np.concatenate([y, tiny], axis=2)

    result = identify.identify(arm_data(noise=(0.2, 0.05), duration=5.0), with_useless, [*ARM_NAMES, "ghost"])
    assert result.flagged == ("ghost",) and result["ghost"].poorly_determined

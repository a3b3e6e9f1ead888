"""A synthetic fleet with a known truth, for tests/test_fleet.py and bench/fleet.py.

Six robots of the two-link arm of tests/models.py (friction on both joints), each with its own small
manufacturing spread (1 % on the masses, inertias and friction), log the same excitation every week:
20 s at 200 Hz of a five-harmonic trajectory, the force computed by the truth's inverse dynamics with
1 % white noise and the positions quantised by an 18-bit encoder (open loop: the motion is the
trajectory; a stiff controller that follows it is assumed). The truth, :data:`TRUTH`, is written here and
in the tests only; the code that searches the fleet sees the model file and the logs:

* r02: Coulomb friction on q2 rises linearly by 40 % over its logs (wear);
* r03: viscous friction on q1 steps up by 30 % from its fourth log on (a maintenance that went wrong);
* r04: a collision in its third log — a half-sine force burst on both joints at 12.00–12.15 s;
* r05: a heavier tool: m2 30 % above its siblings' (an outlier, constant);
* r06: its fourth log is a bad file (a NaN in the force).

Three ways of reading a log's time are used: from the file name (r01–r04), a column of UNIX seconds
(r05), a ``[[robot.log]]`` list (r06).

:func:`cycle_fleet` is another fleet, for the events judged against the siblings (tests/test_fleet_siblings.py):
the six robots log one 20 s test cycle every day, their forces from the hand-written two-link equations of
tests/reference_integrator.py, with a friction rise near rest on q2 that the model lacks (shared by every log),
a collision in one log and the two drifts above.

Run as a script, ``python3 tests/fleet_cases.py DIR`` writes the fleet into DIR (the README's campaign example).
"""

from __future__ import annotations

import datetime as dt
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from models import arm  # noqa: E402

ROBOTS = ("r01", "r02", "r03", "r04", "r05", "r06")
LOGS = 6
START = dt.datetime(2024, 3, 4, 8, 0, tzinfo=dt.timezone.utc)
WEEK = dt.timedelta(days=7)
RATE = 200.0
SECONDS = 20.0
NOISE = 0.01
RESOLUTION = 2 * np.pi / 2**18
SPREAD = 0.01
NOMINAL = {"m1": 3.0, "m2": 2.0, "I1": 0.04, "I2": 0.02, "Fv1": 0.8, "Fv2": 0.5, "Fc1": 0.6, "Fc2": 0.4}

TRUTH = {
    "drift": {("r02", "Fc2"): ("trend", 0.40), ("r03", "Fv1"): ("step", 0.30)},
    "step_log": 3,  # r03's step from its fourth log (index 3) on
    "event": ("r04", 2, 12.0, 12.15),  # robot, log index, start, end (s)
    "outlier": ("r05", "m2", 1.30),
    "bad": ("r06", 3),
}


def number(name: str) -> int:
    """0 for r01, 1 for r02, ..."""
    return int(name[1:]) - 1


def trajectory(t: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ of both joints: five harmonics of 0.1 Hz with random coefficients, speeds up to about 1.5 rad/s."""
    rng = np.random.default_rng(seed)
    wf = 2 * np.pi * 0.1
    k = np.arange(1, 6)
    a, b = rng.normal(0, 1, (2, 5)), rng.normal(0, 1, (2, 5))
    scale = 1.5 / np.sum(np.hypot(a, b) / (wf * k), axis=1, keepdims=True)
    a, b = a * scale, b * scale
    phase = np.outer(t, k * wf)
    q = np.sin(phase) @ (a / (wf * k)).T - np.cos(phase) @ (b / (wf * k)).T + rng.uniform(-0.3, 0.3, 2)
    qd = np.cos(phase) @ a.T + np.sin(phase) @ b.T
    qdd = -(np.sin(phase) * k * wf) @ a.T + (np.cos(phase) * k * wf) @ b.T
    return q, qd, qdd


def robot_parameters(name: str, outlier: bool = True) -> dict[str, float]:
    """The robot's own values: the nominal ones with its manufacturing spread, and r05's heavier tool (unless
    not ``outlier``)."""
    rng = np.random.default_rng(number(name) + 100)
    values = {k: v * (1 + SPREAD * rng.uniform(-1, 1)) for k, v in NOMINAL.items()}
    if outlier and name == TRUTH["outlier"][0]:
        values[TRUTH["outlier"][1]] *= TRUTH["outlier"][2]
    return values


def log_parameters(name: str, index: int, outlier: bool = True) -> dict[str, float]:
    """The values of robot ``name`` at its log ``index``: drift applied."""
    values = robot_parameters(name, outlier)
    for (robot, parameter), (kind, size) in TRUTH["drift"].items():
        if robot != name:
            continue
        if kind == "trend":
            values[parameter] *= 1 + size * min(index, LOGS - 1) / (LOGS - 1)
        elif index >= TRUTH["step_log"]:
            values[parameter] *= 1 + size
    return values


def rigid_and_friction(name: str, t: np.ndarray):
    """The rigid-body force along the robot's trajectory (friction set to zero) and the trajectory."""
    import symbolic
    from symbolic.numeric import numeric_model

    values = robot_parameters(name)
    model = symbolic.derive(symbolic.loads(arm(), "<truth>"))
    p = model.parameter_vector.updated({**values, "Fv1": 0.0, "Fv2": 0.0, "Fc1": 0.0, "Fc2": 0.0}).array()
    num = numeric_model(model)
    q, qd, qdd = trajectory(t, number(name))
    rigid = np.array([num.inverse_dynamics(a, b, c, p) for a, b, c in zip(q, qd, qdd)])
    return rigid, q, qd


def log_force(name: str, index: int, rigid: np.ndarray, qd: np.ndarray, t: np.ndarray) -> np.ndarray:
    """τ of log ``index``: the rigid part, the log's friction (f = Fv·q̇ + Fc·sign(q̇), the model file's law),
    the collision where there is one, and 1 % white noise."""
    values = log_parameters(name, index)
    fv, fc = np.array([values["Fv1"], values["Fv2"]]), np.array([values["Fc1"], values["Fc2"]])
    tau = rigid + fv * qd + fc * np.sign(qd)
    robot, which, start, end = TRUTH["event"]
    if (name, index) == (robot, which):
        inside = (t >= start) & (t <= end)
        pulse = np.sin(np.pi * (t[inside] - start) / (end - start))
        tau[inside] += np.outer(pulse, 0.5 * np.abs(tau).max(axis=0))
    rng = np.random.default_rng(1000 * number(name) + index)
    return tau + rng.normal(0, 1, tau.shape) * NOISE * np.sqrt(np.mean(tau**2, axis=0))


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    names = list(columns)
    data = np.column_stack([columns[n] for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def fleet(folder: Path, logs: int = LOGS, robots: int = len(ROBOTS), seconds: float = SECONDS,
          spacing: dt.timedelta = WEEK, kind: str = "identify") -> Path:
    """Write the model, the logs and the campaign file into ``folder``; return the campaign file.

    The defaults are the fleet of the module docstring; the benchmark (bench/fleet.py) asks for more robots,
    logs, longer or shorter logs, another spacing in time and another task."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "arm.toml").write_text(arm(), encoding="utf-8")
    t = np.arange(0.0, seconds, 1.0 / RATE)
    listed = []
    names = [f"r{k + 1:02d}" for k in range(robots)]
    for name in names:
        rigid, q, qd = rigid_and_friction(name, t)
        (folder / "logs").mkdir(exist_ok=True)
        for index in range(logs):
            moment = START + index * spacing + dt.timedelta(hours=number(name))
            tau = log_force(name, index, rigid, qd, t)
            if (name, index) == TRUTH["bad"]:
                tau[100, 0] = np.nan
            columns = {"t": t, "q_q1": np.round(q[:, 0] / RESOLUTION) * RESOLUTION,
                       "q_q2": np.round(q[:, 1] / RESOLUTION) * RESOLUTION, "tau_q1": tau[:, 0], "tau_q2": tau[:, 1]}
            if name == "r05":
                columns["epoch"] = moment.timestamp() + t
            file = folder / "logs" / f"{name}_{moment:%Y-%m-%d}.csv"
            write_csv(file, columns)
            if name == "r06":
                listed.append((file.relative_to(folder).as_posix(), moment))
    return campaign_file(folder, listed, names, kind)


def campaign_file(folder: Path, listed, names, kind: str) -> Path:
    text = ['name = "synthetic fleet"', f'description = "{len(names)} two-link arms"', "",
            "[task]", f'kind = "{kind}"', "", "[task.identification]", "bandwidth = 4.0", ""]
    for name in [n for n in names if n not in ("r05", "r06")]:
        text += ["[[robot]]", f'id = "{name}"', 'model = "arm.toml"', f'logs = "logs/{name}_*.csv"',
                 r'time = { from = "name", pattern = "_(\\d{4}-\\d{2}-\\d{2})", format = "%Y-%m-%d" }', ""]
    if "r05" in names:
        text += ["[[robot]]", 'id = "r05"', 'model = "arm.toml"', 'logs = "logs/r05_*.csv"',
                 'time = { from = "column", column = "epoch" }', ""]
    if "r06" in names:
        text += ["[[robot]]", 'id = "r06"', 'model = "arm.toml"', ""]
    for file, moment in listed:
        text += ["[[robot.log]]", f'file = "{file}"', f"time = {moment:%Y-%m-%dT%H:%M:%SZ}", ""]
    path = folder / "fleet.toml"
    path.write_text("\n".join(text), encoding="utf-8")
    return path


# --- a fleet running one test cycle: a misfit the siblings share, one collision (docs/fleet.md, "Events") -------

CYCLE = 20.0
"""Seconds of the test cycle every log of :func:`cycle_fleet` records from its start (one period)."""
CYCLE_SEED = 58
"""The cycle's trajectory (:func:`trajectory` with a 0.05 Hz fundamental): q2 reverses four times, three of them
fast (|q̈2| ≥ 0.6 rad/s²) and once slowly, near 16.0 s (|q̈2| ≈ 0.06 rad/s²)."""
STRIBECK = {"Fs2": 0.55, "vs2": 0.005}
"""The machines' friction on q2 near rest: f = Fv2·q̇ + sgn(q̇)·(Fc2 + (Fs2 − Fc2)·exp(−(q̇/vs2)²)), which the model
(Fv2·q̇ + Fc2·sgn(q̇)) lacks: a misfit where q̇2 stays small — the slow reversal — in every log."""
CYCLE_TRUTH = {
    "misfit": ("q2", "the slow reversal of q2"),
    "event": ("r04", 2, 7.0, 7.15),  # robot, log index, start, end (s): a collision on both joints
    "drift": {("r02", "Fc2"): ("trend", 0.40), ("r03", "Fv1"): ("step", 0.30)},
}


def cycle_trajectory(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ of the test cycle: five harmonics of 0.05 Hz, speeds up to about 1.5 rad/s."""
    rng = np.random.default_rng(CYCLE_SEED)
    wf = 2 * np.pi / CYCLE
    k = np.arange(1, 6)
    a, b = rng.normal(0, 1, (2, 5)), rng.normal(0, 1, (2, 5))
    scale = 2.0 / np.sum(np.hypot(a, b) / (wf * k), axis=1, keepdims=True)
    a, b = a * scale, b * scale
    phase = np.outer(t, k * wf)
    q = np.sin(phase) @ (a / (wf * k)).T - np.cos(phase) @ (b / (wf * k)).T
    qd = np.cos(phase) @ a.T + np.sin(phase) @ b.T
    qdd = -(np.sin(phase) * k * wf) @ a.T + (np.cos(phase) * k * wf) @ b.T
    return q, qd, qdd


def slow_reversal() -> float:
    """The time (s) in the cycle of q2's slowest reversal: where the shared misfit is."""
    t = np.arange(0.0, CYCLE, 1.0 / RATE)
    _, qd, qdd = cycle_trajectory(t)
    crossings = np.flatnonzero(np.sign(qd[1:, 1]) != np.sign(qd[:-1, 1]))
    return float(t[crossings[np.argmin(np.abs(qdd[crossings, 1]))]])


def cycle_force(name: str, index: int, t: np.ndarray, *, misfit: bool, event: bool, drift: bool,
                offset: float = 0.0) -> np.ndarray:
    """τ of robot ``name``'s log ``index`` along the cycle, from the hand-written two-link equations of
    tests/reference_integrator.py (not symbolic's), the robot's friction (with the Stribeck rise on q2 when
    ``misfit``), the collision (at the log's times), and 1 % white noise; the log starts ``offset`` s into the
    cycle."""
    from reference_integrator import ARM, arm_terms

    values = log_parameters(name, index, outlier=False) if drift else robot_parameters(name, outlier=False)
    p = {**ARM, **values}
    q, qd, qdd = cycle_trajectory(t + offset)
    tau = np.array([arm_terms(a, b, p)[0] @ c + arm_terms(a, b, p)[1] for a, b, c in zip(q, qd, qdd)])
    fc = np.array([values["Fc1"], values["Fc2"]])
    coulomb = np.outer(np.ones(len(t)), fc)
    if misfit:
        rise = (STRIBECK["Fs2"] - NOMINAL["Fc2"]) * np.exp(-(qd[:, 1] / STRIBECK["vs2"]) ** 2)
        coulomb[:, 1] += rise
    tau += np.array([values["Fv1"], values["Fv2"]]) * qd + coulomb * np.sign(qd)
    robot, which, start, end = CYCLE_TRUTH["event"]
    if event and (name, index) == (robot, which):
        inside = (t >= start) & (t <= end)
        tau[inside] += np.outer(np.sin(np.pi * (t[inside] - start) / (end - start)), 0.3 * np.abs(tau).max(axis=0))
    rng = np.random.default_rng(5000 + 1000 * number(name) + index)
    return tau + rng.normal(0, 1, tau.shape) * NOISE * np.sqrt(np.mean(tau**2, axis=0))


def offset(name: str, index: int) -> float:
    """Where in the cycle log ``index`` of robot ``name`` starts in a shifted fleet (s): 0 to 17 s, distinct."""
    return float((7 * (number(name) * LOGS + index)) % 36) * 0.5


def cycle_fleet(folder: Path, *, misfit: bool = True, event: bool = True, drift: bool = True,
                shifted: bool = False, kind: str = "identify") -> Path:
    """Six robots of the arm (their manufacturing spread, no heavier tool), six daily logs each of the same test
    cycle (:func:`cycle_trajectory`, 18-bit encoders); with ``misfit`` the machines' Stribeck friction on q2
    (:data:`STRIBECK`), with ``event`` r04's collision, with ``drift`` r02's and r03's drifts
    (:data:`CYCLE_TRUTH`); ``shifted``: each log starts at another point of the cycle (:func:`offset`), so
    that the logs share no cycle time, only states. Returns the campaign file."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "arm.toml").write_text(arm(), encoding="utf-8")
    (folder / "logs").mkdir(exist_ok=True)
    t = np.arange(0.0, CYCLE, 1.0 / RATE)
    names = list(ROBOTS)
    for name in names:
        for index in range(LOGS):
            moment = START + index * dt.timedelta(days=1)
            start = offset(name, index) if shifted else 0.0
            q, _, _ = cycle_trajectory(t + start)
            tau = cycle_force(name, index, t, misfit=misfit, event=event, drift=drift, offset=start)
            columns = {"t": t, "q_q1": np.round(q[:, 0] / RESOLUTION) * RESOLUTION,
                       "q_q2": np.round(q[:, 1] / RESOLUTION) * RESOLUTION, "tau_q1": tau[:, 0], "tau_q2": tau[:, 1]}
            write_csv(folder / "logs" / f"{name}_{moment:%Y-%m-%d}.csv", columns)
    text = ['name = "test cycle"', "", "[task]", f'kind = "{kind}"', "", "[task.identification]", "bandwidth = 4.0", ""]
    for name in names:
        text += ["[[robot]]", f'id = "{name}"', 'model = "arm.toml"', f'logs = "logs/{name}_*.csv"',
                 r'time = { from = "name", pattern = "_(\\d{4}-\\d{2}-\\d{2})", format = "%Y-%m-%d" }', ""]
    path = folder / "fleet.toml"
    path.write_text("\n".join(text), encoding="utf-8")
    return path


if __name__ == "__main__":
    # `python3 tests/fleet_cases.py DIR`: the README's campaign example, the fleet written into DIR
    if len(sys.argv) != 2:
        sys.exit("usage: python3 tests/fleet_cases.py DIR   (writes DIR/fleet.toml, DIR/arm.toml and DIR/logs/)")
    target = Path(sys.argv[1])
    campaign = fleet(target)
    written = len(list((target / "logs").glob("*.csv")))
    print(f"wrote {campaign}, {target / 'arm.toml'} and {written} logs in {target / 'logs'}")

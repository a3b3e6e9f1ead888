"""A geared joint with an elastic transmission, logged as industrial arms log it, made without the product's simulator.

The truth of tests/test_joint_elasticity.py. One joint in a vertical plane, everything in link units (the motor
angle divided by the gear ratio):

    J_m·θ̈ = u − Fv·θ̇ − Fc·sgn(θ̇) − k·(θ − q) − d·(θ̇ − q̇)         (the motor: rotor and gear, set-valued friction)
    J_l·q̈ = k·(θ − q) + d·(θ̇ − q̇) − m·g·c·cos q                      (the link: a body at c from the joint)

With backlash b the transmitted torque k·(θ − q) + d·(θ̇ − q̇) becomes k·(δ ∓ b/2) + d·δ̇ in contact and 0 inside
the dead band |δ| ≤ b/2 (δ = θ − q).

Spong's reduced model of a flexible joint. The motor is integrated by the exact solution of a 1-DOF axis with
viscous and set-valued Coulomb friction under a constant torque (tests/reference_integrator.interval: it sticks
while |torque| ≤ Fc at rest), the spring's torque held over each fine step; the link by symplectic Euler; 50 fine
steps per sample. The rigid joint (``rigid=True``) is one body J_m + J_l integrated the same way, the link's
weight held over the fine step.

The loop is an industrial drive's (the law of docs/simulation.md, "The PI velocity cascade", written out
again here): a P position loop on the **motor** encoder's reading into a PI velocity loop on its backward
difference, the command held over the sample. The log holds the motor encoder (``q_q``, 2^17 counts per motor
turn through a 1:100 gear), a link-side encoder behind the transmission (``ql_q``, 2^20 counts per turn), the
command as the force (``tau_q``, with white noise) and the reference.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from reference_integrator import arm_terms, interval, reference_motion

TRUTH = {"Jm": 0.02, "Jl": 0.15, "m": 2.0, "c": 0.1, "g": 9.81, "Fv": 0.3, "Fc": 0.5, "k": 400.0, "d": 0.8}
"""The joint's truth: k/J_l puts the link's mode with the motor held at 8.2 Hz (an industrial arm's 8–10 Hz)."""

GEAR = 100.0
LOOP = {"kp_position": 30.0, "kp_velocity": 2.0, "ki_velocity": 20.0}

MODEL = '''# One geared joint in a vertical plane: a link (a body at c from the axis) driven through a gear; the rotor's
# inertia at the joint is Jm (link units). Rigid: motor and link turn as one.
name = "geared_joint"
coordinates = ["q"]
gravity = ["0", "-9.81", "0"]

[parameters]
Jm = {Jm!r}
Jl = {Jl!r}
m = {m!r}
c = {c!r}
Fv = {Fv!r}
Fc = {Fc!r}

[[frame]]
name = "link"
parent = "base"
dh = {{ theta = "q", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "link"
frame = "link"
mass = "m"
com = ["c", "0", "0"]
inertia = {{ xx = "0", yy = "Jl - m*c**2", zz = "Jl - m*c**2" }}

[[drive]]
coordinate = "q"
ratio = 1
rotor_inertia = "Jm"

[[friction]]
coordinate = "q"
viscous = "Fv"
coulomb = "Fc"
'''


def model_text(**values: float) -> str:
    """The rigid model file of the joint (module docstring) with the truth's values unless given."""
    return MODEL.format(**{**TRUTH, **values})




def elastic_model_text(**values: float) -> str:
    """The joint's model file as a user writes it when the transmission is known to be elastic: :data:`MODEL` with
    two coordinates, the motor ``q`` and the link's deflection from it ``q_flex`` (Spong's model), a spring k and a
    damper d between them (the file's values the truth's unless given)."""
    p = {**TRUTH, **values}
    text = model_text(**values).replace('coordinates = ["q"]', 'coordinates = ["q", "q_flex"]')
    text = text.replace('theta = "q"', 'theta = "q + q_flex"').replace("Fc = ", f"k = {p['k']!r}\nd = {p['d']!r}\nFc = ", 1)
    return text + '\n[[force]]\nname = "transmission"\ncoordinate = "q_flex"\nexpression = "-k*q_flex - d*qd_q_flex"\n'


def motor_encoder_only(experiment: Path) -> Path:
    """``experiment`` with its link-side encoders' columns (``ql_<c>``) left out of [signals]."""
    text = experiment.read_text(encoding="utf-8")
    experiment.write_text("".join(line for line in text.splitlines(keepends=True) if not line.startswith("ql_")),
                          encoding="utf-8")
    return experiment


def transmitted(theta: float, w: float, q: float, v: float, p: dict, k: str = "k", d: str = "d") -> float:
    """The torque through the transmission: k·(δ ∓ b/2) + d·δ̇ in contact, 0 inside the dead band |δ| < b/2
    (``p["backlash"]`` = b, the band's whole width; 0: a spring); ``k``, ``d``: the keys of p to read."""
    half = 0.5 * p.get("backlash", 0.0)
    delta = theta - q
    if abs(delta) <= half:
        return 0.0
    return p[k] * (delta - math.copysign(half, delta)) + p[d] * (w - v)


def _link_acceleration(q: float, v: float, theta: float, w: float, p: dict) -> float:
    return (transmitted(theta, w, q, v, p) - p["m"] * p["g"] * p["c"] * math.cos(q)) / p["Jl"]


def run(t: np.ndarray, reference: np.ndarray, p: dict, *, motor_counts: float, link_counts: float,
        substeps: int = 50, rigid: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor and link encoder readings and the commands of the joint under the cascade (module docstring)."""
    period = float(t[1] - t[0])
    h = period / substeps
    motor_step = 2 * math.pi / motor_counts
    link_step = 2 * math.pi / link_counts
    start = float(reference[0])
    # at rest on the reference: the spring holds the link's weight
    sag = p["m"] * p["g"] * p["c"] * math.cos(start) / p["k"]
    theta, w = start + (0.0 if rigid else sag + math.copysign(0.5 * p.get("backlash", 0.0), sag)), 0.0
    q, v = start, 0.0
    integral, previous, last_reference = 0.0, None, float(reference[0])
    motor, link, command = (np.empty(len(t)) for _ in range(3))
    for k in range(len(t)):
        read = math.floor(theta / motor_step + 0.5) * motor_step
        motor[k], link[k] = read, math.floor(q / link_step + 0.5) * link_step
        velocity = 0.0 if previous is None else (read - previous) / period
        previous = read
        rd = 0.0 if k == 0 else (reference[k] - last_reference) / period
        last_reference = float(reference[k])
        error = LOOP["kp_position"] * (reference[k] - read) + rd - velocity
        u = LOOP["kp_velocity"] * error + LOOP["ki_velocity"] * integral
        integral += period * error
        command[k] = u
        for _ in range(substeps):
            if rigid:  # one body: the link's weight held over the fine step like the spring's torque
                weight = p["m"] * p["g"] * p["c"] * math.cos(theta)
                theta, w = interval(theta, w, u - weight, h, p["Jm"] + p["Jl"], p["Fv"], p["Fc"])
                q, v = theta, w
                continue
            spring = transmitted(theta, w, q, v, p)
            theta, w = interval(theta, w, u - spring, h, p["Jm"], p["Fv"], p["Fc"])
            v += h * _link_acceleration(q, v, theta, w, p)
            q += h * v
    return motor, link, command


def write_joint_experiment(folder: Path, *, stiffness: float | None = None, rigid: bool = False, seconds: float = 6.0,
                           rate: float = 1000.0, motor_counts: float = 2**17 * GEAR, link_counts: float = 2**20,
                           force_noise: float = 0.02, seed: int = 0, link_offset: float = 0.0,
                           backlash: float = 0.0) -> Path:
    """``folder/joint.csv`` and ``folder/joint.experiment.toml`` of the joint under its cascade; ``stiffness``
    replaces the truth's k, ``rigid``: a stiff transmission (motor and link one body of inertia J_m + J_l, each
    encoder reading it), ``link_offset`` shifts the link encoder's zero, ``backlash`` is the transmission's dead
    band (its whole width, rad; the damper acts in contact only)."""
    from symbolic.data import write_columns

    p = {**TRUTH, "backlash": backlash}
    if stiffness is not None:
        p["k"] = stiffness
    t = np.arange(int(round(seconds * rate))) / rate
    reference = 0.3 + reference_motion(t, amplitude=0.2)
    motor, link, command = run(t, reference, p, motor_counts=motor_counts, link_counts=link_counts, rigid=rigid)
    logged = command + np.random.default_rng(seed).normal(0.0, force_noise, len(t))
    folder.mkdir(parents=True, exist_ok=True)
    write_columns({"t": t, "q_q": motor, "ql_q": link + link_offset, "tau_q": logged, "ref_q": reference},
                  folder / "joint.csv")
    path = folder / "joint.experiment.toml"
    resolution = 2 * math.pi / motor_counts
    path.write_text('data = "joint.csv"\n[signals]\nt = "t"\nq_q = "q_q"\nql_q = "ql_q"\ntau_q = "tau_q"\n'
                    'ref_q = "ref_q"\n[controller]\nkind = "cascade_pi"\ncoordinates = ["q"]\n'
                    f'kp_position = [{LOOP["kp_position"]!r}]\nkp_velocity = [{LOOP["kp_velocity"]!r}]\n'
                    f'ki_velocity = [{LOOP["ki_velocity"]!r}]\nvelocity_feedforward = [1.0]\nreference = "ref"\n'
                    f'quantisation = [{resolution!r}]\n', encoding="utf-8")
    return path


# -- the same joint in a chain: joint 2 of the two-link arm ---------------------------------------------------------

ARM_TRUTH = {**{"l1": 0.4, "l2": 0.3, "m1": 3.0, "m2": 2.0, "c1": 0.2, "c2": 0.15, "I1": 0.04, "I2": 0.02, "g": 9.81},
             "Fv1": 0.8, "Jm2": 0.01, "Fv2": 0.2, "Fc2": 0.3, "k2": 300.0, "d2": 0.3}
"""tests/reference_integrator.ARM (I about each link's centre of mass) with viscous friction on joint 1 and joint 2's
transmission elastic: a rotor Jm2 (link units) with viscous and set-valued Coulomb friction, a spring k2 (the link's
mode with the motor held near 8 Hz at the arm's mean pose) and a damper d2 to link 2."""

ARM_LOOP = {"kp_position": (30.0, 30.0), "kp_velocity": (15.0, 1.5), "ki_velocity": (150.0, 15.0)}


def moreau(mass: np.ndarray, force: np.ndarray, v: np.ndarray, h: float, j: int, Fc: float) -> np.ndarray:
    """Velocities after one step of Moreau's time-stepping with set-valued Coulomb friction Fc on coordinate ``j``:
    the friction impulse λ ∈ [−Fc·h, Fc·h] that stops coordinate j if it can, else opposes its free velocity."""
    inverse = np.linalg.inv(mass)
    free = v + h * inverse @ force
    w = inverse[j, j]
    impulse = -free[j] / w if abs(free[j]) <= w * Fc * h else -math.copysign(Fc * h, free[j])
    return free + inverse[:, j] * impulse


def arm_run(t: np.ndarray, reference: np.ndarray, p: dict, *, rigid: bool, motor_counts: float, link_counts: float,
            substeps: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor encoders (joint 1's and joint 2's motor), joint 2's link encoder and the commands of the arm under the
    cascade on the motor encoders (module docstring's law)."""
    period = float(t[1] - t[0])
    h = period / substeps
    step_m, step_l = 2 * math.pi / motor_counts, 2 * math.pi / link_counts
    kp, kv, ki = (np.array(ARM_LOOP[k]) for k in ("kp_position", "kp_velocity", "ki_velocity"))
    q, v = reference[0].copy(), np.zeros(2)  # the links; the motor theta, w of joint 2 (elastic case)
    _, weight = arm_terms(q, v, p)
    sag = weight[1] / p["k2"]
    theta, w = q[1] + (0.0 if rigid else sag + math.copysign(0.5 * p.get("backlash", 0.0), sag)), 0.0
    integral, previous = np.zeros(2), None
    motor, link, command = np.empty((len(t), 2)), np.empty(len(t)), np.empty((len(t), 2))
    for k in range(len(t)):
        angle = np.array([q[0], q[1] if rigid else theta])
        read = np.floor(angle / step_m + 0.5) * step_m
        motor[k], link[k] = read, math.floor(q[1] / step_l + 0.5) * step_l
        velocity = np.zeros(2) if previous is None else (read - previous) / period
        previous = read
        rd = np.zeros(2) if k == 0 else (reference[k] - reference[k - 1]) / period
        error = kp * (reference[k] - read) + rd - velocity
        u = kv * error + ki * integral
        integral = integral + period * error
        command[k] = u
        for _ in range(substeps):
            mass, terms = arm_terms(q, v, p)
            if rigid:  # one body per joint: the rotor on joint 2's diagonal, its friction set-valued
                mass = mass + np.diag([0.0, p["Jm2"]])
                force = u - terms - np.array([p["Fv1"] * v[0], p["Fv2"] * v[1]])
                v = moreau(mass, force, v, h, 1, p["Fc2"])
                q = q + h * v
                continue
            spring = transmitted(theta, w, q[1], v[1], p, "k2", "d2")
            full = np.zeros((3, 3))
            full[:2, :2], full[2, 2] = mass, p["Jm2"]
            force = np.array([u[0] - terms[0] - p["Fv1"] * v[0], spring - terms[1], u[1] - spring - p["Fv2"] * w])
            velocities = moreau(full, force, np.array([v[0], v[1], w]), h, 2, p["Fc2"])
            v, w = velocities[:2], velocities[2]
            q, theta = q + h * v, theta + h * w
    return motor, link, command


ARM_MODEL_EXTRA = '''
[[drive]]
coordinate = "q2"
ratio = 1
rotor_inertia = "Jm2"
'''


def write_arm_joint_experiment(folder: Path, *, rigid: bool = False, seconds: float = 6.0, rate: float = 1000.0,
                               motor_counts: float = 2**17 * GEAR, link_counts: float = 2**20, force_noise: float = 0.02,
                               seed: int = 0, stiffness: float | None = None, backlash: float = 0.0) -> Path:
    """``folder/arm.csv`` and ``folder/arm.experiment.toml`` of the two-link arm with joint 2 elastic (``rigid``:
    stiff) under the cascade on the motor encoders; joint 2's link encoder logged as ``ql_q2``; ``stiffness``
    replaces k2, ``backlash`` is joint 2's dead band."""
    from symbolic.data import write_columns

    t = np.arange(int(round(seconds * rate))) / rate
    reference = np.array([-0.6, 0.8]) + np.column_stack([reference_motion(t, 0.3), reference_motion(t + 0.37, 0.3)])
    p = {**ARM_TRUTH, "backlash": backlash, **({} if stiffness is None else {"k2": stiffness})}
    motor, link, command = arm_run(t, reference, p, rigid=rigid, motor_counts=motor_counts, link_counts=link_counts)
    logged = command + np.random.default_rng(seed).normal(0.0, force_noise, command.shape)
    folder.mkdir(parents=True, exist_ok=True)
    write_columns({"t": t, "q_q1": motor[:, 0], "q_q2": motor[:, 1], "ql_q2": link, "tau_q1": logged[:, 0],
                   "tau_q2": logged[:, 1], "ref_q1": reference[:, 0], "ref_q2": reference[:, 1]}, folder / "arm.csv")
    resolution = 2 * math.pi / motor_counts
    gains = "".join(f"{k} = [{a!r}, {b!r}]\n" for k, (a, b) in ARM_LOOP.items())
    path = folder / "arm.experiment.toml"
    path.write_text('data = "arm.csv"\n[signals]\nt = "t"\nq_q1 = "q_q1"\nq_q2 = "q_q2"\nql_q2 = "ql_q2"\n'
                    'tau_q1 = "tau_q1"\ntau_q2 = "tau_q2"\nref_q1 = "ref_q1"\nref_q2 = "ref_q2"\n[controller]\n'
                    f'kind = "cascade_pi"\ncoordinates = ["q1", "q2"]\n{gains}velocity_feedforward = [1.0, 1.0]\n'
                    f'reference = "ref"\nquantisation = [{resolution!r}, {resolution!r}]\n', encoding="utf-8")
    return path


def elastic_arm_text(**values: float) -> str:
    """The two-link arm's model file with joint 2's transmission elastic as a user writes it (coordinates q1, q2 —
    joint 2's motor — and q2_flex, link 2's deflection from it), the values :data:`ARM_TRUTH`'s unless given."""
    import models

    p = {**ARM_TRUTH, **values}
    text = models.arm(parameters="".join(f"{k} = {p[k]!r}\n" for k in ("Fv1", "Fv2", "Fc2", "Jm2", "k2", "d2")),
                      friction1='viscous = "Fv1"',
                      extra=ARM_MODEL_EXTRA + '\n[[force]]\nname = "transmission"\ncoordinate = "q2_flex"\n'
                                              'expression = "-k2*q2_flex - d2*qd_q2_flex"\n')
    return text.replace('coordinates = ["q1", "q2"]', 'coordinates = ["q1", "q2", "q2_flex"]').replace(
        'theta = "q2"', 'theta = "q2 + q2_flex"')


def case_files(folder: Path, kind: str, one_encoder: bool = False, **options) -> tuple[Path, Path]:
    """(model file, experiment) of a synthetic case in ``folder``: the geared joint (``kind`` ``"joint"``) or joint 2
    of the two-link arm (``"arm"``) logged by :func:`write_joint_experiment` or :func:`write_arm_joint_experiment`
    with ``options``, and the rigid model file a user writes; ``one_encoder``: the link encoder left out."""
    import models

    if kind == "joint":
        experiment, text = write_joint_experiment(folder, **options), model_text()
    else:
        experiment = write_arm_joint_experiment(folder, **options)
        text = models.arm(parameters=models.ARM_PARAMETERS + "Jm2 = 0.01\n", extra=ARM_MODEL_EXTRA)
    if one_encoder:
        motor_encoder_only(experiment)
    model = folder / f"{kind}.toml"
    model.write_text(text, encoding="utf-8")
    return model, experiment

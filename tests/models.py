"""The small models of the test suite, each written once, as model-file text.

Each builder returns the text of a model file (TOML, docs/model-format.md) with the few variations the
tests need (parameters, friction, an end effector, extra entries); a test loads it with
``symbolic.loads(text, name)`` or writes it to a file. The built-in robots (:mod:`symbolic.robots`) and
the golden double pendulum (tests/golden/double_pendulum.toml, pinned by tests/test_golden.py) are read
from their own files. Texts that are malformed on purpose stay in the tests that refuse them
(tests/test_model_errors.py, tests/test_fuzz_model_files.py, tests/test_flexible.py), as do the degenerate
or hostile ones a single test is about (tests/test_hostile_data.py, tests/test_apparent_mass_figure.py).

* :func:`axis`: a rotary axis (one revolute joint about a vertical axis): inertia J, friction;
* :func:`slider`: a prismatic axis (a mass M sliding vertically), gravity along it;
* :func:`pendulum`: planar pendulums of point masses at the link ends, one or more links;
* :func:`arm`: the two-link planar arm with distributed links and friction on both joints;
* :func:`two_link`: a two-link arm with a point mass at the tip, three of its fields given as expressions;
* :func:`flexible_link`, :func:`rigid_link`: the built-in flexible single link made to ring, and its
  rigid counterpart;
* :func:`with_load`: any of them with a load on a compliant coupling;
* :func:`cart_pendulum`: a cart (prismatic) carrying a pendulum (revolute);
* :func:`planar_arm`: a planar two-link arm with distributed links (the cache's tests);
* :func:`hub_spring`: a hub turning a link through a torsional spring (the known-values tests);
* :func:`carriage`: a prismatic carriage without gravity (the bounds tests);
* :func:`flexible_link_rig`: a hub with a link on a torsional spring at its rim (the state-feedback tests);
* :func:`general_frames`, :func:`general_frames_urdf`: a robot in general joint frames, and as URDF;
* :func:`panda_with_friction`: the built-in Panda with Gaz et al.'s viscous and Coulomb friction on every joint.
"""

from __future__ import annotations

import json

import numpy as np

AXIS = '''# A rotary axis about a vertical axis (gravity along the rotation axis: no gravity torque).
name = "axis"
description = "rotary axis: rotor inertia and friction"
coordinates = ["q"]
gravity = ["0", "0", "-9.81"]

[parameters]
J = {{ value = {J}, unit = "kg*m^2", description = "inertia about the axis" }}
{parameters}
[[frame]]
name = "rotor"
parent = "base"
dh = {{ theta = "q", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "rotor"
frame = "rotor"
mass = "2.0"
inertia = {{ xx = "{inertia}/2", yy = "{inertia}/2", zz = "{inertia}" }}

[[friction]]
coordinate = "q"
{friction}
{extra}'''


def axis(parameters: str = "Fv = 0.3\nFc = 0.4\n", friction: str = 'viscous = "Fv"\ncoulomb = "Fc"',
         extra: str = "", J: float = 0.05, inertia: str = "J") -> str:
    """Text of the rotary axis model; the defaults are the nominal model (inertia, viscous, Coulomb).

    The body sits on the rotation axis, which is vertical: D = [J] whatever its mass, and no gravity
    torque. ``parameters`` are [parameters] lines after J, ``friction`` the keys of its [[friction]]
    entry, ``extra`` appended entries, ``inertia`` the expression of the inertia about the axis."""
    return AXIS.format(J=J, parameters=parameters, friction=friction, extra=extra, inertia=inertia)


SLIDER = """
name = "axis"
coordinates = ["x"]
gravity = ["0", "-9.81", "0"]

[parameters]
M = 2.0
Fv = 3.0
Fc = 1.5
off = -0.25
{parameters}
[[frame]]
name = "slider"
parent = "base"
dh = {{ theta = "0", d = "x", a = "0", alpha = "0" }}

[[body]]
name = "slider"
frame = "slider"
mass = "M"
"""


def slider(parameters: str = "", extra: str = "") -> str:
    """Text of a prismatic axis: a mass M sliding along the vertical (gravity −9.81 along −y, DH d = x),
    with the friction coefficients Fv, Fc and off declared but no [[friction]] entry; ``parameters`` are
    more [parameters] lines, ``extra`` appended entries."""
    return SLIDER.format(parameters=parameters) + extra


def pendulum(name: str = "pendulum", coordinates: tuple[str, ...] = ("q",), masses: tuple[float, ...] = (1.0,),
             lengths: tuple[float, ...] = (0.5,), g: float = 9.81, inline: bool = False,
             end_effector: bool = False) -> str:
    """Text of a planar pendulum: point masses ``masses`` at the ends of massless links of ``lengths``
    (standard DH, relative joint angles ``coordinates``), gravity ``g`` along −y.

    With ``inline=False`` the values are parameters (m, l, g for one link; m1, m2, …, l1, l2, …, g
    for more); with ``inline=True`` every value is written inline and the model has no parameters.
    ``end_effector`` declares the last link's end as the end effector."""
    n = len(coordinates)
    if not len(masses) == len(lengths) == n:
        raise ValueError(f"{n} coordinates need {n} masses and {n} lengths")
    suffix = [""] if n == 1 else [str(i + 1) for i in range(n)]
    what = "point mass on a massless link" if n == 1 else "planar double pendulum" if n == 2 else f"planar {n}-link pendulum"
    values = {**{f"m{s}": m for s, m in zip(suffix, masses)}, **{f"l{s}": l for s, l in zip(suffix, lengths)}, "g": g}
    value = (lambda symbol: f"{values[symbol]}") if inline else (lambda symbol: symbol)
    text = (f'name = "{name}"\ndescription = "{what}{", every value inline" if inline else ""}"\n'
            f'coordinates = {json.dumps(list(coordinates))}\ngravity = ["0", "-{value("g")}", "0"]\n')
    if not inline:
        text += "\n[parameters]\n" + "".join(f"{symbol} = {v}\n" for symbol, v in values.items())
    for k, (s, q) in enumerate(zip(suffix, coordinates), start=1):
        parent = "base" if k == 1 else str(k - 1)
        text += (f'\n[[frame]]\nname = "{k}"\nparent = "{parent}"\n'
                 f'dh = {{ theta = "{q}", d = "0", a = "{value("l" + s)}", alpha = "0" }}\n')
    for k, s in enumerate(suffix, start=1):
        text += f'\n[[body]]\nname = "bob{s}"\nframe = "{k}"\nmass = "{value("m" + s)}"\n'
    if end_effector:
        text += f'\n[end_effector]\nframe = "{n}"\npoint = ["0", "0", "0"]\n'
    return text


ARM = '''# A two-link planar arm in a vertical plane (standard DH), friction on both joints.
name = "arm"
description = "two-link planar arm in a vertical plane"
coordinates = ["q1", "q2"]
gravity = ["0", "-9.81", "0"]

[parameters]
l1 = 0.4
m1 = 3.0
m2 = 2.0
c1 = 0.2
c2 = 0.15
I1 = 0.04
I2 = 0.02
{parameters}
[[frame]]
name = "1"
parent = "base"
dh = {{ theta = "q1", d = "0", a = "l1", alpha = "0" }}

[[frame]]
name = "2"
parent = "1"
dh = {{ theta = "q2", d = "0", a = "0.3", alpha = "0" }}

[[body]]
name = "link1"
frame = "1"
mass = "m1"
com = ["c1 - l1", "0", "0"]
inertia = {{ zz = "I1" }}

[[body]]
name = "link2"
frame = "2"
mass = "m2"
com = ["c2 - 0.3", "0", "0"]
inertia = {{ zz = "I2" }}

[[friction]]
coordinate = "q1"
{friction1}

[[friction]]
coordinate = "q2"
{friction2}
{extra}'''

ARM_PARAMETERS = "Fv1 = 0.8\nFv2 = 0.5\nFc1 = 0.6\nFc2 = 0.4\n"
ARM_FRICTION1 = 'viscous = "Fv1"\ncoulomb = "Fc1"'
ARM_FRICTION2 = 'viscous = "Fv2"\ncoulomb = "Fc2"'
ARM_END_EFFECTOR = '[end_effector]\nframe = "2"\npoint = ["0", "0", "0"]\n'
"""The end effector of :func:`arm`: the tip of link 2 (its frame's origin)."""


def arm(parameters: str = ARM_PARAMETERS, friction1: str = ARM_FRICTION1, friction2: str = ARM_FRICTION2,
        extra: str = "", end_effector: bool = False) -> str:
    """Text of the two-link arm; the defaults are the nominal model (viscous and Coulomb on both joints).

    Link 1 of length l1 = 0.4 m, link 2 of 0.3 m, each with mass, centre of mass and inertia as
    parameters, in a vertical plane. ``parameters`` are [parameters] lines after the links',
    ``friction1``/``friction2`` the keys of the joints' [[friction]] entries, ``end_effector`` adds
    :data:`ARM_END_EFFECTOR` before ``extra``, the appended entries."""
    return ARM.format(parameters=parameters, friction1=friction1, friction2=friction2,
                      extra=(ARM_END_EFFECTOR if end_effector else "") + extra)


TWO_LINK = """name = "arm"
coordinates = ["q1", "q2"]
gravity = ["0", "0", "-g"]
[parameters]
g = 9.81
l1 = 0.5
l2 = 0.4
m1 = 1.0
m2 = 0.5
[[frame]]
name = "1"
parent = "base"
dh = {{ theta = "q1", d = "0", a = "l1", alpha = "0" }}
[[frame]]
name = "2"
parent = "1"
dh = {{ theta = {theta}, d = "0", a = {a}, alpha = "0" }}
[[body]]
name = "link1"
frame = "1"
mass = {mass}
com = ["-l1/2", "0", "0"]
inertia = {{ xx = "0.001", yy = "0.02", zz = "0.02" }}
[[body]]
name = "tip"
frame = "2"
mass = "m2"
"""


def two_link(theta: str = "q2", a: str = "l2", mass: str = "m1") -> str:
    """Text of a two-link arm (gravity along −z, link 1 a distributed body, a point mass m2 at the end of
    link 2) with frame 2's ``theta`` and ``a`` and link 1's ``mass`` given as expression strings (written
    as TOML strings, whatever they hold): the model in which the command-line tests plant bad input."""
    return TWO_LINK.format(theta=json.dumps(theta), a=json.dumps(a), mass=json.dumps(mass))


def with_load(text: str, coordinate: str, frame: str, load: float, frequency: float, damping: float,
              name: str = "x", parent: str = "base") -> str:
    """``text`` with a load of inertia ``load`` on a compliant coupling to revolute ``coordinate`` (whose
    frame ``frame`` has parent ``parent`` and θ = coordinate): a second mass whose deflection ``name`` the
    data do not measure, ringing at ``frequency`` Hz with ``damping`` when the coordinate is held."""
    w = 2 * np.pi * frequency
    coordinates = text.split("coordinates = ", 1)[1].split("\n", 1)[0]
    text = text.replace(f"coordinates = {coordinates}", f"coordinates = {coordinates[:-1]}, \"{name}\"]", 1)
    return text + f'''
[[frame]]
name = "{frame}_load"
parent = "{parent}"
dh = {{ theta = "{coordinate} + {name}", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "{frame}_load"
frame = "{frame}_load"
mass = "0"
inertia = {{ xx = "{load / 2!r}", yy = "{load / 2!r}", zz = "{load!r}" }}

[[force]]
name = "coupling"
coordinate = "{name}"
expression = "-{load * w * w!r}*{name} - {2 * damping * w * load!r}*qd_{name}"
'''


def flexible_link(tip_mass: float, damper: float, friction: str = 'viscous = "Fv"', parameters: str = "Fv = 0.5\n") -> str:
    """The built-in flexible single link (Madill's beam on a hub, ``single_flexible_link.toml``) made to ring
    within the data treatment's pass band: a tip mass of ``tip_mass`` kg (1 kg brings the first bending mode
    with the hub held from ≈ 65 Hz down to ≈ 8.6 Hz and gives it ≈ 30 % of the hub's inertia), one vertical
    mode (gravity acts along the hub's axis: the vertical bending does not couple to the hub at rest), a
    damper ``damper`` on the first horizontal modal coordinate (structural damping; the model format has no
    beam damping key, a ``[[force]]`` on the modal coordinate is one) and friction on the hub."""
    from symbolic import robots

    text = robots.path("single_flexible_link").read_text(encoding="utf-8")
    for old, new in (("modes_w = 2", 'modes_w = 1\ntip_mass = "m_t"'),
                     ("\n[[frame]]", f"m_t = {tip_mass!r}\nc_b = {damper!r}\n{parameters}\n[[frame]]")):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    return text + f'''
[[friction]]
coordinate = "q0"
{friction}

[[force]]
name = "structural_damping"
coordinate = "link_nu1"
expression = "-c_b*qd_link_nu1"
'''


RIGID_LINK = '''# The flexible single link as a rigid body: hub and beam (with its tip mass) turning as one.
name = "rigid_link"
description = "hub and link as one rigid body"
coordinates = ["q0"]
gravity = ["0", "0", "-9.81"]

[parameters]
J = {{ value = {J!r}, unit = "kg*m^2", description = "hub, beam and tip mass about the hub axis" }}
Fv = 0.5

[[frame]]
name = "e"
parent = "base"
dh = {{ theta = "q0", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "hub_and_link"
frame = "e"
mass = "0"
inertia = {{ xx = "J/2", yy = "J/2", zz = "J" }}

[[friction]]
coordinate = "q0"
viscous = "Fv"
'''


def rigid_link(inertia: float) -> str:
    """The rigid counterpart of :func:`flexible_link`: one body of the whole ``inertia`` about the hub axis
    and the same friction, nothing but the flexibility missing."""
    return RIGID_LINK.format(J=inertia)


CART_PENDULUM = """
name = "cart_pendulum"
{description}coordinates = ["x", "th"]
gravity = {gravity}

[parameters]
M = {M!r}
m = {m!r}
l = {l!r}
{Fx} = {fx!r}
{Ft} = {ft!r}

[[frame]]
name = "cart"
parent = "base"
dh = {{ theta = "0", d = "x", a = "0", alpha = "pi/2" }}

[[frame]]
name = "{pole}"
parent = "cart"
dh = {{ theta = "th", d = "0", a = "l", alpha = "0" }}

[[body]]
name = "cart"
frame = "cart"
mass = "M"

[[body]]
name = "bob"
frame = "{pole}"
mass = "m"

[[friction]]
coordinate = "x"
viscous = "{Fx}"

[[friction]]
coordinate = "th"
viscous = "{Ft}"
"""


def cart_pendulum(M: float = 1.5, m: float = 0.3, l: float = 0.4,  # noqa: E741, N803
                  viscous: tuple[tuple[str, float], tuple[str, float]] = (("Fvx", 2.0), ("Fvt", 0.02)),
                  gravity: tuple[str, str, str] = ("0", "-9.81", "0"), pole: str = "pole", description: str = "") -> str:
    """Text of a cart pendulum: a cart of mass M on a prismatic joint x (DH d = x along the base z, turned
    by α = π/2 so that the pendulum swings in a plane holding the motion) and a point mass m on a massless
    pole of length l turning about th, with viscous friction on both; ``viscous`` gives the name and value
    of x's coefficient, then th's; ``gravity`` is the vector (the default −y is along th's axis: no
    gravity torque; −x makes the pendulum hang), ``pole`` the pendulum's frame, ``description`` is written
    when given.

    The small model with one prismatic and one revolute coordinate: the figures label each in its own
    units (tests/test_figures.py); hanging, with no actuator on th, it is the unactuated coordinate of
    tests/test_experiment.py."""
    (Fx, fx), (Ft, ft) = viscous  # noqa: N806
    return CART_PENDULUM.format(description=f"description = {json.dumps(description)}\n" if description else "",
                                gravity=json.dumps(list(gravity)), M=M, m=m, l=l, Fx=Fx, fx=fx, Ft=Ft, ft=ft, pole=pole)


PLANAR_ARM = """# a planar arm with friction: its regressor has regrouped base parameters
name = "arm"
coordinates = ["q1", "q2"]
gravity = ["0", "-g", "0"]
[parameters]
g = 9.81
l1 = 0.5
l2 = 0.4
m1 = 1.5
m2 = 0.8
I1 = 0.02
I2 = 0.01
fv1 = 0.3
[[frame]]
name = "1"
parent = "base"
dh = { theta = "q1", d = "0", a = "l1", alpha = "0" }
[[frame]]
name = "2"
parent = "1"
dh = { theta = "q2", d = "0", a = "l2", alpha = "0" }
[[body]]
name = "link1"
frame = "1"
mass = "m1"
com = ["-l1/2", "0", "0"]
inertia = { xx = "0.001", yy = "I1", zz = "I1" }
[[body]]
name = "link2"
frame = "2"
mass = "m2"
com = ["-l2/2", "0", "0"]
inertia = { xx = "0.001", yy = "I2", zz = "I2" }
[[friction]]
coordinate = "q1"
viscous = "fv1"
"""


def planar_arm() -> str:
    """Text of a planar two-link arm in a vertical plane (gravity along −y): both links distributed
    bodies, their lengths l1, l2 parameters, inertias I1, I2 about y and z alike, viscous friction on
    joint 1 only.

    The model of the cache's tests (tests/test_cache.py): its regressor has regrouped base parameters,
    and an edit of a link's ``yy`` changes the description but not D (the joint axes are z), which the
    cache must still tell apart."""
    return PLANAR_ARM


HUB = '''
name = "hub_spring"
description = "a hub turning a link through a torsional spring, in the horizontal plane"
coordinates = ["q1", "a1"]
gravity = ["0", "0", "-9.81"]

[parameters]
J_h = {{ value = 0.02, unit = "kg*m^2"{fix_h} }}
J_l = {{ value = 0.004, unit = "kg*m^2"{fix_l} }}
Ks = {{ value = 1.2, unit = "N*m/rad" }}
Ds = {{ value = 0.002, unit = "N*m*s/rad" }}
Fv1 = 0.01
Fc1 = 0.02

[[frame]]
name = "hub"
parent = "base"
dh = {{ theta = "q1", d = "0", a = "0", alpha = "0" }}

[[frame]]
name = "link"
parent = "hub"
dh = {{ theta = "a1", d = "0", a = "0", alpha = "0" }}

[[body]]
name = "hub"
frame = "hub"
mass = "0"
inertia = {{ xx = "{J_h}/2", yy = "{J_h}/2", zz = "{J_h}" }}

[[body]]
name = "link"
frame = "link"
mass = "0"
inertia = {{ xx = "{J_l}/2", yy = "{J_l}/2", zz = "{J_l}" }}

[[friction]]
coordinate = "q1"
viscous = "Fv1"
coulomb = "Fc1"

[[force]]
name = "spring"
coordinate = "a1"
expression = "-Ks*a1 - Ds*qd_a1"
'''


def hub_spring(fixed: bool = False, inline: bool = False) -> str:
    """Text of a hub turning a link through a torsional spring (Ks, Ds) in the horizontal plane: two
    massless bodies of inertias J_h and J_l about the vertical axis, the link's deflection a1 without an
    actuator, viscous and Coulomb friction on the hub.

    The model of the known-values tests (tests/test_known.py): the equation of a1 is homogeneous, so
    the inertias must be known; ``fixed`` declares them ``fixed = true``, ``inline`` writes them into the
    bodies as numbers, otherwise they are free (the three must give the same fit)."""
    flag = ", fixed = true" if fixed else ""
    return HUB.format(fix_h=flag, fix_l=flag, J_h="0.02" if inline else "J_h", J_l="0.004" if inline else "J_l")


CARRIAGE = '''
name = "axis"
coordinates = ["q"]
gravity = ["0", "0", "0"]

[parameters]
M = {{ value = 2.0, unit = "kg"{mass} }}
Fv = {{ value = 1.0{viscous} }}
Fc = 0.5
{extra}
[[frame]]
name = "carriage"
parent = "base"
dh = {{ theta = "0", d = "q", a = "0", alpha = "0" }}

[[body]]
name = "carriage"
frame = "carriage"
mass = "{body_mass}"

[[friction]]
coordinate = "q"
viscous = "Fv"
coulomb = "Fc"
'''


def carriage(mass: str = "", viscous: str = "", body_mass: str = "M", extra: str = "") -> str:
    """Text of a carriage of mass M on a prismatic joint q, without gravity, with viscous (Fv) and
    Coulomb (Fc) friction: the model of the bounds tests (tests/test_known.py).

    ``mass`` and ``viscous`` are written inside the entries of M and Fv after their value (a bound such
    as ``, max = 1.5``, or ``, fixed = true``), ``body_mass`` is the carriage's mass expression, ``extra``
    more [parameters] lines after Fc."""
    return CARRIAGE.format(mass=mass, viscous=viscous, body_mass=body_mass, extra=extra)


FLEXIBLE_LINK_RIG = '''# A flexible-link rig: a hub turning about a vertical axis (no gravity torque), a link clamped at the hub's
# rim (radius r) through a torsional spring Ks (its deflection alpha), a motor on the hub only.
name = "flexible_link_rig"
description = "rotary hub and a link on a torsional spring"
coordinates = ["theta", "alpha"]
gravity = ["0", "0", "-9.81"]

[parameters]
Jh = 2.0e-3
mh = 0.5
r = 0.02
m = 0.065
c = 0.15
Izz = 4.9e-4
Ks = 0.26
Ds = 1.0e-3
Bh = 4.0e-3

[[frame]]
name = "hub"
parent = "base"
dh = { theta = "theta", d = "0", a = "r", alpha = "0" }

[[frame]]
name = "link"
parent = "hub"
dh = { theta = "alpha", d = "0", a = "0", alpha = "0" }

[[body]]
name = "hub"
frame = "hub"
mass = "mh"
com = ["-r", "0", "0"]
inertia = { xx = "Jh/2", yy = "Jh/2", zz = "Jh" }

[[body]]
name = "link"
frame = "link"
mass = "m"
com = ["c", "0", "0"]
inertia = { xx = "1e-6", yy = "Izz", zz = "Izz" }

[[friction]]
coordinate = "theta"
viscous = "Bh"

[[force]]
name = "torsional spring"
coordinate = "alpha"
expression = "-Ks*alpha - Ds*qd_alpha"
'''


def flexible_link_rig() -> str:
    """Text of a rotary flexible-link rig: a hub (θ) and a link clamped at its rim (radius r) through a
    torsional spring (deflection α, without an actuator), the link a distributed body (mass m, centre of
    mass c, Izz), viscous friction on the hub.

    The plant of the state-feedback tests (tests/test_state_feedback.py), whose equations are written
    out there by hand from these values; not tests/models/flexible_rig.toml (no rim, a massless link)."""
    return FLEXIBLE_LINK_RIG


GENERAL_FRAMES = '''
name = "general"
coordinates = ["q1", "q2", "q3", "q4"]
[parameters]
m1 = 1.3
m2 = 0.8
l = 0.25
[[frame]]
name = "a"
parent = "base"
origin = { xyz = [0.1, 0.0, 0.3] }
joint = { type = "revolute", axis = [0, 0, 1], limit = { lower = -3, upper = 3 } }
coordinate = "q1"
[[frame]]
name = "b"
parent = "a"
origin = { xyz = [0.0, "l", 0.05], rpy = ["pi/2", 0, 0] }
joint = { type = "continuous", axis = [0, -1, 0] }
coordinate = "q2"
[[frame]]
name = "c"
parent = "b"
origin = { xyz = [0.2, 0.01, -0.03], rpy = [0.3, -0.2, 0.7] }
joint = { type = "prismatic", axis = [1, 0, 0] }
coordinate = "q3"
[[frame]]
name = "f"
parent = "c"
origin = { xyz = [0.05, 0.02, 0.0], rpy = [0, "pi/2", 0] }
[[frame]]
name = "d"
parent = "f"
origin = { xyz = [0.1, 0.0, 0.02], rpy = [0.1, 0, 0] }
joint = { type = "revolute", axis = [0, 0.6, 0.8] }
coordinate = "q4"
[[body]]
name = "A"
frame = "a"
mass = "m1"
com = [0.02, 0.01, 0.1]
inertia = { xx = 0.02, yy = 0.03, zz = 0.015, xy = 0.001, xz = -0.002, yz = 0.0015 }
[[body]]
name = "B"
frame = "b"
mass = "m2"
com = [0.1, -0.02, 0.01]
inertia = { xx = 0.01, yy = 0.012, zz = 0.008, xy = 0.0005 }
[[body]]
name = "C"
frame = "c"
mass = 0.6
com = [0.03, 0.0, 0.02]
inertia = { xx = 0.004, yy = 0.005, zz = 0.006, yz = 0.0003 }
[[body]]
name = "F"
frame = "f"
mass = 0.2
com = [0.01, 0.02, 0.03]
inertia = { xx = 0.001, yy = 0.002, zz = 0.0015 }
[[body]]
name = "D"
frame = "d"
mass = 0.4
com = [0.0, 0.05, 0.01]
inertia = { xx = 0.003, yy = 0.002, zz = 0.0025, xz = 0.0002 }
'''

GENERAL_FRAMES_URDF = '''<?xml version="1.0"?>
<robot name="general">
 <link name="root"/>
 <link name="a"><inertial><origin xyz="0.02 0.01 0.1"/><mass value="1.3"/>
   <inertia ixx="0.02" iyy="0.03" izz="0.015" ixy="0.001" ixz="-0.002" iyz="0.0015"/></inertial></link>
 <link name="b"><inertial><origin xyz="0.1 -0.02 0.01"/><mass value="0.8"/>
   <inertia ixx="0.01" iyy="0.012" izz="0.008" ixy="0.0005" ixz="0" iyz="0"/></inertial></link>
 <link name="c"><inertial><origin xyz="0.03 0 0.02"/><mass value="0.6"/>
   <inertia ixx="0.004" iyy="0.005" izz="0.006" ixy="0" ixz="0" iyz="0.0003"/></inertial></link>
 <link name="f"><inertial><origin xyz="0.01 0.02 0.03"/><mass value="0.2"/>
   <inertia ixx="0.001" iyy="0.002" izz="0.0015" ixy="0" ixz="0" iyz="0"/></inertial></link>
 <link name="d"><inertial><origin xyz="0 0.05 0.01"/><mass value="0.4"/>
   <inertia ixx="0.003" iyy="0.002" izz="0.0025" ixy="0" ixz="0.0002" iyz="0"/></inertial></link>
 <joint name="q1" type="revolute"><parent link="root"/><child link="a"/><origin xyz="0.1 0 0.3" rpy="0 0 0"/>
   <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
 <joint name="q2" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 0.25 0.05" rpy="1.5707963267948966 0 0"/>
   <axis xyz="0 -1 0"/><dynamics damping="0.2" friction="0.1"/></joint>
 <joint name="q3" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0.2 0.01 -0.03" rpy="0.3 -0.2 0.7"/>
   <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="10" velocity="2"/></joint>
 <joint name="jf" type="fixed"><parent link="c"/><child link="f"/><origin xyz="0.05 0.02 0" rpy="0 1.5707963267948966 0"/></joint>
 <joint name="q4" type="revolute"><parent link="f"/><child link="d"/><origin xyz="0.1 0 0.02" rpy="0.1 0 0"/>
   <axis xyz="0 0.6 0.8"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
</robot>
'''


def general_frames() -> str:
    """Text of a four-coordinate robot written with general joint frames (``origin`` and ``joint``, not
    DH): axes along ±x, ±y, z and (0, 0.6, 0.8), revolute, continuous and prismatic joints, a fixed
    frame, rotations of every kind, full inertias, numbers as well as expressions.

    The same robot as :func:`general_frames_urdf`: the URDF tests (tests/test_urdf.py) check these
    frames written by hand and the import of the URDF against Pinocchio, and export this text as URDF."""
    return GENERAL_FRAMES


def general_frames_urdf() -> str:
    """The robot of :func:`general_frames` as URDF (a fixed joint, friction and limits on the joints), for
    the URDF import's tests (tests/test_urdf.py)."""
    return GENERAL_FRAMES_URDF


def serial_chain(n: int, spatial: bool = False, end_effector: bool = False) -> str:
    """Text of an ``n``-link serial chain of revolute joints (standard DH), for the derivation at scale.

    Planar (``spatial=False``): every axis along z (α = 0), link i of length l_i along x, its centre of mass
    half-way, inertia I_i about z and y; gravity along −y, in the plane. Spatial: α alternating +π/2, −π/2,
    offsets d_i and lengths a_i on every link, each body with a centre of mass off every axis and a full
    inertia tensor (products of inertia included), gravity along −z: no simplification the derivation could
    exploit. The values differ from link to link (so that nothing cancels by accident) and keep D(q)
    well conditioned for any n. ``end_effector`` declares the last frame's origin the end effector.

    bench/derivation.py times these chains for N = 2 … 20; tests/test_scale.py checks their C against Pinocchio.
    """
    if n < 1:
        raise ValueError("a chain has at least one link")
    kind = "spatial" if spatial else "planar"
    text = (f'name = "{kind}{n}"\ndescription = "{kind} serial chain of {n} revolute links (standard DH)"\n'
            f'convention = "standard"\ncoordinates = {json.dumps([f"q{i}" for i in range(1, n + 1)])}\n'
            f'gravity = {json.dumps(["0", "0", "-g"] if spatial else ["0", "-g", "0"])}\n\n[parameters]\ng = 9.81\n')
    for i in range(1, n + 1):
        scale = 1.0 / (1.0 + 0.05 * i)  # links shorter and lighter outwards, as in an arm
        values = {"a": 0.3 * scale, "m": 2.0 * scale, "I": 0.02 * scale}
        if spatial:
            values |= {"d": 0.05 + 0.01 * (i % 3), "rx": -0.1 * scale, "ry": 0.01 * (1 + i % 2), "rz": 0.02 * (1 + i % 3),
                       "Ixx": 0.02 * scale, "Iyy": 0.025 * scale, "Izz": 0.015 * scale,
                       "Ixy": 0.001 * scale, "Ixz": -0.0015 * scale, "Iyz": 0.0005 * scale}
            del values["I"]
        text += "".join(f"{key}{i} = {round(value, 6)!r}\n" for key, value in values.items())
    for i in range(1, n + 1):
        parent = "base" if i == 1 else str(i - 1)
        alpha = ("pi/2" if i % 2 else "-pi/2") if spatial else "0"
        d = f"d{i}" if spatial else "0"
        text += f'\n[[frame]]\nname = "{i}"\nparent = "{parent}"\ndh = {{ theta = "q{i}", d = "{d}", a = "a{i}", alpha = "{alpha}" }}\n'
    for i in range(1, n + 1):
        if spatial:
            com = f'["rx{i}", "ry{i}", "rz{i}"]'
            inertia = (f'{{ xx = "Ixx{i}", xy = "Ixy{i}", xz = "Ixz{i}", yy = "Iyy{i}", yz = "Iyz{i}", zz = "Izz{i}" }}')
        else:
            com = f'["-a{i}/2", "0", "0"]'
            inertia = f'{{ zz = "I{i}", yy = "I{i}" }}'
        text += f'\n[[body]]\nname = "link{i}"\nframe = "{i}"\nmass = "m{i}"\ncom = {com}\ninertia = {inertia}\n'
    if end_effector:
        text += f'\n[end_effector]\nframe = "{n}"\npoint = ["0", "0", "0"]\n'
    return text


PANDA_VISCOUS = (0.0665, 0.1987, 0.0399, 0.2257, 0.1023, 0.0132, 0.0638)
"""Gaz et al. 2019's viscous friction of the Panda per joint (N·m·s/rad; the shared data's README), joint 6's
−0.0132 taken as its magnitude: a model file refuses a negative coefficient."""
PANDA_COULOMB = (0.2450, 0.1523, 0.1827, 0.3591, 0.2669, 0.1658, 0.2109)
"""Gaz et al. 2019's Coulomb friction of the Panda per joint (N·m)."""


def panda_with_friction() -> str:
    """The built-in ``panda`` with viscous and Coulomb friction on every joint (Gaz et al.'s values), named
    ``panda_friction``."""
    from symbolic.robots import path

    text = path("panda").read_text().replace('name = "panda"', 'name = "panda_friction"', 1)
    values = "".join(f'fv{j} = {{ value = {v}, unit = "N*m*s/rad" }}\nfc{j} = {{ value = {c}, unit = "N*m" }}\n'
                     for j, (v, c) in enumerate(zip(PANDA_VISCOUS, PANDA_COULOMB), 1))
    text = text.replace("[parameters]\n", "[parameters]\n" + values, 1)
    return text + "".join(f'\n[[friction]]\ncoordinate = "q{j}"\nviscous = "fv{j}"\ncoulomb = "fc{j}"\n'
                          for j in range(1, 8))

"""The small models of the test suite, each written once, as model-file text.

Each builder returns the text of a model file (TOML, docs/model-format.md) with the few variations the
tests need (parameters, friction, an end effector, extra entries); a test loads it with
``symbolic.loads(text, name)`` or writes it to a file. The built-in robots (:mod:`symbolic.robots`) and
the golden double pendulum (tests/golden/double_pendulum.toml, pinned by tests/test_golden.py) are read
from their own files. Texts that are malformed on purpose stay in the tests that refuse them
(tests/test_model_errors.py, tests/test_fuzz_model_files.py).

* :func:`axis`: a rotary axis (one revolute joint about a vertical axis): inertia J, friction;
* :func:`slider`: a prismatic axis (a mass M sliding vertically), gravity along it;
* :func:`pendulum`: planar pendulums of point masses at the link ends, one or more links;
* :func:`arm`: the two-link planar arm with distributed links and friction on both joints;
* :func:`two_link`: a two-link arm with a point mass at the tip, three of its fields given as expressions;
* :func:`flexible_link`, :func:`rigid_link`: the built-in flexible single link made to ring, and its
  rigid counterpart;
* :func:`with_load`: any of them with a load on a compliant coupling.
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

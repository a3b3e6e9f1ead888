"""Units a log cannot be in for its model: a warning, not a refusal (issue 22, item 10).

Measured data are in SI units: time in seconds, a joint that turns (its coordinate enters a frame's DH
angle θ or α) in radians, a joint that slides (its coordinate enters d or a) in metres. The usual
mistakes scale a log by 1000 or by 57.3 and leave it perfectly usable for the least squares, which then
return parameters off by those factors without complaint. :func:`check_units` warns
(:class:`~symbolic.errors.ModelWarning`) where the numbers cannot be in those units; the bounds are far
from any robot's, so that real logs never warn:

* sampling rate below :data:`MIN_RATE` (10 Hz): time stamps in milliseconds give 1 Hz for a 1 kHz log;
* a turning joint whose range exceeds :data:`MAX_TURNS` turns (two, 12.6 rad): degrees turn any motion of
  more than 12.6° into that (the Panda's exciting trajectory spans 1.5 to 3.2 rad per joint);
* a sliding joint whose range exceeds :data:`MAX_TRAVEL` (10 m): millimetres turn any stroke of more than
  1 cm into that (EMPS's carriage travels 0.25 m).
"""

from __future__ import annotations

import math
import warnings

from typing import TYPE_CHECKING

import numpy as np

from symbolic.data.measurements import Measurements, duration
from symbolic.description.units import coordinate_kind
from symbolic.errors import ModelWarning

if TYPE_CHECKING:
    from symbolic.description.robot import Robot

MIN_RATE = 10.0
"""Hz: a robot's log is sampled at 100 Hz or faster (EMPS and the Panda: 1 kHz); below 10 Hz the time
stamps are taken to be in the wrong unit."""

MAX_TURNS = 2.0
"""Turns: the range of a turning joint beyond which its positions are taken to be in degrees."""

MAX_TRAVEL = 10.0
"""Metres: the range of a sliding joint beyond which its positions are taken to be in millimetres."""

def check_units(measurements: Measurements, robot: Robot) -> None:
    """Warn once per data file where the rate or the positions of ``measurements`` cannot be in the SI units
    of ``robot``'s coordinates (module docstring)."""
    source = str(measurements.source)
    problems = []
    if measurements.samples >= 2 and measurements.rate < MIN_RATE:
        problems.append(f"the time step is {duration(measurements.sample_period)} ({measurements.rate:.3g} Hz), "
                        f"a robot's log is sampled faster than {MIN_RATE:g} Hz: time stamps in milliseconds? "
                        "(t must be in seconds)")
    kinds = {c: coordinate_kind(robot, c) for c in robot.generalized_coordinates}
    for j, c in enumerate(measurements.coordinates):
        span = float(np.ptp(measurements.q[:, j])) if measurements.samples else 0.0
        if kinds.get(c) == "revolute" and span > MAX_TURNS * 2 * math.pi:
            problems.append(f"q_{c} spans {span:.4g} rad ({span / (2 * math.pi):.3g} turns) on a turning joint: "
                            f"positions in degrees? (radians are expected)")
        elif kinds.get(c) == "prismatic" and span > MAX_TRAVEL:
            problems.append(f"q_{c} spans {span:.4g} m on a sliding joint: positions in millimetres? (metres are "
                            "expected)")
    if problems:
        warnings.warn(f"{source}: units: {'; '.join(problems)}", ModelWarning, stacklevel=3)

"""Actuators ([[drive]]): the rotor's inertia reflected onto its coordinate.

A rotor turning at ratio·q̇ has kinetic energy ½·Ia·ratio²·q̇², so it adds Ia·ratio² to D[q, q]
(Janot II: "for the motorized joints, we add the actuator inertia I_aj"). Gyroscopic coupling of the
rotor with the link's rotation is neglected, as is usual for high ratios (Spong's reduced model).
The drive gain converts the measured drive signal into generalized force and does not enter
the equations of motion.
"""

from __future__ import annotations

import sympy as sp

from symbolic.description.robot import Robot


def rotor_inertia(robot: Robot) -> sp.Matrix:
    """The diagonal N×N inertia added by the drives' rotors."""
    names = robot.generalized_coordinates
    D = sp.zeros(len(names), len(names))
    for drive in robot.drives:
        i = names.index(drive.coordinate)
        D[i, i] += drive.rotor_inertia * drive.ratio**2
    return D

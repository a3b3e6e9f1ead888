"""The product's compiled controller step run sample by sample over a log, as the simulator runs it: the
controller's memory, and a delay line outside it when the delay is too long to keep inside."""

from __future__ import annotations

import numpy as np

from symbolic.simulation import controller as control


def run_step(ctrl: control.Controller, names: tuple[str, ...], period: float, q: np.ndarray,
             signals: control.Inputs) -> np.ndarray:
    """The commands (samples × the controller's outputs) for positions ``q`` (samples × model coordinates)."""
    outside = control.line_outside(ctrl)
    function = control.controller_function(ctrl, names, period, external=outside)
    c = control.constants(ctrl, {})
    memory = np.zeros(ctrl.memory_size(line=not outside))
    line = control.DelayLine(ctrl.delay, ctrl.size) if outside else None
    out = []
    for k in range(len(q)):
        read = (memory, q[k], signals.reference[k], signals.disturbance[k], signals.torque[k], c)
        if line is None:
            memory, tau = function(*read)
        else:
            memory, tau, u = function(*read, line.applied(k, 1)[0])
            line.computed(k, np.asarray(u).reshape(1, -1))
        out.append(np.asarray(tau).ravel())
    return np.array(out)

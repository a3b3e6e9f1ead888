"""Statics of flexible models: the static gravity sag and the torques it leaves (Madill 4.2.1)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from symbolic.derivation.dynamics import DynamicModel
from symbolic.numeric.statespace import numeric_model


@dataclass(frozen=True)
class Sag:
    """Static deflection under gravity at a configuration and the gravity torques it leaves."""

    modal: dict[str, float]
    torques: dict[str, float]  # on the rigid coordinates, N·m (or N)

    def summary(self) -> str:
        worst = max(self.torques.items(), key=lambda kv: abs(kv[1]))
        return f"static sag {self.modal}; largest residual gravity torque {worst[1]:.3g} on {worst[0]}"


def residual_imbalance(
    model: DynamicModel,
    q,
    parameters: Mapping[str, float] | None = None,
    deflection: Mapping[str, float] | None = None,
) -> Sag:
    """Gravity torques on the rigid coordinates at configuration ``q`` with the beams deflected.

    Without ``deflection`` (modal coordinate name -> value) the static gravity sag is used: the modal
    equilibrium g_m(q, ν) + k_m(ν) = 0 is linear in the modal coordinates (V_g is linear in them (3.78),
    V_s quadratic (3.80)) and is solved exactly.
    """
    num = numeric_model(model)
    p = num.params(None if parameters is None else model.parameter_vector.updated(parameters).values)
    names = model.robot.generalized_coordinates
    rigid = len(model.robot.coordinates)
    x = np.zeros(model.n)
    x[:rigid] = np.asarray(q, float)
    modal = list(range(rigid, model.n))
    if not modal:
        return Sag({}, {names[i]: float(v) for i, v in enumerate(num.gravity(x, p))})
    base = num.gravity(x, p)[modal] + num.stiffness(x, p)[modal]
    columns = []
    for j in modal:  # the modal force is affine in the modal coordinates: its Jacobian by unit steps is exact
        e = x.copy()
        e[j] = 1.0
        columns.append((num.gravity(e, p) + num.stiffness(e, p))[modal] - base)
    if deflection is None:
        values = np.linalg.solve(np.column_stack(columns), -base)
    else:
        unknown = set(deflection) - {names[j] for j in modal}
        if unknown:
            raise ValueError(f"unknown modal coordinate(s) {sorted(unknown)} (modal coordinates: {', '.join(names[j] for j in modal)})")
        values = np.array([deflection.get(names[j], 0.0) for j in modal])
    deflection = values
    x[modal] = deflection
    g = num.gravity(x, p)
    return Sag({names[j]: float(v) for j, v in zip(modal, deflection)}, {names[i]: float(g[i]) for i in range(rigid)})

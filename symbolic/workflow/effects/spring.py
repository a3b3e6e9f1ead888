"""An elastic return the model lacks: a spring to a rest position."""

from __future__ import annotations

import numpy as np

from symbolic.description.names import coefficient_name
from symbolic.workflow.effects.base import Effect, on_row, register


class Spring(Effect):
    """Elastic return to a rest position: the force on the system −k·(q − q0), τ side k·q − k·q0."""

    name, roles, axis, optional = "spring", ("stiffness", "rest_position"), "position", (1,)
    summary = "elastic return to a rest position (a cable, a gas spring): −k·(q − q0)"
    formula, regressors, written_as = 'k·(q − q0)', 'q, 1', '`[[force]] -k*(q - q0)`'
    rank, units = 40, {"stiffness": "{force}/{position}", "rest_position": "{position}"}

    def columns(self, q, qd, qdd, j, value):
        return on_row(j, q.shape[1], [q[:, j], np.ones(len(q))])

    def roles_of(self, c, value, reference):
        k = float(c[0])
        rest = None if np.isnan(c[1]) or k == 0 else float(-c[1] / k)
        return {"stiffness": k, "rest_position": rest}

    def check(self, roles, reference, context, j):
        return None if roles["stiffness"] > 0 else f"stiffness {roles['stiffness']:.4g} is not positive"

    def patch(self, editor, context, j, roles, c, value, comment):
        coordinate = context.coordinates[j]
        k = editor.parameter(coefficient_name("k", coordinate), roles["stiffness"], comment)
        if roles["rest_position"] is None:
            editor.add_force(f"spring_{coordinate}", coordinate, f"-{k}*{coordinate}",
                             comment + "; its rest position is not separable from the offset on this coordinate")
            return {k: roles["stiffness"]}
        q0 = editor.parameter(coefficient_name("q0", coordinate), roles["rest_position"], comment)
        editor.add_force(f"spring_{coordinate}", coordinate, f"-{k}*({coordinate} - {q0})", comment)
        return {k: roles["stiffness"], q0: roles["rest_position"]}


register(Spring())

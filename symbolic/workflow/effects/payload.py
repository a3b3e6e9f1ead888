"""A rigid payload on the last body of a chain (:mod:`symbolic.workflow.payload` holds its algebra)."""

from __future__ import annotations

from symbolic.workflow.effects.base import Effect, register
from symbolic.workflow.payload import PHYSICAL, chain_ends, physical_inertia, structure


class Payload(Effect):
    """A rigid payload on the last body of a chain (a tool, a load; :mod:`symbolic.workflow.payload`): its
    weight and inertia forces on every coordinate, linear in its standard parameters, of which the
    combinations the model's own free parameters do not span are the columns. Tested once per chain, on
    the last coordinate that moves the chain's end (the one reported); roles: mass, centre of mass in
    the frame and, when the data determine it, the inertia about the centre of mass (else a point mass)."""

    name, roles, axis = "payload", PHYSICAL, "acceleration"
    summary = "a rigid payload on the last body of a chain (a tool, a load): mass, centre of mass, inertia"
    formula, regressors, written_as = "Y_π(q, q̇, q̈)·π on every coordinate, π the ten standard parameters of a rigid body on the chain's last frame", "the combinations of Y_π's columns that the model's free parameters do not span", '`[[body]] payload` on that frame (a point mass unless the inertia is determined)'
    roles_note = 'centre of mass in the frame; inertia about it, `null` unless determined'
    rank = 130
    units = {"mass": "kg", "com_x": "m", "com_y": "m", "com_z": "m",
             **{f"i{axes}": "kg·m²" for axes in ("xx", "yy", "zz", "xy", "xz", "yz")}}
    groupable = False  # one payload acts on every coordinate already

    def applicable(self, context, j):
        if context.model is None:
            return "needs the derived model"
        ends = chain_ends(context.robot)
        coordinate = context.coordinates[j]
        if coordinate not in ends:
            return ("a payload acts at the end of a chain: tested once per chain, on "
                    + (", ".join(ends) if ends else "no coordinate (no frame moves)"))
        return structure(context.model, ends[coordinate], coordinate, context.terms).reason

    def setting(self, context, j):
        coordinate = context.coordinates[j]
        return structure(context.model, chain_ends(context.robot)[coordinate], coordinate, context.terms)

    def columns_at(self, signals, j, value):
        return value.columns(signals.q, signals.qd, signals.qdd)

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("payload needs the model's geometry: use columns_at")

    def roles_of(self, c, value, reference):
        return value.parameters(c)

    def check(self, roles, reference, context, j):
        return None if roles["mass"] is not None and roles["mass"] > 0 else f"mass {roles['mass']:.4g} is not positive"

    def describe(self, value):
        return {"payload": {"frame": value.frame, "model": "rigid body" if value.rigid else "point mass",
                            "combinations": value.size}}

    def patch(self, editor, context, j, roles, c, value, comment):
        written = {}
        mass = editor.parameter("m_payload", roles["mass"], comment + "; mass")
        written[mass] = roles["mass"]
        com = []
        for axis in "xyz":
            v = roles[f"com_{axis}"]
            if v is None:
                com.append("0")
                continue
            name = editor.parameter(f"c_payload_{axis}", v, f"{comment}; centre of mass, {axis} in frame {value.frame}")
            written[name] = v
            com.append(name)
        inertia = None
        if value.rigid:
            inertia = {}
            for key, v in physical_inertia(roles).items():
                name = editor.parameter(f"I_payload_{key}", v, f"{comment}; inertia about the centre of mass, {key}")
                written[name] = v
                inertia[key] = name
        editor.add_body("payload", value.frame, mass, inertia, comment
                        + ("" if value.rigid else "; a point mass: the data do not separate its own inertia"),
                        com=com)
        return written


register(Payload())

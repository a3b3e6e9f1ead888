"""An unmodelled resonance: a load on a compliant coupling, found by its ringing."""

from __future__ import annotations

import math

import numpy as np

from symbolic.derivation.drives import rotor_inertia
from symbolic.description.names import coefficient_name
from symbolic.workflow.effects.base import Effect, joint_frame, on_row, register


class FlexibleMode(Effect):
    """An unmodelled resonance: a load elastically coupled to coordinate q (a compliant transmission, a
    flexible link's first mode). With the coordinate measured (collocated), the load of inertia J_L on
    a spring k and damper c moves as q_L = L(s)·q with L = (2ζω·s + ω²)/(s² + 2ζω·s + ω²), ω² = k/J_L,
    2ζω = c/J_L, and the actuator must supply J_L·q̈_L in addition to the rest of the model: the column
    is the acceleration q̈ filtered by L (linear in J_L for given ω, ζ; the coordinate's own inertia in
    the model becomes the motor side's). ω and ζ are scanned on a grid and refined.

    Roles: ``frequency_hz`` and ``damping_ratio`` of the ringing as the data show it — the patched
    model's closed-loop mode under the data's ``[controller]`` (:mod:`symbolic.workflow.modes`), nearest
    to the load's own frequency; without a controller, the load's mode with the coordinate held
    (ω, ζ). Written as a second mass: a new coordinate ``<q>_flex`` (the load's deflection), a frame
    turning (or sliding) with q plus it, a body of inertia (mass) J_L, and a ``[[force]]`` −k·x − c·ẋ on it.

    The column acts on coordinate q's row only: exact when no other coordinate moves the load's axis (a
    one-axis machine, the first joint of a chain); on a later joint the load's inertia also reacts on the
    joints before it, which the column leaves out (the patched model holds it in full).
    """

    own_row = True

    name, roles, axis, nonlinear = "flexible_mode", ("frequency_hz", "damping_ratio"), "time", "frequency and damping"
    summary = "unmodelled resonance: a load on a compliant coupling (second mass), ringing at frequency_hz"
    formula, regressors, written_as = 'J_L·q̈_L, q_L = L(s)·q, L = (2ζω·s + ω²)/(s² + 2ζω·s + ω²)', 'q̈ filtered by L; (ω, ζ) on a grid', 'a second mass: coordinate `<q>_flex`, `[[frame]]`, `[[body]]` J_L, `[[force]]` −k·x − c·ẋ'
    roles_note = 'the ringing, closed loop'
    rank, units = 120, {"frequency_hz": "Hz", "damping_ratio": ""}
    DAMPING = (0.01, 0.03, 0.08, 0.2)
    """Damping ratios of the grid; the grid's box caps the refinement at 0.2: a resonance that rings (a
    peak of half-power width ≤ 40 % of its frequency). Wider, the column is a smooth lag of the
    acceleration, which a drive's bandwidth or a filter explains as well (EMPS)."""
    TOP = 0.8
    """Highest load frequency, as a fraction of the treatment's pass band (the decimation filter's edge)."""
    SPACING = 1.03
    """Ratio of neighbouring grid frequencies (a mode of ζ = 0.01 is 2 % wide at half power)."""
    LOWEST_HZ = 1.0

    def applicable(self, context, j):
        c = context.coordinates[j]
        if motor_declared(context.robot, c):
            return (f"the model declares a motor on {c} (a [[drive]] with a rotor inertia): a second mass ringing there "
                    "is its link behind the transmission (joint_elasticity, one encoder)")
        return self.holds(context, j)

    def holds(self, context, j):
        """Why the model cannot hold a second mass on coordinate ``j`` (a modal coordinate; no frame moves
        with it alone), or ``None``."""
        c = context.coordinates[j]
        kind = context.kind(c)
        if kind == "modal":
            return f"{c} is a modal coordinate"
        return None if joint_frame(context.robot, c) is not None else f"no frame moves with {c} alone"

    def grid(self, context, j):
        frequencies = self.frequencies(context)
        if frequencies is None:
            return None
        rows = np.array([(f, z) for f in frequencies for z in self.DAMPING])
        return rows, float(len(rows))

    def frequencies(self, context) -> np.ndarray | None:
        """The grid's frequencies, :attr:`SPACING` apart from :attr:`LOWEST_HZ` (slower is a spring, gravity or the
        loop itself) to :attr:`TOP` × the treatment's pass band; ``None`` when that range is empty."""
        low, high = self.LOWEST_HZ, self.TOP * context.passband
        if high <= low:
            return None
        return np.exp(np.arange(math.log(low), math.log(high), math.log(self.SPACING)))

    def columns(self, q, qd, qdd, j, value):
        raise TypeError("flexible_mode needs the sampling rate: use columns_at")

    def columns_at(self, signals, j, value):
        return on_row(j, signals.qdd.shape[1], [self.row_columns_at(signals, j, value)[:, 0]])

    def row_columns_at(self, signals, j, value):
        import scipy.signal

        frequency, damping = value
        if signals.record is not None:  # the load's state at the first sample is what the motion before left
            whole = self.row_columns_at(signals.record, j, value)
            return whole[signals.start:signals.start + len(signals.t)]
        a, K, w = mode_denominator(frequency, damping, signals.rate)
        c1, c0 = 2.0 * damping * w * K, w * w
        b = np.array([c1 + c0, 2.0 * c0, c0 - c1]) / a[0]
        a = a / a[0]
        x = signals.qdd[:, j]
        # the filter at rest on x[0] (what scipy.signal.lfilter_zi gives, without its linear solve): L has unit
        # gain at DC, so in the transposed direct form the states for a constant input 1 are b2 − a2 and
        # b1 − a1 + (b2 − a2)
        rest = b[2] - a[2]
        load, _ = scipy.signal.lfilter(b, a, x, zi=np.array([b[1] - a[1] + rest, rest]) * x[0])
        return load[:, None]

    def roles_of(self, c, value, reference):
        return {"frequency_hz": float(value[0]), "damping_ratio": float(value[1]), "load": float(c[0])}

    def reference_column(self, q, qd, qdd, j):
        return on_row(j, q.shape[1], [qdd[:, j]])[:, :, 0]  # the coordinate's own inertia, when the model has it alone

    EDGE = 0.02
    """A fit within this relative distance of the searched box's edge is not located (it would go further)."""

    def check(self, roles, reference, context, j):
        if roles["load"] <= 0:
            return f"load inertia {roles['load']:.4g} is not positive (no second mass rings so)"
        f, z, top = roles["frequency_hz"], roles["damping_ratio"], self.TOP * context.passband
        if f >= (1 - self.EDGE) * top or f <= (1 + self.EDGE) * self.LOWEST_HZ or z >= (1 - self.EDGE) * max(self.DAMPING) \
                or z <= (1 + self.EDGE) * min(self.DAMPING):
            return (f"the resonance is not located: {f:.4g} Hz, ζ = {z:.3g} lies at the edge of the range searched "
                    f"({self.LOWEST_HZ:g}–{top:.4g} Hz, ζ {min(self.DAMPING):g}–{max(self.DAMPING):g})")
        # on a single coordinate the column q̈ alone is the whole inertia the model gives it
        if reference is not None and len(context.coordinates) == 1 and reference <= 0:
            return f"the inertia left on the coordinate's own side, {reference:.4g}, is not positive"
        return None

    def patch(self, editor, context, j, roles, c, value, comment):
        frequency, damping = value
        w = 2.0 * math.pi * frequency
        load = roles["load"]
        return second_mass(editor, context, j, load, load * w * w, 2.0 * damping * w * load, comment)

    PEAK_BAND = 1.3
    """A ringing must show as a spectral peak of the residual within this factor of the load's frequency
    (the closed-loop mode the data show lies near it: the flexible cases ring 1–15 % above it)."""
    DOMINANT = 0.5
    """A resonance explaining at least this share of the whole (stacked) residual is its dominant content and
    needs no peak above a floor that a coarse encoder raises (fits of the loop's reaction to quantisation
    explained at most 32 % in the null data sets; the search passes the stacked share, docs/workflow.md)."""

    def check_residual(self, roles, frequency, psd, share, floor=None):
        from symbolic.workflow.where import PEAK_RATIO, peaks

        f = roles["frequency_hz"]
        if share >= self.DOMINANT:
            return None
        near = [p for p in peaks(frequency, psd, count=len(psd)) if f / self.PEAK_BAND <= p["frequency_hz"] <= f * self.PEAK_BAND]
        band = f"{f / self.PEAK_BAND:.3g}–{f * self.PEAK_BAND:.3g} Hz"
        if not near:
            return (f"no ringing: the residual's spectrum has no peak {PEAK_RATIO:g}× above its median level within "
                    f"{band} (a filtered acceleration then fits the loop's reaction to measurement errors, not a "
                    "resonance)")
        if floor is None:
            return None
        above = [p for p in near if psd[k := int(np.argmin(np.abs(frequency - p["frequency_hz"])))] >= self.ABOVE_FLOOR * floor[k]]
        if above:
            return None
        return (f"no ringing: the residual's peaks within {band} stand less than {self.ABOVE_FLOOR:g}× above what the "
                "encoders' rounding, differentiated twice, puts there (its power grows as f⁴ to the kept band's edge: a "
                "hump, not a resonance)")

    ABOVE_FLOOR = 4.0
    """A ringing's peak must stand this many times above the encoders' rounding at its frequency
    (:func:`~symbolic.workflow.where.quantisation_floor`): the 2-link arm under PD with a 14-bit encoder and nothing
    missing had a 15.8 Hz peak 1.9× above it, named as a resonance before this rule; the tests' real loads stand
    9·10⁴–5·10⁵× above it."""

    def as_measured(self, patched, parameters, context, j, roles, controller, period):
        from symbolic.workflow.modes import closed_loop_modes

        own = {"load_frequency_hz": roles["frequency_hz"], "load_damping_ratio": roles["damping_ratio"]}
        if controller is None:
            w = roles["frequency_hz"]
            damped = {"frequency_hz": w * math.sqrt(max(1.0 - roles["damping_ratio"] ** 2, 0.0)),
                      "damping_ratio": roles["damping_ratio"]}
            return damped, {**own, "ringing": "no [controller] declared: the load's mode with the coordinate held"}
        rest = np.zeros(patched.n)
        names = list(patched.robot.generalized_coordinates)
        for k, c in enumerate(context.coordinates):
            rest[names.index(c)] = float(np.mean(context.q[:, k]))
        modes = closed_loop_modes(patched, parameters, controller, period, rest)
        if not modes:
            return {"frequency_hz": None, "damping_ratio": None}, {**own, "ringing": "no oscillatory closed-loop mode"}
        f, z = min(modes, key=lambda m: abs(math.log(max(m[0], 1e-12) / roles["frequency_hz"])))
        return {"frequency_hz": f, "damping_ratio": z}, {**own, "ringing": "closed-loop mode of the patched model",
                                                          "closed_loop_modes": [list(m) for m in modes]}


def second_mass(editor, context, j: int, load: float, stiffness: float, damping: float, comment: str,
                band: float | None = None) -> dict[str, float]:
    """Write a second mass on coordinate ``j`` (:class:`FlexibleMode`): a coordinate ``<q>_flex`` (the load's
    deflection), a frame turning (or sliding) with q plus it, a body of inertia (mass) ``load`` and a ``[[force]]``
    −k·x − d·ẋ on it; with ``band`` (a dead band's whole width b) the spring and damper act in contact only,
    −(k·(x ∓ b/2) + d·ẋ) outside |x| ≤ b/2 and 0 inside, as the two encoders' backlash writes it. Returns the
    parameters written."""
    coordinate = context.coordinates[j]
    revolute = context.kind(coordinate) == "revolute"
    loaded = f"{coordinate}_load"
    name = editor.parameter(coefficient_name("J" if revolute else "m", loaded), load, comment + "; the load")
    k = editor.parameter(coefficient_name("k", loaded), stiffness, comment + "; coupling stiffness")
    d = editor.parameter(coefficient_name("d", loaded), damping, comment + "; coupling damping")
    written = {name: load, k: stiffness, d: damping}
    flex = editor.coordinate(f"{coordinate}_flex", comment + "; the load's deflection")
    frame = joint_frame(context.robot, coordinate)
    dh = editor.frame_dh(frame.name)
    if context.robot.convention != "modified":  # standard DH: the joint turns about the parent's z
        dh.update(a="0", alpha="0")
    key = "theta" if revolute else "d"
    dh[key] = f"{dh[key]} + {flex}"
    target = editor.add_frame(f"{frame.name}_load", frame.parent, dh, comment)
    if revolute:
        # a thin disc about the joint axis (the triangle inequality holds; only zz acts on q)
        editor.add_body(f"{frame.name}_load", target, "0", {"xx": f"{name}/2", "yy": f"{name}/2", "zz": name}, comment)
    else:
        editor.add_body(f"{frame.name}_load", target, name, None, comment)
    return {**written, **coupling(editor, f"coupling_{coordinate}", coordinate, flex, k, d, band, comment)}


def coupling(editor, name: str, coordinate: str, x: str, k: str, d: str, band: float | None, comment: str
             ) -> dict[str, float]:
    """Write the ``[[force]]`` ``name`` on deflection ``x`` of a spring ``k`` and damper ``d``: −k·x − d·ẋ, or with a
    dead band of whole width ``band`` (a parameter ``backlash_<coordinate>``) −(k·(x − b/2·sgn x) + d·ẋ) in contact
    and 0 inside |x| ≤ b/2 (the format has no comparison: a last factor 1 in contact, 0 inside). Returns the band's
    parameter written ({} without one)."""
    if band is None:
        editor.add_force(name, x, f"-{k}*{x} - {d}*qd_{x}", comment)
        return {}
    b = editor.parameter(coefficient_name("backlash", coordinate), band, comment + "; the dead band's whole width")
    editor.add_force(name, x, f"-({k}*({x} - {b}/2*sign({x})) + {d}*qd_{x})*(1 + sign(abs({x}) - {b}/2))/2",
                     comment + "; the spring and damper act in contact only")
    return {b: band}


def mode_denominator(frequency: float, damping: float, rate: float) -> tuple[np.ndarray, float, float]:
    """(a, K, ω): the denominator s² + 2ζω·s + ω² of a mode at ``frequency`` (Hz) and ``damping`` ζ by the bilinear
    transform s = K(z − 1)/(z + 1) at ``rate``, K prewarped so that the resonance stays at ω (not normalised)."""
    w = 2.0 * math.pi * frequency
    K = w / math.tan(w / (2.0 * rate))
    c1, c0 = 2.0 * damping * w * K, w * w
    return np.array([K * K + c1 + c0, 2.0 * (c0 - K * K), K * K - c1 + c0]), K, w


def motor_declared(robot, coordinate: str) -> bool:
    """Whether the model declares a motor on ``coordinate``: a ``[[drive]]`` with a rotor inertia that is not 0.
    Its encoder reads the motor, and a second mass ringing behind it is the link on an elastic transmission
    (:class:`~symbolic.workflow.effects.joint_elasticity.OneEncoder`) rather than a load on a coupling."""
    k = robot.generalized_coordinates.index(coordinate)
    return rotor_inertia(robot)[k, k].is_zero is not True  # a parameter's (not known to be 0) counts


register(FlexibleMode())

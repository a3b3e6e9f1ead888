"""What these data cannot separate: a candidate's column in the span of the current model on the estimation data
only, with the terms it is collinear with and a motion that would separate them (:mod:`symbolic.identify.separation`).
The search asks :meth:`Separability.why` for every column it finds inside the model's span (docs/workflow.md,
"Name")."""

from __future__ import annotations

from typing import Any

import numpy as np

from symbolic.identify import separation
from symbolic.identify.model import geometric_parameters
from symbolic.identify.separation import Motion
from symbolic.workflow.effects import Signals
from symbolic.workflow.records import Candidate, value_key
from symbolic.workflow.terms import solve_normal


class Separability:
    """The search's answers to "why is this column not identifiable here?", kept for the whole search (the probe
    motions, the model's columns on them, each verdict)."""

    def __init__(self, search: Any) -> None:
        """``search``: the :class:`symbolic.workflow.search.Search` it answers for (not imported: the search imports
        this module)."""
        self.search = search
        self._separable: dict[tuple, str | None] = {}
        self._probes: list[tuple[str, int, Motion]] | None = None
        self._probe_columns: dict[int, np.ndarray] = {}

    def why(self, state: Any, c: Candidate, Z: np.ndarray, i: int, kept: tuple[int, ...]) -> str | None:
        """Why column ``i`` of candidate ``c`` (``Z``: its weighted estimation columns; ``kept``: its columns
        before ``i``), in the span of the round's model on these data, is not identifiable from them — the
        terms it is collinear with and a motion that would separate them (:mod:`symbolic.identify.separation`)
        — or ``None`` when no motion would: the model holds it (its relation to the model's terms is the
        model's own). Once per search for each effect, coordinate, value and set of terms."""
        X = state.X
        rows = np.flatnonzero(np.any(Z != 0, axis=1))
        inside = Z[rows][:, list(kept)]
        cross = X[rows].T @ inside
        gram = np.block([[state.gram, cross], [cross.T, inside.T @ inside]])
        right = np.concatenate([X[rows].T @ Z[rows, i], inside.T @ Z[rows, i]])
        coefficients = solve_normal(gram, right)
        taking = separation.involved(coefficients, np.sqrt(np.clip(np.diag(gram), 0.0, None)))
        design, p = state.design, X.shape[1]
        key = (c.effect.name, c.j, value_key(c.value), i, tuple(int(k) for k in taking), len(design.accepted))
        if key not in self._separable:
            combination = np.append(-coefficients[taking], 1.0)
            motion, cases = self.probe_motions()
            phrase = separation.separating_motion(lambda m: self.raw(m, design, c, taking, kept, i), combination,
                                                  motion, self.search.context.coordinates, cases)
            self._separable[key] = None if phrase is None else (
                f"not identifiable from these data: {c.label()} and {self.terms_named(design, taking, p)} cannot be "
                f"separated; a motion that would separate them: {phrase}; {self.excite_command(c, taking, p)}")
        return self._separable[key]

    def probe_motions(self) -> tuple[Motion, list[tuple[str, int, Motion]]]:
        """The estimation data's states (at most :data:`~symbolic.identify.separation.PROBE_SAMPLES`) and the
        probes made from them, once per search (the model's columns on them are kept by :meth:`raw`)."""
        if self._probes is None:
            x = self.search.context
            motion = Motion.of(x.q, x.qd, x.qdd, x.rate, float(self.search.sets["estimation"].t[0]))
            self._probes = [("data", -2, motion)] + separation.probes(motion)
        return self._probes[0][2], self._probes[1:]

    def raw(self, motion: Motion, design: Any, c: Candidate, taking: np.ndarray, kept: tuple[int, ...],
             i: int) -> np.ndarray:
        """Columns ``taking`` of the round's design and the candidate's column ``i``, untreated, on ``motion``
        (``samples × N × k``): the model's free base columns, an accepted effect's kept columns, the
        candidate's columns ``kept`` before ``i``."""
        if id(motion) not in self._probe_columns:  # the probes live as long as the search
            self._probe_columns[id(motion)] = self.search.terms.regressor(motion.q, motion.qd, motion.qdd, t=motion.t)[:, :, self.search.terms.free]
        model = self._probe_columns[id(motion)]
        x = self.search.context
        signals = Signals(motion.q, motion.qd, motion.qdd, motion.t, motion.rate, x.robot, model=x.model,
                          coordinates=x.coordinates)
        own = c.effect.columns_at(signals, c.j, c.value)
        blocks, start = [], model.shape[2]
        for a in design.accepted:
            blocks.append((start, a))
            start += len(a.candidate.kept)
        out = []
        for k in taking:
            if k < model.shape[2]:
                out.append(model[:, :, k])
            elif k < start:
                first, a = max((b for b in blocks if b[0] <= k), key=lambda b: b[0])
                out.append(a.effect.columns_at(signals, a.candidate.j, a.candidate.value)[:, :, a.candidate.kept[k - first]])
            else:
                out.append(own[:, :, kept[k - start]])
        out.append(own[:, :, i])
        return np.stack(out, axis=2)

    def excite_command(self, c: Candidate, taking: np.ndarray, p: int) -> str:
        """The ``symbolic excite ... --separate A,B`` that designs that motion (docs/data.md, "Designs for doubt"):
        the candidate is not in the model, so it is named ``NEW``, the parameter it gets once written into the model
        file; the other is the model's parameter (the first of those named) or, when the candidate's partner is an
        accepted effect, ``OTHER``."""
        terms = self.search.terms
        known = geometric_parameters(terms.model, terms.reg) | set(terms.fixed)
        free = terms.free_names
        partner = "OTHER"
        for k in taking:
            if k < len(free):
                label = separation.parameter_label(terms.model, terms.reg, terms.base, free[k], known)
                partner = label.split(" (of ", 1)[0]  # a model parameter alone in a base parameter, else the base one
                break
        source = getattr(self.search.context.robot, "source", None)
        model = str(source) if source and str(source).endswith((".toml", ".urdf")) else terms.model.name
        return (f"to design it, write {c.label()} into the model file and run: symbolic excite {model} --experiment "
                f"EXP.toml --duration T --separate NEW,{partner} (NEW: its parameter there)")

    def terms_named(self, design: Any, taking: np.ndarray, p: int) -> str:
        """The design's columns ``taking`` in words: the model's parameters (``the model's Fc``), the accepted
        effects (``coulomb on q (accepted in round 1)``); the candidate's own columns are not named."""
        terms = self.search.terms
        known = geometric_parameters(terms.model, terms.reg) | set(terms.fixed)
        free = terms.free_names
        accepted, start = [], len(free)
        for a in design.accepted:
            if any(start <= k < start + len(a.candidate.kept) for k in taking):
                accepted.append(f"{a.candidate.label()} (accepted in round {a.round})")
            start += len(a.candidate.kept)
        named = [separation.parameter_label(terms.model, terms.reg, terms.base, free[k], known) for k in taking if k < len(free)]
        words = ([f"the model's {', '.join(named)}"] if named else []) + accepted
        return " and ".join(words) if words else "its own other columns"

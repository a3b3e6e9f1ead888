"""The lowered band: the estimation data treated again at half the bandwidth, where the encoders' rounding is gone.

The quantisation error e of a logged position enters q̈ as ë, whose power below the cut-off grows with the
cut-off's fifth power, and a feedback loop puts the same e into the logged force: an errors-in-variables error
that the held-out data share, so that cross-validation does not see it (docs/workflow.md §3, "What the search
cannot tell apart", (4)–(5)). Whatever the model's physics is, it holds at every band that holds the motion; an
artefact of the differentiation fades with the band. Corrections of model-file values
(:mod:`symbolic.workflow.corrections`, rule 3) and the search's accepted effects
(:meth:`symbolic.workflow.search.Search.confirm`) are both asked to hold there.
"""
from __future__ import annotations

import math

from symbolic.data.treatment import Processing, Settings

LOWERED = 0.5
"""The factor applied to the bandwidth, the cut-off and the decimation's pass band (:func:`lowered_settings`)."""


def lowered_settings(p: Processing, factor: float = LOWERED) -> Settings:
    """The treatment ``p`` with its band multiplied by ``factor`` (< 1): bandwidth and cut-off × factor,
    decimation ÷ factor (its anti-alias pass band, 0.4·rate/decimation, scales alike), the border at
    least the rule's five periods of the new cut-off; order, position filtering and held force kept."""
    cutoff = None if p.cutoff is None else p.cutoff * factor
    rule = math.ceil(5.0 * p.rate / cutoff) if cutoff is not None else 2
    return Settings(bandwidth=p.bandwidth * factor, cutoff=cutoff, order=p.order,
                    decimation=max(1, int(round(p.decimation / factor))),
                    border=(max(p.border[0], rule), max(p.border[1], rule)),
                    filter_positions=cutoff is not None, held_force=p.held_force)

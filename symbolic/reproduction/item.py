"""One checkable number of a seed document, recomputed, and how it compares.

An :class:`Item` pairs a value printed in a source (Madill's thesis, Milne et al., Janot et al.) with
the value this package computes by the code path a user would call. The status follows from the
relative difference and a tolerance stated per item: by default half a unit of the last printed digit
(:func:`printed_tolerance`), so "matches" means "agrees with every digit the source printed".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Union

SOURCES: tuple[str, ...] = ("madill", "milne", "janot")

Printed = Union[str, Sequence[str]]
Number = Union[float, Sequence[float]]


@dataclass(frozen=True)
class Item:
    """One recomputed number (or list of numbers) of a seed.

    Attributes
    ----------
    source : one of :data:`SOURCES`
    item : the equation or table label as printed, then what it is ("Table 10 C0", "(5.11) first natural frequency")
    published, ours : the printed value(s) and ours, in ``unit`` (``ours`` is None when not reproducible;
        ``published`` None when the source defines the quantity but prints no value)
    unit : the unit the seed prints ("Hz", "rad/s", "" for pure numbers)
    status : ``matches``, ``matches after correcting <misprint>``, ``differs`` or ``not reproducible: <why>``
    relative_difference : max over elements of |ours − published| / |published| (None when not reproducible)
    tolerance : the relative tolerance the status was judged with
    how : the code path that computes ``ours`` and any reading of the source it needs
    """

    source: str
    item: str
    published: float | tuple[float, ...] | None
    ours: float | tuple[float, ...] | None
    unit: str
    status: str
    relative_difference: float | None
    tolerance: float | None
    how: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "item": self.item,
            "published": _plain(self.published),
            "ours": _plain(self.ours),
            "unit": self.unit,
            "relative_difference": self.relative_difference,
            "status": self.status,
            "tolerance": self.tolerance,
            "how": self.how,
        }


def printed_tolerance(printed: Printed) -> float:
    """Half a unit of the last printed digit, relative to the value (the largest over a list).

    ``"36.727"`` → 0.0005/36.727; ``"1.2e-3"`` → 0.05e-3/1.2e-3. Zero printed values are skipped.
    """
    texts = [printed] if isinstance(printed, str) else list(printed)
    worst = 0.0
    for text in texts:
        value = float(text)
        if value == 0.0:
            continue
        mantissa, _, exponent = text.lower().partition("e")
        decimals = len(mantissa.partition(".")[2]) if "." in mantissa else 0
        half_unit = 0.5 * 10.0 ** (-decimals + (int(exponent) if exponent else 0))
        worst = max(worst, half_unit / abs(value))
    return worst


def relative_difference(published: Number, ours: Number) -> float:
    """max |ours − published| / |published| over the elements (absolute where published is 0)."""
    p = _as_tuple(published)
    o = _as_tuple(ours)
    if len(p) != len(o):
        raise ValueError(f"published has {len(p)} numbers, ours {len(o)}")
    return max(abs(b - a) / abs(a) if a != 0 else abs(b) for a, b in zip(p, o))


def compare(
    source: str,
    item: str,
    published: Printed,
    ours: Number,
    unit: str,
    *,
    how: str,
    tolerance: float | None = None,
    correcting: str | None = None,
) -> Item:
    """An :class:`Item` judged against ``published`` as printed (strings keep the printed precision).

    Parameters
    ----------
    published : the value(s) exactly as the source prints them, as strings
    ours : the recomputed value(s)
    tolerance : relative tolerance; default :func:`printed_tolerance` of ``published``. Give one (and say
        why in ``how``) when the source's own chain rounds more than its last digit
    correcting : the misprint corrected to obtain ``ours``; the status then reads
        ``matches after correcting <correcting>`` when the values agree
    """
    _check_source(source)
    values = float(published) if isinstance(published, str) else tuple(float(p) for p in published)
    ours_plain = float(ours) if not isinstance(ours, Sequence) else tuple(float(x) for x in ours)
    limit = printed_tolerance(published) if tolerance is None else tolerance
    difference = relative_difference(values, ours_plain)
    if not math.isfinite(difference) or difference > limit:
        status = "differs"
    else:
        status = "matches" if correcting is None else f"matches after correcting {correcting}"
    return Item(source, item, values, ours_plain, unit, status, difference, limit, how)


def not_reproducible(source: str, item: str, published: Printed | None, unit: str, *, why: str, how: str = "",
                     ours: Number | None = None) -> Item:
    """An item that cannot be checked against the source (``why`` says what is missing): its published
    value cannot be recomputed from published data, or (``published`` None) the source prints no value
    for a quantity it defines, and ``ours`` is what its equation gives on the printed inputs."""
    _check_source(source)
    values = None if published is None else float(published) if isinstance(published, str) else tuple(float(p) for p in published)
    ours_plain = None if ours is None else float(ours) if not isinstance(ours, Sequence) else tuple(float(x) for x in ours)
    return Item(source, item, values, ours_plain, unit, f"not reproducible: {why}", None, None, how)


def _check_source(source: str) -> None:
    if source not in SOURCES:
        raise ValueError(f"source {source!r} is not one of {SOURCES}")


def _as_tuple(x: Number) -> tuple[float, ...]:
    return (float(x),) if not isinstance(x, Sequence) else tuple(float(v) for v in x)


def _plain(x: Any) -> Any:
    return list(x) if isinstance(x, tuple) else x

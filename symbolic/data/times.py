"""Times written for a reader: time windows with the decimals their width needs, not significant digits.

A window of a log whose clock reads 1000 s printed with three significant digits becomes
``1e+03–1e+03 s``: the digits go to the clock's magnitude, not to the window. :func:`time_windows` writes
every window of a set with the same number of decimals, chosen from the narrowest width (or the
smallest step between windows when they are single instants) so that it shows three significant digits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

WIDTH_DIGITS = 3
"""Significant digits of the narrowest width (or step) that the decimals resolve."""
MAX_DECIMALS = 9
"""At most nanoseconds: a narrower width is clock jitter, not a window."""


def decimals_for(windows: Sequence[tuple[float, float]]) -> int:
    """The decimals that write the narrowest of ``windows`` (start, stop in s) to :data:`WIDTH_DIGITS`
    significant digits: d = WIDTH_DIGITS − 1 − ⌊log₁₀ w⌋, between 0 and :data:`MAX_DECIMALS`. Windows of
    zero width use the smallest step between their starts; 3 when there is no width at all."""
    widths = [b - a for a, b in windows if math.isfinite(b - a) and b > a]
    if not widths:
        starts = sorted({a for a, _ in windows if math.isfinite(a)})
        widths = [b - a for a, b in zip(starts, starts[1:])]
    if not widths:
        return 3
    return min(max(WIDTH_DIGITS - 1 - math.floor(math.log10(min(widths))), 0), MAX_DECIMALS)


def time_windows(windows: Sequence[tuple[float, float]], unit: str = " s") -> list[str]:
    """``"start–stop s"`` for each window, all with :func:`decimals_for` decimals.

    >>> time_windows([(1000.0, 1001.03), (1001.03, 1002.06)])
    ['1000.00–1001.03 s', '1001.03–1002.06 s']
    >>> time_windows([(0.0, 125.0), (125.0, 250.0)])
    ['0–125 s', '125–250 s']
    """
    d = decimals_for(windows)
    return [f"{a:.{d}f}–{b:.{d}f}{unit}" for a, b in windows]

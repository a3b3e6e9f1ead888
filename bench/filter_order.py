"""The Butterworth order the identification's position filter may have (issue 22, item 7; ``MAX_ORDER``).

The treatment low-passes the positions by a zero-phase Butterworth (``symbolic.data.filters.lowpass``) and
drops a border of five periods of the cut-off at each end. The filter's impulse response lengthens with the
order while the border does not, so the edge transients reach further into the kept samples. This measures,
for cut-offs from 0.2 Hz to 100 Hz at 1 kHz, the largest error left after the border on a signal well inside
the pass band (sines at cut-off/20 and 0.37·cut-off/20 plus an offset, the Butterworth's gain there being 1 to
1e-20), as a fraction of the signal's amplitude 1::

    python bench/filter_order.py

The truth (the signal itself) is known independently of the filter. ``MAX_ORDER`` = 16 is the highest order
whose error stays at about 1e-3 at every cut-off; EMPS's order 200 (its cut-off 100 Hz) is far past it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from symbolic.data.filters import lowpass
from symbolic.data.settings import MAX_ORDER

RATE = 1000.0
CUTOFFS = (0.2, 1.0, 5.0, 20.0, 100.0)
ORDERS = (2, 4, 8, 12, 16, 20, 24, 32, 48, 64, 100, 150, 200)


def error_after_border(cutoff: float, order: int, periods: float = 200.0) -> float:
    """Largest |lowpass(x) − x| outside the border for x a pass-band signal of ``periods`` cut-off periods."""
    t = np.arange(int(periods * RATE / cutoff)) / RATE
    f0 = cutoff / 20
    x = np.sin(2 * np.pi * f0 * t) + 0.3 * np.cos(2 * np.pi * 0.37 * f0 * t + 0.4) + 0.5
    border = math.ceil(5 * RATE / cutoff)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        y = lowpass(x, cutoff, RATE, order)
    return float(np.max(np.abs(y - x)[border:-border]))


def main() -> None:
    print(f"largest error after the border, pass-band signal of amplitude 1, {RATE:g} Hz (MAX_ORDER = {MAX_ORDER})")
    print("cut-off Hz " + "".join(f"{n:>9d}" for n in ORDERS))
    for cutoff in CUTOFFS:
        print(f"{cutoff:10g} " + "".join(f"{error_after_border(cutoff, n):9.1e}" for n in ORDERS))


if __name__ == "__main__":
    main()

"""The derive layer: pure functions from a validated Robot to SymPy expressions (no numbers; the only I/O is the cache of derivations, :mod:`symbolic.cache`).

:func:`derive` is the entry point; each quantity has its own module: frames and Jacobians
(:mod:`.kinematics`), D(Q) (:mod:`.inertia`), the Christoffel matrix and Coriolis terms
(:mod:`.christoffel`), gravity (:mod:`.gravity`), Newton–Euler τ (:mod:`.newton_euler`), beams by
assumed modes (:mod:`.mode_shapes`, :mod:`.flexible`, :mod:`.sensing`), closed loops and transmissions
(:mod:`.transmission`), decoupling and balancing conditions (:mod:`.analysis`).
"""

from __future__ import annotations

from symbolic.derivation.dynamics import DynamicModel, derive
from symbolic.derivation.products import Product, Products

__all__ = ["DynamicModel", "Product", "Products", "derive"]

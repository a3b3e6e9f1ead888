"""Milne et al.'s methods for one joint of a haptic device, beside the reproduction of their numbers.

Sinusoidal steady-state identification (:mod:`.sine`, Milne (14)–(22)), the inertia and damping model fit
(:mod:`.inertia_model`, (27)–(29)), the yaw inertia in the form of (6) (:mod:`.yaw_inertia`), the
α-invariant damping model (:mod:`.alpha_invariant` (33)–(36), :mod:`.alpha_damping` (38)–(42),
:mod:`.alpha_simulation` (43)–(47)), its fits (:mod:`.alpha_fit`) and Tables 8/11 statistics
(:mod:`.alpha_comparison`). :mod:`.items` and :mod:`.sine_items` recompute the paper's numbers with them.
"""

SOURCE = "<arrays>"
"""What errors name as the source of the arrays these functions are given (no file)."""

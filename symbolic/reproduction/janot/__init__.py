"""Janot et al.: the reproduction of the paper's numbers (:mod:`.items`); the general methods it uses (the
apparent mass, closed loops, base parameters) live in the library's layers."""

"""Deprecated alias of :mod:`symbolic.export` (the export layer was called ``emit`` in 0.1).

``symbolic.emit.generate(...)`` keeps working for one release, with a :class:`DeprecationWarning`;
new code calls :mod:`symbolic.export`. The code-generation modules that lived here are in
:mod:`symbolic.codegen`.
"""

from __future__ import annotations

import warnings

from symbolic.export import *  # noqa: F403 - the alias re-exports the export layer's API
from symbolic.export import __all__  # noqa: F401

warnings.warn("symbolic.emit is deprecated: use symbolic.export", DeprecationWarning, stacklevel=2)

"""matplotlib for the package's PNG figures: optional, imported only when a figure is asked for.

Identification, simulation, diagnosis and the report's apparent-mass figure all draw through
:func:`figure_class` (the non-interactive Agg backend, :class:`MatplotlibMissing` without matplotlib,
which callers turn into a note or an error) and write with :func:`save_png` or :func:`png_bytes`:
PNGs without a "Software" entry, so the same data give the same bytes with the same matplotlib.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

from symbolic.errors import MatplotlibMissing
from symbolic.writing import replacing

MISSING = "figures skipped: matplotlib is not installed (pip install 'symbolic[plot]')"




def figure_class(message: str = MISSING) -> Any:
    """matplotlib's ``Figure`` on the Agg backend; :class:`MatplotlibMissing` (with ``message``) without it."""
    try:
        import matplotlib

        matplotlib.use("Agg", force=True)
        from matplotlib.figure import Figure
    except ImportError:
        raise MatplotlibMissing(message) from None
    return Figure


def png_bytes(figure: Any, **options: Any) -> bytes:
    """The figure as PNG bytes (``options`` go to ``savefig``, e.g. ``dpi``)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None}, **options)
    return buffer.getvalue()


def save_png(figure: Any, path: Path) -> Path:
    """Write the figure to ``path`` atomically (:func:`symbolic.writing.replacing`); return ``path``."""
    with replacing(path, suffix=".png") as temporary:
        figure.savefig(temporary, format="png", metadata={"Software": None})
    return path

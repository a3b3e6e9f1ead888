"""The apparent mass over the workspace as a PNG for the report (``symbolic generate --figures``).

Janot et al. judge a haptic device by the mass a hand feels at the handle (their (18), VII). The
report's table gives it at nine configurations; this figure shows the extreme eigenvalues of the
operational-space inertia Λ = (J D⁻¹ Jᵀ)⁻¹ (:func:`symbolic.numeric.operational.operational_inertia`)
at the end-effector positions of :data:`COUNT` sampled configurations (the report's seed), seen from
above (x–y) and from the side (x–z): λ_min is the lightest direction a hand can push in, λ_max the
heaviest. matplotlib is optional and imported only here; the PNG carries no time stamp or version, so
the same model gives the same bytes with the same matplotlib. ``make generate`` does not draw it
(generated/ must be byte-identical on every machine, whatever matplotlib they have).
"""

from __future__ import annotations

import numpy as np

from symbolic.derivation.dynamics import DynamicModel
from symbolic.plotting import MatplotlibMissing, figure_class, png_bytes
from symbolic.numeric.operational import workspace_points

COUNT = 400
"""Configurations drawn (Q = 0 and 399 uniform in [−π/2, π/2] per rigid coordinate)."""


def file_name(model: DynamicModel) -> str:
    return f"{model.name}_apparent_mass.png"


def png(model: DynamicModel, count: int = COUNT) -> bytes:
    """The figure's PNG bytes (module docstring); :class:`MatplotlibMissing` without matplotlib."""
    Figure = figure_class("the apparent-mass figure needs matplotlib (pip install 'symbolic[plot]')")
    from matplotlib.colors import LogNorm

    points, extremes = workspace_points(model, count)
    figure = Figure(figsize=(9, 7), dpi=100, layout="constrained")
    axes = figure.subplots(2, 2)
    titles = ("λ_min(Λ): the lightest direction [kg]", "λ_max(Λ): the heaviest direction [kg]")
    for column, title in enumerate(titles):
        values = extremes[:, column]
        finite = values[np.isfinite(values) & (values > 0)]
        # logarithmic: near a singular configuration λ_max grows without bound and would flatten the rest
        norm = LogNorm(finite.min(), finite.max()) if finite.size else None
        for row, (i, j, label) in enumerate(((0, 1, "y"), (0, 2, "z"))):
            ax = axes[row, column]
            shown = ax.scatter(points[:, i], points[:, j], c=values, s=12, cmap="viridis", norm=norm)
            ax.set_xlabel("x [m]")
            ax.set_ylabel(f"{label} [m]")
            ax.set_aspect("equal", adjustable="datalim")
            ax.grid(True, linewidth=0.3)
            if row == 0:
                ax.set_title(title, fontsize=10)
            figure.colorbar(shown, ax=ax)
    figure.suptitle(f"{model.name}: apparent mass at the end effector over {count} configurations (Janot (18))")
    return png_bytes(figure)

"""The apparent mass over the workspace as a PNG for the report (``symbolic generate --figures``).

Janot et al. judge a haptic device by the mass a hand feels at the handle (their (18), VII). The
report's table gives it at nine configurations; this figure shows the extreme eigenvalues of the
operational-space inertia Λ = (J D⁻¹ Jᵀ)⁻¹ (:func:`symbolic.numeric.operational.operational_inertia`)
at the end-effector positions of :data:`COUNT` sampled configurations (the report's seed), seen from
above (x–y) and from the side (x–z): λ_min is the lightest direction a hand can push in, λ_max the
heaviest.

Where Λ exists at none of them — a planar arm, whose J (3×N) has rank 2 everywhere — the figure shows
what exists instead: the apparent mass m_u along each base axis u the point moves along
(:func:`symbolic.numeric.operational.workspace_axes`; a planar arm's m_x and m_y), over the plane of the
two position axes the points spread most in. A point that moves along no axis at any sampled
configuration has nothing to draw: :class:`NoFigure`, which says why.

matplotlib is optional and imported only here; the PNG carries no time stamp or version, so the same
model gives the same bytes with the same matplotlib. ``make generate`` does not draw it (generated/ must be
byte-identical on every machine, whatever matplotlib they have).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from symbolic.derivation.dynamics import DynamicModel
from symbolic.errors import SymbolicError
from symbolic.numeric.operational import workspace_axes, workspace_points
from symbolic.plotting import MatplotlibMissing, figure_class, png_bytes  # noqa: F401  (MatplotlibMissing: re-exported)

COUNT = 400
"""Configurations drawn (Q = 0 and 399 uniform in [−π/2, π/2] per rigid coordinate)."""
AXES = "xyz"


class NoFigure(SymbolicError, ValueError):
    """Nothing can be drawn: the end effector moves along no base axis at any sampled configuration."""


@dataclass(frozen=True)
class Panel:
    """One panel: the end-effector positions ``x``, ``y`` (m) coloured by ``values`` (kg; NaN or ∞ where
    the quantity does not exist there), with its title and axis labels."""

    x: np.ndarray
    y: np.ndarray
    values: np.ndarray
    title: str
    xlabel: str
    ylabel: str


def file_name(model: DynamicModel) -> str:
    return f"{model.name}_apparent_mass.png"


def panels(model: DynamicModel, count: int = COUNT) -> tuple[list[Panel], str]:
    """The panels to draw and the figure's title (module docstring).

    Raises
    ------
    NoFigure
        The end effector moves along no base axis at any of the sampled configurations.
    """
    points, extremes = workspace_points(model, count)
    if np.isfinite(extremes).any():
        out = []
        for row, (i, j) in enumerate(((0, 1), (0, 2))):
            for column, title in enumerate(("λ_min(Λ): the lightest direction [kg]", "λ_max(Λ): the heaviest direction [kg]")):
                out.append(Panel(points[:, i], points[:, j], extremes[:, column], title if row == 0 else "",
                                 f"{AXES[i]} [m]", f"{AXES[j]} [m]"))
        return out, f"{model.name}: apparent mass at the end effector over {count} configurations (Janot (18))"
    masses = workspace_axes(model, count)
    moving = [k for k in range(3) if np.isfinite(masses[:, k]).any()]
    if not moving:
        raise NoFigure(f"model {model.name!r}: the end effector moves along no axis at any of the {count} sampled "
                       "configurations (J = 0): there is no apparent mass to draw")
    i, j = sorted(np.argsort(-np.ptp(points, axis=0), kind="stable")[:2])  # the plane the points spread most in
    out = [Panel(points[:, i], points[:, j], masses[:, k], f"m_{AXES[k]}: pushing along {AXES[k]} [kg]",
                 f"{AXES[i]} [m]", f"{AXES[j]} [m]") for k in moving]
    title = (f"{model.name}: apparent mass at the end effector along the axes it moves along, over {count} "
             "configurations\n(Λ exists at none of them: J has rank below 3)")
    return out, title


def png(model: DynamicModel, count: int = COUNT) -> bytes:
    """The figure's PNG bytes (module docstring); :class:`MatplotlibMissing` without matplotlib,
    :class:`NoFigure` when there is nothing to draw."""
    Figure = figure_class("the apparent-mass figure needs matplotlib (pip install 'symbolic[plot]')")
    from matplotlib.colors import LogNorm

    shown, title = panels(model, count)
    columns = 2 if len(shown) == 4 else len(shown)
    rows = len(shown) // columns
    figure = Figure(figsize=(9, 7) if rows == 2 else (4.5 * columns, 4.2), dpi=100, layout="constrained")
    axes = np.asarray(figure.subplots(rows, columns)).reshape(rows, columns)
    for k, panel in enumerate(shown):
        ax = axes[k // columns, k % columns]
        finite = panel.values[np.isfinite(panel.values) & (panel.values > 0)]
        # logarithmic: near a singular configuration the mass grows without bound and would flatten the rest
        norm = LogNorm(finite.min(), finite.max()) if finite.size else None
        values = np.where(np.isfinite(panel.values), panel.values, np.nan)  # ∞: not drawn, like a singular λ
        drawn = ax.scatter(panel.x, panel.y, c=values, s=12, cmap="viridis", norm=norm)
        ax.set_xlabel(panel.xlabel)
        ax.set_ylabel(panel.ylabel)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, linewidth=0.3)
        if panel.title:
            ax.set_title(panel.title, fontsize=10)
        figure.colorbar(drawn, ax=ax)
    figure.suptitle(title)
    return png_bytes(figure)

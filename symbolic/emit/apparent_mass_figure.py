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

import io

import numpy as np

from symbolic.derive.dynamics import DynamicModel
from symbolic.numeric.functions import compile_function
from symbolic.numeric.operational import SingularConfiguration, operational_inertia, workspace_samples

COUNT = 400
"""Configurations drawn (Q = 0 and 399 uniform in [−π/2, π/2] per rigid coordinate)."""


class MatplotlibMissing(RuntimeError):
    """matplotlib is not installed: no figure."""


def file_name(model: DynamicModel) -> str:
    return f"{model.name}_apparent_mass.png"


def workspace_points(model: DynamicModel, count: int = COUNT) -> tuple[np.ndarray, np.ndarray]:
    """End-effector positions (count × 3, base frame) and λ_min, λ_max of Λ there (count × 2; NaN where
    J loses rank), at :func:`~symbolic.numeric.operational.workspace_samples`."""
    ee = model.robot.end_effector
    import sympy as sp

    position = model.kinematics.point_position(ee.frame, sp.Matrix(ee.point))
    rigid = list(model.coordinates[: len(model.robot.coordinates)])
    where = compile_function(model.sub, [rigid, model.parameter_symbols], position, (3,))
    p = [float(v) for v in model.parameters.values()]
    samples = workspace_samples(model, count)
    points = np.array([where(q[: len(rigid)], p) for q in samples])
    extremes = np.full((count, 2), np.nan)
    for k, q in enumerate(samples):
        try:
            eigenvalues = np.linalg.eigvalsh(operational_inertia(model, q))
        except SingularConfiguration:
            continue
        extremes[k] = eigenvalues[0], eigenvalues[-1]
    return points, extremes


def png(model: DynamicModel, count: int = COUNT) -> bytes:
    """The figure's PNG bytes (module docstring); :class:`MatplotlibMissing` without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg", force=True)
        from matplotlib.colors import LogNorm
        from matplotlib.figure import Figure
    except ImportError:
        raise MatplotlibMissing("the apparent-mass figure needs matplotlib (pip install 'symbolic[plot]')") from None
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
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None})
    return buffer.getvalue()

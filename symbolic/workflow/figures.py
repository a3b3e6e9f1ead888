"""PNG figures of a diagnosis (matplotlib, imported only here and only when figures are asked for).

* ``residual_<c>.png``: the residual against time before and after, and against velocity;
* ``effect_<k>_<effect>_<c>.png``: for each found effect, the partial residual (the final residual plus
  the effect's own term) against the state the effect depends on, with the fitted term drawn over it;
* ``spectrum_<c>.png``: Welch spectra of the residual before and after, found peaks marked.
"""

from __future__ import annotations

import numpy as np

from symbolic.plotting import MatplotlibMissing, figure_class, png_bytes
from symbolic.workflow.result import Diagnosis
from symbolic.workflow.where import spectrum


def draw(d: Diagnosis) -> dict[str, bytes]:
    """The figures as PNG bytes by file name (written with the report, all at once)."""
    Figure = figure_class()
    est = d.sets["estimation"]
    before = est.tau - d.before.predicted["estimation"]
    after = est.tau - d.after.predicted["estimation"]
    written: dict[str, bytes] = {}
    rate = 1.0 / float(np.mean(np.diff(est.t)))
    for j, c in enumerate(est.coordinates):
        fig = Figure(figsize=(9, 6))
        top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
        top.plot(est.t, before[:, j], lw=0.6, label="nominal model")
        top.plot(est.t, after[:, j], lw=0.6, label="patched model")
        top.set_xlabel("t (s)")
        top.set_ylabel(f"τ_meas − τ_model on {c}")
        top.legend(loc="upper right")
        bottom.plot(est.qd[:, j], before[:, j], ".", ms=1.5, label="nominal model")
        bottom.plot(est.qd[:, j], after[:, j], ".", ms=1.5, label="patched model")
        bottom.set_xlabel(f"velocity of {c}")
        bottom.set_ylabel("residual")
        bottom.legend(loc="upper right")
        fig.tight_layout()
        written[f"residual_{c}.png"] = png_bytes(fig, dpi=100)
        fig = Figure(figsize=(9, 4))
        ax = fig.add_subplot(1, 1, 1)
        for label, r in (("nominal model", before[:, j]), ("patched model", after[:, j])):
            f, psd = spectrum(r, rate)
            ax.semilogy(f, psd, lw=0.8, label=label)
        for peak in d.where_before["coordinates"][c]["spectrum"]["peaks"]:
            ax.axvline(peak["frequency_hz"], color="k", lw=0.5, ls="--")
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("residual PSD")
        ax.legend(loc="upper right")
        fig.tight_layout()
        written[f"spectrum_{c}.png"] = png_bytes(fig, dpi=100)
    design = d.search.final
    final = est.tau - design.predicted("estimation")
    start = len(d.search.terms.free_names)
    axes = {"position": est.q, "velocity": est.qd, "acceleration": est.qdd,
            "time": np.repeat(np.asarray(est.t)[:, None], est.q.shape[1], axis=1)}
    for k, a in enumerate(d.search.accepted, start=1):
        width = a.columns["estimation"].shape[2]
        values = design.identification.values[start:start + width]
        start += width
        term = a.columns["estimation"] @ values
        j = a.candidate.j
        x = axes[a.effect.axis][:, j]
        order = np.argsort(x, kind="stable")
        fig = Figure(figsize=(9, 4))
        ax = fig.add_subplot(1, 1, 1)
        ax.plot(x, final[:, j] + term[:, j], ".", ms=1.5, color="0.5", label="final residual + the effect's term")
        ax.plot(x[order], term[order, j], lw=1.2, color="C3", label=f"fitted {a.effect.label()}")
        ax.set_xlabel("time (s)" if a.effect.axis == "time" else f"{a.effect.axis} of {a.candidate.coordinate}")
        ax.set_ylabel("generalized force")
        ax.set_title(a.candidate.label())
        ax.legend(loc="upper right")
        fig.tight_layout()
        written[f"effect_{k}_{a.effect.name}_{a.candidate.coordinate}.png"] = png_bytes(fig, dpi=100)
    return written

"""The data treatment of IDIM-LS: from measurements and a regressor to the stacked system ``y = W·β + ρ``.

Steps (Gautier 1997, "Dynamic identification of robots with power model"; the EMPS publication's script):

1. positions low-passed by a zero-phase Butterworth filter (order 4, forward and backward) whose
   cut-off is 5 × the bandwidth of the dynamics (:class:`Settings`);
2. q̇ by central differences of the filtered q, q̈ by central differences of q̇ — unless the data have
   ``qd``/``qdd`` columns, which are then used, low-passed by the same filter;
3. the regressor evaluated at every sample: ``Y(q, q̇, q̈)``, ``samples × N × P``;
4. ``border`` samples dropped at each end, where the filter and the one-sided differences distort q,
   q̇, q̈ (default ``ceil(5·rate/cutoff)``, five periods of the cut-off: 50 samples for EMPS, the
   publication's choice; the tail of the Butterworth's impulse response beyond it is 1.4e-5 of its sum);
5. τ and every column of Y decimated in parallel by the same low-pass and down-sampling
   (:func:`symbolic.data.filters.decimate`; factor ``round(0.8·f_nyquist/(2·bandwidth))``, so that the
   decimation filter's cut-off is twice the bandwidth: 10 for EMPS). The decimation filter is linear
   and applied to both sides alike, so its own border transients keep ``τ = Y·β`` and no further
   samples need dropping;
6. stacked coordinate by coordinate: ``y = [τ_1(all samples); τ_2(...); ...]``, W likewise.
"""

from __future__ import annotations

from collections.abc import Callable
import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from symbolic.data import Measurements
from symbolic.data.treatment import (BANDWIDTH_FRACTION, SETTING_KEYS, Processing, Settings, States,  # noqa: F401 (re-exported)
                                      states)

RegressorFunction = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""``regressor(q, qd, qdd)`` with ``samples × N`` arrays returns ``Y``, ``samples × N × P``. A regressor with
a true attribute ``time_varying`` (a model whose forces depend on time) is called with ``t=`` the sample
times as well."""


@dataclass(frozen=True, eq=False)
class Observation:
    """The stacked system ``y = W·β + ρ`` of one data set, and what it was made from.

    Attributes
    ----------
    coordinates
        Coordinate names; rows of ``y`` and ``W`` are grouped by coordinate in this order.
    t
        Time of the kept (decimated) samples.
    tau
        The decimated generalized forces, ``samples × N``.
    regressor
        The decimated regressor, ``samples × N × P``.
    processing
        The treatment applied.
    q, qd
        The treated positions and velocities at the kept samples (``samples × N``; for the figures of an HTML
        report, ``None`` where not kept).
    """

    coordinates: tuple[str, ...]
    t: np.ndarray
    tau: np.ndarray
    regressor: np.ndarray
    processing: Processing
    q: np.ndarray | None = field(default=None, repr=False)
    qd: np.ndarray | None = field(default=None, repr=False)

    @property
    def y(self) -> np.ndarray:
        """Stacked forces, coordinate by coordinate (``N·samples``,)."""
        return self.tau.T.reshape(-1)

    @property
    def W(self) -> np.ndarray:  # noqa: N802 (the literature's name)
        """Stacked observation matrix (``N·samples × P``)."""
        samples, n, p = self.regressor.shape
        return self.regressor.transpose(1, 0, 2).reshape(n * samples, p)  # explicit: -1 is ambiguous for P = 0

    @property
    def samples(self) -> int:
        """Kept samples per coordinate."""
        return len(self.t)

    def without(self, intervals: Sequence[tuple[float, float]]) -> Observation:
        """The system without its samples in any of ``intervals`` (``(start, stop)``, seconds): data that a
        disturbance outside the model spoils (a collision, docs/fleet.md), left out of the least squares."""
        keep = np.ones(len(self.t), dtype=bool)
        for start, stop in intervals:
            keep &= ~((self.t >= start) & (self.t <= stop))
        return dataclasses.replace(self, t=self.t[keep], tau=self.tau[keep], regressor=self.regressor[keep],
                                   q=None if self.q is None else self.q[keep], qd=None if self.qd is None else self.qd[keep])


def observe(measurements: Measurements, regressor: RegressorFunction, parameters: int, settings: Settings | None = None) -> Observation:
    """Filter, differentiate, evaluate the regressor, drop borders and decimate (module docstring).

    Parameters
    ----------
    measurements
        The data.
    regressor
        ``regressor(q, qd, qdd) -> Y``, ``samples × N × P``.
    parameters
        P, the number of parameters (columns of Y), to check the regressor's output.
    settings
        Overrides of the treatment; unset ones come from the experiment's ``[identification]`` table.
    """
    treated = states(measurements, settings)
    p = treated.processing
    timed = {"t": measurements.t} if getattr(regressor, "time_varying", False) else {}
    Y = np.asarray(regressor(treated.q, treated.qd, treated.qdd, **timed), dtype=float)  # noqa: N806
    expected = (measurements.samples, len(measurements.coordinates), parameters)
    if Y.shape != expected:
        raise ValueError(f"the regressor returned an array of shape {Y.shape}, expected {expected} (samples, N, P)")
    return Observation(
        coordinates=measurements.coordinates,
        t=p.reduce_times(measurements.t),
        tau=p.reduce(p.forces(measurements.tau)),
        regressor=p.reduce(Y),
        processing=p,
        q=p.reduce(treated.q),
        qd=p.reduce(treated.qd),
    )

"""The data treatment shared by identification and the comparison of simulation with measurement.

Gautier 1997 ("Dynamic identification of robots with power model") and the EMPS publication's script:

1. positions low-passed by a zero-phase Butterworth filter (order 4, forward and backward) whose
   cut-off is 5 × the bandwidth of the dynamics (the bandwidth defaulting to rate / 50: 20 Hz at
   1 kHz, EMPS's value, so a 100 Hz cut-off);
2. q̇ by central differences of the filtered q, q̈ by central differences of q̇ — unless the data have
   ``qd``/``qdd`` columns, which are then used, low-passed by the same filter;
3. ``border`` samples left out at each end, where the filter and the one-sided differences distort
   (default ``ceil(5·rate/cutoff)``, five periods of the cut-off; 2 without filtering);
4. for identification, decimation of τ and of every regressor column alike
   (:meth:`Processing.reduce`; :mod:`symbolic.identify.processing` builds the system ``y = W·β``).

:class:`Settings` (:mod:`symbolic.data.settings`) are the choices (``None``: from the experiment's
``[identification]`` table, else the rule above), combined in one place, :func:`settings_for`;
:meth:`Settings.resolve` turns them into the :class:`Processing` applied; :func:`states` gives steps
1–2 and :func:`filtered_motion` the same filtering for any cut-off.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from symbolic.data.experiment import Experiment
from symbolic.data.filters import central_difference, lowpass
from symbolic.data.measurements import Measurements
from symbolic.data.settings import BANDWIDTH_FRACTION, SETTING_KEYS, Processing, Settings

__all__ = ["BANDWIDTH_FRACTION", "SETTING_KEYS", "Processing", "Settings", "States", "filtered_motion",
           "settings_for", "states"]


@dataclass(frozen=True, eq=False)
class States:
    """Steps 1–2: positions, velocities and accelerations as IDIM-LS sees them, at every sample.

    Attributes
    ----------
    q, qd, qdd
        Filtered positions and their central differences (or the filtered measured ``qd``/``qdd``),
        ``samples × N``, before the border is dropped.
    processing
        The treatment, all defaults resolved; :meth:`Processing.reduce` applies steps 4–5.
    """

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    processing: Processing


def settings_for(measurements: Measurements, settings: Settings | None = None) -> Settings:
    """The treatment's choices for ``measurements``: ``settings`` where set, else the experiment's
    ``[identification]`` (:attr:`Experiment.settings`, checked when the file was loaded), else unset
    (the rules). Every user of the treatment — identification, the workflow, the comparison of a
    simulation — combines them here."""
    own = measurements.settings if isinstance(measurements, Experiment) else Settings()
    return (settings or Settings()).combined(own)


def states(measurements: Measurements, settings: Settings | None = None) -> States:
    """Steps 1–2 of the treatment (module docstring) on ``measurements``.

    ``settings`` override the treatment; unset fields come from the experiment's ``[identification]``
    table (:func:`settings_for`).
    """
    source = str(measurements.source)
    p = settings_for(measurements, settings).resolve(measurements.rate, measurements.samples, source)
    return States(*filtered_motion(measurements, p.cutoff, p.order), p)


def filtered_motion(measurements: Measurements, cutoff: float | None, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Steps 1–2: q low-passed at ``cutoff`` Hz (``None``: not filtered) by a zero-phase Butterworth of
    ``order``, q̇ and q̈ by central differences (or the data's own ``qd``/``qdd``, low-passed alike)."""
    h = measurements.sample_period

    def smooth(x: np.ndarray) -> np.ndarray:
        return lowpass(x, cutoff, measurements.rate, order) if cutoff is not None else np.asarray(x, dtype=float)

    q = smooth(measurements.q)
    qd = smooth(measurements.qd) if measurements.qd is not None else central_difference(q, h)
    qdd = smooth(measurements.qdd) if measurements.qdd is not None else central_difference(qd, h)
    return q, qd, qdd

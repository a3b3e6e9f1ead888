"""The error raised for bad measured data and experiment files."""

from __future__ import annotations

from symbolic.errors import ModelError


class DataError(ModelError):
    """A data file or an experiment file is unusable.

    A :class:`~symbolic.errors.ModelError`, so that every command reports it the same way: one line
    ``FILE: KEY: what is wrong (what is allowed)`` and exit status 2.

    Parameters
    ----------
    source
        The data or experiment file (or ``"<arrays>"`` for data given in Python).
    key
        Where: a column (``"column 'tau_q'"``), an experiment key (``"[signals] tau_q"``), ...
    problem
        What is wrong and what is allowed.
    """

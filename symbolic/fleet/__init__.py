"""Fleets: campaigns over many logs and robots on Dask, parameter drift, outliers, time-localised events
(docs/fleet.md; ``symbolic campaign``).

>>> from symbolic.fleet import campaign
>>> campaign.KINDS
('identify', 'diagnose', 'simulate')

A campaign file (:mod:`.campaign`) names robots, their logs and the task per log; :func:`run` runs every
log on Dask, short logs several to a task (:mod:`.tasks`), keeps each result in the output folder's cache (:mod:`.store`), and
tells what the fleet shows: drift (:mod:`.drift`), outliers among siblings (:mod:`.outliers`), residual
bursts within a log (:mod:`.events`) judged against the siblings' logs — events, and the model's systematic
misfits (:mod:`.siblings`) — in ``report.md`` (:mod:`.report`). Dask (``pip install
'symbolic[fleet]'``) is imported only when logs are run (:mod:`.execution`).
"""

from __future__ import annotations

from symbolic.fleet.campaign import Campaign, load
from symbolic.fleet.execution import INSTALL, Outcome, available, run

__all__ = ["INSTALL", "Campaign", "Outcome", "available", "load", "run"]

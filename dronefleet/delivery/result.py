"""What one delivery run recorded: :class:`RunResult`, made by :mod:`.simulation`, read by
:mod:`.records`, :mod:`.metrics` and :mod:`.fleet`.

Its own module, below all four, so that those that read a result need not import the
simulation that makes it (which imports the fleet reader): no import circle.
"""

from dataclasses import dataclass


@dataclass
class RunResult:
    """What a run recorded (docs/delivery-model.md section 10), as numpy arrays; ``records`` turns it into tables.

    ``snapshots`` holds one dict of fleet arrays per week end (and at the horizon);
    ``period`` is 1 for a new fleet, the saved fleet's period plus one for a warm start;
    ``reservations`` counts the auctions won by a reservation bid.
    """

    config: object
    orders: dict
    attempts: dict
    snapshots: list
    series: dict
    auctions: int
    reservations: int
    period: int

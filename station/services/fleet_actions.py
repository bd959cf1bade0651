"""What ``station fleet`` does to every unit, and where it runs by default: the names its
parser offers, in a module of their own so that ``station fleet --help`` does not import
the grading (scipy) that :mod:`station.services.fleet` runs."""

from __future__ import annotations

from typing import Literal

FleetAction = Literal["grade", "analyze", "report"]
ACTIONS: tuple[str, ...] = ("grade", "analyze", "report")
#: The scheduler address that means a Dask cluster on this machine.
LOCAL = "local"

"""Moved to :mod:`analysis.models.power_cycle`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.models.power_cycle import (
    PowerCycleModel as PowerCycleModel,
    ThermalModel as ThermalModel,
    TurnOn as TurnOn,
    first_order_step as first_order_step,
)
from analysis.moved import warn_moved

warn_moved("analysis.power_cycle", "analysis.models.power_cycle")

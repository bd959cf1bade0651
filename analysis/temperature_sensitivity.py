"""Moved to :mod:`analysis.sequences.temperature_sensitivity`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.sequences.temperature_sensitivity import (
    Direction as Direction,
    Hysteresis as Hysteresis,
    TemperatureFit as TemperatureFit,
    TemperaturePoint as TemperaturePoint,
    fit_temperature_sensitivity as fit_temperature_sensitivity,
    hysteresis as hysteresis,
    plateau_point as plateau_point,
    ramp_points as ramp_points,
)

warn_moved("analysis.temperature_sensitivity", "analysis.sequences.temperature_sensitivity")

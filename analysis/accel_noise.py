"""Moved to :mod:`analysis.models.accel_noise`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.models.accel_noise import (
    ACCELEROMETER_TABLE as ACCELEROMETER_TABLE,
    AccelNoiseModel as AccelNoiseModel,
    AccelSimulator as AccelSimulator,
    gravity_by_axis as gravity_by_axis,
)
from analysis.moved import warn_moved

warn_moved("analysis.accel_noise", "analysis.models.accel_noise")

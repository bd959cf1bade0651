"""Moved to :mod:`analysis.figures.tool_units_accel`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.tool_units_accel import (
    M_S2_PER_UG as M_S2_PER_UG,
    AccelNoise as AccelNoise,
)
from analysis.moved import warn_moved

warn_moved("analysis.tool_units_accel", "analysis.figures.tool_units_accel")

"""Moved to :mod:`analysis.figures.accel`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.accel import (
    STANDARD_GRAVITY_M_S2 as STANDARD_GRAVITY_M_S2,
    AccelFigures as AccelFigures,
    accel_figures as accel_figures,
    gravity_by_axis as gravity_by_axis,
    normal_gravity_m_s2 as normal_gravity_m_s2,
    vertical_axis as vertical_axis,
)
from analysis.moved import warn_moved

warn_moved("analysis.accel", "analysis.figures.accel")

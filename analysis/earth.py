"""Moved to :mod:`analysis.units.earth`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.units.earth import (
    DIRECTIONS as DIRECTIONS,
    EARTH_RATE_DEG_H as EARTH_RATE_DEG_H,
    EARTH_RATE_RAD_S as EARTH_RATE_RAD_S,
    Direction as Direction,
    OrientationError as OrientationError,
    axis_direction as axis_direction,
    axis_token as axis_token,
    earth_rate_by_axis as earth_rate_by_axis,
    earth_rate_enu_deg_h as earth_rate_enu_deg_h,
    earth_rate_on_axis_deg_h as earth_rate_on_axis_deg_h,
    format_orientation as format_orientation,
    match_axis as match_axis,
    parse_orientation as parse_orientation,
    rotation_rows as rotation_rows,
)

warn_moved("analysis.earth", "analysis.units.earth")

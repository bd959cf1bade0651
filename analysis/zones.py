"""Moved to :mod:`analysis.figures.zones`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.figures.zones import (
    FILTER_TOLERANCE as FILTER_TOLERANCE,
    MAX_REFITS as MAX_REFITS,
    TONE_SHARE as TONE_SHARE,
    TauZone as TauZone,
    filter_zone as filter_zone,
    fit_outside_zones as fit_outside_zones,
    outside_zones as outside_zones,
    tone_zone as tone_zone,
)
from analysis.moved import warn_moved

warn_moved("analysis.zones", "analysis.figures.zones")

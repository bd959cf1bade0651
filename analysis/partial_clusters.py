"""Moved to :mod:`analysis.allan.partial_clusters`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.partial_clusters import (
    MAX_MISSING_SHARE as MAX_MISSING_SHARE,
    PartialMeans as PartialMeans,
    corrected_mean_variance as corrected_mean_variance,
    partial_allan_variance as partial_allan_variance,
    partial_means as partial_means,
    partial_window_sums as partial_window_sums,
    partial_windows as partial_windows,
    white_level as white_level,
    window_avar as window_avar,
)
from analysis.moved import warn_moved

warn_moved("analysis.partial_clusters", "analysis.allan.partial_clusters")

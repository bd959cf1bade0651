"""Moved to :mod:`analysis.sequences.cycle_stats`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.sequences.cycle_stats import (
    CycleSummary as CycleSummary,
    check_confidence as check_confidence,
    std_interval as std_interval,
    summarize_cycles as summarize_cycles,
    t_half_width as t_half_width,
)

warn_moved("analysis.cycle_stats", "analysis.sequences.cycle_stats")

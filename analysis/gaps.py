"""Moved to :mod:`analysis.allan.gaps`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.gaps import (
    EDF_LENGTH_POINTS as EDF_LENGTH_POINTS,
    EDF_TAU_POINTS as EDF_TAU_POINTS,
    GapSummary as GapSummary,
    gap_allan_variance as gap_allan_variance,
    gap_summary as gap_summary,
    gap_summary_of_index as gap_summary_of_index,
    valid_stretches as valid_stretches,
)
from analysis.moved import warn_moved

warn_moved("analysis.gaps", "analysis.allan.gaps")

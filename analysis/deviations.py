"""Moved to :mod:`analysis.allan.deviations`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.allan.deviations import (
    DEVIATION_KINDS as DEVIATION_KINDS,
    DEVIATION_LABELS as DEVIATION_LABELS,
    THEO1_MIN_M as THEO1_MIN_M,
    THEO1_POINTS_PER_DECADE as THEO1_POINTS_PER_DECADE,
    THEO1_TAU_FACTOR as THEO1_TAU_FACTOR,
    TOTAL_EDF_TABLE as TOTAL_EDF_TABLE,
    DeviationKind as DeviationKind,
    DeviationResult as DeviationResult,
    deviation as deviation,
    deviation_m as deviation_m,
    from_allan as from_allan,
    max_m as max_m,
    theo1_edf as theo1_edf,
    total_edf as total_edf,
)
from analysis.moved import warn_moved

warn_moved("analysis.deviations", "analysis.allan.deviations")

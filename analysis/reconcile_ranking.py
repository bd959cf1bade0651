"""Moved to :mod:`analysis.reconcile.ranking`.

This module re-exports its public names, with a DeprecationWarning, for one
release.
"""

from __future__ import annotations

from analysis.moved import warn_moved
from analysis.reconcile.ranking import (
    CONFIRMED_SHARE as CONFIRMED_SHARE,
    INDISTINCT_BIC as INDISTINCT_BIC,
    TIME_SERIES_TESTED as TIME_SERIES_TESTED,
    Confirmation as Confirmation,
    Ranked as Ranked,
    allan_ranked as allan_ranked,
    alternatives as alternatives,
    ranked as ranked,
)

warn_moved("analysis.reconcile_ranking", "analysis.reconcile.ranking")
